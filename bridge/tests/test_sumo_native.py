"""The SUMO bridge's C++ loop (platoon.sumo.native): chosen by PLATOON_SUMO_NATIVE, a missing
compiler said plainly (a warning and the Python loop by default, an error when it was asked
for), and the radar read through it is the Python loop's to the bit (the whole runs:
tests/sumo.rs)."""

import os
import sys
import tempfile

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))

import libsumo  # noqa: E402

import platoon.sumo.native as sumo_native  # noqa: E402
import platoon.sumo.plant as sumo_plant  # noqa: E402
from test_sumo_radar import sumo_with  # noqa: E402


def no_compiler(monkeypatch, tmp):
    monkeypatch.setenv("CXX", "/nonexistent/g++")
    monkeypatch.setenv("PLATOON_SUMO_NATIVE_CACHE", tmp)  # nothing built there


def test_without_a_compiler_the_default_warns_and_uses_the_python_loop(monkeypatch):
    with tempfile.TemporaryDirectory() as tmp:
        no_compiler(monkeypatch, tmp)
        monkeypatch.delenv("PLATOON_SUMO_NATIVE", raising=False)
        said = []
        assert sumo_native.open_fleet(libsumo, ["leader"], say=said.append) is None
        assert len(said) == 1 and "install g++" in said[0] and "\n" not in said[0], said


def test_without_a_compiler_asking_for_the_cpp_loop_is_an_error(monkeypatch):
    with tempfile.TemporaryDirectory() as tmp:
        no_compiler(monkeypatch, tmp)
        monkeypatch.setenv("PLATOON_SUMO_NATIVE", "1")
        with pytest.raises(sumo_native.NativeError, match="install g\\+\\+"):
            sumo_native.open_fleet(libsumo, ["leader"])


def test_the_python_loop_and_unknown_choices(monkeypatch):
    monkeypatch.setenv("PLATOON_SUMO_NATIVE", "0")
    assert sumo_native.open_fleet(libsumo, ["leader"]) is None
    monkeypatch.setenv("PLATOON_SUMO_NATIVE", "yes")
    with pytest.raises(sumo_native.NativeError, match="use 1"):
        sumo_native.open_fleet(libsumo, ["leader"])


def read_both(tmp, vector):
    """Step 0's states of the radar scenario (an intruder between follower 1 and the leader)
    through the Python loop and the C++ loop, with plain loops or numpy."""
    cars = [("leader", 200.0, 20.0), ("follower1", 140.0, 22.0), ("intruder", 164.0, 15.0),
            ("follower2", 100.0, 21.0)]
    with sumo_with(tmp, cars):
        sumo_plant.NAMES["per_platoon"], sumo_plant.NAMES["platoons"] = 3, 1
        spec = {
            "dt": 0.01,
            "initial": [[100.0, 20.0, 0.0], [40.0, 22.0, 0.0], [0.0, 21.0, 0.0]],
            "vehicles_per_platoon": 3,
            "lanes": [0],
            "radar_range_m": 150.0,
            "sumo": {"offset_m": 100.0},
        }
        os.environ["PLATOON_BRIDGE_VECTOR_MIN"] = "1" if vector else "1000000"
        got = []
        try:
            for native in (None, sumo_native.Fleet(libsumo, ["leader", "follower1", "follower2"],
                                                   [1, 2], 150.0)):
                kin = sumo_plant.Kinematics(spec, libsumo, "sumo", native)
                out = kin.read(0, [0.0, 0.0, 0.0])
                got.append([(s.flags, s.p.hex(), s.v.hex(), s.gap.hex(), s.closing.hex())
                            for s in out])
        finally:
            os.environ.pop("PLATOON_BRIDGE_VECTOR_MIN", None)
        return got


@pytest.mark.parametrize("vector", [False, True])
def test_the_cpp_loop_reads_what_the_python_loop_reads(vector):
    with tempfile.TemporaryDirectory() as tmp:
        python, native = read_both(tmp, vector)
        assert python == native
        assert python[1][0] & 2 and python[2][0] & 2  # both followers see someone ahead
