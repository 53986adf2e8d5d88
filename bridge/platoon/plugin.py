"""What the Python SDKs of plug-ins share (platoon.injector, platoon.controller): the run
that started the process (PLATOON_RUN_ID, PLATOON_CONFIG, and its resolved facts from
PLATOON_RUN_FACTS: steps, fleet, V2V graph, detectors), and the status
messages every node sends (READY/DONE/FAILED) and the control messages it reads (STOP/ABORT).

The run's config (`Run.config`) is read strictly: every table is a `ConfigTable`, which knows
the keys the config's layout has (`config_layout.json`, generated from docs/config.schema.json)
and raises `ConfigLayoutError`, naming the key, for a key no layout has (an old
`[control.path_cacc]` table, a misspelt key, a key that moved) instead of letting `.get()`
return the plug-in's default. A key the layout has but the config leaves out (an optional
table, a key of another law) reads as absent, as from a dict.
"""

import json
import os
import sys
import time
import traceback
from dataclasses import dataclass, field
from functools import lru_cache

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

from . import wire as w


# Where the contract docs keep what changed in the config's layout, the payloads and the SDKs.
MIGRATIONS_DOC = "docs/injector-contract.md#config-and-sdk-changes"

LAYOUT_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "config_layout.json")


class ConfigLayoutError(Exception):
    """A config key no layout of the run's config has: read by a plug-in written for another
    layout, or found in a config this SDK does not know. Not a KeyError, so that code falling
    back to a default on KeyError does not swallow it."""


@lru_cache(maxsize=None)
def _tables() -> dict:
    with open(LAYOUT_FILE, encoding="utf-8") as f:
        return json.load(f)["tables"]


def _display(path: str) -> str:
    """A layout path as a TOML table name: `channel.attacks[]` -> `[[channel.attacks]]`."""
    if not path:
        return "the config's top level"
    if path.endswith("[]"):
        return f"[[{path[:-2]}]]"
    return f"[{path}]"


class ConfigTable(dict):
    """One table of the run's config, parsed: a dict whose reads (`t[key]`, `t.get(key)`,
    `key in t`) raise ConfigLayoutError, naming the key, for a key the table's layout does not
    have, and say where it went if it moved. Nested tables and arrays of tables are
    ConfigTables too."""

    def __init__(self, data=(), path: str = "", where: str = ""):
        super().__init__()
        self._path = path  # the table's path in the layout (`channel.attacks[]`)
        self._where = where  # and in this config (`channel.attacks[1]`)
        layout = _tables().get(path)
        if layout is None:
            raise ConfigLayoutError(
                f"{_display(path)} is a table this SDK does not know: the run's config has a "
                f"layout this bridge does not (take the bridge of the platoon that runs it; "
                f"what changed: {MIGRATIONS_DOC})"
            )
        self._layout = layout
        for key, value in dict(data).items():
            if key not in self._known_keys():
                raise ConfigLayoutError(
                    f"the run's config has {self._name(key)}, which this SDK's layout of "
                    f"{_display(path)} does not: the bridge and the platoon that runs it are of "
                    f"different versions (what changed: {MIGRATIONS_DOC})"
                )
            dict.__setitem__(self, key, self._wrap(key, value))

    def _known_keys(self):
        keys = self._layout["keys"]
        return _Anything() if keys is None else keys

    def _name(self, key) -> str:
        return f"{self._where}.{key}" if self._where else str(key)

    def _child(self, key) -> str:
        if self._layout["keys"] is None:
            return f"{self._path}.*"
        return f"{self._path}.{key}".lstrip(".")

    def _wrap(self, key, value):
        child, where = self._child(key), self._name(key)
        if isinstance(value, dict):
            return ConfigTable(value, child, where)
        if isinstance(value, list) and any(isinstance(v, dict) for v in value):
            return [
                ConfigTable(v, child + "[]", f"{where}[{i}]") if isinstance(v, dict) else v
                for i, v in enumerate(value)
            ]
        return value

    def _check(self, key) -> None:
        name, table = self._name(key), _display(self._where)
        moved = self._layout.get("moved", {}).get(key)
        if moved and not dict.__contains__(self, key):
            # A key the config still accepts under its older name, but never writes so.
            raise ConfigLayoutError(
                f"{name} is no key of the run's config: {moved} ({MIGRATIONS_DOC})"
            )
        if key in self._known_keys():
            return
        tag = self._layout.get("tag")
        if tag and key in self._layout.get("variants", ()):
            raise ConfigLayoutError(
                f"[{name}] is no table of the run's config: the keys of {tag} = {key!r} are keys "
                f"of {table} itself, beside {tag} ([{name}] is an older layout; "
                f"{MIGRATIONS_DOC})"
            )
        keys = ", ".join(sorted(self._known_keys()))
        raise ConfigLayoutError(
            f"{name} is no key of {table} in any layout of the run's config (its keys: {keys}): "
            f"a default for it would never be replaced by the run's value ({MIGRATIONS_DOC})"
        )

    def __getitem__(self, key):
        self._check(key)
        return dict.__getitem__(self, key)

    def get(self, key, default=None):
        self._check(key)
        return dict.get(self, key, default)

    def __contains__(self, key) -> bool:
        self._check(key)
        return dict.__contains__(self, key)

    def setdefault(self, key, default=None):
        self._check(key)
        return dict.setdefault(self, key, default)

    def pop(self, key, *default):
        self._check(key)
        return dict.pop(self, key, *default)


class _Anything:
    """The keys of a table of names (`[vehicle_classes.<name>]`): any."""

    def __contains__(self, key) -> bool:
        return True

    def __iter__(self):
        return iter(("<any name>",))


def config_layout(schema: dict) -> dict:
    """The layout of every table of a config from its JSON Schema (docs/config.schema.json):
    per table path (`control`, `channel.attacks[]`, `vehicle_classes.*`; "" the top level) the
    keys any of its variants has (None: any name), its tag and variants when it is a tagged
    table (`law`: `paper`, `acc`, ...), and what a deprecated key moved to. What
    `config_layout.json` holds."""
    definitions = schema.get("definitions", {})

    def objects(node, seen=()):
        """The object schemas `node` may be (through $ref, allOf, oneOf, anyOf, arrays)."""
        if "$ref" in node:
            name = node["$ref"].rsplit("/", 1)[-1]
            if name in seen:
                return [], []
            return objects(definitions[name], seen + (name,))
        tables, arrays = [], []
        for key in ("allOf", "oneOf", "anyOf"):
            for sub in node.get(key, ()):
                t, a = objects(sub, seen)
                tables += t
                arrays += a
        if "items" in node and isinstance(node["items"], dict):
            t, a = objects(node["items"], seen)
            arrays += t + a
        own = node.get("properties")
        if own is not None and tables:
            # Keys beside a oneOf belong to every variant.
            tables = [dict(t, properties={**own, **t.get("properties", {})}) for t in tables]
        elif own is not None or isinstance(node.get("additionalProperties"), dict):
            tables.append(node)
        return tables, arrays

    tables = {}

    def add(path, alternatives):
        entry = tables.setdefault(path, {"keys": [], "children": {}})
        for alt in alternatives:
            props = alt.get("properties")
            if props is None:
                entry["keys"] = None
                entry["children"].setdefault(f"{path}.*", []).append(alt["additionalProperties"])
                continue
            if entry["keys"] is not None:
                entry["keys"] = sorted(set(entry["keys"]) | set(props))
            for key, value in props.items():
                if value.get("deprecated"):
                    text = value.get("description", "").split(";")[0].strip()
                    entry.setdefault("moved", {})[key] = text
                entry["children"].setdefault(key, []).append(value)
        consts = [
            {k: v["const"] for k, v in alt.get("properties", {}).items() if "const" in v}
            for alt in alternatives
        ]
        shared = set.intersection(*(set(c) for c in consts)) if consts else set()
        if len(alternatives) > 1 and len(shared) == 1:
            tag = shared.pop()
            entry["tag"] = tag
            entry["variants"] = sorted({c[tag] for c in consts})

    def walk(path, alternatives):
        add(path, alternatives)
        entry = tables[path]
        children, entry["children"] = entry["children"], {}
        for key, nodes in children.items():
            sub_tables, sub_arrays = [], []
            for node in nodes:
                t, a = objects(node)
                sub_tables += t
                sub_arrays += a
            base = key if key.endswith(".*") else f"{path}.{key}".lstrip(".")
            if sub_tables:
                walk(base, sub_tables)
            if sub_arrays:
                walk(base + "[]", sub_arrays)

    walk("", objects(schema)[0])
    for entry in tables.values():
        del entry["children"]
    return {"tables": dict(sorted(tables.items()))}


def strict_config(config: dict) -> ConfigTable:
    """`config` (a resolved config, parsed) as ConfigTables: see ConfigTable."""
    return ConfigTable(config)


@dataclass
class Run:
    """What a plug-in knows about its run."""

    run_id: str
    # The resolved scenario config (PLATOON_CONFIG), parsed: a ConfigTable, which refuses keys
    # no layout of the config has (ConfigLayoutError) rather than let a default stand in.
    config: dict
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
        config = strict_config(tomllib.load(f))
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


if __name__ == "__main__":
    # From the repository's root:
    #   bridge/.venv/bin/python -m platoon.plugin config-layout docs/config.schema.json \
    #       > bridge/platoon/config_layout.json
    if len(sys.argv) != 3 or sys.argv[1] != "config-layout":
        raise SystemExit("usage: python -m platoon.plugin config-layout SCHEMA_JSON")
    with open(sys.argv[2], encoding="utf-8") as f:
        print(json.dumps(config_layout(json.load(f)), indent=1, sort_keys=True))
