//! The search file's schema (TOML, unknown keys are errors): the scenario, the harm, the
//! budget, the evaluations and the baselines. `campaigns/worst-dos.toml` documents every key.
use platoon_campaign::metrics;
use platoon_campaign::Values;
use platoon_config::LawName;
use platoon_search::{EvolutionSettings, Limits, RandomSettings};
use platoon_topology::Preset;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Harms a search can maximise: every numeric campaign metric (the smallest ones, `min_*` and
/// `first_collision_s`, are minimised).
pub fn harms() -> Vec<&'static str> {
    metrics::ALL
        .iter()
        .map(|(n, _)| *n)
        .filter(|n| !matches!(*n, "safety_class" | "assumption2" | "triggers_by_follower"))
        .collect()
}

/// The strategies a search can be compared with.
pub const BASELINES: [&str; 2] = ["random", "grid"];

platoon_campaign::scenario_file! {
    /// A search file. `campaigns/worst-dos.toml` documents every key. Each candidate replaces
    /// its base's DoS; the base's link attacks stay.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
    #[serde(deny_unknown_fields)]
    pub struct SearchFile {
        /// Runs per strategy \[1000\].
        #[serde(default = "default_evaluations")]
        pub evaluations: usize,
        /// What the attacker maximises: a campaign metric \[max_spacing_error_m\].
        #[serde(default = "default_harm")]
        pub harm: String,
        /// The strategies run beside the search at the same evaluations \[random, grid\].
        #[serde(default = "default_compare")]
        pub compare: Vec<String>,
        /// A schedule of your own to report beside them, `[start (s), duration (s)]` pairs (the
        /// budget must admit it; it is not one of the evaluations).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub reference: Option<Vec<[f64; 2]>>,
        /// What the attacker may do.
        #[serde(default)]
        pub budget: Limits,
        /// How the search searches.
        #[serde(default)]
        pub search: EvolutionSettings,
        /// The random baseline.
        #[serde(default)]
        pub random: RandomFile,
        /// The grid baseline.
        #[serde(default)]
        pub grid: GridFile,
        /// One search per law and topology.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub study: Option<StudyFile>,
    }
}

fn default_evaluations() -> usize {
    1000
}
fn default_harm() -> String {
    "max_spacing_error_m".into()
}
fn default_compare() -> Vec<String> {
    BASELINES.iter().map(|s| s.to_string()).collect()
}

/// `[random]`: the random admissible baseline (the generator's settings default to the
/// Monte Carlo campaign's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RandomFile {
    /// Its seed, as a Monte Carlo campaign's `seed` \[the search's\]: 2024 meets the schedules of
    /// `campaigns/monte-carlo.toml`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Smallest quiet time between two jams (s) \[1\].
    #[serde(default = "rs_min_gap")]
    pub min_gap_s: f64,
    /// Largest proposed quiet time (s) \[12\].
    #[serde(default = "rs_max_gap")]
    pub max_gap_s: f64,
    /// Shortest proposed jam (s) \[0.5\].
    #[serde(default = "rs_min_duration")]
    pub min_duration_s: f64,
    /// Longest proposed jam (s) \[3\].
    #[serde(default = "rs_max_duration")]
    pub max_duration_s: f64,
}

fn rs_min_gap() -> f64 {
    RandomSettings::default().min_gap_s
}
fn rs_max_gap() -> f64 {
    RandomSettings::default().max_gap_s
}
fn rs_min_duration() -> f64 {
    RandomSettings::default().min_duration_s
}
fn rs_max_duration() -> f64 {
    RandomSettings::default().max_duration_s
}

impl Default for RandomFile {
    fn default() -> Self {
        let d = RandomSettings::default();
        Self {
            seed: None,
            min_gap_s: d.min_gap_s,
            max_gap_s: d.max_gap_s,
            min_duration_s: d.min_duration_s,
            max_duration_s: d.max_duration_s,
        }
    }
}

impl RandomFile {
    /// The generator's settings.
    pub fn settings(&self) -> RandomSettings {
        RandomSettings {
            min_gap_s: self.min_gap_s,
            max_gap_s: self.max_gap_s,
            min_duration_s: self.min_duration_s,
            max_duration_s: self.max_duration_s,
        }
    }
}

/// `[grid]`: the one-jam grid baseline \[the DoS-timing campaign's\].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GridFile {
    /// Onsets (s).
    pub onset_s: Values,
    /// Durations (s).
    pub duration_s: Values,
}

impl Default for GridFile {
    /// `campaigns/dos-timing.toml`'s: onsets 0 to 50 s by 1 s, durations 0.5 to 5 s by 0.5 s.
    fn default() -> Self {
        let range = |from: f64, to: f64, step: f64| {
            Values::Range(platoon_campaign::Range {
                from: toml::Value::Float(from),
                to: toml::Value::Float(to),
                step: Some(toml::Value::Float(step)),
                count: None,
            })
        };
        Self {
            onset_s: range(0.0, 50.0, 1.0),
            duration_s: range(0.5, 5.0, 0.5),
        }
    }
}

/// `[study]`: the search on every law and topology, each law as `platoon experiment
/// controllers` runs it (its beaconing and distances, in formation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// The laws \[every law\].
    #[serde(default = "all_laws")]
    pub laws: Vec<LawName>,
    /// The topologies \[pf, plf\].
    #[serde(default = "pf_plf")]
    pub topologies: Vec<Preset>,
    /// The field's laws' beacon period (s) \[0.1\].
    #[serde(default = "beacon")]
    pub beacon_period_s: f64,
}

fn all_laws() -> Vec<LawName> {
    LawName::ALL.to_vec()
}
fn pf_plf() -> Vec<Preset> {
    vec![Preset::Pf, Preset::Plf]
}
fn beacon() -> f64 {
    0.1
}

/// `docs/search-reference.md`: every key of a search file, generated from [`SearchFile`].
pub fn reference_markdown() -> String {
    platoon_config::file_reference(
        &platoon_config::schema_of::<SearchFile>(),
        "Search file reference",
        "platoon_app::search::reference_markdown() from the schema types in \
         crates/app/src/search/file.rs",
        "`PLATOON_BLESS=1 cargo test -p platoon-app --test app search_file::`",
        "Every key of a search file (`platoon search FILE`), table by table. Unknown keys are \
         errors; a key with a default may be left out. [search.md](search.md) shows them at \
         work.",
    )
}
