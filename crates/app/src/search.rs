//! Worst-case admissible attacks: the search for the most harmful DoS schedule an attacker's
//! budget allows ([`platoon_search`] decides what to run), its candidates run as campaign cells
//! by any [`Executor`] (the local pool, or Dask: a generation is a batch of cells), beside the
//! random admissible sampling and the DoS-timing grid at the same number of evaluations.
//!
//! A search file ([`SearchFile`], TOML) names the scenario, the harm, the budget and the
//! evaluations; [`load`] resolves it (errors name the file, line and key), [`run`] runs it into
//! one directory (atomically, as every command): `search.json`, `evaluations.csv`,
//! `convergence.csv` and `.png`, `worst.toml` (the worst schedule's config, which `platoon run`
//! re-runs) and `worst/` (its run directory, with figures). With `[study]`, one such directory
//! per law and topology and `study.csv` and `study.md` side by side.
//!
//! Harm is measured: every candidate's harm is read from its run's `summary.json` by the
//! campaign metrics ([`platoon_campaign::metrics`]), so the worst schedule re-run gives the same
//! harm, bit for bit (checked on the worst run before the directory is committed).
use crate::campaign::{CellJob, CellReply, Executor};
use crate::progress::Progress;
use crate::run::Stop;
use anyhow::{bail, Context, Result};
use platoon_attacks::Assumption2;
use platoon_campaign::metrics;
use platoon_campaign::{Transport, Values};
use platoon_config::{Config, ConfigError, DosConfig, LawName, LinkAttackConfig, LinkKindConfig};
use platoon_output::plots;
use platoon_output::rundir::RunDir;
use platoon_search::{
    Budget, Certificate, Evolution, Grid, GridSampler, RandomSampler, Schedule, Strategy, Target,
};
use platoon_sim::{SafetyClass, Scenario, Summary};
use platoon_topology::Preset;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Instant;

mod file;

pub use file::*;

/// What the attacker maximises, read from a run's summary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Harm {
    name: String,
}

impl Harm {
    /// The harm `name` (a numeric campaign metric, [`harms`]).
    pub fn new(name: &str) -> Result<Self, String> {
        if harms().contains(&name) {
            Ok(Self { name: name.into() })
        } else {
            Err(format!(
                "unknown harm `{name}`; known: {}",
                harms().join(", ")
            ))
        }
    }

    /// Its name (the campaign metric).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether smaller is more harmful (`min_*`, `first_collision_s`).
    pub fn minimised(&self) -> bool {
        self.name.starts_with("min_") || self.name == "first_collision_s"
    }

    /// Its value in a run's summary, as `cells.csv` would hold it (None: not defined for this
    /// run, e.g. no collision).
    pub fn value(&self, summary: &Summary) -> Option<f64> {
        let names = [self.name.clone()];
        metrics::extract(&names, summary.vehicles.len(), summary)
            .first()
            .and_then(|m| m.as_f64())
    }

    /// The score the search maximises: the harm, or minus it when smaller is worse. For
    /// `first_collision_s`, a run that collides scores above every run that does not (twice
    /// the run's length minus the time), and one that does not scores minus its smallest gap,
    /// so the search is led towards collisions.
    pub fn score(&self, summary: &Summary) -> f64 {
        let value = self.value(summary);
        if self.name == "first_collision_s" {
            return match value {
                Some(t) => 2.0 * summary.duration_s - t,
                None => {
                    let gap = metrics::extract(&["min_gap_m".into()], 0, summary);
                    gap[0].as_f64().map_or(f64::NEG_INFINITY, |g| -g)
                }
            };
        }
        match value {
            Some(v) if self.minimised() => -v,
            Some(v) => v,
            None => f64::NEG_INFINITY,
        }
    }
}

/// One scenario to search: the base, or one law on one topology of a study.
#[derive(Debug, Clone)]
pub struct Problem {
    /// `paper-pf` in a study; the search's name otherwise.
    pub label: String,
    /// Its config (the base's DoS is replaced by each candidate).
    pub config: Config,
    /// Its step grid.
    pub grid: Grid,
    /// The attacker's budget on it.
    pub budget: Budget,
    /// The instants of the leader's manoeuvres (s).
    pub anchors: Vec<f64>,
    /// Why it cannot run (a law that lacks a neighbour the topology gives), if so.
    pub not_run: Option<String>,
}

impl Problem {
    /// The config that runs `schedule` on this problem: the base's DoS replaced by the
    /// whole-channel jams (with the budget's Assumption-2 bounds, so the run checks them
    /// too), each link jam added as a Bernoulli loss of 1 on its link.
    pub fn config_of(&self, schedule: &Schedule) -> Config {
        let mut c = self.config.clone();
        let channel: Vec<[f64; 2]> = schedule
            .jams
            .iter()
            .filter(|j| j.target == Target::Channel)
            .map(|j| [j.start_s, j.duration_s])
            .collect();
        c.attack.kind = if channel.is_empty() {
            DosConfig::None {}
        } else {
            DosConfig::Intervals { intervals: channel }
        };
        if self.budget.assumption2.is_some() {
            c.attack.assumption2 = self.budget.assumption2;
        }
        for j in &schedule.jams {
            if let Target::Link { sender, receiver } = j.target {
                c.channel.attacks.push(LinkAttackConfig {
                    kind: LinkKindConfig::Bernoulli { loss: 1.0 },
                    start_s: j.start_s,
                    end_s: j.start_s + j.duration_s,
                    senders: Some(vec![sender]),
                    receivers: Some(vec![receiver]),
                });
            }
        }
        c
    }
}

/// A resolved search file.
#[derive(Debug, Clone)]
pub struct Search {
    /// The file (used in errors).
    pub file: PathBuf,
    /// The file as parsed, `base` absolute.
    pub spec: SearchFile,
    /// Its name.
    pub name: String,
    /// Where the base came from.
    pub base_label: String,
    /// The base's resolved config.
    pub base_toml: String,
    /// The harm.
    pub harm: Harm,
    /// The scenarios to search (one, or one per law and topology).
    pub problems: Vec<Problem>,
    /// The grid baseline's onsets and durations.
    pub grid_values: (Vec<f64>, Vec<f64>),
    /// The reference schedule, if any.
    pub reference: Option<Schedule>,
}

/// A problem to resolve: its label, its config, and its law and topology in a study.
type Case = (String, Config, Option<(LawName, Preset)>);

/// Reads and resolves a search file; `evaluations` overrides its `evaluations` (a quick
/// pilot). Errors name the file, the line and the key.
pub fn load(path: &Path, evaluations: Option<usize>) -> Result<Search, ConfigError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ConfigError::new(path, "", format!("cannot read the search file: {e}")))?;
    parse(&text, path, evaluations)
}

/// Parses and resolves search text (`file` names it in errors and anchors `base`).
pub fn parse(text: &str, file: &Path, evaluations: Option<usize>) -> Result<Search, ConfigError> {
    let mut spec: SearchFile = platoon_config::deserialize(text, file)?;
    let lines = platoon_config::KeyLines::new(text);
    let err = |key: &str, message: String| ConfigError::at_key(file, &lines, key, message);
    if let Some(n) = evaluations {
        spec.evaluations = n;
    }
    if spec.evaluations == 0 {
        return Err(err("evaluations", "must be at least 1".into()));
    }
    let harm = Harm::new(&spec.harm).map_err(|m| err("harm", m))?;
    for c in &spec.compare {
        if !BASELINES.contains(&c.as_str()) {
            return Err(err(
                "compare",
                format!("unknown strategy `{c}`; known: {}", BASELINES.join(", ")),
            ));
        }
    }
    let dir = file.parent().unwrap_or(Path::new("."));
    let (base, base_label) = match &spec.base {
        Some(b) => {
            let path = dir.join(b);
            let (c, _) = platoon_config::load(&path)
                .map_err(|e| err("base", format!("the base scenario: {e}")))?;
            let abs = std::path::absolute(&path).unwrap_or(path);
            spec.base = Some(abs.display().to_string());
            (c, abs.display().to_string())
        }
        None => {
            let (c, _) = platoon_config::Embedded::Paper.parse()?;
            (c, platoon_config::Embedded::Paper.label())
        }
    };
    let values = |key: &str, v: &Values| -> Result<Vec<f64>, ConfigError> {
        let xs: Vec<f64> = match v {
            Values::List(xs) => xs.clone(),
            Values::Range(r) => platoon_campaign::expand_range(r)
                .map_err(|m| err(key, m))?
                .iter()
                .filter_map(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64)))
                .collect(),
        };
        if xs.is_empty() || xs.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(err(key, "needs at least one value, each >= 0 (s)".into()));
        }
        Ok(xs)
    };
    let grid_values = (
        values("grid.onset_s", &spec.grid.onset_s)?,
        values("grid.duration_s", &spec.grid.duration_s)?,
    );
    let cases: Vec<Case> = match &spec.study {
        None => vec![(String::new(), base.clone(), None)],
        Some(study) => {
            if study.laws.is_empty() || study.topologies.is_empty() {
                return Err(err(
                    "study.laws",
                    "a study needs at least one law and one topology".into(),
                ));
            }
            if !(study.beacon_period_s.is_finite() && study.beacon_period_s > 0.0) {
                return Err(err(
                    "study.beacon_period_s",
                    format!("must be > 0 s (got {})", study.beacon_period_s),
                ));
            }
            let mut v = Vec::new();
            for &law in &study.laws {
                for &preset in &study.topologies {
                    let c =
                        crate::experiment::configure_law(&base, law, preset, study.beacon_period_s);
                    v.push((
                        format!("{}-{}", law.name(), preset.name()),
                        c,
                        Some((law, preset)),
                    ));
                }
            }
            v
        }
    };
    let name = spec.name.clone().unwrap_or_else(|| {
        file.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "search".into())
    });
    let mut problems = Vec::new();
    for (label, mut config, case) in cases {
        let label = if label.is_empty() {
            name.clone()
        } else {
            label
        };
        let bounds = spec.budget.assumption2.or(config.attack.assumption2);
        let scenario = match platoon_config::to_scenario(&mut config) {
            Ok(s) => s,
            Err((key, e)) if case.is_some() && key == "topology.preset" => {
                problems.push(Problem {
                    label,
                    config,
                    grid: Grid::new(1.0, 1).expect("a grid"),
                    budget: Budget::assumption2(Assumption2 {
                        T1: 1.0,
                        T2: 1.0,
                        D1: 1.0,
                        D2: 2.0,
                    }),
                    anchors: Vec::new(),
                    not_run: Some(e),
                });
                continue;
            }
            Err((key, e)) => {
                let at = case.map_or(String::new(), |(l, p)| {
                    format!(" with law {} on {}", l.name(), p.name())
                });
                return Err(err("base", format!("key `{key}`{at}: {e}")));
            }
        };
        if config.simulation.plant == platoon_config::PlantKind::Sumo
            && spec.transport == Transport::Inproc
        {
            return Err(err(
                "transport",
                "the base runs SUMO as the plant, which is a process: set transport = \"iceoryx2\""
                    .into(),
            ));
        }
        let b = &spec.budget;
        if bounds.is_none() && b.max_jammed_s.is_none() && b.max_intervals.is_none() {
            return Err(err(
                "budget",
                "no bound: give budget.assumption2 (or attack.assumption2 in the base), \
                 budget.max_jammed_s or budget.max_intervals"
                    .into(),
            ));
        }
        let targets = match b.jam {
            JamKind::Channel => {
                if b.links.is_some() {
                    return Err(err("budget.links", "needs budget.jam = \"links\"".into()));
                }
                vec![Target::Channel]
            }
            JamKind::Links => {
                let all: Vec<(u16, u16)> =
                    scenario.topology.links().map(|(s, r)| (s.0, r.0)).collect();
                match &b.links {
                    None => all
                        .iter()
                        .map(|&(sender, receiver)| Target::Link { sender, receiver })
                        .collect(),
                    Some(links) => {
                        let mut t = Vec::new();
                        for &[sender, receiver] in links {
                            if !all.contains(&(sender, receiver)) {
                                return Err(err(
                                    "budget.links",
                                    format!(
                                        "{sender} -> {receiver} is not a link of the topology \
                                         ({label})"
                                    ),
                                ));
                            }
                            t.push(Target::Link { sender, receiver });
                        }
                        t
                    }
                }
            }
        };
        let budget = Budget {
            assumption2: bounds,
            max_jammed_s: b.max_jammed_s,
            max_intervals: b.max_intervals,
            min_interval_s: b.min_interval_s,
            max_interval_s: b.max_interval_s,
            targets,
        };
        budget
            .validate()
            .map_err(|e| err(&e.key, e.message.clone()))?;
        let grid = Grid::new(scenario.dt(), scenario.steps).map_err(|e| err(&e.key, e.message))?;
        problems.push(Problem {
            label,
            anchors: anchors(&scenario),
            config,
            grid,
            budget,
            not_run: None,
        });
    }
    spec.search
        .validate()
        .map_err(|e| err(&e.key, e.message.clone()))?;
    let reference = match &spec.reference {
        None => None,
        Some(pairs) => {
            let s = Schedule {
                jams: pairs
                    .iter()
                    .map(|&[start_s, duration_s]| platoon_search::Jamming {
                        start_s,
                        duration_s,
                        target: Target::Channel,
                    })
                    .collect(),
            };
            for p in problems.iter().filter(|p| p.not_run.is_none()) {
                let c = p.budget.certify(&s, p.grid.horizon());
                if !c.holds {
                    return Err(err(
                        "reference",
                        format!(
                            "the budget refuses it ({}): a reference must be admissible",
                            c.violation.unwrap_or_default()
                        ),
                    ));
                }
            }
            Some(s)
        }
    };
    Ok(Search {
        file: file.to_path_buf(),
        base_toml: platoon_config::to_toml(&base),
        spec,
        name,
        base_label,
        harm,
        problems,
        grid_values,
        reference,
    })
}

/// The instants the leader's acceleration changes (s), at most 32.
fn anchors(scenario: &Scenario) -> Vec<f64> {
    let dt = scenario.dt();
    let mut out = Vec::new();
    let mut last = scenario.leader.step_acceleration(0, dt);
    for k in 1..=scenario.steps as usize {
        let a = scenario.leader.step_acceleration(k, dt);
        if (a - last).abs() > 1e-9 {
            out.push(k as f64 * dt);
            if out.len() == 32 {
                break;
            }
        }
        last = a;
    }
    out
}

/// How [`run`] runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SearchOptions {
    /// Replace a finished output directory.
    pub force: bool,
    /// Draw the PNG figures.
    pub plots: bool,
}

impl Default for SearchOptions {
    fn default() -> Self {
        Self {
            force: false,
            plots: true,
        }
    }
}

/// One run of a candidate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// 1-based, in the order the strategy proposed it.
    pub evaluation: usize,
    /// The schedule.
    pub schedule: Schedule,
    /// Its harm (None: not defined for the run, or the run failed).
    pub harm: Option<f64>,
    /// The score the search maximised.
    pub score: f64,
    /// The run's safety class.
    pub class: Option<SafetyClass>,
    /// Why the run failed.
    pub error: Option<String>,
}

/// The most harmful schedule a strategy found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Found {
    /// Which evaluation found it.
    pub evaluation: usize,
    /// Its harm.
    pub harm: Option<f64>,
    /// The schedule, as `34.9+6.5 s, ...`.
    pub text: String,
    /// The schedule.
    pub schedule: Schedule,
    /// The run's safety class.
    pub class: Option<SafetyClass>,
    /// The budget's certificate (Assumption 2's tightest windows, the jammed time).
    pub certificate: Certificate,
}

/// What one strategy did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MethodOutcome {
    /// `search`, `random` or `grid`.
    pub method: &'static str,
    /// Runs.
    pub evaluations: usize,
    /// Proposals the budget refused (never run).
    pub rejected: usize,
    /// Runs that failed.
    pub failed: usize,
    /// The most harmful schedule it found.
    pub best: Option<Found>,
    /// Its wall time (s).
    pub wall_s: f64,
    /// Every run, in order.
    #[serde(skip)]
    pub history: Vec<Evaluation>,
}

impl MethodOutcome {
    /// The best harm after each evaluation (the convergence curve).
    pub fn convergence(&self) -> Vec<Option<f64>> {
        let mut best: Option<&Evaluation> = None;
        self.history
            .iter()
            .map(|e| {
                if best.is_none_or(|b| e.score > b.score) {
                    best = Some(e);
                }
                best.and_then(|b| b.harm)
            })
            .collect()
    }
}

/// One problem's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProblemOutcome {
    /// Its label.
    pub label: String,
    /// Why it did not run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_run: Option<String>,
    /// The budget.
    pub budget: Budget,
    /// The search and the baselines, in that order.
    pub methods: Vec<MethodOutcome>,
    /// The reference schedule's run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<Found>,
    /// The strategy that found the most harmful schedule.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_by: Option<&'static str>,
    /// That schedule's run re-read from `worst/summary.json` gives the same harm (None: not
    /// re-run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reproduced: Option<bool>,
}

impl ProblemOutcome {
    /// The most harmful schedule found by any strategy, with the strategy.
    pub fn worst(&self) -> Option<(&'static str, &Found)> {
        let by = self.worst_by?;
        self.methods
            .iter()
            .find(|m| m.method == by)
            .and_then(|m| m.best.as_ref().map(|f| (by, f)))
    }

    /// The outcome of `method`.
    pub fn method(&self, method: &str) -> Option<&MethodOutcome> {
        self.methods.iter().find(|m| m.method == method)
    }
}

/// A search's outcome ([`run`]).
#[derive(Debug)]
pub struct SearchOutcome {
    /// The output directory (`<out>.partial` when stopped).
    pub dir: PathBuf,
    /// Whether it was renamed into place.
    pub committed: bool,
    /// Every problem.
    pub problems: Vec<ProblemOutcome>,
    /// Why it was stopped.
    pub stopped: Option<String>,
    /// Wall time (s).
    pub wall_s: f64,
}

/// Runs `jobs` on `executor` and returns their replies in job order.
fn execute(
    executor: &dyn Executor,
    jobs: &[CellJob],
    dir: &Path,
    stop: &Stop,
) -> Result<Vec<Option<CellReply>>> {
    let mut replies: Vec<Option<CellReply>> = vec![None; jobs.len()];
    executor.execute(jobs, dir, stop, &mut |r: CellReply| {
        let i = r.index;
        match replies.get_mut(i) {
            Some(slot) => *slot = Some(r),
            None => bail!("a worker replied for job {i}, which this batch does not have"),
        }
        Ok(())
    })?;
    Ok(replies)
}

/// Runs `schedules` on `problem` and measures them.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    search: &Search,
    problem: &Problem,
    schedules: &[Schedule],
    first: usize,
    executor: &dyn Executor,
    dir: &Path,
    stop: &Stop,
) -> Result<Vec<Evaluation>> {
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

/// Drives one strategy through `evaluations` runs.
#[allow(clippy::too_many_arguments)]
fn drive(
    search: &Search,
    problem: &Problem,
    strategy: &mut dyn Strategy,
    batch: usize,
    executor: &dyn Executor,
    dir: &Path,
    stop: &Stop,
    progress: &dyn Progress,
    done: &mut u64,
) -> Result<MethodOutcome> {
    let started = Instant::now();
    let total = search.spec.evaluations;
    let mut history: Vec<Evaluation> = Vec::with_capacity(total);
    let mut best_score = f64::NEG_INFINITY;
    while history.len() < total && !stop.flag.load(Ordering::SeqCst) {
        let schedules = strategy.ask(batch.min(total - history.len()));
        if schedules.is_empty() {
            break;
        }
        let evaluated = evaluate(
            search,
            problem,
            &schedules,
            history.len() + 1,
            executor,
            dir,
            stop,
        )?;
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

fn found(problem: &Problem, e: &Evaluation) -> Found {
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
) -> Result<SearchOutcome> {
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
        let outcome = run_problem(
            search, problem, &dir, &sub, opts, executor, stop, progress, &mut done,
        )?;
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

#[allow(clippy::too_many_arguments)]
fn run_problem(
    search: &Search,
    problem: &Problem,
    dir: &RunDir,
    sub: &Path,
    opts: &SearchOptions,
    executor: &dyn Executor,
    stop: &Stop,
    progress: &dyn Progress,
    done: &mut u64,
) -> Result<ProblemOutcome> {
    let spec = &search.spec;
    let staging = dir.staging().to_path_buf();
    let mut methods = Vec::new();
    let mut evolution = Evolution::new(
        problem.grid,
        problem.budget.clone(),
        spec.search.clone(),
        problem.anchors.clone(),
        spec.evaluations,
        spec.seed,
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", problem.label))?;
    let population = spec.search.population;
    methods.push(drive(
        search,
        problem,
        &mut evolution,
        population,
        executor,
        &staging,
        stop,
        progress,
        done,
    )?);
    for name in &spec.compare {
        if stop.flag.load(Ordering::SeqCst) {
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
                .map_err(|e| anyhow::anyhow!("{}: {e}", problem.label))?,
            ),
            _ => Box::new(
                GridSampler::new(
                    &problem.grid,
                    &problem.budget,
                    &search.grid_values.0,
                    &search.grid_values.1,
                    spec.evaluations,
                )
                .map_err(|e| anyhow::anyhow!("{}: {e}", problem.label))?,
            ),
        };
        let before = *done;
        let m = drive(
            search,
            problem,
            strategy.as_mut(),
            100,
            executor,
            &staging,
            stop,
            progress,
            done,
        )?;
        // A grid smaller than the evaluations leaves the rest unused: the bar moves on.
        *done = before + spec.evaluations as u64;
        progress.at(*done);
        methods.push(m);
    }
    let reference = match &search.reference {
        Some(s) if !stop.flag.load(Ordering::SeqCst) => {
            let e = evaluate(
                search,
                problem,
                std::slice::from_ref(s),
                0,
                executor,
                &staging,
                stop,
            )?;
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
        if !stop.flag.load(Ordering::SeqCst) {
            let harm = worst.harm;
            let schedule = worst.schedule.clone();
            let plugins = executor.plugins();
            let again = rerun_worst(search, problem, &schedule, dir, sub, opts, stop, &plugins)?;
            outcome.reproduced = Some(again.map(|s| search.harm.value(&s)) == Some(harm));
            if outcome.reproduced == Some(false) {
                bail!(
                    "{}: the worst schedule re-run did not reproduce its harm ({:?}): a bug, please report it",
                    problem.label,
                    harm
                );
            }
        }
    }
    Ok(outcome)
}

/// The score of `method`'s best (as the run measured it).
fn score_of(methods: &[MethodOutcome], method: &str, best: &Found) -> f64 {
    methods
        .iter()
        .find(|m| m.method == method)
        .and_then(|m| m.history.iter().find(|e| e.evaluation == best.evaluation))
        .map_or(f64::NEG_INFINITY, |e| e.score)
}

/// `worst.toml` re-run into `worst/` (files and figures), and its summary. With parts of the
/// caller's (`plugins`, the executor's) it re-runs in process with them, and `worst/` is not
/// written (the files of a run are the built-in parts').
#[allow(clippy::too_many_arguments)]
fn rerun_worst(
    search: &Search,
    problem: &Problem,
    schedule: &Schedule,
    dir: &RunDir,
    sub: &Path,
    opts: &SearchOptions,
    stop: &Stop,
    plugins: &crate::campaign::CellPlugins,
) -> Result<Option<Summary>> {
    let mut config = problem.config_of(schedule);
    let text = platoon_config::to_toml(&config);
    let (_, scenario) = platoon_config::parse(&text, Path::new("worst.toml"))?;
    if plugins.any() {
        let summary = platoon_sim::run_until_plugins(&scenario, &plugins.plugins(), |_| {
            std::ops::ControlFlow::Continue(())
        })?;
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

fn fmt_harm(h: Option<f64>) -> String {
    h.map_or("-".into(), |h| format!("{h:.2}"))
}

/// evaluations.csv, convergence.csv, convergence.png, worst.toml and the reference.
fn write_problem(
    search: &Search,
    problem: &Problem,
    dir: &RunDir,
    sub: &Path,
    outcome: &ProblemOutcome,
    opts: &SearchOptions,
) -> Result<()> {
    let path = |name: &str| sub.join(name).to_string_lossy().into_owned();
    let mut w = csv::Writer::from_writer(dir.writer(&path("evaluations.csv"))?);
    w.write_record([
        "method",
        "evaluation",
        "schedule",
        "jams",
        "jammed_s",
        "harm",
        "class",
        "error",
    ])?;
    for m in &outcome.methods {
        for e in &m.history {
            let jammed = e
                .schedule
                .activity()
                .map(|a| a.active_time(0.0, problem.grid.horizon()))
                .unwrap_or(f64::NAN);
            w.write_record([
                m.method.to_string(),
                e.evaluation.to_string(),
                e.schedule.to_string(),
                e.schedule.jams.len().to_string(),
                format!("{jammed}"),
                e.harm.map_or(String::new(), |h| h.to_string()),
                e.class.map_or(String::new(), |c| c.name().to_string()),
                e.error.clone().unwrap_or_default(),
            ])?;
        }
    }
    w.flush()?;
    let mut w = csv::Writer::from_writer(dir.writer(&path("convergence.csv"))?);
    w.write_record(["method", "evaluation", "best_harm"])?;
    for m in &outcome.methods {
        for (i, b) in m.convergence().iter().enumerate() {
            w.write_record([
                m.method.to_string(),
                (i + 1).to_string(),
                b.map_or(String::new(), |h| h.to_string()),
            ])?;
        }
    }
    w.flush()?;
    if let Some((_, worst)) = outcome.worst() {
        let config = problem.config_of(&worst.schedule);
        let mut text = format!(
            "# The most harmful schedule `platoon search` found for {} ({} = {}): re-run it with\n\
             #   platoon run worst.toml --transport {}\n",
            problem.label,
            search.harm.name(),
            fmt_harm(worst.harm),
            search.spec.transport.name()
        );
        text.push_str(&platoon_config::to_toml(&config));
        dir.write(&path("worst.toml"), text.as_bytes())?;
    }
    if opts.plots {
        convergence_plot(
            &dir.path(&path("convergence.png")),
            &format!(
                "{}: most harmful {} found against runs",
                problem.label,
                search.harm.name()
            ),
            search.harm.name(),
            &outcome.methods,
            outcome.reference.as_ref().and_then(|r| r.harm),
        )?;
    }
    Ok(())
}

/// The best harm against runs, one step line per strategy, the reference dashed.
fn convergence_plot(
    path: &Path,
    title: &str,
    harm: &str,
    methods: &[MethodOutcome],
    reference: Option<f64>,
) -> Result<()> {
    use plotters::prelude::*;
    let lines: Vec<(&str, Vec<(f64, f64)>)> = methods
        .iter()
        .map(|m| {
            let mut pts: Vec<(f64, f64)> = Vec::new();
            for (k, b) in m.convergence().iter().enumerate() {
                let Some(b) = *b else { continue };
                let x = (k + 1) as f64;
                if let Some(&(_, last)) = pts.last() {
                    if last != b {
                        pts.push((x, last));
                    }
                }
                pts.push((x, b));
            }
            (m.method, pts)
        })
        .filter(|(_, p)| !p.is_empty())
        .collect();
    let ys = lines
        .iter()
        .flat_map(|(_, p)| p.iter().map(|q| q.1))
        .chain(reference)
        .filter(|y| y.is_finite());
    let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    if !lo.is_finite() {
        return Ok(());
    }
    let pad = ((hi - lo) * 0.08).max(0.5);
    let (y0, y1) = (if lo >= 0.0 { 0.0 } else { lo - pad }, hi + pad);
    let x1 = lines
        .iter()
        .flat_map(|(_, p)| p.iter().map(|q| q.0))
        .fold(1.0, f64::max);
    plots::ensure_font();
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(plots::err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..x1 * 1.02, y0..y1)
        .map_err(plots::err)?;
    chart
        .configure_mesh()
        .x_desc("runs")
        .y_desc(harm)
        .draw()
        .map_err(plots::err)?;
    for (i, (name, pts)) in lines.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(3)))
            .map_err(plots::err)?
            .label(name.to_string())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3))
            });
    }
    if let Some(r) = reference {
        let black = BLACK.stroke_width(1);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(0.0, r), (x1 * 1.02, r)],
                6,
                4,
                black,
            ))
            .map_err(plots::err)?
            .label("reference")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], black));
    }
    plots::legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present().map_err(plots::err)?;
    Ok(())
}

/// study.csv and study.md: per law and topology, what each strategy found.
fn study_tables(search: &Search, outcomes: &[ProblemOutcome]) -> (String, String) {
    let harm = search.harm.name();
    let mut csv = format!(
        "problem,{harm}_search,{harm}_random,{harm}_grid,{harm}_reference,class_search,worst_schedule,worst_by,duration_margin_s,frequency_margin,reproduced,not_run\n"
    );
    let mut md = format!(
        "Harm: `{harm}`{} per strategy; duration margin: the Assumption-2 duration bound's margin on the worst schedule's tightest window.\n\n\
         | law-topology | search | random | grid | reference | class | worst schedule | duration margin (s) |\n|---|---|---|---|---|---|---|---|\n",
        if search.harm.minimised() { " (smallest found: most harmful)" } else { " (largest found: most harmful)" }
    );
    for o in outcomes {
        let best = |m: &str| {
            o.method(m)
                .and_then(|m| m.best.as_ref())
                .and_then(|b| b.harm)
        };
        let s = o.method("search").and_then(|m| m.best.as_ref());
        let worst = o.worst();
        let margins = worst
            .and_then(|(_, w)| w.certificate.assumption2.as_ref())
            .map(|r| {
                (
                    r.worst_duration.map(|w| w.margin()),
                    r.worst_frequency.map(|w| w.margin()),
                )
            });
        let opt = |x: Option<f64>| x.map_or(String::new(), |x| x.to_string());
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},\"{}\",{},{},{},{},\"{}\"",
            o.label,
            opt(best("search")),
            opt(best("random")),
            opt(best("grid")),
            opt(o.reference.as_ref().and_then(|r| r.harm)),
            s.and_then(|s| s.class)
                .map_or(String::new(), |c| c.name().into()),
            worst.map_or(String::new(), |(_, w)| w.text.clone()),
            worst.map_or("", |(m, _)| m),
            opt(margins.and_then(|m| m.0)),
            opt(margins.and_then(|m| m.1)),
            o.reproduced.map_or(String::new(), |r| r.to_string()),
            o.not_run.clone().unwrap_or_default(),
        );
        if o.not_run.is_some() {
            let _ = writeln!(
                md,
                "| {} | not run: the topology lacks a neighbour the law reads | | | | | | |",
                o.label
            );
            continue;
        }
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            o.label,
            fmt_harm(best("search")),
            fmt_harm(best("random")),
            fmt_harm(best("grid")),
            fmt_harm(o.reference.as_ref().and_then(|r| r.harm)),
            s.and_then(|s| s.class)
                .map_or("-".into(), |c| c.to_string()),
            worst.map_or("-".into(), |(_, w)| w.text.clone()),
            margins
                .and_then(|m| m.0)
                .map_or("-".into(), |m| format!("{m:.3}")),
        );
    }
    (csv, md)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, text: &str) -> PathBuf {
        let p = dir.join("s.toml");
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn bad_search_files_name_the_key() {
        let tmp = tempfile::tempdir().unwrap();
        for (text, key) in [
            ("harm = \"speed\"", "harm"),
            ("evaluations = 0", "evaluations"),
            ("compare = [\"annealing\"]", "compare"),
            ("[budget]\nmax_jammed_s = -1.0", "budget.max_jammed_s"),
            ("[budget]\nlinks = [[0, 1]]", "budget.links"),
            (
                "[budget]\njam = \"links\"\nlinks = [[3, 0]]",
                "budget.links",
            ),
            ("[search]\npopulation = 2", "search.population"),
            ("reference = [[30.0, 9.0]]", "reference"),
            ("[budget]\nunknown = 1", "budget.unknown"),
        ] {
            let e = load(&write(tmp.path(), text), None).unwrap_err();
            assert_eq!(e.key, key, "{text}: {e}");
        }
    }

    #[test]
    fn the_paper_search_resolves_with_its_bounds_and_ramps() {
        let tmp = tempfile::tempdir().unwrap();
        let s = load(&write(tmp.path(), "seed = 1"), Some(10)).unwrap();
        assert_eq!(s.problems.len(), 1);
        let p = &s.problems[0];
        assert_eq!(
            p.budget.assumption2,
            Some(Assumption2 {
                T1: 2.0,
                T2: 9.46,
                D1: 6.0,
                D2: 11.33
            })
        );
        assert_eq!(p.anchors, [10.0, 15.0, 35.0, 40.0]);
        assert_eq!(s.grid_values.0.len() * s.grid_values.1.len(), 510);
        // A candidate's config is the base with its DoS replaced.
        let sched = Schedule {
            jams: vec![platoon_search::Jamming {
                start_s: 34.9,
                duration_s: 6.5,
                target: Target::Channel,
            }],
        };
        let c = p.config_of(&sched);
        assert_eq!(
            c.attack.kind,
            DosConfig::Intervals {
                intervals: vec![[34.9, 6.5]]
            }
        );
        let study = load(
            &write(
                tmp.path(),
                "[study]\nlaws = [\"paper\", \"ploeg\"]\ntopologies = [\"pf\"]\n[budget]\njam = \"links\"",
            ),
            None,
        )
        .unwrap();
        let labels: Vec<&str> = study.problems.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(labels, ["paper-pf", "ploeg-pf"]);
        assert_eq!(study.problems[0].budget.targets.len(), 4, "pf: 4 links");
    }
}
