"""The `platoon` Python package (bridge/pyproject.toml) against the `platoon` command: the same
runs, campaigns and errors, the SDKs importable from anywhere, Ctrl-C and the GIL.

Needs the package installed in this interpreter (.ci/run installs it into the bridge's venv:
`pip install ./bridge`); the command is the `platoon` script the package installs beside it.
"""

import importlib
import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest

import platoon

REPO = pathlib.Path(__file__).resolve().parents[2]
BIN = pathlib.Path(sys.executable).parent
PLATOON = str(BIN / "platoon")
TABLES = ["trajectories", "events", "wire", "channel"]


def assert_identical(a, b, what=""):
    """Two Arrow tables hold the same schema and values, floats bit for bit (NaN included,
    which pyarrow's equals() never equates)."""
    assert a.schema == b.schema, what
    assert a.num_rows == b.num_rows, what
    for name in a.column_names:
        x, y = a.column(name), b.column(name)
        if pa.types.is_floating(x.type):
            xs, ys = x.to_numpy(), y.to_numpy()
            assert np.array_equal(xs.view(np.uint64), ys.view(np.uint64)), (what, name)
        else:
            assert x.to_pylist() == y.to_pylist(), (what, name)


def cli(*args, cwd):
    p = subprocess.run([PLATOON, *args], cwd=cwd, capture_output=True, text=True)
    assert p.returncode == 0, f"platoon {' '.join(args)} exited {p.returncode}: {p.stderr}"
    return p


def assert_same_table(csv_path, table):
    """A table the package handed over equals the command's CSV file value for value: numbers
    bit for bit (pandas 3 reads the shortest round-trip text back exactly), NaN where the other
    has NaN (the text "NaN" keeps no sign or payload)."""
    a = pd.read_csv(csv_path)
    b = table.to_pandas()
    assert list(a.columns) == list(b.columns), csv_path
    assert len(a) == len(b), csv_path
    for c in a.columns:
        x, y = a[c].to_numpy(), b[c].to_numpy()
        if a[c].dtype.kind in "fiu" and b[c].dtype.kind in "fiu":
            x, y = x.astype(np.float64), y.astype(np.float64)
            nan = np.isnan(x)
            assert np.array_equal(nan, np.isnan(y)), (csv_path, c)
            assert np.array_equal(x[~nan].view(np.uint64), y[~nan].view(np.uint64)), (csv_path, c)
        else:
            assert [str(v).lower() for v in x] == [str(v).lower() for v in y], (csv_path, c)


def test_the_package_has_its_installed_core():
    # The other bridge tests put the source tree first on sys.path: its platoon finds the
    # installed core all the same.
    core = importlib.import_module("platoon._core")
    assert "site-packages" in core.__file__, core.__file__
    assert core.__version__ == platoon.__version__
    assert platoon.scenarios() == [
        "paper", "table1", "degradation", "cut-in", "join", "join-middle", "leave",
        "merge", "split",
    ]


def test_a_run_of_the_paper_scenario_equals_the_commands_files(tmp_path):
    cli("run", "--transport", "inproc", "--no-plots", "--out", "cli", cwd=tmp_path)
    run = platoon.run(platoon.scenario("paper"))
    assert run.dir is None
    assert sorted(run.tables) == sorted(TABLES)
    for name in TABLES:
        assert isinstance(run.tables[name].arrow, pa.Table)
        assert_same_table(tmp_path / "cli" / f"{name}.csv", run.tables[name])
    assert run.summary == json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert run.summary["complete"] is True


def test_a_run_in_memory_equals_the_commands_parquet_files_bit_for_bit(tmp_path):
    import pyarrow.parquet as pq

    config = tmp_path / "paper-parquet.toml"
    config.write_text((REPO / "configs" / "paper.toml").read_text() + '\n[output]\nformat = "parquet"\n')
    cli("run", str(config), "--transport", "inproc", "--no-plots", "--out", "cli", cwd=tmp_path)
    run = platoon.run(platoon.scenario(config))
    for name in TABLES:
        ours = run.tables[name].arrow
        # Parquet keeps no large_string (the dictionary columns' values): cast it back.
        theirs = pq.read_table(tmp_path / "cli" / f"{name}.parquet").cast(ours.schema)
        assert_identical(theirs, ours, name)


def test_options_that_do_not_go_together_are_refused():
    with pytest.raises(ValueError, match="give out= too"):
        platoon.run("paper", plots=True)
    with pytest.raises(ValueError, match="give injector= too"):
        platoon.run("paper", transport="iceoryx2", injector_after=True)
    with pytest.raises(ValueError, match="jobs= is the local pool's"):
        platoon.campaign(REPO / "campaigns" / "dos-timing.toml", jobs=2, dask="tcp://127.0.0.1:1")
    with pytest.raises(ValueError, match="transport="):
        platoon.run("paper", transport="carrier-pigeon")


def test_a_dict_keeps_the_keys_the_user_set_and_its_files_folder():
    cfg = platoon.scenario("paper")
    cfg["trigger"]["rule"] = "static"
    cfg["trigger"]["eta"] = 123.0  # set by hand: refused, as in a file
    with pytest.raises(platoon.ConfigError, match="trigger.eta"):
        platoon.run(cfg)
    # A plain dict (not from scenario()) switches nothing by itself either.
    plain = json.loads(json.dumps(platoon.scenario("paper")))
    plain["trigger"]["rule"] = "static"
    with pytest.raises(platoon.ConfigError, match="is not used with rule"):
        platoon.run(plain)
    # A dict of a file resolves the file's relative paths against its folder (sumo.net).
    cfg = platoon.scenario(REPO / "configs" / "highway-large.toml")
    assert cfg["sumo"]["net"].startswith("..")
    cfg["fleet"]["platoons"] = 1
    cfg["simulation"]["duration_s"] = 0.05
    run = platoon.run(cfg, transport="iceoryx2")
    assert run.summary["complete"] is True


def test_a_run_directory_from_python_is_the_commands(tmp_path):
    cli("run", "--transport", "inproc", "--no-plots", "--out", "cli", cwd=tmp_path)
    run = platoon.run("paper", out=tmp_path / "py")
    assert run.dir == tmp_path / "py"
    for name in ["trajectories.csv", "events.csv", "wire.csv", "channel.csv", "config.toml"]:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    assert_same_table(tmp_path / "cli" / "trajectories.csv", run.trajectories)


def test_the_co_simulation_through_the_package_agrees_with_the_in_process_run():
    cfg = platoon.scenario("paper")
    cfg["simulation"]["duration_s"] = 5.0
    inproc = platoon.run(cfg)
    cosim = platoon.run(cfg, transport="iceoryx2")
    assert cosim.summary["complete"] is True
    for name in ["trajectories", "events", "wire"]:
        assert_identical(cosim.tables[name].arrow, inproc.tables[name].arrow, name)


def test_tables_convert_to_pandas_polars_and_read_through_the_capsule():
    run = platoon.run("paper")
    t = run.trajectories
    assert len(t) == t.arrow.num_rows == len(t.to_pandas()) == len(t.to_polars())
    assert_identical(pa.table(t), t.arrow)  # through __arrow_c_stream__
    assert t.columns[:4] == ["step", "t", "platoon", "vehicle"]
    with pytest.raises(AttributeError, match="no detections table"):
        run.detections


def test_an_edited_scenario_runs_what_the_edit_says():
    cfg = platoon.scenario("paper")
    cfg["trigger"]["rule"] = "static"
    static = platoon.run(cfg)
    paper = platoon.run("paper")
    broadcasts = lambda r: (r.events.to_pandas()["event"] == "broadcast").sum()  # noqa: E731
    assert broadcasts(static) != broadcasts(paper)


def test_a_bad_key_in_a_dict_raises_config_error_naming_it():
    cfg = platoon.scenario("paper")
    cfg["trigger"]["h_s"] = -1.0
    with pytest.raises(platoon.ConfigError) as e:
        platoon.run(cfg)
    assert e.value.key == "trigger.h_s"
    assert e.value.file == "<dict>" and e.value.line is None
    assert "trigger.h_s" in str(e.value)
    assert isinstance(e.value, ValueError)
    cfg = platoon.scenario("paper")
    cfg["trigger"]["no_such_key"] = 1
    with pytest.raises(platoon.ConfigError, match="no_such_key"):
        platoon.run(cfg)


def test_a_bad_file_raises_config_error_with_its_line(tmp_path):
    bad = tmp_path / "bad.toml"
    lines = (REPO / "configs" / "paper.toml").read_text().splitlines()
    line = next(i for i, l in enumerate(lines) if l.startswith("h_s = ")) + 1
    lines[line - 1] = 'h_s = "soon"'
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(platoon.ConfigError) as e:
        platoon.run(bad)
    assert (e.value.file, e.value.key, e.value.line) == (str(bad), "trigger.h_s", line)
    with pytest.raises(FileNotFoundError, match="not an embedded scenario"):
        platoon.run(tmp_path / "missing.toml")


def test_a_run_that_fails_raises_platoon_error_naming_why():
    with pytest.raises(platoon.PlatoonError, match="--transport iceoryx2"):
        platoon.run("paper", injector="true")


def test_a_plug_in_that_fails_raises_node_error_naming_it_and_its_log(tmp_path):
    plugin = tmp_path / "broken_injector.py"
    plugin.write_text("import sys\nprint('this injector gives up', file=sys.stderr)\nsys.exit(3)\n")
    cfg = platoon.scenario("paper")
    cfg["simulation"]["duration_s"] = 1.0
    out = tmp_path / "run"
    with pytest.raises(platoon.NodeError) as e:
        platoon.run(cfg, transport="iceoryx2", injector=f"{sys.executable} {plugin}", out=out)
    assert isinstance(e.value, platoon.PlatoonError)
    assert e.value.node == "injector"
    assert e.value.step == 0
    assert e.value.log == str(out / "logs" / "injector.log")
    assert "this injector gives up" in pathlib.Path(e.value.log).read_text()
    assert e.value.message and e.value.run_dir == str(out)
    # The message is the command's.
    assert "the injector process" in str(e.value) and "this injector gives up" in str(e.value)


def test_a_run_directory_that_is_there_raises_output_error_with_its_path(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "mine.txt").write_text("not a run")
    with pytest.raises(platoon.OutputError) as e:
        platoon.run("paper", out=out)
    assert isinstance(e.value, platoon.PlatoonError)
    assert e.value.path == str(out)


def campaign_file(tmp_path):
    spec = tmp_path / "small.toml"
    spec.write_text(
        f"""name = "small"
base = "{REPO / 'configs' / 'paper.toml'}"
transport = "inproc"
set = {{ "simulation.duration_s" = 3.0 }}

[[axes]]
key = "trigger.rule"
values = ["static", "dynamic"]

[dos_window]
onset_s = [0.5, 1.0]
duration_s = [1.0]
"""
    )
    return spec


def test_a_campaign_through_the_package_equals_the_commands_cells_csv(tmp_path):
    spec = campaign_file(tmp_path)
    cli("campaign", str(spec), "--out", "cli", "--no-plots", "-j", "2", cwd=tmp_path)
    result = platoon.campaign(spec, out=tmp_path / "py", jobs=2)
    assert (tmp_path / "py" / "cells.csv").read_bytes() == (tmp_path / "cli" / "cells.csv").read_bytes()
    assert result.dir == tmp_path / "py"
    assert result.report["ok"] == 4 and len(result.cells) == 4
    cells = result.cells.to_pandas()
    assert list(cells["status"]) == ["ok"] * 4
    expected = pd.read_csv(tmp_path / "cli" / "cells.csv")
    assert list(cells.columns) == list(expected.columns)
    for c in expected.columns:
        x, y = cells[c], expected[c]
        if x.dtype.kind in "fiu" and y.dtype.kind in "fiu":
            assert np.array_equal(x.to_numpy(float), y.to_numpy(float), equal_nan=True), c
        else:
            as_text = lambda col: [str(v) for v in col.astype(object).fillna("")]
            assert as_text(x) == as_text(y), c
    # The columns are typed by what they are, not by this campaign's values.
    schema = result.cells.arrow.schema
    assert schema.field("cell").type == pa.int64() and schema.field("seed").type == pa.uint64()
    assert schema.field("attacked_time_s").type == pa.float64()  # whole numbers here
    assert schema.field("error").type == pa.string()


def test_a_bad_campaign_file_raises_config_error_naming_its_key(tmp_path):
    spec = tmp_path / "bad.toml"
    spec.write_text('name = "bad"\n[monte_carlo]\nsamples = 0\n')
    with pytest.raises(platoon.ConfigError) as e:
        platoon.campaign(spec, out=tmp_path / "out")
    assert e.value.key == "monte_carlo.samples"
    assert e.value.file == str(spec) and e.value.line == 3
    assert "monte_carlo.samples" in str(e.value)
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial").exists()


def test_a_campaign_directory_that_is_not_one_raises_output_error_with_its_path(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("not a campaign")
    with pytest.raises(platoon.OutputError) as e:
        platoon.campaign(campaign_file(tmp_path), out=out)
    assert isinstance(e.value, platoon.PlatoonError)
    assert e.value.path == str(out)
    assert (out / "notes.txt").read_text() == "not a campaign"


def test_a_design_check_of_an_invalid_config_or_option_raises_by_kind():
    cfg = platoon.scenario("paper")
    cfg["trigger"]["h_s"] = 0.001
    with pytest.raises(platoon.ConfigError) as e:
        platoon.design.check_gain(cfg)
    assert e.value.key == "trigger.h_s"
    # An option no check can use is the check's error, not the config's.
    with pytest.raises(platoon.PlatoonError, match="--time-headway -1") as e:
        platoon.design.check_gain("paper", time_headway=-1.0)
    assert not isinstance(e.value, platoon.ConfigError)


def test_a_design_check_is_the_commands(tmp_path):
    # The paper's config with two followers (half the SDPs' size of its four, half the time):
    # its K at its ratio is not certified there either, so the command exits 1, writing its
    # report all the same. (tests/cli.rs checks the paper's own.)
    text = (REPO / "configs" / "paper.toml").read_text()
    start = text.index("initial_states = [")
    end = text.index("\n]\n", start) + 3
    two = text[:start] + "formation = { leader_position_m = 0.0 }\n" + text[end:]
    config = tmp_path / "two.toml"
    config.write_text(two.replace("followers = 4", "followers = 2", 1))
    p = subprocess.run(
        [PLATOON, "design", "check-gain", str(config), "--out", "cli"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert p.returncode == 1 and "NOT certified" in p.stderr, p.stderr
    report = platoon.design.check_gain(config)
    assert report == json.loads((tmp_path / "cli" / "check.json").read_text())
    assert report["topology_followers"] == 2
    assert report["stable_over_tau_range"] is True


def test_the_sdks_import_from_any_directory(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = (
        "import platoon.injector, platoon.controller, platoon.wire, platoon; "
        "print(platoon.__file__)"
    )
    p = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert p.returncode == 0, p.stderr
    assert "site-packages" in p.stdout


def test_the_command_is_installed_with_the_package(tmp_path):
    p = cli("--version", cwd=tmp_path)
    assert p.stdout.startswith("platoon ")
    p = subprocess.run([PLATOON, "run", "--no-such-flag"], cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 2 and "--no-such-flag" in p.stderr
    p = subprocess.run(
        [sys.executable, "-m", "platoon", "--version"], cwd=tmp_path, capture_output=True, text=True
    )
    assert p.returncode == 0 and p.stdout.startswith("platoon "), p.stderr


# How long a test waits for a process at most: it only bounds a hang, never a figure checked.
PATIENCE_S = 120


def wait_for(what, done):
    """Polls `done()` until it holds; fails after PATIENCE_S saying what was awaited."""
    deadline = time.monotonic() + PATIENCE_S
    while not done():
        assert time.monotonic() < deadline, f"waited {PATIENCE_S} s for {what}"
        time.sleep(0.02)


def long_paper_run(duration_s=1e6):
    """The paper scenario long on purpose (a million simulated seconds: hours in any build), its
    trajectories in CSV (`auto` would pick Parquet, written in large row groups) so that the run
    is seen to progress; a test stops it on purpose."""
    return (
        "cfg = platoon.scenario('paper')\n"
        f"cfg['simulation']['duration_s'] = {duration_s!r}\n"
        "cfg['output']['format'] = 'csv'\n"
    )


def until_interrupted(*lines):
    """Script lines run until a KeyboardInterrupt, which prints so and exits with 130."""
    body = "".join(f"    {line}\n" for line in lines)
    return f"try:\n{body}" + (
        "except KeyboardInterrupt:\n"
        "    print('KeyboardInterrupt', flush=True)\n"
        "    sys.exit(130)\n"
    )


def test_the_gil_is_released_while_the_core_runs(tmp_path):
    # A thread of the script watches the run's trajectories.csv grow while the main thread is in
    # platoon.run (a held GIL would stop it dead), then interrupts the run.
    script = tmp_path / "gil.py"
    script.write_text(
        "import os, pathlib, platoon, signal, sys, threading, time\n"
        + long_paper_run()
        + "csv = pathlib.Path(sys.argv[1] + '.partial') / 'trajectories.csv'\n"
        "def watch():\n"
        "    sizes = set()\n"
        "    while len(sizes) < 3:\n"
        "        if csv.exists():\n"
        "            sizes.add(csv.stat().st_size)\n"
        "        time.sleep(0.01)\n"
        "    print('watched it grow', flush=True)\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "threading.Thread(target=watch, daemon=True).start()\n"
        + until_interrupted(
            "platoon.run(cfg, out=sys.argv[1], transport='inproc')", "print('returned', flush=True)"
        )
    )
    p = subprocess.run(
        [sys.executable, str(script), str(tmp_path / "run")],
        capture_output=True,
        text=True,
        timeout=PATIENCE_S,
    )
    assert p.stdout.split("\n")[:2] == ["watched it grow", "KeyboardInterrupt"], (p.stdout, p.stderr)
    assert p.returncode == 130


def test_ctrl_c_stops_a_long_run_cleanly_and_raises_keyboard_interrupt(tmp_path):
    script = tmp_path / "long.py"
    script.write_text(
        "import platoon, sys\n"
        + long_paper_run()
        + "print('started', flush=True)\n"
        + until_interrupted("platoon.run(cfg, out=sys.argv[1], transport='inproc')")
    )
    p = subprocess.Popen(
        [sys.executable, str(script), str(tmp_path / "run")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert p.stdout.readline().strip() == "started"
    # Interrupt the run once it records steps.
    csv = tmp_path / "run.partial" / "trajectories.csv"
    wait_for("the run to record steps", lambda: csv.exists() and csv.stat().st_size > 10_000)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=PATIENCE_S)
    assert p.returncode == 130, (out, err)
    assert "KeyboardInterrupt" in out
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["complete"] is False
    assert "KeyboardInterrupt" in summary["error"]
    assert summary["steps"] > 0


def test_a_python_injector_example_through_the_package_reproduces_the_builtin_channel():
    # bridge/examples/dos_jammer.py (on platoon.injector) replaces the built-in channel and
    # reproduces its DoS byte for byte.
    cfg = platoon.scenario("paper")
    cfg["simulation"]["duration_s"] = 5.0
    builtin = platoon.run(cfg, transport="iceoryx2")
    example = REPO / "bridge" / "examples" / "dos_jammer.py"
    injected = platoon.run(cfg, transport="iceoryx2", injector=f"{sys.executable} {example}")
    assert "dos_jammer.py" in injected.summary["injector"]["program"]
    for name in ["trajectories", "events"]:
        assert_identical(injected.tables[name].arrow, builtin.tables[name].arrow, name)


def test_a_sumo_run_through_the_package():
    cfg = platoon.scenario(REPO / "configs" / "sumo-paper.toml")
    cfg["simulation"]["duration_s"] = 1.0
    run = platoon.run(cfg, transport="iceoryx2", plant="sumo")
    assert run.summary["complete"] is True
    assert "sumo" in run.summary
    t = run.trajectories.to_pandas()
    assert t["step"].max() == 100 and (t["v"] > 0).all()


def test_ctrl_c_leaves_a_design_check_that_does_not_end(tmp_path):
    # A gain of 1e308 makes the SDP solver run on and on (the command hangs too, but Ctrl-C
    # kills it there): from Python, Ctrl-C must still give the interpreter back at once.
    script = tmp_path / "hang.py"
    script.write_text(
        "import platoon, sys\n"
        "print('started', flush=True)\n"
        + until_interrupted(
            "platoon.design.check_gain('paper', gain=(1e308, 1e308, 1e308))",
            "print('returned', flush=True)",
        )
    )
    p = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "started"
    # In the solver once the process has spent a second of CPU after saying so (what lies
    # between the print and the call takes microseconds).
    at_start = cpu_seconds(p.pid)
    wait_for("the check to spend a second of CPU", lambda: cpu_seconds(p.pid) > at_start + 1.0)
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=PATIENCE_S)
    assert out.strip() == "KeyboardInterrupt", out
    assert p.returncode == 130


def cpu_seconds(pid):
    """The CPU time process `pid` has used, from /proc/PID/stat (utime + stime)."""
    fields = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def test_ctrl_c_stops_a_campaign_which_then_resumes(tmp_path):
    # A campaign long on purpose (1000 cells of 300 simulated seconds: minutes of work in any
    # build), interrupted once a cell is recorded; the same call then keeps it and goes on, and is
    # interrupted in turn once it has run a cell of its own. (That a resumed campaign completes
    # is crates/app/tests/campaign.rs's stopped-campaign test.)
    spec = tmp_path / "long.toml"
    spec.write_text(
        'name = "long"\nset = { "simulation.duration_s" = 300.0 }\n'
        "[monte_carlo]\nsamples = 1000\nloss = [0.0, 0.2]\n"
    )
    script = tmp_path / "campaign.py"
    script.write_text(
        "import platoon, sys\n"
        + until_interrupted(
            f"c = platoon.campaign({str(spec)!r}, out=sys.argv[1], jobs=1)",
            "print('done', c.report['ok'], flush=True)",
        )
    )
    out = tmp_path / "long"
    partial = tmp_path / "long.partial"

    def interrupted_once_recorded(cell):
        p = subprocess.Popen([sys.executable, str(script), str(out)], stdout=subprocess.PIPE, text=True)
        recorded = partial / "cells" / f"c{cell:04}" / "cell.json"
        # One job: cells finish in order.
        wait_for(f"cell {cell} to be recorded", recorded.exists)
        p.send_signal(signal.SIGINT)
        printed, _ = p.communicate(timeout=PATIENCE_S)
        assert p.returncode == 130 and "KeyboardInterrupt" in printed, printed
        assert not out.exists() and partial.is_dir()
        return json.loads((partial / "campaign.json").read_text())

    first = interrupted_once_recorded(0)
    assert first["complete"] is False and first["interrupted_by"]
    kept = first["ok"]
    assert 1 <= kept < 1000, first
    before = (partial / "cells.csv").read_text().splitlines()
    second = interrupted_once_recorded(kept)
    assert second["reused_from_an_earlier_run"] == kept, second
    assert second["ok"] > kept, second
    after = (partial / "cells.csv").read_text().splitlines()
    # The header and the kept cells' rows are as they were.
    assert after[: 1 + kept] == before[: 1 + kept]
