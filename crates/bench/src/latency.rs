//! `platoon bench latency`: one V2V hop through the injector against raw iceoryx2, UDP and
//! Unix-socket hops measured side by side, and the step overhead over in-process.
use anyhow::{bail, Context, Result};
use platoon_runtime::timing::Stats;
use platoon_sim::FleetSimulation;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use crate::machine::{cores, describe_halt_poll, guest_halt_poll_ns};

/// What `platoon bench latency` measures.
#[derive(Debug, Clone)]
pub struct Latency {
    /// Scenario config (TOML); None: the embedded configs/paper.toml.
    pub config: Option<PathBuf>,
    /// Measured ping-pongs per method.
    pub iterations: usize,
    /// Ping-pongs before measuring.
    pub warmup: usize,
    /// Also measure busy-polling iceoryx2.
    pub busy_poll: bool,
    /// Output directory; None: runs/bench-latency.
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    pub force: bool,
}

impl Default for Latency {
    fn default() -> Self {
        Self {
            config: None,
            iterations: 20_000,
            warmup: 2_000,
            busy_poll: false,
            out: None,
            force: false,
        }
    }
}

/// One measured quantity (a row of latency.csv and of latency.json's `rows`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Row {
    pub quantity: String,
    #[serde(flatten)]
    pub stats: Stats,
    pub over_raw_p50: Option<f64>,
}

impl Row {
    /// p50, p90, p99, p99.9 and max (µs), and the ratio to the raw hop's p50 ("" without one).
    pub(crate) fn figures(&self) -> ([f64; 5], String) {
        let over = self
            .over_raw_p50
            .map_or(String::new(), |x| format!("{x:.2}"));
        let s = &self.stats;
        ([s.p50_us, s.p90_us, s.p99_us, s.p999_us, s.max_us], over)
    }

    /// Writes it as a record of `csv`, the header (its fields, flat) before the first: the csv
    /// crate writes a tuple of structs flat where it refuses a flattened field.
    fn write_csv<W: std::io::Write>(&self, csv: &mut csv::Writer<W>) -> csv::Result<()> {
        #[derive(serde::Serialize)]
        struct Quantity<'a> {
            quantity: &'a str,
        }
        #[derive(serde::Serialize)]
        struct Over {
            over_raw_p50: Option<f64>,
        }
        csv.serialize((
            Quantity {
                quantity: &self.quantity,
            },
            self.stats,
            Over {
                over_raw_p50: self.over_raw_p50,
            },
        ))
    }
}

/// The row of `quantity`; no samples is an error (the benchmark measures every row or fails).
fn row(quantity: &str, s: Option<Stats>) -> Result<Row> {
    let stats = s.with_context(|| format!("{quantity}: no samples were recorded"))?;
    Ok(Row {
        quantity: quantity.into(),
        stats,
        over_raw_p50: None,
    })
}

#[derive(serde::Serialize)]
pub struct LatencyReport {
    pub machine_cores: usize,
    pub scenario: String,
    pub vehicles: usize,
    pub batch_items: usize,
    pub rows: Vec<Row>,
    pub injector_hop_over_raw_hop_p50: f64,
    /// The Python SDK's injector hop over the built-in (Rust SDK) one, p50, measured in the
    /// same session, the nodes on any CPU.
    pub python_sdk_over_builtin_injector_p50: f64,
    /// The same with every node of both runs on one core (the SDK's own cost, without
    /// cross-core wake-ups).
    pub python_sdk_over_builtin_injector_p50_one_core: f64,
    pub step_overhead_p50_us: f64,
    /// The same with the nodes on one core.
    pub step_overhead_p50_us_one_core: f64,
    /// `guest_halt_poll_ns` as read during the run (how long an idle vCPU polls before it
    /// halts), or None where it is not readable.
    pub guest_halt_poll_ns: Option<String>,
}

/// Runs `f` with this process (and what it starts) on its first CPU, then restores its set.
fn on_one_core<T>(f: impl FnOnce() -> T) -> Result<T> {
    let size = std::mem::size_of::<libc::cpu_set_t>();
    // SAFETY: cpu_set_t is plain data, filled in and read by the affinity calls of this
    // process.
    let mut home: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    if unsafe { libc::sched_getaffinity(0, size, &mut home) } != 0 {
        bail!(
            "reading this process's CPU set: {}",
            std::io::Error::last_os_error()
        );
    }
    let first = platoon_runtime::available_cpus()
        .first()
        .copied()
        .context("this process may run on no CPU")?;
    let mut one: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    unsafe { libc::CPU_SET(first, &mut one) };
    if unsafe { libc::sched_setaffinity(0, size, &one) } != 0 {
        bail!("moving to CPU {first}: {}", std::io::Error::last_os_error());
    }
    let out = f();
    unsafe { libc::sched_setaffinity(0, size, &home) };
    Ok(out)
}

/// Runs `platoon bench latency`.
pub fn latency(a: Latency) -> Result<LatencyReport> {
    if a.iterations == 0 {
        bail!("--iterations must be at least 1");
    }
    let platoon_config::Loaded {
        config,
        scenario,
        stem,
    } = platoon_config::load_or(a.config.as_deref(), platoon_config::Embedded::Paper)?;
    let dir = crate::create_out(a.out.clone(), "bench-latency", a.force)?;
    dir.write("config.toml", platoon_config::to_toml(&config).as_bytes())?;
    let exe = platoon_app::platoon_program()?;
    let n = scenario.topology.followers();
    let hearing = scenario.hearing();
    let items: usize = (0..=n)
        .map(|v| {
            hearing
                .out_neighbours(platoon_model::VehicleId(v as u16))
                .len()
        })
        .sum();
    let bytes = items * std::mem::size_of::<platoon_wire::LinkPacket>();
    let bar = indicatif::ProgressBar::new(5);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {msg} [{elapsed}] {wide_bar} {pos}/{len}",
        )
        .expect("static template"),
    );
    let samples = hops(&a, &exe, items, bytes, &bar)?;

    let Cosims {
        builtin,
        builtin_one_core,
        python_sdk,
        python_sdk_one_core,
    } = cosims(&dir, &exe, &scenario, &stem, &bar)?;
    let mut inproc = inproc_steps(&scenario)?;
    bar.finish_and_clear();

    // Every row is required: a quantity with no samples fails the benchmark, by name.
    let mut rows: Vec<Row> = samples
        .iter()
        .map(|(name, v)| row(name, Stats::of(&mut v.clone())))
        .collect::<Result<_>>()?;
    let t = builtin;
    rows.extend(
        [
            row("injector_hop", t.injector),
            row("injector_hop_python_sdk", python_sdk),
            row("injector_hop_one_core", builtin_one_core.injector),
            row("injector_hop_python_sdk_one_core", python_sdk_one_core),
            row("cosim_step", t.step),
            row("cosim_step_one_core", builtin_one_core.step),
            row("inproc_step", Stats::of(&mut inproc)),
            row("stage_controller_tx", t.controller_tx),
            row("stage_controller_rx", t.controller_rx),
            row("stage_plant", t.plant),
        ]
        .into_iter()
        .collect::<Result<Vec<_>>>()?,
    );
    let raw_p50 = rows[0].stats.p50_us;
    for r in &mut rows {
        if r.quantity.ends_with("hop") || r.quantity.contains("hop_") {
            r.over_raw_p50 = Some(r.stats.p50_us / raw_p50);
        }
    }
    let p50 = |q: &str| {
        rows.iter()
            .find(|r| r.quantity == q)
            .map(|r| r.stats.p50_us)
            .expect("every row is measured")
    };
    let report = LatencyReport {
        machine_cores: cores(),
        scenario: stem.clone(),
        vehicles: n + 1,
        batch_items: items,
        injector_hop_over_raw_hop_p50: p50("injector_hop") / p50("raw_iceoryx2_hop"),
        python_sdk_over_builtin_injector_p50: p50("injector_hop_python_sdk") / p50("injector_hop"),
        python_sdk_over_builtin_injector_p50_one_core: p50("injector_hop_python_sdk_one_core")
            / p50("injector_hop_one_core"),
        step_overhead_p50_us: p50("cosim_step") - p50("inproc_step"),
        step_overhead_p50_us_one_core: p50("cosim_step_one_core") - p50("inproc_step"),
        guest_halt_poll_ns: guest_halt_poll_ns(),
        rows,
    };
    write_files(&dir, &report, &samples)?;
    let path = dir.commit()?;

    print_report(&report);
    println!("outputs: {}", path.display());
    Ok(report)
}

/// The hops the co-simulation's are set against, each `a.iterations` ping-pongs of a batch of
/// `items` link packets (`bytes` bytes) with another process: the raw iceoryx2 hop (and, with
/// `a.busy_poll`, its busy-polling form), the UDP and Unix-socket hops, and the raw and
/// Unix-socket hops again with both processes on one core. Four steps of `bar`.
fn hops(
    a: &Latency,
    exe: &std::path::Path,
    items: usize,
    bytes: usize,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<(&'static str, Vec<u64>)>> {
    let mut samples: Vec<(&'static str, Vec<u64>)> = Vec::new();

    let raw_hop = |busy_poll: bool| {
        platoon_runtime::bench::raw_hop(
            &platoon_runtime::new_run_id(),
            exe,
            a.iterations,
            a.warmup,
            items,
            busy_poll,
        )
    };
    bar.set_message("raw iceoryx2 hop");
    let raw = raw_hop(false).context("raw iceoryx2 hop")?;
    samples.push(("raw_iceoryx2_hop", raw));
    bar.inc(1);
    if a.busy_poll {
        if cores() < 2 {
            eprintln!(
                "warning: {} core(s) for 2 busy-polling processes: the figure will collapse",
                cores()
            );
        }
        bar.set_message("busy-polling iceoryx2 hop");
        let busy = raw_hop(true).context("busy-polling iceoryx2 hop")?;
        samples.push(("raw_iceoryx2_hop_busy_poll", busy));
    }
    bar.inc(1);
    for socket in [
        platoon_runtime::bench::Socket::Udp,
        platoon_runtime::bench::Socket::Uds,
    ] {
        bar.set_message(format!("{} hop", socket.name()));
        let name = match socket {
            platoon_runtime::bench::Socket::Udp => "udp_loopback_hop",
            platoon_runtime::bench::Socket::Uds => "unix_socket_hop",
        };
        // A baseline that cannot run fails the benchmark: the report compares side by side.
        let h = platoon_runtime::bench::socket_hop(socket, exe, a.iterations, a.warmup, bytes)
            .with_context(|| {
                format!(
                    "the {name} baseline (a ping-pong with `platoon node echo-{}` in another \
                     process) failed; fix it before benchmarking",
                    socket.name()
                )
            })?;
        samples.push((name, h));
        bar.inc(1);
    }
    // The two baselines again with both processes on one core (this process's CPU set, which
    // the echo inherits), so the one-core rows of the co-simulation compare like with like.
    bar.set_message("raw iceoryx2 and Unix-socket hops on one core");
    let (raw_one, uds_one) = on_one_core(|| -> Result<_> {
        let raw = raw_hop(false).context("raw iceoryx2 hop on one core")?;
        let uds = platoon_runtime::bench::socket_hop(
            platoon_runtime::bench::Socket::Uds,
            exe,
            a.iterations,
            a.warmup,
            bytes,
        )
        .context("the Unix-socket hop on one core")?;
        Ok((raw, uds))
    })??;
    samples.push(("raw_iceoryx2_hop_one_core", raw_one));
    samples.push(("unix_socket_hop_one_core", uds_one));
    Ok(samples)
}

/// latency.csv (the rows), latency-samples.csv (every hop's time), latency.png and
/// latency.json (the report) in `dir`.
fn write_files(
    dir: &platoon_output::rundir::RunDir,
    report: &LatencyReport,
    samples: &[(&str, Vec<u64>)],
) -> Result<()> {
    let mut csv = csv::Writer::from_writer(dir.writer("latency.csv")?);
    for r in &report.rows {
        r.write_csv(&mut csv)?;
    }
    csv.flush()?;
    let mut raw_csv = csv::Writer::from_writer(dir.writer("latency-samples.csv")?);
    raw_csv.write_record(["method", "hop_ns"])?;
    for (name, v) in samples {
        for x in v {
            raw_csv.write_record([name.to_string(), x.to_string()])?;
        }
    }
    raw_csv.flush()?;
    platoon_output::plots::histograms(&dir.path("latency.png"), samples)?;
    dir.write(
        "latency.json",
        (serde_json::to_string_pretty(report)? + "\n").as_bytes(),
    )?;
    Ok(())
}

/// The co-simulations `latency` times: the built-in injector, then with the nodes on one core,
/// and the Python SDK's dos_jammer as the injector, both ways.
struct Cosims {
    builtin: platoon_runtime::timing::Timing,
    builtin_one_core: platoon_runtime::timing::Timing,
    python_sdk: Option<Stats>,
    python_sdk_one_core: Option<Stats>,
}

/// Runs [`Cosims`]' co-simulations of `scenario` (`stem`) with the binary `exe`, their facts
/// and logs in `dir`, saying which on `bar`.
fn cosims(
    dir: &platoon_output::rundir::RunDir,
    exe: &std::path::Path,
    scenario: &platoon_sim::Scenario,
    stem: &str,
    bar: &indicatif::ProgressBar,
) -> Result<Cosims> {
    bar.set_message(format!("co-simulating {stem} over iceoryx2"));
    let logs = dir.path("logs");
    std::fs::create_dir_all(&logs)?;
    // Every run names its facts (`PLATOON_RUN_FACTS`) as `platoon run` does: the Python SDK
    // injector refuses to start without them. The runs go one after another, so each rewrites
    // the one facts.json with its own run id.
    let facts = |run_id: &str| -> Result<std::path::PathBuf> {
        let f = platoon_runtime::plugin::RunFacts::of(
            run_id,
            scenario,
            platoon_config::PlantKind::Native,
        );
        dir.write(
            platoon_runtime::plugin::RUN_FACTS_FILE,
            &serde_json::to_vec_pretty(&f)?,
        )?;
        Ok(std::path::absolute(
            dir.path(platoon_runtime::plugin::RUN_FACTS_FILE),
        )?)
    };
    let run_id = platoon_runtime::new_run_id();
    let opts = platoon_runtime::Options {
        facts: Some(facts(&run_id)?),
        run_id,
        exe: exe.to_path_buf(),
        config: std::path::absolute(dir.path("config.toml"))?,
        injector: platoon_runtime::Program::Builtin,
        controller: platoon_runtime::Program::Builtin,
        plant: platoon_runtime::Program::Builtin,
        traffic: 0,
        radar: false,
        env: Vec::new(),
        channel_log: None,
        log_dir: Some(logs),
        python_path: None,
        step_timeout: Duration::from_secs(5),
        ready_timeout: Duration::from_secs(60),
        stop: None,
        observers: 0,
        channel_first: false,
        cpus: Vec::new(),
    };
    let outcome = platoon_runtime::orchestrate(&opts, scenario, |_, _, _| {})
        .context("the iceoryx2 co-simulation")?;
    // The same run with the Python SDK's dos_jammer as the injector (the built-in one is
    // written on the Rust SDK, so its stage is the Rust SDK's), and both again with the nodes
    // on one core: a step is a chain of wake-ups, and waking a process on another core can
    // cost more than the work (VMs that halt idle cores), which is not the SDK's cost.
    let one_core = platoon_runtime::available_cpus()
        .first()
        .map_or_else(Vec::new, |&c| vec![c]);
    let cosim = |injector: platoon_runtime::Program, cpus: &[usize]| {
        let run_id = platoon_runtime::new_run_id();
        let opts = platoon_runtime::Options {
            facts: Some(facts(&run_id)?),
            run_id,
            injector,
            log_dir: None,
            cpus: cpus.to_vec(),
            ..opts.clone()
        };
        Ok::<_, anyhow::Error>(platoon_runtime::orchestrate(&opts, scenario, |_, _, _| {})?.timing)
    };
    bar.set_message("co-simulating with the nodes on one core");
    let builtin_one_core = cosim(platoon_runtime::Program::Builtin, &one_core)
        .context("the iceoryx2 co-simulation on one core")?;
    bar.set_message("co-simulating with the Python SDK injector");
    // The Python rows are part of the report: if they cannot be measured, the benchmark fails.
    let python = platoon_app::sumo::ensure_venv().context(
        "the Python SDK injector needs the bridge's Python environment (bridge/setup-venv.sh)",
    )?;
    let script = platoon_app::sumo::bridge_dir()?.join("examples/dos_jammer.py");
    let program = platoon_runtime::Program::Exec {
        program: python.clone(),
        args: vec![script.display().to_string()],
    };
    // Names what failed and how to reproduce it outside the benchmark.
    let failed = |what: &str| {
        format!(
            "the iceoryx2 co-simulation{what} with the Python SDK injector failed; reproduce \
             and fix it with `platoon run --injector \"{} {}\"`{}",
            python.display(),
            script.display(),
            if what.is_empty() { "" } else { " --cpus N" }
        )
    };
    let python_sdk = cosim(program.clone(), &[])
        .with_context(|| failed(""))?
        .injector;
    let python_sdk_one_core = cosim(program, &one_core)
        .with_context(|| failed(" on one core"))?
        .injector;
    Ok(Cosims {
        builtin: outcome.timing,
        builtin_one_core,
        python_sdk,
        python_sdk_one_core,
    })
}

/// Each step's time (ns) of `scenario` run in process.
fn inproc_steps(scenario: &platoon_sim::Scenario) -> Result<Vec<u64>> {
    let mut sim = FleetSimulation::new(scenario)?;
    let mut inproc = Vec::with_capacity(scenario.steps as usize + 1);
    while !sim.is_done() {
        let t = Instant::now();
        std::hint::black_box(sim.step());
        inproc.push(t.elapsed().as_nanos() as u64);
    }
    Ok(inproc)
}

/// The rows and the ratios against their targets, on stdout.
fn print_report(report: &LatencyReport) {
    println!(
        "{:<28} {:>7} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
        "µs", "n", "p50", "p90", "p99", "p99.9", "max", "x raw"
    );
    for r in &report.rows {
        let ([p50, p90, p99, p999, max], over) = r.figures();
        println!(
            "{:<28} {:>7} {p50:>8.2} {p90:>8.2} {p99:>8.2} {p999:>8.2} {max:>9.2} {over:>8}",
            r.quantity, r.stats.n
        );
    }
    println!(
        "injector hop / raw iceoryx2 hop (p50): {:.2} (target < 2)",
        report.injector_hop_over_raw_hop_p50
    );
    println!(
        "co-simulation step overhead over in-process (p50): {:.1} µs (target < 60 µs); nodes on one core: {:.1} µs",
        report.step_overhead_p50_us, report.step_overhead_p50_us_one_core
    );
    println!(
        "Python SDK injector hop / built-in (Rust SDK) injector hop (p50): {:.2} (target <= 2); \
         nodes on one core (--cpus): {:.2}",
        report.python_sdk_over_builtin_injector_p50,
        report.python_sdk_over_builtin_injector_p50_one_core
    );
    println!(
        "{}",
        describe_halt_poll(report.guest_halt_poll_ns.as_deref())
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// latency.csv and latency.json hold a row's fields flat, in the same order.
    #[test]
    fn a_row_is_flat_in_csv_and_json() {
        let mut ns = [1_000, 2_000, 4_000];
        let mut r = row("raw_iceoryx2_hop", Stats::of(&mut ns)).unwrap();
        r.over_raw_p50 = Some(1.0);
        let mut csv = csv::Writer::from_writer(Vec::new());
        r.write_csv(&mut csv).unwrap();
        r.over_raw_p50 = None;
        r.write_csv(&mut csv).unwrap();
        let text = String::from_utf8(csv.into_inner().unwrap()).unwrap();
        assert_eq!(
            text,
            "quantity,n,p50_us,p90_us,p99_us,p999_us,max_us,over_raw_p50\n\
             raw_iceoryx2_hop,3,2.0,4.0,4.0,4.0,4.0,1.0\n\
             raw_iceoryx2_hop,3,2.0,4.0,4.0,4.0,4.0,\n"
        );
        assert_eq!(
            serde_json::to_string(&r).unwrap(),
            r#"{"quantity":"raw_iceoryx2_hop","n":3,"p50_us":2.0,"p90_us":4.0,"p99_us":4.0,"p999_us":4.0,"max_us":4.0,"over_raw_p50":null}"#
        );
    }
}
