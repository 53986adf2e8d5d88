//! Campaigns: many cells of one scenario ([`platoon_campaign`] decides what each cell is),
//! executed by any [`Executor`] (the [`LocalPool`] of worker threads, a Dask cluster through
//! [`Dask`], or the caller's own), recorded into one campaign directory that an interrupted run
//! resumes.
//!
//! [`run`] returns every cell's typed result (its [`Summary`] and its metrics) and the report
//! ([`Report`], what `campaign.json` holds) in memory, and writes files only into the campaign
//! directory the caller names: `campaign.toml`, `base.toml`, `cells/<cNNNN>/` (each cell's
//! config, summary and record, written atomically as it finishes), `runs/<cNNNN>/` when the
//! cells' full outputs are kept, `cells.csv`, `campaign.json` and `plots/`. Whatever executes the
//! cells only returns each run's `summary.json` ([`CellReply`]); this process alone records them,
//! so every executor gives the same bytes.
mod exec;
mod report;

pub use exec::{
    execute, execute_with, CellJob, CellPlugins, CellReply, Dask, Execution, Executor,
    ExecutorError, LocalCluster, LocalPool,
};
pub use platoon_campaign::metrics::Metric;
pub use platoon_campaign::{Campaign, Cell};
pub use report::{Axis, Failure, Group, Quantiles, Report};

use crate::error::{Context, OtherError};
use crate::progress::Progress;
use crate::run::Stop;
use platoon_campaign::metrics;
use platoon_config::ConfigError;
use platoon_output::error::OutputError;
use platoon_output::rundir::RunDir;
use platoon_sim::Summary;
use report::Table;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Instant;

type Result<T, E = CampaignError> = std::result::Result<T, E>;

/// How [`run`] runs a campaign; [`CampaignOptions::default`] is `platoon campaign`'s default.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CampaignOptions {
    /// Start over: discard an unfinished `<out>.partial` and replace a finished `out` when
    /// this run completes (without it a finished `out` is an error).
    pub force: bool,
    /// Keep every cell's full run outputs (trajectories, events, ...) under `runs/<cNNNN>/`;
    /// otherwise each cell keeps its config.toml and summary.json only.
    pub keep_runs: bool,
    /// Draw the PNG plots (once every cell is done).
    pub plots: bool,
}

impl Default for CampaignOptions {
    fn default() -> Self {
        Self {
            force: false,
            keep_runs: false,
            plots: true,
        }
    }
}

/// What became of a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellStatus {
    /// It ran to the end and its summary is usable.
    Ok,
    /// It has no usable result: an invalid scenario, a run that failed, stopped early or
    /// diverged ([`CellResult::error`] says which).
    Failed,
    /// It did not run (the campaign was stopped or its executor failed first).
    NotRun,
}

impl CellStatus {
    /// `cells.csv`'s spelling: `ok`, `failed` or `not_run`.
    pub fn name(self) -> &'static str {
        match self {
            CellStatus::Ok => "ok",
            CellStatus::Failed => "failed",
            CellStatus::NotRun => "not_run",
        }
    }
}

/// One cell's result (a row of `cells.csv`).
#[derive(Debug, Clone)]
pub struct CellResult {
    /// Ok, failed or not run.
    pub status: CellStatus,
    /// Why it failed.
    pub error: Option<String>,
    /// The run's summary, when it produced one that reads as a summary (a failed cell may
    /// have one: a run that stopped early or diverged).
    pub summary: Option<Summary>,
    /// The campaign's metric values ([`CampaignOutcome::columns`] names them), for ok cells.
    pub metrics: Option<Vec<Metric>>,
    /// Kept from an earlier, unfinished run of the campaign rather than run now.
    pub reused: bool,
    /// The summary as recorded (`summary.json`, with the keys beyond [`Summary`] such as
    /// `injector` and `sumo`).
    json: Option<Value>,
}

impl CellResult {
    fn not_run() -> Self {
        Self {
            status: CellStatus::NotRun,
            error: None,
            summary: None,
            metrics: None,
            reused: false,
            json: None,
        }
    }

    fn failed(error: String) -> Self {
        Self {
            status: CellStatus::Failed,
            error: Some(error),
            ..Self::not_run()
        }
    }

    /// A run's summary: ok, unless it does not read as a summary, stopped early or diverged.
    fn of_summary(campaign: &Campaign, json: Value, reused: bool) -> Self {
        let (summary, why) = match metrics::read(&json) {
            Ok(s) => {
                let why = metrics::failure(&s);
                (Some(s), why)
            }
            Err(e) => (None, Some(e)),
        };
        let metrics = match (&summary, &why) {
            (Some(s), None) => Some(metrics::extract(
                &campaign.metrics,
                campaign.max_followers(),
                s,
            )),
            _ => None,
        };
        Self {
            status: if why.is_none() {
                CellStatus::Ok
            } else {
                CellStatus::Failed
            },
            error: why,
            summary,
            metrics,
            reused,
            json: Some(json),
        }
    }

    /// The summary as `summary.json` holds it, with the keys beyond [`Summary`] (`injector`,
    /// and `sumo` for SUMO cells).
    pub fn summary_json(&self) -> Option<&Value> {
        self.json.as_ref()
    }

    fn done(&self) -> bool {
        self.status != CellStatus::NotRun
    }
}

/// A campaign's run ([`run`]): every cell's result, the report, and where they are.
#[derive(Debug)]
pub struct CampaignOutcome {
    /// The campaign directory: `out` once complete; `<out>.partial` while cells remain (after
    /// a stop or an executor's failure), which the next [`run`] of the same campaign resumes.
    pub dir: PathBuf,
    /// Whether the directory was renamed into place (not when stopped or when the executor
    /// failed).
    pub committed: bool,
    /// Whether an unfinished directory of an earlier run was resumed.
    pub resumed: bool,
    /// Every cell's result, in cell order, whatever order they finished in.
    pub cells: Vec<CellResult>,
    /// The metric columns of `cells.csv` (`triggers_by_follower` expanded), naming the values of
    /// [`CellResult::metrics`].
    pub columns: Vec<String>,
    /// What `campaign.json` holds.
    pub report: Report,
    /// Why the executor stopped before every cell was in (the cells done are recorded and the
    /// directory stays unfinished): [`CampaignError::Executor`], or [`CampaignError::Output`]
    /// when a cell's record could not be written.
    pub failure: Option<CampaignError>,
    /// Why the campaign was stopped, if [`Stop`] asked it to (its reason, e.g. "SIGINT").
    pub stopped: Option<String>,
}

impl CampaignOutcome {
    /// How many cells have `status`.
    pub fn count(&self, status: CellStatus) -> usize {
        self.cells.iter().filter(|c| c.status == status).count()
    }

    /// How many cells were kept from an earlier, unfinished run.
    pub fn reused(&self) -> usize {
        self.cells.iter().filter(|c| c.reused).count()
    }
}

/// Why a campaign failed, by kind: what a caller branches on (the Python package raises one
/// exception class per kind). Each message is the one `platoon campaign` prints. A cell that
/// fails is no error: it is recorded with its error ([`CellStatus::Failed`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CampaignError {
    /// The campaign file is refused ([`Campaign::load`]'s error, for a caller that loads and
    /// runs with one error type; `platoon campaign` exits 2).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The SUMO environment could not be set up for SUMO cells (the bridge, its venv).
    #[error(transparent)]
    Sumo(OtherError),
    /// The campaign directory or one of its records (`out` exists, a cell's record,
    /// `cells.csv`, `campaign.json`).
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The executor stopped before every cell was in: a worker pool's, the Dask driver's or
    /// scheduler's, or the caller's executor's failure ([`CampaignOutcome::failure`]).
    #[error(transparent)]
    Executor(OtherError),
    /// Anything else (a figure that could not be drawn, a directory that could not be pruned).
    #[error(transparent)]
    Other(OtherError),
}

operation_error!(CampaignError);

impl From<ExecutorError> for CampaignError {
    /// A record the executor passed on is the campaign's output; the rest is the executor's.
    fn from(e: ExecutorError) -> Self {
        match e {
            ExecutorError::Output(o) => Self::Output(o),
            ExecutorError::Failed(e) => Self::Executor(e),
        }
    }
}

impl CampaignError {
    /// The config error this is, if it is one (`platoon campaign` exits 2 on it).
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

/// CPU seconds of this process and its waited-for children.
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

/// What is already done (a resumed campaign's finished cells, read back), what cannot run (a
/// cell whose scenario is invalid: recorded as failed) and what to run, as jobs (each with
/// the directory its full outputs go to when `keep_runs`).
fn sort_cells(
    campaign: &Campaign,
    staging: &Path,
    resumed: bool,
    keep_runs: bool,
) -> Result<(Vec<CellResult>, Vec<CellJob>)> {
    let mut outcomes: Vec<CellResult> = vec![CellResult::not_run(); campaign.cells.len()];
    let mut pending = Vec::new();
    for cell in &campaign.cells {
        match &cell.config {
            Err(e) => {
                let o = CellResult::failed(format!("invalid scenario: {e}"));
                write_cell(staging, campaign, cell, &o)?;
                outcomes[cell.index] = o;
            }
            Ok(config) => {
                if resumed {
                    if let Some(o) = finished_before(staging, campaign, cell) {
                        outcomes[cell.index] = o;
                        continue;
                    }
                }
                pending.push(CellJob {
                    index: cell.index,
                    config: config.clone(),
                    transport: campaign.spec.transport,
                    keep: keep_runs.then(|| {
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
    Ok((outcomes, pending))
}

/// The record of a finished cell: `cells/<cNNNN>/{config.toml, summary.json, cell.json}`,
/// written atomically (cell.json identifies it when the campaign resumes).
fn write_cell(
    staging: &Path,
    campaign: &Campaign,
    cell: &Cell,
    outcome: &CellResult,
) -> Result<(), OutputError> {
    let dir = RunDir::create(
        &staging
            .join("cells")
            .join(cell.dir_name(campaign.cells.len())),
        true,
    )?;
    if let Ok(config) = &cell.config {
        dir.write("config.toml", config.as_bytes())?;
    }
    if let Some(s) = &outcome.json {
        dir.write("summary.json", (pretty(s) + "\n").as_bytes())?;
    }
    let record = json!({
        "cell": cell.index,
        "hash": cell.hash,
        "status": if outcome.status == CellStatus::Ok { "ok" } else { "failed" },
        "error": outcome.error,
        "sample": cell.sample,
        "seed": cell.seed,
    });
    dir.write("cell.json", (pretty(&record) + "\n").as_bytes())?;
    dir.commit()?;
    Ok(())
}

/// A JSON value, pretty-printed (a `Value` always is: its keys are strings).
fn pretty(value: &Value) -> String {
    serde_json::to_string_pretty(value).expect("a JSON value prints")
}

/// A cell finished by an earlier run of this campaign, if its record matches.
fn finished_before(staging: &Path, campaign: &Campaign, cell: &Cell) -> Option<CellResult> {
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
    let s = metrics::read(&summary).ok()?;
    // Recorded ok: kept as it was recorded (what it says of failure was read when it ran).
    Some(CellResult {
        status: CellStatus::Ok,
        error: None,
        metrics: Some(metrics::extract(
            &campaign.metrics,
            campaign.max_followers(),
            &s,
        )),
        summary: Some(s),
        reused: true,
        json: Some(summary),
    })
}

/// Removes what an earlier version of the campaign left under cells/ and runs/ that no cell of
/// this one owns (and unfinished cell directories), saying how many.
fn prune(staging: &Path, campaign: &Campaign, progress: &dyn Progress) -> Result<()> {
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
        progress.message(&format!(
            "removed {removed} cell directories of an earlier version of this campaign from {}",
            staging.display()
        ));
    }
    Ok(())
}

/// Runs every cell of `campaign` in this process, one after the other, and returns each
/// cell's result in memory, with no campaign directory: in-process cells touch no file at all
/// (co-simulated ones run as `program run` in a scratch directory that is removed). Once
/// `stop`'s flag is set, the remaining cells are left [`CellStatus::NotRun`]. `progress` hears
/// of the cells ("cells"). What [`run`] adds is the campaign directory: the records, resuming,
/// `cells.csv`, `campaign.json` and the plots.
pub fn evaluate(
    campaign: &Campaign,
    program: Option<&Path>,
    stop: &Stop,
    progress: &dyn Progress,
) -> Vec<CellResult> {
    progress.start("cells", campaign.cells.len() as u64);
    let mut results = Vec::with_capacity(campaign.cells.len());
    for cell in &campaign.cells {
        if stop.flag.load(std::sync::atomic::Ordering::SeqCst) {
            results.push(CellResult::not_run());
            continue;
        }
        let result = match &cell.config {
            Err(e) => CellResult::failed(format!("invalid scenario: {e}")),
            Ok(config) => {
                let job = CellJob {
                    index: cell.index,
                    config: config.clone(),
                    transport: campaign.spec.transport,
                    keep: None,
                };
                let reply = execute(&job, program);
                match (reply.summary, reply.error) {
                    (Some(json), _) => CellResult::of_summary(campaign, json, false),
                    (None, e) => CellResult::failed(e.unwrap_or_else(|| "no result".into())),
                }
            }
        };
        results.push(result);
        progress.at(results.len() as u64);
    }
    progress.finish();
    results
}

/// Runs `campaign` into the campaign directory `out`, its cells executed by `executor`.
///
/// The directory is written as `<out>.partial` and renamed to `out` once the executor is done
/// (a finished `out` is an error unless `opts.force`). An unfinished `<out>.partial` of an
/// earlier run is resumed: its cells recorded ok with the same resolved config are kept, the
/// rest run (with `force` it is discarded). Each cell is recorded as it finishes; a cell that
/// fails is recorded with its error and the campaign goes on.
///
/// Once `stop`'s flag is set, no new cells start; the cells in flight finish (then they are
/// recorded) or fail (then they are left to the next run), `cells.csv` and `campaign.json`
/// say what is done, and the directory stays unfinished. An executor's failure also leaves it
/// unfinished, in [`CampaignOutcome::failure`]. `progress` hears of the cells ("cells"), of
/// failed ones as a detail, and gets the campaign's messages.
///
/// Errors (nothing run): `out` cannot be opened ([`CampaignError::Output`]), the SUMO
/// environment cannot be set up for SUMO cells ([`CampaignError::Sumo`]), a record cannot be
/// written.
pub fn run(
    campaign: &Campaign,
    out: &Path,
    opts: &CampaignOptions,
    executor: &dyn Executor,
    stop: &Stop,
    progress: &dyn Progress,
) -> Result<CampaignOutcome, CampaignError> {
    if campaign
        .cells
        .iter()
        .any(|c| c.plant == Some(platoon_config::PlantKind::Sumo))
    {
        crate::sumo::ensure_venv().map_err(CampaignError::Sumo)?;
    }
    let started = Instant::now();
    let cpu0 = cpu_seconds();
    let (dir, resumed) = RunDir::resumable(out, opts.force)?;
    let staging = dir.staging().to_path_buf();
    dir.write("campaign.toml", campaign.resolved_toml().as_bytes())?;
    dir.write("base.toml", campaign.base_toml.as_bytes())?;
    if resumed {
        prune(&staging, campaign, progress)?;
    }

    let (mut outcomes, pending) = sort_cells(campaign, &staging, resumed, opts.keep_runs)?;
    let reused = outcomes.iter().filter(|o| o.reused).count();
    let executor_name = executor.name();
    progress.message(&format!(
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
        executor_name,
        campaign.spec.transport.name()
    ));
    progress.start("cells", campaign.cells.len() as u64);
    let mut done = (campaign.cells.len() - pending.len()) as u64;
    progress.at(done);
    let mut failed_now = 0usize;
    let mut record = |reply: CellReply| -> Result<(), ExecutorError> {
        let Some(cell) = campaign.cells.get(reply.index) else {
            bail!(
                "a worker replied for cell {}, which this campaign does not have",
                reply.index
            );
        };
        let outcome = match (reply.summary, reply.error) {
            (Some(s), _) => CellResult::of_summary(campaign, s, false),
            (None, e) => CellResult::failed(e.unwrap_or_else(|| "no result".into())),
        };
        let ok = outcome.status == CellStatus::Ok;
        if !ok && stop.flag.load(Ordering::SeqCst) {
            return Ok(()); // most likely stopped by the same cause: left to the next run
        }
        if !ok {
            failed_now += 1;
            progress.detail(&format!("{failed_now} failed"));
        }
        write_cell(&staging, campaign, cell, &outcome)?;
        outcomes[cell.index] = outcome;
        done += 1;
        progress.at(done);
        Ok(())
    };
    let executed = executor.execute(Execution {
        jobs: &pending,
        dir: &staging,
        stop,
        record: &mut record,
    });
    progress.finish();

    // Reports, then the directory goes into place (unless stopped: it stays .partial).
    let table = Table::new(campaign, &outcomes);
    report::cells_csv(&dir.path("cells.csv"), &table, &outcomes)?;
    let stopped = stop
        .flag
        .load(Ordering::SeqCst)
        .then(|| stop.reason().unwrap_or_else(|| "stopped".into()));
    let complete = stopped.is_none() && executed.is_ok() && outcomes.iter().all(|o| o.done());
    let plots = if !opts.plots || !complete {
        Vec::new()
    } else {
        report::plots(&dir.path("plots"), &table)?
    };
    let report = Report::new(
        &table,
        &outcomes,
        report::RunInfo {
            complete,
            interrupted: stopped.clone(),
            executor: executor_name,
            wall_s: started.elapsed().as_secs_f64(),
            cpu_s: cpu_seconds() - cpu0,
            plots,
        },
    );
    // Through a Value: its keys sorted, as campaign.json has always had them.
    let json = serde_json::to_value(&report)?;
    dir.write(
        "campaign.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;
    let columns = table.columns;
    let failure = executed.err().map(CampaignError::from);
    let (dir, committed) = if stopped.is_none() && failure.is_none() {
        (dir.commit()?, true)
    } else {
        (staging, false)
    };
    Ok(CampaignOutcome {
        dir,
        committed,
        resumed,
        cells: outcomes,
        columns,
        report,
        failure,
        stopped,
    })
}
