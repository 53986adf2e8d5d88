"""The SDKs read the run's config strictly (issue 50, item 6): a key no layout of the config
has, such as the old `[control.path_cacc]` table, raises ConfigLayoutError naming it instead of
letting a plug-in's default stand in for the run's value; the layout they check against is the
config's JSON Schema's (docs/config.schema.json)."""

import copy
import glob
import json
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(HERE, ".."))

import platoon.controller as pc  # noqa: E402
import platoon.injector as pi  # noqa: E402
import platoon.plugin as pp  # noqa: E402

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

# A PATH CACC run with its own spacing, as a resolved config writes it (the law's keys beside
# `law`).
PATH_CACC = {
    "simulation": {"dt_s": 0.01, "duration_s": 1.0},
    "control": {"law": "path_cacc", "spacing_m": 7.0, "c1": 0.5, "xi": 1.0},
    "channel": {"seed": 1, "attacks": [{"kind": "bernoulli", "loss": 0.05}]},
    "vehicle_classes": {"truck": {"length_m": 12.0}},
}


def test_the_committed_layout_is_the_schemas():
    with open(os.path.join(ROOT, "docs", "config.schema.json"), encoding="utf-8") as f:
        schema = json.load(f)
    with open(pp.LAYOUT_FILE, encoding="utf-8") as f:
        committed = json.load(f)
    assert committed == pp.config_layout(schema), (
        "regenerate it: bridge/.venv/bin/python -m platoon.plugin config-layout "
        "docs/config.schema.json > bridge/platoon/config_layout.json"
    )


@pytest.mark.parametrize(
    "path", sorted(glob.glob(os.path.join(ROOT, "configs", "*.toml"))), ids=os.path.basename
)
def test_every_shipped_config_has_a_known_layout(path):
    with open(path, "rb") as f:
        pp.strict_config(tomllib.load(f))


def test_a_plug_in_reading_the_old_law_table_is_refused_naming_it():
    config = pp.strict_config(PATH_CACC)
    # What a controller written for [control.path_cacc] did: with a dict it ran on 5.0.
    with pytest.raises(pp.ConfigLayoutError) as e:
        config["control"].get("path_cacc", {}).get("spacing_m", 5.0)
    message = str(e.value)
    assert "[control.path_cacc]" in message
    assert "law" in message and "config-and-sdk-changes" in message
    with pytest.raises(pp.ConfigLayoutError, match=r"control\.path_cacc"):
        config["control"]["path_cacc"]
    with pytest.raises(pp.ConfigLayoutError, match=r"control\.path_cacc"):
        "path_cacc" in config["control"]
    # The new layout reads the run's value.
    assert config["control"]["spacing_m"] == 7.0


def test_a_config_in_the_old_layout_is_refused_naming_the_table():
    old = copy.deepcopy(PATH_CACC)
    old["control"] = {"law": "path_cacc", "path_cacc": {"spacing_m": 7.0}}
    with pytest.raises(pp.ConfigLayoutError, match=r"control\.path_cacc"):
        pp.strict_config(old)


def test_an_unknown_key_is_refused_and_a_known_absent_one_reads_as_absent():
    config = pp.strict_config(PATH_CACC)
    with pytest.raises(pp.ConfigLayoutError, match=r"control\.spacing\b.*its keys: .*spacing_m"):
        config["control"].get("spacing", 5.0)
    with pytest.raises(pp.ConfigLayoutError, match=r"`guards`|guards is no key"):
        config.get("guards", {})
    # Keys the layout has but this config leaves out: an optional table, another law's key.
    assert config.get("guard", {}) == {}
    assert config["control"].get("gain") is None
    assert "detection" not in config
    with pytest.raises(KeyError):
        config["control"]["gain"]


def test_a_key_that_moved_says_where():
    config = pp.strict_config(PATH_CACC)
    with pytest.raises(pp.ConfigLayoutError, match=r"control\.attack_input.*fallback\.mode"):
        config["control"].get("attack_input", "zero")


def test_arrays_of_tables_and_tables_of_names_are_checked_too():
    config = pp.strict_config(PATH_CACC)
    attack = config["channel"]["attacks"][0]
    assert isinstance(attack, pp.ConfigTable) and attack["loss"] == 0.05
    with pytest.raises(pp.ConfigLayoutError, match=r"channel\.attacks\[0\]\.probability"):
        attack.get("probability", 0.0)
    truck = config["vehicle_classes"]["truck"]
    assert truck["length_m"] == 12.0
    with pytest.raises(pp.ConfigLayoutError, match=r"vehicle_classes\.truck\.length\b"):
        truck.get("length", 4.0)


def test_a_layout_error_is_not_a_key_error():
    # Code that falls back to a default on KeyError must not swallow it.
    assert not issubclass(pp.ConfigLayoutError, LookupError)


def test_a_strict_config_is_still_a_dict():
    config = pp.strict_config(PATH_CACC)
    assert isinstance(config, dict)
    assert json.loads(json.dumps(config)) == PATH_CACC
    again = copy.deepcopy(config)
    assert again == PATH_CACC
    with pytest.raises(pp.ConfigLayoutError):
        again["control"].get("path_cacc")


@pytest.fixture
def old_layout_run(tmp_path, monkeypatch):
    config = tmp_path / "config.toml"
    config.write_text('[control]\nlaw = "path_cacc"\nspacing_m = 7.0\n')
    facts = {
        "run_id": "r1",
        "contract_version": 4,
        "dt_s": 0.01,
        "last_step": 10,
        "platoons": 1,
        "followers": 1,
        "vehicles": 2,
        "numbering": "vehicle i of platoon j is j * (N + 1) + i",
        "topologies": [{"adjacency": [[0.0]], "pinning": [1.0]}],
        "hearing": [{"adjacency": [[0.0]], "pinning": [1.0]}],
        "detectors": [],
        "plant": "native",
    }
    (tmp_path / "facts.json").write_text(json.dumps(facts))
    monkeypatch.setenv("PLATOON_RUN_ID", "r1")
    monkeypatch.setenv("PLATOON_CONFIG", str(config))
    monkeypatch.setenv("PLATOON_RUN_FACTS", str(tmp_path / "facts.json"))


@pytest.mark.parametrize("sdk", [pc, pi], ids=["controller", "injector"])
def test_both_sdks_give_plug_ins_the_strict_config(old_layout_run, sdk):
    run = sdk.load_run()
    assert sdk.ConfigLayoutError is pp.ConfigLayoutError
    assert isinstance(run.config, sdk.ConfigTable)
    assert run.config["control"]["spacing_m"] == 7.0
    with pytest.raises(pp.ConfigLayoutError, match=r"control\.path_cacc"):
        run.config["control"].get("path_cacc", {})
