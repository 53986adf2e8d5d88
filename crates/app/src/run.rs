//! Running one scenario: in process or co-simulated over iceoryx2, one platoon or a fleet, the
//! native plant or SUMO. [`run`] records into a run directory (the outputs of `platoon run`);
//! [`record`] drives the same step loop into any [`StepSink`]; [`platoon_sim::run`] gives the
//! summary alone, with no files at all.
use crate::error::{Context, OtherError};
use crate::progress::Progress;
use platoon_attacks::channel::ChannelEvent;
use platoon_config::{Config, Transport};
use platoon_output::plots;
use platoon_output::rundir::RunDir;
use platoon_output::tables::{Format, Table};
use platoon_runtime::timing::CryptoStages;
use platoon_sim::detection::Scored;
use platoon_sim::{Scenario, StepRow, StepWire, Summary};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

mod cosim;
mod error;

use cosim::{cosimulate, peak_rss_mib};
pub use error::{NodeFailure, RunError};
pub use platoon_config::PlantKind;
pub use platoon_output::run_tables::{read_tables, Plotted, RunFiles, Tables};

/// The result of a run, and of the steps of one.
pub type Result<T, E = RunError> = std::result::Result<T, E>;

/// How a third-party injector composes with the built-in channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InjectorMode {
    /// Instead of the built-in channel.
    Replace,
    /// After the built-in channel, on what survived it.
    After,
}

/// A third-party attack injector: a shell command and how it composes with the built-in
/// channel (`docs/injector-contract.md`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Injector {
    /// The command, run by `sh -c`.
    pub command: String,
    /// Instead of, or after, the built-in channel.
    pub mode: InjectorMode,
}

/// How a run runs; [`RunOptions::default`] is `platoon run`'s default.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Separate processes over iceoryx2, or the same core in one process.
    pub transport: Transport,
    /// Overrides the config's `simulation.plant`.
    pub plant: Option<PlantKind>,
    /// A third-party injector (iceoryx2 only); None: the built-in channel.
    pub injector: Option<Injector>,
    /// A third-party controller service, a shell command (iceoryx2 only,
    /// `docs/controller-contract.md`); None: the built-in controllers of the config.
    pub controller: Option<String>,
    /// How long the run waits for one process's sample of a step (iceoryx2).
    pub step_timeout: Duration,
    /// How long the run waits for its processes to report READY (iceoryx2): SUMO and a
    /// Python plug-in take seconds to start on a busy machine.
    pub ready_timeout: Duration,
    /// Read-only observers that may attach (iceoryx2).
    pub observers: usize,
    /// CPUs to pin the run's processes to (iceoryx2; empty: any).
    pub cpus: Vec<usize>,
    /// Draw the PNG figures.
    pub plots: bool,
    /// The program whose `node <role>` subcommand runs the processes of an iceoryx2 run
    /// (None: [`crate::platoon_program`], the `platoon` binary).
    pub node_program: Option<PathBuf>,
    /// The file the config came from, named by SUMO set-up errors.
    pub config_file: PathBuf,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            transport: Transport::Iceoryx2,
            plant: None,
            injector: None,
            controller: None,
            step_timeout: Duration::from_secs(1),
            ready_timeout: Duration::from_secs(60),
            observers: 4,
            cpus: Vec::new(),
            plots: true,
            node_program: None,
            config_file: PathBuf::from(platoon_config::Embedded::Paper.label()),
        }
    }
}

/// Asks a run to stop: the flag its loop checks, and what to say of why (e.g. "interrupted by
/// SIGINT").
#[derive(Clone, Default)]
pub struct Stop {
    /// Set to stop after the current step.
    pub flag: Arc<AtomicBool>,
    reason: Option<Arc<dyn Fn() -> Option<String> + Send + Sync>>,
}

impl Stop {
    /// A flag, and what to record as the reason once it is set (None: no stop was asked).
    pub fn new(
        flag: Arc<AtomicBool>,
        reason: impl Fn() -> Option<String> + Send + Sync + 'static,
    ) -> Self {
        Self {
            flag,
            reason: Some(Arc::new(reason)),
        }
    }

    /// Why the run was asked to stop, if it was.
    pub fn reason(&self) -> Option<String> {
        self.reason.as_ref().and_then(|r| r())
    }

    fn requested(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }
}

/// A finished run: what it recorded and where.
#[derive(Debug)]
pub struct RunOutcome {
    /// The run directory, complete.
    pub dir: PathBuf,
    /// Platoon 0's rows (what the plots show).
    pub rows: Vec<StepRow>,
    /// What `summary.json` holds (without the extra keys `injector`, `controller` and `sumo`).
    pub summary: Summary,
    /// Why a co-simulation ended early, if a process failed ([`RunError::Node`], with its log
    /// in `dir`) or the co-simulation did ([`RunError::Cosim`]); the run directory then says
    /// `complete: false`.
    pub failure: Option<RunError>,
    /// Why it was stopped early, if it was asked to (the summary says so too).
    pub stopped: Option<String>,
    /// Wall time of the steps.
    pub compute: Duration,
}

/// Takes the gain and the ratio beta1/beta2 of a certificate (`platoon design synthesize` or
/// `check-gain`) into `config`: control.gain = its K, control.beta1 = its ratio x beta2. Fails
/// unless the certificate holds; returns a warning when it was issued for another graph or
/// spacing policy (it then certifies nothing about this run, but its K and ratio are used).
pub fn apply_design(
    config: &mut Config,
    scenario: &mut Scenario,
    stem: &str,
    file: &Path,
) -> Result<Option<String>> {
    let text = std::fs::read_to_string(file)
        .with_context(|| format!("reading the design {}", file.display()))?;
    let cert: platoon_synthesis::Certificate = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a certificate", file.display()))?;
    if !cert.verify().map_err(OtherError::wrap)?.holds {
        bail!(
            "{}: the certificate does not hold (platoon design verify says why)",
            file.display()
        );
    }
    let h = scenario.topology.h_matrix();
    let same_graph = cert.h.len() == h.nrows()
        && cert
            .h
            .iter()
            .enumerate()
            .all(|(i, row)| row.iter().enumerate().all(|(j, &x)| x == h[(i, j)]));
    let warning = (!same_graph || cert.headway != scenario.headway()).then(|| {
        format!(
            "{} was issued for {} followers with a time headway of {} s; this run has {} with {} s, so it certifies nothing about this run (its K and ratio are used anyway)",
            file.display(),
            cert.h.len(),
            cert.headway,
            h.nrows(),
            scenario.headway()
        )
    });
    let platoon_config::LawParams::Paper(paper) = &mut config.control.law else {
        bail!(
            "{}: a design is the paper's law's gain and ratio, but the config runs law = \"{}\"",
            file.display(),
            config.control.law.name()
        );
    };
    paper.gain = cert.k;
    paper.beta1 = cert.ratio * paper.beta2;
    let label = format!("{} with the design {}", stem, file.display());
    *scenario = platoon_config::parse(&platoon_config::to_toml(config), Path::new(&label))?.1;
    Ok(warning)
}

/// Runs `config`'s scenario into the run directory `out` (created; replaced with `force`),
/// written atomically: config.toml, the per-step tables, timing.json, the plots and
/// summary.json, then renamed from `<out>.partial` to `out`. A run that a process ended early
/// or that `stop` stopped is still recorded, marked `complete: false`, and returned with the
/// failure or the reason. `progress` hears of the steps.
pub fn run(
    mut config: Config,
    scenario: &Scenario,
    opts: &RunOptions,
    out: &Path,
    force: bool,
    stop: &Stop,
    progress: &dyn Progress,
) -> Result<RunOutcome, RunError> {
    if opts.injector.is_some() && opts.transport == Transport::Inproc {
        return Err(RunError::Other(failure!(
            "--injector needs --transport iceoryx2: an external injector is a process"
        )));
    }
    if opts.controller.is_some() && opts.transport == Transport::Inproc {
        return Err(RunError::Other(failure!(
            "--controller needs --transport iceoryx2: an external controller is a process"
        )));
    }
    if scenario.control.security.is_some() && opts.controller.is_some() {
        // A controller plug-in neither signs nor verifies: refused, not run unsigned.
        return Err(platoon_config::ConfigError::new(
            &opts.config_file,
            "security",
            "a --controller plug-in neither signs nor verifies packets (the built-in \
             controller does): remove --controller, or remove [security]"
                .to_string(),
        )
        .into());
    }
    let plugin = &scenario.control.detection.plugin;
    if !plugin.is_empty() && opts.controller.is_none() {
        // A config this run cannot measure: refused as every bad config is (exit 2).
        return Err(platoon_config::ConfigError::new(
            &opts.config_file,
            "detection.plugin",
            format!(
                "names detectors a --controller plug-in runs ({}), but this run has none: give \
                 --controller (with --transport iceoryx2), or remove detection.plugin",
                plugin.join(", ")
            ),
        )
        .into());
    }
    if let Some(plant) = opts.plant {
        config.simulation.plant = plant;
    }
    if !config.leader.drive.is_profile() && config.simulation.plant != PlantKind::Sumo {
        return Err(platoon_config::ConfigError::new(
            &opts.config_file,
            "leader.drive",
            "kind = \"sumo\" has SUMO's car-following model drive the leader, which needs SUMO as \
             the plant: leave --plant native out (the native plant's leader follows leader.profile)"
                .to_string(),
        )
        .into());
    }
    if config.simulation.plant == PlantKind::Native {
        // SUMO's traffic would be dropped without a word: refused, once the plant is chosen.
        platoon_config::native_plant_check(&config).map_err(|e| {
            let lines = platoon_config::KeyLines::new(
                &std::fs::read_to_string(&opts.config_file).unwrap_or_default(),
            );
            RunError::from(e.in_file(&opts.config_file, &lines))
        })?;
    }
    let sumo_plan = if config.simulation.plant == PlantKind::Sumo {
        if config.plant.discretisation != platoon_model::Discretisation::Exact {
            return Err(RunError::Other(failure!(
                "--plant sumo: the SUMO plant moves vehicles its own way; plant.discretisation = \
                 \"plexe\" is for the native plant (leave --plant out, or set discretisation = \
                 \"exact\")"
            )));
        }
        if opts.transport == Transport::Inproc {
            return Err(RunError::Other(failure!(
                "the SUMO plant is a process: use --transport iceoryx2 (the default), or --plant native"
            )));
        }
        Some(crate::sumo::plan(&opts.config_file, &config, scenario)?)
    } else {
        None
    };
    if opts.step_timeout.is_zero() {
        return Err(RunError::Other(failure!(
            "--step-timeout must be a positive number of seconds"
        )));
    }
    if opts.ready_timeout.is_zero() {
        return Err(RunError::Other(failure!(
            "--ready-timeout must be a positive number of seconds"
        )));
    }
    let dir = RunDir::create(out, force)?;
    dir.write("config.toml", platoon_config::to_toml(&config).as_bytes())?;
    let started = Instant::now();
    let (rows, summary, failure) = match opts.transport {
        Transport::Inproc => {
            let (rows, summary) = simulate_plotted(scenario, &config.output, &dir, progress, stop)?;
            (rows, summary, None)
        }
        Transport::Iceoryx2 => {
            let plant = sumo_plan.as_ref().map(|p| p.launch(&dir)).transpose()?;
            cosimulate(scenario, &config.output, &dir, opts, plant, stop, progress)?
        }
    };
    // A stop wins over whatever it caused (a node that died of the same Ctrl-C, say).
    let stopped = stop.reason();
    let (mut summary, failure) = match &stopped {
        Some(why) => {
            let mut summary = summary;
            mark_stopped(&mut summary, why, scenario);
            (summary, None)
        }
        None => (summary, failure),
    };
    // A run that stopped by itself, neither asked to nor failed: its physics left the model
    // (`platoon_sim::model_check`), as its summary says.
    let left_model = (failure.is_none() && stopped.is_none() && !summary.complete)
        .then(|| summary.error.clone().unwrap_or_default());
    let compute = started.elapsed();
    crate::formations::certify(scenario, &mut summary);
    summary.attack.applied = opts
        .injector
        .as_ref()
        .is_none_or(|i| i.mode == InjectorMode::After);
    let mut extra = extra_json(opts);
    if let Some(plan) = &sumo_plan {
        if let Some(report) = sumo_json(plan, &dir, &mut summary, progress)? {
            extra.push(("sumo", report));
        }
    }
    write_outputs(&dir, &config, scenario, &rows, &summary, opts.plots, &extra)?;
    let dir = dir.commit()?;
    let failure = failure
        .map(|e| RunError::from_runtime(e, &dir.join("logs")))
        .or_else(|| left_model.map(|m| RunError::Other(failure!("{m}"))));
    Ok(RunOutcome {
        dir,
        rows: rows.rows,
        summary,
        failure,
        stopped,
        compute,
    })
}

/// summary.json's `injector` and, for a controller service of the caller's, `controller`.
fn extra_json(opts: &RunOptions) -> Vec<(&'static str, serde_json::Value)> {
    let mut extra = vec![(
        "injector",
        match &opts.injector {
            None => builtin_injector_json(),
            Some(i) => serde_json::json!({
                "program": i.command,
                "mode": match i.mode {
                    InjectorMode::Replace => "replace: the config's attacks were not applied by platoon",
                    InjectorMode::After => "after: the config's attacks first, then this program",
                },
            }),
        },
    )];
    // Which controller service ran, when it was not the built-in one.
    if let Some(program) = &opts.controller {
        extra.push(("controller", serde_json::json!({ "program": program })));
    }
    extra
}

/// summary.json's `sumo` (the bridge's sumo.json with the fcd.xml written from what was
/// recorded), if there is any; a collision SUMO reported makes the run's safety severe.
fn sumo_json(
    plan: &crate::sumo::SumoPlan<'_>,
    dir: &RunDir,
    summary: &mut Summary,
    progress: &dyn Progress,
) -> Result<Option<serde_json::Value>> {
    // fcd.xml from what was recorded (a stopped run's too), after the run's last step.
    // It is only a replay file: a conversion that fails (a run that ended early may have
    // recorded nothing to write) is said in the report and on stderr, and the run is kept
    // as it ended; its own failure, if any, stays the error.
    let fcd = match plan.write_recorded_fcd(dir) {
        Ok(fcd) => fcd.map(|fcd| {
            serde_json::json!({
                "file": "fcd.xml",
                "writer": "recorded",
                "period_s": fcd.period_s,
                "timesteps": fcd.timesteps,
                "vehicles": fcd.vehicles,
            })
        }),
        Err(e) => {
            if summary.complete {
                progress.message(&format!(
                    "warning: fcd.xml (the replay file) was not written, the run is kept: {}",
                    OtherError::report(&e)
                ));
            }
            Some(serde_json::json!({ "writer": "recorded", "error": OtherError::report(&e) }))
        }
    };
    // A plant that wrote no sumo.json (it died first) still has its fcd.xml reported.
    let report = crate::sumo::report(dir)?.or_else(|| fcd.is_some().then(|| serde_json::json!({})));
    Ok(report.map(|mut report| {
        if let Some(fcd) = fcd {
            report["fcd"] = fcd;
        }
        if let Some(first) = report["collisions"].as_array().and_then(|c| c.first()) {
            // SUMO's first collision, unless the platoon's own gaps saw one earlier.
            let t = first["t"].as_f64().unwrap_or(f64::NAN);
            if summary
                .safety
                .first_collision
                .as_ref()
                .is_none_or(|c| c.t_s > t)
            {
                let name = |key: &str| first[key].as_str().unwrap_or("?").to_string();
                summary.safety.first_collision = Some(platoon_sim::Collision {
                    t_s: t,
                    collider: format!("SUMO's {}", name("collider")),
                    victim: name("victim"),
                    lane: first["lane"]
                        .as_str()
                        .map_or("SUMO's road".to_string(), |l| format!("lane {l}")),
                    gap_m: None,
                });
            }
            summary.safety.collided = true;
            summary.safety.class = platoon_sim::SafetyClass::Severe;
            if let Some(f) = &mut summary.fleet {
                f.collided = true;
                f.class = platoon_sim::SafetyClass::Severe;
            }
        }
        report
    }))
}

/// Where a run's per-step data goes, step by step, whichever transport ran it.
pub trait StepSink {
    /// One step: every platoon's rows (platoon by platoon, leader first) and what happened on
    /// the wire.
    fn step(&mut self, rows: &[StepRow], wire: StepWire<'_>) -> Result<()>;
    /// What the built-in channel did not deliver as sent, as it happened (in process only: a
    /// co-simulation's injector writes its own log).
    fn channel(&mut self, _event: &ChannelEvent) -> Result<()> {
        Ok(())
    }
    /// The packets the detectors inspected in the step, with their ground truth (`[detection]`
    /// only; before the step's rows). `names` are the detectors, in the order of each packet's
    /// verdicts.
    fn detections(&mut self, _names: &[&str], _scored: &[Scored]) -> Result<()> {
        Ok(())
    }
    /// After the last step.
    fn finish(&mut self) -> Result<()> {
        Ok(())
    }
}

/// A sink that keeps nothing.
impl StepSink for () {
    fn step(&mut self, _rows: &[StepRow], _wire: StepWire<'_>) -> Result<()> {
        Ok(())
    }
}

/// Runs `scenario` in process, feeding every step to `sink` until the last step or `stop`;
/// returns the summary (`complete: false` when stopped) and each step's compute time (ns).
pub fn record(
    scenario: &Scenario,
    sink: &mut dyn StepSink,
    stop: &Stop,
    progress: &dyn Progress,
) -> Result<(Summary, Vec<u64>)> {
    let (summary, step_ns, _) = record_with(scenario, sink, stop, progress, false)?;
    Ok((summary, step_ns))
}

/// [`record`]; with `check_model`, a run whose physics leaves the vehicle model stops at that
/// step, its summary `complete: false` with the reason (`platoon_sim::model_check`), as
/// `platoon run` does on either transport.
fn record_with(
    scenario: &Scenario,
    sink: &mut dyn StepSink,
    stop: &Stop,
    progress: &dyn Progress,
    check_model: bool,
) -> Result<(Summary, Vec<u64>, Option<CryptoStages>)> {
    let steps = scenario.steps + 1;
    progress.start("simulating", steps);
    let mut step_ns = Vec::with_capacity(steps.min(1 << 20) as usize);
    let mut failure = None;
    let mut last = Instant::now();
    let mut check = platoon_sim::model_check::ModelCheck::new(scenario);
    let mut left_model = None;
    // `[security]`: what signing and verifying took in each step, by the runtime's clock.
    let mut crypto = scenario
        .control
        .security
        .is_some()
        .then(CryptoStages::default);
    let clock = platoon_runtime::monotonic_ns;
    let mut summary = platoon_sim::run_until_timed(scenario, clock, |sim| {
        step_ns.push(last.elapsed().as_nanos() as u64);
        if let (Some(c), Some(total)) = (&mut crypto, sim.crypto_time()) {
            c.push(total);
        }
        let written = sim
            .channel_log()
            .iter()
            .try_for_each(|e| sink.channel(e))
            .and_then(|()| {
                sim.platoons()
                    .iter()
                    .filter(|p| !p.scored().is_empty())
                    .try_for_each(|p| sink.detections(p.controller().detector_names(), p.scored()))
            });
        if let Err(e) = written.and_then(|()| sink.step(sim.rows(), sim.wire())) {
            failure = Some(e);
            return ControlFlow::Break(());
        }
        // Physics that left the vehicle model stops the run at that step, recorded.
        left_model = check_model.then(|| check.push(sim.rows())).flatten();
        if left_model.is_some() {
            return ControlFlow::Break(());
        }
        let k = sim.rows()[0].step;
        if k.is_multiple_of(1000) {
            progress.at(k);
        }
        last = Instant::now();
        if stop.requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })?;
    progress.finish();
    if let Some(e) = failure {
        return Err(e);
    }
    if let Some(exit) = left_model {
        summary.complete = false;
        summary.error = Some(exit.to_string());
    }
    sink.finish()?;
    Ok((summary, step_ns, crypto))
}

impl StepSink for RunFiles {
    fn step(&mut self, rows: &[StepRow], wire: StepWire<'_>) -> Result<()> {
        Ok(RunFiles::step(self, rows, wire)?)
    }

    fn channel(&mut self, event: &ChannelEvent) -> Result<()> {
        Ok(RunFiles::channel(self, event)?)
    }

    fn detections(&mut self, names: &[&str], scored: &[Scored]) -> Result<()> {
        Ok(RunFiles::detections(self, names, scored)?)
    }

    fn finish(&mut self) -> Result<()> {
        Ok(RunFiles::finish(self)?)
    }
}

/// Runs `scenario` in process and keeps everything in memory: the per-step tables `output`
/// asks for (its `files` and `decimate`; the format does not matter) and the summary, marked
/// `complete: false` with the reason when `stop` stopped it. No file is written.
pub fn simulate_in_memory(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    progress: &dyn Progress,
    stop: &Stop,
) -> Result<(Tables, Summary)> {
    let mut files = RunFiles::in_memory(scenario, output)?;
    let (mut summary, _) = record(scenario, &mut files, stop, progress)?;
    summary.attack.applied = true; // the built-in channel: no injector runs in process
    if let Some(why) = stop.reason() {
        mark_stopped(&mut summary, &why, scenario);
    }
    Ok((files.into_tables()?, summary))
}

/// A stopped run's summary: not complete, and why, after how many steps.
fn mark_stopped(summary: &mut Summary, why: &str, scenario: &Scenario) {
    summary.complete = false;
    summary.error = Some(format!(
        "{why} after {} of {} steps",
        summary.steps,
        scenario.steps + 1
    ));
}

/// The JSON of `summary.json`: the summary with the `extra` keys (`injector`, ...) set.
pub fn summary_json(
    summary: &Summary,
    extra: &[(&str, serde_json::Value)],
) -> Result<serde_json::Value> {
    let mut json = serde_json::to_value(summary)?;
    for (key, value) in extra {
        json[*key] = value.clone();
    }
    Ok(json)
}

/// Runs the scenario in process into `dir` (the per-step tables and timing.json); returns
/// platoon 0's rows and the summary.
pub fn simulate(
    scenario: &Scenario,
    dir: &RunDir,
    progress: &dyn Progress,
) -> Result<(Vec<StepRow>, Summary)> {
    simulate_until(
        scenario,
        &Default::default(),
        dir,
        progress,
        &Stop::default(),
    )
}

/// [`simulate`] with the config's `[output]`, stopping after the step at which `stop` is seen
/// set (the summary then says `complete: false`).
pub fn simulate_until(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
    progress: &dyn Progress,
    stop: &Stop,
) -> Result<(Vec<StepRow>, Summary)> {
    let (plotted, summary) = simulate_plotted(scenario, output, dir, progress, stop)?;
    Ok((plotted.rows, summary))
}

/// [`simulate_until`] returning what the plots draw.
fn simulate_plotted(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
    progress: &dyn Progress,
    stop: &Stop,
) -> Result<(Plotted, Summary)> {
    let mut files = RunFiles::create(scenario, output, dir, true, !scenario.cut_ins.is_empty())?;
    let (summary, mut step_ns, crypto) = record_with(scenario, &mut files, stop, progress, true)?;
    // In process a step has no stages: only its compute time, and in `[security]` runs what
    // its signing and verifying took.
    let mut timing = platoon_runtime::timing::Timing {
        step: platoon_runtime::timing::Stats::of(&mut step_ns),
        controller_tx: None,
        injector: None,
        controller_rx: None,
        plant: None,
        sign: None,
        verify: None,
    };
    if let Some(c) = crypto {
        c.report_into(&mut timing);
    }
    let mut timing = serde_json::to_value(&timing)?;
    timing["peak_rss_mib"] = peak_rss_mib(&[]);
    dir.write(
        "timing.json",
        (serde_json::to_string_pretty(&timing)? + "\n").as_bytes(),
    )?;
    Ok((files.into_plotted(), summary))
}

/// summary.json's `injector` when the built-in channel gates the links.
pub fn builtin_injector_json() -> serde_json::Value {
    serde_json::json!({ "program": "built-in", "mode": "built-in" })
}

/// `run.json`, written the moment an iceoryx2 run starts: what an outside observer needs to find
/// this run's services (and not another's) and read them.
fn write_run_json(dir: &RunDir, run_id: &str, scenario: &Scenario, observers: usize) -> Result<()> {
    use platoon_wire::{service_name, Observed, Service};
    let observe: serde_json::Map<String, serde_json::Value> = Observed::ALL
        .iter()
        .map(|&o| {
            (
                o.leaf().to_string(),
                service_name(run_id, Service::Observe(o)).into(),
            )
        })
        .collect();
    let json = serde_json::json!({
        "run_id": run_id,
        "pid": std::process::id(),
        "config": std::path::absolute(dir.path("config.toml")).unwrap_or_default(),
        "observers": observers,
        "observe": observe,
        "platoons": scenario.fleet.platoons,
        "vehicles_per_platoon": scenario.vehicles_per_platoon(),
        "spacing_m": scenario.spacing(),
        "spacing_policy": scenario.spacing_policy().name(),
        "time_headway_s": scenario.headway(),
        "dt_s": scenario.dt(),
        "steps": scenario.steps + 1,
    });
    Ok(dir.write(
        "run.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?)
}

/// Writes config.toml (if not yet there), the plots (of platoon 0's rows, `Plotted::from` them
/// if there is nothing else to draw), and summary.json (with the `extra` keys) last.
pub fn write_outputs(
    dir: &RunDir,
    config: &Config,
    scenario: &Scenario,
    plotted: &Plotted,
    summary: &Summary,
    plots: bool,
    extra: &[(&str, serde_json::Value)],
) -> Result<()> {
    if !dir.path("config.toml").exists() {
        dir.write("config.toml", platoon_config::to_toml(config).as_bytes())?;
    }
    let rows = &plotted.rows;
    if plots {
        for (name, draw) in [
            (
                "fig6.png",
                plots::fig6
                    as fn(&Path, &Scenario, &[StepRow]) -> platoon_output::error::Result<()>,
            ),
            ("fig7.png", plots::fig7),
        ] {
            let path = dir.path(name);
            draw(&path, scenario, rows).with_context(|| format!("drawing {}", path.display()))?;
        }
        if summary.vehicles.len() > 1 {
            // String (in)stability at a glance: the largest gap error along the platoon.
            let path = dir.path("gaps.png");
            let policy = scenario.spacing_policy();
            plots::scatter_with_lines(
                &path,
                &format!("Largest |gap error to the predecessor| per follower ({policy})"),
                "follower",
                "largest |gap error| (m)",
                &[plots::Series {
                    label: "measured in the plant".into(),
                    color: 0,
                    points: summary
                        .vehicles
                        .iter()
                        .map(|v| (f64::from(v.vehicle), v.gap_error_m.max_abs))
                        .collect(),
                }],
            )
            .with_context(|| format!("drawing {}", path.display()))?;
        }
        if !plotted.flags.is_empty()
            || rows
                .iter()
                .any(|r| r.mode != platoon_control::Mode::Coop || r.guard)
        {
            let path = dir.path("modes.png");
            plots::modes(&path, scenario, rows, &plotted.flags)
                .with_context(|| format!("drawing {}", path.display()))?;
        }
    }
    let json = serde_json::to_string_pretty(&summary_json(summary, extra)?)? + "\n";
    Ok(dir.write("summary.json", json.as_bytes())?)
}
