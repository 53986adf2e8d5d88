//! The iceoryx2 co-simulation end to end: it matches the in-process oracle bit for bit, a
//! Python injector can take the built-in one's place, and a dead or silent process stops the run
//! with its name, keeps what was recorded, and leaves nothing running.
use crate::common;

use common::{
    json, ok, platoon, platoon_command, published, repo, wait_for, without_paper_law_keys, PATIENCE,
};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The bridge's Python (creating the venv on first use, as .ci/run does).
fn python() -> String {
    let setup = repo().join("bridge/setup-venv.sh");
    let o = Command::new(&setup).output().unwrap();
    assert!(
        o.status.success(),
        "bridge/setup-venv.sh failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    repo().join("bridge/.venv/bin/python").display().to_string()
}

/// `bridge/examples/<name> ARGS` run by the bridge's Python, as `--injector` takes it.
fn py_example(name: &str, args: &str) -> String {
    format!(
        "{} {} {args}",
        python(),
        repo().join("bridge/examples").join(name).display()
    )
}

fn drop_sender(args: &str) -> String {
    py_example("drop_sender.py", args)
}

const COMPARED: [&str; 5] = [
    "trajectories.csv",
    "events.csv",
    "channel.csv",
    "wire.csv",
    "summary.json",
];

fn summary(run: &Path) -> serde_json::Value {
    json(&run.join("summary.json"))
}

fn same_outputs(a: &Path, b: &Path, files: &[&str]) {
    for f in files {
        let x = std::fs::read(a.join(f)).unwrap();
        let y = std::fs::read(b.join(f)).unwrap();
        assert!(
            x == y,
            "{f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// Runs `config` over both transports (into `ipc/` and `inproc/` of the returned directory) and
/// checks their outputs agree byte for byte.
fn transports_agree(config: &str) -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    let config = repo().join(config);
    let c = config.to_str().unwrap();
    for (out, transport) in [("ipc", "iceoryx2"), ("inproc", "inproc")] {
        let o = platoon(
            &[
                "run",
                c,
                "--out",
                out,
                "--no-plots",
                "--transport",
                transport,
            ],
            tmp.path(),
        );
        ok(&o);
    }
    same_outputs(
        &tmp.path().join("ipc"),
        &tmp.path().join("inproc"),
        &COMPARED,
    );
    tmp
}

#[test]
fn iceoryx2_run_of_the_paper_scenario_is_bit_identical_to_inproc() {
    let tmp = transports_agree("configs/paper.toml");
    // The run's facts, which the plug-ins read, stay in the run directory: the scenario's.
    let facts = json(&tmp.path().join("ipc/facts.json"));
    let run_json = json(&tmp.path().join("ipc/run.json"));
    assert_eq!(facts["run_id"], run_json["run_id"]);
    assert_eq!(facts["last_step"], 5500);
    assert_eq!(facts["dt_s"], 0.01);
    assert_eq!(
        (facts["platoons"].as_u64(), facts["followers"].as_u64()),
        (Some(1), Some(4))
    );
    assert_eq!(facts["plant"], "native");
    let graph = &facts["topologies"][0];
    assert_eq!(graph["pinning"], serde_json::json!([1.0, 1.0, 0.0, 0.0]));
    assert_eq!(
        graph["adjacency"][3],
        serde_json::json!([0.0, 1.0, 1.0, 0.0])
    );
    assert!(!tmp.path().join("inproc/facts.json").exists());
}

#[test]
fn iceoryx2_runs_with_every_fallback_and_the_guard_are_bit_identical_to_inproc() {
    // configs/degradation.toml: ACC on a noisy radar with dropouts, the guard, dwell and a
    // bumpless return; then one fallback per follower.
    transports_agree("configs/degradation.toml");
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/degradation.toml")).unwrap();
    let mixed = tmp.path().join("mixed.toml");
    std::fs::write(
        &mixed,
        text.replace(
            "mode = \"acc\"",
            "mode = \"acc\"\nper_vehicle = [\"acc\", \"zero\", \"hold\", \"predict\"]",
        ),
    )
    .unwrap();
    transports_agree(mixed.to_str().unwrap());
}

#[test]
fn iceoryx2_run_with_every_link_attack_is_bit_identical_to_inproc() {
    transports_agree("configs/link-attacks.toml");
    // And every model of that config did something.
    let tmp = tempfile::tempdir().unwrap();
    let c = repo().join("configs/link-attacks.toml");
    ok(&platoon(
        &["run", c.to_str().unwrap(), "--out", "r", "--no-plots"],
        tmp.path(),
    ));
    let log = std::fs::read_to_string(tmp.path().join("r/channel.csv")).unwrap();
    for action in [
        "dropped_loss",
        "dropped_jammed",
        "delayed",
        "delivered_late",
        "replayed",
        "altered",
    ] {
        assert!(log.contains(action), "no {action} in channel.csv");
    }
    let s = summary(&tmp.path().join("r"));
    assert!(
        s["rejected_packets"]["stale_seq"].as_u64().unwrap() > 0,
        "replayed packets must be refused as stale"
    );
}

#[test]
fn python_injector_dropping_a_sender_equals_the_builtin_with_total_loss_on_it() {
    let tmp = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(repo().join("configs/table1.toml")).unwrap();
    let lossy = tmp.path().join("lossy.toml");
    std::fs::write(
        &lossy,
        base + "\n[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 1.0\nsenders = [2]\n",
    )
    .unwrap();
    let table1 = repo().join("configs/table1.toml");
    ok(&platoon(
        &[
            "run",
            table1.to_str().unwrap(),
            "--out",
            "py",
            "--no-plots",
            "--injector",
            &drop_sender("2"),
        ],
        tmp.path(),
    ));
    ok(&platoon(
        &[
            "run",
            lossy.to_str().unwrap(),
            "--out",
            "rust",
            "--no-plots",
            "--transport",
            "inproc",
        ],
        tmp.path(),
    ));
    same_outputs(
        &tmp.path().join("py"),
        &tmp.path().join("rust"),
        &["trajectories.csv", "events.csv"],
    );
    // Nothing the Python injector sent was malformed (this caught the byte-length slices of
    // iceoryx2 0.10.0's Python bindings, iceoryx2 #1533).
    let s = summary(&tmp.path().join("py"));
    // The wire report says what the third-party injector did: every packet of vehicle 2 was
    // dropped (its receivers 3 and 4 lost them), nothing else, no jamming.
    let wire = &s["wire"]["per_vehicle"];
    for v in [3, 4] {
        assert!(wire[v]["dropped"].as_u64().unwrap() > 0, "{}", wire[v]);
    }
    for v in [1, 2] {
        assert_eq!(wire[v]["dropped"], 0, "{}", wire[v]);
    }
    assert_eq!(s["wire"]["totals"]["jammed"], 0);
    assert_eq!(s["wire"]["totals"]["altered"], 0);
    assert_eq!(
        s["attack"]["applied"], false,
        "replaced: platoon applied no attack"
    );
    assert!(s["injector"]["program"]
        .as_str()
        .unwrap()
        .contains("drop_sender.py"));
    assert!(std::fs::read_to_string(tmp.path().join("py/wire.csv"))
        .unwrap()
        .starts_with(
            "step,t,platoon,vehicle,sent,delivered_as_sent,altered,dropped,injected,jammed"
        ));
    for reason in [
        "non_finite",
        "unknown_sender",
        "future_step",
        "stale_seq",
        "implausible_seq",
        "implausible_state",
    ] {
        assert_eq!(s["rejected_packets"][reason], 0, "{reason}");
    }
    // Its effect is visible: with vehicle 2 silenced, follower 3 (its only predecessor link
    // besides the leader's) tracks worse than without the attack.
    ok(&platoon(
        &[
            "run",
            table1.to_str().unwrap(),
            "--out",
            "clean",
            "--no-plots",
        ],
        tmp.path(),
    ));
    let err = |dir: &str| {
        summary(&tmp.path().join(dir))["vehicles"][2]["spacing_error_m"]["mean_abs"]
            .as_f64()
            .unwrap()
    };
    assert!(
        err("py") > err("clean"),
        "{} vs {}",
        err("py"),
        err("clean")
    );
}

#[test]
fn hostile_packets_are_refused_and_counted_and_change_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let table1 = repo().join("configs/table1.toml");
    // With a forged copy of a genuine packet of follower 1 whose sequence number is near the
    // maximum (accepted, it would lock follower 1 out for the rest of the run).
    let hostile = py_example("hostile.py", "--forge-seq-at 1000");
    ok(&platoon(
        &[
            "run",
            table1.to_str().unwrap(),
            "--out",
            "hostile",
            "--no-plots",
            "--injector",
            &hostile,
        ],
        tmp.path(),
    ));
    ok(&platoon(
        &[
            "run",
            table1.to_str().unwrap(),
            "--out",
            "clean",
            "--no-plots",
            "--transport",
            "inproc",
        ],
        tmp.path(),
    ));
    same_outputs(
        &tmp.path().join("hostile"),
        &tmp.path().join("clean"),
        &["trajectories.csv", "events.csv"],
    );
    let s = summary(&tmp.path().join("hostile"));
    // One of each every 50 steps from step 25: 110 rounds in 5501 steps.
    for reason in ["non_finite", "unknown_sender", "future_step", "stale_seq"] {
        assert_eq!(s["rejected_packets"][reason], 110, "{reason}");
    }
    assert_eq!(s["rejected_packets"]["implausible_seq"], 1);
    assert_eq!(s["rejected_packets"]["implausible_state"], 0);
}

/// The layout tests of the bridge's pytest (the whole of bridge/tests is .ci/run's pytest stage,
/// once; this test is what `cargo test` alone checks of the Python mirror).
#[test]
fn python_layout_mirror_matches_the_rust_layout() {
    let o = Command::new(python())
        .args(["-m", "pytest", "-q", "bridge/tests/test_layout.py"])
        .current_dir(repo())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "pytest failed:\n{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn two_concurrent_runs_do_not_see_each_other() {
    let tmp = tempfile::tempdir().unwrap();
    let c = repo().join("configs/paper.toml");
    let spawn = |out: &str| {
        platoon_command(tmp.path())
            .args(["run", c.to_str().unwrap(), "--out", out, "--no-plots"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn("a"), spawn("b"));
    ok(&a.wait_with_output().unwrap());
    ok(&b.wait_with_output().unwrap());
    same_outputs(&tmp.path().join("a"), &tmp.path().join("b"), &COMPARED);
}

/// The pids of processes whose command line mentions `needle`.
fn pids_with(needle: &str) -> Vec<u32> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        if let Ok(cmd) = std::fs::read(e.path().join("cmdline")) {
            if String::from_utf8_lossy(&cmd).contains(needle) {
                out.push(pid);
            }
        }
    }
    out
}

/// Waits (at most [`PATIENCE`]) until `child` exits, its stderr read meanwhile; one that does
/// not is killed and the test fails saying what it waited for.
fn finish(mut child: Child, what: &str) -> (std::process::ExitStatus, String) {
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut text).unwrap();
        text
    });
    let deadline = Instant::now() + PATIENCE;
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() >= deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("waited {PATIENCE:?} for {what}: {}", reader.join().unwrap());
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    (status, reader.join().unwrap())
}

/// Waits until no process mentions `needle` (the run's directory) any more.
fn no_process_left(needle: &str) {
    let deadline = Instant::now() + PATIENCE;
    while !pids_with(needle).is_empty() {
        assert!(
            Instant::now() < deadline,
            "processes left running {PATIENCE:?} after the run: {:?}",
            pids_with(needle)
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The steps of [`start_long_run`]'s run: it never ends by itself within a test, in any build
/// on any machine, so every test stops it on purpose.
const LONG_STEPS: u64 = 100_000_001;

/// table1.toml, long on purpose (a million simulated seconds, [`LONG_STEPS`] steps), its
/// outputs kept in CSV (`auto` would switch to Parquet for a run this long).
fn long_config(dir: &Path) -> PathBuf {
    let base = std::fs::read_to_string(repo().join("configs/table1.toml")).unwrap();
    assert!(base.contains("duration_s = 55.0") && base.contains("dt_s = 0.01"));
    let config = dir.join("long.toml");
    std::fs::write(
        &config,
        base.replace("duration_s = 55.0", "duration_s = 1000000.0")
            + "\n[output]\nformat = \"csv\"\n",
    )
    .unwrap();
    config
}

/// A run long on purpose ([`long_config`]) to kill processes of or interrupt.
fn start_long_run(dir: &Path, extra: &[&str]) -> (Child, PathBuf) {
    let config = long_config(dir);
    let mut args = vec![
        "run",
        config.to_str().unwrap(),
        "--out",
        "run",
        "--no-plots",
    ];
    args.extend_from_slice(extra);
    let child = platoon_command(dir)
        .args(&args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    (child, dir.join("run"))
}

/// Waits until the run is recording steps (trajectories.csv is growing).
fn wait_until_running(run: &Path) {
    let csv = run.with_extension("partial").join("trajectories.csv");
    wait_for("the run to record 100 kB of trajectories.csv", || {
        std::fs::metadata(&csv).map(|m| m.len()).unwrap_or(0) >= 100_000
    });
}

/// The run (long on purpose) stops because of the fault, naming `node`, keeps whole rows and
/// leaves no process behind.
fn assert_stopped_naming(child: Child, run: &Path, node: &str, needle: &str) {
    let (status, stderr) = finish(child, &format!("the run to stop after the {node}'s fault"));
    assert!(!status.success(), "the run must fail");
    assert!(
        stderr.contains(&format!("the {node} process")),
        "the error must name the {node}: {stderr}"
    );
    let summary = summary(run);
    assert_eq!(summary["complete"], false);
    assert!(summary["error"].as_str().unwrap().contains(node));
    let steps = summary["steps"].as_u64().unwrap();
    assert!(steps > 0, "what was recorded is kept");
    assert!(
        steps < LONG_STEPS,
        "stopped by the fault, not the end: {steps}"
    );
    let rows = std::fs::read_to_string(run.join("trajectories.csv")).unwrap();
    assert_eq!(
        rows.lines().count() as u64,
        1 + 5 * summary["steps"].as_u64().unwrap()
    );
    assert!(!run.with_extension("partial").exists());
    no_process_left(needle);
}

fn kill_node(role: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let (child, run) = start_long_run(tmp.path(), &[]);
    wait_until_running(&run);
    let needle = run.with_extension("partial").display().to_string();
    let victims: Vec<u32> = pids_with(&needle)
        .into_iter()
        .filter(|p| {
            let cmd = std::fs::read(format!("/proc/{p}/cmdline")).unwrap_or_default();
            String::from_utf8_lossy(&cmd).contains(&format!("node\0{role}\0"))
        })
        .collect();
    assert_eq!(victims.len(), 1, "one {role} process");
    Command::new("kill")
        .args(["-9", &victims[0].to_string()])
        .status()
        .unwrap();
    assert_stopped_naming(child, &run, role, &needle);
    // Nothing stale stops the next run.
    ok(&platoon(
        &[
            "run",
            repo().join("configs/table1.toml").to_str().unwrap(),
            "--out",
            "next",
            "--no-plots",
        ],
        tmp.path(),
    ));
}

#[test]
fn killing_the_plant_stops_the_run_and_names_it() {
    kill_node("plant");
}

#[test]
fn killing_the_controller_stops_the_run_and_names_it() {
    kill_node("controller");
}

#[test]
fn killing_the_injector_stops_the_run_and_names_it() {
    kill_node("injector");
}

/// The step timeout of the stall tests: the suite's own (tests/common), so that only the stall
/// can reach it; a second would also catch a process merely starved on a busy machine before
/// the stall, and name the wrong step.
const STALL_TIMEOUT: &str = "20";

#[test]
fn an_injector_that_stops_publishing_is_named_after_the_timeout() {
    common::TIMEOUTS.run("injector stops");
}

pub(crate) fn an_injector_that_stops_publishing() {
    let tmp = tempfile::tempdir().unwrap();
    let injector = drop_sender("--stall-at 300");
    let (child, run) = start_long_run(
        tmp.path(),
        &["--injector", &injector, "--step-timeout", STALL_TIMEOUT],
    );
    let needle = run.with_extension("partial").display().to_string();
    assert_stopped_naming(child, &run, "injector", &needle);
    let summary = summary(&run);
    assert_eq!(summary["steps"], 300);
    let error = summary["error"].as_str().unwrap();
    assert!(
        error.contains("step 300") && error.contains(&format!("within {STALL_TIMEOUT} s")),
        "{error}"
    );
}

/// An injector that keeps re-publishing rx[k] is named after the step timeout: only a
/// completed step counts as progress, so repeated samples cannot make the run wait forever.
#[test]
fn an_injector_repeating_one_step_is_named_after_the_timeout() {
    common::TIMEOUTS.run("injector repeats");
}

pub(crate) fn an_injector_repeating_one_step() {
    let tmp = tempfile::tempdir().unwrap();
    let injector = drop_sender("--repeat-at 200");
    let (child, run) = start_long_run(
        tmp.path(),
        &["--injector", &injector, "--step-timeout", STALL_TIMEOUT],
    );
    let needle = run.with_extension("partial").display().to_string();
    assert_stopped_naming(child, &run, "injector", &needle);
    let summary = summary(&run);
    // rx[200] arrived (again and again): steps 0..=200 are recorded, 201 never comes.
    assert_eq!(summary["steps"], 201);
    let error = summary["error"].as_str().unwrap();
    assert!(error.contains("step 201"), "{error}");
    assert!(error.contains("duplicate samples"), "{error}");
}

/// A malformed sample at step 100 stops the run, and every step that was complete before it
/// is recorded (none lost, as stopping at step 97 would).
#[test]
fn a_malformed_sample_stops_the_run_after_recording_every_complete_step() {
    let tmp = tempfile::tempdir().unwrap();
    let config = repo().join("configs/table1.toml");
    let hostile = py_example("hostile.py", "--bad-count-at 100");
    let o = platoon(
        &[
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            "r",
            "--injector",
            &hostile,
        ],
        tmp.path(),
    );
    assert!(!o.status.success());
    let s = summary(&tmp.path().join("r"));
    assert_eq!(s["complete"], false);
    assert_eq!(s["steps"], 100, "{}", s["error"]);
    let error = s["error"].as_str().unwrap();
    assert!(
        error.contains("step 100") && error.contains("items"),
        "{error}"
    );
    let rows = std::fs::read_to_string(tmp.path().join("r/trajectories.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 5 * 100);
}

/// Duplicates that do not stall the run are dropped, counted and reported.
#[test]
fn duplicate_samples_are_counted_and_change_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let config = repo().join("configs/table1.toml");
    let dup = tmp.path().join("dup");
    let o = platoon(
        &[
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            dup.to_str().unwrap(),
            "--injector",
            &drop_sender("--duplicates 2"),
        ],
        tmp.path(),
    );
    ok(&o);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("repeated a step"), "{stderr}");
    let timing = json(&dup.join("timing.json"));
    assert!(
        timing["duplicate_samples"]["rx"].as_u64().unwrap() > 0,
        "{timing}"
    );
    assert_eq!(timing["duplicate_samples"]["states"], 0);
    let plain = tmp.path().join("plain");
    ok(&platoon(
        &[
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            plain.to_str().unwrap(),
            "--injector",
            &drop_sender(""),
        ],
        tmp.path(),
    ));
    same_outputs(&dup, &plain, &["trajectories.csv", "events.csv"]);
    same_summary_but_the_injector(&dup, &plain);
}

/// Ctrl-C and SIGTERM leave no `.partial` with a half-written CSV row and no summary:
/// the run stops its processes, keeps whole rows, writes summary.json with
/// `complete: false` and the reason, moves the directory into place and exits 128 + signal.
fn interrupted_run_is_kept_whole(signal: i32, transport: &str, code: i32, name: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let (child, run) = start_long_run(tmp.path(), &["--transport", transport]);
    wait_until_running(&run);
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as libc::pid_t, signal) };
    let (status, stderr) = finish(child, &format!("the run to stop on {name}"));
    assert_eq!(status.code(), Some(code), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(!run.with_extension("partial").exists(), "moved into place");
    let s = summary(&run);
    assert_eq!(s["complete"], false);
    let error = s["error"].as_str().unwrap();
    assert!(error.contains(name), "{error}");
    let steps = s["steps"].as_u64().unwrap();
    assert!(steps > 0 && steps < LONG_STEPS, "{steps}");
    let rows = std::fs::read_to_string(run.join("trajectories.csv")).unwrap();
    assert!(rows.ends_with('\n'), "the last row is whole");
    assert_eq!(rows.lines().count() as u64, 1 + 5 * steps);
    no_process_left(&run.with_extension("partial").display().to_string());
}

#[test]
fn sigint_stops_a_co_simulation_and_keeps_what_it_recorded() {
    interrupted_run_is_kept_whole(libc::SIGINT, "iceoryx2", 130, "SIGINT");
}

#[test]
fn sigterm_stops_an_in_process_run_and_keeps_what_it_recorded() {
    interrupted_run_is_kept_whole(libc::SIGTERM, "inproc", 143, "SIGTERM");
}

/// The CSV file `name` of `run` up to step `steps` (its header, then the rows whose `step`
/// column is smaller).
fn rows_before(run: &Path, name: &str, steps: u64) -> Vec<String> {
    let text = std::fs::read_to_string(run.join(name)).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let col = header.split(',').position(|c| c == "step").unwrap();
    std::iter::once(header.to_string())
        .chain(
            lines
                .filter(|l| l.split(',').nth(col).unwrap().parse::<u64>().unwrap() < steps)
                .map(String::from),
        )
        .collect()
}

/// Observers read the run's `observe/*` copies, so two observers cannot kill a run
/// (`ExceedsMaxSupportedSubscribers` in the plant and controller). More observers than
/// there is room for are refused at attach time, a stalled, a crashed and a late one change
/// nothing, and the run's outputs equal those of a run without observers. The run is long on
/// purpose and interrupted once the late observer has seen a step, so every observer meets it
/// running whatever the machine's speed; its steps are compared with a plain run's.
#[test]
fn observers_attach_stall_crash_and_leave_without_touching_the_run() {
    let tmp = tempfile::tempdir().unwrap();
    let config = long_config(tmp.path());
    let run = tmp.path().join("observed");
    let child = platoon_command(tmp.path())
        .args([
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--observers",
            "3",
        ])
        .arg("--out")
        .arg(&run)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // An observer leaves once the run's directory is in place (the run ended), or once no step
    // came for --idle 20 s, the tests' step timeout (a run stalled that long has failed anyway).
    let observer = |extra: &[&str]| {
        Command::new(python())
            .arg(repo().join("bridge/examples/observer.py"))
            .arg(&run)
            .args(["--every", "0.1", "--idle", "20"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let attached = |c: &mut Child| {
        let mut line = String::new();
        std::io::BufRead::read_line(
            &mut std::io::BufReader::new(c.stderr.as_mut().unwrap()),
            &mut line,
        )
        .unwrap();
        assert!(line.contains("attached to run"), "{line}");
    };
    // An observer's first line of spacing errors: it saw a step of the running run.
    let observed = |c: &mut Child| {
        let mut line = String::new();
        std::io::BufRead::read_line(
            &mut std::io::BufReader::new(c.stdout.as_mut().unwrap()),
            &mut line,
        )
        .unwrap();
        assert!(line.contains("spacing errors"), "{line}");
    };
    let mut a = observer(&[]);
    attached(&mut a);
    let mut stalled = observer(&["--stall"]);
    attached(&mut stalled);
    let mut crashing = observer(&[]);
    attached(&mut crashing);
    // The room (3) is full: one more is refused, and says why.
    let extra = observer(&[]).wait_with_output().unwrap();
    assert_eq!(extra.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&extra.stderr).contains("room for 3 observers"));
    // A crash frees its place for a late observer (which removes the dead one's node first).
    crashing.kill().unwrap();
    crashing.wait().unwrap();
    let mut late = observer(&[]);
    attached(&mut late);
    observed(&mut a);
    observed(&mut late);

    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let (status, stderr) = finish(child, "the observed run to stop on SIGINT");
    assert_eq!(status.code(), Some(130), "{stderr}");
    let s = summary(&run);
    let steps = s["steps"].as_u64().unwrap();
    assert!(steps > 0 && steps < LONG_STEPS, "{steps}");
    let run_json = json(&run.join("run.json"));
    assert_eq!(run_json["observers"], 3);
    assert!(run_json["observe"]["states"]
        .as_str()
        .unwrap()
        .ends_with("/observe/states"));
    for c in [a, late] {
        let out = c.wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    stalled.kill().unwrap();
    stalled.wait().unwrap();
    // Observers changed nothing: the recorded steps are a plain run's, step for step.
    let short = tmp.path().join("short.toml");
    std::fs::write(
        &short,
        std::fs::read_to_string(&config).unwrap().replace(
            "duration_s = 1000000.0",
            &format!("duration_s = {}.0", steps / 100 + 1),
        ),
    )
    .unwrap();
    let plain = tmp.path().join("plain");
    ok(&platoon(
        &[
            "run",
            short.to_str().unwrap(),
            "--no-plots",
            "--transport",
            "inproc",
            "--out",
            plain.to_str().unwrap(),
        ],
        tmp.path(),
    ));
    for f in ["trajectories.csv", "events.csv"] {
        let (x, y) = (rows_before(&run, f, steps), rows_before(&plain, f, steps));
        assert_eq!(x.len(), y.len(), "{f}: {steps} steps");
        assert!(x == y, "{f} differs from a run without observers");
    }
    assert_eq!(
        rows_before(&run, "trajectories.csv", steps).len() as u64,
        1 + 5 * steps
    );
}

/// Two runs' summaries are equal but for `injector`, which says what each ran.
fn same_summary_but_the_injector(a: &Path, b: &Path) {
    let (mut sa, mut sb) = (summary(a), summary(b));
    assert_ne!(sa["injector"], sb["injector"]);
    sa["injector"] = serde_json::Value::Null;
    sb["injector"] = serde_json::Value::Null;
    // A replacement injector: the config's schedule was not applied by platoon.
    for s in [&mut sa, &mut sb] {
        s["attack"]["applied"] = serde_json::Value::Null;
    }
    assert_eq!(sa, sb);
}

/// An example injector of the Rust SDK (crates/injector-sdk/examples), built by
/// `cargo test --workspace`.
fn sdk_example(name: &str) -> String {
    let exe = Path::new(env!("CARGO_BIN_EXE_platoon"))
        .parent()
        .unwrap()
        .join("examples")
        .join(name);
    assert!(
        exe.exists(),
        "{} is missing: run the tests with `cargo test --workspace` (it builds the SDK's examples)",
        exe.display()
    );
    exe.display().to_string()
}

/// An injector written on the Rust SDK reproduces the built-in DoS channel byte for
/// byte (the paper scenario, its 7 attacks).
#[test]
fn a_rust_sdk_injector_reproduces_the_builtin_dos_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = repo().join("configs/paper.toml");
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec!["run", paper.to_str().unwrap(), "--no-plots", "--out", out];
        args.extend_from_slice(extra);
        ok(&platoon(&args, tmp.path()));
    };
    run("builtin", &[]);
    run("sdk", &["--injector", &sdk_example("dos_jammer")]);
    same_outputs(
        &tmp.path().join("sdk"),
        &tmp.path().join("builtin"),
        &["trajectories.csv", "events.csv"],
    );
    same_summary_but_the_injector(&tmp.path().join("sdk"), &tmp.path().join("builtin"));
}

/// An attack the built-in channel does not have: a jammer that follows vehicle 2.
#[test]
fn a_rust_sdk_jammer_following_one_vehicle_affects_that_vehicle_only() {
    let tmp = tempfile::tempdir().unwrap();
    let table1 = repo().join("configs/table1.toml");
    let injector = format!("{} 2 10 20", sdk_example("follow_jammer"));
    ok(&platoon(
        &[
            "run",
            table1.to_str().unwrap(),
            "--no-plots",
            "--out",
            "r",
            "--injector",
            &injector,
        ],
        tmp.path(),
    ));
    let s = summary(&tmp.path().join("r"));
    let affected = |i: usize| s["vehicles"][i]["affected_time_s"].as_f64().unwrap();
    assert!(
        affected(1) > 0.0,
        "vehicle 2 is jammed: {}",
        s["vehicles"][1]
    );
    assert_eq!(affected(0), 0.0);
    assert_eq!(affected(3), 0.0);
}

/// The Python SDK (platoon.injector): the same built-in DoS byte for byte, and a
/// ghost of vehicle 1 (Sybil) that slips past the plausibility check and opens the gaps.
#[test]
fn python_sdk_injectors_reproduce_the_builtin_dos_and_run_a_stealthy_ghost() {
    let tmp = tempfile::tempdir().unwrap();
    let example = py_example;
    let run = |config: &str, out: &str, extra: &[&str]| {
        let c = repo().join("configs").join(config);
        let mut args = vec!["run", c.to_str().unwrap(), "--no-plots", "--out", out];
        args.extend_from_slice(extra);
        ok(&platoon(&args, tmp.path()));
        summary(&tmp.path().join(out))
    };
    run("paper.toml", "builtin", &[]);
    run(
        "paper.toml",
        "sdk",
        &["--injector", &example("dos_jammer.py", "")],
    );
    same_outputs(
        &tmp.path().join("sdk"),
        &tmp.path().join("builtin"),
        &["trajectories.csv", "events.csv"],
    );
    same_summary_but_the_injector(&tmp.path().join("sdk"), &tmp.path().join("builtin"));
    let clean = run("table1.toml", "clean", &[]);
    let ghost = run(
        "table1.toml",
        "ghost",
        &["--injector", &example("ghost.py", "1 10 30 0.3")],
    );
    let mean = |s: &serde_json::Value, i: usize| {
        s["vehicles"][i]["spacing_error_m"]["mean_abs"]
            .as_f64()
            .unwrap()
    };
    assert!(
        mean(&ghost, 1) > 2.0 * mean(&clean, 1),
        "{} vs {}",
        mean(&ghost, 1),
        mean(&clean, 1)
    );
    let log = std::fs::read_to_string(tmp.path().join("ghost/logs/injector.log")).unwrap();
    let forged: u64 = log
        .split_whitespace()
        .nth(2)
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{log}"));
    let refused = ghost["rejected_packets"]["implausible_state"]
        .as_u64()
        .unwrap();
    assert!(
        forged > 100 && refused < forged / 50,
        "forged {forged}, refused {refused}"
    );
}

/// `--injector-mode after`: the config's attacks first, then the user's injector on what
/// survived. A DoS-reproducing injector after the built-in DoS changes nothing (Rust and Python
/// SDKs), and a vehicle jammer stacks on top of the DoS.
#[test]
fn an_injector_after_the_builtin_channel_stacks_on_the_configs_attacks() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = repo().join("configs/paper.toml");
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec!["run", paper.to_str().unwrap(), "--no-plots", "--out", out];
        args.extend_from_slice(extra);
        ok(&platoon(&args, tmp.path()));
        summary(&tmp.path().join(out))
    };
    let builtin = run("builtin", &[]);
    let python_dos = py_example("dos_jammer.py", "");
    for (out, injector) in [("rust", sdk_example("dos_jammer")), ("python", python_dos)] {
        let s = run(out, &["--injector-mode", "after", "--injector", &injector]);
        assert!(
            s["injector"]["mode"].as_str().unwrap().starts_with("after"),
            "{}",
            s["injector"]
        );
        same_outputs(
            &tmp.path().join(out),
            &tmp.path().join("builtin"),
            &["trajectories.csv", "events.csv", "channel.csv"],
        );
    }
    let jammer = format!("{} 2 10 20", sdk_example("follow_jammer"));
    let stacked = run(
        "stacked",
        &["--injector-mode", "after", "--injector", &jammer],
    );
    let affected =
        |s: &serde_json::Value, i: usize| s["vehicles"][i]["affected_time_s"].as_f64().unwrap();
    assert!(
        affected(&stacked, 1) > affected(&builtin, 1),
        "vehicle 2: DoS and the jammer"
    );
    assert_eq!(
        affected(&stacked, 0),
        affected(&builtin, 0),
        "vehicle 1: the DoS only"
    );
    assert!(affected(&builtin, 0) > 0.0);
}

/// The contract version this build speaks, as `bridge/wire_layout.json` records it.
fn contract_version() -> u64 {
    json(&repo().join("bridge/wire_layout.json"))["contract_version"]
        .as_u64()
        .unwrap()
}

/// A Python injector written in its own directory, outside `bridge/`, importing the SDK the
/// way the contract says (no sys.path of its own), run with `--injector` on table1; platoon's
/// stderr and the run's error.
fn run_own_injector(dir: &Path, script: &str) -> (String, String) {
    let file = dir.join("my_injector.py");
    std::fs::write(&file, script).unwrap();
    let config = repo().join("configs/table1.toml");
    let injector = format!("{} {}", python(), file.display());
    let o = platoon(
        &[
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            "r",
            "--injector",
            &injector,
        ],
        dir,
    );
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "the run must fail: {stderr}");
    let error = summary(&dir.join("r"))["error"]
        .as_str()
        .unwrap()
        .to_string();
    (stderr, error)
}

/// A third-party injector that fails at step 0 is more than "the injector process
/// exited at step 0: exit status: 1": the error quotes its last lines of stderr, names its log,
/// and says which contract version the run speaks.
#[test]
fn a_dying_plugin_is_quoted_from_its_log_and_told_the_runs_contract() {
    let tmp = tempfile::tempdir().unwrap();
    let (stderr, error) = run_own_injector(
        tmp.path(),
        r#"
import os
import sys

import platoon.injector as pi

print("PYTHONPATH=" + os.environ.get("PYTHONPATH", ""), file=sys.stderr)


class Dies(pi.Injector):
    def step(self, step, rx):
        for i in range(15):
            print(f"my injector says {i}", file=sys.stderr)
        sys.exit(1)


pi.run(lambda run: Dies())
"#,
    );
    for text in [&stderr, &error] {
        assert!(
            text.contains("the injector process") && text.contains("exited at step 0"),
            "{text}"
        );
        assert!(text.contains("logs/injector.log"), "{text}");
        assert!(
            text.contains("| my injector says 14") && text.contains("| my injector says 5"),
            "the last lines are quoted: {text}"
        );
        assert!(
            !text.contains("| my injector says 4"),
            "the last 10 lines only: {text}"
        );
        assert!(
            text.contains(&format!(
                "this run speaks platoon contract v{}",
                contract_version()
            )),
            "{text}"
        );
    }
    // The bridge is first on the plug-in's PYTHONPATH.
    let log = std::fs::read_to_string(tmp.path().join("r/logs/injector.log")).unwrap();
    let bridge = repo().join("bridge");
    assert!(
        log.contains(&format!("PYTHONPATH={}", bridge.display())),
        "{log}"
    );
}

/// A plug-in of another contract version is told at once which version it speaks and which
/// the run speaks: a Python one whose SDK is of another version, and a Rust one started in a
/// run that claims another version.
#[test]
fn a_plugin_of_another_contract_version_is_told_both_versions() {
    let ours = contract_version();
    let old = ours - 1;
    let tmp = tempfile::tempdir().unwrap();
    let (stderr, error) = run_own_injector(
        tmp.path(),
        &format!(
            "import platoon.wire as w\n\
             w.CONTRACT_VERSION = {old}  # an SDK of another version\n\
             import platoon.injector as pi\n\
             pi.run(lambda run: pi.Injector())\n"
        ),
    );
    for text in [&stderr, &error] {
        assert!(
            text.contains(&format!(
                "this plug-in speaks platoon contract v{old}, but the run speaks v{ours}"
            )),
            "{text}"
        );
        assert!(text.contains("docs/injector-contract.md"), "{text}");
    }

    let rust = tempfile::tempdir().unwrap();
    let config = repo().join("configs/table1.toml");
    let injector = format!(
        "env PLATOON_CONTRACT_VERSION={old} {}",
        sdk_example("dos_jammer")
    );
    let o = platoon(
        &[
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            "r",
            "--injector",
            &injector,
        ],
        rust.path(),
    );
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(&format!(
            "this plug-in speaks platoon contract v{ours}, but the run speaks v{old}"
        )),
        "{stderr}"
    );
    assert!(stderr.contains("docs/injector-contract.md"), "{stderr}");
}

/// A run without a DoS says so, never "-0.00 s jammed" (nor summary.json
/// `"attacked_time_s": -0.0`), and one with an injector never "the config's 0 attacks were not
/// applied".
#[test]
fn a_run_without_dos_says_none_and_never_minus_zero() {
    let tmp = tempfile::tempdir().unwrap();
    let config = repo().join("configs/table1.toml");
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec!["run", config.to_str().unwrap(), "--no-plots", "--out", out];
        args.extend_from_slice(extra);
        let o = platoon(&args, tmp.path());
        ok(&o);
        let text = std::fs::read_to_string(tmp.path().join(out).join("summary.json")).unwrap();
        (String::from_utf8_lossy(&o.stdout).into_owned(), text)
    };
    let (stdout, summary) = run("builtin", &[]);
    assert!(stdout.contains("  DoS: none\n"), "{stdout}");
    assert!(!stdout.contains("-0.00"), "{stdout}");
    assert!(!summary.contains("-0.0"), "{summary}");
    let parsed: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let attacked = parsed["attack"]["attacked_time_s"].as_f64().unwrap();
    assert!(attacked == 0.0 && attacked.is_sign_positive());

    let (stdout, summary) = run("injector", &["--injector", &drop_sender("")]);
    assert!(!stdout.contains("0 attacks"), "{stdout}");
    assert!(stdout.contains("DoS: none in the config"), "{stdout}");
    assert!(!summary.contains("-0.0"), "{summary}");
}

#[test]
fn an_injector_command_that_does_not_exist_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let c = repo().join("configs/table1.toml");
    let o = platoon(
        &[
            "run",
            c.to_str().unwrap(),
            "--out",
            "r",
            "--injector",
            "/nonexistent/injector",
        ],
        tmp.path(),
    );
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("the injector process"), "{stderr}");
}

#[test]
fn killing_the_orchestrator_takes_its_processes_down() {
    let tmp = tempfile::tempdir().unwrap();
    let (mut child, run) = start_long_run(tmp.path(), &[]);
    wait_until_running(&run);
    let needle = run.with_extension("partial").display().to_string();
    assert_eq!(
        pids_with(&needle).len(),
        3,
        "plant, controller and injector run"
    );
    child.kill().unwrap(); // SIGKILL: no chance to clean up
    child.wait().unwrap();
    // Orphaned nodes exit by themselves (nobody else is left to stop them).
    no_process_left(&needle);
    assert!(!run.exists(), "a killed run never looks complete");
}

#[test]
fn a_fleet_over_iceoryx2_is_bit_identical_to_inproc() {
    let tmp = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(repo().join("configs/link-attacks.toml")).unwrap();
    let config = tmp.path().join("fleet.toml");
    std::fs::write(
        &config,
        base.replace("duration_s = 40.0", "duration_s = 10.0")
            + "\n[fleet]\nplatoons = 3\nlanes = [0, 1]\ngap_m = 150.0\n",
    )
    .unwrap();
    let c = config.to_str().unwrap();
    for (out, transport) in [("ipc", "iceoryx2"), ("inproc", "inproc")] {
        ok(&platoon(
            &[
                "run",
                c,
                "--out",
                out,
                "--no-plots",
                "--transport",
                transport,
            ],
            tmp.path(),
        ));
    }
    same_outputs(
        &tmp.path().join("ipc"),
        &tmp.path().join("inproc"),
        &COMPARED,
    );
    let s = summary(&tmp.path().join("ipc"));
    assert_eq!(s["fleet"]["platoons"], 3);
    assert_eq!(s["fleet"]["vehicles"], 15);
    // Each platoon has its own loss seed: their channels drop different packets.
    let log = std::fs::read_to_string(tmp.path().join("ipc/channel.csv")).unwrap();
    let per: Vec<usize> = (0..3)
        .map(|j| {
            log.lines()
                .filter(|l| l.split(',').nth(1) == Some(&j.to_string()))
                .count()
        })
        .collect();
    assert!(per.iter().all(|&n| n > 0), "{per:?}");
    assert!(per[0] != per[1] || per[1] != per[2], "{per:?}");
    let rows = std::fs::read_to_string(tmp.path().join("ipc/trajectories.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 1001 * 15);
}

/// The CPU this test process may use first (what `--cpus` is given).
fn first_cpu() -> String {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let list = status
        .lines()
        .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
        .unwrap()
        .trim();
    list.split([',', '-']).next().unwrap().to_string()
}

#[test]
fn cpus_pins_every_node_and_changes_no_result() {
    let tmp = tempfile::tempdir().unwrap();
    let cpu = first_cpu();
    let paper = repo().join("configs/paper.toml");
    let paper = paper.to_str().unwrap();
    ok(&platoon(
        &["run", paper, "--no-plots", "--out", "any"],
        tmp.path(),
    ));
    // The injector is a shell that reports its own CPU list, then becomes the Python SDK's
    // dos_jammer: what it prints is what the pinned process was allowed.
    let injector = format!(
        "sh -c 'grep Cpus_allowed_list /proc/self/status >&2; exec {}'",
        py_example("dos_jammer.py", "")
    );
    ok(&platoon(
        &[
            "run",
            paper,
            "--no-plots",
            "--out",
            "pinned",
            "--cpus",
            &cpu,
            "--injector",
            &injector,
        ],
        tmp.path(),
    ));
    let log = std::fs::read_to_string(tmp.path().join("pinned/logs/injector.log")).unwrap();
    assert!(
        log.contains(&format!("Cpus_allowed_list:\t{cpu}\n")),
        "the injector was not pinned to CPU {cpu}:\n{log}"
    );
    same_outputs(
        &tmp.path().join("pinned"),
        &tmp.path().join("any"),
        &["trajectories.csv", "events.csv"],
    );
    // A CPU this process may not use, and a malformed list: one line naming the flag, exit 2.
    for (list, needle) in [
        ("100000", "CPU 100000 is not available"),
        ("0-x", "\"0-x\""),
    ] {
        let o = platoon(&["run", paper, "--out", "bad", "--cpus", list], tmp.path());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("--cpus") && err.contains(needle), "{err}");
        assert!(!tmp.path().join("bad").exists());
    }
}

/// The time-headway policy (a long PF platoon under the paper's DoS) gives the same
/// bytes over iceoryx2 as in process.
#[test]
fn iceoryx2_run_with_a_time_headway_is_bit_identical_to_inproc() {
    transports_agree("configs/time-headway.toml");
}

/// The paper's scenario with `extra` appended (TOML sections), in `dir`.
fn paper_plus(dir: &Path, name: &str, extra: &str) -> std::path::PathBuf {
    let text = std::fs::read_to_string(repo().join("configs/paper.toml")).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, format!("{text}\n{extra}")).unwrap();
    path
}

#[test]
fn iceoryx2_run_on_the_80211p_radio_is_bit_identical_to_inproc() {
    let tmp = tempfile::tempdir().unwrap();
    // A loaded channel: 0.12 vehicles/m beaconing at 25 Hz loses packets even at 10 m.
    let c = paper_plus(
        tmp.path(),
        "radio.toml",
        "[channel]\nmodel = \"80211p\"\nradio = { density_veh_per_m = 0.12, beacon_hz = 25.0 }\n",
    );
    let runs = transports_agree(c.to_str().unwrap());
    let r = runs.path().join("inproc");
    let log = std::fs::read_to_string(r.join("channel.csv")).unwrap();
    assert!(log.contains("dropped_radio"), "the radio lost nothing");
    // The resolved config says every parameter of the model.
    let resolved = std::fs::read_to_string(r.join("config.toml")).unwrap();
    assert!(resolved.contains("tx_power_dbm = 23.0"), "{resolved}");
}

/// The detectors measured against ground truth give the same `summary.json`
/// `detection` and the same per-message dataset (`detections.csv`) over iceoryx2 (the controller
/// node publishes its verdicts, the orchestrator joins them with the truth) as in process, with
/// an insider's false data, the fallback reaction and the ACC fallback on the radar the radar
/// cross-check reads too.
#[test]
fn iceoryx2_run_with_detection_reports_the_inproc_detection_figures() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = std::fs::read_to_string(repo().join("configs/paper.toml")).unwrap();
    let acc = paper.replace("mode = \"zero\"", "mode = \"acc\"");
    assert_ne!(
        acc, paper,
        "configs/paper.toml has no [fallback] mode = \"zero\""
    );
    let c = tmp.path().join("detection.toml");
    std::fs::write(
        &c,
        format!(
            "{acc}
[[channel.attacks]]
kind = \"false_data\"
offset = [12.0, 0.0, 0.0]
senders = [2]
start_s = 20.0
insider = true

[detection]
reaction = \"fallback\"
[detection.residual]
[detection.plausibility]
[detection.radar_cross]
"
        ),
    )
    .unwrap();
    let runs = transports_agree(c.to_str().unwrap());
    let d = &summary(&runs.path().join("ipc"))["detection"];
    assert!(d["inspected"].as_u64().unwrap() > 0, "{d}");
    assert!(d["any"]["totals"]["tp"].as_u64().unwrap() > 0, "{d}");
    assert_eq!(d["detectors"].as_array().unwrap().len(), 3, "{d}");
    let ipc = runs.path().join("ipc");
    same_outputs(&ipc, &runs.path().join("inproc"), &["detections.csv"]);
    let rows = std::fs::read_to_string(ipc.join("detections.csv")).unwrap();
    let head: Vec<&str> = rows.lines().next().unwrap().split(',').collect();
    let inspected = head.iter().position(|h| *h == "inspected").unwrap();
    assert_eq!(
        rows.lines()
            .skip(1)
            .filter(|l| l.split(',').nth(inspected) == Some("true"))
            .count() as u64,
        d["inspected"].as_u64().unwrap(),
        "one inspected row per inspected packet"
    );
    // The detection and reaction events (the same bytes on both transports, compared above):
    // a row per flagged packet, and the fallback's refusing of the liar.
    let events = std::fs::read_to_string(ipc.join("events.csv")).unwrap();
    let count = |e: &str| events.lines().filter(|l| l.contains(e)).count() as u64;
    assert_eq!(count(",flagged,"), d["flagged"].as_u64().unwrap());
    assert!(count(",distrust,") > 0, "the reaction refused nobody");
}

/// The state-altering link attacks (random offsets per link and per packet, a drift,
/// feigned braking, a scaled acceleration) give the same bytes over iceoryx2 as in process. The
/// insider's random offset covers every sender, also the last follower, whose broadcasts have no
/// listener (not sent, so no draw, on either transport).
#[test]
fn iceoryx2_run_with_the_state_altering_attacks_is_bit_identical_to_inproc() {
    let tmp = tempfile::tempdir().unwrap();
    let c = paper_plus(
        tmp.path(),
        "altering.toml",
        r#"
[[channel.attacks]]
kind = "random_offset"
senders = [0]
std = [0.3, 0.1, 0.05]

[[channel.attacks]]
kind = "random_offset"
start_s = 5.0
std = [0.3, 0.1, 0.05]
insider = true

[[channel.attacks]]
kind = "drift"
senders = [2]
start_s = 10.0
rate = [0.02, 0.0, 0.0]

[[channel.attacks]]
kind = "feigned_braking"
senders = [1]
start_s = 20.0
end_s = 22.0
accel_mps2 = -6.0

[[channel.attacks]]
kind = "accel_scale"
senders = [3]
start_s = 30.0
factor = 3.0
insider = true
"#,
    );
    let runs = transports_agree(c.to_str().unwrap());
    let log = std::fs::read_to_string(runs.path().join("inproc/channel.csv")).unwrap();
    assert!(log.contains("altered"), "nothing altered");
}

/// The load counted from the run (a fleet's platoons loading each other's channels, the other
/// traffic beaconing as the platoon does) and reactive DCC: the injector process measures what
/// the in-process channel does, and reports the radio's figures with DONE.
#[test]
fn iceoryx2_fleet_with_counted_load_and_dcc_is_bit_identical_to_inproc() {
    let tmp = tempfile::tempdir().unwrap();
    let c = paper_plus(
        tmp.path(),
        "load.toml",
        "[fleet]\nplatoons = 2\nlanes = [0, 1]\ngap_m = 150.0\n\
         [channel]\nmodel = \"80211p\"\nbackground_beacons = \"platoon\"\n\
         radio = { density_veh_per_m = 0.3 }\n[channel.dcc]\n",
    );
    let runs = transports_agree(c.to_str().unwrap());
    let s = summary(&runs.path().join("ipc"));
    let radio = &s["channel"];
    // 2 platoons of 5 vehicles measured at each of 5501 steps; DCC held packets back.
    assert_eq!(radio["samples"], 2 * 5 * 5501);
    assert!(radio["dcc_deferred"].as_u64().unwrap() > 0, "{radio}");
    assert!(radio["mean_cbr"].as_f64().unwrap() > 0.1, "{radio}");
    let log = std::fs::read_to_string(runs.path().join("ipc/channel.csv")).unwrap();
    for action in [
        "dcc_deferred",
        "dropped_dcc",
        "delivered_late",
        "dropped_radio",
    ] {
        assert!(log.contains(action), "no {action} in the channel log");
    }
}

#[test]
fn iceoryx2_runs_of_the_fields_laws_are_bit_identical_to_inproc() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/paper.toml")).unwrap();
    // Ploeg's CACC (its own radar, the predecessor's command fed forward) on CAM beacons, and
    // the PATH CACC on 10 Hz beacons, under the paper's DoS.
    for (name, law, spacing, rule) in [
        (
            "ploeg.toml",
            "ploeg",
            "spacing_m = 2.0\nspacing_policy = \"time_headway\"\ntime_headway_s = 0.5",
            "rule = \"cam\"",
        ),
        (
            "path.toml",
            "path_cacc",
            "spacing_m = 5.0",
            "rule = \"periodic\"\nperiod_s = 0.1",
        ),
    ] {
        let config = without_paper_law_keys(&text)
            .replacen("spacing_m = 10.0", spacing, 1)
            .replacen("preset = \"tpsf\"", "preset = \"plf\"", 1)
            .replacen("[control]", &format!("[control]\nlaw = \"{law}\""), 1)
            .replacen("rule = \"dynamic\"", rule, 1);
        let path = tmp.path().join(name);
        std::fs::write(&path, config).unwrap();
        transports_agree(path.to_str().unwrap());
    }
}

/// A jammer on the road: what the vehicles sensed is measured in the run, and Assumption 2 is
/// checked on it (not on the config's schedule); both transports agree bit for bit.
#[test]
fn a_jammer_on_the_road_is_a_dos_observed_by_the_vehicles() {
    let tmp = tempfile::tempdir().unwrap();
    // 20 dBm beside the road at 250 m, on from 10 s to 30 s: the platoon drives through it.
    let c = paper_plus(
        tmp.path(),
        "jammer.toml",
        "[[channel.jammers]]\nposition_m = 250.0\npower_dbm = 20.0\nstart_s = 10.0\nend_s = 30.0\n",
    );
    let runs = transports_agree(c.to_str().unwrap());
    let r = runs.path().join("inproc");
    let s = summary(&r);
    let observed = &s["attack"]["observed"];
    let jammed = observed["jammed_time_s"].as_f64().unwrap();
    // The config's own DoS (10 s, admissible) plus the jammer's (well over Assumption 2's
    // duration bound: one long outage).
    assert!(jammed > 10.0, "{observed}");
    assert_eq!(s["attack"]["assumption2"]["holds"], true);
    assert_eq!(observed["assumption2"]["holds"], false, "{observed}");
    // Without a jammer, nothing is measured (summaries of other runs are unchanged).
    ok(&platoon(
        &["run", "--out", "p", "--no-plots", "--transport", "inproc"],
        tmp.path(),
    ));
    assert!(summary(&tmp.path().join("p"))["attack"]
        .get("observed")
        .is_none());
}

/// Jammers of every behaviour as transmitters (ideal radio: their radius counts): a random one
/// riding behind the last follower, a reactive one beside the road and a periodic one; both
/// transports agree bit for bit, and each link's outages are measured from what happened on the
/// wire.
#[test]
fn random_reactive_and_member_jammers_agree_across_transports_and_are_measured_per_link() {
    let tmp = tempfile::tempdir().unwrap();
    let c = paper_plus(
        tmp.path(),
        "jammers.toml",
        "[[channel.jammers]]\nmember = 4\noffset_m = -30.0\npower_dbm = 5.0\nbehaviour = \"random\"\n\
         mean_on_s = 0.5\nmean_off_s = 2.0\nstart_s = 5.0\nend_s = 25.0\n\
         [[channel.jammers]]\nposition_m = 400.0\nlateral_m = 20.0\npower_dbm = 15.0\n\
         behaviour = \"reactive\"\nstart_s = 5.0\n\
         [[channel.jammers]]\nposition_m = 100.0\npower_dbm = 10.0\non_s = 0.5\noff_s = 3.0\n",
    );
    let runs = transports_agree(c.to_str().unwrap());
    let s = summary(&runs.path().join("inproc"));
    let links = s["attack"]["observed"]["links"]
        .as_array()
        .expect("per link");
    assert!(!links.is_empty(), "{}", s["attack"]["observed"]);
    for l in links {
        assert!(l["intervals"].as_u64().unwrap() >= 1, "{l}");
        assert!(l["jammed_time_s"].as_f64().unwrap() >= l["longest_s"].as_f64().unwrap());
    }
    let log = std::fs::read_to_string(runs.path().join("inproc/channel.csv")).unwrap();
    assert!(
        log.contains("dropped_interference"),
        "no interference losses"
    );
    assert!(log.contains("restored"));
}

/// The state-falsification attacks as an injector of one's own
/// (bridge/examples/falsify.py, an outsider altering vehicle 2's copies): the orchestrator
/// labels every delivered packet against what the controller sent, so a third-party injector's
/// attacks are measured like the channel's. Every packet labelled `altered` claims what the
/// injector made of the sender's true state, every `genuine` one claims that state exactly,
/// and the detector that must catch each attack does.
#[test]
fn a_python_injectors_falsifications_are_labelled_against_the_truth() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = std::fs::read_to_string(repo().join("configs/paper.toml")).unwrap();
    let base = &paper[..paper.find("[attack]").expect("paper.toml has [attack]")];
    let c = tmp.path().join("detect.toml");
    std::fs::write(
        &c,
        format!(
            "{base}[attack]\nkind = \"none\"\n\n[detection]\n[detection.residual]\n\
             [detection.radar_cross]\n"
        ),
    )
    .unwrap();
    // (attack, what an altered claim is: f(claimed, true) must hold, the detector that catches it)
    type Check = fn(&[f64], &[f64]) -> bool;
    let cases: [(&str, Check, &str); 3] = [
        (
            "offset --value 5 0 0",
            |c, t| (c[0] - t[0] - 5.0).abs() < 1e-9 && c[1] == t[1] && c[2] == t[2],
            "radar_cross",
        ),
        (
            "feigned_braking --value -6",
            |c, t| c[0] == t[0] && c[1] == t[1] && c[2] == -6.0,
            "residual",
        ),
        (
            "drift --value 0 0.5 0",
            |c, t| c[0] == t[0] && c[1] > t[1] && c[2] == t[2],
            "radar_cross",
        ),
    ];
    for (attack, altered_claim, catcher) in cases {
        let injector = py_example("falsify.py", &format!("{attack} --sender 2 --start 20"));
        let o = platoon(
            &[
                "run",
                c.to_str().unwrap(),
                "--out",
                "run",
                "--force",
                "--no-plots",
                "--injector",
                &injector,
            ],
            tmp.path(),
        );
        ok(&o);
        let run = tmp.path().join("run");
        let s = summary(&run);
        let d = &s["detection"];
        let altered = d["labels"]["altered"].as_u64().unwrap_or(0);
        assert!(altered > 100, "{attack}: {d}");
        assert!(altered <= s["wire"]["totals"]["altered"].as_u64().unwrap());
        let caught = d["detectors"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["name"] == catcher)
            .unwrap();
        assert!(
            caught["by_label"]["altered"]["tp"].as_u64().unwrap() > 0,
            "{attack}: {caught}"
        );
        let rows = std::fs::read_to_string(run.join("detections.csv")).unwrap();
        let mut lines = rows.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
        let (claimed, truth, label) = (col("claimed_p"), col("true_p"), col("label"));
        let mut seen = 0;
        for line in lines {
            let f: Vec<&str> = line.split(',').collect();
            if f[col("inspected")] != "true" {
                // Refused by the packet checks before the detectors: a row, not scored.
                assert!(!f[col("refused_by")].is_empty(), "{attack}: {line}");
                continue;
            }
            let num = |i: usize| f[i].parse::<f64>().unwrap();
            let c = [num(claimed), num(claimed + 1), num(claimed + 2)];
            let t = [num(truth), num(truth + 1), num(truth + 2)];
            match f[label] {
                "genuine" => assert_eq!(c, t, "{attack}: {line}"),
                "altered" => {
                    assert!(altered_claim(&c, &t), "{attack}: {line}");
                    assert_eq!(f[col("sender")], "2", "{attack}: {line}");
                    seen += 1;
                }
                other => panic!("{attack}: label {other} in {line}"),
            }
        }
        assert_eq!(seen, altered, "{attack}");
    }
}

/// The Sybil ghost (bridge/examples/ghost.py, a Python injector; the experiment runs
/// in process and cannot hold it) faces the detectors over iceoryx2: its forged claims are
/// consistent with each other, so only the radar of the follower right behind the impersonated
/// vehicle flags them, on every packet to it (half of the ghost's packets), and neither the
/// residual nor the plausibility checks do.
#[test]
fn only_the_radar_catches_the_sybil_ghost() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/table1.toml")).unwrap();
    let c = tmp.path().join("ghost.toml");
    std::fs::write(
        &c,
        format!(
            "{text}\n[detection]\n[detection.residual]\n[detection.radar_cross]\n\
             [detection.plausibility]\n"
        ),
    )
    .unwrap();
    ok(&platoon(
        &[
            "run",
            c.to_str().unwrap(),
            "--no-plots",
            "--out",
            "ghost",
            "--injector",
            &py_example("ghost.py", "1 10 30 0.3"),
        ],
        tmp.path(),
    ));
    let d = &summary(&tmp.path().join("ghost"))["detection"];
    let ghost = d["labels"]["altered"].as_u64().unwrap();
    assert!(ghost > 100, "{d}");
    for s in d["detectors"].as_array().unwrap() {
        let tp = s["by_label"]["altered"]["tp"].as_u64().unwrap();
        match s["name"].as_str().unwrap() {
            "radar_cross" => assert!(tp * 2 >= ghost - 2 && tp * 2 <= ghost + 2, "{s}"),
            _ => assert_eq!(tp, 0, "{s}"),
        }
    }
}

/// The maneuver attacks of bridge/examples/maneuver_attacks.py, a Python injector over
/// iceoryx2: a leave notice forged onto follower 1's packet to the leader at 10 s ejects it
/// (its `left` at 10.01 s, before the real leaves at 20 and 45 s), safely; the leader's
/// updates of a join replayed 8 s later (12 deliveries) are dropped as old by every receiver,
/// so trajectories and events are those of the run without the injector, byte for byte.
#[test]
fn the_python_maneuver_attacks_eject_a_member_and_replay_updates_in_vain() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |config: &str, out: &str, injector: Option<&str>| {
        let config = repo().join(config);
        let mut args = vec!["run", config.to_str().unwrap(), "--no-plots", "--out", out];
        let injector = injector.map(|a| py_example("maneuver_attacks.py", a));
        if let Some(i) = &injector {
            args.extend(["--injector", i.as_str()]);
        }
        ok(&platoon(&args, tmp.path()));
        tmp.path().join(out)
    };
    let forged = run("configs/leave.toml", "forged", Some("forge-leave 1 10"));
    let events = std::fs::read_to_string(forged.join("events.csv")).unwrap();
    let left: Vec<&str> = events
        .lines()
        .filter(|l| l.contains(",left,left,"))
        .collect();
    assert_eq!(
        left,
        [
            "0,1,1001,10.01,left,left,,false",
            "0,2,2002,20.02,left,left,,false",
            "0,5,4502,45.02,left,left,,false"
        ]
    );
    assert_eq!(summary(&forged)["safety"]["collided"], false);
    let log = std::fs::read_to_string(forged.join("logs/injector.log")).unwrap();
    assert!(log.contains("forged a leave notice at step 1000"), "{log}");
    let base = run("configs/join.toml", "base", None);
    let replayed = run("configs/join.toml", "replayed", Some("replay-updates 8"));
    let log = std::fs::read_to_string(replayed.join("logs/injector.log")).unwrap();
    assert!(log.contains("replayed 12 update deliveries"), "{log}");
    for f in ["trajectories.csv", "events.csv"] {
        let (a, b) = (base.join(f), replayed.join(f));
        assert!(
            std::fs::read(a).unwrap() == std::fs::read(b).unwrap(),
            "{f} differs"
        );
    }
}

/// The other maneuver attacks of bridge/examples/maneuver_attacks.py over iceoryx2, each
/// keeping the joiner from the platoon, safely: a fake join request in the joiner's name at
/// 3 s, before it asks (the leader waits for a join nobody asked for; the joiner's own
/// requests are dropped as old); an in-position report in its name at 6 s, while it is still
/// far back (the leader admits it; it ignores the update while not in its slot, and its own
/// reports are dropped as old); and every move-in of the middle join lost (it stays beside
/// the gap). Without the injectors both joiners join (tests/maneuvers.rs,
/// tests/join_middle.rs).
#[test]
fn the_python_maneuver_attacks_keep_a_joiner_out_safely() {
    let tmp = tempfile::tempdir().unwrap();
    for (config, attack, log_line, mode) in [
        (
            "configs/join.toml",
            "fake-join 4 3",
            "forged a join request at step 300",
            "outside",
        ),
        (
            "configs/join.toml",
            "lie-in-position 4 6",
            "forged an in-position report at step 600",
            "outside",
        ),
        (
            "configs/join-middle.toml",
            "jam move_in",
            "jammed ",
            "beside",
        ),
    ] {
        let out = attack.split(' ').next().unwrap();
        let config = repo().join(config);
        let injector = py_example("maneuver_attacks.py", attack);
        let args = [
            "run",
            config.to_str().unwrap(),
            "--no-plots",
            "--out",
            out,
            "--injector",
            injector.as_str(),
        ];
        ok(&platoon(&args, tmp.path()));
        let dir = tmp.path().join(out);
        let log = std::fs::read_to_string(dir.join("logs/injector.log")).unwrap();
        assert!(log.contains(log_line), "{attack}: {log}");
        let rows = std::fs::read_to_string(dir.join("trajectories.csv")).unwrap();
        let joiner: Vec<&str> = rows
            .lines()
            .skip(1)
            .filter(|l| l.split(',').nth(3) == Some("4"))
            .map(|l| l.split(',').nth(14).unwrap())
            .collect();
        assert!(!joiner.is_empty());
        assert!(
            joiner.iter().all(|m| *m == mode),
            "{attack}: the joiner stays {mode}"
        );
        let s = summary(&dir);
        assert_eq!(s["safety"]["collided"], false, "{attack}");
        assert!(
            s["safety"]["min_gap_m"].as_f64().unwrap() > 10.0,
            "{attack}"
        );
    }
}

/// A car cuts in between followers 2 and 3 (`configs/cut-in.toml`): the native plant process
/// tells follower 3's controller (`VehicleState::INTRUDER`) what the in-process plant tells it,
/// and both transports agree bit for bit through the cut-in, the ACC on it and the return; the
/// events tell its course.
///
/// What the radars saw goes to the trajectories and, with `[detection]`, to the per-message
/// dataset (`radar_target`, `radar_gap_m`, `radar_closing_mps`): the same bytes on both
/// transports, follower 3's target the car (`cut_in:0`) from the step it enters to the step it
/// leaves, its predecessor (`2`) before and after.
#[test]
fn a_cut_in_runs_bit_identically_on_both_transports() {
    let runs = transports_agree("configs/cut-in.toml");
    let rows = std::fs::read_to_string(runs.path().join("ipc/trajectories.csv")).unwrap();
    assert!(rows.contains(",cut_in,"), "no follower ran on the intruder");
    // Follower 3's course through it, in order: the car enters at 20 s and the follower
    // switches at once, opens the gap it had to follower 2, the car leaves at 30 s, the
    // follower dwells 1 s, blends back and rejoins. Nobody else sees the car.
    let events = std::fs::read_to_string(runs.path().join("ipc/events.csv")).unwrap();
    let course: Vec<(u64, &str, &str)> = events
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[4] != "broadcast")
        .map(|f| {
            assert_eq!(f[1], "3", "{f:?}");
            (f[2].parse().unwrap(), f[4], f[5])
        })
        .collect();
    let names: Vec<(&str, &str)> = course.iter().map(|&(_, e, m)| (e, m)).collect();
    assert_eq!(
        names,
        [
            ("intruder_in", "cut_in"),
            ("switch", "cut_in"),
            ("gap_opened", "cut_in"),
            ("intruder_out", "cut_in"),
            ("switch", "blend"),
            ("switch", "coop"),
            ("rejoined", "coop"),
        ]
    );
    assert_eq!(
        (course[0].0, course[1].0, course[3].0, course[4].0),
        (2000, 2000, 3000, 3100)
    );
    assert!((2000..3000).contains(&course[2].0), "{course:?}");
    published(
        "docs/traffic.md",
        "opens the gap {} s after the car entered",
        &[format!("{:.2}", (course[2].0 - course[0].0) as f64 * 0.01)],
    );
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/cut-in.toml")).unwrap();
    let c = tmp.path().join("cut-in-detection.toml");
    std::fs::write(
        &c,
        format!("{text}\n[detection]\nradar_cross = {{}}\nplausibility = {{}}\n"),
    )
    .unwrap();
    let runs = transports_agree(c.to_str().unwrap());
    let ipc = runs.path().join("ipc");
    same_outputs(&ipc, &runs.path().join("inproc"), &["detections.csv"]);
    let table = |file: &str| {
        let mut r = csv::Reader::from_path(ipc.join(file)).unwrap();
        let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
        let col = |name: &str| header.iter().position(|h| h == name).unwrap();
        let (step, who, gap) = (col("step"), col("radar_target"), col("radar_gap_m"));
        let vehicle = header
            .iter()
            .position(|h| h == "vehicle" || h == "receiver")
            .unwrap();
        let rows: Vec<(u64, u16, String, f64)> = r
            .records()
            .map(|x| {
                let x = x.unwrap();
                (
                    x[step].parse().unwrap(),
                    x[vehicle].parse().unwrap(),
                    x[who].to_string(),
                    x[gap].parse().unwrap(),
                )
            })
            .collect();
        assert_eq!(
            header[header.len() - 3..],
            ["radar_target", "radar_gap_m", "radar_closing_mps"],
            "{file}: the radar's columns last"
        );
        rows
    };
    // Follower 3: its predecessor until the car enters at 20 s, the car until it leaves at
    // 30 s (the gap it was given as it entered: mid-gap), its predecessor again after.
    let seen = table("trajectories.csv");
    let of3: Vec<&(u64, u16, String, f64)> = seen.iter().filter(|r| r.1 == 3).collect();
    for (k, _, who, gap) in &of3 {
        let want = if (2000..3000).contains(k) {
            "cut_in:0"
        } else {
            "2"
        };
        assert_eq!(who, want, "step {k}");
        assert!(gap.is_finite() && *gap > 0.0, "step {k}: {gap}");
    }
    let entry = of3.iter().find(|r| r.0 == 2000).unwrap();
    let before = of3.iter().find(|r| r.0 == 1999).unwrap();
    assert!(
        (entry.3 - (before.3 - 4.5) / 2.0).abs() < 0.1,
        "mid-gap: {entry:?} after {before:?}"
    );
    // The leader sees nothing; every other follower its predecessor.
    for (k, v, who, gap) in &seen {
        match v {
            0 => assert!(who.is_empty() && gap.is_nan(), "step {k}"),
            3 => {}
            v => assert_eq!(*who, (v - 1).to_string(), "step {k}"),
        }
    }
    // The per-message dataset: the receiver's target at the step it got the packet.
    let messages = table("detections.csv");
    let behind: Vec<_> = messages
        .iter()
        .filter(|r| r.1 == 3 && (2000..3000).contains(&r.0))
        .collect();
    assert!(!behind.is_empty());
    for (k, v, who, gap) in messages {
        let row = seen.iter().find(|r| (r.0, r.1) == (k, v)).unwrap();
        assert_eq!((&who, gap.to_bits()), (&row.2, row.3.to_bits()), "{k} {v}");
    }
}

/// Runs maneuver `config` on both transports (they must agree bit for bit) and checks the
/// events.csv lines holding one of `marks` are `expected`, and that nobody collided. Returns
/// the runs' directory (`ipc/`, `inproc/`).
fn maneuver_runs_safely(config: &str, marks: &[&str], expected: &[&str]) -> tempfile::TempDir {
    let runs = transports_agree(config);
    let ipc = runs.path().join("ipc");
    let events = std::fs::read_to_string(ipc.join("events.csv")).unwrap();
    let got: Vec<&str> = events
        .lines()
        .filter(|l| marks.iter().any(|m| l.contains(m)))
        .collect();
    assert_eq!(got, expected, "{config}");
    let summary = json(&ipc.join("summary.json"));
    assert_eq!(summary["safety"]["collided"], false);
    // The summary measured every maneuver of the config, each completed (the same bytes on
    // both transports: above).
    let maneuvers = summary["maneuvers"]["maneuvers"].as_array().unwrap();
    assert!(!maneuvers.is_empty(), "{config}");
    for m in maneuvers {
        assert_eq!(m["outcome"], "completed", "{config}: {m}");
    }
    runs
}

/// A join at the tail negotiated over V2V (`configs/join.toml`): the maneuver messages cross
/// the wire on the packets (contract v4), and both transports agree bit for bit, the joiner's
/// `outside` mode and its `joined` event included; the facts say the leader hears everyone.
#[test]
fn a_join_runs_bit_identically_on_both_transports() {
    let runs = maneuver_runs_safely(
        "configs/join.toml",
        &[",joined,"],
        &["0,4,2692,26.92,joined,blend,,false"],
    );
    let facts = json(&runs.path().join("ipc/facts.json"));
    assert_eq!(
        facts["hearing"][0]["leader_hears"],
        serde_json::json!([1, 2, 3, 4])
    );
    assert!(facts["topologies"][0].get("leader_hears").is_none());
}

/// The leader's checks of maneuver messages measured against the ground truth over iceoryx2:
/// the join of `configs/join.toml` with `check_reports` and `[detection]`, the catalogue's
/// forged in-position reports at 6 s. The controller process reports each message the leader
/// tested as an inspection of receiver 0; both transports write the same bytes (the summary's
/// `maneuver_checks`, the leader's rows of detections.csv), every forged report flagged and
/// refused, no genuine one.
#[test]
fn the_leaders_checks_are_measured_the_same_on_both_transports() {
    let text = std::fs::read_to_string(repo().join("configs/join.toml"))
        .unwrap()
        .replace(
            "[maneuvers]\n",
            "[[channel.attacks]]\nkind = \"forge_maneuver\"\nmessage = \"in_position\"\n\
             senders = [4]\nreceivers = [0]\nstart_s = 6.0\nend_s = 6.2\n\n\
             [detection.plausibility]\n\n[maneuvers]\ncheck_reports = true\n",
        );
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("join-checked.toml");
    std::fs::write(&config, text).unwrap();
    let runs = transports_agree(config.to_str().unwrap());
    let (ipc, inproc) = (runs.path().join("ipc"), runs.path().join("inproc"));
    same_outputs(&ipc, &inproc, &["detections.csv"]);
    let checks = &summary(&ipc)["detection"]["maneuver_checks"];
    assert_eq!(checks["by_label"]["altered"]["tp"], 2, "{checks}");
    assert_eq!(checks["totals"]["fp"], 0, "{checks}");
    assert_eq!(checks["totals"]["fn"], 0, "{checks}");
    let rows = std::fs::read_to_string(ipc.join("detections.csv")).unwrap();
    let head: Vec<&str> = rows.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    // The leader's rows its check tested (every delivery to it has a row).
    let leader: Vec<Vec<&str>> = rows
        .lines()
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|r| r[3] == "0" && r[col("inspected")] == "true")
        .collect();
    assert_eq!(
        leader.len(),
        4,
        "request, two forged reports, the genuine one"
    );
    for r in &leader {
        let bad = r[col("label")] == "altered";
        assert_eq!(
            (r[col("flagged")], r[col("refused")], r[col("refused_by")]),
            if bad {
                ("true", "true", "check_reports")
            } else {
                ("false", "false", "")
            }
        );
        let detectors = col("plausibility_flagged");
        assert!(
            r[detectors..].iter().all(|c| c.is_empty()),
            "no detector's: {r:?}"
        );
    }
}

/// A join in the middle (`configs/join-middle.toml`): the joiner starts in the lane beside
/// (mode 9 `beside` on the wire), changes into the gap follower 2 opened, and both transports
/// agree bit for bit.
#[test]
fn a_join_in_the_middle_runs_bit_identically_on_both_transports() {
    maneuver_runs_safely(
        "configs/join-middle.toml",
        &[",joined,"],
        &["0,4,2760,27.6,joined,blend,,false"],
    );
}

/// Members leave (`configs/leave.toml`: follower 2 from the middle, follower 5 at the tail):
/// the plant takes each off the lane on its command's mode `left` (on the wire, mode 8), the
/// radars then see the member ahead of it, and both transports agree bit for bit.
#[test]
fn leaves_run_bit_identically_on_both_transports() {
    maneuver_runs_safely(
        "configs/leave.toml",
        &[",left,left,"],
        &[
            "0,2,2002,20.02,left,left,,false",
            "0,5,4502,45.02,left,left,,false",
        ],
    );
}

/// Two platoons merge (`configs/merge.toml`): the rear head's request and the leader's update
/// travel on the wire (`V2vPacket::MERGE_REQUEST`, `UPDATE_MERGED`), the rear followers take
/// the leader as theirs from their head's relay of the update, a step later (the `head`
/// column, `split` and `merged` events), and both transports agree bit for bit.
#[test]
fn a_merge_runs_bit_identically_on_both_transports() {
    maneuver_runs_safely(
        "configs/merge.toml",
        &[",joined,", ",merged,"],
        &[
            "0,3,2717,27.17,joined,blend,,false",
            "0,4,2718,27.18,merged,blend,,false",
            "0,5,2718,27.18,merged,blend,,false",
        ],
    );
}

/// A platoon splits in two (`configs/split.toml`): the split notice and the update travel on
/// the wire (`V2vPacket::SPLIT_NOTICE`, `UPDATE_SPLIT`), the splitter leaves the law for its
/// ACC (`outside` on the wire) and the members behind it take it as their leader (`head`), and
/// both transports agree bit for bit.
#[test]
fn a_maneuver_split_runs_bit_identically_on_both_transports() {
    maneuver_runs_safely(
        "configs/split.toml",
        &[",split,"],
        &[
            "0,4,2002,20.02,split,blend,,false",
            "0,5,2002,20.02,split,blend,,false",
        ],
    );
}

/// A platoon that splits behind the car (`configs/cut-in-split.toml`, the flatbed controller):
/// the head's announcement travels on the wire (`V2vPacket::head`), follower 4 hears follower 3
/// over a link its `plf` graph does not have (the run's facts give the channel's links apart
/// from the graph), and both transports agree bit for bit, the `head` column and the `split`
/// and `merged` events included.
#[test]
fn a_split_runs_bit_identically_on_both_transports() {
    let runs = transports_agree("configs/cut-in-split.toml");
    let ipc = runs.path().join("ipc");
    let facts = json(&ipc.join("facts.json"));
    let links = |key: &str| -> f64 {
        let g = &facts[key][0];
        let count = |v: &serde_json::Value| -> f64 {
            v.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .sum()
        };
        count(&g["pinning"])
            + g["adjacency"]
                .as_array()
                .unwrap()
                .iter()
                .map(count)
                .sum::<f64>()
    };
    assert_eq!((links("topologies"), links("hearing")), (7.0, 10.0));
    let events = std::fs::read_to_string(ipc.join("events.csv")).unwrap();
    let formation: Vec<String> = events
        .lines()
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[4] == "split" || f[4] == "merged")
        .map(|f| format!("{} {} {}", f[1], f[2], f[4]))
        .collect();
    assert_eq!(formation, ["4 2001 split", "4 3410 merged"]);
    let rows = std::fs::read_to_string(ipc.join("trajectories.csv")).unwrap();
    assert!(
        rows.lines().next().unwrap().ends_with(",head"),
        "the head column"
    );
    assert_eq!(json(&ipc.join("summary.json"))["safety"]["collided"], false);
    // A forged split (follower 2 announcing itself as a head from 40 s to 45 s) crosses the
    // wire too: the same rows, events and ground-truth labels on both transports.
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/cut-in-split.toml")).unwrap();
    let c = tmp.path().join("forged-split.toml");
    std::fs::write(
        &c,
        format!(
            "{text}\n[detection]\nplausibility = {{}}\n\n[[channel.attacks]]\n\
             kind = \"forged_head\"\nsenders = [2]\nstart_s = 40.0\nend_s = 45.0\n"
        ),
    )
    .unwrap();
    let runs = transports_agree(c.to_str().unwrap());
    let ipc = runs.path().join("ipc");
    same_outputs(&ipc, &runs.path().join("inproc"), &["detections.csv"]);
    let labels = &json(&ipc.join("summary.json"))["detection"]["labels"];
    assert_eq!(labels["altered"], 100, "{labels}");
}

/// `config` (a shipped one) with the paper's law in place of its `[control]` table (the
/// paper's gains; the trigger is the config's), written to `dir`.
fn with_the_papers_law(config: &str, dir: &Path, edit: impl Fn(String) -> String) -> PathBuf {
    let text = std::fs::read_to_string(repo().join(config)).unwrap();
    let start = text.find("[control]\n").expect("a [control] table");
    let end = start + text[start + 1..].find("\n[").expect("a table after it") + 1;
    let paper = "[control]\ngain = [4.81, 9.12, 2.97]\nbeta1 = 319.38\nbeta2 = 5.62\n";
    let text = edit(format!("{}{paper}{}", &text[..start], &text[end..]));
    let path = dir.join(Path::new(config).file_name().unwrap());
    std::fs::write(&path, text).unwrap();
    path
}

/// The paper's law runs the maneuvers of the field's laws through the same pipeline: the tail
/// join of `configs/join.toml` and the two leaves of `configs/leave.toml` complete, nobody
/// collides, and both transports agree bit for bit.
#[test]
fn the_papers_law_joins_and_leaves_on_both_transports() {
    let dir = tempfile::tempdir().unwrap();
    for (config, done) in [
        ("configs/join.toml", vec![",joined,"]),
        (
            "configs/leave.toml",
            vec!["0,2,2002,20.02,left,", "0,5,4502,45.02,left,"],
        ),
    ] {
        let path = with_the_papers_law(config, dir.path(), |t| t);
        let runs = transports_agree(path.to_str().unwrap());
        let ipc = runs.path().join("ipc");
        let summary = json(&ipc.join("summary.json"));
        assert_eq!(summary["safety"]["collided"], false, "{config}");
        let maneuvers = summary["maneuvers"]["maneuvers"].as_array().unwrap();
        assert_eq!(maneuvers.len(), done.len(), "{config}");
        for m in maneuvers {
            assert_eq!(m["outcome"], "completed", "{config}: {m}");
        }
        let events = std::fs::read_to_string(ipc.join("events.csv")).unwrap();
        for mark in done {
            assert!(events.lines().any(|l| l.contains(mark)), "{config}: {mark}");
        }
        // The members settle in their new formation: every gap to the vehicle ahead at the
        // law's by the end (the rooms the leavers left closed).
        for v in summary["vehicles"].as_array().unwrap() {
            let last = v["gap_error_m"]["final_abs"].as_f64().unwrap();
            assert!(last < 0.05, "{config}: {v}");
        }
    }
}

/// The paper's law on its own TPSF graph, and on PLF, behind a car cutting in 6 m ahead of
/// follower 3 at 2 m/s slower, with `[fallback.cut_in]` as configs/cut-in.toml has it (no
/// `split` key: on these graphs the platoon splits behind the car by default), on its cars,
/// with the guard off:
/// follower 3 heads followers 4 and 5 (who stop steering on the members ahead of the car)
/// from the step after the car entered until it is back on its law, nobody collides, and both
/// transports agree bit for bit. With `split = false`, follower 4 (which also hears follower
/// 2 on TPSF) drives into follower 3.
#[test]
fn the_papers_law_splits_behind_a_cut_in_on_both_transports() {
    let dir = tempfile::tempdir().unwrap();
    for preset in ["tpsf", "plf"] {
        let edit = |split: Option<bool>| {
            move |t: String| {
                let handling = match split {
                    None => String::new(),
                    Some(split) => format!(", split = {split}"),
                };
                crate::common::without_guard(&t)
                    .replace("followers = 4", "followers = 5")
                    .replace("preset = \"pf\"", &format!("preset = \"{preset}\" #"))
                    .replace(
                        "cut_in = { dwell_s = 1.0, blend_s = 3.0 }",
                        &format!("cut_in = {{ dwell_s = 1.0, blend_s = 3.0{handling} }}"),
                    )
                    .replace("decel_mps2 = 2.0", "decel_mps2 = 0.0")
                    .replace("at_s = 20.0 ", "gap_m = 6.0\nat_s = 20.0 ")
            }
        };
        let sub = dir.path().join(preset);
        std::fs::create_dir_all(&sub).unwrap();
        let path = with_the_papers_law("configs/cut-in.toml", &sub, edit(None));
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.contains("gap_m = 6.0")
                && text.contains("cut_in = { dwell_s = 1.0, blend_s = 3.0 }")
                && text.contains(&format!("preset = \"{preset}\"")),
            "{text}"
        );
        let runs = transports_agree(path.to_str().unwrap());
        let ipc = runs.path().join("ipc");
        let summary = json(&ipc.join("summary.json"));
        assert_eq!(
            summary["safety"]["collided"], false,
            "{preset}: {}",
            summary["safety"]
        );
        let rows = std::fs::read_to_string(ipc.join("trajectories.csv")).unwrap();
        let header: Vec<&str> = rows.lines().next().unwrap().split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        let (vehicle, step, head) = (col("vehicle"), col("step"), col("head"));
        for v in ["4", "5"] {
            let led: Vec<u64> = rows
                .lines()
                .skip(1)
                .map(|l| l.split(',').collect::<Vec<_>>())
                .filter(|r| r[vehicle] == v && r[head] == "3")
                .map(|r| r[step].parse().unwrap())
                .collect();
            // From the step after the car entered (at 20 s) until past the car's leaving
            // (30 s): follower 3 is back on its law only once it closed up.
            assert_eq!(led.first(), Some(&2001), "{preset}: follower {v}");
            assert!(
                led.last().is_some_and(|&k| k > 3000),
                "{preset}: follower {v}"
            );
        }
        // Without the split the paper's law on TPSF collides (PLF hears no one beyond its
        // predecessor but the leader, which the radar's car does not hide).
        if preset == "tpsf" {
            let path = with_the_papers_law("configs/cut-in.toml", &sub, edit(Some(false)));
            let o = platoon(
                &[
                    "run",
                    path.to_str().unwrap(),
                    "--out",
                    "nosplit",
                    "--no-plots",
                    "--transport",
                    "inproc",
                ],
                &sub,
            );
            ok(&o);
            let s = json(&sub.join("nosplit/summary.json"));
            assert_eq!(s["safety"]["collided"], true, "{}", s["safety"]);
        }
    }
}
