"""A plug-in's run comes from the run's facts (PLATOON_RUN_FACTS, the orchestrator's
facts.json): steps, fleet and V2V graph are read, not re-derived from the config."""

import json
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))

import platoon.plugin as pp  # noqa: E402

# A config whose own keys would give other answers: the facts win.
CONFIG = """
[simulation]
dt_s = 0.01
duration_s = 1.0

[platoon]
followers = 9

[topology]
preset = "pf"
"""

FACTS = {
    "run_id": "r1",
    "contract_version": 4,
    "dt_s": 0.04,
    "last_step": 123,
    "platoons": 2,
    "followers": 2,
    "vehicles": 6,
    "numbering": "vehicle i of platoon j is j * (N + 1) + i",
    "topologies": [
        {"adjacency": [[0.0, 0.0], [1.0, 0.0]], "pinning": [1.0, 1.0]},
        {"adjacency": [[0.0, 0.0], [1.0, 0.0]], "pinning": [1.0, 1.0]},
    ],
    "hearing": [
        {"adjacency": [[0.0, 0.0], [1.0, 0.0]], "pinning": [1.0, 1.0]},
        {"adjacency": [[0.0, 0.0], [1.0, 0.0]], "pinning": [1.0, 1.0]},
    ],
    "detectors": ["mine"],
    "plant": "native",
}


@pytest.fixture
def run_env(tmp_path, monkeypatch):
    config = tmp_path / "config.toml"
    config.write_text(CONFIG)
    facts = tmp_path / "facts.json"
    facts.write_text(json.dumps(FACTS))
    monkeypatch.setenv("PLATOON_RUN_ID", "r1")
    monkeypatch.setenv("PLATOON_CONFIG", str(config))
    monkeypatch.setenv("PLATOON_RUN_FACTS", str(facts))
    return tmp_path


def test_load_run_reads_steps_and_topology_from_the_facts(run_env):
    run = pp.load_run("--controller")
    assert run.run_id == "r1"
    assert run.steps == 123 and run.dt == 0.04
    assert run.platoons == 2 and run.vehicles_per_platoon == 3
    assert list(run.vehicles()) == list(range(6))
    assert run.topology.in_neighbours == [[], [0], [0, 1]]
    assert run.topology.out_neighbours == [[1, 2], [2], []]
    assert run.detectors == ["mine"]
    assert run.config["platoon"]["followers"] == 9  # the config is still read, as it is


def test_without_the_facts_variable_the_run_is_named(run_env, monkeypatch):
    monkeypatch.delenv("PLATOON_RUN_FACTS")
    with pytest.raises(SystemExit) as e:
        pp.load_run("--injector")
    assert "PLATOON_RUN_FACTS is not set" in str(e.value)
    assert "platoon run CONFIG --injector" in str(e.value)
