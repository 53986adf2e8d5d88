"""Type stubs of platoon._core, the package's compiled Rust core (crates/python). Call it
through the functions of `platoon` (platoon/__init__.py), which document the arguments."""

from typing import List, Optional, Sequence, Tuple, TypedDict

import pyarrow

__version__: str
build_profile: str  # "dev" or "release"

class PlatoonError(RuntimeError):
    """A platoon operation failed; the message says what, and what to do."""

class ConfigError(ValueError):
    """An invalid config (a file or a dict) or campaign file."""

    file: str
    line: Optional[int]
    key: str
    message: str

class NodeError(PlatoonError):
    """A process of a co-simulated run (plant, controller, injector, a plug-in) failed."""

    node: str  # "plant", "controller", "injector" or "channel"
    step: Optional[int]  # the step the run was at, None when unknown
    log: Optional[str]  # its log (stdout and stderr), None when it wrote none
    message: str  # what went wrong, in a line
    run_dir: Optional[str]  # what the run recorded

class OutputError(PlatoonError):
    """The files of a run or a campaign could not be written or read."""

    path: Optional[str]  # the file or directory, None when unknown

def scenario_names() -> List[str]: ...
def scenario(name: str) -> str: ...
class ConfigArg(TypedDict, total=False):
    """Where a call's config comes from (platoon._config_arg builds it)."""

    config: str  # a dict as JSON, a file's path or an embedded scenario's name
    is_path: bool
    origin: Optional[str]
    source: Optional[str]

class RunArgs(TypedDict):
    """platoon.run's keyword arguments, every one."""

    transport: str
    plant: Optional[str]
    out: Optional[str]
    force: bool
    plots: bool
    injector: Optional[str]
    injector_after: bool
    controller: Optional[str]
    step_timeout_s: float

class CampaignArgs(TypedDict):
    """platoon.campaign's keyword arguments (dask: a scheduler's address)."""

    out: Optional[str]
    jobs: Optional[int]
    dask: Optional[str]
    force: bool
    keep_runs: bool
    plots: bool
    samples: Optional[int]

class CheckGainArgs(TypedDict):
    """platoon.design.check_gain's keyword arguments."""

    gain: Optional[Sequence[float]]
    c: float
    theorem: int
    time_headway: Optional[float]

def run(
    config: ConfigArg, options: RunArgs
) -> Tuple[str, List[Tuple[str, pyarrow.Table]], Optional[str]]: ...
def campaign(path: str, options: CampaignArgs) -> Tuple[str, pyarrow.Table, str]: ...
def execute_cells(jobs: str) -> str: ...
def check_gain(config: ConfigArg, options: CheckGainArgs) -> str: ...
def cli(argv: List[str]) -> int: ...
