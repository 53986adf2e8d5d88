"""Attacks on the maneuver protocol (docs/maneuvers.md), as an injector you can copy: the
maneuver messages ride in the V2vPacket's `maneuver*` fields (docs/injector-contract.md), so an
injector reads, rewrites, replays, drops or invents them as it does the beacons. Five
attacks on a platoon-management protocol (after Amoozadeh et al., 2015):

- `forge-leave VEHICLE AT_S`: the first packet VEHICLE sends to the leader at or after AT_S
  reaches the leader as a leave notice in its name (an outsider rewriting it on the way, with
  the highest sequence number so the leader takes it): the leader ejects a member that never
  asked to leave, the falsified leave.

      platoon run configs/leave.toml \\
          --injector "bridge/.venv/bin/python bridge/examples/maneuver_attacks.py forge-leave 1 10"

- `fake-join VEHICLE AT_S`: the same rewrite into a join request for the slot behind the
  vehicle numbered just ahead of VEHICLE (for a joiner, the platoon's tail): sent before the
  joiner asks, the leader waits for a join nobody asked for and the joiner's own requests,
  numbered lower, are dropped as old: it stays outside (`configs/join.toml`, `fake-join 4 3`).

- `lie-in-position VEHICLE AT_S`: the same rewrite into an in-position report: a joiner that
  is not in its slot says it is (`configs/join.toml`, `lie-in-position 4 6`). The leader
  admits it; the joiner, which never said so, ignores the update while it is not in position.

- `replay-updates DELAY_S`: every formation update the leader broadcasts is delivered again,
  unchanged, DELAY_S later to each of its receivers. Each receiver drops it as old (its
  sequence number, and its generation, are behind), so the run is the run without the attack.

      platoon run configs/join.toml \\
          --injector "bridge/.venv/bin/python bridge/examples/maneuver_attacks.py replay-updates 8"

- `jam KIND`: every packet that carries a maneuver message of KIND (`move_in`, `gap_ready`,
  ...: the names of V2vPacket's constants, lower case; `update`: every formation update) is
  lost, its beacon with it: a maneuver jammed half way (`configs/join-middle.toml`,
  `jam move_in`: the gap opens, the joiner never moves in, the leader calls the join off and
  the gap closes).

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


class Forge(pi.Injector):
    """Rewrites VEHICLE's first packet to the leader from AT_S into a message of KIND."""

    NAMES = {
        P.LEAVE_NOTICE: "a leave notice",
        P.JOIN_REQUEST: "a join request",
        P.IN_POSITION: "an in-position report",
    }

    def __init__(self, run: pi.Run, kind: int, vehicle: int, at_s: float):
        self.run, self.kind, self.vehicle, self.at_s = run, kind, vehicle, at_s
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
                p.maneuver, p.maneuver_arg = self.kind, 0
                p.maneuver_to = it.receiver  # the leader, in wire ids
                p.maneuver_seq = 0xFFFF  # the highest a receiver takes
                p.maneuver_vehicle = p.maneuver_behind = P.NOBODY
                if self.kind == P.JOIN_REQUEST:
                    # The slot behind the vehicle numbered just ahead (wire ids are
                    # consecutive within a platoon).
                    p.maneuver_vehicle = p.sender - 1
                self.forged_at = step.k
            rx.append(it)

    def finish(self):
        what = self.NAMES[self.kind]
        print(f"maneuver_attacks: forged {what} at step {self.forged_at}", file=sys.stderr)


class Jam(pi.Injector):
    """Loses every packet that carries a maneuver message of one of KINDS."""

    def __init__(self, kinds: frozenset):
        self.kinds = kinds
        self.jammed = 0

    def step(self, step, rx):
        for it in step.tx:
            if it.packet.maneuver in self.kinds:
                self.jammed += 1
            else:
                rx.append(it)

    def finish(self):
        print(f"maneuver_attacks: jammed {self.jammed} deliveries", file=sys.stderr)


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


# The message kinds by name (V2vPacket's constants, lower case); `update` is every update.
KINDS = {
    name: frozenset([getattr(P, name.upper())])
    for name in (
        "join_request", "join_accept", "join_refuse", "open_gap", "gap_ready", "move_in",
        "in_position", "update_joined", "update_left", "abort", "leave_notice",
        "merge_request", "update_merged", "split_notice", "update_split",
    )
}
KINDS["update"] = frozenset(UPDATES)


def kinds(name: str) -> frozenset:
    """The V2vPacket constants a message kind's name gives (`move_in` -> {MOVE_IN})."""
    if name not in KINDS:
        raise ValueError(f"no maneuver message kind {name!r}; one of {', '.join(sorted(KINDS))}")
    return KINDS[name]


FORGED = {
    "forge-leave": P.LEAVE_NOTICE,
    "fake-join": P.JOIN_REQUEST,
    "lie-in-position": P.IN_POSITION,
}


def main() -> int:
    usage = (
        "usage: maneuver_attacks.py forge-leave|fake-join|lie-in-position VEHICLE AT_S"
        " | replay-updates DELAY_S | jam KIND"
    )
    args = sys.argv[1:]
    try:
        if args[:1] and args[0] in FORGED and len(args) == 3:
            forged, vehicle, at_s = FORGED[args[0]], int(args[1]), float(args[2])
            return pi.run(lambda run: Forge(run, forged, vehicle, at_s))
        if args[:1] == ["replay-updates"] and len(args) == 2:
            delay_s = float(args[1])
            return pi.run(lambda run: ReplayUpdates(run, delay_s))
        if args[:1] == ["jam"] and len(args) == 2:
            jammed = kinds(args[1])
            return pi.run(lambda run: Jam(jammed))
    except ValueError as e:
        print(f"maneuver_attacks.py: {e}\n{usage}", file=sys.stderr)
        return 2
    print(usage, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
