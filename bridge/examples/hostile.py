"""A hostile injector, for testing the controllers' defences: it forwards every link packet and
adds, every 50 steps, one packet of each kind the controllers must refuse: a NaN state, an
unknown sender, a packet from a future step, and a replay of an old packet (stale sequence
number), plus a JAMMED notice for a vehicle that does not exist.

    platoon run configs/table1.toml --injector "bridge/.venv/bin/python bridge/examples/hostile.py"
"""

import copy
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon_wire as w  # noqa: E402


def main() -> int:
    node = w.Endpoint("injector")
    tx = node.inlet("tx", w.LinkPacket)
    rx = node.outlet("rx", w.LinkPacket, 64)
    control = node.control_inlet()
    status = node.status_outlet()  # keep it: a dropped publisher takes its samples with it
    w.send_status(status, w.ControlMsg.READY, "injector")

    step, first = 0, None
    while True:
        msg = control.receive()
        while msg is not None:
            if msg.payload().contents.kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT):
                return 0
            msg = control.receive()
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
        rx.send(step, 0.0, out)
        step += 1


if __name__ == "__main__":
    sys.exit(main())
