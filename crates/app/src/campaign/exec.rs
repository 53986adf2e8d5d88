//! Running cells: one cell where this process is ([`execute`]: in process, or as a
//! `platoon run` co-simulation), and the executors that run many: the [`LocalPool`] of worker
//! threads, a Dask cluster through `platoon.dask` ([`Dask`]), or the caller's own
//! ([`Executor`]).
use crate::error::{Context, OtherError};
use crate::run::RunError;
use crate::run::Stop;
use platoon_campaign::Transport;
use platoon_output::error::OutputError;
use platoon_output::rundir::RunDir;
use platoon_sim::{ControllerFactory, InjectorFactory, Plugins};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The result of an executor's work.
pub type Result<T, E = ExecutorError> = std::result::Result<T, E>;

/// Why an [`Executor`] stopped before every cell was in.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExecutorError {
    /// A reply could not be recorded: the campaign's record of a cell ([`Execution::record`]'s
    /// error, passed on).
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The executor's own failure (its workers', its cluster's), or a reply for a cell the
    /// campaign does not have.
    #[error(transparent)]
    Failed(#[from] OtherError),
}

impl From<std::io::Error> for ExecutorError {
    fn from(e: std::io::Error) -> Self {
        Self::Failed(e.into())
    }
}

impl From<serde_json::Error> for ExecutorError {
    fn from(e: serde_json::Error) -> Self {
        Self::Failed(e.into())
    }
}

/// What a worker needs to run one cell (the JSON a Dask worker receives).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellJob {
    /// The cell's index.
    pub index: usize,
    /// Its resolved scenario config (TOML).
    pub config: String,
    /// How it runs.
    pub transport: Transport,
    /// Where to keep the whole run's outputs (`--keep-runs`), on the worker's file system.
    pub keep: Option<PathBuf>,
}

/// What a worker sends back: the run's `summary.json`, or why there is none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellReply {
    /// The cell's index.
    pub index: usize,
    /// The summary, as `platoon run` writes it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub summary: Option<Value>,
    /// Why the cell has no usable result.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// One call of [`Executor::execute`]: the cells to run and where their replies go.
pub struct Execution<'a> {
    /// The cells to run.
    pub jobs: &'a [CellJob],
    /// The campaign directory being written, for the executor's own logs (e.g. `dask.log`).
    pub dir: &'a Path,
    /// Once its flag is set, no new job starts.
    pub stop: &'a Stop,
    /// Takes each reply on the calling thread as it comes, in any order. Its error ends the
    /// execution with that error (later replies are not recorded).
    pub record: &'a mut dyn FnMut(CellReply) -> Result<()>,
}

/// Runs a campaign's cells (see [`super::run`]): whatever runs a cell hands back its
/// [`CellReply`], and the campaign records it.
pub trait Executor {
    /// How `campaign.json` names it ("local pool, 4 jobs", "dask tcp://10.0.0.5:8786").
    fn name(&self) -> String;

    /// Runs `run`'s jobs, as [`Execution`] says. An error is the executor's failure: the
    /// replies recorded so far are kept and the campaign stays resumable.
    fn execute(&self, run: Execution<'_>) -> Result<()>;

    /// What its in-process cells plug in instead of the built-in parts (a search re-runs its
    /// worst schedule with them); none unless it says so.
    fn plugins(&self) -> CellPlugins {
        CellPlugins::default()
    }
}

/// The `platoon` binary that runs what needs a process: `program`, else this executable.
fn platoon_program(program: Option<&Path>) -> Result<PathBuf, OtherError> {
    match program {
        Some(p) => Ok(p.to_path_buf()),
        None => crate::platoon_program(),
    }
}

/// Runs one cell where this process is: an in-process cell on this thread, a co-simulated one
/// (`transport = "iceoryx2"`) as a `platoon run` child of `program` (None: this executable,
/// the `platoon` binary). A cell that fails is a reply with an error.
pub fn execute(job: &CellJob, program: Option<&Path>) -> CellReply {
    execute_with(job, program, &CellPlugins::default())
}

/// What in-process cells plug in instead of the built-in parts their configs name (None: the
/// built-in one).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CellPlugins {
    /// Makes each platoon's controller.
    pub controller: Option<ControllerFactory>,
    /// Makes each platoon's injector: an attack of the caller's.
    pub injector: Option<InjectorFactory>,
}

impl CellPlugins {
    /// Whether anything of the caller's is plugged in.
    pub fn any(&self) -> bool {
        self.controller.is_some() || self.injector.is_some()
    }

    /// The parts of a run: the caller's where given, else the built-in ones.
    pub fn plugins(&self) -> Plugins {
        let builtin = Plugins::default();
        Plugins {
            controller: self.controller.clone().unwrap_or(builtin.controller),
            injector: self.injector.clone().unwrap_or(builtin.injector),
        }
    }
}

/// [`execute`], in-process cells with the controllers and injectors `plugins` make.
pub fn execute_with(job: &CellJob, program: Option<&Path>, plugins: &CellPlugins) -> CellReply {
    let result = match job.transport {
        Transport::Iceoryx2 if plugins.any() => Err(failure!(
            "a controller or an injector of the caller's runs in process only: set transport = \
             \"inproc\" (or run it as a process with platoon run --controller or --injector)"
        )
        .into()),
        Transport::Inproc => in_process(job, plugins),
        Transport::Iceoryx2 => co_simulation(job, program).map_err(RunError::from),
    };
    match result {
        Ok(summary) => CellReply {
            index: job.index,
            summary: Some(summary),
            error: None,
        },
        Err(e) => CellReply {
            index: job.index,
            summary: None,
            error: Some(OtherError::report(&e)),
        },
    }
}

fn in_process(job: &CellJob, plugins: &CellPlugins) -> Result<Value, RunError> {
    let label = format!("cell {}", job.index);
    let (config, scenario) = platoon_config::parse(&job.config, Path::new(&label))?;
    if plugins.controller.is_none() && !scenario.control.detection.plugin.is_empty() {
        bail!(
            "{label}: detection.plugin names detectors a controller plug-in runs ({}), but the \
             cell runs the built-in controllers in process: set transport = \"iceoryx2\" with \
             a --controller, or remove detection.plugin",
            scenario.control.detection.plugin.join(", ")
        );
    }
    // Certified as `platoon run` certifies a co-simulated cell's (before a kept run's files).
    let mut summary = match &job.keep {
        _ if plugins.any() => {
            if job.keep.is_some() {
                bail!(
                    "keeping the runs of cells is not supported with a controller or an \
                     injector of the caller's: leave --keep-runs out"
                );
            }
            platoon_sim::run_until_plugins(&scenario, &plugins.plugins(), |_| {
                std::ops::ControlFlow::Continue(())
            })?
        }
        Some(out) => {
            let dir = RunDir::replace(out)?;
            dir.write("config.toml", job.config.as_bytes())?;
            let (rows, mut summary) =
                crate::run::simulate_until(&scenario, &config.output, &dir, &(), &Stop::default())?;
            crate::formations::certify(&scenario, &mut summary);
            let extra = [("injector", crate::run::builtin_injector_json())];
            crate::run::write_outputs(
                &dir,
                &config,
                &scenario,
                &rows.into(),
                &summary,
                false,
                &extra,
            )?;
            dir.commit()?;
            summary
        }
        None => platoon_sim::run(scenario.clone(), |_| {})?,
    };
    if job.keep.is_none() {
        crate::formations::certify(&scenario, &mut summary);
    }
    let mut json = serde_json::to_value(summary)?;
    json["injector"] = match plugins.injector {
        Some(_) => serde_json::json!({ "program": "in process", "mode": "replace" }),
        None => crate::run::builtin_injector_json(),
    };
    Ok(json)
}

/// `platoon run --transport iceoryx2` in a child process (its own run id, so concurrent cells
/// never share services); the summary is read from its run directory.
fn co_simulation(job: &CellJob, program: Option<&Path>) -> Result<Value, OtherError> {
    let scratch = tempfile::Builder::new()
        .prefix("platoon-cell-")
        .tempdir()
        .context("creating a scratch directory for the cell")?;
    let config = scratch.path().join("config.toml");
    std::fs::write(&config, &job.config)
        .with_context(|| format!("writing {}", config.display()))?;
    let out = job
        .keep
        .clone()
        .unwrap_or_else(|| scratch.path().join("run"));
    let output = Command::new(platoon_program(program)?)
        .arg("run")
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .args(["--force", "--no-plots", "--transport", "iceoryx2"])
        .stdin(Stdio::null())
        .output()
        .context("starting `platoon run` for the cell")?;
    let summary_file = out.join("summary.json");
    let summary: Option<Value> = std::fs::read_to_string(&summary_file)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    match (output.status.success(), summary) {
        (true, Some(s)) => Ok(s),
        (_, Some(s)) if s["complete"] == Value::Bool(false) => Ok(s),
        _ => {
            let stderr = String::from_utf8_lossy(&output.stderr);
            let last = stderr
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("no message");
            bail!(
                "platoon run exited with {}: {}",
                output.status,
                last.trim_start_matches("error: ")
            )
        }
    }
}

/// Cells on worker threads of this process (in-process cells run on the thread; co-simulated
/// ones as `platoon run` children).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LocalPool {
    /// Cells run at once.
    pub jobs: usize,
    /// The `platoon` binary co-simulated cells run (None: this executable).
    pub program: Option<PathBuf>,
    /// What in-process cells plug in (a controller or an attack of the caller's, in Rust,
    /// with no process per cell; by default the built-in ones their configs name). A search
    /// run by this pool runs its candidates with them.
    pub plugins: CellPlugins,
}

impl LocalPool {
    /// A pool of `jobs` workers (None: as many as this machine has cores).
    pub fn new(jobs: Option<std::num::NonZeroUsize>) -> Self {
        Self {
            jobs: jobs
                .or_else(|| std::thread::available_parallelism().ok())
                .map_or(1, |n| n.get()),
            program: None,
            plugins: CellPlugins::default(),
        }
    }
}

impl Default for LocalPool {
    fn default() -> Self {
        Self::new(None)
    }
}

impl Executor for LocalPool {
    fn name(&self) -> String {
        format!("local pool, {} jobs", self.jobs)
    }

    fn plugins(&self) -> CellPlugins {
        self.plugins.clone()
    }

    fn execute(&self, run: Execution<'_>) -> Result<()> {
        let Execution {
            jobs, stop, record, ..
        } = run;
        let next = AtomicUsize::new(0);
        // Set by the caller's stop, or here when recording failed.
        let failed = AtomicBool::new(false);
        let (tx, rx) = mpsc::channel::<CellReply>();
        let program = self.program.as_deref();
        std::thread::scope(|s| {
            for _ in 0..self.jobs.max(1).min(jobs.len().max(1)) {
                let tx = tx.clone();
                let (next, failed) = (&next, &failed);
                s.spawn(move || loop {
                    if stop.flag.load(Ordering::SeqCst) || failed.load(Ordering::SeqCst) {
                        break;
                    }
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    let Some(job) = jobs.get(i) else { break };
                    if tx.send(execute_with(job, program, &self.plugins)).is_err() {
                        break;
                    }
                });
            }
            drop(tx);
            let mut result = Ok(());
            for reply in rx {
                if result.is_ok() {
                    result = record(reply);
                    if result.is_err() {
                        failed.store(true, Ordering::SeqCst);
                    }
                }
            }
            result
        })
    }
}

/// Cells on a Dask cluster: the bridge's `python -m platoon.dask` (in its venv, which pins
/// `distributed`) is fed the jobs as JSON lines and submits them to the scheduler in batches
/// (about four per worker thread). A worker whose Python has the `platoon` package runs a
/// batch in its own process (`platoon._core.execute_cells`); one without it, or every worker
/// when `PLATOON_DASK_IN_WORKER=0` is set in this process's environment, runs a
/// `platoon campaign-cell` process per cell, with the binary at `program`'s path (a shared
/// file system) or at `$PLATOON_EXE` on the worker. The driver's log (which path ran each
/// batch, on which worker) goes to `dask.log` in the campaign directory; a stop ends the
/// driver (SIGTERM).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Dask {
    /// The scheduler's address (e.g. `tcp://10.0.0.5:8786`).
    pub address: String,
    /// The `platoon` binary the workers run (None: this executable).
    pub program: Option<PathBuf>,
}

impl Dask {
    /// The scheduler at `address`; the workers run this executable.
    pub fn new(address: impl Into<String>) -> Self {
        Self {
            address: address.into(),
            program: None,
        }
    }
}

impl Executor for Dask {
    fn name(&self) -> String {
        format!("dask {}", self.address)
    }

    fn execute(&self, run: Execution<'_>) -> Result<()> {
        dask(
            &self.address,
            &platoon_program(self.program.as_deref())?,
            run,
        )
    }
}

/// Sends `run`'s jobs to the Dask scheduler at `address` through the driver, whose workers run
/// the cells in their process or as `exe campaign-cell` (see [`Dask`]). Replies are handed to
/// `run.record` as they complete; once `run.stop` is set the driver gets SIGTERM. The driver's
/// log goes to `dask.log` in `run.dir`.
fn dask(address: &str, exe: &Path, run: Execution<'_>) -> Result<()> {
    let Execution {
        jobs,
        dir,
        stop,
        record,
    } = run;
    let log = &dir.join("dask.log");
    let mut command = crate::sumo::bridge_module("platoon.dask")?;
    let log_file =
        std::fs::File::create(log).with_context(|| format!("creating {}", log.display()))?;
    let started = Instant::now();
    let mut driver = command
        .arg(address)
        .arg(exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(log_file)
        .spawn()
        .context("starting the Dask driver, python -m platoon.dask")?;
    let pid = driver.id();
    let mut stdin = driver.stdin.take().context("the Dask driver's stdin")?;
    let stdout = driver.stdout.take().context("the Dask driver's stdout")?;
    let lines: Vec<String> = jobs
        .iter()
        .map(serde_json::to_string)
        .collect::<Result<_, _>>()?;
    let writer = std::thread::spawn(move || -> std::io::Result<()> {
        for l in lines {
            stdin.write_all(l.as_bytes())?;
            stdin.write_all(b"\n")?;
        }
        Ok(()) // dropping stdin closes it: the driver then submits
    });
    // Passes a stop on to the driver while its output lasts (it is waited for only after
    // this ends, so its pid is still ours whenever it is signalled).
    let over = AtomicBool::new(false);
    let (result, received, status) = std::thread::scope(|s| -> Result<_> {
        let watcher = s.spawn(|| {
            while !over.load(Ordering::SeqCst) {
                if stop.flag.load(Ordering::SeqCst) {
                    // SAFETY: signalling our own child, not yet waited for.
                    unsafe { libc::kill(pid as libc::pid_t, libc::SIGTERM) };
                    break;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        });
        let mut result = Ok(());
        let mut received = 0usize;
        let read = || -> Result<()> {
            for line in BufReader::new(stdout).lines() {
                let line = line.context("reading the Dask driver's output")?;
                let reply: CellReply = serde_json::from_str(&line).with_context(|| {
                    format!("the Dask driver sent a line that is not a reply: {line}")
                })?;
                received += 1;
                if result.is_ok() {
                    result = record(reply);
                }
            }
            Ok(())
        };
        let read = read();
        over.store(true, Ordering::SeqCst);
        let _ = watcher.join();
        if let Err(e) = read {
            // Not left running: it would go on submitting cells nobody records.
            let _ = driver.kill();
            let _ = driver.wait();
            return Err(e);
        }
        let status = driver.wait().context("waiting for the Dask driver")?;
        Ok((result, received, status))
    })?;
    let _ = writer.join();
    result?;
    if !status.success() && received < jobs.len() {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        let last = text
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("no message");
        bail!(
            "the Dask driver stopped after {received} of {} cells ({status}, {:.1} s): {last} (the whole log: {})",
            jobs.len(),
            started.elapsed().as_secs_f64(),
            log.display()
        );
    }
    Ok(())
}

/// A Dask scheduler and workers on 127.0.0.1 started from the bridge's venv (what
/// `platoon bench campaign` measures Dask with), stopped on drop.
pub struct LocalCluster {
    procs: Vec<std::process::Child>,
    /// The scheduler's address (`tcp://127.0.0.1:PORT`).
    pub address: String,
}

impl LocalCluster {
    /// Starts a scheduler and `workers` single-threaded workers, logging into `dir`, and waits
    /// (at most a minute) until every worker has registered.
    pub fn start(workers: usize, dir: &Path) -> Result<Self, OtherError> {
        crate::sumo::ensure_venv()?;
        let dask = crate::sumo::bridge_dir()?.join(".venv/bin/dask");
        let file = dir.join("scheduler.json");
        let log = |name: &str| -> Result<std::fs::File, OtherError> {
            std::fs::File::create(dir.join(name))
                .with_context(|| format!("creating {}", dir.join(name).display()))
        };
        let _ = std::fs::remove_file(&file);
        let scheduler = Command::new(&dask)
            .args([
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
            ])
            .arg("--scheduler-file")
            .arg(&file)
            .stdout(log("scheduler.out")?)
            .stderr(log("scheduler.log")?)
            .spawn()
            .with_context(|| format!("starting {} scheduler", dask.display()))?;
        let mut me = Self {
            procs: vec![scheduler],
            address: String::new(),
        };
        let deadline = Instant::now() + Duration::from_secs(60);
        let wait = |what: &str| -> Result<(), OtherError> {
            if Instant::now() > deadline {
                bail!(
                    "the local Dask cluster did not start within a minute ({what}; logs in {})",
                    dir.display()
                );
            }
            std::thread::sleep(Duration::from_millis(100));
            Ok(())
        };
        me.address = loop {
            let text = std::fs::read_to_string(&file).unwrap_or_default();
            if let Ok(v) = serde_json::from_str::<Value>(&text) {
                if let Some(a) = v["address"].as_str() {
                    break a.to_string();
                }
            }
            wait("no scheduler address")?;
        };
        for i in 0..workers {
            let worker = Command::new(&dask)
                .args(["worker", &me.address, "--nthreads", "1", "--no-dashboard"])
                .args(["--host", "127.0.0.1", "--name", &format!("w{i}")])
                .stdout(log(&format!("worker{i}.out"))?)
                .stderr(log(&format!("worker{i}.log"))?)
                .spawn()
                .context("starting a Dask worker")?;
            me.procs.push(worker);
        }
        while std::fs::read_to_string(dir.join("scheduler.log"))
            .unwrap_or_default()
            .matches("Register worker")
            .count()
            < workers
        {
            wait("workers not registered")?;
        }
        Ok(me)
    }
}

impl Drop for LocalCluster {
    fn drop(&mut self) {
        for p in self.procs.iter().rev() {
            // SAFETY: signalling our own children.
            unsafe { libc::kill(p.id() as libc::pid_t, libc::SIGTERM) };
        }
        for p in &mut self.procs {
            let deadline = Instant::now() + Duration::from_secs(10);
            while matches!(p.try_wait(), Ok(None)) && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = p.kill();
            let _ = p.wait();
        }
    }
}
