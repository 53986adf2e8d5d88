//! `platoon_app::campaign` as a library call, in process with no binary: the typed results of
//! every cell equal the pure core's, the files go only into the campaign directory, any
//! executor gives the same bytes, and a stopped campaign resumes.
use platoon_app::campaign::{
    self, Campaign, CampaignError, CampaignOptions, CellStatus, Execution, Executor, LocalPool,
};
use platoon_app::Stop;
use platoon_campaign::metrics;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Two cells of the embedded paper scenario, 5 s each: the dynamic and the static trigger.
const TWO: &str = r#"
name = "two"
set = { "simulation.duration_s" = 5.0 }
metrics = ["max_spacing_error_m", "triggers_total", "safety_class"]
[[axes]]
key = "trigger.rule"
values = ["dynamic", "static"]
"#;

fn two(dir: &Path) -> Campaign {
    Campaign::parse(TWO, &dir.join("two.toml"), None).unwrap()
}

fn no_plots() -> CampaignOptions {
    CampaignOptions {
        plots: false,
        ..CampaignOptions::default()
    }
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn a_local_pool_gives_each_cell_the_pure_cores_summary_and_metrics() {
    let tmp = tempfile::tempdir().unwrap();
    let c = two(tmp.path());
    let out = tmp.path().join("two");
    let pool = LocalPool {
        jobs: 2,
        program: None,
        plugins: Default::default(),
    };
    let done = campaign::run(&c, &out, &no_plots(), &pool, &Stop::default(), &()).unwrap();
    assert!(done.committed && !done.resumed);
    assert!(done.failure.is_none() && done.stopped.is_none());
    assert_eq!(done.dir, out);
    assert_eq!(
        done.columns,
        ["max_spacing_error_m", "triggers_total", "safety_class"]
    );
    assert_eq!(done.cells.len(), 2);
    for (cell, result) in c.cells.iter().zip(&done.cells) {
        assert_eq!(result.status, CellStatus::Ok, "{:?}", result.error);
        assert!(!result.reused);
        let (_, scenario) =
            platoon_config::parse(cell.config.as_ref().unwrap(), Path::new("cell")).unwrap();
        let expected = platoon_sim::run(scenario, |_| {}).unwrap();
        assert_eq!(expected.steps, 501);
        let summary = result.summary.as_ref().unwrap();
        assert_eq!(summary, &expected);
        assert_eq!(
            result.metrics.as_deref(),
            Some(&metrics::extract(&c.metrics, c.max_followers(), &expected)[..])
        );
        assert_eq!(
            result.summary_json().unwrap()["injector"]["program"],
            "built-in"
        );
    }
    // The static rule broadcasts more than the dynamic one on the same scenario.
    let total = |i: usize| done.cells[i].summary.as_ref().unwrap().triggers_total;
    assert!(total(1) > total(0), "{} vs {}", total(0), total(1));
    let r = &done.report;
    assert!(r.complete && r.interrupted_by.is_none());
    assert_eq!((r.cells, r.ok, r.failed, r.not_run), (2, 2, 0, 0));
    assert_eq!(r.executor, "local pool, 2 jobs");
    assert_eq!(r.groups.len(), 2);
    assert_eq!(r.groups[1].group, "trigger.rule = static");
    assert_eq!(
        r.groups[1].metrics["triggers_total"].median,
        total(1) as f64
    );
    assert!(r.plots.is_empty());
    // campaign.json is the report; the files are in the campaign directory and nowhere else.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("campaign.json")).unwrap()).unwrap();
    assert_eq!(json, serde_json::to_value(r).unwrap());
    assert_eq!(names(tmp.path()), ["two"]);
    assert_eq!(
        names(&out),
        [
            "base.toml",
            "campaign.json",
            "campaign.toml",
            "cells",
            "cells.csv"
        ]
    );
    assert_eq!(names(&out.join("cells")), ["c0000", "c0001"]);
}

/// An executor of the caller's: runs the first `limit` jobs one by one on the calling thread,
/// then asks the campaign to stop.
struct Sequential {
    limit: usize,
    stop: Arc<AtomicBool>,
}

impl Executor for Sequential {
    fn name(&self) -> String {
        "sequential".into()
    }

    fn execute(&self, run: Execution<'_>) -> Result<(), campaign::ExecutorError> {
        for job in run.jobs.iter().take(self.limit) {
            (run.record)(campaign::execute(job, None))?;
        }
        if run.jobs.len() > self.limit {
            self.stop.store(true, Ordering::SeqCst);
        }
        Ok(())
    }
}

#[test]
fn any_executor_gives_the_same_bytes_and_a_stopped_campaign_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    let c = two(tmp.path());
    let pooled = tmp.path().join("pooled");
    let pool = LocalPool {
        jobs: 1,
        program: None,
        plugins: Default::default(),
    };
    campaign::run(&c, &pooled, &no_plots(), &pool, &Stop::default(), &()).unwrap();

    // One cell, then a stop: the directory stays unfinished and says what is done.
    let out = tmp.path().join("mine");
    let flag = Arc::new(AtomicBool::new(false));
    let stop = Stop::new(flag.clone(), || Some("asked to".into()));
    let first = Sequential {
        limit: 1,
        stop: flag.clone(),
    };
    let done = campaign::run(&c, &out, &no_plots(), &first, &stop, &()).unwrap();
    assert!(!done.committed);
    assert_eq!(done.stopped.as_deref(), Some("asked to"));
    assert_eq!(done.dir, tmp.path().join("mine.partial"));
    assert!(!out.exists());
    let status: Vec<CellStatus> = done.cells.iter().map(|r| r.status).collect();
    assert_eq!(status, [CellStatus::Ok, CellStatus::NotRun]);
    assert!(!done.report.complete);
    assert_eq!(done.report.interrupted_by.as_deref(), Some("asked to"));

    // The same campaign again resumes it: the finished cell is kept, the other one runs.
    let rest = Sequential {
        limit: usize::MAX,
        stop: Arc::new(AtomicBool::new(false)),
    };
    let done = campaign::run(&c, &out, &no_plots(), &rest, &Stop::default(), &()).unwrap();
    assert!(done.committed && done.resumed);
    assert_eq!(done.dir, out);
    assert_eq!(done.reused(), 1);
    assert!(done.cells[0].reused && !done.cells[1].reused);
    assert_eq!(done.count(CellStatus::Ok), 2);
    assert_eq!(done.report.reused_from_an_earlier_run, 1);
    assert_eq!(done.report.executor, "sequential");
    let read = |dir: &Path, file: &str| std::fs::read(dir.join(file)).unwrap();
    assert_eq!(read(&out, "cells.csv"), read(&pooled, "cells.csv"));
    for cell in ["c0000", "c0001"] {
        for file in ["config.toml", "summary.json", "cell.json"] {
            let path = format!("cells/{cell}/{file}");
            assert_eq!(read(&out, &path), read(&pooled, &path), "{path}");
        }
    }
}

#[test]
fn an_invalid_cell_is_a_failed_result_naming_the_key_and_the_rest_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let text = "set = { \"simulation.duration_s\" = 2.0 }\n\
                [[axes]]\nkey = \"simulation.dt_s\"\nvalues = [0.01, 0.0]\n";
    let c = Campaign::parse(text, &tmp.path().join("mixed.toml"), None).unwrap();
    let out = tmp.path().join("mixed");
    let done = campaign::run(
        &c,
        &out,
        &no_plots(),
        &LocalPool::default(),
        &Stop::default(),
        &(),
    )
    .unwrap();
    assert!(done.committed);
    assert_eq!(done.cells[0].status, CellStatus::Ok);
    assert_eq!(done.cells[1].status, CellStatus::Failed);
    assert!(done.cells[1].summary.is_none() && done.cells[1].metrics.is_none());
    let error = done.cells[1].error.as_deref().unwrap();
    assert!(error.contains("simulation.dt_s"), "{error}");
    assert_eq!(done.report.failures.len(), 1);
    assert_eq!(done.report.failures[0].cell, 1);
    assert_eq!(done.report.failures[0].directory, "cells/c0001");
}

/// With no campaign directory at all: every cell's result in memory, the same as a run into a
/// directory gives, and a stop leaves the remaining cells not run.
#[test]
fn a_campaign_evaluated_in_memory_gives_what_the_directory_run_records() {
    let tmp = tempfile::tempdir().unwrap();
    let c = two(tmp.path());
    let before = names(tmp.path());
    let cells = campaign::evaluate(&c, None, &Stop::default(), &());
    assert_eq!(names(tmp.path()), before, "nothing written");
    let done = campaign::run(
        &c,
        &tmp.path().join("two"),
        &no_plots(),
        &LocalPool::default(),
        &Stop::default(),
        &(),
    )
    .unwrap();
    assert_eq!(cells.len(), 2);
    for (mem, dir) in cells.iter().zip(&done.cells) {
        assert_eq!(mem.status, CellStatus::Ok, "{:?}", mem.error);
        assert_eq!(mem.summary, dir.summary);
        assert_eq!(mem.metrics, dir.metrics);
        assert_eq!(mem.summary_json(), dir.summary_json());
    }

    let stopped = Stop::new(Arc::new(AtomicBool::new(true)), || Some("test".into()));
    let cells = campaign::evaluate(&c, None, &stopped, &());
    assert!(cells.iter().all(|r| r.status == CellStatus::NotRun));
}

/// `control.law` is a campaign axis like any key: each cell runs the law it names, and says so.
#[test]
fn the_law_is_a_campaign_axis() {
    // The paper's scenario with periodic beacons at 10 Hz on plf, 5 m apart.
    let paper = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/paper.toml"),
    )
    .unwrap();
    let mut base = String::new();
    for line in paper.lines() {
        let line = match line.split_whitespace().next() {
            Some("phi" | "rho" | "eta" | "theta0" | "check_period_s") => continue,
            Some("rule") => "rule = \"periodic\"\nperiod_s = 0.1",
            Some("preset") => "preset = \"plf\"",
            Some("spacing_m") => "spacing_m = 5.0",
            Some("duration_s") => "duration_s = 10.0",
            _ => line,
        };
        base.push_str(line);
        base.push('\n');
    }
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("base.toml"), base).unwrap();
    let text = r#"
name = "laws"
base = "base.toml"
metrics = ["max_spacing_error_m", "triggers_total", "safety_class"]
[[axes]]
key = "control.law"
values = ["paper", "path_cacc", "flatbed"]
"#;
    let c = Campaign::parse(text, &tmp.path().join("laws.toml"), None).unwrap();
    let cells = campaign::evaluate(&c, None, &Stop::default(), &());
    let laws: Vec<String> = cells
        .iter()
        .map(|cell| {
            cell.summary_json().unwrap()["law"]
                .as_str()
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(laws, ["paper", "path_cacc", "flatbed"]);
    let errors: Vec<f64> = cells
        .iter()
        .map(|cell| {
            cell.summary_json().unwrap()["vehicles"][0]["spacing_error_m"]["mean_abs"]
                .as_f64()
                .unwrap()
        })
        .collect();
    assert!(
        errors[0] != errors[1] && errors[1] != errors[2],
        "{errors:?}"
    );
}

/// A law of the caller's, in Rust, runs a campaign's in-process cells with no process per cell:
/// each cell's summary is what the pure core gives with that controller.
#[test]
fn a_callers_controller_runs_in_process_cells() {
    use platoon_control::{ComposedController, Composition, Law, View};
    use platoon_sim::ControllerFactory;

    /// A PD law on the radar: 8 m of bumper gap.
    #[derive(Debug, Clone)]
    struct Radar;
    impl Law for Radar {
        fn command(&mut self, view: &View<'_>) -> f64 {
            view.radar
                .map_or(0.0, |r| 0.5 * (r.gap - 8.0) - 1.2 * r.closing)
        }
    }
    let factory = ControllerFactory::new(|s| {
        let parts = Composition {
            dt: s.control.dt,
            beaconing: Box::new(platoon_control::Periodic { steps: 10 }),
            leader_broadcast_steps: 1,
            spacing: s.control.spacing,
            headway: s.control.headway,
            fallback: s.control.fallback.clone(),
            detection: Default::default(),
            maneuvers: None,
            security: None,
        };
        Ok(Box::new(ComposedController::new(
            Box::new(Radar),
            parts,
            &s.topology,
            &s.initial,
        )?))
    });
    let tmp = tempfile::tempdir().unwrap();
    let c = two(tmp.path());
    let pool = LocalPool {
        jobs: 2,
        program: None,
        plugins: platoon_app::campaign::CellPlugins {
            controller: Some(factory.clone()),
            injector: None,
        },
    };
    let done = campaign::run(
        &c,
        &tmp.path().join("mine"),
        &no_plots(),
        &pool,
        &Stop::default(),
        &(),
    )
    .unwrap();
    let builtin = campaign::evaluate(&c, None, &Stop::default(), &());
    for ((cell, ours), theirs) in done.cells.iter().zip(&c.cells).zip(&builtin) {
        let config = ours.config.as_ref().unwrap();
        let (_, scenario) = platoon_config::parse(config, Path::new("cell.toml")).unwrap();
        let direct = platoon_sim::run_until_with(&scenario, &factory, |_| {
            std::ops::ControlFlow::Continue(())
        })
        .unwrap();
        let got = cell.summary_json().unwrap();
        assert_eq!(
            got["triggers_total"],
            serde_json::json!(direct.triggers_total)
        );
        assert_eq!(
            got["vehicles"][1]["gap_error_m"]["max_abs"],
            serde_json::json!(direct.vehicles[1].gap_error_m.max_abs)
        );
        // Beacons every 10 steps: 51 per follower in 5 s, not the paper's trigger's count.
        assert_eq!(direct.triggers_total, 4 * 51);
        assert_ne!(
            got["triggers_total"],
            theirs.summary_json().unwrap()["triggers_total"]
        );
    }
}

/// An executor of the caller's that fails after the first cell.
struct Failing;

impl Executor for Failing {
    fn name(&self) -> String {
        "failing".into()
    }

    fn execute(&self, run: Execution<'_>) -> Result<(), campaign::ExecutorError> {
        (run.record)(campaign::execute(&run.jobs[0], None))?;
        Err(platoon_app::OtherError::new("the cluster went away").into())
    }
}

#[test]
fn a_campaigns_failures_come_back_by_kind() {
    let tmp = tempfile::tempdir().unwrap();
    let c = two(tmp.path());
    let out = tmp.path().join("two");
    // The executor's: the cells done are recorded, the directory stays unfinished.
    let done = campaign::run(&c, &out, &no_plots(), &Failing, &Stop::default(), &()).unwrap();
    let Some(CampaignError::Executor(e)) = &done.failure else {
        panic!("{:?}", done.failure);
    };
    assert_eq!(e.to_string(), "the cluster went away");
    assert!(!done.committed && done.count(CellStatus::Ok) == 1);

    // A directory that is not a campaign's is refused: nothing runs.
    let mine = tmp.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), "mine").unwrap();
    let e = campaign::run(&c, &mine, &no_plots(), &Failing, &Stop::default(), &()).unwrap_err();
    let CampaignError::Output(o) = &e else {
        panic!("{e:?}");
    };
    assert_eq!(o.path(), Some(mine.as_path()), "{e}");
    assert!(e.config().is_none());
}
