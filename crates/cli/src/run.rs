//! `platoon run`: one scenario, in process, into a run directory.
use platoon_output::rundir::RunDir;
use platoon_output::plots;
use anyhow::{Context, Result};
use platoon_config::{Config, Transport};
use platoon_sim::{Scenario, StepRow, Summary};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `platoon run` (its help text is on the `Run` command in main.rs).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenario config (TOML). Without it, the embedded configs/paper.toml runs.
    pub config: Option<PathBuf>,
    /// Run directory to create [default: runs/<config name>].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the run directory if it exists.
    #[arg(long)]
    pub force: bool,
    /// Skip the PNG plots (faster on long runs).
    #[arg(long)]
    pub no_plots: bool,
    /// iceoryx2: plant, controller and injector run as separate processes over shared memory
    /// (lock-step, event-driven). inproc: the same core in one process, with no IPC (the oracle
    /// the iceoryx2 run must match bit for bit).
    #[arg(long, value_enum, default_value_t = Transport::Iceoryx2)]
    pub transport: Transport,
    /// Run this program as the attack injector instead of the built-in one (iceoryx2 only),
    /// e.g. "bridge/.venv/bin/python bridge/examples/drop_sender.py 2". It gets PLATOON_RUN_ID
    /// and PLATOON_CONFIG in its environment; docs/injector-contract.md says what it must do.
    #[arg(long, value_name = "COMMAND")]
    pub injector: Option<String>,
    /// With --injector: `replace` runs it instead of the built-in channel (the config's
    /// `[attack]` and `[[channel.attacks]]` are then applied by no one); `after` runs the
    /// built-in channel first and gives the injector what survived it, jammed notices included
    /// (it reads the `gated` service instead of `tx`; the SDKs do this by themselves).
    /// summary.json records the mode under "injector".
    #[arg(long, value_enum, default_value_t = InjectorMode::Replace, requires = "injector")]
    pub injector_mode: InjectorMode,
    /// Seconds the run waits for a process's sample of one step before it stops and names the
    /// process (iceoryx2 only).
    #[arg(
        long,
        default_value_t = 1.0,
        value_name = "SECONDS",
        env = "PLATOON_STEP_TIMEOUT"
    )]
    pub step_timeout: f64,
    /// What integrates the vehicles, overriding the config's `simulation.plant`: native (the
    /// model in Rust) or sumo (SUMO through the libsumo bridge in bridge/, whose Python
    /// environment is created on first use; writes fcd.xml and sumo.json too).
    #[arg(long, value_enum)]
    pub plant: Option<PlantKind>,
    /// Read-only observers that may attach to the run's `observe/*` services (iceoryx2 only;
    /// see docs/observer-contract.md). More than this are refused at attach time; the run is
    /// never affected either way.
    #[arg(long, default_value_t = 4, value_name = "N", env = "PLATOON_OBSERVERS")]
    pub observers: usize,
    /// Pin the run's processes (plant, controller, injector) to these CPUs, as `taskset -c`
    /// takes them (e.g. 0 or 0-1; iceoryx2 only). A step is a chain of wake-ups with one
    /// process running at a time, so where waking a process on another core is slow (VMs
    /// that halt idle cores) one core is faster; BENCHMARKS.md measures it. Default: any.
    #[arg(long, value_name = "LIST", env = "PLATOON_CPUS", value_parser = CpuList::parse)]
    pub cpus: Option<CpuList>,
    /// Take K and beta1/beta2 from a certificate (`platoon design synthesize` or `check-gain`):
    /// control.gain = its K, control.beta1 = its ratio x the config's beta2.
    #[arg(long, value_name = "CERTIFICATE")]
    pub design: Option<PathBuf>,
}

/// `--cpus`: a CPU list as `taskset -c` takes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CpuList(pub Vec<usize>);

impl CpuList {
    fn parse(list: &str) -> Result<Self, String> {
        platoon_runtime::parse_cpus(list).map(Self)
    }
}

/// What integrates the vehicles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlantKind {
    /// The model in Rust (`platoon node plant`).
    Native,
    /// SUMO through the libsumo bridge (bridge/sumo_plant.py).
    Sumo,
}

/// How a third-party injector composes with the built-in channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InjectorMode {
    /// Instead of the built-in channel.
    Replace,
    /// After the built-in channel, on what survived it.
    After,
}

pub fn run(args: Args) -> Result<()> {
    let platoon_config::Loaded {
        mut config,
        mut scenario,
        stem,
    } = platoon_config::load_or(args.config.as_deref(), platoon_config::Embedded::Paper)?;
    if let Some(file) = &args.design {
        let text = std::fs::read_to_string(file)
            .with_context(|| format!("reading the design {}", file.display()))?;
        let cert: platoon_synthesis::Certificate = serde_json::from_str(&text)
            .with_context(|| format!("{} is not a certificate", file.display()))?;
        if !cert.verify()?.holds {
            anyhow::bail!(
                "{}: the certificate does not hold (platoon design verify says why)",
                file.display()
            );
        }
        // A certificate speaks of one graph and spacing policy: say so when the run's differ.
        let h = scenario.topology.h_matrix();
        let same_graph = cert.h.len() == h.nrows()
            && cert
                .h
                .iter()
                .enumerate()
                .all(|(i, row)| row.iter().enumerate().all(|(j, &x)| x == h[(i, j)]));
        if !same_graph || cert.headway != scenario.headway() {
            eprintln!(
                "warning: {} was issued for {} followers with a time headway of {} s; this run has {} with {} s, so it certifies nothing about this run (its K and ratio are used anyway)",
                file.display(),
                cert.h.len(),
                cert.headway,
                h.nrows(),
                scenario.headway()
            );
        }
        config.control.gain = cert.k;
        config.control.beta1 = cert.ratio * config.control.beta2;
        let label = format!("{} with the design {}", stem, file.display());
        scenario = platoon_config::parse(&platoon_config::to_toml(&config), Path::new(&label))?.1;
    }
    if args.injector.is_some() && args.transport == Transport::Inproc {
        anyhow::bail!("--injector needs --transport iceoryx2: an external injector is a process");
    }
    match args.plant {
        Some(PlantKind::Sumo) => config.simulation.plant = "sumo".into(),
        Some(PlantKind::Native) => config.simulation.plant = "native".into(),
        None => {}
    }
    let sumo_plan = if config.simulation.plant == "sumo" {
        if args.transport == Transport::Inproc {
            anyhow::bail!(
                "the SUMO plant is a process: use --transport iceoryx2 (the default), or --plant native"
            );
        }
        let file = args
            .config
            .clone()
            .unwrap_or_else(|| PathBuf::from(platoon_config::Embedded::Paper.label()));
        Some(crate::sumo::plan(&file, &config, &scenario)?)
    } else {
        None
    };
    if !(args.step_timeout.is_finite() && args.step_timeout > 0.0) {
        anyhow::bail!("--step-timeout must be a positive number of seconds");
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(&stem));
    let dir = RunDir::create(&out, args.force)?;
    dir.write("config.toml", platoon_config::to_toml(&config).as_bytes())?;
    let interrupt = crate::signals::Interrupt::install(
        "stopping the run; what is recorded is kept (complete: false)",
    )?;
    let started = Instant::now();
    let (rows, summary, failure) = match args.transport {
        Transport::Inproc => {
            let (rows, summary) =
                simulate_until(&scenario, &config.output, &dir, true, Some(&interrupt.stop))?;
            (rows, summary, None)
        }
        Transport::Iceoryx2 => {
            let plant = sumo_plan.as_ref().map(|p| p.launch(&dir)).transpose()?;
            cosimulate(
                &scenario,
                &config.output,
                &dir,
                &args,
                plant,
                interrupt.stop.clone(),
            )?
        }
    };
    // A signal wins over whatever it caused (a node that died of the same Ctrl-C, say).
    let (summary, failure) = match interrupt.signal() {
        Some(sig) => {
            let mut summary = summary;
            summary.complete = false;
            summary.error = Some(format!(
                "interrupted by {} after {} of {} steps",
                crate::signals::name(sig),
                summary.steps,
                scenario.steps + 1
            ));
            (summary, None)
        }
        None => (summary, failure),
    };
    let compute = started.elapsed();
    let mut summary = summary;
    summary.attack.applied = args.injector.is_none() || args.injector_mode == InjectorMode::After;
    let mut extra = vec![(
        "injector",
        match &args.injector {
            None => builtin_injector_json(),
            Some(cmd) => serde_json::json!({
                "program": cmd,
                "mode": match args.injector_mode {
                    InjectorMode::Replace => "replace: the config's attacks were not applied by platoon",
                    InjectorMode::After => "after: the config's attacks first, then this program",
                },
            }),
        },
    )];
    if sumo_plan.is_some() {
        if let Some(report) = crate::sumo::report(&dir)? {
            if report["collisions"]
                .as_array()
                .is_some_and(|c| !c.is_empty())
            {
                summary.safety.collided = true;
                summary.safety.class = platoon_sim::SafetyClass::Severe;
                if let Some(f) = &mut summary.fleet {
                    f.collided = true;
                    f.class = platoon_sim::SafetyClass::Severe;
                }
            }
            extra.push(("sumo", report));
        }
    }
    write_outputs(
        &dir,
        &config,
        &scenario,
        &rows,
        &summary,
        !args.no_plots,
        &extra,
    )?;
    let path = dir.commit()?;
    if let Some(sig) = interrupt.signal() {
        eprintln!(
            "interrupted: {} of {} steps are recorded in {} (summary.json says complete: false)",
            summary.steps,
            scenario.steps + 1,
            path.display()
        );
        std::process::exit(crate::signals::exit_code(sig));
    }
    if let Some(e) = failure {
        eprintln!(
            "the run stopped after {} of {} steps; what it recorded is in {} (summary.json says complete: false)",
            summary.steps,
            scenario.steps + 1,
            path.display()
        );
        return Err(e.into());
    }
    print_summary(&summary, compute.as_secs_f64());
    println!("outputs: {}", path.display());
    Ok(())
}

fn progress_bar(steps: u64, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(steps);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{spinner}} {what} {{pos}}/{{len}} steps [{{elapsed}}] {{wide_bar}}"
        ))
        .expect("static template"),
    );
    bar
}

/// Streams rows to trajectories.csv and broadcasts to events.csv, keeps platoon 0's rows for
/// the plots (memory stays bounded for large fleets) and sums the metrics.
struct Recording {
    trajectories: platoon_output::tables::Table<StepRow>,
    events: platoon_output::tables::Table<EventRow>,
    wire: platoon_output::tables::Table<WireRow>,
    decimate: u64,
    last: Vec<Option<u64>>,
    modes: Vec<platoon_control::Mode>,
    per_platoon: usize,
    dt: f64,
    rows: Vec<StepRow>,
    metrics: platoon_sim::FleetMetrics,
    failure: Option<anyhow::Error>,
    bar: indicatif::ProgressBar,
}

/// One row of wire.csv: a vehicle's link packets in a step where not everything sent to it was
/// delivered as sent.
#[derive(serde::Serialize, serde::Deserialize)]
struct WireRow {
    step: u64,
    t: f64,
    platoon: u16,
    vehicle: u16,
    sent: u64,
    delivered_as_sent: u64,
    altered: u64,
    dropped: u64,
    injected: u64,
    jammed: u64,
}

/// One row per broadcast of a follower, and one per change of its mode.
#[derive(serde::Serialize, serde::Deserialize)]
struct EventRow {
    platoon: u16,
    vehicle: u16,
    step: u64,
    t: f64,
    /// `broadcast`, or `switch` (the vehicle's mode changed at this step).
    event: Event,
    /// The mode it is in (after the switch).
    mode: platoon_control::Mode,
    /// Broadcasts: the time since its previous broadcast.
    inter_event_s: Option<f64>,
    under_attack: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
enum Event {
    Broadcast,
    Switch,
}

impl Recording {
    /// `what` labels the progress bar; None shows none (a campaign's cells). `output` says
    /// which files, in which format, and how decimated.
    fn new(
        scenario: &Scenario,
        output: &platoon_config::OutputConfig,
        dir: &RunDir,
        what: Option<&str>,
    ) -> Result<Self> {
        let steps = scenario.steps + 1;
        let format = platoon_output::tables::Format::of(output, scenario);
        let on = |f: &str| output.files.iter().any(|x| x == f);
        Ok(Self {
            trajectories: platoon_output::tables::Table::create(
                dir,
                "trajectories",
                format,
                on("trajectories"),
            )?,
            events: platoon_output::tables::Table::create(dir, "events", format, on("events"))?,
            wire: platoon_output::tables::Table::create(dir, "wire", format, on("wire"))?,
            decimate: output.decimate,
            last: vec![None; scenario.vehicles()],
            modes: vec![platoon_control::Mode::Coop; scenario.vehicles()],
            per_platoon: scenario.vehicles_per_platoon(),
            dt: scenario.dt(),
            // Platoon 0's rows for the plots; grown as needed past a million steps.
            rows: Vec::with_capacity(steps.min(1 << 20) as usize * scenario.vehicles_per_platoon()),
            metrics: platoon_sim::FleetMetrics::new(scenario),
            failure: None,
            bar: what.map_or_else(indicatif::ProgressBar::hidden, |w| progress_bar(steps, w)),
        })
    }

    fn push(&mut self, step: &[StepRow], wire: platoon_sim::StepWire<'_>) {
        if self.failure.is_none() {
            if let Err(e) = self.write(step, wire) {
                self.failure = Some(e);
            }
        }
        self.metrics.push_wire(wire);
        self.metrics.push(step);
        self.rows.extend(step.iter().take_while(|r| r.platoon == 0));
        if step[0].step.is_multiple_of(1000) {
            self.bar.set_position(step[0].step);
        }
    }

    /// Writes one step's rows: trajectories (every `decimate`-th step), broadcasts, and the
    /// vehicles whose links were not all delivered as sent.
    fn write(&mut self, step: &[StepRow], wire: platoon_sim::StepWire<'_>) -> Result<()> {
        let k = step[0].step;
        for (i, counts) in wire.per_vehicle.iter().enumerate() {
            if counts.is_eventful() {
                self.wire.write(WireRow {
                    step: k,
                    t: step[0].t,
                    platoon: (i / self.per_platoon) as u16,
                    vehicle: (i % self.per_platoon) as u16,
                    sent: counts.sent,
                    delivered_as_sent: counts.delivered_as_sent,
                    altered: counts.altered,
                    dropped: counts.dropped,
                    injected: counts.injected,
                    jammed: counts.jammed,
                })?;
            }
        }
        let keep = k.is_multiple_of(self.decimate);
        for r in step {
            if keep {
                self.trajectories.write(*r)?;
            }
            if r.vehicle == 0 {
                continue;
            }
            let v = usize::from(r.platoon) * self.per_platoon + usize::from(r.vehicle);
            let row = |event, inter_event_s| EventRow {
                platoon: r.platoon,
                vehicle: r.vehicle,
                step: r.step,
                t: r.t,
                event,
                mode: r.mode,
                inter_event_s,
                under_attack: r.under_attack,
            };
            if r.mode != self.modes[v] {
                self.modes[v] = r.mode;
                self.events.write(row(Event::Switch, None))?;
            }
            if r.triggered {
                let prev = &mut self.last[v];
                let inter = prev.map(|p| (r.step - p) as f64 * self.dt);
                self.events.write(row(Event::Broadcast, inter))?;
                *prev = Some(r.step);
            }
        }
        Ok(())
    }

    fn finish(self, rejected: platoon_control::RejectCounts) -> Result<(Vec<StepRow>, Summary)> {
        self.bar.finish_and_clear();
        if let Some(e) = self.failure {
            return Err(e);
        }
        self.trajectories.finish()?;
        self.events.finish()?;
        self.wire.finish()?;
        Ok((self.rows, self.metrics.finish(rejected)))
    }
}

/// Runs the scenario in process with a progress bar and streams trajectories.csv; returns the
/// rows and summary.
pub fn simulate(
    scenario: &Scenario,
    dir: &RunDir,
    progress: bool,
) -> Result<(Vec<StepRow>, Summary)> {
    simulate_until(scenario, &Default::default(), dir, progress, None)
}

/// [`simulate`], stopping after the step at which `stop` is seen set (the summary then says
/// `complete: false`).
pub fn simulate_until(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
    progress: bool,
    stop: Option<&std::sync::atomic::AtomicBool>,
) -> Result<(Vec<StepRow>, Summary)> {
    let mut rec = Recording::new(scenario, output, dir, progress.then_some("simulating"))?;
    let mut sim = platoon_sim::FleetSimulation::new(scenario)?;
    let format = platoon_output::tables::Format::of(output, scenario);
    let mut log = platoon_output::tables::Table::create(
        dir,
        "channel",
        format,
        output.files.iter().any(|f| f == "channel"),
    )?;
    let mut step_ns = Vec::with_capacity(scenario.steps.min(1 << 20) as usize + 1);
    while !sim.is_done() {
        if stop.is_some_and(|s| s.load(std::sync::atomic::Ordering::SeqCst)) {
            break;
        }
        let started = Instant::now();
        sim.step();
        step_ns.push(started.elapsed().as_nanos() as u64);
        rec.push(sim.rows(), sim.wire());
        for e in sim.channel_log() {
            log.write(*e)?;
        }
    }
    log.finish()?;
    let rejected = sim.rejected();
    // In process a step has no stages: only its compute time.
    let timing = platoon_runtime::timing::Timing {
        step: platoon_runtime::timing::Stats::of(&mut step_ns),
        controller_tx: None,
        injector: None,
        controller_rx: None,
        plant: None,
    };
    let finished = rec.finish(rejected)?;
    let mut timing = serde_json::to_value(&timing)?;
    timing["peak_rss_mib"] = peak_rss_mib(&[]);
    dir.write(
        "timing.json",
        (serde_json::to_string_pretty(&timing)? + "\n").as_bytes(),
    )?;
    Ok(finished)
}

/// `timing.json`'s `peak_rss_mib`: the peak resident memory of `platoon run` itself (which
/// records and writes the outputs) and of each node process.
fn peak_rss_mib(nodes: &[(&str, u64)]) -> serde_json::Value {
    let mib = |kib: u64| (kib as f64 / 1024.0 * 10.0).round() / 10.0;
    let mut m = serde_json::Map::new();
    if let Some(own) = platoon_runtime::peak_rss_kib(None) {
        m.insert("platoon_run".into(), mib(own).into());
    }
    for (node, kib) in nodes {
        m.insert((*node).into(), mib(*kib).into());
    }
    m.into()
}

/// Runs the scenario across processes over iceoryx2. A failed run still returns what it
/// recorded, with the summary marked incomplete, and the error.
fn cosimulate(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
    args: &Args,
    plant: Option<crate::sumo::SumoPlant>,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<(Vec<StepRow>, Summary, Option<platoon_runtime::RunError>)> {
    let logs = dir.path("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let injector = match &args.injector {
        Some(cmd) => platoon_runtime::Program::Shell(cmd.clone()),
        None => platoon_runtime::Program::Builtin,
    };
    let (plant, env) = match plant {
        Some(p) => (p.program, p.env),
        None => (platoon_runtime::Program::Builtin, Vec::new()),
    };
    let run_id = platoon_runtime::new_run_id();
    write_run_json(dir, &run_id, scenario, args.observers)?;
    eprintln!(
        "run id {run_id}; observers: {} (docs/observer-contract.md)",
        dir.path("run.json").display()
    );
    let opts = platoon_runtime::Options {
        run_id,
        exe: std::env::current_exe().context("locating the platoon binary")?,
        config: std::path::absolute(dir.path("config.toml"))
            .context("resolving the run directory")?,
        channel_log: ((injector == platoon_runtime::Program::Builtin
            || args.injector_mode == InjectorMode::After)
            && output.files.iter().any(|f| f == "channel"))
        .then(|| dir.path("channel.csv")),
        injector,
        plant,
        env,
        log_dir: Some(logs),
        step_timeout: std::time::Duration::from_secs_f64(args.step_timeout),
        ready_timeout: std::time::Duration::from_secs(60),
        stop: Some(stop),
        observers: args.observers,
        cpus: args.cpus.clone().map(|c| c.0).unwrap_or_default(),
        channel_first: args.injector.is_some() && args.injector_mode == InjectorMode::After,
    };
    let mut rec = Recording::new(scenario, output, dir, Some("co-simulating"))?;
    let result = platoon_runtime::orchestrate(&opts, scenario, |rows, wire| rec.push(rows, wire));
    match result {
        Ok(outcome) => {
            let (rows, summary) = rec.finish(outcome.rejected)?;
            channel_log_format(scenario, output, dir)?;
            let mut timing = serde_json::to_value(&outcome.timing)?;
            timing["duplicate_samples"] = serde_json::to_value(outcome.duplicates)?;
            timing["peak_rss_mib"] = peak_rss_mib(&outcome.peak_rss_kib);
            let json = serde_json::to_string_pretty(&timing)? + "\n";
            dir.write("timing.json", json.as_bytes())?;
            if outcome.duplicates.total() > 0 {
                eprintln!(
                    "warning: {} samples repeated a step already published (states {}, tx {}, rx {}, commands {}); they were dropped, but they slow the run (timing.json counts them)",
                    outcome.duplicates.total(),
                    outcome.duplicates.states,
                    outcome.duplicates.tx,
                    outcome.duplicates.rx,
                    outcome.duplicates.commands
                );
            }
            Ok((rows, summary, None))
        }
        Err(e) => {
            let (rows, mut summary) = rec.finish(Default::default())?;
            summary.complete = false;
            summary.error = Some(e.to_string());
            Ok((rows, summary, Some(e)))
        }
    }
}

/// The injector node writes its channel log as CSV; with Parquet output it is converted, row
/// by row (memory stays flat), and the CSV removed.
fn channel_log_format(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
) -> Result<()> {
    let format = platoon_output::tables::Format::of(output, scenario);
    let csv_path = dir.path("channel.csv");
    if format != platoon_output::tables::Format::Parquet || !csv_path.exists() {
        return Ok(());
    }
    let mut table = platoon_output::tables::Table::create(dir, "channel", format, true)?;
    let mut reader = csv::Reader::from_path(&csv_path)
        .with_context(|| format!("reading {}", csv_path.display()))?;
    for row in reader.deserialize::<platoon_attacks::channel::ChannelEvent>() {
        table.write(row.with_context(|| format!("reading {}", csv_path.display()))?)?;
    }
    table.finish()?;
    std::fs::remove_file(&csv_path).with_context(|| format!("removing {}", csv_path.display()))
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
    dir.write(
        "run.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )
}

/// Writes config.toml (if not yet there), the plots (of platoon 0's `rows`), and summary.json
/// last.
pub fn write_outputs(
    dir: &RunDir,
    config: &Config,
    scenario: &Scenario,
    rows: &[StepRow],
    summary: &Summary,
    plots: bool,
    extra: &[(&str, serde_json::Value)],
) -> Result<()> {
    if !dir.path("config.toml").exists() {
        dir.write("config.toml", platoon_config::to_toml(config).as_bytes())?;
    }
    if plots {
        for (name, draw) in [
            (
                "fig6.png",
                plots::fig6 as fn(&Path, &Scenario, &[StepRow]) -> Result<()>,
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
        if rows
            .iter()
            .any(|r| r.mode != platoon_control::Mode::Coop || r.guard)
        {
            let path = dir.path("modes.png");
            plots::modes(&path, scenario, rows)
                .with_context(|| format!("drawing {}", path.display()))?;
        }
    }
    let mut json = serde_json::to_value(summary)?;
    for (key, value) in extra {
        json[*key] = value.clone();
    }
    let json = serde_json::to_string_pretty(&json)? + "\n";
    dir.write("summary.json", json.as_bytes())
}

fn print_summary(s: &Summary, compute_s: f64) {
    println!(
        "{} steps of {} s (t = 0 to {} s, rule {}) in {:.1} ms",
        s.steps,
        s.dt_s,
        s.duration_s,
        s.rule,
        compute_s * 1e3
    );
    for v in &s.vehicles {
        println!(
            "  follower {}: {:>5} broadcasts, spacing error mean {:.3} m, max {:.3} m, final {:.4} m",
            v.vehicle, v.triggers, v.spacing_error_m.mean_abs, v.spacing_error_m.max_abs, v.spacing_error_m.final_abs
        );
    }
    let a = &s.attack;
    let verdict = match &a.assumption2 {
        Some(r) if r.holds => "satisfies Assumption 2",
        Some(_) => "VIOLATES Assumption 2",
        None => "no Assumption-2 bounds given",
    };
    if a.applied {
        println!(
            "  DoS: {} attacks, {:.2} s jammed, {verdict}",
            a.intervals, a.attacked_time_s
        );
    } else {
        println!(
            "  DoS: the config's {} attacks were not applied (--injector-mode replace); what the injector did is in wire.csv",
            a.intervals
        );
    }
    if let Some(f) = &s.fleet {
        println!(
            "  fleet: {} platoons, {} vehicles, {} broadcasts, smallest gap {:.2} m, largest deceleration {:.2} m/s^2, class {}{}",
            f.platoons,
            f.vehicles,
            f.triggers_total,
            f.min_gap_m,
            f.max_deceleration_mps2,
            f.class,
            if f.collided { ", COLLISION" } else { "" }
        );
        println!(
            "  (the lines above are platoon 0's; summary.json has every platoon under \"fleet\")"
        );
    }
    println!(
        "  safety: {} (smallest gap {:.2} m, follower {} at {:.2} s)",
        if s.safety.collided {
            "COLLISION"
        } else {
            "no collision"
        },
        s.safety.min_gap_m,
        s.safety.min_gap_vehicle,
        s.safety.min_gap_t_s
    );
    // Degradation, when anything but the cooperative law ran.
    let mut modes = std::collections::BTreeMap::<&str, f64>::new();
    for v in &s.vehicles {
        for (m, t) in &v.mode_time_s {
            *modes.entry(m.as_str()).or_default() += t;
        }
    }
    let guard: u64 = s.vehicles.iter().map(|v| v.guard_activations).sum();
    if modes.keys().any(|m| *m != "coop") || guard > 0 {
        let total: f64 = modes.values().sum();
        let shares: Vec<String> = modes
            .iter()
            .map(|(m, t)| format!("{m} {:.1} %", 100.0 * t / total.max(f64::MIN_POSITIVE)))
            .collect();
        println!(
            "  modes (all followers): {}; {} mode switches; guard braked {} times; smallest TTC {}",
            shares.join(", "),
            s.vehicles.iter().map(|v| v.mode_switches).sum::<u64>(),
            guard,
            s.safety
                .min_ttc_s
                .map_or("-".to_string(), |t| format!("{t:.2} s"))
        );
    }
}
