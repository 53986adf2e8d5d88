//! Controllers from outside: `platoon run --controller` replaces the
//! controller service with the user's process. The paper's law re-implemented on the Rust and
//! the Python SDK reproduces the built-in run byte for byte, a law the project does not have
//! runs to completion, and a controller that crashes, hangs, repeats itself or sends malformed
//! commands is named, the complete steps are kept, `complete: false`, and the exit is non-zero.
use crate::common;

use common::{json, ok, platoon, platoon_command, repo};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The bridge's Python (creating the venv on first use, as .ci/run does).
fn python() -> String {
    static PYTHON: OnceLock<String> = OnceLock::new();
    PYTHON
        .get_or_init(|| {
            let o = Command::new(repo().join("bridge/setup-venv.sh"))
                .output()
                .unwrap();
            assert!(
                o.status.success(),
                "bridge/setup-venv.sh failed: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            repo().join("bridge/.venv/bin/python").display().to_string()
        })
        .clone()
}

/// `bridge/examples/<name> ARGS` run by the bridge's Python, as `--controller` takes it.
fn py_example(name: &str, args: &str) -> String {
    format!(
        "{} {} {args}",
        python(),
        repo().join("bridge/examples").join(name).display()
    )
}

/// An example of the Rust controller SDK (crates/controller-sdk/examples), built here once (a
/// no-op when it is fresh) so that the test never runs a stale one.
fn sdk_example(name: &str) -> String {
    static BUILT: OnceLock<()> = OnceLock::new();
    BUILT.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let o = Command::new(cargo)
            .current_dir(repo())
            .args(["build", "--workspace", "--examples", "--locked"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "building the controller SDK's examples: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    });
    let exe = Path::new(env!("CARGO_BIN_EXE_platoon"))
        .parent()
        .unwrap()
        .join("examples")
        .join(name);
    assert!(exe.exists(), "{} is missing", exe.display());
    exe.display().to_string()
}

/// `platoon run configs/<config> --no-plots --out <out> EXTRA` in `dir`.
fn run_in(dir: &Path, config: &str, out: &str, extra: &[&str]) -> Output {
    let c = repo().join("configs").join(config);
    let mut args = vec!["run", c.to_str().unwrap(), "--no-plots", "--out", out];
    args.extend_from_slice(extra);
    platoon(&args, dir)
}

/// The per-step files and the summary of two runs are equal byte for byte, but for the
/// summary's `controller` key, which says what each ran.
fn same_run_but_the_controller(a: &Path, b: &Path) {
    for f in ["trajectories.csv", "events.csv", "wire.csv", "channel.csv"] {
        let (x, y) = (std::fs::read(a.join(f)), std::fs::read(b.join(f)));
        assert!(
            x.is_ok() && x.as_ref().ok() == y.as_ref().ok(),
            "{f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
    let (mut sa, mut sb) = (json(&a.join("summary.json")), json(&b.join("summary.json")));
    assert_ne!(sa["controller"], sb["controller"]);
    sa["controller"] = serde_json::Value::Null;
    sb["controller"] = serde_json::Value::Null;
    assert_eq!(sa, sb);
}

/// The paper's law re-implemented on the Rust SDK (and the config's own controllers run as a
/// plug-in) reproduces the built-in run of the paper scenario, its DoS included, byte for byte.
#[test]
fn the_paper_law_on_the_rust_sdk_reproduces_the_builtin_run_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    ok(&run_in(tmp.path(), "paper.toml", "builtin", &[]));
    let builtin = tmp.path().join("builtin");
    for example in ["paper_law", "configured"] {
        let exe = sdk_example(example);
        ok(&run_in(
            tmp.path(),
            "paper.toml",
            example,
            &["--controller", &exe],
        ));
        let run = tmp.path().join(example);
        same_run_but_the_controller(&run, &builtin);
        assert_eq!(
            json(&run.join("summary.json"))["controller"]["program"],
            exe
        );
    }
    // The paper's run has broadcasts, attacks and both modes: a law that got any of them
    // wrong would differ.
    let s = json(&builtin.join("summary.json"));
    assert!(s["vehicles"][0]["triggers"].as_u64().unwrap() > 10);
    assert!(s["vehicles"][0]["affected_time_s"].as_f64().unwrap() > 1.0);
}

/// The same law re-implemented in Python (bridge/examples/paper_law.py), from the config's
/// numbers: the paper scenario byte for byte, and a run with link attacks (loss, delays,
/// replays: its packet checks refuse what the built-in ones refuse) too.
#[test]
fn the_paper_law_on_the_python_sdk_reproduces_the_builtin_run_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let law = py_example("paper_law.py", "");
    for config in ["paper.toml", "link-attacks.toml"] {
        ok(&run_in(tmp.path(), config, "builtin", &["--force"]));
        ok(&run_in(
            tmp.path(),
            config,
            "python",
            &["--force", "--controller", &law],
        ));
        same_run_but_the_controller(&tmp.path().join("python"), &tmp.path().join("builtin"));
    }
    let s = json(&tmp.path().join("python/summary.json"));
    assert!(
        s["rejected_packets"]["stale_seq"].as_u64().unwrap() > 0,
        "the link attacks make the checks refuse packets: {}",
        s["rejected_packets"]
    );
}

/// A law the project does not have (bridge/examples/sliding_mode.py, a sliding-mode CACC on
/// the radar and the predecessor's broadcasts) runs the paper scenario to completion, keeps
/// the platoon together through the DoS, and reports its own degraded mode.
#[test]
fn a_sliding_mode_law_on_the_python_sdk_runs_to_completion() {
    let tmp = tempfile::tempdir().unwrap();
    let law = py_example("sliding_mode.py", "");
    ok(&run_in(
        tmp.path(),
        "paper.toml",
        "smc",
        &["--controller", &law],
    ));
    let s = json(&tmp.path().join("smc/summary.json"));
    assert_eq!(s["complete"], true);
    assert_eq!(s["steps"], 5501);
    assert_eq!(s["safety"]["collided"], false);
    for v in s["vehicles"].as_array().unwrap() {
        // Every follower broadcasts at every step; it tracks within a few metres.
        assert_eq!(v["triggers"], 5501, "{v}");
        assert!(
            v["spacing_error_m"]["max_abs"].as_f64().unwrap() < 15.0,
            "{v}"
        );
        // Without its predecessor's packets during the DoS it says it is on its radar alone.
        assert!(v["mode_time_s"]["acc"].as_f64().unwrap() > 5.0, "{v}");
    }
}

/// A faulty controller (bridge/examples/radar_controller.py, on the raw protocol) stops a long
/// run: returns the run's stderr and summary.
fn faulty(fault: &str, step_timeout: &str) -> (String, serde_json::Value, PathBuf) {
    let tmp = tempfile::tempdir().unwrap().keep();
    let base = std::fs::read_to_string(repo().join("configs/table1.toml")).unwrap();
    let config = tmp.join("long.toml");
    std::fs::write(
        &config,
        base.replace("duration_s = 55.0", "duration_s = 600.0"),
    )
    .unwrap();
    let controller = py_example("radar_controller.py", fault);
    let o = platoon_command(&tmp)
        .args([
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            "r",
            "--controller",
            &controller,
            "--step-timeout",
            step_timeout,
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "the run must fail: {stderr}");
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    let run = tmp.join("r");
    assert!(!tmp.join("r.partial").exists());
    let s = json(&run.join("summary.json"));
    assert_eq!(s["complete"], false);
    // Every complete step is kept: one row per vehicle and step.
    let rows = std::fs::read_to_string(run.join("trajectories.csv")).unwrap();
    assert_eq!(
        rows.lines().count() as u64,
        1 + 5 * s["steps"].as_u64().unwrap(),
        "{stderr}\n{s}"
    );
    (stderr, s, tmp)
}

#[test]
fn a_controller_that_crashes_is_named_by_its_exit() {
    // Its exit, quoting its log, not the step timeout's "published nothing" (20 s here).
    let (stderr, s, dir) = faulty("--crash-at 5", "20");
    let error = s["error"].as_str().unwrap();
    for text in [&stderr, error] {
        assert!(
            text.contains("the controller process") && text.contains("exited at step 5"),
            "{text}"
        );
        assert!(
            text.contains("the last lines of logs/controller.log")
                && text.contains("| radar_controller: crashing at step 5"),
            "{text}"
        );
    }
    assert_eq!(s["steps"], 5);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_controller_that_hangs_is_named_after_the_step_timeout() {
    common::TIMEOUTS.run("controller hangs");
}

pub(crate) fn a_controller_that_hangs() {
    // 20 s, the suite's: a live controller starved by a busy machine is never taken for a hung
    // one before step 50.
    let (stderr, s, dir) = faulty("--hang-at 50", "20");
    let error = s["error"].as_str().unwrap();
    assert!(
        error.contains("the controller process published nothing for step 50 within 20 s")
            && error.contains("logs/controller.log")
            && error.contains("--step-timeout"),
        "{error}"
    );
    assert!(stderr.contains(error), "{stderr}");
    assert_eq!(s["steps"], 50);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_controller_repeating_one_step_is_named_after_the_step_timeout() {
    common::TIMEOUTS.run("controller repeats");
}

pub(crate) fn a_controller_repeating_one_step() {
    let (_, s, dir) = faulty("--spam-at 60", "20");
    let error = s["error"].as_str().unwrap();
    // commands[60] arrived (again and again): steps 0..=60 are recorded, 61 never comes.
    assert_eq!(s["steps"], 61);
    assert!(
        error.contains("the controller process published nothing for step 61")
            && error.contains("duplicate samples"),
        "{error}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn malformed_commands_are_named_and_the_steps_before_them_kept() {
    for (fault, step, needle) in [
        ("--wrong-ids-at 70", 70, "command 0 is for vehicle 0"),
        ("--nan-at 80", 80, "with u = NaN"),
        // An unknown mode code is an error, never read as the cooperative law.
        ("--bad-mode-at 90", 90, "mode code 12 names no mode"),
    ] {
        let (stderr, s, dir) = faulty(fault, "20");
        let error = s["error"].as_str().unwrap();
        assert!(
            error.starts_with(&format!("controller: step {step}: ")) && error.contains(needle),
            "{error}"
        );
        assert!(stderr.contains(error), "{stderr}");
        assert_eq!(s["steps"], step, "{error}");
        let _ = std::fs::remove_dir_all(dir);
    }
}

/// A controller that cannot run this config says why before the run starts (the Rust SDK
/// reports its builder's error), and `--controller` needs processes.
#[test]
fn a_controller_that_refuses_the_config_and_an_inproc_controller_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let law = sdk_example("paper_law");
    let o = run_in(tmp.path(), "degradation.toml", "r", &["--controller", &law]);
    assert!(!o.status.success());
    let s = json(&tmp.path().join("r/summary.json"));
    let error = s["error"].as_str().unwrap();
    // It reports FAILED, then exits: its report is the run's error, never its exit, however
    // late the orchestrator looks (on a loaded machine the exit can win the race).
    assert!(
        error.contains("the controller process failed at step 0")
            && error.contains("paper_law does not implement this config's")
            && error.contains("logs/controller.log")
            && !error.contains("exited"),
        "{error}"
    );
    assert_eq!(s["steps"], 0);
    let o = run_in(
        tmp.path(),
        "paper.toml",
        "x",
        &["--transport", "inproc", "--controller", &law],
    );
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--controller needs --transport iceoryx2"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!tmp.path().join("x").exists());
}

/// A misbehaviour detector written in Python (bridge/examples/speed_check.py, a
/// position-speed consistency check on the paper's law) is measured against ground truth like
/// the built-in ones: named in `[detection] plugin`, its verdicts travel on the `inspections`
/// service and the orchestrator joins them with what happened on the wire. On clean traffic it
/// stays under 1 % false alarms; it catches a leader lying about its speed within a step; it
/// only logs, so the run is the one of the same law without a detector; and a run naming a
/// plug-in's detector without a plug-in is refused, naming the key.
#[test]
fn a_python_detector_on_the_controller_sdk_is_measured_against_ground_truth() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = std::fs::read_to_string(repo().join("configs/paper.toml")).unwrap();
    let base = &paper[..paper.find("[attack]").expect("paper.toml has [attack]")];
    let detection = "\n[detection]\nplugin = [\"pos_speed\"]\n";
    let lie = "\n[[channel.attacks]]\nkind = \"false_data\"\noffset = [0.0, 3.0, 0.0]\n\
               senders = [0]\nstart_s = 20.0\ninsider = true\n";
    let write = |name: &str, text: String| {
        let p = tmp.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    let clean = write(
        "clean.toml",
        format!("{base}[attack]\nkind = \"none\"\n{detection}"),
    );
    let lying = write(
        "lie.toml",
        format!("{base}[attack]\nkind = \"none\"\n{lie}{detection}"),
    );
    let check = py_example("speed_check.py", "");
    let run = |config: &str, out: &str, controller: &str| {
        // The lying run draws its plots: modes.png shows the flags.
        let mut args = vec!["run", config, "--out", out];
        if out != "lie" {
            args.push("--no-plots");
        }
        if !controller.is_empty() {
            args.extend(["--controller", controller]);
        }
        platoon(&args, tmp.path())
    };

    ok(&run(&clean, "clean", &check));
    let d = &json(&tmp.path().join("clean/summary.json"))["detection"];
    let s = &d["detectors"][0];
    assert_eq!(s["name"], "pos_speed", "{d}");
    assert!(d["inspected"].as_u64().unwrap() > 10_000, "{d}");
    assert_eq!(
        d["labels"].as_object().unwrap().len(),
        1,
        "only genuine: {d}"
    );
    assert!(s["false_alarm_rate"].as_f64().unwrap() < 0.01, "{s}");

    ok(&run(&lying, "lie", &check));
    let out = tmp.path().join("lie");
    let d = &json(&out.join("summary.json"))["detection"];
    let s = &d["detectors"][0];
    let lied = &s["by_label"]["altered"];
    assert!(lied["tp"].as_u64().unwrap() > 1000, "{s}");
    assert!(
        lied["tp"].as_f64().unwrap()
            / (lied["tp"].as_f64().unwrap() + lied["fn"].as_f64().unwrap())
            > 0.99,
        "{s}"
    );
    assert!(s["time_to_detect_s"].as_f64().unwrap() <= 0.01, "{s}");
    // Nobody left the cooperative law: modes.png is drawn for the flags alone, and events.csv
    // has a row per flagged packet.
    assert!(out.join("modes.png").exists());
    let events = std::fs::read_to_string(out.join("events.csv")).unwrap();
    assert_eq!(
        events.lines().filter(|l| l.contains(",flagged,")).count() as u64,
        d["flagged"].as_u64().unwrap()
    );
    // The per-message dataset: a row per delivery, those inspected the summary's, with its
    // flags.
    let rows = std::fs::read_to_string(out.join("detections.csv")).unwrap();
    let head: Vec<&str> = rows.lines().next().unwrap().split(',').collect();
    let inspected = head.iter().position(|h| *h == "inspected").unwrap();
    assert_eq!(
        rows.lines()
            .skip(1)
            .filter(|l| l.split(',').nth(inspected) == Some("true"))
            .count() as u64,
        d["inspected"].as_u64().unwrap()
    );
    assert_eq!(
        rows.lines().filter(|l| l.contains(",true,false,")).count() as u64,
        d["flagged"].as_u64().unwrap(),
        "flagged and not refused"
    );

    // Logging changes nothing: the same law without the detector runs the same; a controller
    // that inspects nothing reports nothing.
    ok(&run(&lying, "law", &py_example("paper_law.py", "")));
    let law = tmp.path().join("law");
    assert_eq!(
        std::fs::read(out.join("trajectories.csv")).unwrap(),
        std::fs::read(law.join("trajectories.csv")).unwrap()
    );
    assert_eq!(json(&law.join("summary.json"))["detection"]["inspected"], 0);

    // A raw-protocol controller that knows nothing of inspections still runs with
    // [detection]: it inspected nothing.
    ok(&run(&lying, "raw", &py_example("radar_controller.py", "")));
    assert_eq!(
        json(&tmp.path().join("raw/summary.json"))["detection"]["inspected"],
        0
    );

    let o = run(&lying, "none", "");
    // A config this run cannot measure is a bad config: exit 2.
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("detection.plugin") && e.contains("--controller"),
        "{e}"
    );
    assert!(!tmp.path().join("none").exists(), "nothing written");
}

/// A plug-in written into `dir` as `name` (on the Python SDK: the run puts the bridge on its
/// PYTHONPATH), as `--controller` takes it.
fn py_plugin(dir: &Path, name: &str, code: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, code).unwrap();
    format!("{} {}", python(), path.display())
}

/// `platoon run configs/table1.toml` with `--controller` and `extra` in `dir` (into `r`): the
/// exit code, the summary's error and stderr.
fn failing(dir: &Path, controller: &str, extra: &[&str]) -> (Option<i32>, String, String) {
    let mut args = vec!["--controller", controller];
    args.extend_from_slice(extra);
    let o = run_in(dir, "table1.toml", "r", &args);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let s = json(&dir.join("r/summary.json"));
    assert_eq!(s["complete"], false, "{stderr}");
    let error = s["error"].as_str().unwrap().to_string();
    assert!(stderr.contains(&error), "{stderr}");
    for text in [&error, &stderr] {
        assert!(
            !text.contains(['\x1b', '\r', '\0']),
            "raw control characters: {text:?}"
        );
    }
    (o.status.code(), error, stderr)
}

/// An exception in a Python controller is the run's error, its message made
/// printable (an escape sequence in it reaches neither the terminal nor summary.json), and the
/// error names the log, which holds the whole traceback.
#[test]
fn an_exception_in_a_python_controller_is_named_with_its_traceback_in_the_log() {
    let tmp = tempfile::tempdir().unwrap();
    let boom = py_plugin(
        tmp.path(),
        "boom.py",
        r#"import sys
import platoon.controller as pc


def explode(k):
    raise ValueError(f"boom at {k} \x1b[31mred\x1b[0m")


class Boom(pc.Controller):
    def __init__(self, run):
        self.n = run.vehicles_per_platoon - 1

    def transmit(self, step, tx):
        if step.k == 3:
            explode(step.k)

    def receive(self, step, commands):
        commands.extend([0.0] * self.n)


sys.exit(pc.run(lambda run, j: Boom(run)))
"#,
    );
    let (code, error, _) = failing(tmp.path(), &boom, &[]);
    assert_eq!(code, Some(1));
    assert!(
        error.starts_with(
            "the controller process failed at step 3: ValueError: boom at 3 \\u{1b}[31mred"
        ) && error.contains("its whole report is in logs/controller.log"),
        "{error}"
    );
    assert_eq!(json(&tmp.path().join("r/summary.json"))["steps"], 3);
    let log = std::fs::read_to_string(tmp.path().join("r/logs/controller.log")).unwrap();
    assert!(
        log.contains("Traceback (most recent call last)")
            && log.contains("in transmit")
            && log.contains("in explode")
            && log.contains("ValueError: boom at 3"),
        "{log}"
    );
}

/// A plug-in that dies without a report is named by its exit, quoting its log's last
/// lines made printable: invalid UTF-8 as U+FFFD, control characters as escapes.
#[test]
fn a_plugin_that_dies_is_quoted_printably() {
    let tmp = tempfile::tempdir().unwrap();
    let junk = py_plugin(
        tmp.path(),
        "junk.py",
        r#"import os, sys
sys.stderr.buffer.write(b"dying \xff\xfe with \x1b[2J junk\r\n")
sys.stderr.flush()
os._exit(3)
"#,
    );
    let (code, error, _) = failing(tmp.path(), &junk, &[]);
    assert_eq!(code, Some(1));
    assert!(
        error.contains("exited at step 0: exit status: 3")
            && error.contains("the last lines of logs/controller.log")
            && error.contains("| dying \u{fffd}\u{fffd} with \\u{1b}[2J junk"),
        "{error}"
    );
}

/// A plug-in that never reports READY is named after `--ready-timeout` (not a fixed
/// minute), with its log, and stopped. 20 s: the built-in plant and injector are ready long
/// before, even on a busy machine, so the controller is the one named.
#[test]
fn a_plugin_that_never_reports_ready_is_named_after_the_ready_timeout() {
    common::TIMEOUTS.run("controller never ready");
}

pub(crate) fn a_plugin_that_never_reports_ready() {
    let tmp = tempfile::tempdir().unwrap();
    let (code, error, _) = failing(tmp.path(), "sleep 600", &["--ready-timeout", "20"]);
    assert_eq!(code, Some(1));
    assert!(
        error.starts_with(
            "the controller process published nothing for step 0 within 20 s (it never \
             reported READY)"
        ) && error.contains("it wrote nothing to logs/controller.log")
            && error.contains("--ready-timeout"),
        "{error}"
    );
    let o = run_in(tmp.path(), "table1.toml", "z", &["--ready-timeout", "0"]);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--ready-timeout must be a positive"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!tmp.path().join("z").exists());
}

/// The built-in detectors are Rust; a Python controller cannot run them. A run that
/// turns them on with a Python controller is refused before step 0, naming them, instead of
/// scoring them as having missed every packet.
#[test]
fn a_python_controller_refuses_the_builtin_detectors() {
    let tmp = tempfile::tempdir().unwrap();
    let table1 = std::fs::read_to_string(repo().join("configs/table1.toml")).unwrap();
    let config = tmp.path().join("detect.toml");
    std::fs::write(
        &config,
        format!("{table1}\n[detection]\n[detection.plausibility]\n[detection.residual]\n"),
    )
    .unwrap();
    let law = py_example("sliding_mode.py", "");
    let o = platoon(
        &[
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            "r",
            "--controller",
            &law,
        ],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(1));
    let s = json(&tmp.path().join("r/summary.json"));
    let error = s["error"].as_str().unwrap();
    assert!(
        error.starts_with(
            "the controller process failed at step 0: the Python SDK cannot run built-in \
             detectors: plausibility, residual"
        ) && error.contains("logs/controller.log"),
        "{error}"
    );
    assert!(s["detection"].is_null(), "nothing was measured: {s}");
    let log = std::fs::read_to_string(tmp.path().join("r/logs/controller.log")).unwrap();
    assert!(
        log.contains("[detection.plausibility], [detection.residual]"),
        "{log}"
    );
}
