"""The contract version and importing the SDK: a plug-in started for a run of another contract
version exits at once naming both versions and the document to read, and the SDK imports from a
user's script outside bridge/ the ways docs/injector-contract.md says."""

import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
BRIDGE = os.path.dirname(HERE)
sys.path.insert(0, BRIDGE)

import platoon.injector as pi  # noqa: E402
import platoon.wire as w  # noqa: E402


def test_the_same_version_or_none_passes(monkeypatch):
    monkeypatch.delenv(w.CONTRACT_VERSION_ENV, raising=False)
    w.check_contract_version()
    w.check_contract_version(str(w.CONTRACT_VERSION))


def test_a_plugin_of_another_version_is_told_both_versions(monkeypatch):
    other = w.CONTRACT_VERSION + 1
    monkeypatch.setenv(w.CONTRACT_VERSION_ENV, str(other))
    with pytest.raises(SystemExit) as e:
        w.check_contract_version()
    message = str(e.value)
    assert f"speaks platoon contract v{w.CONTRACT_VERSION}" in message
    assert f"the run speaks v{other}" in message
    assert w.CONTRACT_DOC in message
    with pytest.raises(SystemExit) as e:
        w.check_contract_version("two")
    assert "'two'" in str(e.value)


def test_the_injector_sdk_checks_before_reading_the_run(monkeypatch):
    """An old SDK meets a new run: the version is named, not a missing variable or a key error
    of a config format it does not know."""
    monkeypatch.setenv(w.CONTRACT_VERSION_ENV, str(w.CONTRACT_VERSION + 1))
    monkeypatch.delenv("PLATOON_CONFIG", raising=False)
    with pytest.raises(SystemExit) as e:
        pi.run(lambda run: pi.Injector())
    assert "contract" in str(e.value)


def test_type_names_follow_the_version(monkeypatch):
    monkeypatch.setattr(w, "CONTRACT_VERSION", 1)
    assert w.LinkPacket.type_name() == "platoon::v1::LinkPacket"


SCRIPT = """
import platoon.injector as pi
import platoon.wire as w
print(w.CONTRACT_VERSION, pi.jammed(3).kind)
"""


def run_elsewhere(tmp_path, **env):
    script = tmp_path / "my_injector.py"
    script.write_text(SCRIPT)
    clean = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(
        [sys.executable, str(script)],
        cwd=tmp_path,
        env={**clean, **env},
        capture_output=True,
        text=True,
    )


def test_the_sdk_imports_from_a_script_anywhere_with_pythonpath(tmp_path):
    o = run_elsewhere(tmp_path, PYTHONPATH=BRIDGE)
    assert o.returncode == 0, o.stderr
    assert o.stdout.split() == [str(w.CONTRACT_VERSION), "1"]


@pytest.mark.skipif(
    os.path.realpath(sys.prefix) != os.path.realpath(os.path.join(BRIDGE, ".venv")),
    reason="only the bridge's venv (bridge/setup-venv.sh) has bridge/ on its path",
)
def test_the_bridge_venv_imports_the_sdk_from_a_script_anywhere(tmp_path):
    o = run_elsewhere(tmp_path)
    assert o.returncode == 0, f"{o.stderr}\n(run bridge/setup-venv.sh: it adds platoon-bridge.pth)"
    assert o.stdout.split() == [str(w.CONTRACT_VERSION), "1"]


OLD_NAMES_SCRIPT = """
import platoon.controller, platoon.injector, platoon.plugin, platoon.wire
import platoon.sumo.model, platoon.sumo.native, platoon.sumo.plant
import platoon_controller, platoon_injector, platoon_plugin, platoon_wire
import platoon_plant, sumo_native, sumo_plant
from platoon_wire import LinkPacket
from platoon_injector import Injector
assert platoon_wire is platoon.wire and platoon_plugin is platoon.plugin
assert platoon_injector is platoon.injector and platoon_controller is platoon.controller
assert platoon_plant is platoon.sumo.model and sumo_native is platoon.sumo.native
assert sumo_plant is platoon.sumo.plant
assert LinkPacket is platoon.wire.LinkPacket and Injector is platoon.injector.Injector
assert isinstance(platoon.wire.LinkPacket(), platoon_wire.LinkPacket)
assert isinstance(platoon_injector.jammed(3), platoon.wire.LinkPacket)
assert platoon_controller.Topology is platoon_plugin.Topology is platoon.plugin.Topology
assert platoon_injector.Run is platoon_controller.Run is platoon.plugin.Run
print(platoon_wire.CONTRACT_VERSION, platoon_injector.jammed(3).kind)
"""

# Each old name and the module it stands for.
OLD_NAMES = {
    "platoon_controller": "platoon.controller",
    "platoon_injector": "platoon.injector",
    "platoon_plugin": "platoon.plugin",
    "platoon_wire": "platoon.wire",
    "platoon_plant": "platoon.sumo.model",
    "sumo_native": "platoon.sumo.native",
    "sumo_plant": "platoon.sumo.plant",
}


def run_script(tmp_path, text, *args):
    """`text` as a script of the user's, outside the bridge, with only the bridge on its path."""
    script = tmp_path / "old_script.py"
    script.write_text(text)
    clean = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(
        [sys.executable, str(script), *args],
        cwd=tmp_path,
        env={**clean, "PYTHONPATH": BRIDGE},
        capture_output=True,
        text=True,
    )


def test_the_old_module_names_are_the_same_modules_and_warn(tmp_path):
    """Scripts written before the package (`import platoon_injector`, `from platoon_wire import
    ...`) get the package's modules themselves, so their objects pass the package's checks;
    each old name warns once (DeprecationWarning, shown by default: it names the script's
    line) with the name to import instead."""
    o = run_script(tmp_path, OLD_NAMES_SCRIPT)
    assert o.returncode == 0, o.stderr
    assert o.stdout.split() == [str(w.CONTRACT_VERSION), "1"]
    for old, module in OLD_NAMES.items():
        line = f"DeprecationWarning: the module {old} is {module}: import that instead"
        assert o.stderr.count(line) == 1, (old, o.stderr)
    assert "old_script.py:" in o.stderr, o.stderr


def test_the_old_names_warn_as_errors_where_deprecations_are_errors(tmp_path):
    script = tmp_path / "strict.py"
    script.write_text("import platoon_wire\n")
    clean = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    o = subprocess.run(
        [sys.executable, "-W", "error::DeprecationWarning", str(script)],
        cwd=tmp_path,
        env={**clean, "PYTHONPATH": BRIDGE},
        capture_output=True,
        text=True,
    )
    assert o.returncode != 0 and "platoon.wire" in o.stderr, o.stderr


@pytest.mark.parametrize(
    "old, program, args, code, says",
    [
        ("sumo_plant.py", "python -m platoon.sumo", [], 2, "PLATOON_PLANT_SPEC is not set"),
        ("dask_cells.py", "python -m platoon.dask", [], 2, "usage: python -m platoon.dask"),
        ("parquet_equals_csv.py", "bridge/tools/parquet_equals_csv.py", [], 2,
         "bridge/.venv/bin/python bridge/tools/parquet_equals_csv.py"),
    ],
)
def test_the_old_script_paths_run_their_programs_and_warn(tmp_path, old, program, args, code, says):
    clean = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PLATOON_PLANT_SPEC")}
    o = subprocess.run(
        [sys.executable, os.path.join(BRIDGE, old), *args],
        cwd=tmp_path,
        env=clean,
        capture_output=True,
        text=True,
    )
    assert o.returncode == code, o.stderr
    assert f"DeprecationWarning: bridge/{old} is {program}" in o.stderr, o.stderr
    assert says in o.stderr, o.stderr
