use crate::serde_util::{self, DefaultTag};
use platoon_attacks::Assumption2;
use platoon_control::fallback::AccParams;
use platoon_control::{FallbackMode, SpacingPolicy};
use platoon_model::tau::Interpolation;
use platoon_topology::Preset;
use schemars::JsonSchema;
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

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
}

/// `[detection]`: the detectors every follower runs on the packets it accepts (each present
/// table turns its detector on, an empty one with its defaults) and what a flag makes it do.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DetectionConfig {
    /// `[detection.plausibility]`: F2MD's legacy plausibility and consistency checks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plausibility: Option<platoon_detect::PlausibilityParams>,
    /// `[detection.radar_cross]`: the predecessor's claim against the follower's radar.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radar_cross: Option<platoon_detect::RadarCrossParams>,
    /// `[detection.residual]`: a chi-square test of the claim against a prediction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<platoon_detect::ResidualParams>,
    /// What a follower does about a flagged sender: `log` (the default: nothing), `drop` (refuse
    /// its packets until `quiet_s` pass without a flag) or `fallback` (refuse them and run the
    /// fallback meanwhile).
    #[serde(default)]
    pub reaction: platoon_control::Reaction,
    /// The quiet period after the last flag (s; default 1).
    #[serde(default = "detection_quiet")]
    pub quiet_s: f64,
    /// The names of detectors a `--controller` plug-in runs itself and reports on the wire
    /// (docs/detection.md): measured against ground truth like the built-in ones, after them.
    /// Only a run with a controller plug-in may name any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plugin: Vec<String>,
}

fn detection_quiet() -> f64 {
    1.0
}

/// `[output]`: the per-step files (trajectories, events, channel log, wire log).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OutputConfig {
    /// The files' format.
    #[serde(default)]
    pub format: OutputFormat,
    /// Write every n-th step to the trajectories (metrics and plots still use every step), >= 1.
    #[serde(default = "one_step")]
    pub decimate: u64,
    /// Which files to write.
    #[serde(default = "all_files")]
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
            decimate: one_step(),
            files: all_files(),
        }
    }
}

fn one_step() -> u64 {
    1
}
fn all_files() -> Vec<OutputFile> {
    OutputFile::ALL.to_vec()
}

/// `[fleet]`: platoon j drives on `lanes[j % len]`, `(j / len) * gap_m` behind platoon 0, with
/// channel seed `channel.seed + j`; all share the DoS schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FleetConfig {
    /// Number of platoons.
    #[serde(default = "one_platoon")]
    pub platoons: usize,
    /// Lanes used in turn (SUMO plant); absent: the one lane `sumo.lane`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lanes: Option<Vec<u32>>,
    /// Distance between the leaders of consecutive platoons on one lane (m).
    #[serde(default = "fleet_gap")]
    pub gap_m: f64,
}

impl Default for FleetConfig {
    fn default() -> Self {
        Self {
            platoons: one_platoon(),
            lanes: None,
            gap_m: fleet_gap(),
        }
    }
}

fn one_platoon() -> usize {
    1
}
fn fleet_gap() -> f64 {
    200.0
}

/// `[sumo]`: where the platoon drives when SUMO is the plant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Sumo {
    /// The network (`.net.xml`), relative to the config file; absent: the bundled
    /// `sumo/highway/highway.net.xml`, a straight 3-lane, 3 km highway.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub net: Option<String>,
    /// The edge the platoon drives on.
    #[serde(default = "highway_edge")]
    pub edge: String,
    /// Its lane index (0 = rightmost).
    #[serde(default = "one")]
    pub lane: u32,
    /// Lane position of the rearmost vehicle's front at t = 0 (m): the platoon's coordinates
    /// are shifted by this much onto the road.
    #[serde(default = "fifty")]
    pub start_m: f64,
    /// SUMO's `--collision.action`.
    #[serde(default)]
    pub collision_action: CollisionAction,
    /// What the controllers see.
    #[serde(default)]
    pub states: SumoStates,
    /// Who writes fcd.xml, SUMO's FCD output for replay in sumo-gui.
    #[serde(default)]
    pub fcd: FcdWriter,
    /// How often fcd.xml has a line per vehicle (s); 0 writes no FCD output; absent: every
    /// step the trajectories hold (every `output.decimate`-th; every step with `fcd = "sumo"`).
    /// With `fcd = "recorded"` a whole number of `output.decimate` steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fcd_period_s: Option<f64>,
    /// Background traffic: vehicles of SUMO's own car-following model on the lanes no platoon
    /// uses, spread along the road with seeded speeds (0: none).
    #[serde(default)]
    pub background_vehicles: usize,
    /// Seed of the background traffic's speeds and spacing.
    #[serde(default)]
    pub background_seed: u64,
    /// How far SUMO may deviate from the vehicle model before the run stops (m and m/s; in
    /// `states = "sumo"` mode over one step, in `model` mode accumulated over the run).
    #[serde(default = "tolerance")]
    pub tolerance_m: f64,
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

fn tolerance() -> f64 {
    1e-6
}

impl Default for Sumo {
    fn default() -> Self {
        Self {
            net: None,
            edge: highway_edge(),
            lane: one(),
            start_m: fifty(),
            collision_action: CollisionAction::default(),
            states: SumoStates::default(),
            fcd: FcdWriter::default(),
            fcd_period_s: None,
            background_vehicles: 0,
            background_seed: 0,
            tolerance_m: tolerance(),
        }
    }
}

fn highway_edge() -> String {
    "highway".into()
}
fn one() -> u32 {
    1
}
fn fifty() -> f64 {
    50.0
}

/// `[safety]`: the largest deceleration any follower needed classes the run (m/s^2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SafetyConfig {
    /// At most this: class `none` (by default the paper leader's own braking).
    #[serde(default = "none_decel")]
    pub none_decel_mps2: f64,
    /// At most this: `negligible` (by default comfortable braking).
    #[serde(default = "negligible_decel")]
    pub negligible_decel_mps2: f64,
    /// At most this: `benign` (by default emergency braking); beyond it, or any collision:
    /// `severe`.
    #[serde(default = "benign_decel")]
    pub benign_decel_mps2: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            none_decel_mps2: none_decel(),
            negligible_decel_mps2: negligible_decel(),
            benign_decel_mps2: benign_decel(),
        }
    }
}

fn none_decel() -> f64 {
    2.0
}
fn negligible_decel() -> f64 {
    3.5
}
fn benign_decel() -> f64 {
    6.0
}

/// `[channel]`: a seed and a list of `[[channel.attacks]]`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Channel {
    /// Seed of the random losses (Bernoulli, Gilbert-Elliott).
    #[serde(default)]
    pub seed: u64,
    /// The attacks, applied in this order to each packet on each link.
    #[serde(default)]
    pub attacks: Vec<LinkAttackConfig>,
    /// The radio: `ideal` (every packet the attacks leave arrives) or `80211p` (IEEE 802.11p
    /// delivery against distance and channel load, the analytical model of Sepulcre et al.,
    /// docs/channel-80211p.md, with `[channel.radio]`).
    #[serde(default)]
    pub model: RadioModel,
    /// `model = "80211p"`: the model's parameters (every key optional: the paper's base case,
    /// 0.06 vehicles/m at 10 Hz, 23 dBm, 6 Mbps, 190 bytes). The density and beacon rate are
    /// the traffic the run does not simulate, evenly spread (0 vehicles/m: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radio: Option<platoon_radio::Params80211p>,
    /// `model = "80211p"`: where the channel's load comes from: `scenario` (the default: the
    /// radio's traffic plus every transmitter of the run within its interferer range, the
    /// platoon's and the fleet's vehicles at their measured beacon rate, SUMO's background
    /// vehicles at the radio's beacon rate) or `fixed` (the radio's traffic alone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<LoadConfig>,
    /// `model = "80211p"`: the beacon rate of the traffic the run does not simulate (the
    /// radio's density and SUMO's background vehicles): `fixed` (the default, the radio's
    /// `beacon_hz`) or `platoon` (the platoon's mean rate since the start: every vehicle
    /// beacons as the platoon does, at other times).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub background_beacons: Option<BackgroundBeaconsConfig>,
    /// `model = "80211p"`: the window the vehicles' beacon rates are measured over (s; default
    /// 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_window_s: Option<f64>,
    /// `model = "80211p"`: reactive decentralised congestion control (ETSI TS 102 687) in each
    /// vehicle's access layer; an empty `[channel.dcc]` turns it on with the standard's table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dcc: Option<DccConfig>,
    /// Jammers as transmitters on the road (docs/channel-80211p.md#jammers).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub jammers: Vec<JammerConfig>,
}

/// `[[channel.jammers]]`: a transmitter on the road. While it transmits, a vehicle that
/// receives it above the radio's sensing threshold (the path loss of `[channel.radio]`, its
/// defaults without one) senses its channel jammed and can neither send nor receive, as under
/// the paper's DoS; with `[channel] model = "80211p"` its power also enters every other link's
/// SINR. It stands at `position_m` (moving at `speed_mps`), rides with platoon vehicle `member`
/// (at `offset_m`), or rides SUMO background vehicle `background`: exactly one of the three.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JammerConfig {
    /// Its road coordinate at t = 0 (m; the platoon's coordinates): a roadside jammer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_m: Option<f64>,
    /// Rides with this platoon vehicle (0 = the leader), `offset_m` along the road from it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub member: Option<u16>,
    /// With `member`: its offset along the road from that vehicle (m; negative: behind).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_m: Option<f64>,
    /// Rides SUMO background vehicle `bg<background>` (`simulation.plant = "sumo"` with
    /// `sumo.background_vehicles` above it); silent while that vehicle is off the road.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub background: Option<usize>,
    /// When it transmits within `[start_s, end_s)`: `constant`, `periodic` (`on_s`/`off_s`),
    /// `random` (exponential on/off times of means `mean_on_s`/`mean_off_s`, seeded from
    /// `[channel] seed`) or `reactive` (only while it senses a vehicle's transmission; it then
    /// destroys that packet wherever it is heard). Absent: `periodic` with `on_s`/`off_s`,
    /// `constant` without.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub behaviour: Option<JammerBehaviour>,
    /// Random: mean burst length (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_on_s: Option<f64>,
    /// Random: mean pause between bursts (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_off_s: Option<f64>,
    /// Its speed along the road (m/s; 0: roadside; with `position_m` only).
    #[serde(default)]
    pub speed_mps: f64,
    /// Its distance from the road (m): it reaches the road over the part of it within its
    /// sensing radius, none when it stands farther away than that.
    #[serde(default)]
    pub lateral_m: f64,
    /// Its transmit power (dBm).
    #[serde(default = "jammer_power")]
    pub power_dbm: f64,
    /// When it starts (s).
    #[serde(default)]
    pub start_s: f64,
    /// When it stops (s; `inf`: never).
    #[serde(default = "forever")]
    #[schemars(default = "forever_in_json")]
    pub end_s: f64,
    /// Periodic: on for `on_s`, then off for `off_s`, from `start_s` (absent: always on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub on_s: Option<f64>,
    /// Periodic: off time between two bursts (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub off_s: Option<f64>,
}

/// `[[channel.jammers]] behaviour`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum JammerBehaviour {
    /// Transmits all the time.
    Constant,
    /// On for `on_s`, off for `off_s`.
    Periodic,
    /// Exponential on/off times.
    Random,
    /// Transmits only while it senses a transmission.
    Reactive,
}

fn jammer_power() -> f64 {
    23.0
}

/// `[channel] load`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LoadConfig {
    /// The radio's traffic plus the run's transmitters, measured as the run goes.
    Scenario,
    /// The radio's traffic alone.
    Fixed,
}

/// `[channel] background_beacons`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BackgroundBeaconsConfig {
    /// `[channel.radio] beacon_hz`.
    Fixed,
    /// The platoon's mean beacon rate since the start.
    Platoon,
}

/// `[channel.dcc]`: reactive DCC's states (ETSI TS 102 687 V1.2.1, Annex A, packets of at most
/// 0.5 ms on air): a vehicle measuring a CBR below `cbr_thresholds[i]` (and at or above the
/// one before) waits at least `t_off_s[i]` between two transmissions; at or above the last
/// threshold, the last `t_off_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DccConfig {
    /// The CBR limits between the states, increasing in (0, 1) (default: relaxed below 0.30,
    /// active 1 to 3 below 0.40, 0.50 and 0.65, restrictive above).
    #[serde(default = "dcc_thresholds")]
    pub cbr_thresholds: Vec<f64>,
    /// The least time between two transmissions in each state (s), one more than the
    /// thresholds, not decreasing (default: 0.06, 0.10, 0.18, 0.26, 1.0).
    #[serde(default = "dcc_t_off")]
    pub t_off_s: Vec<f64>,
}

fn dcc_thresholds() -> Vec<f64> {
    vec![0.30, 0.40, 0.50, 0.65]
}
fn dcc_t_off() -> Vec<f64> {
    vec![0.06, 0.10, 0.18, 0.26, 1.0]
}

/// `[channel] model`: the radio under the attacks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
pub enum RadioModel {
    /// Every packet the attacks leave is delivered.
    #[default]
    #[serde(rename = "ideal")]
    Ideal,
    /// IEEE 802.11p's delivery ratio at the link's distance (docs/channel-80211p.md).
    #[serde(rename = "80211p")]
    Ieee80211p,
}

impl Channel {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// `[[channel.attacks]]`: one link attack, its `kind` and that kind's keys (the keys of another
/// kind are errors), active on `[start_s, end_s)` for the links it targets.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
pub struct LinkAttackConfig {
    /// What it does to the packets it hits.
    #[serde(flatten)]
    pub kind: LinkKindConfig,
    /// Start of activity (s).
    #[serde(default)]
    pub start_s: f64,
    /// End of activity (s, exclusive); `inf`, the default: the end of the run.
    #[serde(default = "forever")]
    #[schemars(default = "forever_in_json")]
    pub end_s: f64,
    /// Targeted senders (vehicle ids, 0 = leader); absent: all.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub senders: Option<Vec<u16>>,
    /// Targeted receivers; absent: all.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub receivers: Option<Vec<u16>>,
}

fn forever() -> f64 {
    f64::INFINITY
}

/// JSON has no infinity: the schema gives TOML's spelling.
fn forever_in_json() -> &'static str {
    "inf"
}

/// The selector first, the keys every kind has, then the kind's own (a config's order).
impl Serialize for LinkAttackConfig {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("kind", self.kind.name())?;
        m.serialize_entry("start_s", &self.start_s)?;
        m.serialize_entry("end_s", &self.end_s)?;
        if let Some(v) = &self.senders {
            m.serialize_entry("senders", v)?;
        }
        if let Some(v) = &self.receivers {
            m.serialize_entry("receivers", v)?;
        }
        serde_util::entries(&mut m, &self.kind, "kind")?;
        m.end()
    }
}

/// `[[channel.attacks]] kind` and its keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LinkKindConfig {
    /// Each packet on each targeted link is lost with probability `loss`.
    Bernoulli {
        /// Loss probability in `[0, 1]`.
        loss: f64,
    },
    /// Burst loss: a two-state (good/bad) Markov chain per link, advanced once per packet on
    /// that link; a packet is lost with `loss_good` or `loss_bad` depending on the state.
    GilbertElliott {
        /// Probability of going from good to bad, per packet.
        p_good_bad: f64,
        /// Probability of going from bad to good, per packet.
        p_bad_good: f64,
        /// Loss probability in the good state.
        #[serde(default)]
        loss_good: f64,
        /// Loss probability in the bad state.
        #[serde(default = "certain")]
        loss_bad: f64,
    },
    /// Every targeted packet arrives `delay_s` late (the receiver propagates it open-loop).
    Delay {
        /// The delay (s), a whole number of steps.
        delay_s: f64,
    },
    /// A jammer (e.g. a drone) at `position_m + speed_mps t` along the road: a vehicle within
    /// `radius_m` of it can neither send nor receive, and senses its channel jammed.
    RangeJamming {
        /// Jammer position at t = 0 (m, road coordinate of the platoon).
        position_m: f64,
        /// Jammer speed (m/s).
        #[serde(default)]
        speed_mps: f64,
        /// Jamming radius (m).
        radius_m: f64,
    },
    /// The targeted senders' packets are replaced by the ones they sent `lag_s` earlier, with
    /// their old sequence numbers.
    Replay {
        /// Age of the replayed packets (s), a whole number of steps.
        lag_s: f64,
    },
    /// False data injection: `offset` is added to the state in the targeted senders' packets.
    FalseData {
        /// Offset added to `[p, v, a]`.
        offset: [f64; 3],
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// Random false data: zero-mean normal noise of standard deviation `std` added to the state,
    /// drawn from the channel's seeded stream per packet and link (per packet for an insider,
    /// whose receivers all get the same draw).
    RandomOffset {
        /// Standard deviation on `[p, v, a]` (m, m/s, m/s^2), each >= 0.
        std: [f64; 3],
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// A slow drift: the offset `rate (t - start_s)` on the state grows linearly from the
    /// attack's start; sized to stay inside sensor noise, it passes plausibility checks for a
    /// while.
    Drift {
        /// Growth of the offset on `[p, v, a]` per second (m/s, m/s^2, m/s^3).
        rate: [f64; 3],
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// Feigned braking: the claimed acceleration is replaced by `accel_mps2`; position and
    /// speed stay true.
    FeignedBraking {
        /// The claimed acceleration (m/s^2), e.g. -6.
        accel_mps2: f64,
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// The claimed acceleration multiplied by `factor`; position and speed stay true.
    AccelScale {
        /// The factor.
        factor: f64,
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
}

fn certain() -> f64 {
    1.0
}

impl LinkKindConfig {
    /// Its `kind`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Bernoulli { .. } => "bernoulli",
            Self::GilbertElliott { .. } => "gilbert_elliott",
            Self::Delay { .. } => "delay",
            Self::RangeJamming { .. } => "range_jamming",
            Self::Replay { .. } => "replay",
            Self::FalseData { .. } => "false_data",
            Self::RandomOffset { .. } => "random_offset",
            Self::Drift { .. } => "drift",
            Self::FeignedBraking { .. } => "feigned_braking",
            Self::AccelScale { .. } => "accel_scale",
        }
    }

    /// Whether the attacker is an insider (false for the kinds that do not alter states).
    pub fn insider(&self) -> bool {
        match *self {
            Self::FalseData { insider, .. }
            | Self::RandomOffset { insider, .. }
            | Self::Drift { insider, .. }
            | Self::FeignedBraking { insider, .. }
            | Self::AccelScale { insider, .. } => insider,
            Self::Bernoulli { .. }
            | Self::GilbertElliott { .. }
            | Self::Delay { .. }
            | Self::RangeJamming { .. }
            | Self::Replay { .. } => false,
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
    /// SUMO through the libsumo bridge (bridge/sumo_plant.py).
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
    /// Vehicle length for gap and safety figures (m); 0 treats vehicles as points.
    #[serde(default)]
    pub vehicle_length_m: f64,
    /// `[p, v, a]` of the leader then of each follower (N + 1 rows); or give `formation`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_states: Option<Vec<[f64; 3]>>,
    /// Generated initial states instead of `initial_states`: the platoon in formation at the
    /// leader's initial speed, with seeded jitter (so `followers` alone sets the platoon's size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formation: Option<Formation>,
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
    /// The policy it names (not validated: see [`crate::to_scenario`]).
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
        match self {
            Self::Pf {} => "pf",
            Self::Plf {} => "plf",
            Self::Bpf {} => "bpf",
            Self::Tpsf {} => "tpsf",
            Self::Explicit { .. } => "explicit",
        }
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

/// `[control]`: which law the followers run; the paper's law's gain and the trigger
/// conditions' weights; the parameters of one of the field's laws in its own table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Control {
    /// The law (docs/controllers.md): the paper's (its keys: `gain`, `beta1`, `beta2`, and the
    /// event triggers of `[trigger]`), or one of the field's, which beacon periodically or by
    /// ETSI's CAM rules (`[trigger] rule = "periodic"` or `"cam"`) and take their parameters
    /// from `[control.<law>]`
    /// (every key optional, SUMO's Plexe defaults).
    #[serde(default)]
    pub law: LawName,
    /// K in `u_i = -K q_i` (docs/paper-readings.md#R1); the paper's law only.
    #[serde(default = "paper_gain")]
    pub gain: [f64; 3],
    /// Weight of |eps|^2 in the trigger conditions; the paper's law only.
    #[serde(default = "paper_beta1")]
    pub beta1: f64,
    /// Weight of |q|^2 in the trigger conditions; the paper's law only.
    #[serde(default = "paper_beta2")]
    pub beta2: f64,
    /// `law = "acc"`: Plexe's ACC (radar only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acc: Option<platoon_control::laws::PlexeAccParams>,
    /// `law = "path_cacc"`: the PATH CACC (Rajamani).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_cacc: Option<platoon_control::laws::PathCaccParams>,
    /// `law = "ploeg"`: Ploeg et al.'s CACC.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ploeg: Option<platoon_control::laws::PloegParams>,
    /// `law = "consensus"`: the consensus law (Santini et al.).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub consensus: Option<platoon_control::laws::ConsensusParams>,
    /// `law = "flatbed"`: the flatbed controller (Ali, Garcia, Martinet; in Plexe by Segata).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flatbed: Option<platoon_control::laws::FlatbedParams>,
    /// The older name of `fallback.mode`; set one of them. The resolved config says
    /// `fallback.mode`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("deprecated" = true))]
    pub attack_input: Option<FallbackMode>,
}

/// `[control] law`: which law the followers run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LawName {
    /// The paper's `u = -K q` on open-loop estimates, with its event triggers.
    #[default]
    Paper,
    /// Plexe's ACC: cruise control and a constant time headway on the radar, no V2V.
    Acc,
    /// The PATH CACC (Rajamani et al.): constant spacing, predecessor and leader.
    PathCacc,
    /// Ploeg et al.'s CACC: time headway, the predecessor's command fed forward.
    Ploeg,
    /// The consensus law of Santini et al.
    Consensus,
    /// The flatbed controller of Ali, Garcia and Martinet (2015), as Plexe has it.
    Flatbed,
}

impl LawName {
    /// Every law, the paper's first.
    pub const ALL: [LawName; 6] = [
        Self::Paper,
        Self::Acc,
        Self::PathCacc,
        Self::Ploeg,
        Self::Consensus,
        Self::Flatbed,
    ];

    /// The law of a config name (`ploeg`).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|l| l.name() == name)
    }

    /// The law with its default parameters (SUMO's Plexe defaults; the paper's own).
    pub fn defaults(self) -> platoon_control::LawParams {
        use platoon_control::LawParams as P;
        match self {
            Self::Paper => P::Paper,
            Self::Acc => P::Acc(Default::default()),
            Self::PathCacc => P::PathCacc(Default::default()),
            Self::Ploeg => P::Ploeg(Default::default()),
            Self::Consensus => P::Consensus(Default::default()),
            Self::Flatbed => P::Flatbed(Default::default()),
        }
    }

    /// Its config name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Acc => "acc",
            Self::PathCacc => "path_cacc",
            Self::Ploeg => "ploeg",
            Self::Consensus => "consensus",
            Self::Flatbed => "flatbed",
        }
    }
}

fn paper_gain() -> [f64; 3] {
    [4.81, 9.12, 2.97]
}

fn paper_beta1() -> f64 {
    319.38
}

fn paper_beta2() -> f64 {
    5.62
}

/// `[fallback]`: what a follower does while affected by an attack, and how it comes back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FallbackConfig {
    /// Every follower's fallback (`control.attack_input`, its older name, if given; else
    /// `zero`, the paper's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<FallbackMode>,
    /// One mode per follower instead (follower 1 first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_vehicle: Option<Vec<FallbackMode>>,
    /// Time a vehicle stays in its fallback once it is no longer affected (s).
    #[serde(default)]
    pub dwell_s: f64,
    /// Time over which it then returns to the cooperative law, bumplessly (s; 0: at once).
    #[serde(default)]
    pub blend_s: f64,
    /// ...or longer, so that the gap its fallback left closes at most this fast (m/s).
    #[serde(default = "two")]
    pub closing_mps: f64,
    /// The ACC law.
    #[serde(default)]
    pub acc: AccParams,
}

impl Default for FallbackConfig {
    fn default() -> Self {
        Self {
            mode: None,
            per_vehicle: None,
            dwell_s: 0.0,
            blend_s: 0.0,
            closing_mps: two(),
            acc: AccParams::default(),
        }
    }
}

fn two() -> f64 {
    2.0
}

/// `[radar]`: every follower's on-board radar (read by the `acc` fallback and the guard).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct RadarConfig {
    /// Range (m).
    pub range_m: f64,
    /// Measurement period (s), a whole number of steps.
    pub period_s: f64,
    /// Standard deviation of the gap's noise (m).
    pub noise_m: f64,
    /// Standard deviation of the closing speed's noise (m/s).
    pub noise_mps: f64,
    /// Probability a measurement is lost.
    pub dropout: f64,
    /// Seed of noise and dropouts.
    pub seed: u64,
}

impl Default for RadarConfig {
    fn default() -> Self {
        Self {
            range_m: 150.0,
            period_s: 0.05,
            noise_m: 0.05,
            noise_mps: 0.05,
            dropout: 0.0,
            seed: 1,
        }
    }
}

/// `[guard]`: emergency braking on the radar's time to collision, in every mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct GuardConfig {
    /// Whether it is on.
    pub enabled: bool,
    /// Time to collision below which it brakes (s; the paper's engine lag of up to 0.82 s
    /// makes a trigger much later than the default too late).
    pub ttc_s: f64,
    /// Its deceleration (m/s^2).
    pub decel_mps2: f64,
}

impl Default for GuardConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            ttc_s: 4.0,
            decel_mps2: 8.0,
        }
    }
}

/// `[trigger]`: the rule (`rule`) and its keys (the keys of another rule are errors), and how
/// often and how resiliently it is checked.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
pub struct Trigger {
    /// The triggering rule and its parameters.
    #[serde(flatten)]
    pub rule: RuleConfig,
    /// How often the event condition is checked (s), a whole number of steps; absent: every
    /// step (docs/paper-readings.md#R10; the resolved config says the step).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check_period_s: Option<f64>,
    /// Use the resilient mechanism (11) during attacks.
    #[serde(default = "yes")]
    pub resilient: bool,
    /// Sampling period h of the resilient mechanism (s), a whole number of steps.
    pub h_s: f64,
}

/// The selector first, the keys every rule has, then the rule's own (a config's order).
impl Serialize for Trigger {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("rule", self.rule.name())?;
        if let Some(p) = &self.check_period_s {
            m.serialize_entry("check_period_s", p)?;
        }
        m.serialize_entry("resilient", &self.resilient)?;
        m.serialize_entry("h_s", &self.h_s)?;
        serde_util::entries(&mut m, &self.rule, "rule")?;
        m.end()
    }
}

fn yes() -> bool {
    true
}

/// `[trigger] rule` and its keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "rule", rename_all = "snake_case", deny_unknown_fields)]
pub enum RuleConfig {
    /// The paper's dynamic event-triggering mechanism (4)+(12).
    Dynamic {
        /// phi_i, the weight of the internal variable theta in the condition.
        phi: f64,
        /// rho_i, theta's decay rate.
        rho: f64,
        /// eta_i, the gain of the static condition in theta's dynamics.
        eta: f64,
        /// theta_i(0).
        theta0: f64,
    },
    /// The static event-triggering mechanism (21).
    Static {},
    /// Table I's baseline: the static condition with an exponentially decaying offset
    /// `beta1 mu exp(-alpha t)` (docs/paper-readings.md#R13).
    Mixed {
        /// The offset at t = 0.
        #[serde(default)]
        mu: f64,
        /// The offset's decay rate (1/s).
        #[serde(default)]
        alpha: f64,
    },
    /// Time-triggered: a broadcast every `period_s`.
    Periodic {
        /// The period (s), a whole number of steps.
        period_s: f64,
    },
    /// ETSI EN 302 637-2's CAM generation rules, usable with every law: a new message when the
    /// vehicle moved more than `position_m` or its speed changed more than `speed_mps` since
    /// its last one, never sooner than `min_interval_s` nor later than `max_interval_s`.
    Cam {
        /// The shortest interval (s), a whole number of steps.
        #[serde(default = "cam_min")]
        min_interval_s: f64,
        /// The longest interval (s), a whole number of steps.
        #[serde(default = "cam_max")]
        max_interval_s: f64,
        /// Displacement that triggers a message (m).
        #[serde(default = "cam_position")]
        position_m: f64,
        /// Speed change that triggers a message (m/s).
        #[serde(default = "cam_speed")]
        speed_mps: f64,
    },
}

fn cam_min() -> f64 {
    0.1
}

fn cam_max() -> f64 {
    1.0
}

fn cam_position() -> f64 {
    4.0
}

fn cam_speed() -> f64 {
    0.5
}

impl RuleConfig {
    /// Its `rule`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Dynamic { .. } => "dynamic",
            Self::Static {} => "static",
            Self::Mixed { .. } => "mixed",
            Self::Periodic { .. } => "periodic",
            Self::Cam { .. } => "cam",
        }
    }
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
        match self {
            Self::None {} => "none",
            Self::Intervals { .. } => "intervals",
            Self::Periodic { .. } => "periodic",
            Self::Random { .. } => "random",
        }
    }
}
