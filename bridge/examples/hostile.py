"""A hostile injector, for testing the controllers' defences: it forwards every link packet and
adds, every 50 steps, one packet of each kind the controllers must refuse: a NaN state, an
unknown sender, a packet from a future step, and a replay of an old packet (stale sequence
number), plus a JAMMED notice for a vehicle that does not exist.

    platoon run configs/table1.toml --injector "bridge/.venv/bin/python bridge/examples/hostile.py"

`--forge-seq-at K` also sends, at the first step from K on at which vehicle 1 broadcasts, a copy of a genuine packet from a real neighbour with a
near-maximum sequence number (it must be refused, and must not lock the sender out);
`--bad-count-at K` publishes the rx batch of step K with a count larger than what it carries (a
contract violation that stops the run; every step before K must still be recorded).
"""

import argparse
import copy
import ctypes
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.wire as w  # noqa: E402
from platoon.plugin import stop_received  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--forge-seq-at", type=int, default=None)
    ap.add_argument("--bad-count-at", type=int, default=None)
    args = ap.parse_args()
    node = w.Endpoint("injector")
    tx = node.inlet("tx", w.LinkPacket)
    rx = node.outlet("rx", w.LinkPacket, 64)
    control = node.control_inlet()
    status = node.status_outlet()  # keep it: a dropped publisher takes its samples with it
    w.send_status(status, w.ControlMsg.READY, "injector")

    step, first, forged_once = 0, None, False
    while True:
        if stop_received(control):
            return 0
        items = tx.take(step)
        if items is None:
            node.wait()
            continue
        out = list(items)
        if first is None and items:
            first = copy.deepcopy(items[0])
        if step % 50 == 25 and first is not None:
            nan = copy.deepcopy(first)
            nan.packet.state[0] = float("nan")
            nan.packet.seq = 10**9
            unknown = copy.deepcopy(first)
            unknown.packet.sender = 999
            future = copy.deepcopy(first)
            future.packet.step = step + 1000
            future.packet.seq = 10**9
            ghost = w.LinkPacket(receiver=4096, kind=w.LinkPacket.JAMMED)
            out += [nan, unknown, future, copy.deepcopy(first), ghost]
        if args.forge_seq_at is not None and step >= args.forge_seq_at and not forged_once:
            real = [it for it in items if it.packet.sender == 1]
            if real:
                forged_once = True
                forged = copy.deepcopy(real[0])
                forged.packet.seq = 2**32 - 2
                out.insert(0, forged)  # before the genuine packet of the same step
        if step == args.bad_count_at:
            data = b"".join(bytes(it) for it in out)
            sample = rx.publisher.loan_slice_uninit(len(out))
            header = w.StepHeader.from_address(sample.user_header_ptr)
            header.step, header.time_s, header.count = step, 0.0, len(out) + 100
            header.stamp_ns = time.monotonic_ns()
            ctypes.memmove(sample.payload_ptr, data, len(data))
            sample.assume_init().send()
            for waker in rx.wakers:
                waker.notify()
            node.wait(1000)
            continue
        rx.send(step, 0.0, out)
        step += 1


if __name__ == "__main__":
    sys.exit(main())
