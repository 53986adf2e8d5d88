"""Python mirror of the platoon wire contract (crates/wire): payload types, service names, and
the helpers an injector (or any other node) needs to take part in an iceoryx2 run.

Every type mirrors its Rust `#[repr(C)]` twin; `tests/test_layout.py` checks size, alignment and
every field offset against `wire_layout.json`, which a Rust test checks against the Rust types.
See docs/injector-contract.md for the protocol.
"""

import ctypes
import os
import time

import iceoryx2 as iox

# The contract version (crates/wire CONTRACT_VERSION; tests/test_layout.py checks it against
# wire_layout.json). Every payload's type name carries it, so iceoryx2 refuses to connect
# processes of different versions; `platoon run` gives every process it starts the run's
# version in PLATOON_CONTRACT_VERSION, and `Endpoint` compares it with this one first.
# v1: the first published contract; v2: V2vPacket gained `u` (the sender's latest command);
# later, still v2: the optional `traffic` service (TrafficVehicle; no v2 payload changed), then
# the optional `inspections` service (Inspection; the same way); v3: V2vPacket gained `head`
# (the head of the platoon the sender drives in, for a platoon split behind a cut-in) and
# `reserved` (always 0); v4: V2vPacket carries a maneuver message (`maneuver` and its fields in
# place of `reserved`; 80 bytes); v5: V2vPacket carries its sender's seal (`seal_len`, `seal`:
# the security header of a `[security]` run, docs/security.md; 280 bytes); v6: ControlMsg
# counts the controller's misbehaviour reports (`reports`), Command.flags bit 3 (REVOKED); v7:
# V2vPacket carries its group-key fields (`group_len`, `group`: a `[security.group]` run's tag,
# key share or wrapped key; 400 bytes), ControlMsg.seals counts their refusals, tags, renewals.
CONTRACT_VERSION = 7
CONTRACT_VERSION_ENV = "PLATOON_CONTRACT_VERSION"
CONTRACT_DOC = "docs/injector-contract.md"


def type_name(short: str) -> str:
    """The iceoryx2 type name of payload `short`: platoon::v<CONTRACT_VERSION>::<short>."""
    return f"platoon::v{CONTRACT_VERSION}::{short}"


def check_contract_version(run=None) -> None:
    """Exits (SystemExit, status 1, message on stderr) if the run that started this process
    speaks another contract version than this module; `run` defaults to the environment's
    PLATOON_CONTRACT_VERSION (absent: not started by `platoon run`, nothing to compare)."""
    if run is None:
        run = os.environ.get(CONTRACT_VERSION_ENV)
    if run is None:
        return
    try:
        version = int(run.strip())
    except ValueError:
        raise SystemExit(
            f"this plug-in speaks platoon contract v{CONTRACT_VERSION}, but "
            f"{CONTRACT_VERSION_ENV} is {run!r}, not a version number (see {CONTRACT_DOC})"
        ) from None
    if version != CONTRACT_VERSION:
        raise SystemExit(
            f"this plug-in speaks platoon contract v{CONTRACT_VERSION}, but the run speaks "
            f"v{version} ({CONTRACT_VERSION_ENV}={version}): use the bridge/ (platoon/wire.py and the "
            f'injector or controller SDK) of v{version} (see "Contract versions" in {CONTRACT_DOC} '
            "for what changed)"
        )


class Payload(ctypes.Structure):
    """A type that crosses the wire: its iceoryx2 type name is its class name (`type_name`)."""

    @classmethod
    def type_name(cls) -> str:
        return type_name(cls.__name__)


class StepHeader(Payload):
    """User header of every step sample. `count` is the number of items: read that, never the
    slice length, which iceoryx2 0.10.0's Python bindings report in bytes (iceoryx2 #1533)."""

    _fields_ = [
        ("step", ctypes.c_uint64),
        ("time_s", ctypes.c_double),
        ("count", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
    ]


class VehicleState(Payload):
    """A vehicle's true state at a step (plant -> controller, injector, orchestrator)."""

    _fields_ = [
        ("vehicle", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("p", ctypes.c_double),
        ("v", ctypes.c_double),
        ("a", ctypes.c_double),
        ("gap", ctypes.c_double),  # to the vehicle ahead as the plant sees it (flags & AHEAD)
        ("closing", ctypes.c_double),  # v - v_ahead
    ]

    COLLIDED = 1
    AHEAD = 2
    INTRUDER = 4  # the vehicle ahead is not the platoon's predecessor
    BESIDE = 8  # the vehicle drives in the lane beside the platoon's (as the plant has it)
    # With INTRUDER, flags >> TARGET_SHIFT names it: 1 + c for the platoon's cut-in c, 1 + C + b
    # for background vehicle bg<b> (C cut-ins), 0 for a vehicle the plant does not name.
    TARGET_SHIFT = 8


class V2vPacket(Payload):
    """A V2V broadcast: sender, sequence number, sampling step, send time stamp, state [p, v, a],
    the sender's latest commanded acceleration u, the head of the platoon the sender drives in
    (a wire id like sender: the leader, or the sender when it heads a split platoon), and the
    maneuver message it may carry (`maneuver`: NO_MANEUVER or a kind below; its addressee,
    sequence number, the vehicle it names and, for an update that a vehicle joined, whom it
    follows, as wire ids; `maneuver_arg`: the middle flag, the refusal reason or the update's
    generation). An injector passes these through, or forges them (docs/maneuvers.md).
    `seal_len` and `seal`: the sender's seal in a `[security]` run (docs/security.md), opaque
    bytes an injector forwards with the packet; an altered packet keeps a seal that no longer
    verifies, an invented one has none (`seal_len` 0). `group_len` and `group`: its group-key
    fields in a `[security.group]` run (a tag under the platoon's key, a join's key share, a
    wrapped key), opaque too and covered by the seal's signature."""

    _fields_ = [
        ("sender", ctypes.c_uint32),
        ("seq", ctypes.c_uint32),
        ("step", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("state", ctypes.c_double * 3),
        ("u", ctypes.c_double),
        ("head", ctypes.c_uint32),
        ("maneuver", ctypes.c_uint16),
        ("maneuver_arg", ctypes.c_uint16),
        ("maneuver_to", ctypes.c_uint32),
        ("maneuver_seq", ctypes.c_uint32),
        ("maneuver_vehicle", ctypes.c_uint32),
        ("maneuver_behind", ctypes.c_uint32),
        ("seal_len", ctypes.c_uint32),
        ("seal", ctypes.c_uint8 * 196),
        ("group_len", ctypes.c_uint32),
        ("group", ctypes.c_uint8 * 116),
    ]

    # The size of `seal` (crates/wire V2vPacket::SEAL_CAPACITY).
    SEAL_CAPACITY = 196
    # The size of `group` (crates/wire V2vPacket::GROUP_CAPACITY).
    GROUP_CAPACITY = 116

    # `maneuver` (crates/wire V2vPacket's constants).
    NO_MANEUVER = 0
    JOIN_REQUEST = 1
    JOIN_ACCEPT = 2
    JOIN_REFUSE = 3
    OPEN_GAP = 4
    GAP_READY = 5
    MOVE_IN = 6
    IN_POSITION = 7
    UPDATE_JOINED = 8
    UPDATE_LEFT = 9
    ABORT = 10
    LEAVE_NOTICE = 11
    MERGE_REQUEST = 12
    UPDATE_MERGED = 13
    SPLIT_NOTICE = 14
    UPDATE_SPLIT = 15
    # `maneuver_arg` of a refusal.
    REFUSED_BUSY = 0
    REFUSED_FULL = 1
    REFUSED_NO_SLOT = 2
    REFUSED_MEMBER = 3
    # `maneuver_to`: every member; `maneuver_vehicle`, `maneuver_behind`: no vehicle.
    EVERYONE = 0xFFFFFFFF
    NOBODY = 0xFFFFFFFF


class LinkPacket(Payload):
    """A packet on one link (tx and rx batches); kind JAMMED tells the receiver it was jammed."""

    DELIVERY = 0
    JAMMED = 1

    _fields_ = [
        ("receiver", ctypes.c_uint32),
        ("kind", ctypes.c_uint32),
        ("packet", V2vPacket),
    ]


class Command(Payload):
    """A follower's command and what its controller did (controller -> plant, orchestrator)."""

    TRIGGERED = 1
    AFFECTED = 2
    GUARD = 4
    REVOKED = 8  # the misbehaviour authority revoked its certificates ([security.reports])
    LEADER_REVOKED = 1 << 24  # ... and its platoon's leader's
    MODE_SHIFT = 4  # (flags >> MODE_SHIFT) & MODE_MASK: 0 coop, 1 zero, 2 hold, 3 predict,
    MODE_MASK = 0b1111  # 4 acc, 5 blend, 6 cut_in, 7 outside, 8 left, 9 beside
    # (flags >> HEAD_SHIFT) & HEAD_MASK: whom it took as its leader (0: the platoon's leader;
    # a member ahead heading a platoon split behind a cut-in).
    HEAD_SHIFT = 8
    HEAD_MASK = 0xFFFF

    _fields_ = [
        ("vehicle", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("u", ctypes.c_double),
        ("theta", ctypes.c_double),
    ]


class TrafficVehicle(Payload):
    """A vehicle of the plant's background traffic at a step (plant -> injector, orchestrator,
    service `traffic`, published before the states of the step): SUMO's `bg<index>`. `p` is
    its position along the road in the platoon's coordinates when `flags & ON_ROAD`, else NaN
    (not inserted yet, or left the road)."""

    ON_ROAD = 1

    _fields_ = [
        ("index", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("p", ctypes.c_double),
    ]


class Inspection(Payload):
    """What a follower's misbehaviour detectors said of one packet it received at a step, and
    what its reaction did (controller -> orchestrator, service `inspections`, published before
    the step's commands in runs that measure detectors): the receiver and the packet's sender
    (wire ids), its seq, step and claimed state; flags: FLAGGED (any detector), REFUSED (the
    reaction refused it), bits REFUSED_BY_SHIFT.. (REFUSED_BY_MASK) what refused it (0: accepted
    or not said; 1-6 the packet checks' reasons in the order of ControlMsg.counts, for a
    delivery no detector saw; 7 the reaction; 8 the leader's check of maneuver messages; 9 the
    receiver's maneuver machine dropped the message as old, after the step's other items; 10-23
    the seal (or the group key) of a [security] run, its refusal code + 9; bits 2-7 since v5), and
    bit DETECTOR_SHIFT + d when detector d flagged it (the run's `[detection]` order: built-in
    ones, then `plugin`); scores[d] its statistic (NaN: not tested)."""

    FLAGGED, REFUSED, DETECTOR_SHIFT = 1, 2, 8
    REFUSED_BY_SHIFT = 2
    REFUSED_BY_MASK = 0x3F << REFUSED_BY_SHIFT

    _fields_ = [
        ("receiver", ctypes.c_uint32),
        ("sender", ctypes.c_uint32),
        ("seq", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("step", ctypes.c_uint64),
        ("state", ctypes.c_double * 3),
        ("scores", ctypes.c_double * 8),
    ]


class ControlMsg(Payload):
    """Control (orchestrator -> nodes) and status (nodes -> orchestrator) messages."""

    START, STOP, ABORT = 1, 2, 3
    READY, DONE, FAILED = 10, 11, 12
    # Controller -> orchestrator before DONE in a [security] run: per-step crypto time percentiles.
    TIMING = 13

    _fields_ = [
        ("kind", ctypes.c_uint32),
        ("node", ctypes.c_uint32),
        ("step", ctypes.c_uint64),
        ("counts", ctypes.c_uint64 * 6),
        # DONE from the controller in a [security] run: signed, verified, refusals by code 1-14,
        # then tags made and group-key renewals ([security.group]); with [security.reports]:
        # reports filed, lost, then arrived by outcome code 1-9.
        ("seals", ctypes.c_uint64 * 18),
        ("reports", ctypes.c_uint64 * 11),
        ("reason", ctypes.c_uint8 * 120),
    ]


ALL_TYPES = [
    StepHeader,
    VehicleState,
    V2vPacket,
    LinkPacket,
    Command,
    TrafficVehicle,
    Inspection,
    ControlMsg,
]

# A node keeps a CPU set the wake-up hand-off narrowed for this many wake-ups, then returns to
# its own (crates/runtime/src/handoff.rs, RETURN_EVERY; a Rust test checks they agree).
HANDOFF_RETURN_EVERY = 64

NODES = {"orchestrator": 0, "plant": 1, "controller": 2, "injector": 3, "channel": 4}

# Whom a publisher on each service wakes after every sample (crates/wire `wakes`).
WAKES = {
    "states": ["controller"],
    "tx": ["injector"],
    "gated": ["injector"],
    "rx": ["controller"],
    "commands": ["plant", "orchestrator"],
    "traffic": [],  # published before the states; its readers are woken by what follows
    "inspections": [],  # published before the commands, which wake the orchestrator
    "control": ["plant", "controller", "injector"],
    "status": ["orchestrator"],
}


def service_name(run_id: str, service: str) -> str:
    """The iceoryx2 service name (crates/wire `service_name`): platoon/<run id>/<service>."""
    return f"platoon/{run_id}/{service}"


def wake_name(run_id: str, node: str) -> str:
    """The event service that wakes `node`."""
    return f"platoon/{run_id}/wake/{node}"


class Endpoint:
    """One node of a run: opens (never creates) the services the orchestrator made."""

    def __init__(self, role: str, run_id: "str | None" = None):
        check_contract_version()  # before opening anything: other versions cannot connect
        iox.set_log_level_from_env_or(iox.LogLevel.Error)
        self.role = role
        self.run_id = run_id or os.environ["PLATOON_RUN_ID"]
        self.node = (
            iox.NodeBuilder.new()
            .name(iox.NodeName.new(f"platoon-{role}-py-{self.run_id}"))
            .signal_handling_mode(iox.SignalHandlingMode.Disabled)
            .create(iox.ServiceType.Ipc)
        )
        self.parent = os.getppid()
        self.listener = self._event(role).listener_builder().create()
        # The Rust nodes hand a sleeping reader the CPU they wake it from (crates/runtime
        # src/handoff.rs): kept for a few wake-ups, then back to this process's own CPUs.
        home = os.sched_getaffinity(0)
        self._home = home if len(home) > 1 else None
        self._woken = 0

    def _event(self, node: str):
        return (
            self.node.service_builder(iox.ServiceName.new(wake_name(self.run_id, node)))
            .event()
            .open()
        )

    def _wakers(self, service: str):
        return [
            self._event(n).notifier_builder().create()
            for n in WAKES[service]
            if n != self.role
        ]

    def _step_service(self, service: str, item):
        return (
            self.node.service_builder(iox.ServiceName.new(service_name(self.run_id, service)))
            .publish_subscribe(iox.Slice[item])
            .user_header(StepHeader)
            .open()
        )

    def has_service(self, service: str) -> bool:
        """Whether the run has step service `service` (the orchestrator creates the optional
        ones, such as `traffic`, only when some node publishes them)."""
        return iox.Service.does_exist(
            iox.ServiceName.new(service_name(self.run_id, service)),
            self.node.config,
            iox.MessagingPattern.PublishSubscribe,
            iox.ServiceType.Ipc,
        )

    def inlet(self, service: str, item) -> "Inlet":
        return Inlet(self._step_service(service, item).subscriber_builder().create(), item)

    def outlet(self, service: str, item, max_len: int, grow: bool = True) -> "Outlet":
        """A publisher of one sample per step on `service`, of up to `max_len` items.

        With `grow=False` its shared memory holds exactly `max_len` items, and the run's
        readers map it when the run starts: what this process published stays readable after
        it exits (or crashes), and a batch of more than `max_len` items is an error. With
        `grow=True` (the default) a larger batch reallocates it, but a reader maps that memory
        only when it first reads from it, so samples not yet read when this process exits are
        lost with it. Bound what you can (a controller's commands, its tx batch); grow what you
        cannot (an injector that duplicates packets)."""
        strategy = iox.AllocationStrategy.PowerOfTwo if grow else iox.AllocationStrategy.Static
        pub = (
            self._step_service(service, item)
            .publisher_builder()
            .initial_max_slice_len(max(1, max_len))
            .allocation_strategy(strategy)
            .create()
        )
        return Outlet(pub, self._wakers(service), service, None if grow else max(1, max_len))

    def control_inlet(self):
        svc = (
            self.node.service_builder(iox.ServiceName.new(service_name(self.run_id, "control")))
            .publish_subscribe(ControlMsg)
            .open()
        )
        return svc.subscriber_builder().create()

    def status_outlet(self):
        """The status publisher and its wakers. Keep it for the whole run: a publisher that is
        dropped takes its unread samples with it."""
        svc = (
            self.node.service_builder(iox.ServiceName.new(service_name(self.run_id, "status")))
            .publish_subscribe(ControlMsg)
            .open()
        )
        return svc.publisher_builder().create(), self._wakers("status")

    def wait(self, timeout_ms: int = 200) -> None:
        """Blocks until notified or the timeout; exits if the orchestrator is gone."""
        self.listener.timed_wait(iox.Duration.from_millis(timeout_ms))
        if self._home is not None:
            self._woken += 1
            if self._woken >= HANDOFF_RETURN_EVERY:
                self._woken = 0
                os.sched_setaffinity(0, self._home)
        if os.getppid() != self.parent:
            raise SystemExit("platoon: the orchestrator is gone")


class Inlet:
    """Buffers step samples by step (copies the items out of shared memory)."""

    def __init__(self, subscriber, item):
        self.subscriber = subscriber
        self.item = item
        self.pending = {}

    def take(self, step: int):
        if step in self.pending:
            return self.pending.pop(step)
        while True:
            sample = self.subscriber.receive()
            if sample is None:
                break
            # Raw pointers, not user_header()/payload(): each of those builds a ctypes pointer
            # or a Slice per sample, which costs more than the copy.
            header = StepHeader.from_address(sample.user_header_ptr)
            count = header.count
            if count > sample.header.number_of_elements:
                raise ValueError(f"sample of step {header.step} claims {count} items")
            # One copy of the whole batch out of shared memory.
            array = (self.item * count)()
            ctypes.memmove(array, sample.payload_ptr, ctypes.sizeof(array))
            self.pending[header.step] = array
            if header.step == step:
                break  # what the caller waits for: later samples stay in the subscriber
        if self.pending:
            for old in [s for s in self.pending if s < step]:
                del self.pending[old]
        return self.pending.pop(step, None)


class Outlet:
    """Publishes one sample per step and wakes its readers."""

    def __init__(self, publisher, wakers, service: str = "", max_len=None):
        self.publisher = publisher
        self.wakers = wakers
        self.service = service
        self.max_len = max_len  # None: it grows

    def send(self, step: int, time_s: float, items) -> None:
        """Publishes `items`: a ctypes array of structures (copied straight into shared
        memory) or a list of them."""
        if isinstance(items, ctypes.Array):
            self.send_bytes(step, time_s, len(items), items, ctypes.sizeof(items))
        else:
            self.send_bytes(step, time_s, len(items), b"".join(map(bytes, items)))

    def send_bytes(self, step: int, time_s: float, count: int, data, size=None) -> None:
        """Publishes `count` items already laid out in `data` (bytes-like, e.g. packed with
        struct, or a ctypes array; `size` bytes of it, default len(data)): one copy into
        shared memory."""
        if self.max_len is not None and count > self.max_len:
            raise ValueError(
                f"the {self.service} sample of step {step} holds {count} items, more than the "
                f"{self.max_len} its outlet was opened for: open it with a larger max_len, "
                "or with grow=True"
            )
        sample = self.publisher.loan_slice_uninit(count)
        header = StepHeader.from_address(sample.user_header_ptr)
        header.step = step
        header.time_s = time_s
        header.count = count
        header.stamp_ns = time.monotonic_ns()  # CLOCK_MONOTONIC, as the Rust nodes
        if count:
            ctypes.memmove(sample.payload_ptr, data, len(data) if size is None else size)
        sample.assume_init().send()
        for w in self.wakers:
            w.notify()


def send_status(outlet, kind: int, node: str, step: int = 0) -> None:
    publisher, wakers = outlet
    msg = ControlMsg()
    msg.kind = kind
    msg.node = NODES[node]
    msg.step = step
    publisher.send_copy(msg)
    for w in wakers:
        w.notify()
