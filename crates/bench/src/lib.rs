//! The benchmark harness behind `platoon bench`: what the co-simulation costs on this machine,
//! measured side by side in one run (medians, percentiles and ratios; the machines are shared
//! and noisy, so no absolute thresholds anywhere). `platoon bench all` runs every benchmark and
//! writes BENCHMARKS.md. The co-simulations it starts run the processes of the `platoon` binary
//! it is called from (`platoon node ...`), so it runs from that binary, not on its own.
use anyhow::{bail, Context, Result};
use platoon_output::rundir::RunDir;
use platoon_runtime::timing::Stats;
use platoon_sim::FleetSimulation;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Benchmarks.
#[derive(Debug, clap::Subcommand)]
pub enum Bench {
    /// One V2V hop through the injector against baselines measured side by side: a raw
    /// iceoryx2 publish-subscribe hop (event-driven, and busy-polling with --busy-poll), a UDP
    /// loopback hop and a Unix-domain-socket hop, each with the same payload and an echo in
    /// another process.
    ///
    /// Method (as iceoryx2's own benchmarks): ping-pong, warm-up first, then many iterations;
    /// each hop is publish-to-publish (CLOCK_MONOTONIC stamps, shared by the processes), the way
    /// the co-simulation's injector stage is timed. Then the scenario runs over iceoryx2 and in
    /// process. Writes latency.csv and latency.json (p50, p90, p99, p99.9, max in µs; ratios to
    /// the raw iceoryx2 hop), latency-samples.csv (every hop) and latency.png (histograms).
    Latency(LatencyArgs),
    /// Co-simulation step cost against the number of followers (platoons of 4 followers):
    /// in process, over iceoryx2 with the native plant, and over iceoryx2 with SUMO; by stage,
    /// with the real-time factor. Writes step.csv, step.json and step.png (cost per step
    /// against N, with the least-squares line and its slope).
    Step(StepArgs),
    /// LMI design time against the number of followers (TPSF, `design synthesize` defaults),
    /// and the time of the checks of `design check-gain` (the paper's K on PLF: the smallest
    /// ratio with a common and with a block-diagonal Lyapunov matrix, the largest-decay
    /// bisection, the closed-loop spectrum and string stability) against the number of
    /// followers. Writes design.csv and check.csv.
    Design(DesignArgs),
    /// Campaign throughput: the paper scenario with a random admissible DoS schedule per cell
    /// (`platoon campaign`, in process, metrics only, no plots), run with each --jobs value,
    /// then the same cells through a Dask cluster started on 127.0.0.1 (two single-threaded
    /// workers) beside the local pool with two jobs: in the workers' processes (batches on the
    /// platoon package's core, which bridge/.venv needs: `pip install ./bridge`), then with a
    /// `platoon campaign-cell` process per cell (PLATOON_DASK_IN_WORKER=0). Each figure is the
    /// campaign's own wall time (campaign.json), so start-up, per-cell records and cells.csv are
    /// included. Writes campaign.csv and campaign.json.
    Campaign(CampaignArgs),
    /// Worst-case DoS search throughput: `platoon search`'s search (no baselines, no figures)
    /// on the paper scenario under its Assumption 2, in process, with each --jobs value; each
    /// figure is the search's own wall time (search.json: proposing, certifying, running and
    /// measuring every candidate). Writes search.csv and search.json.
    Search(SearchArgs),
    /// Every benchmark above with its defaults, and BENCHMARKS.md (method, machine, figures).
    All(AllArgs),
}

/// Arguments of `platoon bench latency`.
#[derive(Debug, clap::Args)]
pub struct LatencyArgs {
    /// Scenario config (TOML) [default: the embedded configs/paper.toml].
    pub config: Option<PathBuf>,
    /// Measured ping-pongs per method.
    #[arg(long, default_value_t = 20_000)]
    pub iterations: usize,
    /// Ping-pongs before measuring.
    #[arg(long, default_value_t = 2_000)]
    pub warmup: usize,
    /// Also measure busy-polling iceoryx2 (burns a core per process; on 2 cores with more
    /// processes it collapses).
    #[arg(long)]
    pub busy_poll: bool,
    /// Output directory [default: runs/bench-latency].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `platoon bench step`.
#[derive(Debug, clap::Args)]
pub struct StepArgs {
    /// Numbers of followers (multiples of 4: platoons of 4 followers).
    #[arg(long, value_delimiter = ',', default_value = "4,100,1000")]
    pub followers: Vec<usize>,
    /// Transports and plants to measure: inproc, native (iceoryx2), sumo (iceoryx2 + SUMO), and
    /// native-1cpu, sumo-1cpu: the same with the nodes on one core (`platoon run --cpus`).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "inproc,native,sumo,native-1cpu,sumo-1cpu"
    )]
    pub modes: Vec<String>,
    /// Simulated seconds per case.
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// Skip the peers: after each `sumo` case, the same fleet driven by SUMO itself
    /// (`bridge/bench_peers.py`: SUMO's Krauss model, Plexe's ACC and auto-fed CACC inside
    /// SUMO's CC model, and the floor of any external driver from Python), so our step reads as
    /// a ratio to each.
    #[arg(long)]
    pub no_peers: bool,
    /// Rounds: every case (and its peers, right after it) runs this many times, the cases
    /// interleaved; the tables give the median over the rounds of each figure, and our step's
    /// ratio to a peer is the median of the rounds' ratios (this VM's speed drifts by up to 2x
    /// over minutes, which a single run cannot tell from a real difference). step.csv and
    /// peers.csv have every round's figures, step.json the medians and ratios too; the run
    /// directories are the last round's.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub rounds: u32,
    /// Output directory [default: runs/bench-step].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `platoon bench design`.
#[derive(Debug, clap::Args)]
pub struct DesignArgs {
    /// Numbers of followers of the designs.
    #[arg(long, value_delimiter = ',', default_value = "4,10,20")]
    pub followers: Vec<usize>,
    /// Numbers of followers of the checks (PLF, the paper's K).
    #[arg(long, value_delimiter = ',', default_value = "10,25,50,100")]
    pub check_followers: Vec<usize>,
    /// Output directory [default: runs/bench-design].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `platoon bench campaign`.
#[derive(Debug, clap::Args)]
pub struct CampaignArgs {
    /// Cells of the local runs.
    #[arg(long, default_value_t = 1000)]
    pub cells: usize,
    /// Local pool sizes to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    pub jobs: Vec<usize>,
    /// Cells sent through Dask (0: skip Dask); each way of running them pays about a second to
    /// start the Python driver and its client, so fewer cells measure mostly that.
    #[arg(long, default_value_t = 1000)]
    pub dask_cells: usize,
    /// Output directory [default: runs/bench-campaign].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `platoon bench search`.
#[derive(Debug, clap::Args)]
pub struct SearchArgs {
    /// Evaluations of the search.
    #[arg(long, default_value_t = 1000)]
    pub evaluations: usize,
    /// Local pool sizes to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    pub jobs: Vec<usize>,
    /// Output directory [default: runs/bench-search].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `platoon bench all`.
#[derive(Debug, clap::Args)]
pub struct AllArgs {
    /// Output directory [default: runs/bench].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
    /// Where to write the report.
    #[arg(long, default_value = "BENCHMARKS.md")]
    pub markdown: PathBuf,
}

pub fn run(b: Bench) -> Result<()> {
    match b {
        Bench::Latency(a) => latency(a).map(|_| ()),
        Bench::Step(a) => step(a).map(|_| ()),
        Bench::Design(a) => design(a).map(|_| ()),
        Bench::Campaign(a) => campaign(a).map(|_| ()),
        Bench::Search(a) => search(a).map(|_| ()),
        Bench::All(a) => all(a),
    }
}

#[derive(Debug, Clone, serde::Serialize)]
struct Row {
    quantity: String,
    n: usize,
    p50_us: f64,
    p90_us: f64,
    p99_us: f64,
    p999_us: f64,
    max_us: f64,
    over_raw_p50: Option<f64>,
}

/// The row of `quantity`; no samples is an error (the benchmark measures every row or fails).
fn row(quantity: &str, s: Option<Stats>) -> Result<Row> {
    let s = s.with_context(|| format!("{quantity}: no samples were recorded"))?;
    Ok(Row {
        quantity: quantity.into(),
        n: s.n,
        p50_us: s.p50_us,
        p90_us: s.p90_us,
        p99_us: s.p99_us,
        p999_us: s.p999_us,
        max_us: s.max_us,
        over_raw_p50: None,
    })
}

#[derive(serde::Serialize)]
struct LatencyReport {
    machine_cores: usize,
    scenario: String,
    vehicles: usize,
    batch_items: usize,
    rows: Vec<Row>,
    injector_hop_over_raw_hop_p50: f64,
    /// The Python SDK's injector hop over the built-in (Rust SDK) one, p50, measured in the
    /// same session, the nodes on any CPU.
    python_sdk_over_builtin_injector_p50: f64,
    /// The same with every node of both runs on one core (the SDK's own cost, without
    /// cross-core wake-ups).
    python_sdk_over_builtin_injector_p50_one_core: f64,
    step_overhead_p50_us: f64,
    /// The same with the nodes on one core.
    step_overhead_p50_us_one_core: f64,
    /// `guest_halt_poll_ns` as read during the run (how long an idle vCPU polls before it
    /// halts), or None where it is not readable.
    guest_halt_poll_ns: Option<String>,
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

/// Where the haltpoll cpuidle driver (KVM guests) exposes how long an idle vCPU polls before
/// halting.
const HALT_POLL: &str = "/sys/module/haltpoll/parameters/guest_halt_poll_ns";

/// `guest_halt_poll_ns`, read from this machine (None where it is not readable).
fn guest_halt_poll_ns() -> Option<String> {
    std::fs::read_to_string(HALT_POLL)
        .ok()
        .map(|v| v.trim().to_string())
        .filter(|v| !v.is_empty())
}

/// What was read of `guest_halt_poll_ns`, for the report.
fn describe_halt_poll(v: Option<&str>) -> String {
    match v {
        Some("0") => format!(
            "`guest_halt_poll_ns` = 0, read from {HALT_POLL}: idle vCPUs halt without polling"
        ),
        Some(v) => format!(
            "`guest_halt_poll_ns` = {v}, read from {HALT_POLL}: idle vCPUs poll up to {v} ns before halting"
        ),
        None => format!("`guest_halt_poll_ns` not readable here ({HALT_POLL})"),
    }
}

/// The commit of the source tree this binary was built from, as git reports it when the
/// benchmarks start: the short hash, with " + uncommitted changes" when a tracked file other
/// than BENCHMARKS.md (the report itself) differs from it, or "unknown" without git or the tree.
fn commit() -> String {
    let tree = Path::new(env!("CARGO_MANIFEST_DIR"));
    let git = |args: &[&str]| -> Option<String> {
        let o = Command::new("git")
            .arg("-C")
            .arg(tree)
            .args(args)
            .stderr(std::process::Stdio::null())
            .output()
            .ok()?;
        o.status
            .success()
            .then(|| String::from_utf8_lossy(&o.stdout).into_owned())
    };
    let Some(head) = git(&["rev-parse", "--short", "HEAD"]) else {
        return "unknown".into();
    };
    let head = head.trim().to_string();
    match git(&["status", "--porcelain", "--untracked-files=no"]) {
        Some(status) => {
            let changed = status
                .lines()
                .filter_map(|l| l.get(3..))
                .any(|path| path != "BENCHMARKS.md");
            if changed {
                format!("{head} + uncommitted changes")
            } else {
                head
            }
        }
        None => format!("{head} (uncommitted changes unknown)"),
    }
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(0, |n| n.get())
}

fn latency(a: LatencyArgs) -> Result<LatencyReport> {
    if a.iterations == 0 {
        bail!("--iterations must be at least 1");
    }
    let platoon_config::Loaded {
        config,
        scenario,
        stem,
    } = platoon_config::load_or(a.config.as_deref(), platoon_config::Embedded::Paper)?;
    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("bench-latency"));
    let dir = RunDir::create(&out, a.force)?;
    dir.write("config.toml", platoon_config::to_toml(&config).as_bytes())?;
    let exe = platoon_app::platoon_program()?;
    let n = scenario.topology.followers();
    let items: usize = (0..=n)
        .map(|v| {
            scenario
                .topology
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
    let mut samples: Vec<(&str, Vec<u64>)> = Vec::new();

    let raw_hop = |busy_poll: bool| {
        platoon_runtime::bench::raw_hop(
            &platoon_runtime::new_run_id(),
            &exe,
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
        let h = platoon_runtime::bench::socket_hop(socket, &exe, a.iterations, a.warmup, bytes)
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
            &exe,
            a.iterations,
            a.warmup,
            bytes,
        )
        .context("the Unix-socket hop on one core")?;
        Ok((raw, uds))
    })??;
    samples.push(("raw_iceoryx2_hop_one_core", raw_one));
    samples.push(("unix_socket_hop_one_core", uds_one));

    bar.set_message(format!("co-simulating {stem} over iceoryx2"));
    let logs = dir.path("logs");
    std::fs::create_dir_all(&logs)?;
    let opts = platoon_runtime::Options {
        run_id: platoon_runtime::new_run_id(),
        exe: exe.clone(),
        config: std::path::absolute(dir.path("config.toml"))?,
        injector: platoon_runtime::Program::Builtin,
        controller: platoon_runtime::Program::Builtin,
        plant: platoon_runtime::Program::Builtin,
        traffic: 0,
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
    let outcome = platoon_runtime::orchestrate(&opts, &scenario, |_, _, _| {})
        .context("the iceoryx2 co-simulation")?;
    // The same run with the Python SDK's dos_jammer as the injector (the built-in one is
    // written on the Rust SDK, so its stage is the Rust SDK's), and both again with the nodes
    // on one core: a step is a chain of wake-ups, and waking a process on another core can
    // cost more than the work (VMs that halt idle cores), which is not the SDK's cost.
    let one_core = platoon_runtime::available_cpus()
        .first()
        .map_or_else(Vec::new, |&c| vec![c]);
    let cosim = |injector: platoon_runtime::Program, cpus: &[usize]| {
        let opts = platoon_runtime::Options {
            run_id: platoon_runtime::new_run_id(),
            injector,
            log_dir: None,
            cpus: cpus.to_vec(),
            ..opts.clone()
        };
        Ok::<_, anyhow::Error>(platoon_runtime::orchestrate(&opts, &scenario, |_, _, _| {})?.timing)
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
    let mut sim = FleetSimulation::new(&scenario)?;
    let mut inproc = Vec::with_capacity(scenario.steps as usize + 1);
    while !sim.is_done() {
        let t = Instant::now();
        std::hint::black_box(sim.step());
        inproc.push(t.elapsed().as_nanos() as u64);
    }
    bar.finish_and_clear();

    // Every row is required: a quantity with no samples fails the benchmark, by name.
    let mut rows: Vec<Row> = samples
        .iter()
        .map(|(name, v)| row(name, Stats::of(&mut v.clone())))
        .collect::<Result<_>>()?;
    let t = outcome.timing;
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
    let raw_p50 = rows[0].p50_us;
    for r in &mut rows {
        if r.quantity.ends_with("hop") || r.quantity.contains("hop_") {
            r.over_raw_p50 = Some(r.p50_us / raw_p50);
        }
    }
    let p50 = |q: &str| {
        rows.iter()
            .find(|r| r.quantity == q)
            .map(|r| r.p50_us)
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
    let mut csv = csv::Writer::from_writer(dir.writer("latency.csv")?);
    for r in &report.rows {
        csv.serialize(r)?;
    }
    csv.flush()?;
    let mut raw_csv = csv::Writer::from_writer(dir.writer("latency-samples.csv")?);
    raw_csv.write_record(["method", "hop_ns"])?;
    for (name, v) in &samples {
        for x in v {
            raw_csv.write_record([name.to_string(), x.to_string()])?;
        }
    }
    raw_csv.flush()?;
    platoon_output::plots::histograms(&dir.path("latency.png"), &samples)?;
    dir.write(
        "latency.json",
        (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;

    println!(
        "{:<28} {:>7} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
        "µs", "n", "p50", "p90", "p99", "p99.9", "max", "x raw"
    );
    for r in &report.rows {
        println!(
            "{:<28} {:>7} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>9.2} {:>8}",
            r.quantity,
            r.n,
            r.p50_us,
            r.p90_us,
            r.p99_us,
            r.p999_us,
            r.max_us,
            r.over_raw_p50.map_or(String::new(), |x| format!("{x:.2}"))
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
    println!("outputs: {}", path.display());
    Ok(report)
}

#[derive(Debug, Clone, serde::Serialize)]
struct StepRow {
    /// The round (1, 2, ...), or 0 for the median over the rounds.
    round: u32,
    mode: String,
    followers: usize,
    vehicles: usize,
    steps: u64,
    step_p50_us: f64,
    step_p99_us: f64,
    real_time_factor: f64,
    plant_p50_us: Option<f64>,
    controller_p50_us: Option<f64>,
    injector_p50_us: Option<f64>,
    sumo_step_p50_us: Option<f64>,
    bridge_p50_us: Option<f64>,
    /// Peak resident memory of every process of the run (`platoon run` and its nodes), MiB.
    peak_rss_mib: Option<f64>,
    /// SUMO's step and the bridge's work for the same SUMO and model in a loop with no
    /// co-simulation around it (`sumo_plant.py --tight-loop`).
    sumo_step_tight_p50_us: Option<f64>,
    bridge_tight_p50_us: Option<f64>,
}

/// One peer of a SUMO case: the same fleet for the same steps, driven by SUMO itself
/// (`bridge/bench_peers.py`).
#[derive(Debug, Clone, serde::Serialize)]
struct PeerRow {
    /// The round (1, 2, ...), or 0 for the median over the rounds.
    round: u32,
    followers: usize,
    vehicles: usize,
    /// krauss, plexe_acc, plexe_cacc or floor.
    peer: String,
    step_p50_us: f64,
    step_p90_us: f64,
    step_mean_us: f64,
    /// SUMO's `simulationStep` alone (the floor's calls around it left out).
    sumo_step_p50_us: f64,
}

/// What `platoon bench step` measured: our cases and their peers (medians over the rounds),
/// and our `sumo` step over each peer's, per round.
struct StepReport {
    rows: Vec<StepRow>,
    peers: Vec<PeerRow>,
    ratios: Vec<PeerRatio>,
}

/// Our `sumo` step over a peer's, in each round (the same round's runs, one after the other).
#[derive(Debug, Clone, serde::Serialize)]
struct PeerRatio {
    followers: usize,
    peer: String,
    /// One per round, in order.
    rounds: Vec<f64>,
    /// Their median.
    median: f64,
}

/// The median of `xs` (NaN when there are none).
fn median(mut xs: Vec<f64>) -> f64 {
    xs.retain(|x| !x.is_nan());
    xs.sort_by(f64::total_cmp);
    match xs.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => xs[n / 2],
        n => 0.5 * (xs[n / 2 - 1] + xs[n / 2]),
    }
}

/// The median over `rows` of a figure some rows may not have.
fn median_of<T>(rows: &[&T], f: impl Fn(&T) -> Option<f64>) -> Option<f64> {
    let xs: Vec<f64> = rows.iter().filter_map(|r| f(r)).collect();
    (!xs.is_empty()).then(|| median(xs))
}

/// `rows` grouped by `key`, the groups in the order their first rows come (a case's or a
/// peer's rows of every round).
fn groups<T, K: PartialEq>(rows: &[T], key: impl Fn(&T) -> K) -> Vec<Vec<&T>> {
    let mut out: Vec<(K, Vec<&T>)> = Vec::new();
    for r in rows {
        let k = key(r);
        match out.iter_mut().find(|(g, _)| *g == k) {
            Some((_, group)) => group.push(r),
            None => out.push((k, vec![r])),
        }
    }
    out.into_iter().map(|(_, group)| group).collect()
}

/// One row per case of the rounds' rows (in the order of the first round): each figure the
/// median over the rounds.
fn median_rows(rounds: &[StepRow]) -> Vec<StepRow> {
    groups(rounds, |r| (r.mode.clone(), r.followers))
        .into_iter()
        .map(|same| {
            let r = same[0];
            let step = median(same.iter().map(|x| x.step_p50_us).collect());
            StepRow {
                round: 0,
                mode: r.mode.clone(),
                followers: r.followers,
                vehicles: r.vehicles,
                steps: r.steps,
                step_p50_us: step,
                step_p99_us: median(same.iter().map(|x| x.step_p99_us).collect()),
                real_time_factor: 0.01 * 1e6 / step,
                plant_p50_us: median_of(&same, |x| x.plant_p50_us),
                controller_p50_us: median_of(&same, |x| x.controller_p50_us),
                injector_p50_us: median_of(&same, |x| x.injector_p50_us),
                sumo_step_p50_us: median_of(&same, |x| x.sumo_step_p50_us),
                bridge_p50_us: median_of(&same, |x| x.bridge_p50_us),
                peak_rss_mib: median_of(&same, |x| x.peak_rss_mib),
                sumo_step_tight_p50_us: median_of(&same, |x| x.sumo_step_tight_p50_us),
                bridge_tight_p50_us: median_of(&same, |x| x.bridge_tight_p50_us),
            }
        })
        .collect()
}

/// The peers' rows of every round as one row per size and peer, each figure the median.
fn median_peers(rounds: &[PeerRow]) -> Vec<PeerRow> {
    groups(rounds, |r| (r.peer.clone(), r.followers))
        .into_iter()
        .map(|same| {
            let r = same[0];
            let m = |f: fn(&PeerRow) -> f64| median(same.iter().map(|x| f(x)).collect());
            PeerRow {
                round: 0,
                followers: r.followers,
                vehicles: r.vehicles,
                peer: r.peer.clone(),
                step_p50_us: m(|x| x.step_p50_us),
                step_p90_us: m(|x| x.step_p90_us),
                step_mean_us: m(|x| x.step_mean_us),
                sumo_step_p50_us: m(|x| x.sumo_step_p50_us),
            }
        })
        .collect()
}

/// Our `sumo` step over each peer's, round by round.
fn peer_ratios(steps: &[StepRow], peers: &[PeerRow]) -> Vec<PeerRatio> {
    groups(peers, |p| (p.peer.clone(), p.followers))
        .into_iter()
        .map(|same| {
            let rounds: Vec<f64> = same
                .iter()
                .map(|q| {
                    steps
                        .iter()
                        .find(|r| {
                            r.mode == "sumo" && r.followers == q.followers && r.round == q.round
                        })
                        .map_or(f64::NAN, |r| r.step_p50_us / q.step_p50_us)
                })
                .collect();
            PeerRatio {
                followers: same[0].followers,
                peer: same[0].peer.clone(),
                median: median(rounds.clone()),
                rounds,
            }
        })
        .collect()
}

/// `bridge/bench_peers.py` on a SUMO case's plant.json: each peer's step, µs.
fn peers(plant_json: &std::path::Path, followers: usize, round: u32) -> Result<Vec<PeerRow>> {
    let python = platoon_app::sumo::ensure_venv()?;
    let o = Command::new(python)
        .arg(platoon_app::sumo::bridge_dir()?.join("bench_peers.py"))
        .arg("--plant-json")
        .arg(plant_json)
        .output()
        .context("starting bridge/bench_peers.py")?;
    if !o.status.success() {
        bail!(
            "bridge/bench_peers.py on {} ended with {}: {}",
            plant_json.display(),
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        );
    }
    let v: serde_json::Value = serde_json::from_slice(&o.stdout)
        .context("bench_peers.py printed something other than its JSON report")?;
    let peers = v
        .as_object()
        .context("bench_peers.py's report is not a JSON object")?;
    peers
        .iter()
        .map(|(peer, r)| {
            let num = |k: &str| {
                r[k].as_f64()
                    .with_context(|| format!("bench_peers.py's report: {peer}.{k} is missing"))
            };
            Ok(PeerRow {
                round,
                followers,
                vehicles: num("vehicles")? as usize,
                peer: peer.clone(),
                step_p50_us: num("p50_us")?,
                step_p90_us: num("p90_us")?,
                step_mean_us: num("mean_us")?,
                sumo_step_p50_us: num("sumo_step_p50_us")?,
            })
        })
        .collect()
}

/// A platoon-of-4 fleet config with `followers` followers in all, `seconds` long: Table I's
/// scenario, resolved, with its keys set by dotted path as a campaign sets them.
fn fleet_config(followers: usize, seconds: f64, sumo: bool) -> Result<String> {
    let net = platoon_app::sumo::bridge_dir()?.join("../sumo/highway-long/highway-long.net.xml");
    let (config, _) = platoon_config::Embedded::Table1.parse()?;
    let mut root = toml::Value::try_from(&config).context("the resolved Table I config")?;
    let lanes: Vec<toml::Value> = (0..4).map(toml::Value::Integer).collect();
    let mut keys: Vec<(&str, toml::Value)> = vec![
        ("simulation.duration_s", seconds.into()),
        ("topology.preset", "pf".into()),
        ("platoon.vehicle_length_m", 4.0.into()),
        ("fleet.platoons", (followers as i64 / 4).into()),
        ("fleet.lanes", lanes.into()),
        ("fleet.gap_m", 60.0.into()),
        ("sumo.net", net.display().to_string().into()),
        ("sumo.fcd_period_s", 0.0.into()),
    ];
    if sumo {
        keys.push(("simulation.plant", "sumo".into()));
    }
    for (key, value) in keys {
        platoon_campaign::overrides::set(&mut root, key, value)
            .map_err(|e| anyhow::anyhow!("the benchmark's fleet config: {e}"))?;
    }
    Ok(toml::to_string(&root)?)
}

/// `bridge/sumo_plant.py --tight-loop`: the same SUMO and model as a run's plant.json, timed
/// in a loop with no co-simulation around it.
fn tight_loop(plant_json: &std::path::Path, steps: u32) -> Result<serde_json::Value> {
    let python = platoon_app::sumo::ensure_venv()?;
    let o = Command::new(python)
        .arg(platoon_app::sumo::bridge_dir()?.join("sumo_plant.py"))
        .args(["--tight-loop", &steps.to_string()])
        .env("PLATOON_PLANT_SPEC", plant_json)
        .output()?;
    if !o.status.success() {
        bail!("{}", String::from_utf8_lossy(&o.stderr).trim());
    }
    Ok(serde_json::from_slice(&o.stdout)?)
}

fn step(a: StepArgs) -> Result<StepReport> {
    if a.followers.is_empty() || a.followers.iter().any(|&n| n == 0 || n % 4 != 0) {
        bail!(
            "--followers needs positive multiples of 4 (platoons of 4 followers), e.g. 4,100,1000"
        );
    }
    for m in &a.modes {
        if !matches!(
            m.as_str(),
            "inproc" | "native" | "sumo" | "native-1cpu" | "sumo-1cpu"
        ) {
            bail!(
                "unknown mode {m:?} in --modes: use inproc, native, sumo, native-1cpu or sumo-1cpu"
            );
        }
    }
    if !(a.seconds.is_finite() && a.seconds >= 0.1) {
        bail!("--seconds must be at least 0.1");
    }
    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("bench-step"));
    let dir = RunDir::create(&out, a.force)?;
    let exe = platoon_app::platoon_program()?;
    let one_cpu = platoon_runtime::available_cpus()
        .first()
        .map_or_else(|| "0".to_string(), |c| c.to_string());
    let bar =
        indicatif::ProgressBar::new((a.rounds as usize * a.followers.len() * a.modes.len()) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {msg} [{elapsed}] {wide_bar} {pos}/{len}",
        )
        .expect("static template"),
    );
    let mut rows = Vec::new();
    let mut peer_rows = Vec::new();
    for round in 1..=a.rounds {
        for &n in &a.followers {
            for mode in &a.modes {
                bar.set_message(format!("round {round}/{}: {mode}, {n} followers", a.rounds));
                let config = dir.path(&format!("{mode}-{n}.toml"));
                let sumo = mode.starts_with("sumo");
                std::fs::write(&config, fleet_config(n, a.seconds, sumo)?)?;
                let case = dir.path(&format!("{mode}-{n}"));
                let transport = if mode == "inproc" {
                    "inproc"
                } else {
                    "iceoryx2"
                };
                let mut cmd = Command::new(&exe);
                cmd.args([
                    "run",
                    config.to_str().unwrap_or_default(),
                    "--no-plots",
                    "--force",
                    "--transport",
                    transport,
                    "--out",
                ])
                .arg(&case);
                if mode.ends_with("-1cpu") {
                    cmd.arg("--cpus").arg(one_cpu.as_str());
                }
                let o = cmd
                    .env("PLATOON_STEP_TIMEOUT", "30")
                    .output()
                    .with_context(|| format!("running the {mode} case with {n} followers"))?;
                if !o.status.success() {
                    bail!(
                        "the {mode} case with {n} followers failed: {}",
                        String::from_utf8_lossy(&o.stderr).trim()
                    );
                }
                let read = |f: &str| -> Option<serde_json::Value> {
                    serde_json::from_str(&std::fs::read_to_string(case.join(f)).ok()?).ok()
                };
                let timing = read("timing.json").context("timing.json missing")?;
                let sumo = read("sumo.json");
                let tight =
                    if sumo.is_some() {
                        Some(tight_loop(&case.join("plant.json"), 500).with_context(|| {
                            format!("timing SUMO's tight loop for {n} followers")
                        })?)
                    } else {
                        None
                    };
                if mode == "sumo" && !a.no_peers {
                    bar.set_message(format!(
                        "round {round}/{}: SUMO's own peers, {n} followers",
                        a.rounds
                    ));
                    peer_rows.extend(
                        peers(&case.join("plant.json"), n, round)
                            .with_context(|| format!("running the peers for {n} followers"))?,
                    );
                }
                let p = |v: &serde_json::Value, k: &str| v[k]["p50_us"].as_f64();
                let step_p50 = p(&timing, "step").unwrap_or(f64::NAN);
                let dt = 0.01;
                rows.push(StepRow {
                    round,
                    mode: mode.clone(),
                    followers: n,
                    vehicles: n / 4 * 5,
                    steps: (a.seconds / dt).round() as u64 + 1,
                    step_p50_us: step_p50,
                    step_p99_us: timing["step"]["p99_us"].as_f64().unwrap_or(f64::NAN),
                    real_time_factor: dt * 1e6 / step_p50,
                    plant_p50_us: p(&timing, "plant"),
                    controller_p50_us: p(&timing, "controller_tx")
                        .zip(p(&timing, "controller_rx"))
                        .map(|(x, y)| x + y),
                    injector_p50_us: p(&timing, "injector"),
                    sumo_step_p50_us: sumo
                        .as_ref()
                        .and_then(|s| s["sumo_step"]["p50_us"].as_f64()),
                    bridge_p50_us: sumo
                        .as_ref()
                        .and_then(|s| s["bridge_step"]["p50_us"].as_f64()),
                    sumo_step_tight_p50_us: tight
                        .as_ref()
                        .and_then(|t| t["sumo_step_p50_us"].as_f64()),
                    bridge_tight_p50_us: tight
                        .as_ref()
                        .and_then(|t| t["bridge_step_p50_us"].as_f64()),
                    peak_rss_mib: timing["peak_rss_mib"]
                        .as_object()
                        .map(|m| m.values().filter_map(|v| v.as_f64()).sum()),
                });
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    let mut csv = csv::Writer::from_writer(dir.writer("step.csv")?);
    for r in &rows {
        csv.serialize(r)?;
    }
    csv.flush()?;
    if !peer_rows.is_empty() {
        let mut csv = csv::Writer::from_writer(dir.writer("peers.csv")?);
        for r in &peer_rows {
            csv.serialize(r)?;
        }
        csv.flush()?;
    }
    // From here on, one row per case and per peer: the median over the rounds.
    let ratios = peer_ratios(&rows, &peer_rows);
    let (round_rows, round_peers) = (rows, peer_rows);
    let (rows, peer_rows) = (median_rows(&round_rows), median_peers(&round_peers));
    // Least-squares line per mode: cost per step = a + b N.
    let mut series = Vec::new();
    let mut fits = Vec::new();
    for (i, mode) in a.modes.iter().enumerate() {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| &r.mode == mode)
            .map(|r| (r.followers as f64, r.step_p50_us))
            .collect();
        let (a0, b) = fit(&pts);
        fits.push(
            serde_json::json!({"mode": mode, "intercept_us": a0, "slope_us_per_follower": b}),
        );
        series.push(platoon_output::plots::Series {
            label: format!("{mode}: {a0:.1} + {b:.3} N µs"),
            color: i,
            points: pts,
        });
    }
    platoon_output::plots::scatter_with_lines(
        &dir.path("step.png"),
        "Co-simulation cost per step (p50) against followers",
        "followers N",
        "µs per step",
        &series,
    )?;
    dir.write(
        "step.json",
        (serde_json::to_string_pretty(&serde_json::json!({
            "rounds": a.rounds,
            "rows": rows,
            "fits": fits,
            "peers": peer_rows,
            "ratios": ratios,
            "round_rows": round_rows,
            "round_peers": round_peers,
        }))? + "\n")
            .as_bytes(),
    )?;
    let path = dir.commit()?;
    println!(
        "{:<7} {:>6} {:>9} {:>11} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "mode", "N", "vehicles", "step p50", "x realtime", "plant", "control", "injector", "SUMO"
    );
    // A stage a mode does not have (in process: no plant or injector process) prints "-".
    let stage = |x: Option<f64>| x.map_or(String::from("-"), |x| format!("{x:.1}"));
    for r in &rows {
        println!(
            "{:<7} {:>6} {:>9} {:>9.1}µs {:>10.1} {:>10} {:>10} {:>10} {:>10}",
            r.mode,
            r.followers,
            r.vehicles,
            r.step_p50_us,
            r.real_time_factor,
            stage(r.plant_p50_us),
            stage(r.controller_p50_us),
            stage(r.injector_p50_us),
            stage(r.sumo_step_p50_us)
        );
    }
    for f in &fits {
        let mode = f["mode"].as_str().unwrap_or_default();
        match (
            f["intercept_us"].as_f64(),
            f["slope_us_per_follower"].as_f64(),
        ) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() => {
                println!("{mode}: {a:.1} µs + {b:.3} µs per follower")
            }
            _ => println!("{mode}: one size only, no fit of cost against N"),
        }
    }
    if !peer_rows.is_empty() {
        println!(
            "\nthe same fleet driven by SUMO itself (step p50, and our sumo step as a ratio, the \
             median of the rounds' ratios, then each round's):"
        );
        for p in &peer_rows {
            let r = ratios
                .iter()
                .find(|r| r.peer == p.peer && r.followers == p.followers);
            let each = r.map_or(String::new(), |r| {
                r.rounds
                    .iter()
                    .map(|x| format!("{x:.2}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            });
            println!(
                "{:<11} {:>6} {:>9.1}µs  ours {:.2}x  ({each})",
                p.peer,
                p.followers,
                p.step_p50_us,
                r.map_or(f64::NAN, |r| r.median)
            );
        }
    }
    println!("outputs: {}", path.display());
    Ok(StepReport {
        rows,
        peers: peer_rows,
        ratios,
    })
}

/// BENCHMARKS.md's table of the peers: the same fleets driven by SUMO itself, our `sumo` step
/// as a ratio to each (the median of the rounds' ratios), and the target against Plexe's
/// auto-fed CACC.
fn peers_section(md: &mut String, peers: &[PeerRow], ratios: &[PeerRatio]) {
    if peers.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "### The same fleets driven by SUMO itself (`bridge/bench_peers.py`, in the same run)\n\n\
         After each `sumo` case, its plant.json (network, vehicles, lanes, initial states, steps) \
         runs again in one process through libsumo: `krauss`, SUMO's own model drives every \
         vehicle; `plexe_acc` and `plexe_cacc`, Plexe's ACC and PATH CACC in SUMO's CC model (the \
         CACC fed by SUMO itself every step, `ccaf`), leaders on cruise control; `floor`, any \
         external driver's least work (per vehicle one `setAcceleration` and two getters from \
         Python, no control). µs per step, medians over the rounds; \"ours / peer\" is the `sumo` \
         row's step (nodes on any CPU) over the peer's (p50), the median of the rounds' ratios, \
         each taken between runs made one right after the other:\n"
    );
    let _ = writeln!(
        md,
        "| followers | vehicles | peer | p50 | p90 | mean | SUMO's step alone (p50) | ours / peer (p50) | each round |\n|---|---|---|---|---|---|---|---|---|"
    );
    let ratio = |p: &PeerRow| {
        ratios
            .iter()
            .find(|r| r.peer == p.peer && r.followers == p.followers)
    };
    let each = |r: &PeerRatio| {
        r.rounds
            .iter()
            .map(|x| format!("{x:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    for p in peers {
        let r = ratio(p);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {} |",
            p.followers,
            p.vehicles,
            p.peer,
            p.step_p50_us,
            p.step_p90_us,
            p.step_mean_us,
            p.sumo_step_p50_us,
            r.map_or("-".into(), |r| format!("{:.2}", r.median)),
            r.map_or("-".into(), each)
        );
    }
    let _ = writeln!(md);
    let big = peers.iter().map(|p| p.followers).max().unwrap_or(0);
    if let Some((cacc, r)) = peers
        .iter()
        .find(|p| p.followers == big && p.peer == "plexe_cacc")
        .and_then(|p| Some((p, ratio(p)?)))
    {
        let x = r.median;
        let _ = writeln!(
            md,
            "{big} followers ({} vehicles) with SUMO: our step is **{x:.2}x** Plexe's auto-fed CACC inside SUMO, the median of {} rounds ({}; target <= 0.8: {}).\n",
            cacc.vehicles,
            r.rounds.len(),
            each(r),
            if x <= 0.8 { "met" } else { "missed" }
        );
    }
}

/// Least squares y = a + b x.
fn fit(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    if pts.len() < 2 {
        return (pts.first().map_or(f64::NAN, |p| p.1), f64::NAN);
    }
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    (my - b * mx, b)
}

#[derive(Debug, Clone, serde::Serialize)]
struct DesignRow {
    followers: usize,
    seconds: f64,
    sdps: usize,
    feasible: bool,
    beta1_over_beta2: Option<f64>,
    /// `theorem1` (common P) or `theorem1-block-diagonal`.
    certificate: Option<String>,
    /// The followers the procedure ran on.
    designed_on: Option<usize>,
}

/// One measured `check-gain` on PLF.
#[derive(Debug, Clone, serde::Serialize)]
struct CheckRow {
    followers: usize,
    /// The smallest ratio with I_N kron P (one SDP and its re-check).
    common_s: f64,
    common_ratio: Option<f64>,
    /// The same with one P per follower.
    block_diagonal_s: f64,
    block_diagonal_ratio: Option<f64>,
    /// The largest-decay bisection.
    max_decay_s: f64,
    /// The closed-loop spectrum at 51 taus over the paper's tau range.
    spectrum_s: f64,
    /// String stability at the paper's smallest, nominal and largest tau.
    string_stability_s: f64,
    /// Everything above: what `design check-gain` computes for this platoon.
    total_s: f64,
}

fn design(a: DesignArgs) -> Result<(Vec<DesignRow>, Vec<CheckRow>)> {
    if a.followers.is_empty() || a.followers.contains(&0) || a.check_followers.contains(&0) {
        bail!("--followers and --check-followers need positive platoon sizes, e.g. 4,10,20");
    }
    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("bench-design"));
    let dir = RunDir::create(&out, a.force)?;
    let mut rows = Vec::new();
    for &n in &a.followers {
        eprintln!("designing for {n} followers (TPSF) ...");
        let t = platoon_topology::Topology::preset(platoon_topology::Preset::Tpsf, n)?;
        let h = platoon_synthesis::Coupling::constant(t.h_matrix());
        let started = Instant::now();
        let d = platoon_synthesis::design_theorem1(&Default::default(), &h)?;
        rows.push(DesignRow {
            followers: n,
            seconds: started.elapsed().as_secs_f64(),
            sdps: d.as_ref().map_or(0, |d| d.sdps),
            feasible: d.is_some(),
            beta1_over_beta2: d.as_ref().map(|d| d.certificate.ratio),
            certificate: d.as_ref().map(|d| d.certificate.condition.clone()),
            designed_on: d.as_ref().map(|d| d.designed_on),
        });
    }
    // The tau grids of `design check-gain` for the paper scenario: 51 taus over its range for
    // the spectrum; its smallest, nominal and largest for string stability.
    let (_, paper) = platoon_config::Embedded::Paper.parse()?;
    let (lo, hi) = paper.tau_range();
    let spectrum_taus: Vec<f64> = (0..=50)
        .map(|i| lo + (hi - lo) * f64::from(i) / 50.0)
        .collect();
    let mut string_taus = vec![lo, paper.control.tau_nominal, hi];
    string_taus.sort_by(f64::total_cmp);
    string_taus.dedup();
    let mut checks = Vec::new();
    for &n in &a.check_followers {
        eprintln!("checking the paper's K on {n} followers (PLF) ...");
        let t = platoon_topology::Topology::preset(platoon_topology::Preset::Plf, n)?;
        let g = platoon_synthesis::Coupling::constant(t.h_matrix());
        let k = [4.81, 9.12, 2.97];
        let ratio = |f: platoon_synthesis::Feasibility| match f {
            platoon_synthesis::Feasibility::Feasible(c) => Some(c.ratio),
            platoon_synthesis::Feasibility::Infeasible => None,
        };
        let started = Instant::now();
        let common = ratio(platoon_synthesis::min_ratio(k, 0.0, &g, &[0.5], 1e-6)?);
        let common_s = started.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let block = ratio(platoon_synthesis::min_ratio_block_diagonal(
            k,
            0.0,
            &g,
            &[0.5],
            1e-6,
        )?);
        let block_s = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        platoon_synthesis::theorem1_max_decay(k, &g, &[0.5], 10.0, 1e-3)?;
        let max_decay_s = t2.elapsed().as_secs_f64();
        let t3 = Instant::now();
        std::hint::black_box(platoon_synthesis::closed_loop_spectrum(
            k,
            &g,
            &spectrum_taus,
        ));
        let spectrum_s = t3.elapsed().as_secs_f64();
        let t4 = Instant::now();
        std::hint::black_box(platoon_synthesis::string_stability(k, &g, &string_taus));
        let string_stability_s = t4.elapsed().as_secs_f64();
        checks.push(CheckRow {
            followers: n,
            common_s,
            common_ratio: common,
            block_diagonal_s: block_s,
            block_diagonal_ratio: block,
            max_decay_s,
            spectrum_s,
            string_stability_s,
            total_s: started.elapsed().as_secs_f64(),
        });
    }
    let mut csv = csv::Writer::from_writer(dir.writer("design.csv")?);
    for r in &rows {
        csv.serialize(r)?;
    }
    csv.flush()?;
    let mut csv = csv::Writer::from_writer(dir.writer("check.csv")?);
    for r in &checks {
        csv.serialize(r)?;
    }
    csv.flush()?;
    let path = dir.commit()?;
    for r in &rows {
        println!(
            "N = {:>3}: {:>7.2} s, {:>3} SDPs, {}{}",
            r.followers,
            r.seconds,
            r.sdps,
            r.beta1_over_beta2
                .map_or("infeasible".to_string(), |x| format!(
                    "beta1/beta2 = {x:.1}"
                )),
            match (&r.certificate, r.designed_on) {
                (Some(c), Some(on)) => format!(" ({c}, designed on {on} followers)"),
                _ => String::new(),
            }
        );
    }
    for r in &checks {
        println!(
            "check, N = {:>3} (PLF): {:>6.2} s in all (common P {:.2} s, one P per follower {:.2} s, largest decay {:.2} s, spectrum {:.2} s, string stability {:.2} s)",
            r.followers, r.total_s, r.common_s, r.block_diagonal_s, r.max_decay_s, r.spectrum_s, r.string_stability_s
        );
    }
    if let Some(e) = growth_exponent(&checks) {
        println!("check time grows as N^{e:.2}");
    }
    println!("outputs: {}", path.display());
    Ok((rows, checks))
}

/// The slope of log(total time) against log(N): the check time grows as N^slope.
fn growth_exponent(checks: &[CheckRow]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = checks
        .iter()
        .map(|r| ((r.followers as f64).ln(), r.total_s.ln()))
        .collect();
    let (_, b) = fit(&pts);
    b.is_finite().then_some(b)
}

/// One measured campaign run.
#[derive(Debug, Clone, serde::Serialize)]
struct CampaignRow {
    /// `throughput` (the pool sizes), `dask` (the Dask comparison, local beside Dask) or
    /// `dask-fifth` (local and Dask in the workers again on a fifth of the cells: the slope
    /// between the two sizes is the cost per cell without the fixed start-up).
    part: &'static str,
    executor: String,
    workers: usize,
    cells: usize,
    wall_s: f64,
    cpu_s: f64,
    cells_per_s: f64,
    ms_per_cell: f64,
}

fn campaign(a: CampaignArgs) -> Result<Vec<CampaignRow>> {
    if a.cells == 0 || a.jobs.is_empty() || a.jobs.contains(&0) {
        bail!("--cells and every --jobs value must be at least 1");
    }
    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("bench-campaign"));
    let dir = RunDir::create(&out, a.force)?;
    let exe = platoon_app::platoon_program()?;
    // A Monte Carlo campaign of `samples` cells on `base` (a file in the output directory; None:
    // the embedded paper scenario), written as `bench-<name>.toml`.
    let file_on = |name: &str, samples: usize, base: Option<&str>| -> Result<PathBuf> {
        let path = dir.path(&format!("bench-{name}.toml"));
        let base = base.map_or(String::new(), |b| format!("base = \"{b}\"\n"));
        let text = format!(
            "name = \"bench-{name}\"\n{base}seed = 1\n[monte_carlo]\nsamples = {samples}\n\
             dos = {{ T1 = 2.0, T2 = 9.46, D1 = 6.0, D2 = 11.33, min_gap_s = 1.0, max_gap_s = 12.0, \
             min_duration_s = 0.5, max_duration_s = 3.0 }}\n"
        );
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
        Ok(path)
    };
    let file = |samples: usize| file_on(&samples.to_string(), samples, None);
    let measure = |part: &'static str,
                   file: &Path,
                   name: &str,
                   extra: &[&str],
                   executor: String,
                   workers: usize,
                   env: &[(&str, &str)]| {
        let target = dir.path(name);
        let o = Command::new(&exe)
            .arg("campaign")
            .arg(file)
            .arg("--out")
            .arg(&target)
            .args(["--no-plots", "--force"])
            .args(extra)
            .envs(env.iter().copied())
            .output()
            .context("running platoon campaign")?;
        if !o.status.success() {
            bail!(
                "platoon campaign {}: {}",
                extra.join(" "),
                String::from_utf8_lossy(&o.stderr).trim()
            );
        }
        let text = std::fs::read_to_string(target.join("campaign.json"))?;
        let j: serde_json::Value = serde_json::from_str(&text)?;
        let cells = j["cells"].as_u64().unwrap_or(0) as usize;
        let wall = j["wall_s"].as_f64().unwrap_or(f64::NAN);
        let row = CampaignRow {
            part,
            executor,
            workers,
            cells,
            wall_s: wall,
            cpu_s: j["cpu_s"].as_f64().unwrap_or(f64::NAN),
            cells_per_s: cells as f64 / wall,
            ms_per_cell: 1e3 * wall / cells as f64,
        };
        println!(
            "{:<28} {:>5} cells in {:>6.2} s: {:>7.1} cells/s",
            row.executor, row.cells, row.wall_s, row.cells_per_s
        );
        Ok(row)
    };
    let mut rows = Vec::new();
    let big = file(a.cells)?;
    for &j in &a.jobs {
        let jobs = j.to_string();
        rows.push(measure(
            "throughput",
            &big,
            &format!("local-{j}"),
            &["--jobs", &jobs],
            format!("local pool, {j} jobs"),
            j,
            &[],
        )?);
    }
    if a.dask_cells > 0 {
        let small = file(a.dask_cells)?;
        rows.push(measure(
            "dask",
            &small,
            "dask-local-2",
            &["--jobs", "2"],
            "local pool, 2 jobs".into(),
            2,
            &[],
        )?);
        let logs = dir.path("dask-logs");
        std::fs::create_dir_all(&logs)?;
        let cluster = platoon_app::campaign::LocalCluster::start(2, &logs)?;
        // The cells in the workers' processes (batches on the platoon package's core, when
        // bridge/.venv has it), then a `platoon campaign-cell` process per cell.
        let mut in_worker = measure(
            "dask",
            &small,
            "dask-2",
            &["--dask", &cluster.address],
            "Dask, 2 workers (127.0.0.1), in the workers".into(),
            2,
            &[],
        )?;
        let ran = dask_in_worker(&dir.path("dask-2").join("dask.log"));
        if ran != Some(in_worker.cells) {
            eprintln!(
                "warning: through Dask only {} of {} cells ran in the workers' processes (is the \
                 platoon package installed in bridge/.venv? `pip install ./bridge`); see {}",
                ran.unwrap_or(0),
                in_worker.cells,
                dir.path("dask-2").join("dask.log").display()
            );
            in_worker.executor =
                "Dask, 2 workers (127.0.0.1), fell back to a process per cell".into();
        }
        rows.push(in_worker);
        rows.push(measure(
            "dask",
            &small,
            "dask-2-process",
            &["--dask", &cluster.address],
            "Dask, 2 workers (127.0.0.1), a process per cell".into(),
            2,
            &[("PLATOON_DASK_IN_WORKER", "0")],
        )?);
        // A fifth of the cells both ways: what a cell costs beyond the fixed start-up (the
        // driver's Python and its connection) is the slope between the two sizes.
        let fifth = a.dask_cells / 5;
        if fifth > 0 {
            let path = file(fifth)?;
            rows.push(measure(
                "dask-fifth",
                &path,
                "dask-local-2-fifth",
                &["--jobs", "2"],
                "local pool, 2 jobs".into(),
                2,
                &[],
            )?);
            rows.push(measure(
                "dask-fifth",
                &path,
                "dask-2-fifth",
                &["--dask", &cluster.address],
                "Dask, 2 workers (127.0.0.1), in the workers".into(),
                2,
                &[],
            )?);
        }
    }
    // The 802.11p channel's cost per cell beside Bernoulli loss: the same Monte Carlo cells on
    // one job, the paper scenario with each channel.
    let paper = platoon_config::PAPER_TOML;
    let channels = [
        (
            "bernoulli",
            "Bernoulli loss 5 %, 1 job",
            "[channel]\nseed = 1\n[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.05\n",
        ),
        (
            "80211p",
            "802.11p (0.12 veh/m, 25 Hz), 1 job",
            "[channel]\nseed = 1\nmodel = \"80211p\"\nradio = { density_veh_per_m = 0.12, beacon_hz = 25.0 }\n",
        ),
    ];
    let channel_cells = a.cells.min(200);
    for (name, executor, section) in channels {
        let base = dir.path(&format!("base-{name}.toml"));
        std::fs::write(&base, format!("{paper}\n{section}"))
            .with_context(|| format!("writing {}", base.display()))?;
        let path = file_on(name, channel_cells, Some(&format!("base-{name}.toml")))?;
        rows.push(measure(
            "channel",
            &path,
            &format!("channel-{name}"),
            &["--jobs", "1"],
            executor.into(),
            1,
            &[],
        )?);
    }
    let mut w = csv::Writer::from_writer(dir.writer("campaign.csv")?);
    for r in &rows {
        w.serialize(r)?;
    }
    w.flush()?;
    let json = serde_json::json!({ "machine_cores": cores(), "rows": rows });
    dir.write(
        "campaign.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;
    println!("outputs: {}", path.display());
    Ok(rows)
}

/// How many cells a Dask campaign ran in the workers' processes, from the driver's last line
/// in its dask.log ("dask_cells: T s: done: N cells in-worker, ...").
fn dask_in_worker(log: &Path) -> Option<usize> {
    let text = std::fs::read_to_string(log).ok()?;
    let done = text
        .lines()
        .rev()
        .find_map(|l| l.split_once(" s: done: ").map(|(_, done)| done))?;
    done.split_whitespace().next()?.parse().ok()
}

/// One measured search.
#[derive(Debug, Clone, serde::Serialize)]
struct SearchRow {
    jobs: usize,
    evaluations: usize,
    wall_s: f64,
    evaluations_per_s: f64,
    ms_per_evaluation: f64,
    /// The largest spacing error found (m), the same for every pool size.
    harm: f64,
}

fn search(a: SearchArgs) -> Result<Vec<SearchRow>> {
    if a.evaluations == 0 || a.jobs.is_empty() || a.jobs.contains(&0) {
        bail!("--evaluations and every --jobs value must be at least 1");
    }
    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("bench-search"));
    let dir = RunDir::create(&out, a.force)?;
    let file = dir.path("bench.toml");
    std::fs::write(&file, "name = \"bench\"\nseed = 1\ncompare = []\n")
        .with_context(|| format!("writing {}", file.display()))?;
    let spec = platoon_app::search::load(&file, Some(a.evaluations))?;
    let mut rows = Vec::new();
    for &j in &a.jobs {
        let pool = platoon_app::campaign::LocalPool::new(std::num::NonZeroUsize::new(j));
        let opts = platoon_app::search::SearchOptions {
            force: true,
            plots: false,
        };
        let o = platoon_app::search::run(
            &spec,
            &dir.path(&format!("jobs-{j}")),
            &opts,
            &pool,
            &platoon_app::Stop::default(),
            &(),
        )?;
        let m = &o.problems[0].methods[0];
        let row = SearchRow {
            jobs: j,
            evaluations: m.evaluations,
            wall_s: m.wall_s,
            evaluations_per_s: m.evaluations as f64 / m.wall_s,
            ms_per_evaluation: 1e3 * m.wall_s / m.evaluations as f64,
            harm: m.best.as_ref().and_then(|b| b.harm).unwrap_or(f64::NAN),
        };
        println!(
            "search, local pool {:>2} jobs: {:>5} evaluations in {:>6.2} s ({:>6.1}/s), largest spacing error {:.2} m",
            j, row.evaluations, row.wall_s, row.evaluations_per_s, row.harm
        );
        rows.push(row);
    }
    let mut w = csv::Writer::from_writer(dir.writer("search.csv")?);
    for r in &rows {
        w.serialize(r)?;
    }
    w.flush()?;
    let json = serde_json::json!({ "machine_cores": cores(), "rows": rows });
    dir.write(
        "search.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;
    println!("outputs: {}", path.display());
    Ok(rows)
}

fn all(a: AllArgs) -> Result<()> {
    let out = a.out.unwrap_or_else(|| PathBuf::from("runs").join("bench"));
    if out.exists() && !a.force {
        bail!(
            "output directory {} exists; choose another --out or pass --force",
            out.display()
        );
    }
    std::fs::create_dir_all(&out)?;
    // Read before anything runs: the commit that measures every section below.
    let commit = commit();
    println!("benchmarking commit {commit}");
    let measured =
        |command: &str| format!("Measured by `platoon {command}` at commit `{commit}`.\n");
    let lat = latency(LatencyArgs {
        config: None,
        iterations: 20_000,
        warmup: 2_000,
        busy_poll: false,
        out: Some(out.join("latency")),
        force: true,
    })?;
    let steps = step(StepArgs {
        followers: vec![4, 100, 1000],
        modes: ["inproc", "native", "sumo", "native-1cpu", "sumo-1cpu"]
            .map(String::from)
            .to_vec(),
        seconds: 5.0,
        no_peers: false,
        rounds: 3,
        out: Some(out.join("step")),
        force: true,
    })?;
    let StepReport {
        rows: steps,
        peers: peer_rows,
        ratios,
    } = steps;
    let (designs, checks) = design(DesignArgs {
        followers: vec![4, 10, 20],
        check_followers: vec![10, 25, 50, 100],
        out: Some(out.join("design")),
        force: true,
    })?;
    let campaigns = campaign(CampaignArgs {
        cells: 1000,
        jobs: vec![1, 2],
        dask_cells: 1000,
        out: Some(out.join("campaign")),
        force: true,
    })?;
    let searches = search(SearchArgs {
        evaluations: 1000,
        jobs: vec![1, 2],
        out: Some(out.join("search")),
        force: true,
    })?;
    let mut md = String::new();
    let _ = writeln!(md, "# Benchmarks\n");
    let _ = writeln!(
        md,
        "Regenerate with `cargo run --release -- bench all --force` (writes this file and runs/bench/). \
         Measured in one `platoon bench all` run at commit `{commit}` (`git rev-parse --short HEAD` \
         when the run started, \"+ uncommitted changes\" when tracked files differed from it); \
         each section repeats the commit that measured it. \
         Machine: {} cores, `{}`; {}. The machines are shared and noisy: read medians and ratios \
         measured side by side in one run, not absolute thresholds.\n",
        cores(),
        std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|c| c.lines().find(|l| l.starts_with("model name")).map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string()))
            .unwrap_or_else(|| "unknown CPU".into()),
        describe_halt_poll(lat.guest_halt_poll_ns.as_deref())
    );
    let _ = writeln!(
        md,
        "## V2V hop and step overhead (`platoon bench latency`)\n\n{}",
        measured("bench latency")
    );
    let _ = writeln!(
        md,
        "Ping-pong between two processes with the paper scenario's tx batch ({} link packets), {} iterations after a warm-up; \
         each hop is publish to publish (CLOCK_MONOTONIC stamps in the payload). µs:\n",
        lat.batch_items, 20_000
    );
    let _ = writeln!(md, "| quantity | p50 | p90 | p99 | p99.9 | max | x raw iceoryx2 (p50) |\n|---|---|---|---|---|---|---|");
    for r in &lat.rows {
        let _ = writeln!(
            md,
            "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} |",
            r.quantity,
            r.p50_us,
            r.p90_us,
            r.p99_us,
            r.p999_us,
            r.max_us,
            r.over_raw_p50.map_or(String::new(), |x| format!("{x:.2}"))
        );
    }
    let _ = writeln!(
        md,
        "\nInjector hop / raw iceoryx2 hop (p50): **{:.2}** (target < 2: {}). Step overhead over in-process (p50): **{:.1} µs** (target < 60 µs: {}); with the nodes on one core (`--cpus`): **{:.1} µs** ({}).\n",
        lat.injector_hop_over_raw_hop_p50,
        if lat.injector_hop_over_raw_hop_p50 < 2.0 { "met" } else { "missed" },
        lat.step_overhead_p50_us,
        if lat.step_overhead_p50_us < 60.0 { "met" } else { "missed: a step is four event-driven hops, each a wake-up of another process, possibly on the other core" },
        lat.step_overhead_p50_us_one_core,
        if lat.step_overhead_p50_us_one_core < 60.0 { "met" } else { "missed" }
    );
    let p50 = |q: &str| {
        lat.rows
            .iter()
            .find(|r| r.quantity == q)
            .map_or(f64::NAN, |r| r.p50_us)
    };
    let step_ratio = lat.step_overhead_p50_us / lat.step_overhead_p50_us_one_core;
    let hop_ratio = p50("injector_hop") / p50("unix_socket_hop");
    let _ = writeln!(
        md,
        "Nodes on any CPU against one core: the step overhead is **{step_ratio:.2}x** the one-core figure (target <= 2: {}); the injector hop on any CPU is **{hop_ratio:.2}x** a Unix-datagram hop measured in the same run (target <= 3: {}). On one core the raw iceoryx2 hop is {:.2} µs and the Unix-datagram hop {:.2} µs. A node that wakes another first hands the sleeping reader its own CPU unless the reader already has just that one, and the reader keeps it for 64 wake-ups before it returns to its CPU set (`crates/runtime/src/handoff.rs`; `PLATOON_WAKE_HANDOFF=0` turns it off): without it, the woken process lands on the idle vCPU, which is halted (`guest_halt_poll_ns` above) and costs 20-30 µs to wake.\n",
        if step_ratio <= 2.0 { "met" } else { "missed" },
        if hop_ratio <= 3.0 { "met" } else { "missed" },
        p50("raw_iceoryx2_hop_one_core"),
        p50("unix_socket_hop_one_core"),
    );
    let (any, one) = (
        lat.python_sdk_over_builtin_injector_p50,
        lat.python_sdk_over_builtin_injector_p50_one_core,
    );
    let _ = writeln!(
        md,
        "Injector SDKs: the built-in injector is written on the Rust SDK (`platoon_runtime::injector`), so its hop is the Rust SDK's (1.0x by construction). The Python SDK's `bridge/examples/dos_jammer.py` in the same scenario, with the nodes on one core (`--cpus`, the `_one_core` rows): **{one:.2}x** the built-in hop (p50; target <= 2: {}). With the nodes on any CPU: **{any:.2}x** ({}).\n",
        if one <= 2.0 { "met" } else { "missed: each step crosses into Python and copies the batch through ctypes" },
        if any <= 2.0 {
            "within the target too"
        } else {
            "what the one-core rows do not pay is the wake-up of a process on the other core; `platoon run --cpus 0` avoids it"
        }
    );
    let _ = writeln!(
        md,
        "## Step cost against size (`platoon bench step`)\n\n{}",
        measured("bench step")
    );
    let _ = writeln!(md, "Platoons of 4 followers (PF, dynamic ETM, no DoS), 5 simulated seconds per case, dt = 0.01 s, every case run in 3 rounds (interleaved). p50 µs per step, each figure the median over the rounds:\n");
    let _ = writeln!(md, "Modes ending in -1cpu run the nodes on one core (`platoon run --cpus`). Peak RSS is the sum over every process of the run (`platoon run` and its nodes; `timing.json` has each), in MiB.\n");
    let _ = writeln!(md, "| mode | followers | vehicles | step | x real time | plant | controller | injector | SUMO step | bridge | SUMO step, tight loop | bridge, tight loop | peak RSS |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let f = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.1}"));
    for r in &steps {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.1} | {:.1} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.mode,
            r.followers,
            r.vehicles,
            r.step_p50_us,
            r.real_time_factor,
            f(r.plant_p50_us),
            f(r.controller_p50_us),
            f(r.injector_p50_us),
            f(r.sumo_step_p50_us),
            f(r.bridge_p50_us),
            f(r.sumo_step_tight_p50_us),
            f(r.bridge_tight_p50_us),
            f(r.peak_rss_mib)
        );
    }
    let find = |mode: &str, n: usize| steps.iter().find(|r| r.mode == mode && r.followers == n);
    let met = |ok: bool| if ok { "met" } else { "missed" };
    for (sumo, native, label) in [
        ("sumo", "native", "nodes on any CPU"),
        ("sumo-1cpu", "native-1cpu", "nodes on one core"),
    ] {
        if let Some(big) = find(sumo, 1000) {
            let s = big.sumo_step_p50_us.unwrap_or(f64::NAN);
            let ours = big.step_p50_us - s;
            let floor = big.bridge_tight_p50_us.unwrap_or(f64::NAN);
            let _ = writeln!(
                md,
                "\nN = 1000 with SUMO, {label}: {:.1}x real time (target >= 2: {}); our overhead {:.0} µs = {:.0} % of SUMO's step (target <= 30 %: {}); of it, {:.0} µs ({:.0} % of SUMO's step) is the bridge's work that remains with no co-simulation around it (the tight loop: one libsumo call per vehicle to set its acceleration and two to read it back).",
                big.real_time_factor,
                met(big.real_time_factor >= 2.0),
                ours,
                100.0 * ours / s,
                met(ours <= 0.3 * s),
                floor,
                100.0 * floor / s,
            );
        }
        if let (Some(small), Some(nat)) = (find(sumo, 4), find(native, 4)) {
            let x = small.step_p50_us / nat.step_p50_us;
            let _ = writeln!(
                md,
                "\n5 vehicles, {label}: the SUMO co-simulation step is {x:.1}x the native one ({:.1} against {:.1} µs; target <= 3: {}). SUMO's own step: {} µs in the co-simulation, {} µs in the tight loop.",
                small.step_p50_us,
                nat.step_p50_us,
                met(x <= 3.0),
                f(small.sumo_step_p50_us),
                f(small.sumo_step_tight_p50_us),
            );
        }
    }
    let _ = writeln!(md);
    let _ = writeln!(
        md,
        "The scaling plot with the least-squares lines is runs/bench/step/step.png.\n"
    );
    peers_section(&mut md, &peer_rows, &ratios);
    // What was measured by hand (a `### ... (measured by hand` subsection of the report being
    // replaced) is carried over: no run of `bench all` drops it.
    let previous = std::fs::read_to_string(&a.markdown).unwrap_or_default();
    md.push_str(&hand_sections(&previous));
    let _ = writeln!(md, "## LMI design time (`platoon bench design`)\n\n{}\n| followers (TPSF) | seconds | SDPs | beta1/beta2 | certificate | designed on |\n|---|---|---|---|---|---|", measured("bench design"));
    for r in &designs {
        let _ = writeln!(
            md,
            "| {} | {:.2} | {} | {} | {} | {} |",
            r.followers,
            r.seconds,
            r.sdps,
            r.beta1_over_beta2
                .map_or("infeasible".into(), |x| format!("{x:.1}")),
            r.certificate.as_deref().unwrap_or("-"),
            r.designed_on.map_or("-".into(), |n| n.to_string())
        );
    }
    let _ = writeln!(md, "\nTargets: under 1 s for N = 4, under 30 s for N = 20.");
    let _ = writeln!(
        md,
        "\nThe checks of `design check-gain` for the paper's K on PLF (the LMIs at the nominal tau; \
         the closed-loop spectrum at 51 taus and string stability at the smallest, nominal and \
         largest tau of the paper's range):\n\n\
         | followers (PLF) | common P (s) | ratio | one P per follower (s) | ratio | largest decay (s) | spectrum (s) | string stability (s) | all (s) |\n|---|---|---|---|---|---|---|---|---|"
    );
    let ratio = |x: Option<f64>| x.map_or("infeasible".to_string(), |x| format!("{x:.1}"));
    for r in &checks {
        let _ = writeln!(
            md,
            "| {} | {:.2} | {} | {:.2} | {} | {:.2} | {:.2} | {:.2} | {:.2} |",
            r.followers,
            r.common_s,
            ratio(r.common_ratio),
            r.block_diagonal_s,
            ratio(r.block_diagonal_ratio),
            r.max_decay_s,
            r.spectrum_s,
            r.string_stability_s,
            r.total_s
        );
    }
    if let Some(e) = growth_exponent(&checks) {
        let _ = writeln!(
            md,
            "\nThe check time grows as N^{e:.2} (least squares on log-log). Target: under 60 s for N = 100."
        );
    }
    let _ = writeln!(
        md,
        "\n## Campaign throughput (`platoon bench campaign`)\n\n{}",
        measured("bench campaign")
    );
    let _ = writeln!(
        md,
        "The paper scenario with a random admissible DoS schedule per cell, in process, metrics only, \
         no plots; wall time as campaign.json reports it (start-up, per-cell records and cells.csv \
         included). The Dask rows send the same cells to a scheduler and two single-threaded workers \
         on 127.0.0.1, beside the local pool with two jobs: in batches run in the workers' processes \
         on the platoon package's core, then (`PLATOON_DASK_IN_WORKER=0`) with a \
         `platoon campaign-cell` process per cell on its worker.\n"
    );
    let _ = writeln!(md, "| executor | cells | wall (s) | CPU (s) | cells/s | ms per cell |\n|---|---|---|---|---|---|");
    for r in &campaigns {
        let _ = writeln!(
            md,
            "| {} | {} | {:.2} | {:.2} | {:.0} | {:.2} |",
            r.executor, r.cells, r.wall_s, r.cpu_s, r.cells_per_s, r.ms_per_cell
        );
    }
    if let Some(r) = campaigns
        .iter()
        .find(|r| r.part == "throughput" && r.workers == 2)
    {
        let _ = writeln!(
            md,
            "\n1000 cells on 2 jobs: {:.2} s (target <= 10 s: {}).",
            r.wall_s,
            if r.wall_s <= 10.0 { "met" } else { "missed" }
        );
    }
    let channel: Vec<&CampaignRow> = campaigns.iter().filter(|r| r.part == "channel").collect();
    if let [bernoulli, radio] = channel[..] {
        let ratio = radio.ms_per_cell / bernoulli.ms_per_cell;
        let _ = writeln!(
            md,
            "A cell on the 802.11p channel costs {:.2} ms against {:.2} ms with Bernoulli loss \
             ({ratio:.2}x; target within 2x: {}).",
            radio.ms_per_cell,
            bernoulli.ms_per_cell,
            if ratio <= 2.0 { "met" } else { "missed" }
        );
    }
    let dask: Vec<&CampaignRow> = campaigns.iter().filter(|r| r.part == "dask").collect();
    if let [local, in_worker, process] = dask[..] {
        let ratio = in_worker.ms_per_cell / local.ms_per_cell;
        let _ = writeln!(
            md,
            "Through Dask a cell costs {:.2} ms of wall time in the workers' processes against \
             {:.2} ms in the local pool ({ratio:.2}x; target <= 1.5x: {}), and {:.2} ms ({:.1}x) \
             with a process per cell.",
            in_worker.ms_per_cell,
            local.ms_per_cell,
            if ratio <= 1.5 { "met" } else { "missed" },
            process.ms_per_cell,
            process.ms_per_cell / local.ms_per_cell
        );
        let fifth: Vec<&CampaignRow> = campaigns
            .iter()
            .filter(|r| r.part == "dask-fifth")
            .collect();
        if let [local_fifth, in_worker_fifth] = fifth[..] {
            // ms per cell between the two sizes, and what is left at zero cells (s).
            let slope = |big: &CampaignRow, small: &CampaignRow| {
                (big.wall_s - small.wall_s) / (big.cells - small.cells) as f64 * 1e3
            };
            let fixed = |big: &CampaignRow, ms: f64| big.wall_s - ms * 1e-3 * big.cells as f64;
            let (l, d) = (slope(local, local_fifth), slope(in_worker, in_worker_fifth));
            let ratio = d / l;
            let _ = writeln!(
                md,
                "Per cell beyond the fixed start-up (the slope between {} and {} cells): {d:.2} ms \
                 through Dask in the workers against {l:.2} ms in the local pool ({ratio:.2}x; \
                 target <= 1.5x: {}). Dask's fixed cost, the driver's start (a Python process \
                 importing distributed) and its connection, is {:.2} s against the local pool's \
                 {:.2} s.",
                in_worker_fifth.cells,
                in_worker.cells,
                if ratio <= 1.5 { "met" } else { "missed" },
                fixed(in_worker, d),
                fixed(local, l)
            );
        }
    }
    let _ = writeln!(
        md,
        "\n## Worst-case DoS search (`platoon bench search`)\n\n{}",
        measured("bench search")
    );
    let _ = writeln!(
        md,
        "`platoon search`'s search alone (no baselines, no figures) on the paper scenario under its \
         Assumption 2, in process; wall time as search.json reports it (proposing, certifying, \
         running and measuring every candidate).\n"
    );
    let _ = writeln!(
        md,
        "| jobs | evaluations | wall (s) | evaluations/s | ms per evaluation | largest spacing error found (m) |\n|---|---|---|---|---|---|"
    );
    for r in &searches {
        let _ = writeln!(
            md,
            "| {} | {} | {:.2} | {:.0} | {:.2} | {:.2} |",
            r.jobs, r.evaluations, r.wall_s, r.evaluations_per_s, r.ms_per_evaluation, r.harm
        );
    }
    if let Some(r) = searches.iter().find(|r| r.jobs == 2) {
        let _ = writeln!(
            md,
            "\n1000 evaluations on 2 jobs: {:.2} s (target < 5 s: {}).",
            r.wall_s,
            if r.wall_s < 5.0 { "met" } else { "missed" }
        );
    }
    // Written whole or not at all: a killed run leaves the previous report.
    let partial = a.markdown.with_extension("md.partial");
    std::fs::write(&partial, md)
        .and_then(|()| std::fs::rename(&partial, &a.markdown))
        .with_context(|| format!("writing {}", a.markdown.display()))?;
    println!("wrote {}", a.markdown.display());
    Ok(())
}

/// The subsections of a report measured by hand (a `### ` heading that says "(measured by
/// hand"), each up to the next heading of level 2 or 3, in order.
fn hand_sections(report: &str) -> String {
    let mut out = String::new();
    let mut keep = false;
    for line in report.lines() {
        if line.starts_with("## ") || line.starts_with("### ") {
            keep = line.starts_with("### ") && line.contains("(measured by hand");
        }
        if keep {
            out.push_str(line);
            out.push('\n');
        }
    }
    if !out.is_empty() && !out.ends_with("\n\n") {
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_measured_subsections_are_carried_over_and_nothing_else() {
        let old = "# Benchmarks\n\nintro\n\n## Step cost\n\n| generated |\n\n\
                   ### The loop in C++ (measured by hand, not by `platoon bench`)\n\nfig 1\n\n\
                   ### SUMO's FCD (measured by hand, not by `platoon bench`)\nfig 2\n\
                   ## LMI design time\n\n| generated |\n### Other\nno\n";
        assert_eq!(
            hand_sections(old),
            "### The loop in C++ (measured by hand, not by `platoon bench`)\n\nfig 1\n\n\
             ### SUMO's FCD (measured by hand, not by `platoon bench`)\nfig 2\n\n"
        );
        assert_eq!(hand_sections("# Benchmarks\n## A\n### B\n"), "");
    }

    /// The stamp of BENCHMARKS.md: a short hash (with a note when the tree differs from it), or
    /// "unknown" where git or the source tree is missing.
    #[test]
    fn the_commit_is_a_short_hash_or_unknown() {
        let c = commit();
        let hash = c.split(' ').next().unwrap_or_default();
        assert!(
            c == "unknown"
                || (hash.len() >= 7
                    && hash.chars().all(|x| x.is_ascii_hexdigit())
                    && [hash.to_string(), format!("{hash} + uncommitted changes")].contains(&c)),
            "{c}"
        );
    }

    /// `guest_halt_poll_ns` is reported as read, never assumed.
    #[test]
    fn halt_polling_is_reported_as_read() {
        assert!(describe_halt_poll(Some("0")).contains("= 0, read from"));
        assert!(describe_halt_poll(Some("200000")).contains("poll up to 200000 ns"));
        assert!(describe_halt_poll(None).contains("not readable here"));
        let read = describe_halt_poll(guest_halt_poll_ns().as_deref());
        match std::fs::read_to_string(HALT_POLL) {
            Ok(v) => assert!(read.contains(&format!("= {},", v.trim())), "{read}"),
            Err(_) => assert!(read.contains("not readable here"), "{read}"),
        }
    }
}
