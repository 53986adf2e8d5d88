"""Write an attack injector for `platoon run --injector` in Python: one method per step.

Subclass `Injector` and pass a factory to `run`; everything else of docs/injector-contract.md
is done here (the same shape as the Rust SDK, crates/injector-sdk): the ports of the run named by
PLATOON_RUN_ID, READY, waiting on wake-ups (never busy polling), exactly one rx sample per step
with its `count` (even when empty), waking the controller, DONE, STOP/ABORT, and exiting when
`platoon run` is gone. An exception in your factory, `step` or `finish` stops the run, which
names the injector and its log (logs/injector.log, which holds the whole traceback).

    import platoon.injector as pi

    class DropTwo(pi.Injector):
        def step(self, step, rx):
            rx.extend(it for it in step.tx if it.packet.sender != 2)

    pi.run(lambda run: DropTwo())

`bridge/examples/dos_jammer.py` reproduces the built-in DoS channel byte for byte;
`bridge/examples/ghost.py` impersonates a vehicle with drifting, plausible states.
"""

import os

from . import plugin as _plugin
from . import wire as w
from .plugin import ConfigLayoutError, ConfigTable, Run, stop_received  # noqa: F401 (its API)


def send_failed(outlet, step: int, reason: str) -> None:
    """FAILED with a reason: the run stops and names the injector."""
    _plugin.send_failed(outlet, step, reason, "injector")


class Step:
    """What an injector sees at step k: `k`, `t`, `tx` (the broadcasts of step k, one
    LinkPacket per link), `states` (every vehicle, platoon by platoon, leader first) and
    `traffic` (the plant's background vehicles, a TrafficVehicle per vehicle: SUMO's `bg<b>` as
    item b, `p` NaN and `flags & ON_ROAD` clear when it is not on the road; empty when the run
    has none). Both are copied out of shared memory only when first read: an injector that
    never reads them does not pay for them within the hop."""

    __slots__ = ("k", "t", "tx", "_states", "_inlet", "_traffic", "_traffic_inlet")

    def __init__(self, k: int, t: float, tx, inlet, traffic_inlet=None):
        self.k, self.t, self.tx = k, t, tx
        self._states, self._inlet = None, inlet
        self._traffic, self._traffic_inlet = None, traffic_inlet

    @property
    def states(self) -> "ctypes.Array[w.VehicleState]":
        if self._states is None:
            self._states = self._inlet.take(self.k)
            if self._states is None:
                raise RuntimeError(f"the plant's states of step {self.k} are missing")
        return self._states

    @property
    def traffic(self):
        if self._traffic is None:
            if self._traffic_inlet is None:
                self._traffic = ()
            else:
                self._traffic = self._traffic_inlet.take(self.k)
                if self._traffic is None:
                    raise RuntimeError(
                        f"the plant's traffic sample of step {self.k} is missing (it is "
                        "published before the states of the step)"
                    )
        return self._traffic


class Injector:
    """An attack injector: decides, every step, what each receiver gets."""

    def step(self, step: Step, rx: list) -> None:
        """Append to `rx` (empty on entry) the LinkPackets the receivers get at step k:
        deliveries (kind DELIVERY: forward, alter, delay, replay or invent; drop by leaving
        out) and jammed notices (`jammed(receiver)`)."""
        raise NotImplementedError

    def finish(self) -> None:
        """Called once after the last step."""


class DeliveryLog:
    """A per-delivery log of what an injector did, to set a run's ground truth against
    (`detections.csv`'s `label`, docs/detection.md): `deliver(step, rx, item, action)` appends
    `item` to `rx` and writes `step,receiver,sender,seq,action` (vehicle indices within the
    platoon) to the CSV file `path`, whose header it writes first; `dropped(step, item)` writes
    an item left out (`drop`). The actions are yours to name; `pass`, `alter`, `forge`, `replay`
    and `delay` are the labels `genuine`, `altered`, `forged`, `replayed` (`delayed` to a
    receiver that never got the original) and `delayed`. Call `close()` in `finish`.

        log = pi.DeliveryLog(run, "injector.csv")
        log.deliver(step, rx, item, "pass")
    """

    def __init__(self, run: Run, path: str):
        self.run = run
        self.file = open(path, "w")
        self.file.write("step,receiver,sender,seq,action\n")

    def _write(self, step: Step, item: w.LinkPacket, action: str) -> None:
        local, p = self.run.local, item.packet
        self.file.write(f"{step.k},{local(item.receiver)},{local(p.sender)},{p.seq},{action}\n")

    def deliver(self, step: Step, rx: list, item: w.LinkPacket, action: str) -> None:
        """Delivers `item` (appends it to `rx`) and logs it as `action`."""
        rx.append(item)
        self._write(step, item, action)

    def dropped(self, step: Step, item: w.LinkPacket) -> None:
        """Logs `item` as dropped (not delivered)."""
        self._write(step, item, "drop")

    def close(self) -> None:
        self.file.close()


def jammed(receiver: int) -> w.LinkPacket:
    """A jammed notice for `receiver` (its broadcast of this step did not get through)."""
    return w.LinkPacket(receiver=receiver, kind=w.LinkPacket.JAMMED)


def load_run() -> Run:
    """The run that started this process, from PLATOON_RUN_ID, PLATOON_CONFIG and
    PLATOON_RUN_FACTS (paths)."""
    return _plugin.load_run("--injector")


def run(make) -> int:
    """Runs the injector `make(run)` returns until the run ends; returns the exit code."""
    w.check_contract_version()  # before anything that depends on the run's formats
    info = load_run()
    vehicles = info.vehicles_per_platoon * info.platoons
    node = w.Endpoint("injector", info.run_id)
    states_in = node.inlet("states", w.VehicleState)
    # Only runs with background traffic (SUMO's) have it.
    traffic_in = (
        node.inlet("traffic", w.TrafficVehicle) if node.has_service("traffic") else None
    )
    # `--injector-mode after`: read what survived the built-in channel (deliveries and jammed
    # notices) instead of the broadcasts.
    tx_in = node.inlet(os.environ.get("PLATOON_INJECTOR_INPUT", "tx"), w.LinkPacket)
    rx_out = node.outlet("rx", w.LinkPacket, 4 * vehicles)
    control = node.control_inlet()
    status = node.status_outlet()  # keep it: a dropped publisher takes its samples with it
    try:
        injector = make(info)
    except Exception as e:  # noqa: BLE001: any failure of user code stops the run
        return _plugin.report_failure(node, control, status, "injector", 0, e)
    w.send_status(status, w.ControlMsg.READY, "injector")

    # Only tx[k] wakes the injector; states[k] was published before it (the controller reads
    # it first), so it is already waiting when tx[k] arrives, and is read only on demand.
    k = 0
    while True:
        tx = tx_in.take(k)
        if tx is None:
            # Nothing to do: the only time to look at the control channel (STOP/ABORT).
            if stop_received(control):
                return 0
            node.wait()
            continue
        step = Step(k, k * info.dt, tx, states_in, traffic_in)
        rx = []
        try:
            injector.step(step, rx)
        except Exception as e:  # noqa: BLE001: any failure of user code stops the run
            return _plugin.report_failure(node, control, status, "injector", k, e)
        rx_out.send(k, step.t, rx)
        if step._states is None:
            states_in.take(k)  # drained after the hop, off its path
        if step._traffic is None and traffic_in is not None:
            traffic_in.take(k)
        if k == info.steps:
            try:
                injector.finish()
            except Exception as e:  # noqa: BLE001: any failure of user code stops the run
                return _plugin.report_failure(node, control, status, "injector", k, e)
            w.send_status(status, w.ControlMsg.DONE, "injector", k)
            while not stop_received(control):
                node.wait()
            return 0
        k += 1
