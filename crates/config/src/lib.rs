//! Scenario configuration files (TOML).
//!
//! Unknown keys are errors; every default is written in one place (the `default_*` functions and
//! `Default` impls here); a bad value is reported as `FILE: KEY: what is wrong`. [`load`] parses and
//! validates a file into a resolved [`Config`] (every default written out, so it can be saved next
//! to a run's outputs) and a runnable [`Scenario`].
#![warn(missing_docs)]

mod schema;
mod validate;

pub use schema::*;
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
        ConfigError {
            file: file.to_path_buf(),
            key: if key == "." { String::new() } else { key },
            message: inner.message().trim().to_string(),
            line,
        }
    })
}

/// Parses TOML text (from `file`, used in errors) into a resolved config and its scenario.
pub fn parse(text: &str, file: &Path) -> Result<(Config, Scenario), ConfigError> {
    let mut config: Config = deserialize(text, file)?;
    let scenario = to_scenario(&mut config).map_err(|(key, message)| ConfigError {
        file: file.to_path_buf(),
        key,
        message,
        line: None,
    })?;
    Ok((config, scenario))
}

/// Reads and parses a config file.
pub fn load(path: &Path) -> Result<(Config, Scenario), ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
        file: path.to_path_buf(),
        key: String::new(),
        message: format!("cannot read the config: {e}"),
        line: None,
    })?;
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
