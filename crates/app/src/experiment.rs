//! The paper's Section IV experiments, and ours, as library calls: Table I and Fig. 8
//! ([`table1`]), Fig. 9 ([`robust`]), Fig. 10 ([`topologies`]), graceful degradation
//! ([`degradation`]), long platoons ([`scaling`]), controllers side by side under attack
//! ([`controllers`]), misbehaviour detectors against ground truth ([`detection`]) and cut-ins
//! by law and attack ([`traffic`]). Each runs
//! on a [`Base`] scenario and
//! returns its results in memory; given a run directory it also writes the files of
//! `platoon experiment` there (the caller creates and commits it). Progress goes to a
//! [`Progress`].
use crate::error::OtherError;
use crate::progress::Progress;
use crate::run::{record, simulate, write_outputs, RunError, StepSink, Stop};
use platoon_config::{Config, ConfigError, Embedded};
use platoon_control::TriggerRule;
use platoon_output::error::OutputError;
use platoon_output::plots::{self, Series};
use platoon_output::rundir::RunDir;
use platoon_sim::{SafetyClass, Scenario, StepRow, StepWire, Summary};
use platoon_synthesis::Design;
use platoon_topology::Preset;
use std::fmt::Write as _;
use std::path::Path;

mod controllers;
mod degradation;
mod detection;
mod maneuvers;
mod robust;
mod scaling;
mod security;
mod table1;
mod topologies;
mod traffic;
pub(crate) use controllers::{
    configure as configure_law, keep_law_spacing, law_config, on_standstill,
};
pub use controllers::{
    controllers, Controllers, ControllersOptions, ControllersRow, ATTACKS as CONTROLLER_ATTACKS,
};
pub use degradation::*;
pub use detection::{
    attack_kind, detection, Detection, DetectionOptions, DetectionRow, Intensity,
    ATTACKS as DETECTION_ATTACKS, DETECTORS, REACTIONS as DETECTION_REACTIONS,
};
pub use maneuvers::{
    maneuvers, Maneuvers, ManeuversOptions, ManeuversRow, ATTACKS as MANEUVER_ATTACKS, MANEUVERS,
    SECURITY as MANEUVER_SECURITY,
};
pub use robust::*;
pub use scaling::*;
pub use security::{
    security, Security, SecurityOptions, SecurityRow, ATTACKERS as SECURITY_ATTACKERS,
    DEFENCES as SECURITY_DEFENCES,
};
pub use table1::*;
pub use topologies::*;
pub use traffic::{traffic, Traffic, TrafficOptions, TrafficRow, ATTACKS as TRAFFIC_ATTACKS};

/// The result of the experiments.
pub type Result<T, E = ExperimentError> = std::result::Result<T, E>;

/// Why an experiment failed, by kind: what a caller branches on. Each message is the one
/// `platoon experiment` prints.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExperimentError {
    /// The base config is refused ([`Base::load`]'s error, for a caller that loads and runs
    /// with one error type; `platoon experiment` exits 2).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Options no experiment can use (an empty list, a size of 0, an unknown name), refused
    /// before anything runs.
    #[error("{0}")]
    Options(String),
    /// The base config is valid but not one this experiment can start from (Table I needs the
    /// dynamic trigger; Fig. 10 its parameters and Assumption 2's bounds).
    #[error("{0}")]
    Base(String),
    /// A scenario the experiment makes of the base (a law, a topology, a size, an attack)
    /// does not resolve; the message names it and the key.
    #[error("{0}")]
    Variant(String),
    /// No gain within the bound was found for a design the experiment needs (Fig. 9).
    #[error("infeasible: no design for {design} with |K| <= {k_max}")]
    Infeasible {
        /// The design (`tau = 0.5`, `robust`).
        design: String,
        /// The bound on |K|.
        k_max: f64,
    },
    /// The SDP solver failed (or this build has none).
    #[error(transparent)]
    Solver(#[from] platoon_synthesis::LmiError),
    /// A run of the experiment, in process, refused its scenario or failed.
    #[error(transparent)]
    Run(#[from] platoon_sim::ScenarioError),
    /// The output directory or one of its files.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Anything else (a table that could not be written, a run that measured nothing).
    #[error(transparent)]
    Other(OtherError),
}

operation_error!(ExperimentError);

impl From<platoon_topology::TopologyError> for ExperimentError {
    fn from(e: platoon_topology::TopologyError) -> Self {
        Self::Other(OtherError::wrap(e))
    }
}

impl From<RunError> for ExperimentError {
    /// A run's config and output errors are the experiment's; the rest is `Other`.
    fn from(e: RunError) -> Self {
        match e {
            RunError::Config(c) | RunError::Sumo(crate::sumo::SumoError::Config(c)) => {
                Self::Config(c)
            }
            RunError::Output(o) => Self::Output(o),
            RunError::Other(o) => Self::Other(o),
            e => Self::Other(OtherError::wrap(e)),
        }
    }
}

impl ExperimentError {
    /// The config error this is, if it is one (`platoon experiment` exits 2 on it).
    pub fn config(&self) -> Option<&ConfigError> {
        match self {
            Self::Config(c) => Some(c),
            _ => None,
        }
    }

    /// The output error this is, if it is one.
    pub fn output(&self) -> Option<&OutputError> {
        match self {
            Self::Output(o) => Some(o),
            _ => None,
        }
    }
}

/// Returns an [`ExperimentError`] of `kind` with the message `format!` makes of the rest.
macro_rules! refuse {
    ($kind:ident, $($message:tt)+) => {
        return Err(ExperimentError::$kind(format!($($message)+)))
    };
}
pub(crate) use refuse;

/// What every experiment is: options checked before anything runs, a base config it may
/// refuse, its cells measured on the base (results in memory; given a run directory, the
/// runs' own directories there), its tables and figures written into that directory, and the
/// text it prints. [`run`] runs any of them; each also has a function of its own
/// (`controllers`, ...) that is [`run`] of it.
pub trait Experiment: Sized {
    /// Its options (`()` when it has none).
    type Options;
    /// Its name: `platoon experiment <NAME>`.
    const NAME: &'static str;
    /// The run directory `platoon experiment` writes it into by default.
    const DIR: &'static str;
    /// The embedded config it starts from when given none.
    const BASE: Embedded;
    /// Refuses options no run can use, before anything runs.
    fn validate(opts: &Self::Options) -> Result<()>;
    /// Refuses a base config the experiment cannot start from, before anything runs.
    fn check_base(_base: &Base) -> Result<()> {
        Ok(())
    }
    /// The plant its runs use: the native one, in process, unless its options say SUMO.
    fn plant(_opts: &Self::Options) -> platoon_config::PlantKind {
        platoon_config::PlantKind::Native
    }
    /// Measures its cells on `base`; with `out`, writes its config.toml and its runs'
    /// directories there.
    fn measure(
        base: &Base,
        opts: &Self::Options,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self>;
    /// Writes its tables (`<name>.csv`, `<name>.md`) and figures into `dir`.
    fn write(&self, base: &Base, opts: &Self::Options, dir: &RunDir) -> Result<()>;
    /// Its table as `platoon experiment` prints it (the Markdown of its `.md` file).
    fn summary(&self) -> String;
}

/// Runs the experiment `E` on `base`: its options and the base checked, its cells measured,
/// and with `out` its files written there.
pub fn run<E: Experiment>(
    base: &Base,
    opts: &E::Options,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<E> {
    E::validate(opts)?;
    E::check_base(base)?;
    if E::plant(opts) == platoon_config::PlantKind::Native {
        // SUMO's traffic in the base would be dropped without a word (as `platoon run`
        // refuses it on the native plant).
        platoon_config::native_plant_check(&base.config)
            .map_err(|e| ConfigError::new(Path::new(&base.label), &e.key, e.reason.to_string()))?;
    }
    let result = E::measure(base, opts, out, progress)?;
    written(result, out, |r, dir| r.write(base, opts, dir))
}

/// The scenario an experiment starts from: its config, what it runs, and how errors name it.
#[derive(Debug, Clone)]
pub struct Base {
    /// The resolved config (written as the experiment's config.toml).
    pub config: Config,
    /// What it runs.
    pub scenario: Scenario,
    /// The file, or the embedded config's label, as errors name it.
    pub label: String,
}

impl Base {
    /// Loads `path`, or without one the embedded config `default`.
    pub fn load(path: Option<&Path>, default: Embedded) -> Result<Self, ConfigError> {
        let platoon_config::Loaded {
            config, scenario, ..
        } = platoon_config::load_or(path, default)?;
        let label = path.map_or_else(|| default.label(), |p| p.display().to_string());
        Ok(Self {
            config,
            scenario,
            label,
        })
    }
}

/// Platoon 0's rows, kept in memory.
#[derive(Default)]
struct Rows(Vec<StepRow>);

impl StepSink for Rows {
    fn step(&mut self, rows: &[StepRow], _wire: StepWire<'_>) -> Result<(), RunError> {
        self.0.extend(rows.iter().take_while(|r| r.platoon == 0));
        Ok(())
    }
}

/// Runs `scenario` in process: with `out`, into its sub-directory `name` (the per-step tables,
/// timing.json, config.toml and summary.json, as `platoon run --transport inproc --no-plots`
/// writes them), else in memory. Returns platoon 0's rows and the summary.
fn run_in(
    config: &Config,
    scenario: &Scenario,
    out: Option<&RunDir>,
    name: &str,
    progress: &dyn Progress,
) -> Result<(Vec<StepRow>, Summary)> {
    match out {
        Some(dir) => {
            let sub = RunDir::create(&dir.path(name), true)?;
            let (rows, summary) = simulate(scenario, &sub, progress)?;
            let plotted = crate::run::Plotted::from(rows);
            write_outputs(&sub, config, scenario, &plotted, &summary, false, &[])?;
            sub.commit()?;
            Ok((plotted.rows, summary))
        }
        None => {
            let mut rows = Rows::default();
            let (summary, _) = record(scenario, &mut rows, &Stop::default(), progress)?;
            Ok((rows.0, summary))
        }
    }
}

/// Mean over followers of |spacing error| at each step: (t, m).
pub fn average_error(rows: &[StepRow]) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64, u32)> = Vec::new();
    for r in rows.iter().filter(|r| r.vehicle > 0) {
        if out.last().is_none_or(|l| l.0 != r.t) {
            out.push((r.t, 0.0, 0));
        }
        let l = out.last_mut().expect("pushed above");
        l.1 += r.spacing_error.abs();
        l.2 += 1;
    }
    out.into_iter()
        .map(|(t, s, n)| (t, s / f64::from(n)))
        .collect()
}

/// Starts `config`'s platoon in formation (the leader at 0 m, no jitter) in place of its
/// initial states.
fn in_formation(config: &mut Config) {
    config.platoon.initial_states = None;
    config.platoon.formation = Some(platoon_config::Formation {
        leader_position_m: 0.0,
        position_jitter_m: 0.0,
        speed_jitter_mps: 0.0,
        seed: 0,
    });
}

/// `config` with `followers` followers, in formation ([`in_formation`]), one fallback for all.
fn resize(config: &mut Config, followers: usize) {
    config.platoon.followers = followers;
    in_formation(config);
    config.fallback.per_vehicle = None;
}

/// Fails unless `sizes` (the option `flag`) are platoon sizes of at least one follower; the
/// message shows `example`.
/// Refuses an empty list of names for `flag` and a name not among `all`.
fn check_names(flag: &str, given: &[String], all: &[&str]) -> Result<()> {
    if given.is_empty() {
        refuse!(Options, "{flag} needs at least one of {}", all.join(", "));
    }
    if let Some(x) = given.iter().find(|x| !all.contains(&x.as_str())) {
        refuse!(Options, "{flag}: unknown {x:?}; use {}", all.join(", "));
    }
    Ok(())
}

fn check_sizes(sizes: &[usize], flag: &str, example: &str) -> Result<()> {
    if sizes.is_empty() || sizes.contains(&0) {
        refuse!(
            Options,
            "{flag} needs platoon sizes of at least one follower, e.g. {example}"
        );
    }
    Ok(())
}

/// With `out`, writes `config` as the experiment's config.toml.
fn write_config(out: Option<&RunDir>, config: &Config) -> Result<()> {
    if let Some(dir) = out {
        dir.write("config.toml", platoon_config::to_toml(config).as_bytes())?;
    }
    Ok(())
}

/// Runs `cell` on each of `cells` in order as the stage `what` of `progress`, naming each by
/// `detail` and counting it when it is done; stops at the first error. Returns what each cell
/// gave, in the cells' order.
fn walk<C, R>(
    progress: &dyn Progress,
    what: &str,
    cells: Vec<C>,
    detail: impl Fn(&C) -> String,
    mut cell: impl FnMut(C) -> Result<R>,
) -> Result<Vec<R>> {
    progress.start(what, cells.len() as u64);
    let mut out = Vec::with_capacity(cells.len());
    for c in cells {
        progress.detail(&detail(&c));
        out.push(cell(c)?);
        progress.at(out.len() as u64);
    }
    progress.finish();
    Ok(out)
}

/// `result`, after `write` has written its files into `out` when there is one.
fn written<T>(
    result: T,
    out: Option<&RunDir>,
    write: impl FnOnce(&T, &RunDir) -> Result<()>,
) -> Result<T> {
    if let Some(dir) = out {
        write(&result, dir)?;
    }
    Ok(result)
}

/// `rows` as `<name>.csv`, one record a row.
fn write_csv(dir: &RunDir, name: &str, rows: &[impl serde::Serialize]) -> Result<()> {
    let mut csv = csv::Writer::from_writer(dir.writer(&format!("{name}.csv"))?);
    for r in rows {
        csv.serialize(r)?;
    }
    csv.flush()?;
    Ok(())
}

/// An experiment's table: `rows` as `<name>.csv` ([`write_csv`]) and `markdown` as
/// `<name>.md`.
fn write_table(
    dir: &RunDir,
    name: &str,
    rows: &[impl serde::Serialize],
    markdown: &str,
) -> Result<()> {
    write_csv(dir, name, rows)?;
    dir.write(&format!("{name}.md"), markdown.as_bytes())?;
    Ok(())
}

/// The rows of each value of `key`, the values in the order they first appear: the repeats
/// of one cell of a table.
fn repeats<'a, R, K: PartialEq>(rows: &'a [R], key: impl Fn(&'a R) -> K) -> Vec<(K, Vec<&'a R>)> {
    let mut groups: Vec<(K, Vec<&'a R>)> = Vec::new();
    for r in rows {
        let k = key(r);
        match groups.iter_mut().find(|(g, _)| *g == k) {
            Some((_, same)) => same.push(r),
            None => groups.push((k, vec![r])),
        }
    }
    groups
}

/// The bars of a figure by law: for each of `laws`, `value(law, attack)` (by name) under each
/// of `attacks`.
fn bars_by_law(
    laws: &[platoon_config::LawName],
    attacks: &[impl AsRef<str>],
    value: impl Fn(&str, &str) -> f64,
) -> Vec<(String, Vec<f64>)> {
    laws.iter()
        .map(|law| {
            let values = attacks
                .iter()
                .map(|a| value(law.name(), a.as_ref()))
                .collect();
            (law.name().to_string(), values)
        })
        .collect()
}

/// A value as pretty JSON with a final newline, as every JSON file of platoon is written.
fn pretty(value: &impl serde::Serialize) -> Result<Vec<u8>> {
    Ok((serde_json::to_string_pretty(value)? + "\n").into_bytes())
}

/// `<name>.csv` (t and one mean-absolute-spacing-error column per curve) and `<name>.png`.
fn error_figure(dir: &RunDir, name: &str, curves: &[(&str, &[(f64, f64)])]) -> Result<()> {
    let mut csv = csv::Writer::from_writer(dir.writer(&format!("{name}.csv"))?);
    let mut header = vec!["t".to_string()];
    header.extend(
        curves
            .iter()
            .map(|(n, _)| format!("{n}_mean_abs_spacing_error_m")),
    );
    csv.write_record(&header)?;
    for k in 0..curves[0].1.len() {
        let mut rec = vec![curves[0].1[k].0.to_string()];
        rec.extend(curves.iter().map(|(_, e)| e[k].1.to_string()));
        csv.write_record(&rec)?;
    }
    csv.flush()?;
    let series: Vec<Series> = curves
        .iter()
        .enumerate()
        .map(|(i, (n, e))| Series {
            label: n.to_string(),
            color: i,
            points: e.to_vec(),
        })
        .collect();
    Ok(plots::lines(
        &dir.path(&format!("{name}.png")),
        "Average tracking error (mean over followers of |p_i - p_0 + i l|)",
        "m",
        &series,
    )?)
}

/// Three decimals, or three significant digits in scientific notation for the huge and tiny
/// numbers of a diverging platoon.
fn short(x: f64) -> String {
    if x != 0.0 && !(1e-3..1e5).contains(&x.abs()) {
        format!("{x:.2e}")
    } else {
        format!("{x:.3}")
    }
}

/// A certified ratio for the tables: "-" when not computed, "infeasible" when infinite.
fn ratio_text(x: Option<f64>) -> String {
    match x {
        None => "-".into(),
        Some(x) if x.is_finite() => format!("{x:.1}"),
        Some(_) => "infeasible".into(),
    }
}
