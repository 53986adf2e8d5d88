//! Running cells: one cell (in process, or as a `platoon run` co-simulation), a local worker
//! pool, and a Dask cluster through `bridge/dask_cells.py`.
use anyhow::{bail, Context, Result};
use platoon_campaign::Transport;
use platoon_output::rundir::RunDir;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::Instant;

/// What a worker needs to run one cell (the JSON a Dask worker receives).
#[derive(Debug, Clone, Serialize, Deserialize)]
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
#[derive(Debug, Clone, Serialize, Deserialize)]
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

/// Runs one cell where this process is.
pub fn execute(job: &CellJob) -> CellReply {
    let result = match job.transport {
        Transport::Inproc => in_process(job),
        Transport::Iceoryx2 => co_simulation(job),
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
            error: Some(format!("{e:#}")),
        },
    }
}

fn in_process(job: &CellJob) -> Result<Value> {
    let label = format!("cell {}", job.index);
    let (config, scenario) = platoon_config::parse(&job.config, Path::new(&label))?;
    let summary = match &job.keep {
        Some(out) => {
            let dir = RunDir::replace(out)?;
            dir.write("config.toml", job.config.as_bytes())?;
            let (rows, summary) = platoon_app::run::simulate_until(
                &scenario,
                &config.output,
                &dir,
                &(),
                &platoon_app::Stop::default(),
            )?;
            let extra = [("injector", platoon_app::run::builtin_injector_json())];
            platoon_app::run::write_outputs(
                &dir, &config, &scenario, &rows, &summary, false, &extra,
            )?;
            dir.commit()?;
            summary
        }
        None => platoon_sim::run(scenario, |_| {})?,
    };
    let mut json = serde_json::to_value(summary)?;
    json["injector"] = platoon_app::run::builtin_injector_json();
    Ok(json)
}

/// `platoon run --transport iceoryx2` in a child process (its own run id, so concurrent cells
/// never share services); the summary is read from its run directory.
fn co_simulation(job: &CellJob) -> Result<Value> {
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
    let exe = std::env::current_exe().context("locating the platoon binary")?;
    let output = Command::new(exe)
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

/// `platoon campaign-cell`: one job as JSON on stdin, its reply as JSON on stdout (what a Dask
/// worker runs). A cell that fails is a reply with an error, not a failed command.
pub fn cell_command() -> Result<()> {
    let mut text = String::new();
    std::io::Read::read_to_string(&mut std::io::stdin(), &mut text)
        .context("reading the cell job from stdin")?;
    let job: CellJob = serde_json::from_str(&text).context("the cell job is not valid JSON")?;
    let reply = execute(&job);
    println!("{}", serde_json::to_string(&reply)?);
    Ok(())
}

/// Runs `jobs` on `workers` threads of this process, handing each reply to `record` on the
/// calling thread as it comes. Stops taking new jobs once `stop` is set.
pub fn local_pool(
    jobs: &[CellJob],
    workers: usize,
    stop: &AtomicBool,
    mut record: impl FnMut(CellReply) -> Result<()>,
) -> Result<()> {
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<CellReply>();
    std::thread::scope(|s| {
        for _ in 0..workers.max(1).min(jobs.len().max(1)) {
            let tx = tx.clone();
            let next = &next;
            s.spawn(move || loop {
                if stop.load(Ordering::SeqCst) {
                    break;
                }
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some(job) = jobs.get(i) else { break };
                if tx.send(execute(job)).is_err() {
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
                    stop.store(true, Ordering::SeqCst);
                }
            }
        }
        result
    })
}

/// Sends `jobs` to the Dask scheduler at `address` through `bridge/dask_cells.py` (in the
/// bridge's venv, which pins `distributed`); each worker runs `platoon campaign-cell` with the
/// same binary. Replies are handed to `record` as they complete. `child` receives the driver's
/// process id so a signal can stop it. The driver's log goes to `log`.
pub fn dask(
    address: &str,
    jobs: &[CellJob],
    log: &Path,
    child: &std::sync::atomic::AtomicU32,
    mut record: impl FnMut(CellReply) -> Result<()>,
) -> Result<()> {
    let python = platoon_app::sumo::ensure_venv()?;
    let script = platoon_app::sumo::bridge_dir()?.join("dask_cells.py");
    let exe = std::env::current_exe().context("locating the platoon binary")?;
    let log_file =
        std::fs::File::create(log).with_context(|| format!("creating {}", log.display()))?;
    let started = Instant::now();
    let mut driver = Command::new(&python)
        .arg(&script)
        .arg(address)
        .arg(&exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(log_file)
        .spawn()
        .with_context(|| format!("starting {} {}", python.display(), script.display()))?;
    child.store(driver.id(), Ordering::SeqCst);
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
    let mut result = Ok(());
    let mut received = 0usize;
    for line in BufReader::new(stdout).lines() {
        let line = line.context("reading the Dask driver's output")?;
        let reply: CellReply = serde_json::from_str(&line)
            .with_context(|| format!("the Dask driver sent a line that is not a reply: {line}"))?;
        received += 1;
        if result.is_ok() {
            result = record(reply);
        }
    }
    let status = driver.wait().context("waiting for the Dask driver")?;
    child.store(0, Ordering::SeqCst);
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
    pub fn start(workers: usize, dir: &Path) -> Result<Self> {
        platoon_app::sumo::ensure_venv()?;
        let dask = platoon_app::sumo::bridge_dir()?.join(".venv/bin/dask");
        let file = dir.join("scheduler.json");
        let log = |name: &str| -> Result<std::fs::File> {
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
        let deadline = Instant::now() + std::time::Duration::from_secs(60);
        let wait = |what: &str| -> Result<()> {
            if Instant::now() > deadline {
                bail!(
                    "the local Dask cluster did not start within a minute ({what}; logs in {})",
                    dir.display()
                );
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
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
            let deadline = Instant::now() + std::time::Duration::from_secs(10);
            while matches!(p.try_wait(), Ok(None)) && Instant::now() < deadline {
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
            let _ = p.kill();
            let _ = p.wait();
        }
    }
}
