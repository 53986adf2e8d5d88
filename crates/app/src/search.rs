//! Worst-case admissible attacks: the search for the most harmful DoS schedule an attacker's
//! budget allows ([`platoon_search`] decides what to run), its candidates run as campaign cells
//! by any [`Executor`](crate::campaign::Executor) (the local pool, or Dask: a generation is a batch of cells), beside the
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
use crate::error::OtherError;
use platoon_attacks::Assumption2;
use platoon_campaign::metrics;
use platoon_campaign::{BaseScenario, Transport, Values};
use platoon_config::{Config, ConfigError, DosConfig, LawName, LinkAttackConfig, LinkKindConfig};
use platoon_search::{Budget, Certificate, Grid, JamKind, Limits, Schedule, Target};
use platoon_sim::{SafetyClass, Scenario, Summary};
use platoon_topology::Preset;
use serde::Serialize;
use std::path::{Path, PathBuf};

mod driver;
mod file;
mod report;

pub use driver::run;
pub use file::*;

/// Why [`run`] failed, by kind: what a caller branches on. Each message is the one
/// `platoon search` prints. A candidate whose run fails is no error: it is an evaluation with
/// its error. A search file that is refused is [`load`]'s and [`parse`]'s `ConfigError`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SearchError {
    /// A config is refused: the search file (for a caller that loads and runs with one error
    /// type; `platoon search` exits 2), or the worst schedule's.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The output directory or one of its files.
    #[error(transparent)]
    Output(#[from] platoon_output::error::OutputError),
    /// A strategy cannot start on a problem (its budget or settings do not fit the problem's
    /// grid).
    #[error("{problem}")]
    Strategy {
        /// The problem's label.
        problem: String,
        /// The setting and what is wrong with it.
        #[source]
        source: platoon_search::SearchError,
    },
    /// The executor failed before a batch was in (the local pool's, Dask's, the caller's).
    #[error(transparent)]
    Executor(OtherError),
    /// The worst schedule's re-run into `worst/` failed.
    #[error(transparent)]
    Worst(#[from] crate::run::RunError),
    /// The worst schedule re-run gave another harm than it did as a candidate: a bug.
    #[error("{problem}: the worst schedule re-run did not reproduce its harm ({harm:?}): a bug, please report it")]
    NotReproduced {
        /// The problem's label.
        problem: String,
        /// Its harm as a candidate.
        harm: Option<f64>,
    },
    /// Anything else (a figure that could not be drawn, a summary that could not be read).
    #[error(transparent)]
    Other(OtherError),
}

operation_error!(SearchError);

impl From<crate::campaign::ExecutorError> for SearchError {
    /// A record the executor passed on is the search's output; the rest is the executor's.
    fn from(e: crate::campaign::ExecutorError) -> Self {
        match e {
            crate::campaign::ExecutorError::Output(o) => Self::Output(o),
            crate::campaign::ExecutorError::Failed(e) => Self::Executor(e),
        }
    }
}

impl SearchError {
    /// The config error this is, if it is one: the search file's, or the worst schedule's.
    pub fn config(&self) -> Option<&ConfigError> {
        match self {
            Self::Config(c) => Some(c),
            Self::Worst(r) => r.config(),
            _ => None,
        }
    }

    /// The output error this is, if it is one: the search directory's, or the worst
    /// schedule's run's.
    pub fn output(&self) -> Option<&platoon_output::error::OutputError> {
        match self {
            Self::Output(o) => Some(o),
            Self::Worst(r) => r.output(),
            _ => None,
        }
    }
}

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
        if self.budget.limits.assumption2.is_some() {
            c.attack.assumption2 = self.budget.limits.assumption2;
        }
        for j in &schedule.jams {
            if let Target::Link { sender, receiver } = j.target {
                c.channel.attacks.push(LinkAttackConfig {
                    kind: LinkKindConfig::Bernoulli { loss: 1.0 },
                    start_s: j.start_s,
                    end_s: j.start_s + j.duration_s,
                    senders: Some(vec![sender]),
                    receivers: Some(vec![receiver]),
                    acts_as: None,
                    key_of: None,
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

/// The problems' configs: the base alone, or with a `[study]` the base with each law on each
/// topology.
fn cases(
    base: &Config,
    study: Option<&StudyFile>,
    err: &dyn Fn(&str, String) -> ConfigError,
) -> Result<Vec<Case>, ConfigError> {
    Ok(match study {
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
                        crate::experiment::configure_law(base, law, preset, study.beacon_period_s);
                    v.push((
                        format!("{}-{}", law.name(), preset.name()),
                        c,
                        Some((law, preset)),
                    ));
                }
            }
            v
        }
    })
}

/// What the budget `b` lets the attacker jam on `scenario`'s platoon (`label`): the channel,
/// or links of its topology (all, or those `budget.links` names).
fn targets(
    b: &Limits,
    scenario: &Scenario,
    label: &str,
    err: &dyn Fn(&str, String) -> ConfigError,
) -> Result<Vec<Target>, ConfigError> {
    Ok(match b.jam {
        JamKind::Channel => {
            if b.links.is_some() {
                return Err(err("budget.links", "needs budget.jam = \"links\"".into()));
            }
            vec![Target::Channel]
        }
        JamKind::Links => {
            let all: Vec<(u16, u16)> = scenario
                .hearing()
                .links()
                .map(|(s, r)| (s.0, r.0))
                .collect();
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
    })
}

/// The reference schedule (`reference`: each jam's start and duration, s, on the channel),
/// admissible under every runnable problem's budget.
fn reference(
    pairs: Option<&[[f64; 2]]>,
    problems: &[Problem],
    err: &dyn Fn(&str, String) -> ConfigError,
) -> Result<Option<Schedule>, ConfigError> {
    Ok(match pairs {
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
    })
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
    let BaseScenario {
        config: base,
        label: base_label,
        ..
    } = BaseScenario::load(&mut spec.base, file, &lines)?;
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
    let cases = cases(&base, spec.study.as_ref(), &err)?;
    let name = platoon_campaign::file_name(spec.name.as_deref(), file, "search");
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
            Err(e) if case.is_some() && matches!(e.reason, platoon_config::Reason::Unheard(_)) => {
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
                    not_run: Some(e.reason.to_string()),
                });
                continue;
            }
            Err(platoon_config::KeyError { key, reason: e }) => {
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
        let targets = targets(b, &scenario, &label, &err)?;
        let budget = Budget {
            limits: Limits {
                assumption2: bounds,
                ..b.clone()
            },
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
    let reference = reference(spec.reference.as_deref(), &problems, &err)?;
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
            p.budget.limits.assumption2,
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
