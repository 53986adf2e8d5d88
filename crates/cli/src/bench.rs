//! `platoon bench`: what the co-simulation costs on this machine, measured side by side in one
//! run (medians and ratios; the machines are shared and noisy, so never absolute thresholds).
use crate::output::RunDir;
use anyhow::{bail, Context, Result};
use platoon_runtime::timing::{Stats, Timing};
use platoon_sim::Simulation;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Benchmarks.
#[derive(Debug, clap::Subcommand)]
pub enum Bench {
    /// The V2V hop through the injector against a raw iceoryx2 hop, and the step overhead of
    /// the iceoryx2 co-simulation against the in-process runner.
    ///
    /// Method: a ping-pong between this process and an echo process over the same services,
    /// payload (the scenario's largest tx batch) and event-driven waits as a co-simulation,
    /// after a warm-up; the hop is publish-to-publish (CLOCK_MONOTONIC stamps in the sample
    /// headers), exactly as the co-simulation's injector stage is measured. Then the scenario
    /// runs over iceoryx2 (stage timings from the same stamps) and in process (each step timed).
    /// Writes latency.csv (one row per measured quantity: p50, p90, p99, max in µs) and
    /// latency.json into the output directory.
    Latency(LatencyArgs),
}

/// Arguments of `platoon bench latency`.
#[derive(Debug, clap::Args)]
pub struct LatencyArgs {
    /// Scenario config (TOML) [default: the embedded configs/paper.toml].
    pub config: Option<PathBuf>,
    /// Measured ping-pongs of the raw hop.
    #[arg(long, default_value_t = 20_000)]
    pub iterations: usize,
    /// Ping-pongs before measuring.
    #[arg(long, default_value_t = 2_000)]
    pub warmup: usize,
    /// Output directory [default: runs/bench-latency].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

pub fn run(b: Bench) -> Result<()> {
    match b {
        Bench::Latency(a) => latency(a),
    }
}

#[derive(serde::Serialize)]
struct Row {
    quantity: &'static str,
    n: usize,
    p50_us: f64,
    p90_us: f64,
    p99_us: f64,
    max_us: f64,
}

fn row(quantity: &'static str, s: Option<Stats>) -> Option<Row> {
    s.map(|s| Row {
        quantity,
        n: s.n,
        p50_us: s.p50_us,
        p90_us: s.p90_us,
        p99_us: s.p99_us,
        max_us: s.max_us,
    })
}

#[derive(serde::Serialize)]
struct Report<'a> {
    machine_cores: usize,
    scenario: &'a str,
    vehicles: usize,
    batch_items: usize,
    rows: &'a [Row],
    injector_hop_over_raw_hop_p50: f64,
    step_overhead_p50_us: f64,
}

fn latency(a: LatencyArgs) -> Result<()> {
    if a.iterations == 0 {
        bail!("--iterations must be at least 1");
    }
    let (config, scenario, stem) =
        crate::run::load(a.config.as_deref(), platoon_config::PAPER_TOML, "paper")?;
    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("bench-latency"));
    let dir = RunDir::create(&out, a.force)?;
    dir.write("config.toml", platoon_config::to_toml(&config).as_bytes())?;
    let exe = std::env::current_exe().context("locating the platoon binary")?;
    let n = scenario.topology.followers();
    let items: usize = (0..=n)
        .map(|v| {
            scenario
                .topology
                .out_neighbours(platoon_model::VehicleId(v as u16))
                .len()
        })
        .sum();

    eprintln!(
        "raw iceoryx2 hop: {} ping-pongs of {items} link packets (+{} warm-up) ...",
        a.iterations, a.warmup
    );
    let mut raw = platoon_runtime::bench::raw_hop(
        &platoon_runtime::new_run_id(),
        &exe,
        a.iterations,
        a.warmup,
        items,
    )
    .context("raw iceoryx2 hop")?;

    eprintln!("co-simulating {stem} over iceoryx2 ...");
    let logs = dir.path("logs");
    std::fs::create_dir_all(&logs)?;
    let opts = platoon_runtime::Options {
        run_id: platoon_runtime::new_run_id(),
        exe: exe.clone(),
        config: std::path::absolute(dir.path("config.toml"))?,
        injector: platoon_runtime::Program::Builtin,
        plant: platoon_runtime::Program::Builtin,
        env: Vec::new(),
        channel_log: None,
        log_dir: Some(logs),
        step_timeout: Duration::from_secs(5),
        ready_timeout: Duration::from_secs(60),
    };
    let outcome = platoon_runtime::orchestrate(&opts, &scenario, |_| {})
        .context("the iceoryx2 co-simulation")?;
    let Timing {
        step,
        controller_tx,
        injector,
        controller_rx,
        plant,
    } = outcome.timing;

    eprintln!("running {stem} in process ...");
    let mut sim = Simulation::new(scenario.clone())?;
    let mut inproc = Vec::with_capacity(scenario.steps as usize + 1);
    while !sim.is_done() {
        let t = Instant::now();
        std::hint::black_box(sim.step());
        inproc.push(t.elapsed().as_nanos() as u64);
    }
    let inproc = Stats::of(&mut inproc);
    let raw = Stats::of(&mut raw);

    let rows: Vec<Row> = [
        row("raw_iceoryx2_hop", raw),
        row("injector_hop", injector),
        row("cosim_step", step),
        row("inproc_step", inproc),
        row("stage_controller_tx", controller_tx),
        row("stage_controller_rx", controller_rx),
        row("stage_plant", plant),
    ]
    .into_iter()
    .flatten()
    .collect();
    let p50 = |q: &str| {
        rows.iter()
            .find(|r| r.quantity == q)
            .map_or(f64::NAN, |r| r.p50_us)
    };
    let report = Report {
        machine_cores: std::thread::available_parallelism().map_or(0, |n| n.get()),
        scenario: &stem,
        vehicles: n + 1,
        batch_items: items,
        injector_hop_over_raw_hop_p50: p50("injector_hop") / p50("raw_iceoryx2_hop"),
        step_overhead_p50_us: p50("cosim_step") - p50("inproc_step"),
        rows: &rows,
    };
    let mut csv = csv::Writer::from_writer(dir.writer("latency.csv")?);
    for r in &rows {
        csv.serialize(r)?;
    }
    csv.flush()?;
    dir.write(
        "latency.json",
        (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;

    println!(
        "{:<22} {:>8} {:>9} {:>9} {:>9} {:>9}",
        "µs", "n", "p50", "p90", "p99", "max"
    );
    for r in &rows {
        println!(
            "{:<22} {:>8} {:>9.2} {:>9.2} {:>9.2} {:>9.2}",
            r.quantity, r.n, r.p50_us, r.p90_us, r.p99_us, r.max_us
        );
    }
    println!(
        "injector hop / raw iceoryx2 hop (p50): {:.2} (target < 2)",
        report.injector_hop_over_raw_hop_p50
    );
    println!(
        "co-simulation step overhead over in-process (p50): {:.1} µs (target < 60 µs)",
        report.step_overhead_p50_us
    );
    if report.machine_cores < 4 {
        println!(
            "note: {} cores for 4 processes; event-driven waits keep that workable, busy polling would not",
            report.machine_cores
        );
    }
    println!("outputs: {}", path.display());
    Ok(())
}
