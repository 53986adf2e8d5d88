//! Scenario configuration files (TOML).
//!
//! Unknown keys are errors; every default is written in one place (the `default_*` functions and
//! `Default` impls here); a bad value is reported as `FILE: KEY: what is wrong`. [`load`] parses and
//! validates a file into a resolved [`Config`] (every default written out, so it can be saved next
//! to a run's outputs) and a runnable [`Scenario`].
#![warn(missing_docs)]

mod schema;
mod transport;
mod validate;

pub use schema::*;
pub use transport::Transport;
pub use validate::to_scenario;

use platoon_sim::Scenario;
use std::fmt;
use std::path::{Path, PathBuf};

/// A config that cannot be used, with the file, the key and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigError {
    /// The file (or a label such as `<embedded paper>`).
    pub file: PathBuf,
    /// Dotted key path, e.g. `trigger.h_s`; empty for syntax errors.
    pub key: String,
    /// What is wrong and, where useful, what to do.
    pub message: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if !self.key.is_empty() {
            write!(f, ": key `{}`", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ConfigError {}

impl ConfigError {
    /// What is wrong with `key` (dotted path; empty for the file as a whole) of `file`.
    pub fn new(
        file: impl Into<PathBuf>,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self {
            file: file.into(),
            key: key.into(),
            message: message.into(),
            line: None,
        }
    }

    /// The same error, placed at 1-based `line` when known.
    pub fn at_line(mut self, line: Option<usize>) -> Self {
        self.line = line;
        self
    }
}

/// The configs this crate embeds, so that commands run with nothing but the binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Embedded {
    /// `configs/paper.toml`: the paper's Section IV scenario ([`PAPER_TOML`]).
    Paper,
    /// `configs/table1.toml`: Table I ([`TABLE1_TOML`]).
    Table1,
    /// `configs/degradation.toml`: graceful degradation ([`DEGRADATION_TOML`]).
    Degradation,
}

impl Embedded {
    /// Its stem in `configs/` (the default name of its runs).
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Table1 => "table1",
            Self::Degradation => "degradation",
        }
    }

    /// Its TOML text.
    pub fn text(self) -> &'static str {
        match self {
            Self::Paper => PAPER_TOML,
            Self::Table1 => TABLE1_TOML,
            Self::Degradation => DEGRADATION_TOML,
        }
    }

    /// The label its errors name in place of a file: `<embedded configs/paper.toml>`.
    pub fn label(self) -> String {
        format!("<embedded configs/{}.toml>", self.name())
    }

    /// Parses it.
    pub fn parse(self) -> Result<(Config, Scenario), ConfigError> {
        parse(self.text(), Path::new(&self.label()))
    }
}

/// A loaded config: the resolved [`Config`], its [`Scenario`], and the stem that names its runs
/// (the file's, or the embedded config's).
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The resolved config (every default written out).
    pub config: Config,
    /// What it runs.
    pub scenario: Scenario,
    /// The file's stem, or the embedded config's name.
    pub stem: String,
}

/// Loads `path`, or without one the embedded config `default`.
pub fn load_or(path: Option<&Path>, default: Embedded) -> Result<Loaded, ConfigError> {
    let ((config, scenario), stem) = match path {
        Some(path) => (
            load(path)?,
            path.file_stem()
                .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned()),
        ),
        None => (default.parse()?, default.name().into()),
    };
    Ok(Loaded {
        config,
        scenario,
        stem,
    })
}

/// The paper's Section IV scenario, embedded so `platoon run` works with nothing but cargo.
pub const PAPER_TOML: &str = include_str!("../../../configs/paper.toml");

/// Deserialises TOML text (from `file`, used in errors) into any of our file schemas, with the
/// line and dotted key of the first error (`FILE:LINE: key `KEY`: ...`).
pub fn deserialize<T: serde::de::DeserializeOwned>(
    text: &str,
    file: &Path,
) -> Result<T, ConfigError> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        let line = inner
            .span()
            .map(|s| text[..s.start.min(text.len())].lines().count().max(1));
        ConfigError::new(
            file,
            if key == "." { String::new() } else { key },
            inner.message().trim(),
        )
        .at_line(line)
    })
}

/// Parses TOML text (from `file`, used in errors) into a resolved config and its scenario.
pub fn parse(text: &str, file: &Path) -> Result<(Config, Scenario), ConfigError> {
    let mut config: Config = deserialize(text, file)?;
    let scenario =
        to_scenario(&mut config).map_err(|(key, message)| ConfigError::new(file, key, message))?;
    Ok((config, scenario))
}

/// Reads and parses a config file.
pub fn load(path: &Path) -> Result<(Config, Scenario), ConfigError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ConfigError::new(path, "", format!("cannot read the config: {e}")))?;
    parse(&text, path)
}

/// The resolved config as TOML (what a run directory's `config.toml` holds).
pub fn to_toml(config: &Config) -> String {
    toml::to_string_pretty(config).expect("a resolved config always serialises")
}

/// The Table I scenario (no DoS, tau = 0.5 s), embedded for `platoon experiment table1`.
pub const TABLE1_TOML: &str = include_str!("../../../configs/table1.toml");

/// The graceful-degradation scenario (ACC fallback, guard; an 8 s jam on the braking ramp),
/// embedded for `platoon experiment degradation`.
pub const DEGRADATION_TOML: &str = include_str!("../../../configs/degradation.toml");
