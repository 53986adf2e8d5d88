"""An attack injector you can copy: forwards every link packet except those sent by the chosen
vehicles, which it drops. It is a complete iceoryx2 node of a platoon run:

    platoon run configs/paper.toml --injector "bridge/.venv/bin/python bridge/examples/drop_sender.py 2"

Per step k it waits for the tx batch (one item per link), decides per item, and always
publishes the rx batch for k (empty if everything was dropped), as docs/injector-contract.md
asks. `--stall-at K` stops publishing at step K, `--repeat-at K` publishes rx[K] again and again
and never rx[K + 1], and `--duplicates N` publishes every rx batch N extra times (to test the
orchestrator's timeout and its duplicate count).
"""

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.wire as w  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("senders", type=int, nargs="*", help="vehicle ids whose packets are dropped")
    ap.add_argument("--stall-at", type=int, default=None, help="publish nothing from this step")
    ap.add_argument("--repeat-at", type=int, default=None, help="repeat this step's batch forever")
    ap.add_argument("--duplicates", type=int, default=0, help="extra copies of every batch")
    args = ap.parse_args()
    drop = set(args.senders)

    node = w.Endpoint("injector")
    tx = node.inlet("tx", w.LinkPacket)
    rx = node.outlet("rx", w.LinkPacket, 64)
    control = node.control_inlet()
    status = node.status_outlet()
    w.send_status(status, w.ControlMsg.READY, "injector")

    step, dropped = 0, 0
    while True:
        msg = control.receive()
        while msg is not None:
            kind = msg.payload().contents.kind
            if kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT):
                print(f"drop_sender: dropped {dropped} link packets", file=sys.stderr)
                return 0
            msg = control.receive()
        items = tx.take(step)
        if items is None or (args.stall_at is not None and step >= args.stall_at):
            node.wait()
            continue
        kept = [it for it in items if it.packet.sender not in drop]
        dropped += len(items) - len(kept)
        if args.repeat_at is not None and step >= args.repeat_at:
            while control.receive() is None:  # rx[K] forever, until STOP or ABORT
                rx.send(step, 0.0, kept)
                time.sleep(0.005)
            return 0
        for _ in range(1 + args.duplicates):
            rx.send(step, 0.0, kept)
        step += 1


if __name__ == "__main__":
    sys.exit(main())
