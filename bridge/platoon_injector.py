"""Write an attack injector for `platoon run --injector` in Python: one method per step.

Subclass `Injector` and pass a factory to `run`; everything else of docs/injector-contract.md
is done here (the same shape as the Rust SDK, crates/injector): the ports of the run named by
PLATOON_RUN_ID, READY, waiting on wake-ups (never busy polling), exactly one rx sample per step
with its `count` (even when empty), waking the controller, DONE, STOP/ABORT, and exiting when
`platoon run` is gone. An exception in `step` stops the run, which names the injector.

    import platoon_injector as pi

    class DropTwo(pi.Injector):
        def step(self, step, rx):
            rx.extend(it for it in step.tx if it.packet.sender != 2)

    pi.run(lambda run: DropTwo())

`bridge/examples/dos_jammer.py` reproduces the built-in DoS channel byte for byte;
`bridge/examples/ghost.py` impersonates a vehicle with drifting, plausible states.
"""

import os
import sys
import tomllib
from dataclasses import dataclass

import platoon_wire as w


@dataclass
class Run:
    """What an injector knows about its run."""

    run_id: str
    config: dict  # the resolved scenario config (PLATOON_CONFIG), parsed
    dt: float
    steps: int  # the last step is `steps`
    vehicles_per_platoon: int
    platoons: int

    def vehicles(self):
        """Every vehicle's wire id (vehicle i of platoon j is j * (N + 1) + i)."""
        return range(self.vehicles_per_platoon * self.platoons)

    def local(self, vehicle_id: int) -> int:
        """The vehicle's index within its platoon (0 = leader)."""
        return vehicle_id % self.vehicles_per_platoon


class Step:
    """What an injector sees at step k: `k`, `t`, `tx` (the broadcasts of step k, one
    LinkPacket per link) and `states` (every vehicle, platoon by platoon, leader first), which
    is copied out of shared memory only when first read: an injector that never reads it does
    not pay for it within the hop."""

    __slots__ = ("k", "t", "tx", "_states", "_inlet")

    def __init__(self, k: int, t: float, tx, inlet):
        self.k, self.t, self.tx = k, t, tx
        self._states, self._inlet = None, inlet

    @property
    def states(self) -> "ctypes.Array[w.VehicleState]":
        if self._states is None:
            self._states = self._inlet.take(self.k)
            if self._states is None:
                raise RuntimeError(f"the plant's states of step {self.k} are missing")
        return self._states


class Injector:
    """An attack injector: decides, every step, what each receiver gets."""

    def step(self, step: Step, rx: list) -> None:
        """Append to `rx` (empty on entry) the LinkPackets the receivers get at step k:
        deliveries (kind DELIVERY: forward, alter, delay, replay or invent; drop by leaving
        out) and jammed notices (`jammed(receiver)`)."""
        raise NotImplementedError

    def finish(self) -> None:
        """Called once after the last step."""


def jammed(receiver: int) -> w.LinkPacket:
    """A jammed notice for `receiver` (its broadcast of this step did not get through)."""
    return w.LinkPacket(receiver=receiver, kind=w.LinkPacket.JAMMED)


def load_run() -> Run:
    """The run that started this process, from PLATOON_RUN_ID and PLATOON_CONFIG (a path)."""
    missing = [v for v in ("PLATOON_RUN_ID", "PLATOON_CONFIG") if v not in os.environ]
    if missing:
        raise SystemExit(
            f"{missing[0]} is not set: run this program as "
            '`platoon run CONFIG --injector "python PROGRAM ARGS"`'
        )
    with open(os.environ["PLATOON_CONFIG"], "rb") as f:
        config = tomllib.load(f)
    dt = config["simulation"]["dt_s"]
    return Run(
        run_id=os.environ["PLATOON_RUN_ID"],
        config=config,
        dt=dt,
        steps=round(config["simulation"]["duration_s"] / dt),
        vehicles_per_platoon=config["platoon"]["followers"] + 1,
        platoons=config.get("fleet", {}).get("platoons", 1),
    )


def run(make) -> int:
    """Runs the injector `make(run)` returns until the run ends; returns the exit code."""
    w.check_contract_version()  # before anything that depends on the run's formats
    info = load_run()
    injector = make(info)
    vehicles = info.vehicles_per_platoon * info.platoons
    node = w.Endpoint("injector", info.run_id)
    states_in = node.inlet("states", w.VehicleState)
    # `--injector-mode after`: read what survived the built-in channel (deliveries and jammed
    # notices) instead of the broadcasts.
    tx_in = node.inlet(os.environ.get("PLATOON_INJECTOR_INPUT", "tx"), w.LinkPacket)
    rx_out = node.outlet("rx", w.LinkPacket, 4 * vehicles)
    control = node.control_inlet()
    status = node.status_outlet()  # keep it: a dropped publisher takes its samples with it
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
        step = Step(k, k * info.dt, tx, states_in)
        rx = []
        try:
            injector.step(step, rx)
        except Exception as e:  # noqa: BLE001: any failure of user code stops the run
            print(f"injector: step {k}: {type(e).__name__}: {e}", file=sys.stderr)
            send_failed(status, k, f"{type(e).__name__}: {e}")
            return 1
        rx_out.send(k, step.t, rx)
        if step._states is None:
            states_in.take(k)  # drained after the hop, off its path
        if k == info.steps:
            injector.finish()
            w.send_status(status, w.ControlMsg.DONE, "injector", k)
            while not stop_received(control):
                node.wait()
            return 0
        k += 1


def stop_received(control) -> bool:
    """Drains the control channel; True once STOP or ABORT is among its messages."""
    stop = False
    msg = control.receive()
    while msg is not None:
        stop |= msg.payload().contents.kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT)
        msg = control.receive()
    return stop


def send_failed(outlet, step: int, reason: str) -> None:
    """FAILED with a reason: the run stops and names the injector."""
    publisher, wakers = outlet
    msg = w.ControlMsg()
    msg.kind = w.ControlMsg.FAILED
    msg.node = w.NODES["injector"]
    msg.step = step
    data = reason.encode()[: len(msg.reason)]
    msg.reason[: len(data)] = data
    publisher.send_copy(msg)
    for waker in wakers:
        waker.notify()
