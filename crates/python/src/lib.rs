//! `platoon._core`, the compiled half of the Python package (`bridge/platoon`): thin wrappers
//! over [`platoon_app`], the library under every front-end. The pure-Python layer
//! (`bridge/platoon/__init__.py`) gives them their signatures, docstrings and result types;
//! this crate only converts: configs in (a TOML file's path, or a dict as JSON), results out
//! (summaries as JSON text, per-step tables as `pyarrow.Table`s handed over through the Arrow C
//! data interface, without copying the columns).
//!
//! Every call that runs something releases the GIL and runs on a thread of its own while the
//! calling thread waits for it, checking for signals every 100 ms: a KeyboardInterrupt asks
//! the run (or campaign) to stop as the CLI's Ctrl-C does, waits for it to stop cleanly (a run
//! directory is committed, marked incomplete; a campaign stays resumable), then is raised.
use anyhow::{Context, Result};
use arrow_array::RecordBatch;
use arrow_pyarrow::IntoPyArrow;
use platoon_app::campaign::{CampaignOptions, CellJob, CellReply, Dask, Executor, LocalPool};
use platoon_app::run::{RunOptions, Tables};
use platoon_app::Stop;
use platoon_config::{ConfigError as ConfigFileError, Embedded, PlantKind, Transport};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

create_exception!(
    _core,
    PlatoonError,
    PyRuntimeError,
    "A platoon operation failed; the message says what, and what to do."
);
create_exception!(
    _core,
    ConfigError,
    PyValueError,
    "A config (a file or a dict) or a campaign file is invalid. Attributes: `file` (the path, \
     or `<dict>`), `line` (1-based, None when unknown or for a dict), `key` (the dotted key, '' \
     for the file as a whole) and `message` (what is wrong)."
);

/// The Python exception for `e`: [`ConfigError`] with its attributes for a config error,
/// else [`PlatoonError`] with the whole chain of causes.
fn py_err(py: Python<'_>, e: anyhow::Error) -> PyErr {
    if let Some(c) = e.downcast_ref::<ConfigFileError>() {
        let err = ConfigError::new_err(c.to_string());
        let value = err.value(py);
        let _ = value.setattr("file", c.file.display().to_string());
        let _ = value.setattr("key", c.key.as_str());
        let _ = value.setattr("message", c.message.as_str());
        let _ = value.setattr("line", c.line);
        return err;
    }
    PlatoonError::new_err(format!("{e:#}"))
}

/// Runs `work` on a thread of its own without the GIL; the calling thread waits, checking for
/// signals. On a KeyboardInterrupt (or any exception a signal handler raises) `flag` is set, the
/// work is waited for (it stops at its next check of the flag), and the exception is raised.
fn interruptible<T: Send>(
    py: Python<'_>,
    flag: &Arc<AtomicBool>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let done = Arc::new((Mutex::new(false), Condvar::new()));
    std::thread::scope(|s| {
        let signal_done = done.clone();
        let worker = s.spawn(move || {
            let out = work();
            let (lock, cv) = &*signal_done;
            *lock.lock().unwrap_or_else(|p| p.into_inner()) = true;
            cv.notify_all();
            out
        });
        let mut interrupt = None;
        loop {
            let finished = py.detach(|| {
                let (lock, cv) = &*done;
                let guard = lock.lock().unwrap_or_else(|p| p.into_inner());
                let (guard, _) = cv
                    .wait_timeout_while(guard, Duration::from_millis(100), |d| !*d)
                    .unwrap_or_else(|p| p.into_inner());
                *guard
            });
            if finished {
                break;
            }
            if interrupt.is_none() {
                if let Err(e) = py.check_signals() {
                    flag.store(true, Ordering::SeqCst);
                    interrupt = Some(e);
                }
            }
        }
        let out = py.detach(|| worker.join()).map_err(|_| {
            PyRuntimeError::new_err("platoon's core panicked (a bug: please report it)")
        })?;
        match interrupt {
            Some(e) => Err(e),
            None => Ok(out),
        }
    })
}

/// A stop that a KeyboardInterrupt sets, named as the CLI names its signals.
fn keyboard_stop() -> (Arc<AtomicBool>, Stop) {
    let flag = Arc::new(AtomicBool::new(false));
    let seen = flag.clone();
    let stop = Stop::new(flag.clone(), move || {
        seen.load(Ordering::SeqCst)
            .then(|| "interrupted by KeyboardInterrupt".to_string())
    });
    (flag, stop)
}

/// The config a call names: a TOML file (`is_path`) or a dict as JSON (labelled `<dict>`; a
/// dict has no lines, so its errors name the key alone; keys of another rule or kind than a
/// table's own are dropped).
fn load_config(
    config: &str,
    is_path: bool,
) -> Result<(platoon_config::Config, platoon_sim::Scenario, PathBuf)> {
    if is_path {
        let path = PathBuf::from(config);
        let (c, s) = platoon_config::load(&path)?;
        return Ok((c, s, path));
    }
    let label = PathBuf::from("<dict>");
    let mut value: toml::Value = serde_json::from_str(config)
        .map_err(|e| ConfigFileError::new(&label, "", format!("not a config dict: {e}")))?;
    // A dict starts from a resolved config, which holds its rule's parameters: switching the
    // rule (or a kind) drops the old one's, as a campaign's axis does.
    platoon_campaign::overrides::drop_other_variants(&mut value);
    let text = toml::to_string(&value)
        .map_err(|e| ConfigFileError::new(&label, "", format!("not a config dict: {e}")))?;
    let (c, s) = platoon_config::parse(&text, &label).map_err(|mut e| {
        e.line = None;
        e
    })?;
    Ok((c, s, label))
}

/// The embedded scenarios, by name.
const EMBEDDED: [Embedded; 3] = [Embedded::Paper, Embedded::Table1, Embedded::Degradation];

/// `scenario(name)`: an embedded scenario (`paper`, `table1`, `degradation`) or a TOML file,
/// resolved (every default written out), as JSON.
#[pyfunction]
fn scenario(py: Python<'_>, name: &str) -> PyResult<String> {
    let loaded = match EMBEDDED.iter().find(|e| e.name() == name) {
        Some(e) => e.parse().map_err(anyhow::Error::from),
        None if Path::new(name).is_file() => {
            platoon_config::load(Path::new(name)).map_err(Into::into)
        }
        None => Err(anyhow::anyhow!(
            "no scenario {name:?}: the embedded ones are {}, or give a TOML file's path",
            EMBEDDED.map(|e| e.name()).join(", ")
        )),
    };
    let (config, _) = loaded.map_err(|e| py_err(py, e))?;
    serde_json::to_string(&config).map_err(|e| py_err(py, e.into()))
}

/// The names of the embedded scenarios.
#[pyfunction]
fn scenario_names() -> Vec<&'static str> {
    EMBEDDED.iter().map(|e| e.name()).collect()
}

/// `tables` as `pyarrow.Table`s by name: the batches are exported through the Arrow C data
/// interface (pyarrow takes ownership of the buffers, nothing is copied).
fn to_pyarrow(py: Python<'_>, tables: Tables) -> PyResult<Vec<(String, Py<PyAny>)>> {
    tables
        .into_iter()
        .map(|(name, schema, batches)| {
            let table = arrow_pyarrow::Table::try_new(batches, schema)
                .map_err(|e| PlatoonError::new_err(format!("the {name} table: {e}")))?;
            Ok((name.to_string(), table.into_pyarrow(py)?.unbind()))
        })
        .collect()
}

/// What `run` hands back: the summary (JSON), the tables, the run directory (when one was
/// asked for).
type RunResult = (String, Vec<(String, Py<PyAny>)>, Option<String>);

/// `run(...)`: one scenario. In process with no `out`, nothing touches the disk: the tables
/// come from memory. Otherwise (a run directory asked for, a co-simulation, SUMO, an external
/// injector or controller) it is `platoon run` into `out` (a temporary directory, removed
/// after, when None), and the tables are read back from its files.
#[pyfunction]
#[pyo3(signature = (config, is_path, transport, plant=None, out=None, force=false, plots=false, injector=None, injector_after=false, controller=None, step_timeout_s=1.0))]
#[allow(clippy::too_many_arguments)]
fn run(
    py: Python<'_>,
    config: &str,
    is_path: bool,
    transport: &str,
    plant: Option<&str>,
    out: Option<PathBuf>,
    force: bool,
    plots: bool,
    injector: Option<String>,
    injector_after: bool,
    controller: Option<String>,
    step_timeout_s: f64,
) -> PyResult<RunResult> {
    let (config, scenario, label) = load_config(config, is_path).map_err(|e| py_err(py, e))?;
    let transport = match transport {
        "inproc" => Transport::Inproc,
        "iceoryx2" => Transport::Iceoryx2,
        other => {
            return Err(PyValueError::new_err(format!(
                "transport={other:?}: use \"inproc\" (one process) or \"iceoryx2\" (processes over shared memory)"
            )))
        }
    };
    let plant = match plant {
        None => None,
        Some("native") => Some(PlantKind::Native),
        Some("sumo") => Some(PlantKind::Sumo),
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "plant={other:?}: use \"native\" or \"sumo\" (None: the config's simulation.plant)"
            )))
        }
    };
    if !(step_timeout_s.is_finite() && step_timeout_s > 0.0) {
        return Err(PyValueError::new_err(format!(
            "step_timeout_s={step_timeout_s}: a positive number of seconds"
        )));
    }
    let (flag, stop) = keyboard_stop();
    let native = plant.unwrap_or(config.simulation.plant) == PlantKind::Native;
    if transport == Transport::Inproc
        && out.is_none()
        && native
        && injector.is_none()
        && controller.is_none()
    {
        let (tables, summary) = interruptible(py, &flag, || {
            platoon_app::run::simulate_in_memory(&scenario, &config.output, &(), &stop)
        })?
        .map_err(|e| py_err(py, e))?;
        let extra = [("injector", platoon_app::run::builtin_injector_json())];
        let json = platoon_app::run::summary_json(&summary, &extra)
            .and_then(|j| Ok(serde_json::to_string(&j)?))
            .map_err(|e| py_err(py, e))?;
        return Ok((json, to_pyarrow(py, tables)?, None));
    }
    let opts = RunOptions {
        transport,
        plant,
        injector: injector.map(|command| platoon_app::run::Injector {
            command,
            mode: if injector_after {
                platoon_app::run::InjectorMode::After
            } else {
                platoon_app::run::InjectorMode::Replace
            },
        }),
        controller,
        step_timeout: Duration::from_secs_f64(step_timeout_s),
        plots,
        config_file: label,
        ..RunOptions::default()
    };
    let temp = match &out {
        Some(_) => None,
        None => Some(
            tempfile::Builder::new()
                .prefix("platoon-run-")
                .tempdir()
                .map_err(|e| {
                    py_err(
                        py,
                        anyhow::Error::from(e).context("creating a temporary run directory"),
                    )
                })?,
        ),
    };
    let dir = match (&out, &temp) {
        (Some(out), _) => out.clone(),
        (None, Some(t)) => t.path().join("run"),
        (None, None) => unreachable!("a temporary directory is made when no out is given"),
    };
    let outcome = interruptible(py, &flag, || {
        platoon_app::run::run(config, &scenario, &opts, &dir, force, &stop, &())
    })?
    .map_err(|e| py_err(py, e))?;
    if let Some(failure) = &outcome.failure {
        let kept = match &out {
            Some(_) => format!(" (what it recorded is in {})", outcome.dir.display()),
            None => String::new(),
        };
        return Err(PlatoonError::new_err(format!("{failure}{kept}")));
    }
    let read = || -> Result<(String, Tables)> {
        let summary = outcome.dir.join("summary.json");
        let json = std::fs::read_to_string(&summary)
            .with_context(|| format!("reading {}", summary.display()))?;
        Ok((json, platoon_app::run::read_tables(&outcome.dir)?))
    };
    let (json, tables) = read().map_err(|e| py_err(py, e))?;
    let dir = out.map(|_| outcome.dir.display().to_string());
    Ok((json, to_pyarrow(py, tables)?, dir))
}

/// `cells.csv` as a `pyarrow.Table`, each column's type inferred from its values (a metric
/// column is float64; an empty cell is null).
fn read_cells(path: &Path) -> Result<(arrow_schema::SchemaRef, Vec<RecordBatch>)> {
    use std::io::Seek;
    let mut file =
        std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let format = arrow_csv::reader::Format::default().with_header(true);
    let (schema, _) = format
        .infer_schema(&mut file, None)
        .with_context(|| format!("reading {}", path.display()))?;
    file.rewind()?;
    let schema = Arc::new(schema);
    let reader = arrow_csv::ReaderBuilder::new(schema.clone())
        .with_format(format)
        .build(file)
        .with_context(|| format!("reading {}", path.display()))?;
    let batches = reader
        .collect::<Result<Vec<_>, _>>()
        .with_context(|| format!("reading {}", path.display()))?;
    Ok((schema, batches))
}

/// What `campaign` hands back: campaign.json (text), the cells, the directory.
type CampaignResult = (String, Py<PyAny>, String);

/// `campaign(...)`: `platoon campaign` into `out` (default `runs/<campaign name>`), on the
/// local pool or a Dask scheduler.
#[pyfunction]
#[pyo3(signature = (path, out=None, jobs=None, dask=None, force=false, keep_runs=false, plots=false, samples=None))]
#[allow(clippy::too_many_arguments)]
fn campaign(
    py: Python<'_>,
    path: PathBuf,
    out: Option<PathBuf>,
    jobs: Option<usize>,
    dask: Option<String>,
    force: bool,
    keep_runs: bool,
    plots: bool,
    samples: Option<usize>,
) -> PyResult<CampaignResult> {
    let campaign =
        platoon_campaign::Campaign::load(&path, samples).map_err(|e| py_err(py, e.into()))?;
    let jobs = match jobs {
        None => None,
        Some(n) => Some(
            std::num::NonZeroUsize::new(n)
                .ok_or_else(|| PyValueError::new_err("jobs=0: at least one cell at a time"))?,
        ),
    };
    let executor: Box<dyn Executor + Sync> = match dask {
        Some(address) => Box::new(Dask::new(address)),
        None => Box::new(LocalPool::new(jobs)),
    };
    let out = out.unwrap_or_else(|| PathBuf::from("runs").join(&campaign.name));
    let opts = CampaignOptions {
        force,
        keep_runs,
        plots,
    };
    let (flag, stop) = keyboard_stop();
    let outcome = interruptible(py, &flag, || {
        platoon_app::campaign::run(&campaign, &out, &opts, &*executor, &stop, &())
    })?
    .map_err(|e| py_err(py, e))?;
    if let Some(e) = outcome.failure {
        let e = e.context(format!(
            "the cells done are kept in {}; call again to resume",
            outcome.dir.display()
        ));
        return Err(py_err(py, e));
    }
    let read = || -> Result<_> {
        let report = outcome.dir.join("campaign.json");
        let json = std::fs::read_to_string(&report)
            .with_context(|| format!("reading {}", report.display()))?;
        Ok((json, read_cells(&outcome.dir.join("cells.csv"))?))
    };
    let (json, (schema, batches)) = read().map_err(|e| py_err(py, e))?;
    let cells = to_pyarrow(py, vec![("cells", schema, batches)])?
        .pop()
        .map(|(_, t)| t)
        .expect("one table in, one out");
    Ok((json, cells, outcome.dir.display().to_string()))
}

/// `execute_cells(jobs)`: campaign cells in this process (what a Dask worker runs): a JSON list
/// of cell jobs in, the JSON list of their replies out, in the same order. A cell that fails
/// is a reply with an error.
#[pyfunction]
fn execute_cells(py: Python<'_>, jobs: &str) -> PyResult<String> {
    let jobs: Vec<CellJob> = serde_json::from_str(jobs)
        .map_err(|e| PyValueError::new_err(format!("not a JSON list of cell jobs: {e}")))?;
    let replies: Vec<CellReply> = py.detach(|| {
        jobs.iter()
            .map(|job| platoon_app::campaign::execute(job, None))
            .collect()
    });
    serde_json::to_string(&replies).map_err(|e| py_err(py, e.into()))
}

/// `check_gain(...)`: `platoon design check-gain`'s report (check.json) as JSON.
#[pyfunction]
#[pyo3(signature = (config, is_path, gain=None, c=0.0, theorem=1, time_headway=None))]
fn check_gain(
    py: Python<'_>,
    config: &str,
    is_path: bool,
    gain: Option<[f64; 3]>,
    c: f64,
    theorem: u8,
    time_headway: Option<f64>,
) -> PyResult<String> {
    let (config, scenario, _) = load_config(config, is_path).map_err(|e| py_err(py, e))?;
    let theorem = platoon_app::design::Theorem::from_number(theorem)
        .ok_or_else(|| PyValueError::new_err(format!("theorem={theorem}: 1 or 2")))?;
    let opts = platoon_app::design::CheckOptions {
        gain,
        c,
        theorem,
        time_headway,
    };
    let (flag, _) = keyboard_stop();
    let report = interruptible(py, &flag, || {
        platoon_app::design::check_gain(&config, &scenario, &opts)
    })?
    .map_err(|e| py_err(py, e))?;
    serde_json::to_string(&report).map_err(|e| py_err(py, e.into()))
}

/// `cli(argv)`: the `platoon` command (argv[0] is the program name); returns its exit status.
/// The package's `platoon` script.
#[pyfunction]
fn cli(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| {
        let code = platoon_cli::main_with(argv);
        let _ = std::io::Write::flush(&mut std::io::stdout());
        code
    })
}

/// The compiled core of the `platoon` Python package.
#[pymodule]
#[pyo3(name = "_core")]
fn core_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("PlatoonError", m.py().get_type::<PlatoonError>())?;
    m.add("ConfigError", m.py().get_type::<ConfigError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(scenario, m)?)?;
    m.add_function(wrap_pyfunction!(scenario_names, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(campaign, m)?)?;
    m.add_function(wrap_pyfunction!(execute_cells, m)?)?;
    m.add_function(wrap_pyfunction!(check_gain, m)?)?;
    m.add_function(wrap_pyfunction!(cli, m)?)?;
    Ok(())
}
