"""Write the controller service of `platoon run --controller` in Python: one method per phase of
a step.

A step k has two phases because the V2V network sits between them: `transmit` gets what the
vehicles measured and appends the broadcasts of step k; `receive` gets what the network
delivered and appends every follower's command. Subclass `Controller` (one object per platoon,
with the platoon's own vehicle ids: 0 the leader, 1..N the followers) and pass a factory to
`run`; everything else of docs/controller-contract.md is done here (the same shape as the Rust
SDK, crates/controller-sdk): the ports of the run named by PLATOON_RUN_ID, READY, waiting on
wake-ups (never busy polling), one tx sample per step with each broadcast sent to every
out-neighbour of its sender (the run's `hearing` graph: [topology] of the config, plus every
member ahead when the platoon splits behind a cut-in), sorting the rx sample into deliveries
and jammed notices, one commands sample per step with its flags, DONE with the packets your
controller refused, STOP/ABORT, and exiting when `platoon run` is gone. An exception in your
code, a missing or non-finite command, or a broadcast from a vehicle the platoon does not have
stops the run, which names the controller and its log (logs/controller.log, which holds the
whole traceback). The built-in detectors ([detection.plausibility] etc.) are Rust: a config
that turns them on is refused before step 0.

    import platoon.controller as pc

    class Brake(pc.Controller):
        def __init__(self, run, platoon):
            self.n = run.vehicles_per_platoon - 1

        def transmit(self, step, tx):
            leader = step.states[0]  # u: a command of the step before (0.0: none here)
            tx.append(pc.Packet(0, step.k + 1, step.k, (leader.p, leader.v, leader.a), 0.0))

        def receive(self, step, commands):
            commands.extend([-0.5] * self.n)  # or pc.Command(u, theta, affected, mode, guard)

    pc.run(Brake)

`bridge/examples/paper_law.py` re-implements the paper's law and reproduces the built-in run
of configs/paper.toml byte for byte; `bridge/examples/sliding_mode.py` is a law the project does
not have (a sliding-mode CACC on the radar and the predecessor's broadcast acceleration).

Misbehaviour detectors of your own: name them in the config (`[detection] plugin = ["mine"]`),
and in `receive` append an `Inspection` per packet your detectors looked at to
`step.inspections`, in the order of `step.deliveries`, with each detector's verdict. The run
measures them against ground truth like the built-in detectors (`summary.json` `detection`,
the `detections` dataset); `bridge/examples/speed_check.py` is one.
"""

import math
import sys
import time
from typing import NamedTuple, Optional

from . import plugin as _plugin
from . import wire as w
from .plugin import ConfigLayoutError, ConfigTable, Run, Topology  # noqa: F401 (this SDK's API)

# Modes a command may report (Command.mode), as the outputs name them.
COOP, ZERO, HOLD, PREDICT, ACC, BLEND, CUT_IN, OUTSIDE, LEFT, BESIDE = range(10)

# A vehicle id that no vehicle has (Rust: u16::MAX): what a delivery's receiver or sender becomes
# when the rx batch names a vehicle that is not in this platoon.
UNKNOWN = 0xFFFF


# A maneuver message's addressee when it is for every member, and a vehicle field it leaves
# empty, in a platoon's ids (the Rust SDK's VehicleId(u16::MAX)).
EVERYONE = NOBODY = UNKNOWN


class Maneuver(NamedTuple):
    """A maneuver message riding on a packet (`[maneuvers]`, docs/maneuvers.md), as the Rust
    SDK's `Packet::maneuver` carries it: its `kind` (wire.V2vPacket.JOIN_REQUEST ...
    UPDATE_SPLIT), its addressee `to` (EVERYONE: every member), the sender's maneuver sequence
    number `seq`, `arg` (an accept's middle flag, a refusal's reason, an update's generation),
    the vehicle it names and, for an update that a vehicle joined, whom it follows (for a merge
    request or update: the rear platoon's head or the tail it asks for, and its last vehicle;
    `vehicle`, `behind`; NOBODY: none), in the platoon's ids. A controller of a platoon that negotiates
    maneuvers reads them in the deliveries and may send its own on its packets."""

    kind: int
    to: int
    seq: int
    arg: int = 0
    vehicle: int = NOBODY
    behind: int = NOBODY


class Packet(NamedTuple):
    """A V2V broadcast: the sender (0 = the leader), its sequence number, the step its state was
    sampled at, that state (p, v, a), the sender's latest command u, and the head of the
    platoon the sender drives in (0 = the leader; the sender itself when it heads the part of
    a platoon split behind a car that cut in, docs/traffic.md), and the maneuver message it
    carries, if any (`Maneuver`)."""

    sender: int
    seq: int
    step: int
    state: tuple
    u: float = 0.0
    head: int = 0
    maneuver: Optional[Maneuver] = None


class Delivery(NamedTuple):
    """A packet the network delivered to `receiver` (a follower of this platoon, or UNKNOWN)."""

    receiver: int
    packet: Packet


class Inspection(NamedTuple):
    """What your detectors said of one delivery (append it to `step.inspections` in `receive`,
    in the order of `step.deliveries`): `verdicts` maps a detector's name (one of
    `run.detectors`, the config's `[detection]`) to whether it flagged the packet, or to
    (flagged, score), score its test statistic (larger: more suspicious); a detector left out
    did not test it. `refused`: your reaction refused the packet."""

    delivery: Delivery
    verdicts: dict
    refused: bool = False


class Command:
    """A follower's command u and what its controller did, for the outputs: theta (the trigger's
    internal variable, 0 if none), affected (by an attack), mode (COOP, ZERO, ...), guard
    (emergency braking), triggered (it broadcast in this step; None: whether it is the sender
    of a packet of this step's transmit) and head (whom it took as its leader: 0, the platoon's
    leader, or a member ahead heading a platoon split behind a cut-in; docs/traffic.md)."""

    __slots__ = ("u", "theta", "affected", "mode", "guard", "triggered", "head")

    def __init__(
        self, u, theta=0.0, affected=False, mode=COOP, guard=False, triggered=None, head=0
    ):
        self.u, self.theta, self.affected = u, theta, affected
        self.mode, self.guard, self.triggered = mode, guard, triggered
        self.head = head


class Step:
    """What a controller sees in a phase of step k: `k`, `t`, `platoon` (its index in the
    fleet), `states` (this platoon's vehicles as the plant measured them, leader first:
    `.p .v .a`, and the radar's view of the vehicle ahead `.gap .closing`, valid when
    `.flags & AHEAD`, of a vehicle that is not the platoon's predecessor when
    `.flags & INTRUDER`: a cut-in, named by `.flags >> VehicleState.TARGET_SHIFT`, docs/traffic.md); in `receive` also `deliveries` (a list of Delivery) and `jammed`
    (jammed[v]: vehicle v was told its channel was jammed in this step) and `inspections`, a
    list to which your detectors append an `Inspection` per delivery they looked at (runs with
    `[detection]`)."""

    __slots__ = ("k", "t", "platoon", "states", "deliveries", "jammed", "inspections")

    def __init__(self, k, t, platoon, states, deliveries=None, jammed=None):
        self.k, self.t, self.platoon, self.states = k, t, platoon, states
        self.deliveries, self.jammed = deliveries, jammed
        self.inspections = []


AHEAD = w.VehicleState.AHEAD
INTRUDER = w.VehicleState.INTRUDER


class Controller:
    """One platoon's follower controllers."""

    def transmit(self, step: Step, tx: list) -> None:
        """Phase 1 of step k: append the Packets broadcast at step k (the leader's too, if it
        broadcasts). Each goes to every vehicle that hears its sender."""
        raise NotImplementedError

    def receive(self, step: Step, commands: list) -> None:
        """Phase 2 of step k: append one command per follower, 1..N in order: a float (u) or a
        Command."""
        raise NotImplementedError

    def rejected(self):
        """Packets refused so far, by reason: non-finite, unknown sender, future step, stale,
        implausible sequence number, implausible state (reported in summary.json)."""
        return (0, 0, 0, 0, 0, 0)

    def finish(self) -> None:
        """Called once after the last step."""


class ContractError(Exception):
    """What the controller gave cannot be sent."""


BUILTIN_DETECTORS = ("plausibility", "radar_cross", "residual")


def detector_names(config: dict) -> list:
    """The detectors a run measures, in the order of every inspection's verdicts (crates/control
    `DetectionParams::names`): the built-in ones the config's `[detection]` turns on, then the
    plug-in's (`plugin`). Empty: the run measures none, and has no `inspections` service."""
    d = config.get("detection")
    if not d:
        return []
    return [n for n in BUILTIN_DETECTORS if n in d] + list(d.get("plugin", []))


def load_run() -> Run:
    """The run that started this process, from PLATOON_RUN_ID, PLATOON_CONFIG and
    PLATOON_RUN_FACTS (paths)."""
    return _plugin.load_run("--controller")


def run(make) -> int:
    """Runs the controllers `make(run, platoon)` returns (one per platoon, in order) until the
    run ends; returns the exit code."""
    w.check_contract_version()  # before anything that depends on the run's formats
    info = load_run()
    n1, platoons = info.vehicles_per_platoon, info.platoons
    out = info.hearing.out_neighbours
    node = w.Endpoint("controller", info.run_id)
    states_in = node.inlet("states", w.VehicleState)
    rx_in = node.inlet("rx", w.LinkPacket)
    tx_out = node.outlet("tx", w.LinkPacket, sum(map(len, out)) * platoons, grow=False)
    cmd_out = node.outlet("commands", w.Command, (n1 - 1) * platoons, grow=False)
    detectors = info.detectors
    links = sum(map(len, out)) * platoons
    insp_out = node.outlet("inspections", w.Inspection, links) if detectors else None
    control = node.control_inlet()
    status = node.status_outlet()  # keep it: a dropped publisher takes its samples with it
    k = 0

    def failed(e):
        return _plugin.report_failure(node, control, status, "controller", k, e)

    # The built-in detectors are Rust (platoon-detect): a Python controller cannot run them, and
    # a run that measured them anyway would score them as having missed every packet.
    builtin = [n for n in BUILTIN_DETECTORS if n in (info.config.get("detection") or {})]
    if builtin:
        tables = ", ".join(f"[detection.{n}]" for n in builtin)
        print(
            f"controller: the config turns on the built-in detectors {tables}, which the Python "
            "controller SDK cannot run (they are Rust, platoon-detect). Remove those tables and "
            "name your own detectors in [detection] plugin = [...], or run the built-in "
            "controllers (no --controller) or a Rust SDK controller (platoon-controller-sdk), which "
            "run them.",
            file=sys.stderr,
        )
        reason = f"the Python SDK cannot run built-in detectors: {', '.join(builtin)}"
        return _plugin.fail(node, control, status, "controller", 0, reason)

    try:
        controllers = [make(info, j) for j in range(platoons)]
    except Exception as e:  # noqa: BLE001: any failure of user code stops the run
        return failed(e)
    w.send_status(status, w.ControlMsg.READY, "controller")
    sent = [[False] * n1 for _ in range(platoons)]
    states = None
    while True:
        t = k * info.dt
        try:
            if states is None:
                states = states_in.take(k)
                if states is not None:
                    tx_out.send(k, t, _transmit(controllers, k, t, states, n1, out, sent))
            if states is not None:
                rx = rx_in.take(k)
                if rx is not None:
                    commands, inspections = _receive(controllers, k, t, states, rx, n1, sent)
                    if insp_out is not None:
                        insp_out.send(k, t, _inspections(inspections, detectors, n1))
                    cmd_out.send(k, t, commands)
                    states = None
                    if k == info.steps:
                        counts = [0] * 6
                        for c in controllers:
                            c.finish()
                            counts = [a + b for a, b in zip(counts, c.rejected())]
                        _plugin.send_done(status, "controller", k, counts)
                        while not _plugin.stop_received(control):
                            node.wait()
                        return 0
                    k += 1
                    continue  # the next states may already be here
        except Exception as e:  # noqa: BLE001: any failure of user code stops the run
            return failed(e)
        # Nothing to do: the only time to look at the control channel (STOP/ABORT).
        if _plugin.stop_received(control):
            return 0
        node.wait()


def _transmit(controllers, k, t, states, n1, out, sent):
    """Phase 1 for every platoon: the tx items, one per link."""
    items = []
    stamp = time.monotonic_ns()
    for j, c in enumerate(controllers):
        base = j * n1
        tx = []
        c.transmit(Step(k, t, j, states[base : base + n1]), tx)
        flags = sent[j]
        for v in range(n1):
            flags[v] = False
        for p in tx:
            s = p.sender
            if not 0 <= s < n1:
                raise ContractError(f"platoon {j} broadcast as vehicle {s}, which it does not have")
            if not 0 <= p.head < n1:
                raise ContractError(
                    f"platoon {j}: vehicle {s} names vehicle {p.head} as its head, which the "
                    "platoon does not have"
                )
            if flags[s]:
                raise ContractError(
                    f"platoon {j}: vehicle {s} broadcast twice in step {k} (at most once per step)"
                )
            flags[s] = True
            packet = w.V2vPacket(
                sender=base + s, seq=p.seq, step=p.step, stamp_ns=stamp, u=p.u, head=base + p.head
            )
            packet.state[0], packet.state[1], packet.state[2] = p.state
            if p.maneuver is not None:
                _maneuver_to_wire(p.maneuver, packet, base)
            for r in out[s]:
                items.append(
                    w.LinkPacket(receiver=base + r, kind=w.LinkPacket.DELIVERY, packet=packet)
                )
    return items


def _local(g, j, n1):
    """Wire id `g` in platoon `j`'s ids, or UNKNOWN when it is of no vehicle of that platoon."""
    return g - j * n1 if j * n1 <= g < (j + 1) * n1 else UNKNOWN


def _maneuver_to_wire(m, packet, base):
    """Maneuver `m` (platoon ids from `base`) into the wire packet's maneuver fields."""

    def wire_id(v, none):
        return none if v == NOBODY else base + v

    packet.maneuver = m.kind
    packet.maneuver_arg = m.arg
    packet.maneuver_to = wire_id(m.to, w.V2vPacket.EVERYONE)
    packet.maneuver_seq = m.seq
    packet.maneuver_vehicle = wire_id(m.vehicle, w.V2vPacket.NOBODY)
    packet.maneuver_behind = wire_id(m.behind, w.V2vPacket.NOBODY)


def _maneuver(p, j, n1):
    """The maneuver message of wire packet `p` in platoon `j`'s ids, or None: without one, and,
    as the Rust SDK drops it, for one that names a vehicle of another platoon or of none."""
    if p.maneuver == w.V2vPacket.NO_MANEUVER:
        return None
    ids = []
    for g in (p.maneuver_to, p.maneuver_vehicle, p.maneuver_behind):
        v = NOBODY if g == w.V2vPacket.NOBODY else _local(g, j, n1)
        if v == UNKNOWN and g != w.V2vPacket.NOBODY:
            return None
        ids.append(v)
    to, vehicle, behind = ids
    return Maneuver(p.maneuver, to, p.maneuver_seq, p.maneuver_arg, vehicle, behind)


def _packet(p, j, n1) -> Packet:
    state = (p.state[0], p.state[1], p.state[2])
    return Packet(
        _local(p.sender, j, n1),
        p.seq,
        p.step,
        state,
        p.u,
        _local(p.head, j, n1),
        _maneuver(p, j, n1),
    )


def sort_rx(rx, n1, platoons):
    """An rx batch as each platoon's deliveries and jammed notices, as the Rust SDK sorts it
    (crates/runtime session::deliveries_from_wire): a receiver no vehicle has goes to platoon 0
    as a delivery to UNKNOWN (its checks count it), a sender of another platoon or of no vehicle
    becomes UNKNOWN, a jammed notice for no vehicle is ignored."""
    total = n1 * platoons
    deliveries = [[] for _ in range(platoons)]
    jammed = [[False] * n1 for _ in range(platoons)]
    for it in rx:
        g = it.receiver
        if g >= total:
            if it.kind != w.LinkPacket.JAMMED:
                deliveries[0].append(Delivery(UNKNOWN, _packet(it.packet, 0, n1)))
            continue
        j, r = divmod(g, n1)
        if it.kind == w.LinkPacket.JAMMED:
            jammed[j][r] = True
            continue
        deliveries[j].append(Delivery(r, _packet(it.packet, j, n1)))
    return deliveries, jammed


def _receive(controllers, k, t, states, rx, n1, sent):
    """Phase 2 for every platoon: the commands of every follower, in order."""
    deliveries, jammed = sort_rx(rx, n1, len(controllers))
    commands, inspections = [], []
    for j, c in enumerate(controllers):
        base = j * n1
        got = []
        step = Step(k, t, j, states[base : base + n1], deliveries[j], jammed[j])
        c.receive(step, got)
        inspections.extend((j, i) for i in step.inspections)
        if len(got) != n1 - 1:
            raise ContractError(f"platoon {j} gave {len(got)} commands for {n1 - 1} followers")
        for i, cmd in enumerate(got, start=1):
            if not isinstance(cmd, Command):
                cmd = Command(cmd)
            if not math.isfinite(cmd.u):
                raise ContractError(f"the command of follower {i} of platoon {j} is {cmd.u}")
            triggered = sent[j][i] if cmd.triggered is None else cmd.triggered
            flags = (
                (w.Command.TRIGGERED if triggered else 0)
                | (w.Command.AFFECTED if cmd.affected else 0)
                | (w.Command.GUARD if cmd.guard else 0)
                | ((cmd.mode & w.Command.MODE_MASK) << w.Command.MODE_SHIFT)
                | ((cmd.head & w.Command.HEAD_MASK) << w.Command.HEAD_SHIFT)
            )
            commands.append(w.Command(vehicle=base + i, flags=flags, u=cmd.u, theta=cmd.theta))
    return commands, inspections


def _wire_id(j, n1, v):
    return UNKNOWN_WIRE if v == UNKNOWN else j * n1 + v


# What a vehicle id no vehicle has becomes on the wire (Rust: u32::MAX).
UNKNOWN_WIRE = 0xFFFFFFFF


def _inspections(inspections, detectors, n1):
    """The controllers' inspections of a step as wire items (global ids, a flag bit and a
    score per detector in the run's order)."""
    index = {name: d for d, name in enumerate(detectors)}
    items = []
    for j, ins in inspections:
        if not isinstance(ins, Inspection):
            raise ContractError(f"platoon {j} appended {ins!r} to step.inspections, not an Inspection")
        d, p = ins.delivery
        item = w.Inspection(
            receiver=_wire_id(j, n1, d), sender=_wire_id(j, n1, p.sender), seq=p.seq, step=p.step
        )
        item.state[0], item.state[1], item.state[2] = p.state
        for x in range(8):
            item.scores[x] = math.nan
        flags = w.Inspection.REFUSED if ins.refused else 0
        for name, verdict in ins.verdicts.items():
            if name not in index:
                raise ContractError(
                    f"platoon {j} reported detector {name!r}, which the run does not measure "
                    f"(its [detection] names {detectors}; add it to plugin = [...])"
                )
            if isinstance(verdict, (tuple, list)):
                if len(verdict) != 2:
                    raise ContractError(
                        f"platoon {j}: the verdict of {name!r} is {verdict!r}: give flagged or "
                        "(flagged, score)"
                    )
                flagged, score = verdict
            else:
                flagged, score = verdict, math.nan
            if flagged:
                flags |= w.Inspection.FLAGGED | (1 << (w.Inspection.DETECTOR_SHIFT + index[name]))
            item.scores[index[name]] = float(score)
        item.flags = flags
        items.append(item)
    return items
