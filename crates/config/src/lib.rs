//! Scenario configuration files (TOML).
//!
//! Unknown keys are errors; every default is written in one place (the schema types' serde
//! defaults and `Default` impls); a bad value is reported as `FILE:LINE: key `KEY`: what is
//! wrong`. [`load`] parses and validates a file into a resolved [`Config`] (every default
//! written out, so it can be saved next to a run's outputs) and a runnable [`Scenario`]:
//! [`scenario_of`] resolves the tables, one resolver each, reading the config only, and
//! [`write_resolved_defaults`] then writes the defaults that depend on other keys. A value
//! that cannot be used is a [`KeyError`] (the key and a [`Reason`]), placed at its file and
//! line as a [`ConfigError`].
//!
//! A table whose keys depend on a selector (`[trigger] rule`, `[attack] kind`,
//! `[[channel.attacks]] kind`, `[platoon] spacing_policy`, `[topology] preset`) is a typed enum
//! ([`RuleConfig`], [`DosConfig`], [`LinkKindConfig`], [`SpacingConfig`], [`TopologyConfig`])
//! flattened into it; [`tagged_tables`] lists them, read from the JSON Schema the
//! [`mod@reference`] module derives from the types.
#![warn(missing_docs)]

mod error;
mod lines;
pub mod reference;
mod resolve;
mod schema;
mod serde_util;
#[cfg(test)]
mod shipped;
mod tagged;
mod transport;

pub use error::{ConfigError, KeyError, Num, Reason};
use lines::line_at;
pub use lines::KeyLines;
pub use reference::{
    check_committed, file_reference, json_schema, reference_markdown, schema_json, schema_of,
};
pub use resolve::{native_plant_check, scenario_of, to_scenario, write_resolved_defaults};
pub use schema::*;
pub use tagged::{tagged_tables, TaggedTable, TaggedVariant};
pub use transport::Transport;

use platoon_sim::Scenario;
use std::path::Path;

/// The configs this crate embeds, so that commands run with nothing but the binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Embedded {
    /// `configs/paper.toml`: the paper's Section IV scenario ([`PAPER_TOML`]).
    Paper,
    /// `configs/table1.toml`: Table I ([`TABLE1_TOML`]).
    Table1,
    /// `configs/degradation.toml`: graceful degradation ([`DEGRADATION_TOML`]).
    Degradation,
    /// `configs/cut-in.toml`: a car cuts in between followers 2 and 3 ([`CUT_IN_TOML`]).
    CutIn,
    /// `configs/join.toml`: a join at the tail ([`JOIN_TOML`]).
    Join,
    /// `configs/join-middle.toml`: a join in the middle ([`JOIN_MIDDLE_TOML`]).
    JoinMiddle,
    /// `configs/leave.toml`: leaves in the middle and at the tail ([`LEAVE_TOML`]).
    Leave,
    /// `configs/merge.toml`: two platoons merge ([`MERGE_TOML`]).
    Merge,
    /// `configs/split.toml`: a platoon splits in two ([`SPLIT_TOML`]).
    Split,
}

impl Embedded {
    /// Every embedded config.
    pub const ALL: [Embedded; 9] = [
        Self::Paper,
        Self::Table1,
        Self::Degradation,
        Self::CutIn,
        Self::Join,
        Self::JoinMiddle,
        Self::Leave,
        Self::Merge,
        Self::Split,
    ];

    /// Its stem in `configs/` (the default name of its runs).
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Table1 => "table1",
            Self::Degradation => "degradation",
            Self::CutIn => "cut-in",
            Self::Join => "join",
            Self::JoinMiddle => "join-middle",
            Self::Leave => "leave",
            Self::Merge => "merge",
            Self::Split => "split",
        }
    }

    /// Its TOML text.
    pub fn text(self) -> &'static str {
        match self {
            Self::Paper => PAPER_TOML,
            Self::Table1 => TABLE1_TOML,
            Self::Degradation => DEGRADATION_TOML,
            Self::CutIn => CUT_IN_TOML,
            Self::Join => JOIN_TOML,
            Self::JoinMiddle => JOIN_MIDDLE_TOML,
            Self::Leave => LEAVE_TOML,
            Self::Merge => MERGE_TOML,
            Self::Split => SPLIT_TOML,
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

/// A deserialisation error: the error, and the span of the value it is about.
type Spanned = (ConfigError, Option<std::ops::Range<usize>>);

fn deserialize_spanned<T: serde::de::DeserializeOwned>(
    text: &str,
    file: &Path,
) -> Result<T, Spanned> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        let span = inner.span();
        let line = span.as_ref().map(|s| {
            let l = line_at(text, s.start);
            // A span starting at a line's end is about the next line.
            l.min(text.lines().count().max(1))
        });
        let error = ConfigError::new(
            file,
            if key == "." { String::new() } else { key },
            inner.message().trim(),
        )
        .at_line(line);
        (error, span)
    })
}

/// Deserialises TOML text (from `file`, used in errors) into any of our file schemas, with the
/// line and dotted key of the first error (`FILE:LINE: key `KEY`: ...`).
pub fn deserialize<T: serde::de::DeserializeOwned>(
    text: &str,
    file: &Path,
) -> Result<T, ConfigError> {
    deserialize_spanned(text, file).map_err(|(e, _)| e)
}

/// `missing field `X`` at `table` is about the key `table.X`.
fn missing_key(path: &str, message: &str) -> Option<String> {
    let rest = message.strip_prefix("missing field `")?;
    let key = &rest[..rest.find('`')?];
    Some(if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    })
}

/// The key at fault when deserialising a config failed at `path` with `message`: serde reports
/// the errors inside a tagged table (a flattened enum) at the table; [`tagged::diagnose`] finds
/// the key and says what is wrong in the config's terms (`trigger.mu` is not used with
/// `rule = "dynamic"`). `None` when the error is already about a key.
fn refine(path: &str, message: &str, document: &toml::Value) -> Option<KeyError> {
    let value = refine_value(document, path)?;
    let parent = path.rsplit_once('.').map(|(p, _)| p).unwrap_or("");
    tagged::diagnose(path, value, message)
        .or_else(|| {
            // An unknown selector value is reported at the selector, below its table.
            let table = refine_value(document, parent)?;
            tagged::diagnose(parent, table, message).filter(|e| e.key == path)
        })
        .or_else(|| {
            missing_key(path, message).map(|k| KeyError::new(k, Reason::Schema(message.into())))
        })
}

/// The value at a dotted `path` (`channel.attacks[1]`) of `document`.
fn refine_value<'a>(document: &'a toml::Value, path: &str) -> Option<&'a toml::Value> {
    let mut value = document;
    for segment in path.split('.').filter(|s| !s.is_empty()) {
        let (name, indices) = match segment.find('[') {
            Some(i) => (&segment[..i], &segment[i..]),
            None => (segment, ""),
        };
        value = value.get(name)?;
        for index in indices.split(['[', ']']).filter(|s| !s.is_empty()) {
            value = value.get(index.parse::<usize>().ok()?)?;
        }
    }
    Some(value)
}

/// The line of `key` (its last segment) within the span of its table, if it is written there
/// (at the start of a line, or after `{` or `,` in an inline table, not in a comment).
fn key_line(text: &str, span: &std::ops::Range<usize>, key: &str) -> Option<usize> {
    let name = key.rsplit('.').next()?;
    let region = text.get(span.clone())?;
    let mut from = 0;
    while let Some(i) = region[from..].find(name) {
        let at = from + i;
        let line_start = region[..at].rfind('\n').map_or(0, |n| n + 1);
        let before = region[line_start..at].trim_end();
        let in_comment = region[line_start..at].contains('#');
        let starts_key = before.is_empty() || before.ends_with('{') || before.ends_with(',');
        let after = region[at + name.len()..].trim_start();
        if starts_key && !in_comment && after.starts_with('=') {
            return Some(line_at(text, span.start + at));
        }
        from = at + name.len();
    }
    None
}

/// Deserialises a config's TOML text, naming the key at fault in a tagged table.
fn deserialize_config(text: &str, file: &Path) -> Result<Config, ConfigError> {
    deserialize_spanned(text, file).map_err(|(mut e, span)| {
        let document: Option<toml::Value> = toml::from_str(text).ok();
        if let Some(refined) = document.and_then(|d| refine(&e.key, &e.message, &d)) {
            if let Some(line) = span.as_ref().and_then(|s| key_line(text, s, &refined.key)) {
                e.line = Some(line);
            }
            e.message = refined.reason.to_string();
            e.key = refined.key;
        }
        e
    })
}

/// Deserialises a config held as a TOML value (a campaign's cell before it is written), the
/// error naming the key at fault as [`parse`] names it ([`Reason::Schema`]).
pub fn from_value(value: toml::Value) -> Result<Config, KeyError> {
    serde_path_to_error::deserialize::<_, Config>(value.clone()).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        let message = e.inner().message().trim().to_string();
        refine(&path, &message, &value)
            .unwrap_or_else(|| KeyError::new(path, Reason::Schema(message)))
    })
}

/// Parses TOML text (from `file`, used in errors) into a resolved config and its scenario.
pub fn parse(text: &str, file: &Path) -> Result<(Config, Scenario), ConfigError> {
    let mut config: Config = deserialize_config(text, file)?;
    let scenario = scenario_of(&config).map_err(|e| e.in_file(file, &KeyLines::new(text)))?;
    write_resolved_defaults(&mut config);
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

/// The cut-in scenario (a car cuts in between followers 2 and 3, no attack), embedded for
/// `platoon experiment traffic`.
pub const CUT_IN_TOML: &str = include_str!("../../../configs/cut-in.toml");

/// The maneuver scenarios, embedded for `platoon experiment maneuvers`: a join at the tail...
pub const JOIN_TOML: &str = include_str!("../../../configs/join.toml");

/// ...a join in the middle...
pub const JOIN_MIDDLE_TOML: &str = include_str!("../../../configs/join-middle.toml");

/// ...leaves...
pub const LEAVE_TOML: &str = include_str!("../../../configs/leave.toml");

/// ...a merge of two platoons...
pub const MERGE_TOML: &str = include_str!("../../../configs/merge.toml");

/// ...and a split of one.
pub const SPLIT_TOML: &str = include_str!("../../../configs/split.toml");
