use platoon_attacks::Assumption2;
use platoon_control::fallback::AccParams;
use platoon_control::FallbackMode;
use platoon_model::tau::Interpolation;
use serde::{Deserialize, Serialize};

/// A scenario file. See `configs/paper.toml` for every key with a comment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
}

/// `[output]`: the per-step files (trajectories, events, channel log, wire log).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputConfig {
    /// `csv`, `parquet` (zstd, the same columns) or `auto`: Parquet when the trajectories would
    /// exceed [`AUTO_PARQUET_ROWS`] rows \[auto\].
    #[serde(default = "auto")]
    pub format: String,
    /// Write every n-th step to the trajectories (metrics and plots still use every step) \[1\].
    #[serde(default = "one_step")]
    pub decimate: u64,
    /// Which of `trajectories`, `events`, `channel`, `wire` to write \[all\].
    #[serde(default = "all_files")]
    pub files: Vec<String>,
}

/// `format = "auto"` writes Parquet from this many trajectory rows on.
pub const AUTO_PARQUET_ROWS: u64 = 2_000_000;

/// The per-step files a run can write.
pub const OUTPUT_FILES: [&str; 4] = ["trajectories", "events", "channel", "wire"];

impl Default for OutputConfig {
    fn default() -> Self {
        Self {
            format: auto(),
            decimate: one_step(),
            files: all_files(),
        }
    }
}

fn auto() -> String {
    "auto".into()
}
fn one_step() -> u64 {
    1
}
fn all_files() -> Vec<String> {
    OUTPUT_FILES.iter().map(|s| s.to_string()).collect()
}

/// `[fleet]`: platoon j drives on `lanes[j % len]`, `(j / len) * gap_m` behind platoon 0, with
/// channel seed `channel.seed + j`; all share the DoS schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FleetConfig {
    /// Number of platoons \[1\].
    #[serde(default = "one_platoon")]
    pub platoons: usize,
    /// Lanes used in turn (SUMO plant) [the `[sumo] lane`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lanes: Option<Vec<u32>>,
    /// Distance between the leaders of consecutive platoons on one lane (m) \[200\].
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sumo {
    /// The network (`.net.xml`), relative to the config file [default: the bundled
    /// sumo/highway/highway.net.xml, a straight 3-lane, 3 km highway].
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
    /// SUMO's `--collision.action`: `warn` (record and go on), `none`, `remove` or `teleport`.
    #[serde(default = "warn")]
    pub collision_action: String,
    /// What the controllers see: `sumo` (SUMO's positions and speeds: SUMO is the plant) or
    /// `model` (the vehicle model's, bit-identical to the native plant, with SUMO checked
    /// against them every step).
    #[serde(default = "sumo_states")]
    pub states: String,
    /// How often SUMO writes a line per vehicle to fcd.xml, for replay in sumo-gui (s); 0
    /// writes no FCD output [every step].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fcd_period_s: Option<f64>,
    /// Background traffic: vehicles of SUMO's own car-following model on the lanes no platoon
    /// uses, spread along the road with seeded speeds [0: none].
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

fn sumo_states() -> String {
    "sumo".into()
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
            collision_action: warn(),
            states: sumo_states(),
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
fn warn() -> String {
    "warn".into()
}

/// `[safety]`: the largest deceleration any follower needed classes the run (m/s^2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetyConfig {
    /// At most this: class `none` [2.0, the paper leader's own braking].
    #[serde(default = "none_decel")]
    pub none_decel_mps2: f64,
    /// At most this: `negligible` [3.5, comfortable braking].
    #[serde(default = "negligible_decel")]
    pub negligible_decel_mps2: f64,
    /// At most this: `benign` [6.0, emergency braking]; beyond it, or any collision: `severe`.
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
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Channel {
    /// Seed of the random losses (Bernoulli, Gilbert-Elliott).
    #[serde(default)]
    pub seed: u64,
    /// The attacks, applied in this order to each packet on each link.
    #[serde(default)]
    pub attacks: Vec<LinkAttackConfig>,
}

impl Channel {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// `[[channel.attacks]]`. Keys that belong to another kind are errors.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkAttackConfig {
    /// `bernoulli`, `gilbert_elliott`, `delay`, `range_jamming`, `replay` or `false_data`.
    pub kind: String,
    /// Start of activity (s) [default 0].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_s: Option<f64>,
    /// End of activity (s, exclusive) [default: the end of the run].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_s: Option<f64>,
    /// Targeted senders (vehicle ids, 0 = leader) [default: all].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub senders: Option<Vec<u16>>,
    /// Targeted receivers [default: all].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub receivers: Option<Vec<u16>>,
    /// `bernoulli`: loss probability.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loss: Option<f64>,
    /// `gilbert_elliott`: good -> bad probability per packet.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p_good_bad: Option<f64>,
    /// `gilbert_elliott`: bad -> good probability per packet.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p_bad_good: Option<f64>,
    /// `gilbert_elliott`: loss probability in the good state [default 0].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loss_good: Option<f64>,
    /// `gilbert_elliott`: loss probability in the bad state [default 1].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loss_bad: Option<f64>,
    /// `delay`: delay (s), a whole number of steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_s: Option<f64>,
    /// `range_jamming`: jammer position at t = 0 (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_m: Option<f64>,
    /// `range_jamming`: jammer speed (m/s) [default 0].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mps: Option<f64>,
    /// `range_jamming`: radius (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_m: Option<f64>,
    /// `replay`: age of the replayed packets (s), a whole number of steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lag_s: Option<f64>,
    /// `false_data`: offset added to `[p, v, a]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<[f64; 3]>,
}

/// `[simulation]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Simulation {
    /// Simulated time (s); a multiple of `dt_s`.
    pub duration_s: f64,
    /// Step length (s).
    pub dt_s: f64,
    /// What integrates the vehicles: `native` (the model in Rust) or `sumo` (SUMO through
    /// the libsumo bridge, see `[sumo]`); `platoon run --plant` overrides it.
    #[serde(default = "native")]
    pub plant: String,
}

fn native() -> String {
    "native".into()
}

/// `[platoon]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Platoon {
    /// Number of followers N.
    pub followers: usize,
    /// Desired spacing l between consecutive vehicles (m), front to front: the whole desired
    /// distance with `spacing_policy = "constant"`, the standstill part with `"time_headway"`.
    pub spacing_m: f64,
    /// `constant` (the paper: the desired distance is `spacing_m`) or `time_headway` (it is
    /// `spacing_m + time_headway_s * v`, v the speed of the rear vehicle) \[constant\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spacing_policy: Option<String>,
    /// The time headway h_t of `spacing_policy = "time_headway"` (s), > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_headway_s: Option<f64>,
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

/// `[platoon.formation]`: the leader at `leader_position_m` with its profile's speed v0 at t = 0,
/// follower i at `leader_position_m - i spacing_m` (`- i (spacing_m + time_headway_s v0)` with
/// the time-headway policy) with the same speed and zero acceleration,
/// then each follower's position and speed moved by independent uniform draws from
/// `[-position_jitter_m, position_jitter_m]` and `[-speed_jitter_mps, speed_jitter_mps]`
/// (ChaCha8 seeded with `seed`; the leader is never jittered).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Formation {
    /// The leader's initial position (m) \[0\].
    #[serde(default)]
    pub leader_position_m: f64,
    /// Largest position offset of a follower (m) \[0\].
    #[serde(default)]
    pub position_jitter_m: f64,
    /// Largest speed offset of a follower (m/s) \[0\].
    #[serde(default)]
    pub speed_jitter_mps: f64,
    /// Seed of the jitter \[0\].
    #[serde(default)]
    pub seed: u64,
}

/// `[leader]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Leader {
    /// The velocity profile.
    #[serde(default)]
    pub profile: LeaderProfileConfig,
    /// Broadcast period of the leader (s); absent: every step (docs/paper-readings.md#R5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub broadcast_period_s: Option<f64>,
}

/// `leader.profile`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LeaderProfileConfig {
    /// Section IV's profile (docs/paper-readings.md#R4).
    #[default]
    Paper,
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

/// `[topology]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopologyConfig {
    /// `pf`, `plf`, `bpf`, `tpsf`, or `explicit` (then `adjacency` and `pinning` are required).
    pub preset: String,
    /// Row i lists whom follower i receives from (a_ij = 1), only with `preset = "explicit"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adjacency: Option<Vec<Vec<f64>>>,
    /// h_i = 1 if follower i receives from the leader, only with `preset = "explicit"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pinning: Option<Vec<f64>>,
}

/// `[plant]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plant {
    /// Nominal time constant used by the controllers' estimators (s).
    pub tau_nominal_s: f64,
    /// The true time constant over time, for every follower.
    pub tau: TauConfig,
    /// Per-follower overrides of `tau` (N entries).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_per_vehicle: Option<Vec<TauConfig>>,
}

/// A tau schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TauConfig {
    /// Fig. 5(a): 0.34 s until 20 s, a linear ramp, 0.82 s from 35 s.
    Paper,
    /// A constant.
    Constant {
        /// tau (s).
        value_s: f64,
    },
    /// Through `[t, tau]` knots with the given interpolation (`step`, `linear` or `smooth`).
    Knots {
        /// `[t (s), tau (s)]` pairs with increasing t.
        knots: Vec<[f64; 2]>,
        /// How tau moves between knots.
        interpolation: Interpolation,
    },
}

/// `[control]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Control {
    /// K in `u_i = -K q_i` (docs/paper-readings.md#R1).
    pub gain: [f64; 3],
    /// Weight of |eps|^2 in the trigger conditions.
    pub beta1: f64,
    /// Weight of |q|^2 in the trigger conditions.
    pub beta2: f64,
    /// The older name of `fallback.mode` (`zero` or `hold`); set one of them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attack_input: Option<FallbackMode>,
}

/// `[fallback]`: what a follower does while affected by an attack, and how it comes back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FallbackConfig {
    /// `zero` (the paper), `hold`, `predict` or `acc` \[zero\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<FallbackMode>,
    /// One mode per follower instead (follower 1 first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_vehicle: Option<Vec<FallbackMode>>,
    /// Time a vehicle stays in its fallback once it is no longer affected (s) \[0\].
    #[serde(default)]
    pub dwell_s: f64,
    /// Time over which it then returns to the cooperative law, bumplessly (s) [0: at once].
    #[serde(default)]
    pub blend_s: f64,
    /// ...or longer, so that the gap its fallback left closes at most this fast (m/s) \[2\].
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
            closing_mps: 2.0,
            acc: AccParams::default(),
        }
    }
}

fn two() -> f64 {
    2.0
}

/// `[radar]`: every follower's on-board radar (read by the `acc` fallback and the guard).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadarConfig {
    /// Range (m) \[150\].
    pub range_m: f64,
    /// Measurement period (s), a whole number of steps [0.05].
    pub period_s: f64,
    /// Standard deviation of the gap's noise (m) [0.05].
    pub noise_m: f64,
    /// Standard deviation of the closing speed's noise (m/s) [0.05].
    pub noise_mps: f64,
    /// Probability a measurement is lost \[0\].
    pub dropout: f64,
    /// Seed of noise and dropouts \[1\].
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GuardConfig {
    /// Whether it is on [false].
    pub enabled: bool,
    /// Time to collision below which it brakes (s) [4: the paper's engine lag of up to
    /// 0.82 s makes a later trigger too late].
    pub ttc_s: f64,
    /// Its deceleration (m/s^2) \[8\].
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

/// `[trigger]`. Keys that belong to another rule are errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Trigger {
    /// `dynamic` (4)+(12), `static` (21), `mixed` (the Table I baseline) or `periodic`.
    pub rule: String,
    /// How often the event condition is checked (s); default: every step
    /// (docs/paper-readings.md#R10).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check_period_s: Option<f64>,
    /// Use the resilient mechanism (11) during attacks.
    #[serde(default = "yes")]
    pub resilient: bool,
    /// Sampling period h of the resilient mechanism (s).
    pub h_s: f64,
    /// Dynamic rule: phi_i.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phi: Option<f64>,
    /// Dynamic rule: rho_i.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rho: Option<f64>,
    /// Dynamic rule: eta_i.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eta: Option<f64>,
    /// Dynamic rule: theta_i(0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta0: Option<f64>,
    /// Mixed rule: offset at t = 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mu: Option<f64>,
    /// Mixed rule: offset decay rate (1/s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    /// Periodic rule: period (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_s: Option<f64>,
}

fn yes() -> bool {
    true
}

/// `[attack]`. Keys that belong to another kind are errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Attack {
    /// `none`, `intervals`, `periodic` or `random`.
    pub kind: String,
    /// `intervals`: `[start (s), duration (s)]` pairs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intervals: Option<Vec<[f64; 2]>>,
    /// `periodic`: period (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_s: Option<f64>,
    /// `periodic`: attack length (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub duration_s: Option<f64>,
    /// `periodic`: first start (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_s: Option<f64>,
    /// `random`: seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// `random`: smallest quiet time (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_gap_s: Option<f64>,
    /// `random`: largest proposed quiet time (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_gap_s: Option<f64>,
    /// `random`: shortest proposed attack (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_duration_s: Option<f64>,
    /// `random`: longest proposed attack (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_duration_s: Option<f64>,
    /// Bounds of Assumption 2 to check the schedule against (required for `random`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assumption2: Option<Assumption2>,
}

impl Default for Attack {
    fn default() -> Self {
        Attack {
            kind: "none".into(),
            intervals: None,
            period_s: None,
            duration_s: None,
            offset_s: None,
            seed: None,
            min_gap_s: None,
            max_gap_s: None,
            min_duration_s: None,
            max_duration_s: None,
            assumption2: None,
        }
    }
}
