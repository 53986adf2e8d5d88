"""The Python controller SDK's pieces that need no running co-simulation: the V2V graph of
the run's facts (the Rust order of neighbours), the fan-out of broadcasts to links, the sorting
of an rx batch, and the commands' checks and flags."""

import math
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))

import platoon.controller as pc  # noqa: E402
import platoon.wire as w  # noqa: E402


# Two-predecessor following (tpsf) of 4 followers as crates/topology writes it in facts.json.
TPSF4 = (
    [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0], [0.0, 1.0, 1.0, 0.0]],
    [1.0, 1.0, 0.0, 0.0],
)
TPSF2 = ([[0.0, 0.0], [1.0, 0.0]], [1.0, 1.0])


def test_a_graph_gives_the_rust_neighbour_lists():
    t = pc.Topology(*TPSF4)
    assert t.in_neighbours == [[], [0], [0, 1], [1, 2], [2, 3]]
    assert t.out_neighbours == [[1, 2], [2, 3], [3, 4], [4], []]
    t = pc.Topology([[0.0, 1.0], [1.0, 0.0]], [0.0, 1.0])
    assert t.in_neighbours == [[], [2], [0, 1]]
    assert t.out_neighbours == [[2], [2], [1]]


class Broadcasting(pc.Controller):
    def __init__(self, senders):
        self.senders = senders

    def transmit(self, step, tx):
        for s in self.senders:
            tx.append(pc.Packet(s, 7, step.k, (1.0, 2.0, 3.0), 0.5, head=s if s == 2 else 0))


def test_each_broadcast_goes_to_every_out_neighbour_numbered_by_platoon():
    topo = pc.Topology(*TPSF2)
    sent = [[False] * 3, [False] * 3]
    items = pc._transmit(
        [Broadcasting([0]), Broadcasting([1, 2])], 4, 0.04, [None] * 6, 3, topo.out_neighbours, sent
    )
    # Platoon 0: the leader to 1 and 2. Platoon 1 (ids 3..5): 1 to 2, 2 to nobody.
    assert [(it.receiver, it.packet.sender) for it in items] == [(1, 0), (2, 0), (5, 4)]
    assert all(it.kind == w.LinkPacket.DELIVERY and it.packet.step == 4 for it in items)
    assert list(items[0].packet.state) == [1.0, 2.0, 3.0] and items[0].packet.u == 0.5
    # The head as a wire id too: platoon 1's leader (3), and follower 2 heading itself (5).
    assert [it.packet.head for it in items] == [0, 0, 3]
    assert sent == [[True, False, False], [False, True, True]]
    with pytest.raises(pc.ContractError, match="vehicle 3"):
        pc._transmit([Broadcasting([3])], 0, 0.0, [None] * 3, 3, topo.out_neighbours, sent)

    class Lying(pc.Controller):
        def transmit(self, step, tx):
            tx.append(pc.Packet(1, 1, step.k, (0.0, 0.0, 0.0), 0.0, head=7))

    with pytest.raises(pc.ContractError, match="vehicle 7 as its head"):
        pc._transmit([Lying()], 0, 0.0, [None] * 3, 3, topo.out_neighbours, sent)


def link(receiver, sender, kind=w.LinkPacket.DELIVERY, head=None):
    it = w.LinkPacket(receiver=receiver, kind=kind)
    it.packet.sender = sender
    it.packet.head = sender - sender % 3 if head is None else head  # its platoon's leader
    it.packet.step = 1
    return it


def test_an_rx_batch_is_sorted_as_the_rust_sdk_sorts_it():
    rx = [
        link(1, 0),
        link(4, 3),
        link(5, 4, head=4),  # follower 1 of platoon 1 heads a split
        link(2, 1, head=5),  # a head of another platoon: UNKNOWN
        link(5, 1),  # a sender of another platoon
        link(9, 2),  # a receiver no vehicle has: platoon 0, UNKNOWN
        link(2, 0, w.LinkPacket.JAMMED),
        link(9, 0, w.LinkPacket.JAMMED),  # ignored
    ]
    deliveries, jammed = pc.sort_rx(rx, 3, 2)
    assert [(d.receiver, d.packet.sender) for d in deliveries[0]] == [
        (1, 0),
        (2, 1),
        (pc.UNKNOWN, 2),
    ]
    assert [(d.receiver, d.packet.sender) for d in deliveries[1]] == [
        (1, 0),
        (2, 1),
        (2, pc.UNKNOWN),
    ]
    # Heads in the platoon's own ids, as the senders.
    assert [d.packet.head for d in deliveries[0]] == [0, pc.UNKNOWN, 0]
    assert [d.packet.head for d in deliveries[1]] == [0, 1, pc.UNKNOWN]
    assert jammed == [[False, False, True], [False, False, False]]


def test_maneuver_messages_cross_the_wire_in_the_platoons_ids():
    """A Python controller sends and reads maneuver messages as the Rust SDK does: wire ids
    from the platoon's base, EVERYONE and NOBODY as the wire's sentinels, a message naming a
    vehicle of another platoon dropped (the beacon kept)."""
    update = pc.Maneuver(w.V2vPacket.UPDATE_JOINED, pc.EVERYONE, 4, 1, vehicle=2, behind=1)

    class Announcing(pc.Controller):
        def transmit(self, step, tx):
            tx.append(pc.Packet(0, 9, step.k, (1.0, 2.0, 3.0), maneuver=update))

    topo = pc.Topology(*TPSF2)
    sent = [[False] * 3, [False] * 3]
    items = pc._transmit(
        [Broadcasting([]), Announcing()], 2, 0.02, [None] * 6, 3, topo.out_neighbours, sent
    )
    p = items[0].packet
    assert (p.maneuver, p.maneuver_arg, p.maneuver_seq) == (w.V2vPacket.UPDATE_JOINED, 1, 4)
    assert (p.maneuver_to, p.maneuver_vehicle, p.maneuver_behind) == (w.V2vPacket.EVERYONE, 5, 4)
    back = pc._packet(p, 1, 3)
    assert back.maneuver == update and back.state == (1.0, 2.0, 3.0)
    # A packet without one, and one naming a vehicle of platoon 0 read by platoon 1.
    assert pc._packet(w.V2vPacket(sender=3), 1, 3).maneuver is None
    p.maneuver_vehicle = 2
    assert pc._packet(p, 1, 3).maneuver is None
    # A request to the leader: NOBODY stays NOBODY.
    request = pc.Maneuver(w.V2vPacket.JOIN_REQUEST, 0, 1, vehicle=1)
    wire = w.V2vPacket(sender=5)
    pc._maneuver_to_wire(request, wire, 3)
    assert (wire.maneuver_to, wire.maneuver_vehicle, wire.maneuver_behind) == (
        3,
        4,
        w.V2vPacket.NOBODY,
    )
    assert pc._packet(wire, 1, 3).maneuver == request


class Commanding(pc.Controller):
    def __init__(self, commands):
        self.commands = commands

    def receive(self, step, commands):
        commands.extend(self.commands)


def test_commands_carry_their_flags_and_bad_ones_are_refused():
    sent = [[False, True, False]]
    out, inspections = pc._receive(
        [Commanding([0.5, pc.Command(-1.0, theta=3.0, affected=True, mode=pc.ZERO, guard=True)])],
        2,
        0.02,
        [None] * 3,
        [],
        3,
        sent,
    )
    assert [(c.vehicle, c.u, c.theta) for c in out] == [(1, 0.5, 0.0), (2, -1.0, 3.0)]
    assert inspections == []  # it inspected nothing
    assert out[0].flags == w.Command.TRIGGERED  # it broadcast in this step's transmit
    assert out[1].flags == w.Command.AFFECTED | w.Command.GUARD | (pc.ZERO << 4)
    heading = Commanding([0.0, pc.Command(0.0, head=1)])
    out, _ = pc._receive([heading], 2, 0.02, [None] * 3, [], 3, sent)
    assert out[1].flags >> w.Command.HEAD_SHIFT == 1  # whom it took as its leader
    with pytest.raises(pc.ContractError, match="1 commands for 2 followers"):
        pc._receive([Commanding([0.0])], 0, 0.0, [None] * 3, [], 3, sent)
    with pytest.raises(pc.ContractError, match="follower 2 of platoon 0 is nan"):
        pc._receive([Commanding([0.0, math.nan])], 0, 0.0, [None] * 3, [], 3, sent)


def test_the_detectors_of_a_run_are_the_builtin_ones_then_the_plugins():
    assert pc.detector_names({}) == []
    d = {"residual": {}, "plausibility": {}, "plugin": ["mine", "other"], "reaction": "log"}
    # The Rust order (plausibility, radar_cross, residual), whatever the table order.
    assert pc.detector_names({"detection": d}) == ["plausibility", "residual", "mine", "other"]


def test_inspections_go_on_the_wire_with_a_bit_and_a_score_per_detector():
    packet = pc.Packet(0, 7, 41, (1.0, 2.0, 3.0))
    d = pc.Delivery(2, packet)
    names = ["residual", "mine"]
    items = pc._inspections(
        [(1, pc.Inspection(d, {"mine": (True, 4.5)}, refused=True))], names, 5
    )
    (it,) = items
    # Vehicle 2 and the leader of platoon 1, in wire ids.
    assert (it.receiver, it.sender, it.seq, it.step) == (7, 5, 7, 41)
    assert list(it.state) == [1.0, 2.0, 3.0]
    assert it.flags == w.Inspection.FLAGGED | w.Inspection.REFUSED | (1 << 9)
    assert math.isnan(it.scores[0]) and it.scores[1] == 4.5
    # A plain bool is a verdict without a score; not flagged sets no bit.
    (it,) = pc._inspections([(0, pc.Inspection(d, {"residual": False}))], names, 5)
    assert it.flags == 0 and math.isnan(it.scores[0])
    with pytest.raises(pc.ContractError, match="'unknown'.*plugin"):
        pc._inspections([(0, pc.Inspection(d, {"unknown": True}))], names, 5)
    with pytest.raises(pc.ContractError, match="not an Inspection"):
        pc._inspections([(0, "flagged")], names, 5)
