//! `platoon campaign` and the hidden `platoon campaign-cell`: the arguments, the signals, what
//! is printed and the exit codes; the campaign itself is [`platoon_app::campaign`].
use crate::{bail, Result};
use anyhow::Context;
use platoon_app::campaign::{CampaignOptions, CellJob, CellStatus, Dask, Executor, LocalPool};
use platoon_app::Stop;
use platoon_campaign::Campaign;
use std::path::PathBuf;

/// Arguments of `platoon campaign` (the help text is on the command in main.rs).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The campaign file (TOML; see campaigns/ for commented examples).
    pub campaign: PathBuf,
    /// Campaign directory [default: runs/<campaign name>]. An unfinished `<DIR>.partial` from
    /// an interrupted run is resumed: cells finished with the same resolved config are kept.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Start over: discard an unfinished `<DIR>.partial` and replace a finished `<DIR>` when
    /// this run completes.
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub executor: Executors,
    /// Keep every cell's full run outputs (trajectories.csv, events.csv, ...) under runs/;
    /// without it each cell keeps its config.toml and summary.json only.
    #[arg(long)]
    pub keep_runs: bool,
    /// Override `monte_carlo.samples` (a quick pilot of a large study).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Skip the PNG plots.
    #[arg(long)]
    pub no_plots: bool,
}

pub fn run(args: Args) -> Result<()> {
    let campaign = Campaign::load(&args.campaign, args.samples)?;
    let executor = args.executor.build();
    let out = out_dir(args.out.clone(), &campaign.name);
    let (interrupt, stop) =
        stop_on_signal("stopping: no new cells start; the cells in flight finish or are dropped")?;
    let opts = CampaignOptions {
        force: args.force,
        keep_runs: args.keep_runs,
        plots: !args.no_plots,
    };
    let bar = crate::progress::Bar::cells();
    let outcome = platoon_app::campaign::run(&campaign, &out, &opts, &*executor, &stop, &bar)?;
    let cells = campaign.cells.len();
    let done = cells - outcome.count(CellStatus::NotRun);
    if outcome.stopped.is_some() {
        interrupt.exit(&format!(
            "interrupted: {done} of {cells} cells are done and kept in {}; run the same command again to resume",
            outcome.dir.display()
        ));
    }
    if let Some(e) = outcome.failure {
        eprintln!(
            "{done} of {cells} cells are done and kept in {}; run the same command again to resume",
            outcome.dir.display()
        );
        return Err(e.into());
    }
    let (failed, reused) = (outcome.report.failed, outcome.reused());
    println!(
        "{cells} cells: {} ok, {failed} failed{}, in {:.1} s ({:.1} s CPU)",
        outcome.report.ok,
        if reused > 0 {
            format!(" ({reused} kept from the interrupted run)")
        } else {
            String::new()
        },
        outcome.report.wall_s,
        outcome.report.cpu_s
    );
    println!("outputs: {}", outcome.dir.display());
    if failed > 0 {
        bail!("{failed} of {cells} cells failed; campaign.json lists them with their errors");
    }
    Ok(())
}

/// `platoon campaign-cell`: one job as JSON on stdin, its reply as JSON on stdout (what a Dask
/// worker runs). A cell that fails is a reply with an error, not a failed command.
pub fn cell_command() -> Result<()> {
    let mut text = String::new();
    std::io::Read::read_to_string(&mut std::io::stdin(), &mut text)
        .context("reading the cell job from stdin")?;
    let job: CellJob = serde_json::from_str(&text).context("the cell job is not valid JSON")?;
    let reply = platoon_app::campaign::execute(&job, None);
    println!("{}", serde_json::to_string(&reply)?);
    Ok(())
}

/// `--jobs` and `--dask`: what runs the cells of a campaign or the candidates of a search.
#[derive(Debug, clap::Args)]
pub struct Executors {
    /// Runs at once in the local pool (a campaign's cells, a search's candidates) [default: the
    /// number of cores].
    #[arg(long, short = 'j')]
    pub jobs: Option<std::num::NonZeroUsize>,
    /// Send the runs to a running Dask scheduler (e.g. tcp://10.0.0.5:8786) instead of the
    /// local pool, a batch at a time (a search's generation); the workers run this same
    /// platoon binary (see docs/campaigns.md).
    #[arg(long, value_name = "ADDRESS")]
    pub dask: Option<String>,
}

impl Executors {
    /// The executor of `--dask ADDRESS` (a Dask scheduler), or else a local pool of `--jobs`
    /// workers.
    pub fn build(&self) -> Box<dyn Executor> {
        match &self.dask {
            Some(address) => Box::new(Dask::new(address.clone())),
            None => Box::new(LocalPool::new(self.jobs)),
        }
    }
}

/// The output directory, `--out` or `runs/<name>`.
pub(crate) fn out_dir(out: Option<PathBuf>, name: &str) -> PathBuf {
    out.unwrap_or_else(|| PathBuf::from("runs").join(name))
}

/// The interrupt handler, installed with `message` (printed on the first signal), and the
/// [`Stop`] it triggers, which names the signal.
pub(crate) fn stop_on_signal(
    message: &'static str,
) -> Result<(std::sync::Arc<crate::signals::Interrupt>, Stop)> {
    let interrupt = std::sync::Arc::new(crate::signals::Interrupt::install(message)?);
    let signalled = interrupt.clone();
    let stop = Stop::new(interrupt.stop.clone(), move || {
        signalled
            .signal()
            .map(|sig| crate::signals::name(sig).to_string())
    });
    Ok((interrupt, stop))
}
