//! `platoon_app::run` as a library call: the same results as the pure core, files only where
//! the caller says, any sink under the same step loop.
use platoon_app::run::{self, RunOptions, StepSink, Stop};
use platoon_config::{Embedded, Transport};
use platoon_sim::{StepRow, StepWire};

fn short_paper(duration: &str) -> (platoon_config::Config, platoon_sim::Scenario) {
    let text = platoon_config::PAPER_TOML.replace("duration_s = 55.0", duration);
    platoon_config::parse(&text, std::path::Path::new(&Embedded::Paper.label())).unwrap()
}

#[test]
fn a_run_directory_holds_what_the_pure_core_computes() {
    let (config, scenario) = short_paper("duration_s = 20.0");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("paper");
    let opts = RunOptions {
        transport: Transport::Inproc,
        plots: false,
        ..RunOptions::default()
    };
    let done = run::run(config, &scenario, &opts, &out, false, &Stop::default(), &()).unwrap();
    assert_eq!(done.dir, out);
    assert!(done.failure.is_none() && done.stopped.is_none());
    let oracle = platoon_sim::run(scenario.clone(), |_| {}).unwrap();
    let mut expected = oracle.clone();
    expected.attack.applied = true;
    assert_eq!(done.summary, expected);
    // summary.json is the same summary plus the injector it ran with.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["injector"]["program"], "built-in");
    let read: platoon_sim::Summary = serde_json::from_value(json).unwrap();
    assert_eq!(read, expected);
    for f in [
        "config.toml",
        "trajectories.csv",
        "events.csv",
        "timing.json",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    assert!(!out.join("fig6.png").exists(), "plots were not asked for");
    assert!(!tmp.path().join("paper.partial").exists());
    // Platoon 0's rows, one per vehicle and step.
    assert_eq!(done.rows.len() as u64, (scenario.steps + 1) * 5);
}

/// A sink of the caller's: counts what it is given.
#[derive(Default)]
struct Count {
    steps: u64,
    rows: usize,
    sent: u64,
    finished: bool,
}

impl StepSink for Count {
    fn step(&mut self, rows: &[StepRow], wire: StepWire<'_>) -> Result<(), run::RunError> {
        self.steps += 1;
        self.rows += rows.len();
        self.sent += wire.per_vehicle.iter().map(|c| c.sent).sum::<u64>();
        Ok(())
    }
    fn finish(&mut self) -> Result<(), run::RunError> {
        self.finished = true;
        Ok(())
    }
}

#[test]
fn any_sink_hears_every_step_of_a_fleet_and_a_stop_ends_the_run() {
    let (_, mut scenario) = short_paper("duration_s = 5.0");
    scenario.fleet.platoons = 3;
    let mut count = Count::default();
    let (summary, step_ns) = run::record(&scenario, &mut count, &Stop::default(), &()).unwrap();
    assert!(count.finished && summary.complete);
    assert_eq!(count.steps, scenario.steps + 1);
    assert_eq!(step_ns.len() as u64, count.steps);
    assert_eq!(count.rows as u64, count.steps * 3 * 5);
    assert_eq!(count.sent, summary.wire.as_ref().unwrap().totals.sent);
    assert_eq!(summary.fleet.as_ref().unwrap().platoons, 3);

    // A stop asked before the run ends it after its first step, and says so.
    let flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let stop = Stop::new(flag, || Some("stopped by the test".into()));
    let mut count = Count::default();
    let (summary, _) = run::record(&scenario, &mut count, &stop, &()).unwrap();
    assert_eq!(count.steps, 1);
    assert!(!summary.complete);
    assert_eq!(stop.reason().as_deref(), Some("stopped by the test"));
}

#[test]
fn options_a_run_cannot_honour_are_refused_before_anything_is_written() {
    let (config, scenario) = short_paper("duration_s = 1.0");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x");
    let opts = RunOptions {
        transport: Transport::Inproc,
        injector: Some(run::Injector {
            command: "true".into(),
            mode: run::InjectorMode::Replace,
        }),
        ..RunOptions::default()
    };
    let e = run::run(config, &scenario, &opts, &out, false, &Stop::default(), &()).unwrap_err();
    assert!(
        e.to_string()
            .contains("--injector needs --transport iceoryx2"),
        "{e}"
    );
    assert!(!out.exists() && !tmp.path().join("x.partial").exists());
}

#[test]
fn a_run_that_fails_says_its_kind() {
    // A config the run cannot measure: the config's kind, naming the key.
    let (config, mut scenario) = short_paper("duration_s = 1.0");
    scenario.control.detection.plugin = vec!["theirs".into()];
    let tmp = tempfile::tempdir().unwrap();
    let opts = RunOptions {
        transport: Transport::Inproc,
        plots: false,
        ..RunOptions::default()
    };
    let out = tmp.path().join("x");
    let e = run::run(config, &scenario, &opts, &out, false, &Stop::default(), &()).unwrap_err();
    let run::RunError::Config(c) = &e else {
        panic!("not a config error: {e:?}")
    };
    assert_eq!(c.key, "detection.plugin");
    assert_eq!(e.config().map(|c| c.key.as_str()), Some("detection.plugin"));
    assert!(!out.exists());

    // A destination that is not to be replaced: the output's kind, with its path.
    let (config, scenario) = short_paper("duration_s = 1.0");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("mine.txt"), "not a run").unwrap();
    let e = run::run(config, &scenario, &opts, &out, false, &Stop::default(), &()).unwrap_err();
    let run::RunError::Output(o) = &e else {
        panic!("not an output error: {e:?}")
    };
    assert_eq!(o.path(), Some(out.as_path()));
    assert!(e.config().is_none());

    // Options that do not go together: neither.
    let (config, scenario) = short_paper("duration_s = 1.0");
    let opts = RunOptions {
        controller: Some("true".into()),
        ..opts
    };
    let e = run::run(config, &scenario, &opts, &out, true, &Stop::default(), &()).unwrap_err();
    assert!(matches!(e, run::RunError::Other(_)), "{e:?}");
}

#[test]
fn a_failed_process_is_a_node_failure_with_its_log() {
    let tmp = tempfile::tempdir().unwrap();
    let logs = tmp.path().join("logs");
    std::fs::create_dir(&logs).unwrap();
    std::fs::write(logs.join("injector.log"), "Traceback: gave up\n").unwrap();
    let died = platoon_runtime::CosimError::Died {
        node: "injector",
        pid: 42,
        step: 7,
        status: "exit status: 3".into(),
        detail: "\n  the last lines of logs/injector.log (in the run directory):".into(),
    };
    let shown = died.to_string();
    let e = run::RunError::from_runtime(died, &logs);
    // The message is the run's, unchanged.
    assert_eq!(e.to_string(), shown);
    let run::RunError::Node(n) = &e else {
        panic!("not a node failure: {e:?}")
    };
    assert_eq!(
        (n.node, n.step, n.log.as_deref()),
        (
            "injector",
            Some(7),
            Some(logs.join("injector.log").as_path())
        )
    );
    assert_eq!(n.message, "exited: exit status: 3");

    // A node that reported its failure and wrote no log.
    let failed = platoon_runtime::CosimError::Failed {
        node: "controller",
        step: 3,
        reason: "no gain".into(),
        detail: String::new(),
    };
    let run::RunError::Node(n) = run::RunError::from_runtime(failed, &logs) else {
        panic!("not a node failure")
    };
    assert_eq!(
        (n.node, n.step, n.log, n.message.as_str()),
        ("controller", Some(3), None, "no gain")
    );

    // No process to blame: the co-simulation's own kind.
    let ipc = platoon_runtime::CosimError::Ipc {
        what: "creating a service".into(),
        source: "refused".into(),
    };
    assert!(matches!(
        run::RunError::from_runtime(ipc, &logs),
        run::RunError::Cosim(_)
    ));
}
