//! `platoon campaign`: many cells of one scenario, in a local worker pool or on a Dask cluster,
//! into one campaign directory that an interrupted run resumes.
pub mod exec;
mod report;

use crate::signals::Interrupt;
use anyhow::{Context, Result};
use exec::{CellJob, CellReply};
use platoon_campaign::{metrics, Campaign, Cell};
use platoon_output::rundir::RunDir;
use report::{Outcome, RunInfo, Table};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Instant;

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
    /// Cells run at once by the local pool [default: the number of cores].
    #[arg(long, short = 'j')]
    pub jobs: Option<std::num::NonZeroUsize>,
    /// Send the cells to a running Dask scheduler (e.g. tcp://10.0.0.5:8786) instead of the
    /// local pool; the workers run this same platoon binary (see the README).
    #[arg(long, value_name = "ADDRESS")]
    pub dask: Option<String>,
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

fn cpu_seconds() -> f64 {
    let mut total = 0.0;
    for who in [libc::RUSAGE_SELF, libc::RUSAGE_CHILDREN] {
        // SAFETY: getrusage fills the struct we own.
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        if unsafe { libc::getrusage(who, &mut u) } == 0 {
            for t in [u.ru_utime, u.ru_stime] {
                total += t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
            }
        }
    }
    total
}

/// The record of a finished cell: `cells/<cNNNN>/{config.toml, summary.json, cell.json}`,
/// written atomically (cell.json identifies it when the campaign resumes).
fn write_cell(staging: &Path, campaign: &Campaign, cell: &Cell, outcome: &Outcome) -> Result<()> {
    let dir = RunDir::create(
        &staging
            .join("cells")
            .join(cell.dir_name(campaign.cells.len())),
        true,
    )?;
    if let Ok(config) = &cell.config {
        dir.write("config.toml", config.as_bytes())?;
    }
    if let Some(s) = &outcome.summary {
        dir.write(
            "summary.json",
            (serde_json::to_string_pretty(s)? + "\n").as_bytes(),
        )?;
    }
    let record = json!({
        "cell": cell.index,
        "hash": cell.hash,
        "status": if outcome.ok { "ok" } else { "failed" },
        "error": outcome.error,
        "sample": cell.sample,
        "seed": cell.seed,
    });
    dir.write(
        "cell.json",
        (serde_json::to_string_pretty(&record)? + "\n").as_bytes(),
    )?;
    dir.commit()?;
    Ok(())
}

/// A cell finished by an earlier run of this campaign, if its record matches.
fn finished_before(staging: &Path, campaign: &Campaign, cell: &Cell) -> Option<Outcome> {
    let dir = staging
        .join("cells")
        .join(cell.dir_name(campaign.cells.len()));
    let record: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("cell.json")).ok()?).ok()?;
    if record["hash"].as_str() != Some(cell.hash.as_str()) || record["status"] != "ok" {
        return None;
    }
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).ok()?).ok()?;
    metrics::read(&summary).ok()?;
    Some(Outcome {
        ok: true,
        error: None,
        summary: Some(summary),
        reused: true,
    })
}

/// Removes what an earlier version of the campaign left under cells/ and runs/ that no cell of
/// this one owns (and unfinished cell directories), saying how many.
fn prune(staging: &Path, campaign: &Campaign) -> Result<()> {
    let names: std::collections::HashSet<String> = campaign
        .cells
        .iter()
        .map(|c| c.dir_name(campaign.cells.len()))
        .collect();
    let mut removed = 0;
    for sub in ["cells", "runs"] {
        let Ok(entries) = std::fs::read_dir(staging.join(sub)) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if !names.contains(&name) {
                std::fs::remove_dir_all(e.path())
                    .with_context(|| format!("removing {}", e.path().display()))?;
                removed += usize::from(!name.ends_with(".partial") && !name.ends_with(".old"));
            }
        }
    }
    if removed > 0 {
        eprintln!(
            "removed {removed} cell directories of an earlier version of this campaign from {}",
            staging.display()
        );
    }
    Ok(())
}

fn progress(total: u64, done: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} cells {pos}/{len} [{elapsed} elapsed, ETA {eta}] {wide_bar} {msg}",
        )
        .expect("static template"),
    );
    bar.set_position(done);
    bar.reset_eta();
    bar
}

pub fn run(args: Args) -> Result<()> {
    let campaign = Campaign::load(&args.campaign, args.samples)?;
    let jobs = args
        .jobs
        .or_else(|| std::thread::available_parallelism().ok())
        .map_or(1, |n| n.get());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(&campaign.name));
    if campaign.cells.iter().any(|c| c.plant == "sumo") {
        platoon_app::sumo::ensure_venv()?;
    }
    let interrupt = Interrupt::install(
        "stopping: no new cells start; the cells in flight finish or are dropped",
    )?;
    let started = Instant::now();
    let cpu0 = cpu_seconds();
    let (dir, resumed) = RunDir::resumable(&out, args.force)?;
    let staging = dir.staging().to_path_buf();
    dir.write("campaign.toml", campaign.resolved_toml().as_bytes())?;
    dir.write("base.toml", campaign.base_toml.as_bytes())?;
    if resumed {
        prune(&staging, &campaign)?;
    }

    // What is already done, what cannot run, what to run.
    let mut outcomes: Vec<Option<Outcome>> = vec![None; campaign.cells.len()];
    let mut pending = Vec::new();
    for cell in &campaign.cells {
        match &cell.config {
            Err(e) => {
                let o = Outcome {
                    ok: false,
                    error: Some(format!("invalid scenario: {e}")),
                    summary: None,
                    reused: false,
                };
                write_cell(&staging, &campaign, cell, &o)?;
                outcomes[cell.index] = Some(o);
            }
            Ok(config) => {
                if resumed {
                    if let Some(o) = finished_before(&staging, &campaign, cell) {
                        outcomes[cell.index] = Some(o);
                        continue;
                    }
                }
                pending.push(CellJob {
                    index: cell.index,
                    config: config.clone(),
                    transport: campaign.spec.transport,
                    keep: args.keep_runs.then(|| {
                        std::path::absolute(
                            staging
                                .join("runs")
                                .join(cell.dir_name(campaign.cells.len())),
                        )
                        .unwrap_or_default()
                    }),
                });
            }
        }
    }
    let reused = outcomes.iter().flatten().filter(|o| o.reused).count();
    let executor = match &args.dask {
        Some(a) => format!("dask {a}"),
        None => format!("local pool, {jobs} jobs"),
    };
    eprintln!(
        "campaign {}: {} cells ({} to run{}), {}, transport {}",
        campaign.name,
        campaign.cells.len(),
        pending.len(),
        if resumed {
            format!(
                ", {reused} finished before and kept from {}",
                staging.display()
            )
        } else {
            String::new()
        },
        executor,
        campaign.spec.transport.name()
    );
    let bar = progress(
        campaign.cells.len() as u64,
        (campaign.cells.len() - pending.len()) as u64,
    );
    let mut failed_now = 0usize;
    let mut record = |reply: CellReply| -> Result<()> {
        let Some(cell) = campaign.cells.get(reply.index) else {
            anyhow::bail!(
                "a worker replied for cell {}, which this campaign does not have",
                reply.index
            );
        };
        let outcome = match (reply.summary, reply.error) {
            (Some(s), _) => {
                let why =
                    metrics::read(&s).and_then(|run| metrics::failure(&run).map_or(Ok(()), Err));
                Outcome {
                    ok: why.is_ok(),
                    error: why.err(),
                    summary: Some(s),
                    reused: false,
                }
            }
            (None, e) => Outcome {
                ok: false,
                error: Some(e.unwrap_or_else(|| "no result".into())),
                summary: None,
                reused: false,
            },
        };
        if !outcome.ok && interrupt.stop.load(Ordering::SeqCst) {
            return Ok(()); // most likely stopped by the same signal: left to the next run
        }
        if !outcome.ok {
            failed_now += 1;
            bar.set_message(format!("{failed_now} failed"));
        }
        write_cell(&staging, &campaign, cell, &outcome)?;
        outcomes[cell.index] = Some(outcome);
        bar.inc(1);
        Ok(())
    };
    let executed = match &args.dask {
        None => exec::local_pool(&pending, jobs, &interrupt.stop, &mut record),
        Some(address) => exec::dask(
            address,
            &pending,
            &staging.join("dask.log"),
            &interrupt.driver,
            &mut record,
        ),
    };
    bar.finish_and_clear();

    // Reports, then the directory goes into place (unless interrupted: it stays .partial).
    let table = Table::new(&campaign, &outcomes);
    report::cells_csv(&dir.path("cells.csv"), &table, &outcomes)?;
    let interrupted = interrupt.signal();
    let complete =
        interrupted.is_none() && executed.is_ok() && outcomes.iter().all(|o| o.is_some());
    let plots = if args.no_plots || !complete {
        Vec::new()
    } else {
        report::plots(&dir.path("plots"), &table)?
    };
    let info = RunInfo {
        complete,
        interrupted: interrupted.map(|s| {
            if s == libc::SIGINT {
                "SIGINT"
            } else {
                "SIGTERM"
            }
        }),
        executor,
        wall_s: started.elapsed().as_secs_f64(),
        cpu_s: cpu_seconds() - cpu0,
        plots,
    };
    let summary = report::campaign_json(&table, &outcomes, &info);
    dir.write(
        "campaign.json",
        (serde_json::to_string_pretty(&summary)? + "\n").as_bytes(),
    )?;
    let done = outcomes.iter().filter(|o| o.is_some()).count();
    if let Some(sig) = interrupted {
        eprintln!(
            "interrupted: {done} of {} cells are done and kept in {}; run the same command again to resume",
            campaign.cells.len(),
            staging.display()
        );
        std::process::exit(crate::signals::exit_code(sig));
    }
    if let Err(e) = executed {
        eprintln!(
            "{done} of {} cells are done and kept in {}; run the same command again to resume",
            campaign.cells.len(),
            staging.display()
        );
        return Err(e);
    }
    let path = dir.commit()?;
    let failed = summary["failed"].as_u64().unwrap_or(0);
    println!(
        "{} cells: {} ok, {failed} failed{}, in {:.1} s ({:.1} s CPU)",
        campaign.cells.len(),
        summary["ok"],
        if reused > 0 {
            format!(" ({reused} kept from the interrupted run)")
        } else {
            String::new()
        },
        info.wall_s,
        info.cpu_s
    );
    println!("outputs: {}", path.display());
    if failed > 0 {
        anyhow::bail!(
            "{failed} of {} cells failed; campaign.json lists them with their errors",
            campaign.cells.len()
        );
    }
    Ok(())
}
