//! `platoon bench`: the arguments of each benchmark (the harness and its defaults are
//! `platoon_bench`'s).
use crate::outdir::OutDir;
use crate::Result;
use platoon_bench::{All, Campaign, Design, Latency, Search, Security, Step};
use std::path::PathBuf;

/// Benchmarks.
#[derive(Debug, clap::Subcommand)]
pub(crate) enum Bench {
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
    /// What signed V2V (`[security]`, docs/security.md) costs, as a ratio to the same run
    /// unsigned: the paper's scenario with every packet verified (`policy = "every"`) on each
    /// transport, and a fleet on SUMO with verify-on-demand (`policy = "on_demand"`) over
    /// iceoryx2, with its real-time factor.
    ///
    /// Method: each case runs unsigned and signed one right after the other, the pair's order
    /// alternating from round to round; a round's ratio is its signed run over its unsigned
    /// one, the tables give the medians over the rounds. Figures: `platoon run`'s wall time,
    /// timing.json's step p50 (the real-time factor is dt over it) and its `sign` and `verify`
    /// stages, summary.json's counts. Writes security.csv (every run) and security.json (the
    /// medians and ratios). Not part of `bench all`.
    Security(SecurityArgs),
    /// Every benchmark above with its defaults, and BENCHMARKS.md (method, machine, figures).
    All(AllArgs),
}

/// Arguments of `platoon bench latency`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/bench-latency]")))]
pub(crate) struct LatencyArgs {
    /// Scenario config (TOML) [default: the embedded configs/paper.toml].
    pub config: Option<PathBuf>,
    /// Measured ping-pongs per method.
    #[arg(long, default_value_t = Latency::default().iterations)]
    pub iterations: usize,
    /// Ping-pongs before measuring.
    #[arg(long, default_value_t = Latency::default().warmup)]
    pub warmup: usize,
    /// Also measure busy-polling iceoryx2 (burns a core per process; on 2 cores with more
    /// processes it collapses).
    #[arg(long)]
    pub busy_poll: bool,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon bench step`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/bench-step]")))]
pub(crate) struct StepArgs {
    /// Numbers of followers (multiples of 4: platoons of 4 followers).
    #[arg(long, value_delimiter = ',', default_values_t = Step::default().followers)]
    pub followers: Vec<usize>,
    /// Transports and plants to measure: inproc, native (iceoryx2), sumo (iceoryx2 + SUMO), and
    /// native-1cpu, sumo-1cpu: the same with the nodes on one core (`platoon run --cpus`);
    /// sumo-traffic: sumo with traffic that touches every platoon (a car cutting in ahead of
    /// each platoon's follower 3, handled by [fallback.cut_in], and one SUMO background vehicle
    /// per 5 followers changing lanes among the platoons).
    #[arg(long, value_delimiter = ',', default_values_t = Step::default().modes)]
    pub modes: Vec<String>,
    /// Simulated seconds per case.
    #[arg(long, default_value_t = Step::default().seconds)]
    pub seconds: f64,
    /// Skip the peers: after each `sumo` case, the same fleet driven by SUMO itself
    /// (`bridge/tools/bench_peers.py`: SUMO's Krauss model, Plexe's ACC and auto-fed CACC inside
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
    #[arg(long, default_value_t = Step::default().rounds, value_parser = clap::value_parser!(u32).range(1..))]
    pub rounds: u32,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon bench design`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/bench-design]")))]
pub(crate) struct DesignArgs {
    /// Numbers of followers of the designs.
    #[arg(long, value_delimiter = ',', default_values_t = Design::default().followers)]
    pub followers: Vec<usize>,
    /// Numbers of followers of the checks (PLF, the paper's K).
    #[arg(long, value_delimiter = ',', default_values_t = Design::default().check_followers)]
    pub check_followers: Vec<usize>,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon bench campaign`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/bench-campaign]")))]
pub(crate) struct CampaignArgs {
    /// Cells of the local runs.
    #[arg(long, default_value_t = Campaign::default().cells)]
    pub cells: usize,
    /// Local pool sizes to measure.
    #[arg(long, value_delimiter = ',', default_values_t = Campaign::default().jobs)]
    pub jobs: Vec<usize>,
    /// Cells sent through Dask (0: skip Dask); each way of running them pays about a second to
    /// start the Python driver and its client, so fewer cells measure mostly that.
    #[arg(long, default_value_t = Campaign::default().dask_cells)]
    pub dask_cells: usize,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon bench search`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/bench-search]")))]
pub(crate) struct SearchArgs {
    /// Evaluations of the search.
    #[arg(long, default_value_t = Search::default().evaluations)]
    pub evaluations: usize,
    /// Local pool sizes to measure.
    #[arg(long, value_delimiter = ',', default_values_t = Search::default().jobs)]
    pub jobs: Vec<usize>,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon bench security`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/bench-security]")))]
pub(crate) struct SecurityArgs {
    /// Rounds of the paper's scenario (each an unsigned and a signed run per transport).
    #[arg(long, default_value_t = Security::default().rounds, value_parser = clap::value_parser!(u32).range(1..))]
    pub rounds: u32,
    /// Transports of the paper's scenario: inproc, iceoryx2.
    #[arg(long, value_delimiter = ',', default_values_t = Security::default().transports)]
    pub transports: Vec<String>,
    /// Vehicles of the SUMO fleet, a multiple of 5 (platoons of 4 followers); 0: no fleet.
    #[arg(long, default_value_t = Security::default().fleet_vehicles)]
    pub fleet_vehicles: usize,
    /// Simulated seconds of each fleet run.
    #[arg(long, default_value_t = Security::default().fleet_seconds)]
    pub fleet_seconds: f64,
    /// Rounds of the fleet (each an unsigned and a signed run).
    #[arg(long, default_value_t = Security::default().fleet_rounds, value_parser = clap::value_parser!(u32).range(1..))]
    pub fleet_rounds: u32,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon bench all`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/bench]")))]
pub(crate) struct AllArgs {
    #[command(flatten)]
    pub output: OutDir,
    /// Where to write the report.
    #[arg(long, default_value_os_t = All::default().markdown)]
    pub markdown: PathBuf,
}

/// Runs one benchmark.
pub(crate) fn run(b: Bench) -> Result<()> {
    if let Bench::Latency(LatencyArgs {
        config: Some(path), ..
    }) = &b
    {
        // Refused as every bad config is (exit 2), before the harness (whose errors are
        // anyhow's) runs.
        platoon_config::load(path)?;
    }
    Ok(match b {
        Bench::Latency(a) => platoon_bench::latency(a.into()).map(|_| ()),
        Bench::Step(a) => platoon_bench::step(a.into()).map(|_| ()),
        Bench::Design(a) => platoon_bench::design(a.into()).map(|_| ()),
        Bench::Campaign(a) => platoon_bench::campaign(a.into()).map(|_| ()),
        Bench::Search(a) => platoon_bench::search(a.into()).map(|_| ()),
        Bench::Security(a) => platoon_bench::security(a.into()).map(|_| ()),
        Bench::All(a) => platoon_bench::all(a.into()),
    }?)
}

impl From<LatencyArgs> for Latency {
    fn from(a: LatencyArgs) -> Self {
        Self {
            config: a.config,
            iterations: a.iterations,
            warmup: a.warmup,
            busy_poll: a.busy_poll,
            out: a.output.out,
            force: a.output.force,
        }
    }
}

impl From<StepArgs> for Step {
    fn from(a: StepArgs) -> Self {
        Self {
            followers: a.followers,
            modes: a.modes,
            seconds: a.seconds,
            no_peers: a.no_peers,
            rounds: a.rounds,
            out: a.output.out,
            force: a.output.force,
        }
    }
}

impl From<DesignArgs> for Design {
    fn from(a: DesignArgs) -> Self {
        Self {
            followers: a.followers,
            check_followers: a.check_followers,
            out: a.output.out,
            force: a.output.force,
        }
    }
}

impl From<CampaignArgs> for Campaign {
    fn from(a: CampaignArgs) -> Self {
        Self {
            cells: a.cells,
            jobs: a.jobs,
            dask_cells: a.dask_cells,
            out: a.output.out,
            force: a.output.force,
        }
    }
}

impl From<SearchArgs> for Search {
    fn from(a: SearchArgs) -> Self {
        Self {
            evaluations: a.evaluations,
            jobs: a.jobs,
            out: a.output.out,
            force: a.output.force,
        }
    }
}

impl From<SecurityArgs> for Security {
    fn from(a: SecurityArgs) -> Self {
        Self {
            rounds: a.rounds,
            transports: a.transports,
            fleet_vehicles: a.fleet_vehicles,
            fleet_seconds: a.fleet_seconds,
            fleet_rounds: a.fleet_rounds,
            out: a.output.out,
            force: a.output.force,
        }
    }
}

impl From<AllArgs> for All {
    fn from(a: AllArgs) -> Self {
        Self {
            out: a.output.out,
            force: a.output.force,
            markdown: a.markdown,
        }
    }
}
