"""Type stubs of platoon._core, the package's compiled Rust core (crates/python). Call it
through the functions of `platoon` (platoon/__init__.py), which document the arguments."""

from typing import List, Optional, Sequence, Tuple

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
def run(
    config: str,
    is_path: bool,
    transport: str,
    origin: Optional[str] = None,
    source: Optional[str] = None,
    plant: Optional[str] = None,
    out: Optional[str] = None,
    force: bool = False,
    plots: bool = False,
    injector: Optional[str] = None,
    injector_after: bool = False,
    controller: Optional[str] = None,
    step_timeout_s: float = 1.0,
) -> Tuple[str, List[Tuple[str, pyarrow.Table]], Optional[str]]: ...
def campaign(
    path: str,
    out: Optional[str] = None,
    jobs: Optional[int] = None,
    dask: Optional[str] = None,
    force: bool = False,
    keep_runs: bool = False,
    plots: bool = False,
    samples: Optional[int] = None,
) -> Tuple[str, pyarrow.Table, str]: ...
def execute_cells(jobs: str) -> str: ...
def check_gain(
    config: str,
    is_path: bool,
    origin: Optional[str] = None,
    source: Optional[str] = None,
    gain: Optional[Sequence[float]] = None,
    c: float = 0.0,
    theorem: int = 1,
    time_headway: Optional[float] = None,
) -> str: ...
def cli(argv: List[str]) -> int: ...
