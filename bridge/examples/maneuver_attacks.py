"""Attacks on the maneuver protocol (docs/maneuvers.md), as an injector you can copy: the
maneuver messages ride in the V2vPacket's `maneuver*` fields (docs/injector-contract.md), so an
injector reads, rewrites, replays or invents them as it does the beacons. Two attacks:

- `forge-leave VEHICLE AT_S`: the first packet VEHICLE sends to the leader at or after AT_S
  reaches the leader as a leave notice in its name (an outsider rewriting it on the way, with
  the highest sequence number so the leader takes it): the leader ejects a member that never
  asked to leave, the falsified leave of Amoozadeh et al. (2015).

      platoon run configs/leave.toml \\
          --injector "bridge/.venv/bin/python bridge/examples/maneuver_attacks.py forge-leave 1 10"

- `replay-updates DELAY_S`: every formation update the leader broadcasts is delivered again,
  unchanged, DELAY_S later to each of its receivers. Each receiver drops it as old (its
  sequence number, and its generation, are behind), so the run is the run without the attack.

      platoon run configs/join.toml \\
          --injector "bridge/.venv/bin/python bridge/examples/maneuver_attacks.py replay-updates 8"

Everything else is forwarded as sent. What it did goes to stderr (logs/injector.log).
"""

import copy
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.injector as pi  # noqa: E402
import platoon.wire as w  # noqa: E402

P = w.V2vPacket
UPDATES = (P.UPDATE_JOINED, P.UPDATE_LEFT, P.UPDATE_MERGED, P.UPDATE_SPLIT)


class ForgeLeave(pi.Injector):
    """Rewrites VEHICLE's first packet to the leader from AT_S into a leave notice."""

    def __init__(self, run: pi.Run, vehicle: int, at_s: float):
        self.run, self.vehicle, self.at_s = run, vehicle, at_s
        self.forged_at = None

    def step(self, step, rx):
        for it in step.tx:
            p = it.packet
            if (
                self.forged_at is None
                and step.t >= self.at_s
                and self.run.local(p.sender) == self.vehicle
                and self.run.local(it.receiver) == 0
            ):
                it = copy.deepcopy(it)
                p = it.packet
                p.maneuver, p.maneuver_arg = P.LEAVE_NOTICE, 0
                p.maneuver_to = it.receiver  # the leader, in wire ids
                p.maneuver_seq = 0xFFFF  # the highest a receiver takes
                p.maneuver_vehicle = p.maneuver_behind = P.NOBODY
                self.forged_at = step.k
            rx.append(it)

    def finish(self):
        print(f"maneuver_attacks: forged a leave notice at step {self.forged_at}", file=sys.stderr)


class ReplayUpdates(pi.Injector):
    """Delivers every leader update again DELAY_S later."""

    def __init__(self, run: pi.Run, delay_s: float):
        self.delay = max(1, round(delay_s / run.dt))
        self.pending = {}  # step -> link packets to deliver again then
        self.replayed = 0

    def step(self, step, rx):
        for it in step.tx:
            if it.packet.maneuver in UPDATES:
                self.pending.setdefault(step.k + self.delay, []).append(copy.deepcopy(it))
            rx.append(it)
        again = self.pending.pop(step.k, [])
        self.replayed += len(again)
        rx.extend(again)

    def finish(self):
        print(f"maneuver_attacks: replayed {self.replayed} update deliveries", file=sys.stderr)


def main() -> int:
    usage = "usage: maneuver_attacks.py forge-leave VEHICLE AT_S | replay-updates DELAY_S"
    args = sys.argv[1:]
    if args[:1] == ["forge-leave"] and len(args) == 3:
        vehicle, at_s = int(args[1]), float(args[2])
        return pi.run(lambda run: ForgeLeave(run, vehicle, at_s))
    if args[:1] == ["replay-updates"] and len(args) == 2:
        delay_s = float(args[1])
        return pi.run(lambda run: ReplayUpdates(run, delay_s))
    print(usage, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
