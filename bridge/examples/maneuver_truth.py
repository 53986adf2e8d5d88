"""An injector that forges, alters and replays maneuver messages and logs what it did to every
delivery, so that a run's ground truth (`detections.csv`'s `label`) can be checked against it
delivery for delivery (tests/ground_truth.rs). Run it on `configs/leave.toml` with a
`[detection]` table:

    platoon run leave-detected.toml --injector \\
        "bridge/.venv/bin/python bridge/examples/maneuver_truth.py LOG.csv VICTIM AT_S"

- forge: at AT_S, VICTIM's packet of that step is delivered as sent, and then a forged copy in
  its name, with its next sequence number (used before VICTIM uses it) and a leave notice to
  the leader, to each of its receivers (the leader takes the notice; the followers refuse the
  copy as stale, its step is the one they just got);
- alter: from AT_S + 1 s, the first packet of the member behind VICTIM to follower 1 carries
  an in-position report addressed to the leader that its sender never made (follower 1 ignores
  a message not addressed to it);
- replay: every formation update of the leader is delivered again, unchanged, 8 s later (the
  followers refuse the copies as stale).

Everything else is forwarded as sent. LOG.csv (the SDK's `DeliveryLog`) gets one line per
delivery: `step,receiver,sender,seq,action` (vehicle indices within the platoon; `action` one of
`pass`, `forge`, `alter`, `replay`).
"""

import copy
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.injector as pi  # noqa: E402
import platoon.wire as w  # noqa: E402

P = w.V2vPacket
UPDATES = (P.UPDATE_JOINED, P.UPDATE_LEFT, P.UPDATE_MERGED, P.UPDATE_SPLIT)


class Truth(pi.Injector):
    def __init__(self, run: pi.Run, log: str, victim: int, at_s: float):
        self.run, self.victim, self.at_s = run, victim, at_s
        self.log = pi.DeliveryLog(run, log)
        self.forged = False
        self.altered = False
        self.delay = max(1, round(8.0 / run.dt))
        self.pending = {}  # step -> link packets to deliver again then

    def step(self, step, rx):
        forgeries = []
        for it in step.tx:
            p = it.packet
            sender, receiver = self.run.local(p.sender), self.run.local(it.receiver)
            if p.maneuver in UPDATES:
                self.pending.setdefault(step.k + self.delay, []).append(copy.deepcopy(it))
            if not self.forged and step.t >= self.at_s and sender == self.victim:
                forged = copy.deepcopy(it)
                q = forged.packet
                q.seq = p.seq + 1  # the victim's next sequence number, before it uses it
                q.maneuver, q.maneuver_arg = P.LEAVE_NOTICE, 0
                q.maneuver_to = p.sender - sender  # the leader, in wire ids
                q.maneuver_seq = 0xFFFF
                q.maneuver_vehicle = q.maneuver_behind = P.NOBODY
                forgeries.append(forged)
            if (
                self.forged
                and not self.altered
                and step.t >= self.at_s + 1.0
                and sender == self.victim + 1
                and receiver == 1
                and p.maneuver == P.NO_MANEUVER
            ):
                it = copy.deepcopy(it)
                q = it.packet
                q.maneuver, q.maneuver_arg = P.IN_POSITION, 0
                q.maneuver_to = p.sender - sender
                q.maneuver_seq = 0xFFFF
                q.maneuver_vehicle = q.maneuver_behind = P.NOBODY
                self.altered = True
                self.log.deliver(step, rx, it, "alter")
                continue
            self.log.deliver(step, rx, it, "pass")
        for it in forgeries:
            self.log.deliver(step, rx, it, "forge")
        self.forged = self.forged or bool(forgeries)
        for it in self.pending.pop(step.k, []):
            self.log.deliver(step, rx, it, "replay")

    def finish(self):
        self.log.close()


def main() -> int:
    args = sys.argv[1:]
    if len(args) != 3:
        print("usage: maneuver_truth.py LOG.csv VICTIM AT_S", file=sys.stderr)
        return 2
    log, victim, at_s = args[0], int(args[1]), float(args[2])
    return pi.run(lambda run: Truth(run, log, victim, at_s))


if __name__ == "__main__":
    sys.exit(main())
