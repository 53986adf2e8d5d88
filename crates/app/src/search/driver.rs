//! The search's driver: each problem's strategies run generation by generation as campaign
//! cells, their harms read back, and the worst schedule re-run and checked.
use super::report::{study_tables, write_problem};
use super::{
    Evaluation, Found, MethodOutcome, Problem, ProblemOutcome, Search, SearchError, SearchOptions,
    SearchOutcome,
};
use crate::campaign::{CellJob, CellReply, Execution, Executor};
use crate::error::{Context, OtherError};
use crate::progress::Progress;
use crate::run::Stop;
use platoon_campaign::metrics;
use platoon_output::rundir::RunDir;
use platoon_search::{Evolution, GridSampler, RandomSampler, Schedule, Strategy};
use platoon_sim::Summary;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Runs `jobs` on `executor` and returns their replies in job order.
pub(super) fn execute(
    executor: &dyn Executor,
    jobs: &[CellJob],
    dir: &Path,
    stop: &Stop,
) -> Result<Vec<Option<CellReply>>, SearchError> {
    let mut replies: Vec<Option<CellReply>> = vec![None; jobs.len()];
    let mut record = |r: CellReply| {
        let i = r.index;
        match replies.get_mut(i) {
            Some(slot) => *slot = Some(r),
            None => bail!("a worker replied for job {i}, which this batch does not have"),
        }
        Ok(())
    };
    executor.execute(Execution {
        jobs,
        dir,
        stop,
        record: &mut record,
    })?;
    Ok(replies)
}

/// What every batch of one problem's search shares: the search, the problem, who runs the
/// cells and where (the staging directory, for the executor's logs), when to stop, and who
/// hears of the evaluations.
struct Driver<'a> {
    search: &'a Search,
    problem: &'a Problem,
    executor: &'a dyn Executor,
    dir: &'a Path,
    stop: &'a Stop,
    progress: &'a dyn Progress,
}

impl Driver<'_> {
    fn stopped(&self) -> bool {
        self.stop.flag.load(Ordering::SeqCst)
    }
}

/// Runs `schedules` on the driver's problem and measures them; the first is evaluation
/// number `first`.
fn evaluate(
    driver: &Driver<'_>,
    schedules: &[Schedule],
    first: usize,
) -> Result<Vec<Evaluation>, SearchError> {
    let Driver {
        search,
        problem,
        executor,
        dir,
        stop,
        ..
    } = *driver;
    let jobs: Vec<CellJob> = schedules
        .iter()
        .enumerate()
        .map(|(index, s)| CellJob {
            index,
            config: platoon_config::to_toml(&problem.config_of(s)),
            transport: search.spec.transport,
            keep: None,
        })
        .collect();
    let replies = execute(executor, &jobs, dir, stop)?;
    Ok(schedules
        .iter()
        .zip(replies)
        .enumerate()
        .map(|(k, (s, reply))| {
            let mut e = Evaluation {
                evaluation: first + k,
                schedule: s.clone(),
                harm: None,
                score: f64::NEG_INFINITY,
                class: None,
                error: None,
            };
            let summary = match reply {
                None => Err("not run".to_string()),
                Some(CellReply {
                    summary: Some(json),
                    ..
                }) => metrics::read(&json),
                Some(CellReply { error, .. }) => Err(error.unwrap_or_else(|| "no result".into())),
            };
            match summary {
                Ok(summary) => match metrics::failure(&summary) {
                    Some(why) => e.error = Some(why),
                    None => {
                        e.harm = search.harm.value(&summary);
                        e.score = search.harm.score(&summary);
                        e.class = Some(
                            summary
                                .fleet
                                .as_ref()
                                .map_or(summary.safety.class, |f| f.class),
                        );
                    }
                },
                Err(why) => e.error = Some(why),
            }
            e
        })
        .collect())
}

/// Drives one strategy through `evaluations` runs, `batch` at a time; `done` counts every
/// evaluation of the search.
fn drive(
    driver: &Driver<'_>,
    strategy: &mut dyn Strategy,
    batch: usize,
    done: &mut u64,
) -> Result<MethodOutcome, SearchError> {
    let Driver {
        search,
        problem,
        stop,
        progress,
        ..
    } = *driver;
    let started = Instant::now();
    let total = search.spec.evaluations;
    let mut history: Vec<Evaluation> = Vec::with_capacity(total);
    let mut best_score = f64::NEG_INFINITY;
    while history.len() < total && !stop.flag.load(Ordering::SeqCst) {
        let schedules = strategy.ask(batch.min(total - history.len()));
        if schedules.is_empty() {
            break;
        }
        let evaluated = evaluate(driver, &schedules, history.len() + 1)?;
        if stop.flag.load(Ordering::SeqCst) {
            break;
        }
        strategy.tell(&evaluated.iter().map(|e| e.score).collect::<Vec<_>>());
        for e in &evaluated {
            if e.score > best_score {
                best_score = e.score;
            }
        }
        *done += evaluated.len() as u64;
        history.extend(evaluated);
        progress.at(*done);
        progress.detail(&format!(
            "{} {}: best {} {}",
            problem.label,
            strategy.name(),
            search.harm.name(),
            history
                .iter()
                .filter(|e| e.score == best_score)
                .find_map(|e| e.harm)
                .map_or("-".into(), |h| format!("{h:.3}"))
        ));
    }
    let failed = history.iter().filter(|e| e.error.is_some()).count();
    let best = history
        .iter()
        .filter(|e| e.error.is_none())
        .fold(None::<&Evaluation>, |b, e| match b {
            Some(b) if b.score >= e.score => Some(b),
            _ => Some(e),
        })
        .map(|e| found(problem, e));
    Ok(MethodOutcome {
        method: strategy.name(),
        evaluations: history.len(),
        rejected: strategy.rejected(),
        failed,
        best,
        wall_s: started.elapsed().as_secs_f64(),
        history,
    })
}

pub(super) fn found(problem: &Problem, e: &Evaluation) -> Found {
    Found {
        evaluation: e.evaluation,
        harm: e.harm,
        text: e.schedule.to_string(),
        schedule: e.schedule.clone(),
        class: e.class,
        certificate: problem.budget.certify(&e.schedule, problem.grid.horizon()),
    }
}

/// Runs every problem of `search` into `out`: the search and each baseline of `compare` at the
/// same evaluations, their candidates executed by `executor` in batches (a generation of the
/// search; 100 runs of a baseline), the reference, and the worst schedule found re-run into
/// `worst/` with its files and figures (in process, or as `platoon run` with `transport =
/// "iceoryx2"`). The directory is staged in `<out>.partial` and renamed when every problem is
/// done; once `stop`'s flag is set no new batch starts and it stays unfinished (with what was
/// done in `search.json`). `progress` hears of the evaluations.
pub fn run(
    search: &Search,
    out: &Path,
    opts: &SearchOptions,
    executor: &dyn Executor,
    stop: &Stop,
    progress: &dyn Progress,
) -> Result<SearchOutcome, SearchError> {
    let started = Instant::now();
    let dir = RunDir::create(out, opts.force)?;
    let staging = dir.staging().to_path_buf();
    dir.write(
        "search.toml",
        toml::to_string_pretty(&search.spec)
            .context("writing the resolved search file")?
            .as_bytes(),
    )?;
    dir.write("base.toml", search.base_toml.as_bytes())?;
    let runnable = search
        .problems
        .iter()
        .filter(|p| p.not_run.is_none())
        .count();
    let methods = 1 + search.spec.compare.len();
    progress.message(&format!(
        "search {}: {} of {} per strategy ({}), {} scenario{}, {}",
        search.name,
        search.spec.evaluations,
        search.harm.name(),
        std::iter::once("search")
            .chain(search.spec.compare.iter().map(String::as_str))
            .collect::<Vec<_>>()
            .join(", "),
        runnable,
        if runnable == 1 { "" } else { "s" },
        executor.name()
    ));
    progress.start(
        "evaluations",
        (runnable * methods * search.spec.evaluations) as u64,
    );
    let mut done = 0u64;
    let mut outcomes = Vec::new();
    let study = search.spec.study.is_some();
    for problem in &search.problems {
        if stop.flag.load(Ordering::SeqCst) {
            break;
        }
        let sub = if study {
            std::fs::create_dir_all(staging.join(&problem.label))?;
            PathBuf::from(&problem.label)
        } else {
            PathBuf::new()
        };
        if let Some(why) = &problem.not_run {
            outcomes.push(ProblemOutcome {
                label: problem.label.clone(),
                not_run: Some(why.clone()),
                budget: problem.budget.clone(),
                methods: Vec::new(),
                reference: None,
                worst_by: None,
                reproduced: None,
            });
            continue;
        }
        let driver = Driver {
            search,
            problem,
            executor,
            dir: &staging,
            stop,
            progress,
        };
        let outcome = run_problem(&driver, &dir, &sub, opts, &mut done)?;
        outcomes.push(outcome);
    }
    progress.finish();
    let stopped = stop
        .flag
        .load(Ordering::SeqCst)
        .then(|| stop.reason().unwrap_or_else(|| "stopped".into()));
    let wall_s = started.elapsed().as_secs_f64();
    if study {
        let (csv, md) = study_tables(search, &outcomes);
        dir.write("study.csv", csv.as_bytes())?;
        dir.write("study.md", md.as_bytes())?;
    }
    let json = serde_json::json!({
        "name": search.name,
        "base": search.base_label,
        "harm": search.harm.name(),
        "minimised": search.harm.minimised(),
        "seed": search.spec.seed,
        "evaluations": search.spec.evaluations,
        "executor": executor.name(),
        "complete": stopped.is_none(),
        "interrupted": stopped,
        "wall_s": wall_s,
        "problems": outcomes,
    });
    dir.write(
        "search.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;
    let (dir, committed) = if stopped.is_none() {
        (dir.commit()?, true)
    } else {
        (staging, false)
    };
    Ok(SearchOutcome {
        dir,
        committed,
        problems: outcomes,
        stopped,
        wall_s,
    })
}

/// The driver's problem: the search and each baseline, the reference, its files in `sub` of
/// `dir`, and its worst schedule re-run.
fn run_problem(
    driver: &Driver<'_>,
    dir: &RunDir,
    sub: &Path,
    opts: &SearchOptions,
    done: &mut u64,
) -> Result<ProblemOutcome, SearchError> {
    let Driver {
        search, problem, ..
    } = *driver;
    let spec = &search.spec;
    let mut methods = Vec::new();
    let mut evolution = Evolution::new(
        problem.grid,
        problem.budget.clone(),
        spec.search.clone(),
        problem.anchors.clone(),
        spec.evaluations,
        spec.seed,
    )
    .map_err(strategy(problem))?;
    let population = spec.search.population;
    methods.push(drive(driver, &mut evolution, population, done)?);
    for name in &spec.compare {
        if driver.stopped() {
            break;
        }
        let mut strategy: Box<dyn Strategy> = match name.as_str() {
            "random" => Box::new(
                RandomSampler::new(
                    problem.grid,
                    problem.budget.clone(),
                    spec.random.settings(),
                    spec.random.seed.unwrap_or(spec.seed),
                )
                .map_err(strategy(problem))?,
            ),
            _ => Box::new(
                GridSampler::new(
                    &problem.grid,
                    &problem.budget,
                    &search.grid_values.0,
                    &search.grid_values.1,
                    spec.evaluations,
                )
                .map_err(strategy(problem))?,
            ),
        };
        let before = *done;
        let m = drive(driver, strategy.as_mut(), 100, done)?;
        // A grid smaller than the evaluations leaves the rest unused: the bar moves on.
        *done = before + spec.evaluations as u64;
        driver.progress.at(*done);
        methods.push(m);
    }
    let reference = match &search.reference {
        Some(s) if !driver.stopped() => {
            let e = evaluate(driver, std::slice::from_ref(s), 0)?;
            e.first().map(|e| found(problem, e))
        }
        _ => None,
    };
    let worst_by = methods
        .iter()
        .filter_map(|m| m.best.as_ref().map(|b| (m.method, b)))
        .fold(None::<(&'static str, f64)>, |acc, (m, b)| {
            let score = score_of(&methods, m, b);
            match acc {
                Some((_, s)) if s >= score => acc,
                _ => Some((m, score)),
            }
        })
        .map(|(m, _)| m);
    let mut outcome = ProblemOutcome {
        label: problem.label.clone(),
        not_run: None,
        budget: problem.budget.clone(),
        methods,
        reference,
        worst_by,
        reproduced: None,
    };
    write_problem(search, problem, dir, sub, &outcome, opts)?;
    if let Some((_, worst)) = outcome.worst() {
        if !driver.stopped() {
            let harm = worst.harm;
            let schedule = worst.schedule.clone();
            let again = rerun_worst(driver, &schedule, dir, sub, opts)?;
            outcome.reproduced = Some(again.map(|s| search.harm.value(&s)) == Some(harm));
            if outcome.reproduced == Some(false) {
                return Err(SearchError::NotReproduced {
                    problem: problem.label.clone(),
                    harm,
                });
            }
        }
    }
    Ok(outcome)
}

/// A strategy's refusal of `problem`, as [`SearchError::Strategy`].
fn strategy(problem: &Problem) -> impl Fn(platoon_search::SearchError) -> SearchError + '_ {
    |source| SearchError::Strategy {
        problem: problem.label.clone(),
        source,
    }
}

/// The score of `method`'s best (as the run measured it).
pub(super) fn score_of(methods: &[MethodOutcome], method: &str, best: &Found) -> f64 {
    methods
        .iter()
        .find(|m| m.method == method)
        .and_then(|m| m.history.iter().find(|e| e.evaluation == best.evaluation))
        .map_or(f64::NEG_INFINITY, |e| e.score)
}

/// `worst.toml` re-run into `worst/` in `sub` of `dir` (files and figures), and its summary.
/// With parts of the caller's (the executor's plugins) it re-runs in process with them, and
/// `worst/` is not written (the files of a run are the built-in parts').
fn rerun_worst(
    driver: &Driver<'_>,
    schedule: &Schedule,
    dir: &RunDir,
    sub: &Path,
    opts: &SearchOptions,
) -> Result<Option<Summary>, SearchError> {
    let Driver {
        search,
        problem,
        stop,
        ..
    } = *driver;
    let plugins = &driver.executor.plugins();
    let mut config = problem.config_of(schedule);
    let text = platoon_config::to_toml(&config);
    let (_, scenario) = platoon_config::parse(&text, Path::new("worst.toml"))?;
    if plugins.any() {
        let summary = platoon_sim::run_until_plugins(&scenario, &plugins.plugins(), |_| {
            std::ops::ControlFlow::Continue(())
        })
        .map_err(OtherError::wrap)?;
        return Ok(metrics::read(&serde_json::to_value(summary)?).ok());
    }
    let out = dir.staging().join(sub).join("worst");
    let run_opts = crate::run::RunOptions {
        transport: search.spec.transport,
        plots: opts.plots,
        config_file: dir.staging().join(sub).join("worst.toml"),
        ..Default::default()
    };
    config.simulation.plant = problem.config.simulation.plant;
    let outcome = crate::run::run(config, &scenario, &run_opts, &out, true, stop, &())?;
    let text = std::fs::read_to_string(outcome.dir.join("summary.json"))
        .with_context(|| format!("reading {}", outcome.dir.join("summary.json").display()))?;
    let json: serde_json::Value = serde_json::from_str(&text)?;
    Ok(metrics::read(&json).ok())
}
