//! The `[control]`, `[trigger]`, `[fallback]`, `[radar]`, `[guard]` and `[detection]` tables:
//! what the followers run.
use crate::serde_util::{self, DefaultTag};
use platoon_control::fallback::AccParams;
use platoon_control::{FallbackMode, LawParams, PaperParams};
use schemars::JsonSchema;
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

/// `[control]`: the law (`law`) and its keys (the keys of another law are errors).
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[schemars(transform = serde_util::default_tag_schema::<LawParams>)]
pub struct Control {
    /// The law and its parameters.
    #[serde(flatten, deserialize_with = "serde_util::with_default_tag")]
    pub law: LawParams,
    /// The older name of `fallback.mode`; set one of them. The resolved config says
    /// `fallback.mode`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("deprecated" = true))]
    pub attack_input: Option<FallbackMode>,
}

/// The selector first, then the law's own keys (a config's order).
impl Serialize for Control {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("law", self.law.name())?;
        serde_util::entries(&mut m, &self.law, "law")?;
        if let Some(a) = &self.attack_input {
            m.serialize_entry("attack_input", a)?;
        }
        m.end()
    }
}

impl Control {
    /// The paper's law's gain and weights: the config's with `law = "paper"`, else the paper's
    /// own (the controller takes them whatever it runs).
    pub fn paper_law(&self) -> PaperParams {
        match &self.law {
            LawParams::Paper(p) => *p,
            _ => PaperParams::default(),
        }
    }

    /// The paper's law's keys, to change them; the law becomes the paper's if it was another.
    pub fn paper_law_mut(&mut self) -> &mut PaperParams {
        if !self.law.is_paper() {
            self.law = LawParams::Paper(PaperParams::default());
        }
        match &mut self.law {
            LawParams::Paper(p) => p,
            _ => unreachable!("set just above"),
        }
    }
}

impl DefaultTag for LawParams {
    const SELECTOR: &'static str = "law";
    const DEFAULT: &'static str = "paper";
}

/// `[fallback]`: what a follower does while affected by an attack, and how it comes back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct FallbackConfig {
    /// Every follower's fallback (`control.attack_input`, its older name, if given; else
    /// `zero`, the paper's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mode: Option<FallbackMode>,
    /// One mode per follower instead (follower 1 first).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_vehicle: Option<Vec<FallbackMode>>,
    /// Time a vehicle stays in its fallback once it is no longer affected (s).
    pub dwell_s: f64,
    /// Time over which it then returns to the cooperative law, bumplessly (s; 0: at once).
    pub blend_s: f64,
    /// ...or longer, so that the gap its fallback left closes at most this fast (m/s).
    pub closing_mps: f64,
    /// The ACC law.
    pub acc: AccParams,
    /// `[fallback.cut_in]`: a follower whose radar sees a vehicle that is not its
    /// predecessor (a cut-in) runs the ACC law above on it, and returns as from a fallback;
    /// absent: it does not tell a cut-in from its predecessor.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cut_in: Option<CutInHandling>,
    /// A follower whose law reads V2V is affected (it applies its fallback, as on a jammed
    /// channel) when the vehicle it follows, or its leader, has had no packet accepted for
    /// longer than this (s, > 0): a link that delivers nothing, or whose packets are all
    /// refused. For periodic beaconing (set it above the beacon period); under event
    /// triggering a neighbour is silent by design between its events. Absent: silence goes
    /// unnoticed and the law steers on the last packet it took.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub silence_s: Option<f64>,
}

/// `[fallback.cut_in]`: how a follower handles a vehicle that cut in ahead of it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct CutInHandling {
    /// Time it stays on the intruder's ACC once its radar sees its predecessor again (s).
    pub dwell_s: f64,
    /// Time over which it then returns to its law, bumplessly (s; at least `fallback.blend_s`).
    pub blend_s: f64,
    /// Split the platoon behind the car: while a follower runs its ACC on a car that cut in, it
    /// announces in its beacons that it heads the followers behind it, and they take it as
    /// their leader until it is back on its law: the PATH CACC and the flatbed controller read
    /// its packets as their leader's, the paper's law and the consensus law couple the
    /// followers behind it only, the head in the leader's place. Each switch of leader is blended over `blend_s`. Every
    /// follower then also hears the members ahead of it beyond its `[topology]` (the channel
    /// carries those links too). Absent: split where a follower would otherwise steer on a
    /// vehicle ahead of the car, that is with `path_cacc`, `flatbed` or `consensus` (they read
    /// the leader), and with the paper's law on a graph where some follower hears a vehicle
    /// ahead of its predecessor (`tpsf`, `plf`, not `pf`), unless `[maneuvers]` merges or
    /// splits the platoon. Only for those four laws (`ploeg` and `acc` read their predecessor
    /// alone: nothing to re-point).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split: Option<bool>,
}

impl Default for CutInHandling {
    /// A second's dwell, three seconds' return, the split as the law and graph need it.
    fn default() -> Self {
        Self {
            dwell_s: 1.0,
            blend_s: 3.0,
            split: None,
        }
    }
}

/// `[[cut_ins]]`: one scripted vehicle that enters the platoon's lane in the gap ahead of a
/// follower, of every platoon of a fleet. The same on either plant: on SUMO it is a SUMO
/// vehicle on the platoon's lane, put there at the step it enters on the native plant, moved
/// with the same kinematics and removed at `leave_s`; the radars see it through SUMO's
/// `getLeader`, and its collisions are SUMO's (docs/sumo.md). Checked before the run against
/// the gap it enters at `at_s` (the initial states' at t = 0, later the larger of that and the
/// formation's at the leader's speed then): it must fit, and no other car may be in that gap
/// then (docs/traffic.md#checked-before-the-run).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CutInConfig {
    /// When it appears on the lane beside, level with the gap, and starts asking to cut in
    /// (s); it cuts in at once where the gap is safe (or it is `aggressive`).
    pub at_s: f64,
    /// The follower it cuts in front of (1..=N).
    pub ahead_of: usize,
    /// The gap it leaves to that follower as it enters (m, bumper to bumper, > 0, and the car
    /// must fit: `gap_m + length_m` below the gap it enters); absent: the middle of the gap,
    /// equal gaps ahead of it and behind it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gap_m: Option<f64>,
    /// Its speed when it enters, minus the follower's (m/s): it enters at 0 to 100 m/s.
    #[serde(default)]
    pub speed_diff_mps: f64,
    /// How hard it brakes after it entered (m/s^2, >= 0)...
    #[serde(default)]
    pub decel_mps2: f64,
    /// ...and for how long (s).
    #[serde(default)]
    pub brake_s: f64,
    /// When it asks to leave the lane again, for the lane beside, where it drives on (s);
    /// absent: it stays.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leave_s: Option<f64>,
    /// Its length (m), shorter than the gap it enters; absent: `platoon.vehicle_length_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length_m: Option<f64>,
    /// It cuts in at `at_s` and leaves at `leave_s` whatever the gaps (the aggressive driver of
    /// a cut-in study); `false` (the default): it waits beside the platoon until the gap is
    /// safe by the lane-change rule of the members' lane changes, for each change.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub aggressive: bool,
}

/// `[maneuvers]`: the platoon's maneuvers and the protocol's timing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ManeuversConfig {
    /// `[[maneuvers.joins]]`: vehicles that start outside the platoon, behind it, and join at
    /// its tail. The joiners are the platoon's last vehicles (their initial states are theirs).
    pub joins: Vec<JoinAt>,
    /// `[[maneuvers.leaves]]`: members that leave: on the leader's update a leaver moves to
    /// the lane beside once the gap there is safe (on either plant) and drives on its ACC at
    /// the speed it left at, and the member behind it closes up to the one ahead, its gap
    /// shrinking at `fallback.closing_mps`.
    pub leaves: Vec<LeaveAt>,
    /// `[maneuvers.merge]`: the vehicles from follower `head` to the last start as a platoon of
    /// their own, headed by `head` on its ACC (`fallback.acc`) behind the platoon's tail; at
    /// `at_s` the head asks the leader to merge, closes up to the platoon's gap once accepted,
    /// and on the leader's update both are one platoon (no joins or leaves beside it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub merge: Option<HeadAt>,
    /// `[maneuvers.split]`: at `at_s` follower `head` tells the leader it heads the members
    /// behind it off as a platoon of their own; on the leader's update it drives on its ACC
    /// (`fallback.acc`, its headway opening from the platoon's to the ACC's over `opening_s`)
    /// and the members behind it take it as their leader (no joins or leaves beside it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split: Option<HeadAt>,
    /// How long a vehicle waits for an answer before it asks again, and the spacing of the
    /// leader's repeats of a formation update (s).
    pub reply_s: f64,
    /// How many times a message that wants an answer is sent, at most (>= 1).
    pub tries: u32,
    /// How long a join may take from the leader's accept (s): then it is called off. At least
    /// a step; one longer than the run is a join that never times out.
    pub timeout_s: f64,
    /// A joiner is in position when its gap is within this of the platoon's (m)...
    pub in_position_m: f64,
    /// ...and it closes on the vehicle ahead at most this fast (m/s).
    pub in_position_mps: f64,
    /// Members the platoon admits, the leader counted (at least those it starts with); absent:
    /// every vehicle of the scenario.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_members: Option<usize>,
    /// The leader checks an in-position report (a joiner's, a merging head's) against the
    /// sender's own beacons: one whose beacon puts the sender farther than 3 x `in_position_m`
    /// from its slot (behind the member it follows, as that member's last beacon places it) is
    /// dropped before the protocol sees it, its sequence number unused; so is a join or
    /// merge request from a vehicle the leader never heard beaconing before it (both counted
    /// in `summary.json`'s `rejected_packets`; with `[detection]`, every message it tested is
    /// measured against the ground truth in `detection.maneuver_checks` and `detections.csv`).
    /// Off: the leader takes the messages as they come (Plexe's and VENTOS's way).
    pub check_reports: bool,
}

/// A join: at the tail from behind the platoon, or from the lane beside it into the slot
/// behind a member.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JoinAt {
    /// The joiner (a follower id; the joiners are the last vehicles).
    pub vehicle: usize,
    /// When it asks the leader (s).
    pub at_s: f64,
    /// The member whose slot behind it the joiner asks for (0 the leader): the joiner starts
    /// in the lane beside the platoon's (its initial state alongside), the member behind the
    /// slot opens a gap, and the joiner changes lanes into it. Absent: at the tail, the joiner
    /// starting behind the platoon in its lane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub behind: Option<usize>,
}

/// A leave.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LeaveAt {
    /// The leaver (a follower the run starts with).
    pub vehicle: usize,
    /// When it tells the leader (s).
    pub at_s: f64,
}

/// A merge or a split: the rear platoon's head, and when it tells the leader.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HeadAt {
    /// The rear platoon's head (a follower, 2 to N - 1: each platoon keeps a follower).
    pub head: usize,
    /// When it tells the leader (s).
    pub at_s: f64,
}

/// Plexe-like timing: answers within 0.5 s, 3 tries, a join within 30 s; in position within
/// 1 m of the platoon's gap, closing slower than 0.5 m/s.
impl Default for ManeuversConfig {
    fn default() -> Self {
        Self {
            joins: Vec::new(),
            leaves: Vec::new(),
            merge: None,
            split: None,
            reply_s: 0.5,
            tries: 3,
            timeout_s: 30.0,
            in_position_m: 1.0,
            in_position_mps: 0.5,
            max_members: None,
            check_reports: false,
        }
    }
}

/// The controller's defaults: no dwell, no blend.
impl Default for FallbackConfig {
    fn default() -> Self {
        let d = platoon_control::FallbackParams::default();
        Self {
            mode: None,
            per_vehicle: None,
            dwell_s: 0.0,
            blend_s: 0.0,
            closing_mps: d.closing_mps,
            acc: d.acc,
            cut_in: None,
            silence_s: None,
        }
    }
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
        let d = platoon_control::fallback::RadarParams::default();
        Self {
            range_m: d.range_m,
            // The controller's period of 5 steps at the paper's step of 0.01 s.
            period_s: 0.05,
            noise_m: d.noise_m,
            noise_mps: d.noise_mps,
            dropout: d.dropout,
            seed: d.seed,
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
    #[serde(default = "resilient_by_default")]
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

/// The paper's mechanism (11) is on unless a config turns it off.
fn resilient_by_default() -> bool {
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
        serde_util::tag_name(self, "rule")
    }
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
    #[serde(default = "quiet_period_s")]
    pub quiet_s: f64,
    /// The names of detectors a `--controller` plug-in runs itself and reports on the wire
    /// (docs/detection.md): measured against ground truth like the built-in ones, after them.
    /// Only a run with a controller plug-in may name any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plugin: Vec<String>,
}

fn quiet_period_s() -> f64 {
    1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `LawName::name` is the one list of the laws' names: serde's for both enums agree.
    #[test]
    fn every_law_is_named_as_serde_names_it() {
        for law in platoon_control::LawName::ALL {
            let as_name = toml::Value::try_from(law).unwrap();
            assert_eq!(as_name.as_str(), Some(law.name()));
            let params = toml::Value::try_from(law.defaults()).unwrap();
            assert_eq!(params.get("law").and_then(|l| l.as_str()), Some(law.name()));
            assert_eq!(law.defaults().kind(), law);
            assert_eq!(platoon_control::LawName::from_name(law.name()), Some(law));
        }
    }

    /// A `[control]` table without `law` is the paper's.
    #[test]
    fn the_law_defaults_to_the_papers() {
        let c: Control = toml::from_str("gain = [1.0, 2.0, 3.0]").unwrap();
        assert_eq!(
            c.law,
            LawParams::Paper(PaperParams {
                gain: [1.0, 2.0, 3.0],
                ..Default::default()
            })
        );
        let c: Control = toml::from_str("law = \"ploeg\"\nheadway_s = 0.6").unwrap();
        assert!(matches!(c.law, LawParams::Ploeg(p) if p.headway_s == 0.6));
        assert!(toml::from_str::<Control>("law = \"ploeg\"\ngain = [1.0, 2.0, 3.0]").is_err());
    }
}
