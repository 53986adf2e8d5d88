"""The bridge's old top-level modules and script paths (`import platoon_wire`,
`python bridge/sumo_plant.py`, ...), each a small file at its old place that calls `alias`: it
warns (DeprecationWarning, naming what to use instead), then gives the module it stands for or
runs the program. They go in a later release; bridge/README.md lists them.
"""

import importlib
import importlib.util
import os
import runpy
import sys
import warnings


def alias(name: str, module: "str | None" = None, run: "str | None" = None) -> None:
    """Called by the old file, whose `__name__` is `name`.

    Imported, it becomes `module` itself (`sys.modules`), so `import platoon_wire` gives
    `platoon.wire`; without `module`, the file `run` loaded as a module of that name. Run as a
    script, it runs `run` as `__main__` with the same arguments: a module, as `python -m` would
    ("platoon.sumo"), or a file of the bridge ("tools/bench_peers.py"). Either way it warns
    first, naming the importer's line or the old script, where Python shows it by default."""
    old = sys.modules[name].__file__
    bridge = os.path.dirname(os.path.abspath(old))
    if name != "__main__":
        new = module or f"bridge/{run}"
        warnings.warn(
            f"the module {name} is {new}: import that instead ({name} goes in a later release)",
            DeprecationWarning,
            stacklevel=3,  # this function, the old file, then (past importlib) its importer
        )
        sys.modules[name] = importlib.import_module(module) if module else _load(name, bridge, run)
        return
    path = run.endswith(".py")
    instead = f"bridge/{run}" if path else f"python -m {run} (with bridge/ on PYTHONPATH)"
    warnings.warn(
        f"bridge/{os.path.basename(old)} is {instead}: run that instead (the old path goes in a "
        "later release)",
        DeprecationWarning,
        stacklevel=2,  # the old script, which is __main__
    )
    if path:
        runpy.run_path(os.path.join(bridge, run), run_name="__main__")
    else:
        runpy.run_module(run, run_name="__main__", alter_sys=True)


def _load(name: str, bridge: str, path: str):
    """The file `path` of the bridge `bridge` loaded as the module `name`."""
    spec = importlib.util.spec_from_file_location(name, os.path.join(bridge, path))
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod
