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
use anyhow::Context;
use arrow_array::RecordBatch;
use arrow_pyarrow::IntoPyArrow;
use platoon_app::campaign::{CampaignOptions, CellJob, CellReply, Dask, Executor, LocalPool};
use platoon_app::run::{RunError, RunOptions, Tables};
use platoon_app::Stop;
use platoon_app::{CampaignError, DesignError};
use platoon_config::{ConfigError as ConfigFileError, Embedded, PlantKind, Transport};
use platoon_output::error::OutputError as OutputFileError;
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

create_exception!(
    _core,
    NodeError,
    PlatoonError,
    "A process of a co-simulated run (the plant, the controller, the injector, a plug-in) \
     failed. Attributes: `node` (`plant`, `controller`, `injector` or `channel`), `step` (the \
     step the run was at, None when unknown), `log` (the path of its log, None when it wrote \
     none), `message` (what went wrong, in a line) and `run_dir` (what the run recorded)."
);
create_exception!(
    _core,
    OutputError,
    PlatoonError,
    "The files of a run or a campaign could not be written or read. Attribute: `path` (the \
     file or directory, None when unknown)."
);

/// Why a call failed, by kind: what decides the Python exception (see [`py_err`]).
#[derive(Debug)]
enum CoreError {
    /// A config (a file or a dict) or a campaign file is refused.
    Config(ConfigFileError),
    /// A run failed before it recorded anything.
    Run(RunError),
    /// A co-simulation failed, and what it recorded is kept in `dir`.
    Recorded { failure: RunError, dir: PathBuf },
    /// A campaign failed before it started.
    Campaign(CampaignError),
    /// A campaign's executor stopped; the cells done are kept in `dir`.
    Resumable {
        failure: CampaignError,
        dir: PathBuf,
    },
    /// A design check failed.
    Design(DesignError),
    /// The files of a run read back.
    Output(OutputFileError),
    /// Anything else, with its context.
    Other(anyhow::Error),
}

type Result<T, E = CoreError> = std::result::Result<T, E>;

impl CoreError {
    /// The error of a run, if this is one.
    fn run(&self) -> Option<&RunError> {
        match self {
            Self::Run(e) | Self::Recorded { failure: e, .. } => Some(e),
            _ => None,
        }
    }

    /// The output error this is, of any call.
    fn output(&self) -> Option<&OutputFileError> {
        match self {
            Self::Output(o) => Some(o),
            Self::Run(e) | Self::Recorded { failure: e, .. } => e.output(),
            Self::Campaign(e) | Self::Resumable { failure: e, .. } => e.output(),
            Self::Design(e) => e.output(),
            Self::Config(_) | Self::Other(_) => None,
        }
    }

    /// The config error this is, of any call.
    fn config(&self) -> Option<&ConfigFileError> {
        match self {
            Self::Config(c) => Some(c),
            Self::Run(e) | Self::Recorded { failure: e, .. } => e.config(),
            Self::Campaign(e) | Self::Resumable { failure: e, .. } => e.config(),
            Self::Design(e) => e.config(),
            Self::Output(_) | Self::Other(_) => None,
        }
    }

    /// The message: the error with its causes, and where a failed run's records are.
    fn message(&self) -> String {
        let report = platoon_app::OtherError::report;
        match self {
            Self::Config(e) => report(e),
            Self::Run(e) => report(e),
            Self::Recorded { failure, dir } => {
                format!("{failure} (what the run recorded is in {})", dir.display())
            }
            Self::Campaign(e) => report(e),
            Self::Resumable { failure, dir } => format!(
                "the cells done are kept in {}; call again to resume: {}",
                dir.display(),
                report(failure)
            ),
            Self::Design(e) => report(e),
            Self::Output(e) => report(e),
            Self::Other(e) => format!("{e:#}"),
        }
    }
}

impl From<ConfigFileError> for CoreError {
    fn from(e: ConfigFileError) -> Self {
        Self::Config(e)
    }
}

impl From<RunError> for CoreError {
    fn from(e: RunError) -> Self {
        Self::Run(e)
    }
}

impl From<CampaignError> for CoreError {
    fn from(e: CampaignError) -> Self {
        Self::Campaign(e)
    }
}

impl From<DesignError> for CoreError {
    fn from(e: DesignError) -> Self {
        Self::Design(e)
    }
}

impl From<OutputFileError> for CoreError {
    fn from(e: OutputFileError) -> Self {
        Self::Output(e)
    }
}

impl From<anyhow::Error> for CoreError {
    fn from(e: anyhow::Error) -> Self {
        Self::Other(e)
    }
}

impl From<serde_json::Error> for CoreError {
    fn from(e: serde_json::Error) -> Self {
        Self::Other(e.into())
    }
}

impl From<std::io::Error> for CoreError {
    fn from(e: std::io::Error) -> Self {
        Self::Other(e.into())
    }
}

/// The Python exception for `e`, by its kind: [`NodeError`] with its attributes for a run's
/// failed process, [`OutputError`] for the files of a run or a campaign, [`ConfigError`] with
/// its attributes for a config error (a run's, a campaign's, a design's), else
/// [`PlatoonError`]; the message is the whole chain of causes.
fn py_err(py: Python<'_>, e: CoreError) -> PyErr {
    let message = e.message();
    if let Some(RunError::Node(n)) = e.run() {
        let dir = match &e {
            CoreError::Recorded { dir, .. } => Some(dir),
            _ => None,
        };
        let err = NodeError::new_err(message);
        let value = err.value(py);
        let _ = value.setattr("node", n.node);
        let _ = value.setattr("step", n.step);
        let _ = value.setattr("log", n.log.as_ref().map(|p| p.display().to_string()));
        let _ = value.setattr("message", n.message.as_str());
        let _ = value.setattr("run_dir", dir.map(|d| d.display().to_string()));
        return err;
    }
    if let Some(o) = e.output() {
        let err = OutputError::new_err(message);
        let _ = err
            .value(py)
            .setattr("path", o.path().map(|p| p.display().to_string()));
        return err;
    }
    if let Some(c) = e.config() {
        let err = ConfigError::new_err(c.to_string());
        let value = err.value(py);
        let _ = value.setattr("file", c.file.display().to_string());
        let _ = value.setattr("key", c.key.as_str());
        let _ = value.setattr("message", c.message.as_str());
        let _ = value.setattr("line", c.line);
        return err;
    }
    PlatoonError::new_err(message)
}

/// Runs `work` on a thread of its own without the GIL; the calling thread waits, checking for
/// signals every 100 ms. On a KeyboardInterrupt (or any exception a signal handler raises)
/// with a `flag`, the flag is set and the work waited for (it stops at its next check of the
/// flag), then the exception is raised. A second interrupt, or the first for work that cannot
/// be stopped (`flag` None), is raised at once: the work is left to finish on its thread.
fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    flag: Option<&Arc<AtomicBool>>,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    /// Marks the work done however its thread ends (a panic too), and wakes the caller.
    struct Finished(Arc<(Mutex<bool>, Condvar)>);
    impl Drop for Finished {
        fn drop(&mut self) {
            let (lock, cv) = &*self.0;
            *lock.lock().unwrap_or_else(|p| p.into_inner()) = true;
            cv.notify_all();
        }
    }
    let done = Arc::new((Mutex::new(false), Condvar::new()));
    let finished = Finished(done.clone());
    let worker = std::thread::Builder::new()
        .name("platoon-core".into())
        .spawn(move || {
            let _finished = finished;
            work()
        })
        .map_err(|e| PlatoonError::new_err(format!("cannot start a thread: {e}")))?;
    let mut interrupt = None;
    loop {
        let over = py.detach(|| {
            let (lock, cv) = &*done;
            let guard = lock.lock().unwrap_or_else(|p| p.into_inner());
            let (guard, _) = cv
                .wait_timeout_while(guard, Duration::from_millis(100), |d| !*d)
                .unwrap_or_else(|p| p.into_inner());
            *guard
        });
        if over {
            break;
        }
        if let Err(e) = py.check_signals() {
            match (flag, &interrupt) {
                (Some(flag), None) => {
                    flag.store(true, Ordering::SeqCst);
                    interrupt = Some(e);
                }
                _ => return Err(e),
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

/// Where a dict config came from: the resolved config it was made from (JSON), whose
/// untouched keys of a switched rule may go, and the file it was read from, whose directory its
/// relative paths (`sumo.net`, ...) are relative to.
struct DictOrigin {
    config: Option<String>,
    file: Option<PathBuf>,
}

/// The config a call names: a TOML file (`is_path`) or a dict as JSON, labelled `<dict>` (or
/// `<dict of NAME>` beside the file NAME it was read from, which relative paths are resolved
/// against); a dict has no lines, so its errors name the key alone. A dict made from a resolved
/// config may switch a rule or kind without removing the old one's keys.
fn load_config(
    config: &str,
    is_path: bool,
    origin: &DictOrigin,
) -> Result<(platoon_config::Config, platoon_sim::Scenario, PathBuf)> {
    if is_path {
        let path = PathBuf::from(config);
        let (c, s) = platoon_config::load(&path)?;
        return Ok((c, s, path));
    }
    let label = match &origin.file {
        Some(file) => {
            let name = file.file_name().unwrap_or_default().to_string_lossy();
            file.parent()
                .unwrap_or(Path::new(""))
                .join(format!("<dict of {name}>"))
        }
        None => PathBuf::from("<dict>"),
    };
    // JSON's nulls (a key left at its default) have no TOML form: they are left out.
    fn without_nulls(v: serde_json::Value) -> serde_json::Value {
        use serde_json::Value;
        match v {
            Value::Object(m) => Value::Object(
                m.into_iter()
                    .filter(|(_, v)| !v.is_null())
                    .map(|(k, v)| (k, without_nulls(v)))
                    .collect(),
            ),
            Value::Array(a) => Value::Array(a.into_iter().map(without_nulls).collect()),
            other => other,
        }
    }
    let parse_json = |text: &str| -> Result<toml::Value, ConfigFileError> {
        let bad = |e: serde_json::Error| {
            ConfigFileError::new(&label, "", format!("not a config dict: {e}"))
        };
        let json: serde_json::Value = serde_json::from_str(text).map_err(bad)?;
        serde_json::from_value(without_nulls(json)).map_err(bad)
    };
    let mut value = parse_json(config)?;
    if let Some(origin) = &origin.config {
        platoon_campaign::overrides::drop_switched_variants(&mut value, &parse_json(origin)?);
    }
    let text = toml::to_string(&value)
        .map_err(|e| ConfigFileError::new(&label, "", format!("not a config dict: {e}")))?;
    let (c, s) = platoon_config::parse(&text, &label).map_err(|mut e| {
        e.line = None;
        e
    })?;
    Ok((c, s, label))
}

/// `scenario(name)`: an embedded scenario (`paper`, `table1`, `degradation`) or a TOML file,
/// resolved (every default written out), as JSON.
#[pyfunction]
fn scenario(py: Python<'_>, name: &str) -> PyResult<String> {
    let loaded = match Embedded::ALL.iter().find(|e| e.name() == name) {
        Some(e) => e.parse().map_err(CoreError::from),
        None if Path::new(name).is_file() => {
            platoon_config::load(Path::new(name)).map_err(CoreError::from)
        }
        None => Err(CoreError::Other(anyhow::anyhow!(
            "no scenario {name:?}: the embedded ones are {}, or give a TOML file's path",
            Embedded::ALL.map(|e| e.name()).join(", ")
        ))),
    };
    let (config, _) = loaded.map_err(|e| py_err(py, e))?;
    serde_json::to_string(&config).map_err(|e| py_err(py, e.into()))
}

/// The names of the embedded scenarios.
#[pyfunction]
fn scenario_names() -> Vec<&'static str> {
    Embedded::ALL.iter().map(|e| e.name()).collect()
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
/// after, when None; kept and named when the run fails), and the tables are read back from
/// its files.
/// Where a call's config comes from, as the package's `_config_arg` hands it over: a dict as
/// JSON (with where a Scenario came from), a file's path, or an embedded scenario's name.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct ConfigArg {
    config: String,
    is_path: bool,
    #[pyo3(default)]
    origin: Option<String>,
    #[pyo3(default)]
    source: Option<PathBuf>,
}

impl ConfigArg {
    /// The config, its scenario and the label a run records it under.
    fn load(self) -> Result<(platoon_config::Config, platoon_sim::Scenario, PathBuf)> {
        let origin = DictOrigin {
            config: self.origin,
            file: self.source,
        };
        load_config(&self.config, self.is_path, &origin)
    }
}

/// `run`'s options, the keyword arguments of `platoon.run` (a dict with every key).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct RunArgs {
    transport: String,
    plant: Option<String>,
    out: Option<PathBuf>,
    force: bool,
    plots: bool,
    injector: Option<String>,
    injector_after: bool,
    controller: Option<String>,
    step_timeout_s: f64,
}

/// `run(config, options)`: one scenario. In process with no `out`, nothing touches the disk:
/// the tables come from memory. Otherwise (a run directory asked for, a co-simulation, SUMO,
/// an external injector or controller) it is `platoon run` into `out` (a temporary directory,
/// removed after, when None; kept and named when the run fails), and the tables are read back
/// from its files.
#[pyfunction]
fn run(py: Python<'_>, config: ConfigArg, options: RunArgs) -> PyResult<RunResult> {
    let RunArgs {
        transport,
        plant,
        out,
        force,
        plots,
        injector,
        injector_after,
        controller,
        step_timeout_s,
    } = options;
    let (config, scenario, label) = config.load().map_err(|e| py_err(py, e))?;
    let transport = match transport.as_str() {
        "inproc" => Transport::Inproc,
        "iceoryx2" => Transport::Iceoryx2,
        other => {
            return Err(PyValueError::new_err(format!(
                "transport={other:?}: use \"inproc\" (one process) or \"iceoryx2\" (processes over shared memory)"
            )))
        }
    };
    let plant = match plant.as_deref() {
        None => None,
        Some("native") => Some(PlantKind::Native),
        Some("sumo") => Some(PlantKind::Sumo),
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "plant={other:?}: use \"native\" or \"sumo\" (None: the config's simulation.plant)"
            )))
        }
    };
    let step_timeout = match Duration::try_from_secs_f64(step_timeout_s) {
        Ok(t) if !t.is_zero() => t,
        _ => {
            return Err(PyValueError::new_err(format!(
                "step_timeout_s={step_timeout_s}: a positive number of seconds"
            )))
        }
    };
    if out.is_none() && (plots || force) {
        return Err(PyValueError::new_err(
            "plots=True and force=True are about a run directory: give out= too",
        ));
    }
    if injector_after && injector.is_none() {
        return Err(PyValueError::new_err(
            "injector_after=True runs an injector after the config's attacks: give injector= too",
        ));
    }
    let (flag, stop) = keyboard_stop();
    let native = plant.unwrap_or(config.simulation.plant) == PlantKind::Native;
    if transport == Transport::Inproc
        && out.is_none()
        && native
        && injector.is_none()
        && controller.is_none()
    {
        let done = interruptible(py, Some(&flag), move || -> Result<(Tables, String)> {
            let (tables, summary) =
                platoon_app::run::simulate_in_memory(&scenario, &config.output, &(), &stop)?;
            let extra = [("injector", platoon_app::run::builtin_injector_json())];
            let json = platoon_app::run::summary_json(&summary, &extra)?;
            Ok((tables, serde_json::to_string(&json)?))
        })?;
        let (tables, json) = done.map_err(|e| py_err(py, e))?;
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
        step_timeout,
        plots,
        config_file: label,
        ..RunOptions::default()
    };
    let (dir, temp) = match out {
        Some(out) => (out, None),
        None => {
            let temp = tempfile::Builder::new()
                .prefix("platoon-run-")
                .tempdir()
                .map_err(|e| {
                    py_err(
                        py,
                        anyhow::Error::from(e)
                            .context("creating a temporary run directory")
                            .into(),
                    )
                })?;
            (temp.path().join("run"), Some(temp))
        }
    };
    let asked = temp.is_none();
    let done = interruptible(
        py,
        Some(&flag),
        move || -> Result<(String, Tables, PathBuf)> {
            let outcome = platoon_app::run::run(config, &scenario, &opts, &dir, force, &stop, &())?;
            if let Some(failure) = outcome.failure {
                // What it recorded stays, in a temporary directory too (its logs say why).
                let dir = match temp {
                    Some(t) => t.keep().join("run"),
                    None => outcome.dir,
                };
                return Err(CoreError::Recorded { failure, dir });
            }
            let summary = outcome.dir.join("summary.json");
            let json = std::fs::read_to_string(&summary)
                .with_context(|| format!("reading {}", summary.display()))?;
            let tables = platoon_app::run::read_tables(&outcome.dir)?;
            drop(temp);
            Ok((json, tables, outcome.dir))
        },
    )?;
    let (json, tables, dir) = done.map_err(|e| py_err(py, e))?;
    let dir = asked.then(|| dir.display().to_string());
    Ok((json, to_pyarrow(py, tables)?, dir))
}

/// `cells.csv`'s columns by their meaning, whatever the values of one campaign: `cell` and
/// `sample` int64, `seed` uint64 (null without a seed), `status` and `error` strings, every
/// other column (an axis, a drawn value, a metric) float64 unless it holds text in this
/// campaign (a string axis or metric such as `safety_class`).
fn cells_schema(inferred: &arrow_schema::Schema) -> arrow_schema::Schema {
    use arrow_schema::{DataType, Field};
    let fields: Vec<Field> = inferred
        .fields()
        .iter()
        .map(|f| {
            let t = match f.name().as_str() {
                "cell" | "sample" => DataType::Int64,
                "seed" => DataType::UInt64,
                "status" | "error" => DataType::Utf8,
                _ => match f.data_type() {
                    DataType::Int64 | DataType::Float64 | DataType::Null => DataType::Float64,
                    other => other.clone(),
                },
            };
            Field::new(f.name(), t, true)
        })
        .collect();
    arrow_schema::Schema::new(fields)
}

/// `cells.csv` as record batches with [`cells_schema`]'s types (an empty cell is null).
fn read_cells(path: &Path) -> anyhow::Result<(arrow_schema::SchemaRef, Vec<RecordBatch>)> {
    use std::io::Seek;
    let mut file =
        std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let format = arrow_csv::reader::Format::default().with_header(true);
    let (inferred, _) = format
        .infer_schema(&mut file, None)
        .with_context(|| format!("reading {}", path.display()))?;
    file.rewind()?;
    let schema = Arc::new(cells_schema(&inferred));
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

/// `campaign`'s options, the keyword arguments of `platoon.campaign` (a dict with every key).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct CampaignArgs {
    out: Option<PathBuf>,
    jobs: Option<usize>,
    dask: Option<String>,
    force: bool,
    keep_runs: bool,
    plots: bool,
    samples: Option<usize>,
}

/// `campaign(path, options)`: `platoon campaign` into `out` (default `runs/<campaign name>`),
/// on the local pool or a Dask scheduler.
#[pyfunction]
fn campaign(py: Python<'_>, path: PathBuf, options: CampaignArgs) -> PyResult<CampaignResult> {
    let CampaignArgs {
        out,
        jobs,
        dask,
        force,
        keep_runs,
        plots,
        samples,
    } = options;
    let campaign =
        platoon_campaign::Campaign::load(&path, samples).map_err(|e| py_err(py, e.into()))?;
    let jobs = match jobs {
        None => None,
        Some(n) => Some(
            std::num::NonZeroUsize::new(n)
                .ok_or_else(|| PyValueError::new_err("jobs=0: at least one cell at a time"))?,
        ),
    };
    let executor: Box<dyn Executor + Send> = match (dask, jobs) {
        (Some(_), Some(_)) => {
            return Err(PyValueError::new_err(
                "jobs= is the local pool's; with dask= the cluster's workers run the cells",
            ))
        }
        (Some(address), None) => Box::new(Dask::new(address)),
        (None, jobs) => Box::new(LocalPool::new(jobs)),
    };
    let out = out.unwrap_or_else(|| PathBuf::from("runs").join(&campaign.name));
    let opts = CampaignOptions {
        force,
        keep_runs,
        plots,
    };
    let (flag, stop) = keyboard_stop();
    let done = interruptible(py, Some(&flag), move || -> Result<_> {
        let outcome = platoon_app::campaign::run(&campaign, &out, &opts, &*executor, &stop, &())?;
        if let Some(e) = outcome.failure {
            return Err(CoreError::Resumable {
                failure: e,
                dir: outcome.dir,
            });
        }
        if let Some(why) = outcome.stopped {
            return Err(CoreError::Other(anyhow::anyhow!(
                "{why}: the cells done are kept in {}; call again to resume",
                outcome.dir.display()
            )));
        }
        let report = outcome.dir.join("campaign.json");
        let json = std::fs::read_to_string(&report)
            .with_context(|| format!("reading {}", report.display()))?;
        Ok((
            json,
            read_cells(&outcome.dir.join("cells.csv"))?,
            outcome.dir,
        ))
    })?;
    let (json, (schema, batches), dir) = done.map_err(|e| py_err(py, e))?;
    let cells = to_pyarrow(py, vec![("cells", schema, batches)])?
        .pop()
        .map(|(_, t)| t)
        .expect("one table in, one out");
    Ok((json, cells, dir.display().to_string()))
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
            .map(|job| {
                // A cell that panics is that cell's error, not its batch's.
                std::panic::catch_unwind(|| platoon_app::campaign::execute(job, None))
                    .unwrap_or_else(|_| CellReply {
                        index: job.index,
                        summary: None,
                        error: Some(
                            "platoon's core panicked on this cell (a bug: please report it)".into(),
                        ),
                    })
            })
            .collect()
    });
    serde_json::to_string(&replies).map_err(|e| py_err(py, e.into()))
}

/// `check_gain`'s options, the keyword arguments of `platoon.design.check_gain` (a dict with
/// every key).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct CheckGainArgs {
    gain: Option<[f64; 3]>,
    c: f64,
    theorem: u8,
    time_headway: Option<f64>,
}

/// `check_gain(config, options)`: `platoon design check-gain`'s report (check.json) as JSON.
/// A design check cannot be stopped halfway: a KeyboardInterrupt returns at once and leaves
/// it to finish on its thread.
#[pyfunction]
fn check_gain(py: Python<'_>, config: ConfigArg, options: CheckGainArgs) -> PyResult<String> {
    let CheckGainArgs {
        gain,
        c,
        theorem,
        time_headway,
    } = options;
    let (config, scenario, _) = config.load().map_err(|e| py_err(py, e))?;
    let theorem = platoon_app::design::Theorem::from_number(theorem)
        .ok_or_else(|| PyValueError::new_err(format!("theorem={theorem}: 1 or 2")))?;
    let opts = platoon_app::design::CheckOptions {
        gain,
        c,
        theorem,
        time_headway,
    };
    let report = interruptible(py, None, move || -> Result<String> {
        let report = platoon_app::design::check_gain(&config, &scenario, &opts)?;
        Ok(serde_json::to_string(&report)?)
    })?;
    report.map_err(|e| py_err(py, e))
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

/// The bridge of the checkout this core was built from (the SUMO plant, the Python examples,
/// its venv), if it is still there: the core's program is the Python interpreter, so the
/// command's own lookup (beside the running binary) would fall back to the copy it carries.
fn built_bridge() -> Option<PathBuf> {
    let bridge = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bridge");
    bridge
        .join("setup-venv.sh")
        .is_file()
        .then(|| bridge.canonicalize().ok())
        .flatten()
}

/// The compiled core of the `platoon` Python package.
#[pymodule]
#[pyo3(name = "_core")]
fn core_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    if std::env::var_os("PLATOON_BRIDGE_DIR").is_none() {
        if let Some(bridge) = built_bridge() {
            // For this process's lookups and the processes it starts.
            std::env::set_var("PLATOON_BRIDGE_DIR", bridge);
        }
    }
    m.add("PlatoonError", m.py().get_type::<PlatoonError>())?;
    m.add("ConfigError", m.py().get_type::<ConfigError>())?;
    m.add("NodeError", m.py().get_type::<NodeError>())?;
    m.add("OutputError", m.py().get_type::<OutputError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // Benchmarks through the package should say when they measured an unoptimised core.
    m.add(
        "build_profile",
        if cfg!(debug_assertions) {
            "dev"
        } else {
            "release"
        },
    )?;
    m.add_function(wrap_pyfunction!(scenario, m)?)?;
    m.add_function(wrap_pyfunction!(scenario_names, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(campaign, m)?)?;
    m.add_function(wrap_pyfunction!(execute_cells, m)?)?;
    m.add_function(wrap_pyfunction!(check_gain, m)?)?;
    m.add_function(wrap_pyfunction!(cli, m)?)?;
    Ok(())
}
