//! `platoon campaign` end to end: the shipped campaigns at a reduced size, a Dask cluster on
//! 127.0.0.1 against the local pool, resumption after Ctrl-C, failed cells, bad files.
use crate::common;

use common::{json, ok, platoon, platoon_command, published, repo, wait_for};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A shipped campaign, edited by `edit` and written into `dir` (its `base` made absolute).
fn shipped(name: &str, dir: &Path, edit: impl FnOnce(&mut toml::Table)) -> PathBuf {
    let src = repo().join("campaigns").join(format!("{name}.toml"));
    let mut t: toml::Table = toml::from_str(&std::fs::read_to_string(&src).unwrap()).unwrap();
    if let Some(base) = t.get("base").and_then(|b| b.as_str()) {
        let abs = repo().join("campaigns").join(base);
        t.insert("base".into(), abs.display().to_string().into());
    }
    edit(&mut t);
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, toml::to_string(&t).unwrap()).unwrap();
    path
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// cells.csv as rows of (column -> field).
fn cells(out: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_path(out.join("cells.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|rec| {
            header
                .iter()
                .cloned()
                .zip(rec.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}

fn num(row: &std::collections::HashMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = {:?}", row[key]))
}

fn campaign(args: &[&str], cwd: &Path) -> std::process::Output {
    let mut all = vec!["campaign"];
    all.extend_from_slice(args);
    platoon(&all, cwd)
}

#[test]
fn dos_timing_lights_up_the_ramps_and_each_cell_equals_platoon_run() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("dos-timing", tmp.path(), |t| {
        t.insert(
            "dos_window".into(),
            toml::from_str::<toml::Value>("onset_s = [20.0, 35.5]\nduration_s = [1.0, 4.0]")
                .unwrap(),
        );
    });
    let out = tmp.path().join("out");
    let o = campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    );
    ok(&o);
    let rows = cells(&out);
    assert_eq!(rows.len(), 4);
    assert!(rows.iter().all(|r| r["status"] == "ok"));
    let at = |onset: &str, d: &str| {
        rows.iter()
            .find(|r| r["dos.onset_s"] == onset && r["dos.duration_s"] == d)
            .unwrap()
    };
    // Reading R23: 4 s of jam over the braking ramp collides; during cruise it is harmless.
    let ramp = at("35.5", "4");
    let cruise = at("20", "4");
    assert!(
        num(ramp, "max_spacing_error_m") > 3.0 * num(cruise, "max_spacing_error_m"),
        "ramp {} vs cruise {}",
        ramp["max_spacing_error_m"],
        cruise["max_spacing_error_m"]
    );
    assert_eq!(ramp["safety_class"], "severe");
    assert_ne!(cruise["safety_class"], "severe");
    assert_eq!(num(cruise, "attacked_time_s"), 4.0, "measured in the run");
    for plot in [
        "heatmap_max_spacing_error_m.png",
        "heatmap_safety_class.png",
        "lines_max_spacing_error_m.png",
    ] {
        assert!(out.join("plots").join(plot).is_file(), "{plot}");
    }
    let summary = json(&out.join("campaign.json"));
    assert_eq!(summary["complete"], true);
    assert_eq!(summary["ok"], 4);
    assert!(summary["cpu_s"].as_f64().unwrap() > 0.0);
    assert!(out.join("campaign.toml").is_file() && out.join("base.toml").is_file());
    // A cell is exactly `platoon run --transport inproc` of its config.
    let cell = out.join("cells/c0003");
    let run = tmp.path().join("run");
    ok(&platoon(
        &[
            "run",
            cell.join("config.toml").to_str().unwrap(),
            "--transport",
            "inproc",
            "--no-plots",
            "--out",
            run.to_str().unwrap(),
        ],
        tmp.path(),
    ));
    assert_eq!(
        json(&cell.join("summary.json")),
        json(&run.join("summary.json"))
    );
    assert_eq!(json(&cell.join("cell.json"))["status"], "ok");
    // An in-process run writes timing.json too, but none of what
    // a_sumo_campaign_runs_full_co_simulations takes as the proof of an iceoryx2 run: no stage
    // timings (null), no duplicate count, no run.json, no logs/.
    let timing = json(&run.join("timing.json"));
    assert!(timing["step"]["p50_us"].is_f64(), "{timing}");
    for stage in ["controller_tx", "injector", "controller_rx", "plant"] {
        assert!(timing[stage].is_null(), "{stage}: {timing}");
    }
    assert!(timing.get("duplicate_samples").is_none(), "{timing}");
    assert!(!run.join("run.json").exists() && !run.join("logs").exists());
}

#[test]
fn scaling_shows_pf_colliding_at_100_followers_while_plf_stays_close() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("scaling", tmp.path(), |t| {
        let axes = t["axes"].as_array_mut().unwrap();
        axes[0]["values"] = toml::Value::try_from(["pf", "plf"]).unwrap();
        axes[1]["values"] = toml::Value::try_from([4, 100]).unwrap();
    });
    let out = tmp.path().join("out");
    ok(&campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    ));
    let rows = cells(&out);
    let at = |topology: &str, n: &str| {
        rows.iter()
            .find(|r| r["topology.preset"] == topology && r["platoon.followers"] == n)
            .unwrap()
    };
    let pf = at("pf", "100");
    assert_eq!(pf["collided"], "1", "{pf:?}");
    assert_eq!(pf["safety_class"], "severe");
    assert!(num(pf, "min_gap_m") < 0.0);
    let plf = at("plf", "100");
    assert_eq!(plf["collided"], "0");
    assert!(num(plf, "max_spacing_error_m") < 0.5, "{plf:?}");
    assert!(num(at("pf", "4"), "max_spacing_error_m") < num(pf, "max_spacing_error_m"));
    assert!(out.join("plots/lines_max_spacing_error_m.png").is_file());
    assert!(out.join("plots/heatmap_safety_class.png").is_file());
}

#[test]
fn monte_carlo_compares_rules_on_the_same_schedules() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("monte-carlo", tmp.path(), |_| {});
    let out = tmp.path().join("out");
    ok(&campaign(
        &[
            file.to_str().unwrap(),
            "--samples",
            "20",
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    ));
    let rows = cells(&out);
    assert_eq!(rows.len(), 40);
    // Common random numbers: sample s has one seed and one measured schedule in both rules.
    for s in 0..20 {
        let pair: Vec<_> = rows
            .iter()
            .filter(|r| r["sample"] == s.to_string())
            .collect();
        assert_eq!(pair.len(), 2);
        assert_eq!(pair[0]["seed"], pair[1]["seed"]);
        assert_eq!(pair[0]["attacked_time_s"], pair[1]["attacked_time_s"]);
        assert_eq!(
            pair[0]["assumption2"], "holds",
            "admissible by construction"
        );
    }
    let seeds: std::collections::HashSet<_> = rows.iter().map(|r| r["seed"].clone()).collect();
    assert_eq!(seeds.len(), 20);
    let summary = json(&out.join("campaign.json"));
    let groups = summary["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 2);
    let mean = |g: &serde_json::Value| g["triggers_total"]["mean"].as_f64().unwrap();
    assert!(groups[0]["group"].as_str().unwrap().contains("dynamic"));
    assert!(
        mean(&groups[0]) < mean(&groups[1]),
        "the dynamic rule sends fewer messages: {} vs {}",
        mean(&groups[0]),
        mean(&groups[1])
    );
    // The share of severe cells is the one cells.csv shows (not merely a number).
    for g in groups {
        let rule = if g["group"].as_str().unwrap().contains("dynamic") {
            "dynamic"
        } else {
            "static"
        };
        let of_rule: Vec<_> = rows.iter().filter(|r| r["trigger.rule"] == rule).collect();
        let severe = of_rule
            .iter()
            .filter(|r| r["safety_class"] == "severe")
            .count();
        assert_eq!(of_rule.len(), 20);
        assert_eq!(
            g["severe_fraction"].as_f64(),
            Some(severe as f64 / 20.0),
            "{g}"
        );
    }
    assert!(out.join("plots/ecdf_max_spacing_error_m.png").is_file());
    // The same campaign file and seed give the same cells.csv.
    let again = tmp.path().join("again");
    ok(&campaign(
        &[
            file.to_str().unwrap(),
            "--samples",
            "20",
            "--no-plots",
            "--jobs",
            "1",
            "--out",
            again.to_str().unwrap(),
        ],
        tmp.path(),
    ));
    assert_eq!(
        std::fs::read(out.join("cells.csv")).unwrap(),
        std::fs::read(again.join("cells.csv")).unwrap()
    );
}

#[test]
fn a_sumo_campaign_runs_full_co_simulations() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("sumo-background", tmp.path(), |t| {
        t["set"]["simulation.duration_s"] = toml::Value::Float(5.0);
        t["axes"][0]["values"] = toml::Value::try_from([1, 2]).unwrap();
    });
    let out = tmp.path().join("out");
    ok(&campaign(
        &[
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--keep-runs",
        ],
        tmp.path(),
    ));
    let rows = cells(&out);
    assert_eq!(rows.len(), 2);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r["status"], "ok", "{r:?}");
        let summary = json(&out.join(format!("cells/c000{i}/summary.json")));
        assert!(summary["sumo"]["sumo_version"].is_string(), "SUMO ran");
        // What only an iceoryx2 run writes (an in-process run, kept with --keep-runs, writes
        // timing.json too, but with no stage timings, no duplicate count, no run.json and no
        // logs/): the run id its services were named with, the time of each stage between two
        // processes, and one log per node process.
        let run = out.join(format!("runs/c000{i}"));
        let run_json = json(&run.join("run.json"));
        assert!(
            run_json["run_id"].as_str().is_some_and(|id| !id.is_empty()),
            "{run_json}"
        );
        let timing = json(&run.join("timing.json"));
        for stage in ["controller_tx", "injector", "controller_rx", "plant"] {
            assert!(timing[stage]["p50_us"].is_f64(), "{stage}: {timing}");
        }
        assert!(timing["duplicate_samples"].is_object(), "{timing}");
        for node in ["plant", "controller", "injector"] {
            assert!(run.join(format!("logs/{node}.log")).is_file(), "{node}.log");
        }
    }
    // Background traffic does not move the platoon.
    assert_eq!(
        rows[0]["max_spacing_error_m"],
        rows[1]["max_spacing_error_m"]
    );
    assert_eq!(rows[0]["triggers_total"], rows[1]["triggers_total"]);
}

/// A Dask scheduler and two workers on 127.0.0.1, stopped on drop.
struct Cluster {
    procs: Vec<Child>,
    address: String,
}

impl Cluster {
    /// Workers run `exe` (through `$PLATOON_EXE`, as docs/campaigns.md documents) with `WORKER` set.
    fn start(dir: &Path, exe: &Path) -> Cluster {
        let setup = repo().join("bridge/setup-venv.sh");
        assert!(Command::new(&setup).status().unwrap().success());
        let dask = repo().join("bridge/.venv/bin/dask");
        let file = dir.join("scheduler.json");
        let log = |name: &str| std::fs::File::create(dir.join(name)).unwrap();
        let mut procs = vec![Command::new(&dask)
            .args([
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
            ])
            .arg("--scheduler-file")
            .arg(&file)
            .stdout(log("scheduler.out"))
            .stderr(log("scheduler.log"))
            .spawn()
            .unwrap()];
        let mut address = String::new();
        wait_for("the Dask scheduler's address", || {
            let text = std::fs::read_to_string(&file).unwrap_or_default();
            match serde_json::from_str::<serde_json::Value>(&text) {
                Ok(v) => {
                    address = v["address"].as_str().unwrap().to_string();
                    true
                }
                Err(_) => false,
            }
        });
        for i in 0..2 {
            procs.push(
                Command::new(&dask)
                    .env("PLATOON_EXE", exe)
                    .env("WORKER", format!("w{i}"))
                    .args(["worker", &address, "--nthreads", "1", "--no-dashboard"])
                    .args(["--host", "127.0.0.1", "--name", &format!("w{i}")])
                    .stdout(log(&format!("worker{i}.out")))
                    .stderr(log(&format!("worker{i}.log")))
                    .spawn()
                    .unwrap(),
            );
        }
        // Both workers registered (the scheduler logs each).
        wait_for("both Dask workers to register", || {
            std::fs::read_to_string(dir.join("scheduler.log"))
                .unwrap_or_default()
                .matches("Register worker")
                .count()
                >= 2
        });
        Cluster { procs, address }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for p in self.procs.iter_mut().rev() {
            // SAFETY: signalling our own child.
            unsafe { libc::kill(p.id() as libc::pid_t, libc::SIGTERM) };
        }
        for p in &mut self.procs {
            let deadline = Instant::now() + Duration::from_secs(10);
            while p.try_wait().unwrap().is_none() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = p.kill();
            let _ = p.wait();
        }
    }
}

/// The driver's log of a Dask campaign: how many cells ran in the workers' processes
/// (platoon._core) and how many as `platoon campaign-cell` processes, from its last line.
fn dask_paths(out: &Path) -> (usize, usize, String) {
    let log = std::fs::read_to_string(out.join("dask.log")).unwrap();
    let done = log
        .lines()
        .rev()
        .find_map(|l| l.split_once(" s: done: ").map(|(_, done)| done))
        .unwrap_or_else(|| panic!("no summary line in dask.log:\n{log}"));
    let words: Vec<&str> = done.split_whitespace().collect();
    // "N cells in-worker, M by subprocess, K in failed batches"
    (words[0].parse().unwrap(), words[3].parse().unwrap(), log)
}

#[test]
fn a_dask_cluster_on_localhost_gives_the_local_cells_csv_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(
        tmp.path(),
        "small.toml",
        r#"
        name = "small"
        [[axes]]
        key = "trigger.rule"
        values = ["dynamic", "static"]
        [monte_carlo]
        samples = 3
        loss = [0.0, 0.3]
        tau_s = [0.34, 0.82]
        position_jitter_m = 0.5
        [dos_window]
        onset_s = [12.0]
        duration_s = [1.0, 2.0]
        "#,
    );
    // Two co-simulated cells: in a worker's process they start `platoon run` children.
    let cosim = write(
        tmp.path(),
        "cosim.toml",
        r#"
        name = "cosim"
        transport = "iceoryx2"
        [set]
        "simulation.duration_s" = 5.0
        [[axes]]
        key = "trigger.rule"
        values = ["dynamic", "static"]
        "#,
    );
    let run = |file: &Path, out: &str, extra: &[&str], env: &[(&str, &str)]| -> PathBuf {
        let out = tmp.path().join(out);
        let mut args = vec![file.to_str().unwrap(), "--no-plots", "--out"];
        args.push(out.to_str().unwrap());
        args.extend_from_slice(extra);
        let mut c = platoon_command(tmp.path());
        c.arg("campaign").args(&args).envs(env.iter().copied());
        ok(&c.output().unwrap());
        out
    };
    // A scheduler that is not there is named, and the campaign stays resumable: the Dask
    // client waits out its 20 s connect timeout, so this campaign starts first and is read at
    // the end, the rest of the test running meanwhile.
    let none = tmp.path().join("none");
    let unreachable = platoon_command(tmp.path())
        .args([
            "campaign",
            file.to_str().unwrap(),
            "--dask",
            "tcp://127.0.0.1:9",
            "--out",
        ])
        .arg(&none)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let local = run(&file, "local", &[], &[]);
    let local_cosim = run(&cosim, "local-cosim", &[], &[]);
    // The workers run platoon through a wrapper that logs each call: proof the cells' processes
    // ran there.
    let calls = tmp.path().join("calls.log");
    let wrapper = write(
        tmp.path(),
        "platoon-on-worker.sh",
        &format!(
            "#!/bin/sh\necho \"$WORKER $*\" >> {}\nexec {} \"$@\"\n",
            calls.display(),
            env!("CARGO_BIN_EXE_platoon")
        ),
    );
    std::fs::set_permissions(
        &wrapper,
        std::os::unix::fs::PermissionsExt::from_mode(0o755),
    )
    .unwrap();
    let calls_log = || std::fs::read_to_string(&calls).unwrap_or_default();
    let cluster = Cluster::start(tmp.path(), &wrapper);
    let dask = ["--dask", cluster.address.as_str()];
    let same_cells = |a: &Path, b: &Path| {
        assert_eq!(
            std::fs::read_to_string(a.join("cells.csv")).unwrap(),
            std::fs::read_to_string(b.join("cells.csv")).unwrap(),
            "{} against {}",
            a.display(),
            b.display()
        );
    };

    // By default each batch runs in a worker's process, on the installed package's core (CI
    // installs it into bridge/.venv before the tests): no process per cell.
    let remote = run(&file, "remote", &dask, &[]);
    same_cells(&local, &remote);
    let summary = json(&remote.join("campaign.json"));
    assert!(summary["executor"]
        .as_str()
        .unwrap()
        .starts_with("dask tcp://127.0.0.1"));
    assert_eq!(summary["ok"], 12);
    let (in_worker, subprocess, log) = dask_paths(&remote);
    assert_eq!(
        (in_worker, subprocess),
        (12, 0),
        "the cells did not all run in the workers (is the platoon package installed in \
         bridge/.venv? `pip install ./bridge`):\n{log}"
    );
    let batches: Vec<&str> = log
        .lines()
        .filter(|l| l.contains(": in-worker on "))
        .collect();
    assert!(batches.len() > 1, "{log}");
    assert!(
        batches.iter().all(
            |l| (l.contains(" on w0 ") || l.contains(" on w1 ")) && l.contains("site-packages")
        ),
        "{log}"
    );
    assert_eq!(calls_log(), "", "no process per cell");
    // Co-simulated cells in a worker's process start `platoon run` (which starts its nodes)
    // from the worker's $PLATOON_EXE.
    let remote_cosim = run(&cosim, "remote-cosim", &dask, &[]);
    same_cells(&local_cosim, &remote_cosim);
    assert_eq!(dask_paths(&remote_cosim).0, 2);
    let log = calls_log();
    let runs: Vec<&str> = log.lines().filter(|l| !l.contains(" node ")).collect();
    assert_eq!(runs.len(), 2, "{log}");
    assert!(
        runs.iter()
            .all(|l| (l.starts_with("w0 run ") || l.starts_with("w1 run "))
                && l.contains("--transport iceoryx2")),
        "{log}"
    );
    std::fs::remove_file(&calls).unwrap();

    // PLATOON_DASK_IN_WORKER=0: one `platoon campaign-cell` per cell, started by a worker,
    // and the same cells.csv.
    let forced = run(&file, "forced", &dask, &[("PLATOON_DASK_IN_WORKER", "0")]);
    same_cells(&local, &forced);
    let (in_worker, subprocess, log) = dask_paths(&forced);
    assert_eq!((in_worker, subprocess), (0, 12), "{log}");
    assert!(
        log.contains("subprocess on w") && log.contains("PLATOON_DASK_IN_WORKER=0"),
        "{log}"
    );
    let log = calls_log();
    assert_eq!(log.lines().count(), 12, "{log}");
    assert!(
        log.lines()
            .all(|l| (l.starts_with("w0 ") || l.starts_with("w1 ")) && l.ends_with("campaign-cell")),
        "{log}"
    );
    drop(cluster);
    let o = unreachable.wait_with_output().unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("Dask") && err.contains("127.0.0.1:9"), "{err}");
    assert!(tmp.path().join("none.partial").is_dir());
}

/// `platoon campaign ARGS` in `dir`, started; its first line (the campaign's plan) is read.
fn start_campaign(
    dir: &Path,
    args: &[&str],
) -> (Child, BufReader<std::process::ChildStderr>, String) {
    let mut child = platoon_command(dir)
        .args(args)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    (child, err, line)
}

/// SIGINT to a campaign: it exits 130, says how to resume, and leaves its `.partial`.
fn interrupt(mut child: Child, mut err: BufReader<std::process::ChildStderr>) {
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let status = child.wait().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    assert_eq!(status.code(), Some(130), "{rest}");
    assert!(
        rest.contains("run the same command again to resume"),
        "{rest}"
    );
}

/// A campaign long on purpose (1000 cells of 300 simulated seconds: minutes of work in any
/// build), interrupted once a cell is recorded, so that it cannot have finished whatever the
/// machine's speed; the same command then keeps what was done and goes on, and is interrupted
/// in turn once it has run a cell of its own. (That a resumed campaign completes, with the
/// same bytes, is crates/app/tests/campaign.rs's stopped-campaign test.)
#[test]
fn ctrl_c_keeps_finished_cells_and_the_same_command_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(
        tmp.path(),
        "long.toml",
        "name = \"long\"\nset = { \"simulation.duration_s\" = 300.0 }\n[monte_carlo]\nsamples = 1000\nloss = [0.0, 0.2]\n",
    );
    let out = tmp.path().join("out");
    let args = [
        "campaign",
        file.to_str().unwrap(),
        "--no-plots",
        "--jobs",
        "1",
        "--out",
        out.to_str().unwrap(),
    ];
    let partial = tmp.path().join("out.partial");
    let recorded = |i: u64| partial.join(format!("cells/c{i:04}/cell.json")).exists();
    let (child, err, line) = start_campaign(tmp.path(), &args);
    assert!(line.starts_with("campaign long: 1000 cells"), "{line}");
    // One job: cells finish in order.
    wait_for("the first cell to be recorded", || recorded(0));
    interrupt(child, err);
    assert!(
        !out.exists(),
        "an interrupted campaign never looks finished"
    );
    let summary = json(&partial.join("campaign.json"));
    assert_eq!(summary["complete"], false);
    assert_eq!(summary["interrupted_by"], "SIGINT");
    let done = summary["ok"].as_u64().unwrap();
    assert!(done > 0 && done < 1000, "{done} cells done");
    let before = cells(&partial);
    assert_eq!(
        before.iter().filter(|r| r["status"] == "not_run").count() as u64,
        1000 - done
    );

    let (child, err, line) = start_campaign(tmp.path(), &args);
    assert!(
        line.contains(&format!("{done} finished before and kept")),
        "{line}"
    );
    wait_for("the resumed campaign to record a cell of its own", || {
        recorded(done)
    });
    interrupt(child, err);
    let summary = json(&partial.join("campaign.json"));
    assert_eq!(summary["reused_from_an_earlier_run"], done);
    assert!(summary["ok"].as_u64().unwrap() > done, "{summary}");
    let after = cells(&partial);
    for r in before.iter().filter(|r| r["status"] == "ok") {
        let i: usize = r["cell"].parse().unwrap();
        assert_eq!(&after[i], r, "a kept cell is unchanged");
    }
}

#[test]
fn failed_cells_are_recorded_and_the_exit_code_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(
        tmp.path(),
        "mixed.toml",
        "[[axes]]\nkey = \"simulation.dt_s\"\nvalues = [0.01, 0.0]\n",
    );
    let out = tmp.path().join("out");
    let o = campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("1 of 2 cells failed"), "{err}");
    let rows = cells(&out);
    assert_eq!(rows[0]["status"], "ok");
    assert_eq!(rows[1]["status"], "failed");
    assert!(
        rows[1]["error"].contains("simulation.dt_s"),
        "{:?}",
        rows[1]
    );
    let summary = json(&out.join("campaign.json"));
    assert_eq!(summary["failed"], 1);
    assert_eq!(summary["failures"][0]["cell"], 1);
    // A finished campaign is not overwritten without --force; with it, it is replaced.
    let o = campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    );
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--force"));
    let o = campaign(
        &[
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--force",
        ],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(!tmp.path().join("out.old").exists());
}

#[test]
fn bad_campaign_files_exit_2_with_one_line_and_write_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    for (text, needle) in [
        ("samplez = 3\n", "bad.toml:1"),
        (
            "[[axes]]\nkey = \"trigger.rulez\"\nvalues = [1]\n",
            "bad.toml:2",
        ),
        ("metrics = [\"max_speed\"]\n", "unknown metric `max_speed`"),
        ("base = \"missing.toml\"\n", "key `base`"),
        ("[monte_carlo]\nsamples = 0\n", "monte_carlo.samples"),
    ] {
        let file = write(tmp.path(), "bad.toml", text);
        let out = tmp.path().join("out");
        let o = campaign(
            &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
            tmp.path(),
        );
        assert_eq!(o.status.code(), Some(2), "{text}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{needle:?} in {err}");
        assert!(!out.exists() && !tmp.path().join("out.partial").exists());
    }
}

#[test]
fn every_shipped_campaign_parses() {
    let mut seen = 0;
    for entry in std::fs::read_dir(repo().join("campaigns")).unwrap() {
        let path = entry.unwrap().path();
        // worst-dos*.toml are search files (`platoon search`; tests/search.rs parses them).
        let search = path
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with("worst-dos"));
        if path.extension().is_some_and(|e| e == "toml") && !search {
            let c = platoon_campaign::Campaign::load(&path, None).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                c.cells.iter().all(|cell| cell.config.is_ok()),
                "{}: every cell is a valid scenario",
                path.display()
            );
            seen += 1;
        }
    }
    assert_eq!(seen, 8);
}

/// campaigns/join-loss.toml whole (60 cells, in process): the middle join under every loss
/// rate it draws, binned as docs/maneuvers.md publishes it; nobody collides.
#[test]
fn a_middle_join_under_loss_completes_as_the_docs_say() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("join-loss", tmp.path(), |_| {});
    let out = tmp.path().join("out");
    ok(&campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    ));
    let rows = cells(&out);
    assert_eq!(rows.len(), 60);
    for (lo, hi) in [(0.0, 0.15), (0.15, 0.3), (0.3, 0.45), (0.45, 0.6)] {
        let bin: Vec<_> = rows
            .iter()
            .filter(|r| (lo..hi).contains(&num(r, "mc.loss")))
            .collect();
        let done: Vec<f64> = bin
            .iter()
            .filter(|r| r["maneuvers_completed"] == "1")
            .map(|r| num(r, "maneuver_time_s"))
            .collect();
        let smallest = bin
            .iter()
            .map(|r| num(r, "min_gap_m"))
            .fold(f64::INFINITY, f64::min);
        assert!(bin.iter().all(|r| r["safety_class"] != "severe"));
        let slowest = done.iter().copied().fold(0.0, f64::max);
        published(
            "docs/maneuvers.md",
            "| {}-{} | {} of {} | {} | {} |",
            &[
                format!("{:.0} %", lo * 100.0),
                format!("{:.0} %", hi * 100.0),
                done.len().to_string(),
                bin.len().to_string(),
                format!("{slowest:.1}"),
                format!("{smallest:.1}"),
            ],
        );
    }
}

/// campaigns/jammer.toml: the README's findings on four of its cells, measured in the run.
#[test]
fn a_jammer_on_the_road_breaks_the_platoon_as_the_readme_says() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("jammer", tmp.path(), |t| {
        let axes = toml::from_str::<toml::Table>(
            "[[axes]]\nkey = \"channel.jammers[0].power_dbm\"\nvalues = [0.0, 20.0, 25.0]\nzip = \"j\"\n\
             [[axes]]\nkey = \"channel.jammers[0].lateral_m\"\nvalues = [50.0, 300.0, 10.0]\nzip = \"j\"\n\
             [[axes]]\nkey = \"fallback.mode\"\nvalues = [\"zero\", \"acc\"]",
        )
        .unwrap();
        t.insert("axes".into(), axes["axes"].clone());
    });
    let out = tmp.path().join("out");
    ok(&campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    ));
    let rows = cells(&out);
    assert_eq!(rows.len(), 6);
    let at = |power: &str, mode: &str| {
        rows.iter()
            .find(|r| r["channel.jammers[0].power_dbm"] == power && r["fallback.mode"] == mode)
            .unwrap()
    };
    // 0 dBm at 50 m: an admissible observed DoS of ~5.8 s, and u = 0 collides.
    let weak = at("0", "zero");
    assert_eq!(weak["observed_assumption2"], "holds");
    assert!(
        (5.0..6.5).contains(&num(weak, "observed_jammed_s")),
        "{weak:?}"
    );
    assert!(num(weak, "min_gap_m") < 0.0);
    // 20 dBm at 300 m never reaches the road: nothing observed, the unattacked 8.45 m.
    let far = at("20", "zero");
    assert_eq!(num(far, "observed_jammed_s"), 0.0);
    assert!((num(far, "min_gap_m") - 8.45).abs() < 0.01);
    // 25 dBm at 10 m: violated; u = 0 collides, ACC keeps ~8 m.
    assert_eq!(at("25", "zero")["observed_assumption2"], "violated");
    assert!(num(at("25", "zero"), "min_gap_m") < 0.0);
    assert!(num(at("25", "acc"), "min_gap_m") > 7.0);
}

#[test]
fn fallback_timing_maps_which_fallback_survives_a_jam_on_the_braking_ramp() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("fallback-timing", tmp.path(), |t| {
        let axes = toml::from_str::<toml::Table>(
            "[[axes]]\nkey = \"fallback.mode\"\nvalues = [\"zero\", \"acc\"]\n\
             [[axes]]\nkey = \"guard.enabled\"\nvalues = [false, true]",
        )
        .unwrap();
        t.insert("axes".into(), axes["axes"].clone());
        t.insert(
            "dos_window".into(),
            toml::from_str::<toml::Value>("onset_s = [34.0]\nduration_s = [8.0]").unwrap(),
        );
    });
    let out = tmp.path().join("out");
    ok(&campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    ));
    let rows = cells(&out);
    assert_eq!(rows.len(), 4);
    let at = |mode: &str, guard: &str| {
        rows.iter()
            .find(|r| r["fallback.mode"] == mode && r["guard.enabled"] == guard)
            .unwrap()
    };
    assert_eq!(at("zero", "false")["collided"], "1");
    assert_eq!(at("zero", "true")["collided"], "0", "the guard prevents it");
    assert!(num(at("zero", "true"), "guard_activations") > 0.0);
    assert_eq!(at("acc", "false")["collided"], "0");
    assert!(num(at("acc", "false"), "fallback_time_s") > 4.0 * 8.0);
    assert!(num(at("acc", "false"), "min_ttc_s") > 0.0);
}

/// campaigns/density.toml: the README's findings on the load the platoon's beaconing puts on the
/// 802.11p channel, measured in the run (a subset of its cells).
#[test]
fn the_density_study_finds_what_the_readme_says() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shipped("density", tmp.path(), |t| {
        let axes = t["axes"].as_array().unwrap().clone();
        let mut keep = Vec::new();
        for mut a in axes {
            let table = a.as_table_mut().unwrap();
            match table["key"].as_str().unwrap() {
                "channel.radio.density_veh_per_m" => {
                    table.insert(
                        "values".into(),
                        toml::Value::Array(vec![0.0.into(), 0.48.into()]),
                    );
                }
                // CAM, static and dynamic (the first is periodic).
                "trigger" => {
                    let v = table["values"].as_array().unwrap()[1..].to_vec();
                    table.insert("values".into(), toml::Value::Array(v));
                }
                _ => {}
            }
            keep.push(a);
        }
        t.insert("axes".into(), toml::Value::Array(keep));
    });
    let out = tmp.path().join("out");
    ok(&campaign(
        &[file.to_str().unwrap(), "--out", out.to_str().unwrap()],
        tmp.path(),
    ));
    let rows = cells(&out);
    assert_eq!(rows.len(), 24);
    let at = |density: &str, rule: &str, background: &str, dcc: bool| {
        rows.iter()
            .find(|r| {
                r["channel.radio.density_veh_per_m"] == density
                    && r["trigger"].contains(&format!("rule = \"{rule}\""))
                    && r["channel.background_beacons"] == background
                    && r["channel.dcc.t_off_s"].contains("0.06") == dcc
            })
            .unwrap_or_else(|| panic!("{density} {rule} {background} {dcc}"))
    };
    // Around traffic beaconing at 10 Hz, the platoon's rule hardly moves the channel.
    let (s, d) = (
        at("0.48", "static", "fixed", false),
        at("0.48", "dynamic", "fixed", false),
    );
    assert!(
        (num(s, "mean_cbr") - num(d, "mean_cbr")).abs() < 0.01,
        "{s:?} {d:?}"
    );
    assert!((num(s, "delivery_ratio") - num(d, "delivery_ratio")).abs() < 0.01);
    // When every vehicle beacons as the platoon does, the dynamic trigger's fewer packets buy a
    // less busy channel and a better delivery ratio than the static one's.
    let (s, d) = (
        at("0.48", "static", "platoon", false),
        at("0.48", "dynamic", "platoon", false),
    );
    assert!(
        num(d, "transmissions") < 0.9 * num(s, "transmissions"),
        "{s:?} {d:?}"
    );
    assert!(
        num(d, "mean_cbr") < num(s, "mean_cbr") - 0.03,
        "{s:?} {d:?}"
    );
    assert!(
        num(d, "delivery_ratio") > num(s, "delivery_ratio") + 0.02,
        "{s:?} {d:?}"
    );
    // Reactive DCC in a busy channel holds the paper's triggers back: the gap error doubles.
    let (off, on) = (
        at("0.48", "dynamic", "fixed", false),
        at("0.48", "dynamic", "fixed", true),
    );
    assert!(num(on, "dcc_deferred") > 1000.0, "{on:?}");
    assert!(num(on, "rms_spacing_error_m") > 1.5 * num(off, "rms_spacing_error_m"));
    // The paper's law on CAM beacons collides even on an empty channel, without DoS.
    let cam = at("0", "cam", "fixed", false);
    assert!(
        num(cam, "delivery_ratio") > 0.99 && num(cam, "min_gap_m") < 0.0,
        "{cam:?}"
    );
}
