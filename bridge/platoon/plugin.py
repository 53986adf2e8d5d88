"""What the Python SDKs of plug-ins share (platoon.injector, platoon.controller): the run
that started the process (PLATOON_RUN_ID, PLATOON_CONFIG, and its resolved facts from
PLATOON_RUN_FACTS: steps, fleet, V2V graph, detectors), and the status
messages every node sends (READY/DONE/FAILED) and the control messages it reads (STOP/ABORT).
"""

import json
import os
import sys
import time
import traceback
from dataclasses import dataclass, field

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

from . import wire as w


@dataclass
class Run:
    """What a plug-in knows about its run."""

    run_id: str
    config: dict  # the resolved scenario config (PLATOON_CONFIG), parsed
    dt: float
    steps: int  # the last step is `steps`
    vehicles_per_platoon: int
    platoons: int
    topology: "Topology | None" = field(default=None, repr=False)
    # The links the channel carries (the facts' `hearing`): the topology's, plus every member
    # ahead when the platoon splits behind a car that cut in. Controllers publish one item per
    # link of this graph.
    hearing: "Topology | None" = field(default=None, repr=False)
    # The detectors the run measures, in the order of every inspection's verdicts (the facts'
    # `detectors`).
    detectors: list = field(default_factory=list)

    def vehicles(self):
        """Every vehicle's wire id (vehicle i of platoon j is j * (N + 1) + i)."""
        return range(self.vehicles_per_platoon * self.platoons)

    def local(self, vehicle_id: int) -> int:
        """The vehicle's index within its platoon (0 = leader)."""
        return vehicle_id % self.vehicles_per_platoon

    def global_id(self, platoon: int, vehicle: int) -> int:
        """The wire id of vehicle `vehicle` (0 = leader) of platoon `platoon`."""
        return platoon * self.vehicles_per_platoon + vehicle


class Topology:
    """The V2V graph of one platoon as crates/topology computes it (the run's facts): whom each
    follower hears (`in_neighbours[i]`, leader first, then followers in order) and who hears
    each vehicle (`out_neighbours[v]`, v = 0 the leader), in the Rust order. `adjacency[i][j]`
    is 1 when follower i hears follower j (0-based), `pinning[i]` when follower i hears the
    leader, and `leader_hears` lists the followers the leader hears (1-based; every follower on
    the channel of a platoon that negotiates maneuvers)."""

    def __init__(self, adjacency, pinning, leader_hears=()):
        n = len(pinning)
        self.followers = n
        self.in_neighbours = [[] for _ in range(n + 1)]  # index 0 (the leader) stays empty
        self.out_neighbours = [[] for _ in range(n + 1)]
        for i in range(n):
            me = i + 1
            if pinning[i] == 1.0:
                self.in_neighbours[me].append(0)
                self.out_neighbours[0].append(me)
            for j in range(n):
                if adjacency[i][j] == 1.0:
                    self.in_neighbours[me].append(j + 1)
                    self.out_neighbours[j + 1].append(me)
        for f in leader_hears:
            self.in_neighbours[0].append(f)
            self.out_neighbours[f].append(0)


RUN_VARIABLES = ("PLATOON_RUN_ID", "PLATOON_CONFIG", "PLATOON_RUN_FACTS")


def load_run(option: str = "--injector") -> Run:
    """The run that started this process, from PLATOON_RUN_ID, PLATOON_CONFIG (a path) and
    PLATOON_RUN_FACTS (the path of the run's facts.json, which the orchestrator resolved from
    the config: steps, fleet, V2V graph, detectors); `option` is the `platoon run` option that
    starts this kind of plug-in, for the error."""
    missing = [v for v in RUN_VARIABLES if v not in os.environ]
    if missing:
        raise SystemExit(
            f"{missing[0]} is not set: run this program as "
            f'`platoon run CONFIG {option} "python PROGRAM ARGS"`'
        )
    with open(os.environ["PLATOON_CONFIG"], "rb") as f:
        config = tomllib.load(f)
    with open(os.environ["PLATOON_RUN_FACTS"], encoding="utf-8") as f:
        facts = json.load(f)
    # Every platoon of a fleet is a replica of the scenario: one graph serves them all.
    graph = facts["topologies"][0]
    hearing = facts["hearing"][0]
    return Run(
        run_id=os.environ["PLATOON_RUN_ID"],
        config=config,
        dt=facts["dt_s"],
        steps=facts["last_step"],
        vehicles_per_platoon=facts["followers"] + 1,
        platoons=facts["platoons"],
        topology=Topology(graph["adjacency"], graph["pinning"]),
        hearing=Topology(
            hearing["adjacency"], hearing["pinning"], hearing.get("leader_hears", ())
        ),
        detectors=list(facts["detectors"]),
    )


def stop_received(control) -> bool:
    """Drains the control channel; True once STOP or ABORT is among its messages."""
    stop = False
    msg = control.receive()
    while msg is not None:
        stop |= msg.payload().contents.kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT)
        msg = control.receive()
    return stop


def send_failed(outlet, step: int, reason: str, node: str = "injector") -> None:
    """FAILED with a reason: the run stops and names `node`."""
    msg = w.ControlMsg()
    msg.kind = w.ControlMsg.FAILED
    msg.node = w.NODES[node]
    msg.step = step
    # Cut on a character boundary, as the Rust side does.
    data = reason.encode()[: len(msg.reason)].decode("utf-8", "ignore").encode()
    msg.reason[: len(data)] = data
    _send(outlet, msg)


# How long a node that reported FAILED waits for the orchestrator's ABORT before it exits anyway.
FAILED_WAIT_S = 10.0


def fail(endpoint, control, outlet, node: str, step: int, reason: str) -> int:
    """FAILED with `reason`, then wait for the orchestrator's ABORT (at most FAILED_WAIT_S, or
    until it is gone) before exiting: the report lives in this process's status publisher, and
    a process that exits at once may take it with it, leaving the run to name its exit instead.
    Returns the process's exit code, 1."""
    send_failed(outlet, step, reason, node)
    deadline = time.monotonic() + FAILED_WAIT_S
    try:
        while time.monotonic() < deadline and not stop_received(control):
            endpoint.wait()
    except SystemExit:  # the orchestrator is gone: nobody is left to read the report
        pass
    return 1


def report_failure(
    endpoint, control, outlet, node: str, step: int, error: BaseException
) -> int:
    """An exception of the user's code stops the run: its whole traceback goes to stderr (the
    run's logs/<node>.log), its last line to the orchestrator as the FAILED reason, which names
    the log (`fail`). Returns the process's exit code, 1."""
    print(f"{node}: step {step}: the run stops on this exception:", file=sys.stderr)
    traceback.print_exception(type(error), error, error.__traceback__, file=sys.stderr)
    sys.stderr.flush()
    return fail(endpoint, control, outlet, node, step, f"{type(error).__name__}: {error}")


def send_done(outlet, node: str, step: int, counts=()) -> None:
    """DONE after the last step, with up to six counts (a controller's refused packets, in the
    order of docs/controller-contract.md)."""
    msg = w.ControlMsg()
    msg.kind = w.ControlMsg.DONE
    msg.node = w.NODES[node]
    msg.step = step
    for i, c in enumerate(counts):
        msg.counts[i] = c
    _send(outlet, msg)


def _send(outlet, msg) -> None:
    publisher, wakers = outlet
    publisher.send_copy(msg)
    for waker in wakers:
        waker.notify()
