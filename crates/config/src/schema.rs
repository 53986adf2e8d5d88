use crate::serde_util::{self, DefaultTag};
use platoon_attacks::Assumption2;
use platoon_control::SpacingPolicy;
use platoon_model::tau::Interpolation;
use platoon_topology::Preset;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

mod channel;
mod control;

pub use channel::*;
pub use control::*;
pub use platoon_control::{LawName, LawParams, PaperParams};

// A table whose keys depend on a selector (`[trigger] rule`, `[attack] kind`,
// `[[channel.attacks]] kind`, `[platoon] spacing_policy`, `[topology] preset`) holds an
// internally tagged enum, flattened into the table: one variant per value of the selector, each
// with its own keys. The enum is the one list of those keys: deserialisation refuses the keys of
// another variant, the JSON Schema (`crate::reference`) documents them, and campaigns drop
// them when they change the selector (`crate::tagged`). Variants without keys are written
// `Name {}`, so that their keys too are checked.

/// A scenario file. See `configs/paper.toml` for every key with a comment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Free-form name of the scenario.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Time grid.
    pub simulation: Simulation,
    /// Vehicles and their initial states.
    pub platoon: Platoon,
    /// The leader's reference.
    #[serde(default)]
    pub leader: Leader,
    /// The communication graph.
    pub topology: TopologyConfig,
    /// The vehicles' dynamics.
    pub plant: Plant,
    /// Controller gain and trigger weights.
    pub control: Control,
    /// The triggering rule.
    pub trigger: Trigger,
    /// Degradation while affected by an attack.
    #[serde(default)]
    pub fallback: FallbackConfig,
    /// The on-board radar.
    #[serde(default)]
    pub radar: RadarConfig,
    /// The emergency-braking guard.
    #[serde(default)]
    pub guard: GuardConfig,
    /// `[vehicle_classes.<name>]`: named vehicle classes (length, engine lag and its range,
    /// acceleration limits) that `platoon.members` assigns to the vehicles
    /// (docs/traffic.md#mixed-vehicles); absent: every vehicle `platoon.vehicle_length_m` long,
    /// without limits.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub vehicle_classes: std::collections::BTreeMap<String, VehicleClass>,
    /// `[[cut_ins]]`: scripted vehicles that cut into the platoon's lane (either plant).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cut_ins: Vec<CutInConfig>,
    /// `[maneuvers]`: membership changes negotiated over V2V (docs/maneuvers.md): joins at the
    /// tail, with the field's laws, on either plant and transport.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maneuvers: Option<ManeuversConfig>,
    /// The DoS attack.
    #[serde(default)]
    pub attack: Attack,
    /// Link-level attacks on the V2V channel, applied after the DoS schedule.
    #[serde(default, skip_serializing_if = "Channel::is_default")]
    pub channel: Channel,
    /// The SUMO plant's road and options (used with `simulation.plant = "sumo"`).
    #[serde(default)]
    pub sumo: Sumo,
    /// Deceleration thresholds that class the run's safety.
    #[serde(default)]
    pub safety: SafetyConfig,
    /// Several identical, independent platoons on one road.
    #[serde(default)]
    pub fleet: FleetConfig,
    /// Which per-step files a run writes, and how.
    #[serde(default)]
    pub output: OutputConfig,
    /// Misbehaviour detection in the followers' receive path (docs/detection.md): absent, off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detection: Option<DetectionConfig>,
    /// `[security]`: signed V2V (docs/security.md): every vehicle signs its broadcasts with a
    /// pseudonym of a simulated PKI, every receiver checks them before use. Absent: unsigned.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub security: Option<SecurityConfig>,
}

/// `[security]`: signed V2V, ECDSA P-256 with pseudonym certificates (IEEE 1609.2 / ETSI TS
/// 103 097 in spirit; docs/security.md), on either transport (contract v5 carries the seal).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct SecurityConfig {
    /// Which received packets have their signature verified: `every` (the default) or
    /// `on_demand` (only those a law or a maneuver acts on; the certificate, validity and
    /// freshness checks on every packet).
    pub policy: SecurityPolicyConfig,
    /// The longest time between two packets of a vehicle that carry its full certificate
    /// instead of its digest (s; the standards' 1), > 0.
    pub certificate_period_s: f64,
    /// Every vehicle changes its pseudonym every this many seconds (0: never), >= 0.
    pub pseudonym_change_s: f64,
    /// The largest difference between a packet's generation time and its receiver's time it
    /// accepts (s; 1), > 0: older is refused as `stale` (a replay).
    pub freshness_s: f64,
    /// The seed of the PKI's and pseudonyms' keys (signatures are deterministic: the run is
    /// the same bit for bit at the same seed).
    pub seed: u64,
    /// Misbehaviour reports and revocation: a detector's flag becomes a signed report to the
    /// misbehaviour authority, which revokes a vehicle reported by enough others; needs
    /// `[detection]`. Absent: a flag stays a flag.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reports: Option<ReportsConfig>,
    /// A group key at join: agreed with the leader at each join (ECDH, HKDF), a MAC under it
    /// on the platoon's messages, renewed whenever a member leaves. Absent: signatures alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub group: Option<GroupConfig>,
}

/// `[security.group]`: the platoon's group key (docs/security.md#a-group-key-at-join).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(default, deny_unknown_fields)]
pub struct GroupConfig {
    /// What carries a tag under the group key: `maneuvers` (the default: every maneuver
    /// message between members; needs `[maneuvers]`) or `all` (those and every beacon of a
    /// member).
    pub mac: GroupMacConfig,
}

/// `[security.group] mac`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum GroupMacConfig {
    /// The maneuver messages between members.
    #[default]
    Maneuvers,
    /// The maneuver messages and every member's beacons.
    All,
}

/// `[security.reports]`: the reporters' uplink and the misbehaviour authority's rule
/// (docs/security.md#misbehaviour-reports-and-revocation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ReportsConfig {
    /// The uplink's latency from a reporter to the authority (s), >= 0, whole milliseconds.
    pub latency_s: f64,
    /// The probability that the uplink loses a report, in [0, 1).
    pub loss: f64,
    /// How many distinct vehicles other than the accused must report it, >= 1.
    pub quorum: u32,
    /// Within how long of each other their reports must arrive (s), > 0.
    pub window_s: f64,
    /// A vehicle reports the same pseudonym at most this often (s), > 0.
    pub every_s: f64,
    /// The catalogue's false report campaign: an insider reporting an honest member.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub false_reports: Option<FalseReportsConfig>,
}

/// `[security.reports.false_reports]`: insider `reporter` reports honest member `accused`
/// whenever it receives one of its packets (at most every `every_s`), over
/// `[start_s, end_s)`, the packet as evidence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FalseReportsConfig {
    /// The insider filing them (a vehicle id, 0 = the leader).
    pub reporter: u16,
    /// The honest member it accuses.
    pub accused: u16,
    /// From (s).
    #[serde(default)]
    pub start_s: f64,
    /// Until (s, exclusive; `inf`, the default: the end of the run).
    #[serde(default = "channel::forever")]
    #[schemars(default = "channel::forever_in_json")]
    pub end_s: f64,
}

impl Default for ReportsConfig {
    fn default() -> Self {
        Self {
            latency_s: 0.1,
            loss: 0.0,
            quorum: 2,
            window_s: 5.0,
            every_s: 1.0,
            false_reports: None,
        }
    }
}

impl Default for SecurityConfig {
    fn default() -> Self {
        Self {
            policy: SecurityPolicyConfig::Every,
            certificate_period_s: 1.0,
            pseudonym_change_s: 0.0,
            freshness_s: 1.0,
            seed: 0,
            reports: None,
            group: None,
        }
    }
}

/// `[security] policy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SecurityPolicyConfig {
    /// Verify every packet received.
    #[default]
    Every,
    /// Verify the signature of a packet only when a law or a maneuver acts on it.
    OnDemand,
}

/// `[output]`: the per-step files (trajectories, events, channel log, wire log).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct OutputConfig {
    /// The files' format.
    pub format: OutputFormat,
    /// Write every n-th step to the trajectories (metrics and plots still use every step), >= 1.
    pub decimate: u64,
    /// Which files to write.
    pub files: Vec<OutputFile>,
}

/// `format = "auto"` writes Parquet from this many trajectory rows on.
pub const AUTO_PARQUET_ROWS: u64 = 2_000_000;

/// `[output] format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum OutputFormat {
    /// Comma-separated text with one header line.
    Csv,
    /// Apache Parquet (zstd), the same columns.
    Parquet,
    /// Parquet when the trajectories would have 2 million rows (`AUTO_PARQUET_ROWS`) or more,
    /// CSV below.
    #[default]
    Auto,
}

/// A per-step file a run can write (`[output] files`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum OutputFile {
    /// Every vehicle's state and command at every (n-th) step.
    Trajectories,
    /// Broadcasts, attacks and mode changes.
    Events,
    /// The packets the channel did not deliver as sent.
    Channel,
    /// What crossed the wire per link and step.
    Wire,
    /// One row per packet the detectors inspected, with its ground truth and every detector's
    /// verdict (runs with `[detection]`).
    Detections,
}

impl OutputFile {
    /// Every file, in the order of [`OutputConfig::files`]' default.
    pub const ALL: [OutputFile; 5] = [
        OutputFile::Trajectories,
        OutputFile::Events,
        OutputFile::Channel,
        OutputFile::Wire,
        OutputFile::Detections,
    ];

    /// Its name in configs, and the stem of the file it writes.
    pub fn name(self) -> &'static str {
        match self {
            OutputFile::Trajectories => "trajectories",
            OutputFile::Events => "events",
            OutputFile::Channel => "channel",
            OutputFile::Wire => "wire",
            OutputFile::Detections => "detections",
        }
    }
}

impl OutputConfig {
    /// Whether the run writes `file`.
    pub fn writes(&self, file: OutputFile) -> bool {
        self.files.contains(&file)
    }
}

impl Default for OutputConfig {
    fn default() -> Self {
        Self {
            format: OutputFormat::default(),
            decimate: 1,
            files: OutputFile::ALL.to_vec(),
        }
    }
}

/// `[fleet]`: platoon j drives on `lanes[j % len]`, `(j / len) * gap_m` behind platoon 0, with
/// channel seed `channel.seed + j`; all share the DoS schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct FleetConfig {
    /// Number of platoons.
    pub platoons: usize,
    /// Lanes used in turn (SUMO plant); absent: the one lane `sumo.lane`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lanes: Option<Vec<u32>>,
    /// Distance between the leaders of consecutive platoons on one lane (m).
    pub gap_m: f64,
}

impl Default for FleetConfig {
    fn default() -> Self {
        Self {
            platoons: 1,
            lanes: None,
            gap_m: 200.0,
        }
    }
}

/// `[sumo]`: where the platoon drives when SUMO is the plant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct Sumo {
    /// The network (`.net.xml`), relative to the config file; absent: the bundled
    /// `sumo/highway/highway.net.xml`, a straight 3-lane, 3 km highway.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub net: Option<String>,
    /// The edge the platoon drives on.
    pub edge: String,
    /// Its lane index (0 = rightmost).
    pub lane: u32,
    /// Lane position of the rearmost vehicle's front at t = 0 (m): the platoon's coordinates
    /// are shifted by this much onto the road.
    pub start_m: f64,
    /// SUMO's `--collision.action`.
    pub collision_action: CollisionAction,
    /// What the controllers see.
    pub states: SumoStates,
    /// Who writes fcd.xml, SUMO's FCD output for replay in sumo-gui.
    pub fcd: FcdWriter,
    /// How often fcd.xml has a line per vehicle (s); 0 writes no FCD output; absent: every
    /// step the trajectories hold (every `output.decimate`-th; every step with `fcd = "sumo"`).
    /// With `fcd = "recorded"` a whole number of `output.decimate` steps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fcd_period_s: Option<f64>,
    /// Background traffic: vehicles of SUMO's own car-following model on the lanes no platoon
    /// uses (every lane with `background_on_platoon_lanes`), spread along the road with seeded
    /// speeds (0: none).
    pub background_vehicles: usize,
    /// Seed of the background traffic's speeds, spacing and vehicle classes.
    pub background_seed: u64,
    /// Present: the background traffic changes lanes as SUMO's LC2013 model decides, with
    /// these parameters (`{}`: SUMO's defaults); absent: it keeps its lane. The platoons'
    /// vehicles never change lanes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub background_lane_changes: Option<LaneChanges>,
    /// Background vehicles also on the platoons' lanes, ahead of each platoon's leader and
    /// behind its last vehicle (never inside a platoon's extent).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    #[schemars(extend("default" = false))]
    pub background_on_platoon_lanes: bool,
    /// The share of the background vehicles that are trucks (0..=1): 12 m long, slower
    /// (at most 25 m/s, entering at 18-24 m/s) than the cars (4.5 m, at most 36 m/s,
    /// entering at 20-30 m/s).
    #[serde(skip_serializing_if = "is_zero")]
    #[schemars(extend("default" = 0.0))]
    pub background_truck_share: f64,
    /// How far SUMO may deviate from the vehicle model before the run stops (m and m/s; in
    /// `states = "sumo"` mode over one step, in `model` mode accumulated over the run).
    pub tolerance_m: f64,
    /// The edges the platoon drives along, in order, the first being `edge` (absent: `edge`
    /// alone). Positions are then measured along the platoon's lane through them (and the
    /// junctions between), e.g. `["in", "merge", "out"]` of `sumo/onramp`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub route: Vec<String>,
    /// `[[sumo.ahead]]`: SUMO vehicles on each platoon's lane ahead of its leader at t = 0, at
    /// a constant desired speed (SUMO's Krauss model, no lane changes): a slow truck the leader
    /// meets when `leader.drive` is SUMO's. SUMO plant only (a config error on the native
    /// plant, which does not drive them).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub ahead: Vec<AheadVehicle>,
    /// `[[sumo.flows]]`: SUMO vehicles entering the network at a steady rate from one edge to
    /// another (an on-ramp's traffic), driven by SUMO's Krauss and LC2013 models
    /// (`background_lane_changes` sets LC2013's weights). SUMO plant only (a config error on
    /// the native plant, as are `background_vehicles` and a `route` of several edges).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub flows: Vec<SumoFlow>,
}

/// `[[sumo.ahead]]`: a vehicle ahead of the leader on its lane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AheadVehicle {
    /// Its gap to the leader at t = 0 (m, bumper to bumper): it must start on the platoon's
    /// first edge and not inside another vehicle ahead.
    pub gap_m: f64,
    /// Its initial and desired speed (m/s).
    pub speed_mps: f64,
    /// Its length (m): a truck's by default.
    #[serde(default = "default_truck_length")]
    pub length_m: f64,
}

fn default_truck_length() -> f64 {
    12.0
}

/// `[[sumo.flows]]`: vehicles from one edge to another at a steady rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SumoFlow {
    /// The edge they enter on (`ramp` of `sumo/onramp`).
    pub from: String,
    /// The edge they drive to (SUMO routes them).
    pub to: String,
    /// How many enter per hour, evenly spaced: at most one a step (`3600 / simulation.dt_s`).
    pub vehicles_per_hour: f64,
    /// When the first may enter (s): before the run's end.
    #[serde(default)]
    pub begin_s: f64,
    /// When the last may enter (s); absent: the run's end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_s: Option<f64>,
    /// Their speed as they enter (m/s); absent: the lane's limit. At most their vType's top
    /// speed, which SUMO holds them to: 36 m/s for cars, 25 m/s with a `truck_share`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mps: Option<f64>,
    /// The share of them that are trucks (12 m, at most 25 m/s), 0..=1.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub truck_share: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// `[sumo] background_lane_changes`: the parameters of SUMO's LC2013 lane-change model for the
/// background vehicles (the vType attributes `lcCooperative`, `lcSpeedGain`, `lcKeepRight`,
/// `lcAssertive`; every default is SUMO's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct LaneChanges {
    /// Willingness to change lanes to let others in (`lcCooperative`, 0..=1).
    pub cooperative: f64,
    /// Eagerness to change lanes for a faster one (`lcSpeedGain`, >= 0).
    pub speed_gain: f64,
    /// Eagerness to return to the rightmost lane (`lcKeepRight`, >= 0).
    pub keep_right: f64,
    /// Gap acceptance: the gaps a change needs on the target lane, ahead and behind, are
    /// divided by this (`lcAssertive`, > 0; above 1 accepts smaller gaps).
    pub assertive: f64,
}

impl Default for LaneChanges {
    fn default() -> Self {
        Self {
            cooperative: 1.0,
            speed_gain: 1.0,
            keep_right: 1.0,
            assertive: 1.0,
        }
    }
}

/// Who writes fcd.xml (`[sumo] fcd`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FcdWriter {
    /// platoon, after the run, from the recorded trajectories: the platoons' vehicles under
    /// SUMO's ids, placed on the network's lane shapes (no background traffic); costs the run's
    /// steps nothing. Needs `trajectories` in `output.files`. `platoon fcd DIR` does the same
    /// for a run directory.
    #[default]
    Recorded,
    /// SUMO, during the run (background traffic included): at 1000 vehicles a step that
    /// writes takes about 4x one that does not, so writing every tenth step puts the step
    /// time's p90 at about 3x its median (BENCHMARKS.md, "SUMO's FCD output").
    Sumo,
}

/// SUMO's `--collision.action` (`[sumo] collision_action`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CollisionAction {
    /// Record the collision and go on.
    #[default]
    Warn,
    /// Ignore it.
    None,
    /// Remove the vehicles involved.
    Remove,
    /// Teleport them.
    Teleport,
}

/// Whose positions and speeds the controllers see (`[sumo] states`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SumoStates {
    /// SUMO's: SUMO is the plant.
    #[default]
    Sumo,
    /// The vehicle model's, bit-identical to the native plant, with SUMO checked against them
    /// every step.
    Model,
}

impl Default for Sumo {
    fn default() -> Self {
        Self {
            net: None,
            edge: "highway".into(),
            lane: 1,
            start_m: 50.0,
            collision_action: CollisionAction::default(),
            states: SumoStates::default(),
            fcd: FcdWriter::default(),
            fcd_period_s: None,
            background_vehicles: 0,
            background_seed: 0,
            background_lane_changes: None,
            background_on_platoon_lanes: false,
            background_truck_share: 0.0,
            tolerance_m: 1e-6,
            route: Vec::new(),
            ahead: Vec::new(),
            flows: Vec::new(),
        }
    }
}

/// `[safety]`: the largest deceleration any follower needed classes the run (m/s^2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct SafetyConfig {
    /// At most this: class `none` (by default the paper leader's own braking).
    pub none_decel_mps2: f64,
    /// At most this: `negligible` (by default comfortable braking).
    pub negligible_decel_mps2: f64,
    /// At most this: `benign` (by default emergency braking); beyond it, or any collision:
    /// `severe`.
    pub benign_decel_mps2: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        let d = platoon_sim::SafetyThresholds::default();
        Self {
            none_decel_mps2: d.none,
            negligible_decel_mps2: d.negligible,
            benign_decel_mps2: d.benign,
        }
    }
}

/// `[simulation]`: the time grid and what integrates the vehicles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Simulation {
    /// Simulated time (s); a multiple of `dt_s`.
    pub duration_s: f64,
    /// Step length (s).
    pub dt_s: f64,
    /// What integrates the vehicles; `platoon run --plant` overrides it.
    #[serde(default)]
    pub plant: PlantKind,
}

/// What integrates the vehicles (`[simulation] plant`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum PlantKind {
    /// The model in Rust (`platoon node plant`).
    #[default]
    Native,
    /// SUMO through the libsumo bridge (`python -m platoon.sumo`, bridge/platoon/sumo/plant.py).
    Sumo,
}

impl PlantKind {
    /// Its name in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PlantKind::Native => "native",
            PlantKind::Sumo => "sumo",
        }
    }
}

/// `[platoon]`: the vehicles, their spacing policy and their initial states.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Platoon {
    /// Number of followers N.
    pub followers: usize,
    /// Desired spacing l between consecutive vehicles (m), front to front: the whole desired
    /// distance with `spacing_policy = "constant"`, the standstill part with `"time_headway"`.
    pub spacing_m: f64,
    /// The spacing policy (`spacing_policy`) and its keys.
    #[serde(flatten, deserialize_with = "serde_util::with_default_tag")]
    pub spacing: SpacingConfig,
    /// Vehicle length for gap and safety figures (m); 0 treats vehicles as points. With
    /// `members` each member's class gives its own (this stays the cut-ins' default).
    #[serde(default)]
    pub vehicle_length_m: f64,
    /// Each vehicle's class in `[vehicle_classes]`, the leader first (N + 1 names), or one
    /// class's name for every vehicle (`members = "car"`); absent: no classes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub members: Option<Members>,
    /// `[p, v, a]` of the leader then of each follower (N + 1 rows); or give `formation`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_states: Option<Vec<[f64; 3]>>,
    /// Generated initial states instead of `initial_states`: the platoon in formation at the
    /// leader's initial speed, with seeded jitter (so `followers` alone sets the platoon's size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formation: Option<Formation>,
}

/// `[platoon] members`: which class each vehicle is of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Members {
    /// One class for every vehicle, the leader included, however many followers there are.
    Every(String),
    /// Each vehicle's class, the leader first (N + 1 names).
    Each(Vec<String>),
}

/// `[vehicle_classes.<name>]`: one kind of vehicle (a car, a truck). The plant moves each
/// member with its class's length, lag and limits; the design covers every member's lag range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VehicleClass {
    /// Length (m), >= 0: the gap behind a vehicle is measured from its rear.
    pub length_m: f64,
    /// Its true engine lag, constant (s); or give `tau`; absent both: the follower's
    /// `[plant] tau` (or `tau_per_vehicle` entry).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_s: Option<f64>,
    /// Its true engine lag as a schedule (like `[plant] tau`), instead of `tau_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau: Option<TauConfig>,
    /// `[lo, hi]`: the lags (s) the design must cover for the class's followers; it must
    /// contain each one's true lag. Absent: the true lag's own range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_range_s: Option<[f64; 2]>,
    /// The largest acceleration the plant applies (m/s^2, > 0): a follower's command is held
    /// below it. Absent: unlimited.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_max_mps2: Option<f64>,
    /// The largest deceleration the plant applies (m/s^2, > 0): a follower's command is held
    /// above its negative (while the guard brakes, above `-emergency_decel_mps2` if given).
    /// Absent: unlimited.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decel_max_mps2: Option<f64>,
    /// The harder braking the plant applies while the emergency-braking guard overrides the
    /// command (m/s^2, >= `decel_max_mps2`): a production ACC brakes within `decel_max_mps2`,
    /// an emergency brake beyond it. Absent: `decel_max_mps2` for the guard too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub emergency_decel_mps2: Option<f64>,
}

/// `[platoon] spacing_policy` and its keys: which distance the law keeps
/// ([`platoon_control::SpacingPolicy`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "spacing_policy", rename_all = "snake_case", deny_unknown_fields)]
#[schemars(transform = serde_util::default_tag_schema::<SpacingConfig>)]
pub enum SpacingConfig {
    /// The paper: the desired distance is `spacing_m`.
    Constant {},
    /// The desired distance is `spacing_m + time_headway_s * v`, v the speed of the rear
    /// vehicle.
    TimeHeadway {
        /// The time headway h_t (s), > 0.
        time_headway_s: f64,
    },
}

impl DefaultTag for SpacingConfig {
    const SELECTOR: &'static str = "spacing_policy";
    const DEFAULT: &'static str = "constant";
}

impl Default for SpacingConfig {
    fn default() -> Self {
        Self::Constant {}
    }
}

impl SpacingConfig {
    /// The policy it names (not validated: see [`crate::scenario_of`]).
    pub fn policy(self) -> SpacingPolicy {
        match self {
            Self::Constant {} => SpacingPolicy::Constant,
            Self::TimeHeadway { time_headway_s } => SpacingPolicy::TimeHeadway(time_headway_s),
        }
    }
}

impl From<SpacingPolicy> for SpacingConfig {
    fn from(p: SpacingPolicy) -> Self {
        match p {
            SpacingPolicy::Constant => Self::Constant {},
            SpacingPolicy::TimeHeadway(h) => Self::TimeHeadway { time_headway_s: h },
        }
    }
}

/// `[platoon.formation]`: the leader at `leader_position_m` with its profile's speed v0 at t = 0,
/// follower i at `leader_position_m - i spacing_m` (`- i (spacing_m + time_headway_s v0)` with
/// the time-headway policy) with the same speed and zero acceleration,
/// then each follower's position and speed moved by independent uniform draws from
/// `[-position_jitter_m, position_jitter_m]` and `[-speed_jitter_mps, speed_jitter_mps]`
/// (ChaCha8 seeded with `seed`; the leader is never jittered).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Formation {
    /// The leader's initial position (m).
    #[serde(default)]
    pub leader_position_m: f64,
    /// Largest position offset of a follower (m).
    #[serde(default)]
    pub position_jitter_m: f64,
    /// Largest speed offset of a follower (m/s).
    #[serde(default)]
    pub speed_jitter_mps: f64,
    /// Seed of the jitter.
    #[serde(default)]
    pub seed: u64,
}

/// `[leader]`: the leader's velocity profile and how often it broadcasts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Leader {
    /// The velocity profile.
    #[serde(default)]
    pub profile: LeaderProfileConfig,
    /// Broadcast period of the leader (s); absent: every step (docs/paper-readings.md#R5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub broadcast_period_s: Option<f64>,
    /// Who drives the leader: its `profile` (the default), or SUMO's car-following model in
    /// traffic (`kind = "sumo"`, SUMO plant only).
    #[serde(default, skip_serializing_if = "LeaderDrive::is_profile")]
    pub drive: LeaderDrive,
}

/// `leader.drive`: who drives the leader, `kind` and that kind's keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LeaderDrive {
    /// `leader.profile`, on either plant.
    Profile {},
    /// SUMO's car-following model (`simulation.plant = "sumo"` only): the leader is a SUMO
    /// vehicle that drives at `speed_mps` behind whatever is ahead of it on its lane (a slow
    /// truck of `[[sumo.ahead]]`, a merging car), and its state as SUMO moved it is what the
    /// followers' controllers and V2V see. `leader.profile` only has to start at the leader's
    /// initial speed.
    Sumo {
        /// SUMO's car-following model (the vType's `carFollowModel`).
        #[serde(default)]
        car_follow_model: CarFollowModel,
        /// Its desired speed (m/s; the vType's `maxSpeed`).
        speed_mps: f64,
        /// Its largest acceleration (m/s^2; `accel`).
        #[serde(default = "default_leader_accel")]
        accel_mps2: f64,
        /// Its comfortable deceleration (m/s^2; `decel`).
        #[serde(default = "default_leader_decel")]
        decel_mps2: f64,
        /// Its desired time headway (s; `tau`).
        #[serde(default = "default_leader_headway")]
        headway_s: f64,
        /// The gap it keeps when stopped (m; `minGap`).
        #[serde(default = "default_leader_min_gap")]
        min_gap_m: f64,
    },
}

fn default_leader_accel() -> f64 {
    2.6
}
fn default_leader_decel() -> f64 {
    4.5
}
fn default_leader_headway() -> f64 {
    1.0
}
fn default_leader_min_gap() -> f64 {
    2.5
}

impl Default for LeaderDrive {
    fn default() -> Self {
        Self::Profile {}
    }
}

impl LeaderDrive {
    /// Whether the profile drives the leader (the default).
    pub fn is_profile(&self) -> bool {
        matches!(self, Self::Profile {})
    }
}

/// A SUMO car-following model (`leader.drive.car_follow_model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CarFollowModel {
    /// SUMO's default, Krauss (with no dawdling: `sigma = 0`).
    #[default]
    Krauss,
    /// The Intelligent Driver Model.
    Idm,
}

/// `leader.profile`: the leader's velocity over time, `kind` and that kind's keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LeaderProfileConfig {
    /// Section IV's profile (docs/paper-readings.md#R4).
    Paper {},
    /// Constant speed.
    Constant {
        /// Speed (m/s).
        speed_mps: f64,
    },
    /// Piecewise-linear velocity through `[t, v]` points, the first at t = 0.
    Waypoints {
        /// `[t (s), v (m/s)]` pairs.
        points: Vec<[f64; 2]>,
    },
}

impl Default for LeaderProfileConfig {
    fn default() -> Self {
        Self::Paper {}
    }
}

/// `[topology]`: a preset graph (`preset` names it), or an explicit one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "preset", rename_all = "snake_case", deny_unknown_fields)]
pub enum TopologyConfig {
    /// Predecessor following: i hears i-1 (follower 1 hears the leader).
    Pf {},
    /// Predecessor-leader following: i hears i-1 and the leader.
    Plf {},
    /// Bidirectional predecessor following: i hears i-1 and i+1 (follower 1 hears the leader).
    Bpf {},
    /// Two-predecessor single following: i hears i-1 and i-2, where vehicle 0 is the leader
    /// (docs/paper-readings.md#R7: pinning diag(1, 1, 0, ...)).
    Tpsf {},
    /// Any graph, given by its adjacency and pinning.
    Explicit {
        /// Row i lists whom follower i receives from (a_ij = 1).
        adjacency: Vec<Vec<f64>>,
        /// h_i = 1 if follower i receives from the leader.
        pinning: Vec<f64>,
    },
}

impl TopologyConfig {
    /// The preset it names (`None` for an explicit graph).
    pub fn preset(&self) -> Option<Preset> {
        match self {
            Self::Pf {} => Some(Preset::Pf),
            Self::Plf {} => Some(Preset::Plf),
            Self::Bpf {} => Some(Preset::Bpf),
            Self::Tpsf {} => Some(Preset::Tpsf),
            Self::Explicit { .. } => None,
        }
    }

    /// Its `preset` name.
    pub fn name(&self) -> &'static str {
        serde_util::tag_name(self, "preset")
    }
}

impl From<Preset> for TopologyConfig {
    fn from(p: Preset) -> Self {
        match p {
            Preset::Pf => Self::Pf {},
            Preset::Plf => Self::Plf {},
            Preset::Bpf => Self::Bpf {},
            Preset::Tpsf => Self::Tpsf {},
        }
    }
}

/// `[plant]`: the vehicles' engine time constant, true and nominal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Plant {
    /// Nominal time constant used by the controllers' estimators (s).
    pub tau_nominal_s: f64,
    /// The true time constant over time, for every follower.
    pub tau: TauConfig,
    /// Per-follower overrides of `tau` (N entries).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_per_vehicle: Option<Vec<TauConfig>>,
    /// How the native plant moves the followers: `exact` (the paper's model sampled exactly:
    /// a ballistic move, then the exact lag) or `plexe` (SUMO's CC model, Plexe: a
    /// backward-Euler lag, then a ballistic move with the new acceleration; docs/controllers.md).
    #[serde(default)]
    pub discretisation: platoon_model::Discretisation,
}

/// A tau schedule (`plant.tau`, `plant.tau_per_vehicle`): `kind` and that kind's keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TauConfig {
    /// Fig. 5(a): 0.34 s until 20 s, a linear ramp, 0.82 s from 35 s.
    Paper {},
    /// A constant.
    Constant {
        /// tau (s).
        value_s: f64,
    },
    /// Through `[t, tau]` knots with the given interpolation.
    Knots {
        /// `[t (s), tau (s)]` pairs with increasing t.
        knots: Vec<[f64; 2]>,
        /// How tau moves between knots.
        interpolation: Interpolation,
    },
}

/// `[attack]`: the DoS attack, its `kind` and that kind's keys (the keys of another kind are
/// errors).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct Attack {
    /// When the channel is jammed.
    #[serde(flatten)]
    pub kind: DosConfig,
    /// Bounds of Assumption 2 to check the schedule against (required with `kind = "random"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assumption2: Option<Assumption2>,
}

/// `[attack] kind` and its keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DosConfig {
    /// No DoS.
    None {},
    /// Given intervals.
    Intervals {
        /// `[start (s), duration (s)]` pairs.
        intervals: Vec<[f64; 2]>,
    },
    /// An attack of `duration_s` every `period_s`, the first at `offset_s`.
    Periodic {
        /// Period (s).
        period_s: f64,
        /// Attack length (s).
        duration_s: f64,
        /// First start (s).
        #[serde(default)]
        offset_s: f64,
    },
    /// Seeded random attacks that satisfy `assumption2`.
    Random {
        /// Seed.
        seed: u64,
        /// Smallest quiet time (s).
        min_gap_s: f64,
        /// Largest proposed quiet time (s).
        max_gap_s: f64,
        /// Shortest proposed attack (s).
        min_duration_s: f64,
        /// Longest proposed attack (s).
        max_duration_s: f64,
    },
}

impl Default for DosConfig {
    fn default() -> Self {
        Self::None {}
    }
}

impl DosConfig {
    /// Its `kind`.
    pub fn name(&self) -> &'static str {
        serde_util::tag_name(self, "kind")
    }
}
