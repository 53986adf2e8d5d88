//! What can be wrong with a config: [`KeyError`], a key and why (what resolution and
//! deserialising a value say), and [`ConfigError`], what users see: the file, the line, the
//! key and the message (`FILE:LINE: key `KEY`: message`).
use crate::lines::KeyLines;
use std::fmt;
use std::path::PathBuf;

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
            message: sane_numbers(&message.into()),
            line: None,
        }
    }

    /// What is wrong with `key` of `file`, placed at the line the key stands on in `lines`.
    pub fn at_key(
        file: impl Into<PathBuf>,
        lines: &KeyLines,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        let key = key.into();
        let line = lines.line_of(&key);
        Self::new(file, key, message).at_line(line)
    }

    /// The same error, placed at 1-based `line` when known.
    pub fn at_line(mut self, line: Option<usize>) -> Self {
        self.line = line;
        self
    }
}

/// What is wrong with one key of a config, before it is placed in a file: the key's dotted path
/// (`channel.attacks[1].loss`) and the [`Reason`]. [`crate::scenario_of`] and
/// [`crate::from_value`] return it; [`KeyError::in_file`] makes it a [`ConfigError`] at the
/// key's line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `{key}`: {}", sane_numbers(&reason.to_string()))]
pub struct KeyError {
    /// Dotted key path; empty for the config as a whole.
    pub key: String,
    /// What is wrong with it.
    pub reason: Reason,
}

impl KeyError {
    /// `key` is wrong for `reason`.
    pub fn new(key: impl Into<String>, reason: Reason) -> Self {
        Self {
            key: key.into(),
            reason,
        }
    }

    /// `key` is wrong, as `message` says ([`Reason::Invalid`]).
    pub fn invalid(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(key, Reason::Invalid(message.into()))
    }

    /// The error users see: in `file`, at the line `lines` gives the key.
    pub fn in_file(self, file: impl Into<PathBuf>, lines: &KeyLines) -> ConfigError {
        ConfigError::at_key(file, lines, self.key, self.reason.to_string())
    }
}

/// Why a key's value cannot be used. The message of each says it in the config's terms.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Reason {
    /// The value does not deserialise (a wrong type, an unknown key, a missing one, the keys of
    /// another variant of a tagged table): what serde, or the tagged table's schema, says.
    #[error("{0}")]
    Schema(String),
    /// Not a finite number.
    #[error("must be a finite number, got {}", Num(*.0))]
    NotFinite(f64),
    /// Not above zero.
    #[error("must be > 0, got {}", Num(*.0))]
    NotPositive(f64),
    /// A period shorter than the simulation's step.
    #[error("{} s is shorter than the step simulation.dt_s = {} s", Num(*.period_s), Num(*.dt_s))]
    ShorterThanStep {
        /// The period (s).
        period_s: f64,
        /// The step (s).
        dt_s: f64,
    },
    /// A period that is no whole number of steps.
    #[error("{} s must be a whole number of steps of {} s", Num(*.period_s), Num(*.dt_s))]
    NotWholeSteps {
        /// The period (s).
        period_s: f64,
        /// The step (s).
        dt_s: f64,
    },
    /// The law reads a vehicle that the topology does not let a follower hear (key
    /// `topology.preset`): another topology may run it.
    #[error("{0}")]
    Unheard(String),
    /// The law cannot run the platoon's maneuvers (key `maneuvers`): another law may.
    #[error("{0}")]
    LawWithoutManeuvers(String),
    /// Any other value out of its range or at odds with another key, as the message says.
    #[error("{0}")]
    Invalid(String),
}

/// A number as a config error prints it: as Rust writes it between 1e-4 and 1e15 (`0.5`,
/// `20`), in scientific notation beyond (`1e308`, not its 309 digits).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a.is_finite() && a != 0.0 && !(1e-4..1e15).contains(&a) {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

/// `message` with every number of more than 17 digits (how Rust's `{}` and serde print 1e308,
/// 1e-300 or an integer key given 2e17) rewritten as [`Num`] prints it, whatever wrote it.
pub(crate) fn sane_numbers(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(start) = rest.find(|c: char| c.is_ascii_digit()) {
        out.push_str(&rest[..start]);
        let token_len = rest[start..]
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(rest.len() - start);
        let token = rest[start..start + token_len].trim_end_matches('.');
        let digits = token.chars().filter(char::is_ascii_digit).count();
        match token.parse::<f64>() {
            Ok(x) if digits > 17 => out.push_str(&Num(x).to_string()),
            _ => out.push_str(token),
        }
        rest = &rest[start + token.len()..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_numbers_are_printed_as_numbers() {
        let long = format!("got {} and {}, 12.5 m", 1e308, -1e-300);
        assert_eq!(sane_numbers(&long), "got 1e308 and -1e-300, 12.5 m");
        assert_eq!(
            sane_numbers("floating point `100000000000000000000.0`, expected u64."),
            "floating point `1e20`, expected u64."
        );
        assert_eq!(sane_numbers("line 12: 0.5 s"), "line 12: 0.5 s");
    }
}
