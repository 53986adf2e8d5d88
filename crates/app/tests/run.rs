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
    fn step(&mut self, rows: &[StepRow], wire: StepWire<'_>) -> anyhow::Result<()> {
        self.steps += 1;
        self.rows += rows.len();
        self.sent += wire.per_vehicle.iter().map(|c| c.sent).sum::<u64>();
        Ok(())
    }
    fn finish(&mut self) -> anyhow::Result<()> {
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
