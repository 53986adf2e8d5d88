//! The campaign file's schema (TOML, unknown keys are errors).
pub use platoon_config::Transport;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Declares a file that runs a base scenario (a campaign file, a search file): its keys
/// `name`, `base`, `seed` and `transport` first, then the struct's own. A macro, not a shared
/// struct: the files are flat TOML tables, and `serde(flatten)` goes neither with
/// `deny_unknown_fields` nor with the config crate's key-span errors. Every crate that uses it
/// depends on `platoon-config`.
#[macro_export]
macro_rules! scenario_file {
    ($(#[$meta:meta])* pub struct $name:ident { $($fields:tt)* }) => {
        $(#[$meta])*
        pub struct $name {
            /// Free-form name \[the file's stem\].
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub name: Option<String>,
            /// The scenario it starts from, relative to this file \[the embedded paper
            /// scenario, configs/paper.toml\].
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub base: Option<String>,
            /// The seed every random draw derives from \[0\].
            #[serde(default)]
            pub seed: u64,
            /// How each run goes: `inproc` (the pure core in this process's workers, the
            /// oracle) or `iceoryx2` (a full co-simulation of processes per run; needed for
            /// `plant = "sumo"`).
            #[serde(default = "platoon_config::Transport::file_default")]
            pub transport: platoon_config::Transport,
            $($fields)*
        }
    };
}

scenario_file! {
    /// A campaign file. `campaigns/*.toml` document every key with a comment. Its Monte Carlo
    /// draws derive from the seed and the sample index.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
    #[serde(deny_unknown_fields)]
    pub struct CampaignFile {
        /// Keys set in every cell, by dotted path (`"simulation.duration_s" = 20.0`).
        #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
        #[schemars(with = "BTreeMap<String, serde_json::Value>")]
        pub set: BTreeMap<String, toml::Value>,
        /// The axes, crossed in file order (the first varies slowest), except those sharing a
        /// `zip` group, which advance together.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        pub axes: Vec<AxisSpec>,
        /// The DoS-window map: one attack interval `[onset, onset + duration)` per cell.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub dos_window: Option<DosWindow>,
        /// Random draws per sample, crossed with the axes.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub monte_carlo: Option<MonteCarlo>,
        /// What `cells.csv` reports per cell [see `platoon campaign --help`].
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub metrics: Option<Vec<String>>,
    }
}

/// `[[axes]]`: one config key and its values (a list or a range).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AxisSpec {
    /// Dotted path of a scenario key: `trigger.rule`, `platoon.followers`,
    /// `channel.attacks[0].loss`, ...
    pub key: String,
    /// The values, any TOML values of the key's type.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<Vec<serde_json::Value>>")]
    pub values: Option<Vec<toml::Value>>,
    /// Or a numeric range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<Range>,
    /// Axes with the same zip group advance together (equal lengths) instead of crossing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zip: Option<String>,
}

/// A numeric range: `from`, `to` (inclusive) and either `step` or `count` (evenly spaced).
/// Integers throughout (`from`, `to`, `step`) give integer values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Range {
    /// First value.
    #[schemars(with = "serde_json::Value")]
    pub from: toml::Value,
    /// Last value (included when the steps land on it).
    #[schemars(with = "serde_json::Value")]
    pub to: toml::Value,
    /// Increment.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<serde_json::Value>")]
    pub step: Option<toml::Value>,
    /// Number of evenly spaced values from `from` to `to`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<usize>,
}

/// Values of a DoS-window axis: a list of seconds or a range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Values {
    /// Explicit values.
    List(Vec<f64>),
    /// A range.
    Range(Range),
}

/// `[dos_window]`: replaces the base's DoS schedule by one interval per cell (keeping its
/// `attack.assumption2` bounds, so every cell gets the Assumption-2 verdict).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DosWindow {
    /// Start of the attack (s).
    pub onset_s: Values,
    /// Its length (s).
    pub duration_s: Values,
}

/// `[monte_carlo]`: `samples` draws per combination of the axes; draw `s` uses the same random
/// numbers in every combination (common random numbers, so axes compare on equal draws).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MonteCarlo {
    /// Number of samples.
    pub samples: usize,
    /// A random admissible DoS schedule per sample (`attack.kind = "random"` with a drawn seed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dos: Option<RandomDosSpec>,
    /// `[min, max]`: a Bernoulli loss rate drawn uniformly, on every link, appended to
    /// `channel.attacks` (with a drawn `channel.seed`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loss: Option<[f64; 2]>,
    /// `[min, max]`: a constant true tau drawn uniformly (replaces `plant.tau`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_s: Option<[f64; 2]>,
    /// Largest initial position offset of a follower (m), uniform \[0\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub position_jitter_m: f64,
    /// Largest initial speed offset of a follower (m/s), uniform \[0\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub speed_jitter_mps: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// Assumption 2's bounds and the generator's proposal ranges (see `[attack] kind = "random"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct RandomDosSpec {
    /// Frequency bound: N(t1, t2) <= T1 + (t2 - t1) / T2.
    pub T1: f64,
    /// Frequency bound's period (s).
    pub T2: f64,
    /// Duration bound: |A(t1, t2)| <= D1 + (t2 - t1) / D2 (s).
    pub D1: f64,
    /// Duration bound's ratio.
    pub D2: f64,
    /// Smallest quiet time between attacks (s).
    pub min_gap_s: f64,
    /// Largest proposed quiet time (s).
    pub max_gap_s: f64,
    /// Shortest proposed attack (s).
    pub min_duration_s: f64,
    /// Longest proposed attack (s).
    pub max_duration_s: f64,
}

/// `docs/campaign-reference.md`: every key of a campaign file, generated from [`CampaignFile`].
pub fn reference_markdown() -> String {
    platoon_config::file_reference(
        &platoon_config::schema_of::<CampaignFile>(),
        "Campaign file reference",
        "platoon_campaign::reference_markdown() from the schema types in \
         crates/campaign/src/spec.rs",
        "`PLATOON_BLESS=1 cargo test -p platoon-campaign --test reference`",
        "Every key of a campaign file (`platoon campaign FILE`), table by table. Unknown keys are \
         errors; a key with a default may be left out. The scenario keys a campaign sets or \
         sweeps are those of the [config reference](config-reference.md). \
         [campaigns.md](campaigns.md) shows them at work.",
    )
}
