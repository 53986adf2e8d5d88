"""platoon: resilient event-triggered control of vehicle platoons under DoS attacks, from Python.

The Rust core (runs, campaigns, LMI design) as a package; results as Arrow tables and dicts.

    import platoon
    cfg = platoon.scenario("paper")          # the embedded paper scenario, a dict to edit
    cfg["trigger"]["rule"] = "static"
    run = platoon.run(cfg)                   # in process; transport="iceoryx2", plant="sumo" too
    run.summary["safety"]["class"]
    df = run.trajectories.to_pandas()        # or .to_polars(), or .arrow (a pyarrow.Table)
    cells = platoon.campaign("campaigns/dos-timing.toml", jobs=2)   # or dask=Client(...)
    cert = platoon.design.check_gain(cfg)

Submodules: `platoon.design` (LMI checks), `platoon.injector` and `platoon.controller` (the
SDKs for attack injectors and controllers that a co-simulated run starts as processes, see
docs/injector-contract.md and docs/controller-contract.md), `platoon.wire` (the shared-memory
payloads). The SDKs need no compiled core: they also run from the bridge's venv of a checkout.

Errors: `platoon.ConfigError` (a ValueError) for an invalid config or campaign, with `file`,
`line`, `key` and `message` attributes; `platoon.PlatoonError` (a RuntimeError) for anything
else that failed, with the message the `platoon` command would print; two of its subclasses
say more: `platoon.NodeError`, a co-simulated run's process that failed (`node`, `step`, `log`,
`message`, `run_dir`), and `platoon.OutputError`, the files of a run or a campaign (`path`).
A design check raises ConfigError for its config and PlatoonError for options it cannot use
or a solver that failed. Ctrl-C
(KeyboardInterrupt) stops a run or a campaign cleanly, as in the command, then is raised.
"""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import sys
import sysconfig

__version__ = "0.1.0"

# The compiled core may be in another copy of this package further down sys.path: the installed
# one, when a script or test puts the bridge's source tree (this folder's parent) first. Its
# submodules are looked for in every copy.
__path__ = __import__("pkgutil").extend_path(__path__, __name__)

__all__ = [
    "Campaign",
    "ConfigError",
    "NodeError",
    "OutputError",
    "PlatoonError",
    "Run",
    "Table",
    "campaign",
    "design",
    "run",
    "scenario",
    "scenarios",
]

_TABLES = ("trajectories", "events", "wire", "channel", "detections")


def _fspath(path):
    """A path argument as the core takes it: a string, or None."""
    return None if path is None else os.fspath(path)


def _native():
    """The compiled core, or an ImportError that says how to get it."""
    try:
        from . import _core as core
    except ImportError as e:
        raise ImportError(
            "platoon's compiled core is not installed (this is the source tree's pure-Python "
            "half, whose SDKs need no core): install the package with `pip install ./bridge` "
            f"from a checkout ({e})"
        ) from e
    _program()
    return core


def _program():
    """Points $PLATOON_PROGRAM at this environment's `platoon` script, which the core runs as
    the processes of a co-simulation (here the running program is Python, not `platoon`): the
    scripts directory of this interpreter's install scheme, the user scheme's (pip --user),
    then the PATH's `platoon`. Set it yourself to run another `platoon` binary."""
    if os.environ.get("PLATOON_PROGRAM"):
        return
    dirs = [sysconfig.get_path("scripts")]
    try:
        dirs.append(sysconfig.get_path("scripts", f"{os.name}_user"))
    except KeyError:
        pass
    for where in [*dirs, None]:
        script = shutil.which("platoon", path=where)
        if script:
            os.environ["PLATOON_PROGRAM"] = script
            return


def __getattr__(name):
    # The core's exception classes, loaded with the core (the SDKs import this package too).
    if name in ("ConfigError", "NodeError", "OutputError", "PlatoonError"):
        return getattr(_native(), name)
    raise AttributeError(f"module 'platoon' has no attribute {name!r}")


def scenarios() -> list[str]:
    """The names of the embedded scenarios (`paper`, `table1`, `degradation`)."""
    return list(_native().scenario_names())


class Scenario(dict):
    """A scenario as a dict (what `scenario` returns): it remembers the resolved config it was
    made from and the file it was read from, so that `run` can drop the parameters of a rule
    you switched and resolve the file's relative paths (`sumo.net`, ...) against its folder."""

    _origin = None
    _source = None


def scenario(name: str | os.PathLike = "paper") -> Scenario:
    """A scenario as a dict to edit and pass to `run`: an embedded one by name (see
    `scenarios()`) or a TOML config file's path, resolved (every default written out, the keys
    of docs/config-reference.md). Switching a table's rule or kind in it (`trigger.rule`,
    `attack.kind`, ...) drops the old one's parameters that you left as they were, as a
    campaign axis does; a None value means the key's default."""
    text = _native().scenario(os.fspath(name))
    s = Scenario(json.loads(text))
    s._origin = text
    if os.fspath(name) not in _native().scenario_names():
        s._source = os.path.abspath(os.fspath(name))
    return s


def _config_arg(config):
    """The core's config arguments: a dict as JSON (with where a Scenario came from), a file's
    path, or an embedded scenario's name (names first, as `scenario` takes them)."""
    if isinstance(config, dict):
        return {
            "config": json.dumps(config, allow_nan=False),  # the core leaves None values out
            "is_path": False,
            "origin": getattr(config, "_origin", None),
            "source": getattr(config, "_source", None),
        }
    if isinstance(config, (str, os.PathLike)):
        text = os.fspath(config)
        if text in _native().scenario_names():
            return _config_arg(scenario(text))
        if os.path.isfile(text):
            return {"config": text, "is_path": True}
        raise FileNotFoundError(
            f"config {text!r}: no such file, and not an embedded scenario ({', '.join(scenarios())})"
        )
    raise TypeError(
        f"config: a dict (platoon.scenario(...)), a TOML file's path or an embedded scenario's "
        f"name, not {type(config).__name__}"
    )


class Table:
    """A per-step table of a run (trajectories, events, wire, channel, detections) or a
    campaign's cells: a `pyarrow.Table` (`.arrow`), handed over from Rust without copying.

    `to_pandas()`, `to_polars()` convert it; anything that reads the Arrow PyCapsule stream
    interface (pyarrow.table, polars.DataFrame, duckdb) reads it directly. The columns are the
    CSV file's of the same name (docs/outputs.md)."""

    def __init__(self, name, arrow):
        self.name = name
        self.arrow = arrow

    def to_pandas(self, **kwargs):
        """A pandas DataFrame (pyarrow.Table.to_pandas; needs pandas)."""
        return self.arrow.to_pandas(**kwargs)

    def to_polars(self):
        """A polars DataFrame (needs polars)."""
        try:
            import polars
        except ImportError as e:
            raise ImportError(f"Table.to_polars needs polars: pip install polars ({e})") from e
        return polars.from_arrow(self.arrow)

    def to_pylist(self):
        """The rows as dicts."""
        return self.arrow.to_pylist()

    @property
    def columns(self):
        """The column names."""
        return list(self.arrow.column_names)

    def column(self, name):
        """One column as a Python list."""
        return self.arrow.column(name).to_pylist()

    def __arrow_c_stream__(self, requested_schema=None):
        return self.arrow.__arrow_c_stream__(requested_schema)

    def __len__(self):
        return self.arrow.num_rows

    def __repr__(self):
        return f"<platoon.Table {self.name}: {self.arrow.num_rows} rows x {self.arrow.num_columns} columns>"


class Run:
    """A finished run: `summary` (the dict of summary.json), its tables by name in `tables`
    and as attributes (`trajectories`, `events`, `wire`, `channel` in process, `detections` with
    [detection]), and `dir`, the run directory when one was asked for (else None)."""

    def __init__(self, summary, tables, dir):
        self.summary = summary
        self.tables = tables
        self.dir = dir

    def __getattr__(self, name):
        if name in _TABLES:
            try:
                return self.tables[name]
            except KeyError:
                raise AttributeError(
                    f"this run has no {name} table ([output] files left it out, or the run "
                    f"does not record it: {', '.join(self.tables) or 'none'} here)"
                ) from None
        raise AttributeError(f"'Run' object has no attribute {name!r}")

    def __repr__(self):
        s = self.summary
        return (
            f"<platoon.Run {s.get('steps')} steps, complete={s.get('complete')}, "
            f"safety={s.get('safety', {}).get('class')}, tables={list(self.tables)}>"
        )


def run(
    config: dict | str | os.PathLike = "paper",
    *,
    transport: str = "inproc",
    plant: str | None = None,
    out: str | os.PathLike | None = None,
    force: bool = False,
    plots: bool = False,
    injector: str | None = None,
    injector_after: bool = False,
    controller: str | None = None,
    step_timeout_s: float = 1.0,
) -> Run:
    """Runs one scenario and returns a `Run`.

    config: a dict (see `scenario`), a TOML file's path, or an embedded scenario's name.
    transport: "inproc" (one process, the default) or "iceoryx2" (the co-simulation's
        processes over shared memory: controller, attack injector, plant).
    plant: "native" or "sumo" (SUMO needs transport="iceoryx2"); None: the config's.
    out: a run directory to write, as `platoon run --out` writes it (None: in process nothing
        is written and the tables come from memory; otherwise a temporary directory is used
        and removed, or kept and named if the run fails). force: replace `out` if it exists.
        plots: draw the PNG figures there (both need `out`).
    injector / controller: a shell command starting an external attack injector or controller
        (iceoryx2 only; see platoon.injector, platoon.controller); injector_after runs the
        config's attacks first, then the injector.
    step_timeout_s: how long the run waits for one process's sample of a step (iceoryx2).

    Raises ConfigError for an invalid config (file, line, key), NodeError (a PlatoonError)
    when a process of a co-simulated run fails (its node, step, log and message), OutputError
    (a PlatoonError) when the run's files cannot be written (path), PlatoonError when the run
    fails otherwise, ValueError for options that do not go
    together, KeyboardInterrupt after stopping it (a second one returns at once, leaving the
    run to stop at its next step)."""
    summary, tables, directory = _native().run(
        _config_arg(config),
        {
            "transport": transport,
            "plant": plant,
            "out": _fspath(out),
            "force": force,
            "plots": plots,
            "injector": injector,
            "injector_after": injector_after,
            "controller": controller,
            "step_timeout_s": float(step_timeout_s),
        },
    )
    return Run(
        json.loads(summary),
        {name: Table(name, t) for name, t in tables},
        None if directory is None else pathlib.Path(directory),
    )


class Campaign:
    """A finished campaign: `report` (campaign.json's dict), `cells` (cells.csv as a Table: one
    row per cell, its parameters, status and metrics) and `dir`, the campaign directory."""

    def __init__(self, report, cells, dir):
        self.report = report
        self.cells = cells
        self.dir = dir

    def __repr__(self):
        r = self.report
        return f"<platoon.Campaign {r.get('name')}: {len(self.cells)} cells, {r.get('ok')} ok, {r.get('failed')} failed, in {self.dir}>"


def campaign(
    spec: str | os.PathLike,
    *,
    out: str | os.PathLike | None = None,
    jobs: int | None = None,
    dask=None,
    force: bool = False,
    keep_runs: bool = False,
    plots: bool = False,
    samples: int | None = None,
) -> Campaign:
    """Runs a campaign file (campaigns/*.toml) as `platoon campaign` does; returns a Campaign.

    out: the campaign directory (default runs/<name>); an unfinished one is resumed, a
        finished one is an error unless force=True. jobs: cells at once on the local pool
        (default: the cores). dask: a distributed.Client or a scheduler's address: the cells
        run on its workers, in the workers' processes, batched (they need this package);
        jobs does not go with it. A KeyboardInterrupt stops it cleanly (the cells done are
        kept; call again to resume), then is raised.
    keep_runs: keep every cell's full outputs. samples: override monte_carlo.samples.
    cells.csv is byte for byte the same whichever executor ran it. A cell that fails is a row
    with its status and error, not an exception.

    Raises ConfigError for an invalid campaign file or base (file, line, key), OutputError (a
    PlatoonError) when the campaign directory or its records cannot be written (path), e.g.
    `out` is a directory that is not a campaign's, PlatoonError when the executor fails (the
    cells done are kept: call again to resume) or anything else does."""
    address = None
    if dask is not None:
        address = dask if isinstance(dask, str) else dask.scheduler.address
    report, cells, directory = _native().campaign(
        os.fspath(spec),
        {
            "out": _fspath(out),
            "jobs": jobs,
            "dask": address,
            "force": force,
            "keep_runs": keep_runs,
            "plots": plots,
            "samples": samples,
        },
    )
    return Campaign(json.loads(report), Table("cells", cells), pathlib.Path(directory))


from . import design  # noqa: E402 (after what it imports from this module)
