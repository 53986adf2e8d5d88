//! What a run says about itself: the types of `summary.json` (per follower, safety, the
//! attack, the wire, the fleet), which round-trip through it. The accumulators that fill them
//! step by step are `metrics`.
use platoon_attacks::{Assumption2, Assumption2Report};
use platoon_control::RejectCounts;
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;

/// Mean, max and RMS of an error's magnitude over a run, and its final value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Mean of |e| over all steps.
    #[serde(deserialize_with = "nullable")]
    pub mean_abs: f64,
    /// Largest |e|.
    #[serde(deserialize_with = "nullable")]
    pub max_abs: f64,
    /// Root mean square of e.
    #[serde(deserialize_with = "nullable")]
    pub rms: f64,
    /// |e| at the last step.
    #[serde(deserialize_with = "nullable")]
    pub final_abs: f64,
}

/// One follower's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VehicleSummary {
    /// Follower id.
    pub vehicle: u16,
    /// Broadcasts, the one at t = 0 included.
    pub triggers: u64,
    /// Shortest time between two broadcasts (s); None with fewer than two.
    pub min_inter_event_s: Option<f64>,
    /// Mean time between broadcasts (s); None with fewer than two.
    pub mean_inter_event_s: Option<f64>,
    /// Spacing error to the leader, `p_i - p_0 + i l` (`+ i (l + h_t v_i)` with a time
    /// headway) (m).
    pub spacing_error_m: ErrorStats,
    /// Gap error to the predecessor, `p_{i-1} - p_i - l` (`- (l + h_t v_i)` with a time
    /// headway) (m), positive when too far behind: string stability is whether it grows along the
    /// platoon.
    pub gap_error_m: ErrorStats,
    /// Velocity error `v_i - v_0` (m/s).
    pub velocity_error_mps: ErrorStats,
    /// Time affected by attacks (`A*`, s).
    #[serde(deserialize_with = "nullable")]
    pub affected_time_s: f64,
    /// Most negative acceleration (m/s^2).
    #[serde(deserialize_with = "nullable")]
    pub min_acceleration_mps2: f64,
    /// Time spent in each mode it was in (s): `coop`, its fallback, `blend`.
    pub mode_time_s: BTreeMap<String, f64>,
    /// Changes of mode.
    pub mode_switches: u64,
    /// Times the emergency-braking guard took over (from not braking to braking).
    pub guard_activations: u64,
    /// Time the guard was braking (s).
    #[serde(deserialize_with = "nullable")]
    pub guard_time_s: f64,
    /// Time the plant held its command within its class's limits (s): the law (or the
    /// guard) asked for more than the vehicle does. Absent without vehicle classes (the
    /// paper's ideal vehicle, which has none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub saturated_time_s: Option<f64>,
}

/// Gaps, decelerations and the run's safety class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Safety {
    /// A gap reached zero (a collision; the class is then `severe`). Not the same as "safe": a
    /// run without collision can still be `severe` by its deceleration.
    pub collided: bool,
    /// Smallest bumper-to-bumper gap `p_{i-1} - p_i - length` (m).
    #[serde(deserialize_with = "nullable")]
    pub min_gap_m: f64,
    /// The follower behind that gap.
    pub min_gap_vehicle: u16,
    /// When it happened (s).
    #[serde(deserialize_with = "nullable")]
    pub min_gap_t_s: f64,
    /// Smallest time to collision `gap / closing speed` of any follower while closing in on
    /// the vehicle ahead (s; true states, not the radar); None if no follower ever closed in.
    pub min_ttc_s: Option<f64>,
    /// When a gap first reached zero (s); absent without a collision.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_collision_t_s: Option<f64>,
    /// Who hit whom first, where and when, as the run's safety line names it (in memory:
    /// summary.json keeps `first_collision_t_s`, and a SUMO run's collisions are in its
    /// `sumo.collisions`).
    #[serde(skip)]
    pub first_collision: Option<Collision>,
    /// The largest deceleration any follower needed (m/s^2, positive).
    #[serde(deserialize_with = "nullable")]
    pub max_deceleration_mps2: f64,
    /// The run's class, as attack-injection studies (e.g. ComFASE) class outcomes: `none`,
    /// `negligible`, `benign` or `severe`, from the largest deceleration against the scenario's
    /// [`SafetyThresholds`]; a collision (a gap at or below zero) is always `severe`.
    pub class: SafetyClass,
    /// The thresholds used.
    pub thresholds: SafetyThresholds,
}

/// A collision: who hit whom, on which lane, when.
#[derive(Debug, Clone, PartialEq)]
pub struct Collision {
    /// When (s).
    pub t_s: f64,
    /// The vehicle behind, that drove into the other (`follower 3`, SUMO's id).
    pub collider: String,
    /// The vehicle ahead (`follower 2`, `the leader`, `cut-in car 0`, SUMO's id).
    pub victim: String,
    /// The lane (`the platoon's lane`, SUMO's lane id).
    pub lane: String,
    /// The gap between them then (m), when the plant measured it.
    pub gap_m: Option<f64>,
}

impl std::fmt::Display for Collision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} hit {} on {} at {:.2} s",
            self.collider, self.victim, self.lane, self.t_s
        )?;
        if let Some(g) = self.gap_m {
            write!(f, " (gap {g:.2} m)")?;
        }
        Ok(())
    }
}

/// A run's safety class, as attack-injection studies (e.g. ComFASE) class outcomes, from the
/// mildest to the worst (`Ord` follows severity).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SafetyClass {
    /// No more deceleration than the reference itself demands.
    None,
    /// Comfortable braking.
    Negligible,
    /// Hard braking, below emergency braking.
    Benign,
    /// Emergency braking or a collision.
    Severe,
}

impl SafetyClass {
    /// Its name in files: `none`, `negligible`, `benign` or `severe`.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Negligible => "negligible",
            Self::Benign => "benign",
            Self::Severe => "severe",
        }
    }
}

impl std::fmt::Display for SafetyClass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `summary.json` writes a number that is not finite (a diverged run, an empty minimum) as
/// `null`, as JSON has no NaN; this reads it back as NaN so that a summary round-trips.
fn nullable<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Deceleration thresholds (m/s^2, positive) that class a run's safety: at most `none` is
/// class `none` (no more than the reference itself demands), at most `negligible` is
/// `negligible` (comfortable braking), at most `benign` is `benign` (hard but below emergency
/// braking); beyond, or any collision, is `severe`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SafetyThresholds {
    /// Upper bound of class `none`.
    pub none: f64,
    /// Upper bound of class `negligible`.
    pub negligible: f64,
    /// Upper bound of class `benign`.
    pub benign: f64,
}

impl Default for SafetyThresholds {
    /// 2 m/s^2 (the paper leader's own braking), 3.5 (comfort), 6 (emergency braking).
    fn default() -> Self {
        Self {
            none: 2.0,
            negligible: 3.5,
            benign: 6.0,
        }
    }
}

impl SafetyThresholds {
    /// The class of a run with this largest deceleration and whether it collided.
    pub fn class(&self, max_deceleration: f64, collided: bool) -> SafetyClass {
        if collided || max_deceleration > self.benign {
            SafetyClass::Severe
        } else if max_deceleration > self.negligible {
            SafetyClass::Benign
        } else if max_deceleration > self.none {
            SafetyClass::Negligible
        } else {
            SafetyClass::None
        }
    }
}

/// The config's DoS schedule: its figures and its Assumption-2 verdict. What actually happened
/// on the channel is [`Summary::wire`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AttackSummary {
    /// Whether platoon's channel applied this schedule (false when a third-party injector
    /// replaced it: `--injector-mode replace`).
    pub applied: bool,
    /// Number of attack intervals `N(0, T)`.
    pub intervals: usize,
    /// Exact attacked time `|A(0, T)|` (s).
    #[serde(deserialize_with = "nullable")]
    pub attacked_time_s: f64,
    /// Steps whose instant fell inside an attack.
    pub attacked_steps: u64,
    /// Bounds checked, if the config gave them.
    pub assumption2_bounds: Option<Assumption2>,
    /// The exact verdict on every window, if bounds were given.
    pub assumption2: Option<Assumption2Report>,
    /// What jamming the vehicles sensed, measured in the run: with range jammers or jammers as
    /// transmitters (`[[channel.jammers]]`), whose DoS is not the config's schedule.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observed: Option<ObservedJamming>,
}

/// The DoS the vehicles observed: the steps in which at least one of them sensed its channel
/// jammed, as intervals, and the paper's Assumption 2 checked on them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObservedJamming {
    /// Jamming intervals (a run of jammed steps is one, `[start, start + steps dt)`).
    pub intervals: usize,
    /// Their total duration (s).
    pub jammed_time_s: f64,
    /// `[start (s), duration (s)]` of each.
    pub schedule: Vec<[f64; 2]>,
    /// The exact verdict on the observed schedule, if the config gave bounds.
    pub assumption2: Option<Assumption2Report>,
    /// With jammers as transmitters: every link that jamming cut, measured from the channel's
    /// log (a link is out from a packet lost to jamming, `dropped_jammed` or
    /// `dropped_interference`, until the next packet through, `restored`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<LinkOutage>,
}

/// One link's outages caused by jamming, in aggregate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinkOutage {
    /// The sender (0 = the leader).
    pub sender: u16,
    /// The receiver.
    pub receiver: u16,
    /// Outage intervals: from a packet lost to jamming to the next one through (exclusive).
    pub intervals: usize,
    /// Their total duration (s).
    pub jammed_time_s: f64,
    /// The longest (s).
    pub longest_s: f64,
    /// The exact verdict on the link's outages as a DoS schedule, if the config gave bounds.
    pub assumption2: Option<Assumption2Report>,
}

/// What `summary.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The run reached its last step.
    pub complete: bool,
    /// Why the run stopped early (the process and step), if it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// A fleet of several platoons: figures over all of them. The other fields are then
    /// platoon 0's (except `rejected_packets`, summed over the fleet).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fleet: Option<FleetOverview>,
    /// Steps run.
    pub steps: u64,
    /// Step length (s).
    #[serde(deserialize_with = "nullable")]
    pub dt_s: f64,
    /// Simulated time (s).
    #[serde(deserialize_with = "nullable")]
    pub duration_s: f64,
    /// The control law (`[control] law`; summaries from before it existed read `paper`).
    #[serde(default = "paper")]
    pub law: String,
    /// The triggering rule.
    pub rule: String,
    /// How often event conditions were checked (s).
    #[serde(deserialize_with = "nullable")]
    pub check_period_s: f64,
    /// The spacing policy: `constant` or `time_headway`.
    pub spacing_policy: String,
    /// Its time headway (s; 0 with constant spacing).
    #[serde(deserialize_with = "nullable")]
    pub time_headway_s: f64,
    /// Broadcasts per follower (keys are follower ids).
    pub triggers: BTreeMap<String, u64>,
    /// Broadcasts of all followers.
    pub triggers_total: u64,
    /// Shortest inter-event time over all followers (s): Zeno evidence if it equals the check period often.
    pub min_inter_event_s: Option<f64>,
    /// Per-follower figures.
    pub vehicles: Vec<VehicleSummary>,
    /// The attack.
    pub attack: AttackSummary,
    /// Gaps.
    pub safety: Safety,
    /// Packets the controllers refused.
    pub rejected_packets: RejectCounts,
    /// What happened on the V2V channel, measured between the broadcasts and what the
    /// controllers received, whatever injector ran (absent when nothing measured it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wire: Option<WireSummary>,
    /// What the 802.11p radio measured (`[channel] model = "80211p"` only): the load and the
    /// channel busy ratio the vehicles' radios saw, and what DCC did; over the fleet.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel: Option<platoon_attacks::channel::RadioStats>,
    /// The misbehaviour detectors measured against ground truth (`[detection]` only;
    /// platoon 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detection: Option<crate::detection::DetectionSummary>,
    /// The maneuvers (`[maneuvers]` only; platoon 0), measured on the wire and in the plant.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maneuvers: Option<ManeuversSummary>,
    /// Each scripted cut-in (`[[cut_ins]]`; platoon 0) as the members' radars saw it: when it
    /// asked for the platoon's lane, when it was first on it ahead of a member (and of whom),
    /// and when last; absent in runs without cut-ins.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cut_ins: Vec<CutInRecord>,
    /// Signed V2V (`[security]` only; over the fleet): packets signed, signatures verified,
    /// deliveries refused by reason.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub security: Option<SecuritySummary>,
}

/// `summary.json`'s `security` (`[security]` runs; docs/security.md).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SecuritySummary {
    /// `every` or `on_demand`.
    pub policy: String,
    /// Packets signed (one per broadcast).
    pub signed: u64,
    /// Deliveries whose signature was checked and held (shared by the receivers of one
    /// broadcast through a memo: at most one ECDSA verification per packet).
    pub verified: u64,
    /// Deliveries refused, by reason (`platoon_security::Refusal::name`: `bad_signature`,
    /// `truncated` for a packet without a seal, ...; every reason listed).
    pub refused: BTreeMap<String, u64>,
    /// Deliveries refused in all.
    pub refused_total: u64,
    /// Misbehaviour reports and revocations (`[security.reports]` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reports: Option<ReportsSummary>,
    /// The platoon's group key (`[security.group]` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group: Option<GroupSummary>,
}

/// `summary.json`'s `security.group` (`[security.group]` runs; docs/security.md).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct GroupSummary {
    /// What the tags protect: `maneuvers` or `all`.
    pub mac: String,
    /// Packets the senders tagged (over the fleet).
    pub tagged: u64,
    /// The leaders' renewals of the group key: one per member that left holding it.
    pub renewals: u64,
}

/// `summary.json`'s `security.reports` (`[security.reports]` runs; docs/security.md).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ReportsSummary {
    /// Reports the vehicles filed (over the fleet).
    pub filed: u64,
    /// Reports the uplink lost.
    pub lost: u64,
    /// What the authority made of those that arrived, by outcome
    /// (`platoon_security::ReportOutcome::name`: `counted`, `self_report`, ...; every outcome
    /// listed).
    pub outcomes: BTreeMap<String, u64>,
    /// The vehicles revoked, in order, as the controllers reported them at each step.
    pub revoked: Vec<RevokedRecord>,
}

/// A vehicle the misbehaviour authority revoked.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RevokedRecord {
    /// Its platoon.
    pub platoon: u16,
    /// The vehicle (0 = the leader).
    pub vehicle: u16,
    /// The first step its rows say it is revoked.
    pub step: u64,
    /// Ground truth (platoon 0, which the detections measure): whether its key had signed a
    /// delivered lie by then (`detection.signed_lies`): a liar, or a member whose key was
    /// stolen; `false` is a false revocation. Absent for other platoons.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signed_a_lie: Option<bool>,
}

impl Summary {
    /// Says of each revocation of platoon 0 whether the revoked vehicle's key had signed a
    /// delivered lie by then ([`RevokedRecord::signed_a_lie`]), from the detections' ground
    /// truth: call once `security` and `detection` are set.
    pub fn judge_revocations(&mut self) {
        let (Some(security), Some(detection)) = (&mut self.security, &self.detection) else {
            return;
        };
        let Some(reports) = &mut security.reports else {
            return;
        };
        for r in reports.revoked.iter_mut().filter(|r| r.platoon == 0) {
            r.signed_a_lie = Some(
                detection
                    .signed_lies
                    .iter()
                    .any(|l| l.vehicle == r.vehicle && l.first_step <= r.step),
            );
        }
    }
}

impl SecuritySummary {
    /// The summary of `counts` under `security`, with the vehicles `revoked` (from the rows).
    pub fn of(
        security: &platoon_control::SecurityParams,
        counts: &platoon_control::SealCounts,
        revoked: &[RevokedRecord],
    ) -> Self {
        let reports = &counts.reports;
        Self {
            policy: security.policy.name().to_string(),
            signed: counts.signed,
            verified: counts.verified,
            refused: counts
                .by_reason()
                .map(|(name, n)| (name.to_string(), n))
                .collect(),
            refused_total: counts.refused_total(),
            reports: security.reports.map(|_| ReportsSummary {
                filed: reports.filed,
                lost: reports.lost,
                outcomes: reports
                    .by_outcome()
                    .map(|(name, n)| (name.to_string(), n))
                    .collect(),
                revoked: revoked.to_vec(),
            }),
            group: security.group.map(|g| GroupSummary {
                mac: g.mac.name().to_string(),
                tagged: counts.tagged,
                renewals: counts.renewals,
            }),
        }
    }
}

/// One scripted cut-in (`summary.json`'s `cut_ins`), measured by the members' radars (the
/// truth they measure: `radar_target` of `trajectories.csv`): a car waits beside the platoon
/// until the gap it wants is safe (unless `aggressive`), so it may cut in later than it asked,
/// or never.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CutInRecord {
    /// The cut-in (entry c of `[[cut_ins]]`; `cut_in:<c>` in `radar_target`).
    pub cut_in: u16,
    /// When it appeared beside the platoon and asked for its lane (its `at_s`, s).
    pub asked_t_s: f64,
    /// When a member's radar first had it ahead on the platoon's lane (s); absent: never.
    pub entered_t_s: Option<f64>,
    /// That member (the follower it cut in ahead of).
    pub ahead_of: Option<u16>,
    /// How long it waited beside the platoon for a safe gap (s): `entered_t_s - asked_t_s`.
    pub waited_s: Option<f64>,
    /// When a member's radar last had it ahead on the platoon's lane (s).
    pub last_seen_t_s: Option<f64>,
}

/// What a run's maneuvers did (`summary.json`'s `maneuvers`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManeuversSummary {
    /// Maneuver messages the vehicles broadcast, each broadcast once whatever its receivers
    /// (what the channel did to them is in `wire`).
    pub messages_sent: u64,
    /// Each maneuver the config asks for, in the order of the steps they are asked at.
    pub maneuvers: Vec<ManeuverRecord>,
    /// Every formation the run visited, as the plant drove it, the first at 0 s.
    #[serde(default)]
    pub formations: Vec<FormationRecord>,
    /// Every lane change a vehicle's role asked for, as the plant made it (a vehicle changes
    /// lanes only into a safe gap, `platoon_sim::lanes`); absent in runs where nobody
    /// changes lanes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lane_changes: Vec<LaneChangeRecord>,
}

/// One lane change: when a vehicle's role asked for the other lane, and when the plant moved
/// it there, once the gap was safe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LaneChangeRecord {
    /// The vehicle.
    pub vehicle: u16,
    /// The lane it asked for: `beside` (the lane beside the platoon's) or `platoon`.
    pub to: String,
    /// When its role first asked for it (s).
    pub asked_t_s: f64,
    /// When it drove on that lane (s); absent: the gap there never became safe before the
    /// run ended (or the role asked for its lane back first).
    pub t_s: Option<f64>,
    /// How long it waited for a safe gap (s): 0 when it moved at once, the step after asking.
    pub waited_s: f64,
}

/// A formation a run visited: the lane's platoons as the rows say (the vehicles in each, by
/// the leader they took, in road order), from the step it began.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FormationRecord {
    /// When it began (s).
    pub t_s: f64,
    /// The leader's speed then (m/s).
    pub speed_mps: f64,
    /// The platoons in road order, each head first (the first headed by the leader): a
    /// vehicle belongs to the platoon of the leader it took, unless it is outside the lane's
    /// platoons (approaching, beside, left); a head of its own part (a split's, a merging
    /// platoon's) heads it on its ACC.
    pub platoons: Vec<Vec<u16>>,
    /// The stability certificate of its nominal closed loop (`platoon run` checks it, not
    /// the in-process library: `platoon_app::formations`): absent where it was not checked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stability: Option<FormationStability>,
}

/// The certificate of a formation's closed loop (docs/maneuvers.md#what-holds-during-a-formation-change):
/// its one-step maps at the ends of the lag range, and a common quadratic Lyapunov function.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FormationStability {
    /// The largest spectral radius of the one-step maps (below 1: each stable on its own);
    /// absent where it was not checked.
    pub spectral_radius: Option<f64>,
    /// The decay rate a common quadratic Lyapunov function certifies (1/s); absent: none was
    /// found.
    pub decay_per_s: Option<f64>,
    /// Why it could not be checked (the law has no loop, no SDP solver in this build, too
    /// many vehicles); the figures above are then absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unchecked: Option<String>,
}

/// One maneuver of a run: when its vehicle asked (on the wire), whether and when it was done
/// (in the plant), and what the platoon went through from the request on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManeuverRecord {
    /// `join`, `leave`, `merge` or `split`.
    pub maneuver: String,
    /// The joiner, the leaver, the merging platoon's head or the splitter.
    pub vehicle: u16,
    /// `completed` (the joiner or merging head admitted and in the lane's platoon, the leaver
    /// out of the lane, the splitter heading its part), `failed` (asked, and not completed by
    /// the end of the run: refused, timed out, given up or under way) or `not_requested` (the
    /// run ended before its vehicle asked).
    pub outcome: String,
    /// When its vehicle first broadcast the request (or the leave or split notice) (s).
    pub requested_t_s: Option<f64>,
    /// From the request to its completion (s).
    pub completion_s: Option<f64>,
    /// The largest |spacing error| of a vehicle in the lane's platoon, from the request to the
    /// end of the run (m).
    pub max_spacing_error_m: Option<f64>,
    /// The smallest gap to the vehicle ahead on the lane, from the request to the end of the
    /// run (m).
    pub min_gap_m: Option<f64>,
    /// Maneuver messages broadcast about it from the request until its completion (or the
    /// end of the run): sent by
    /// its vehicle or to it, or naming it (the leader's accept, the opener's gap ready, the
    /// update that admits it, ...).
    pub messages: u64,
}

/// The V2V channel over a run, as measured on the wire (see [`crate::tally`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WireSummary {
    /// Every vehicle of every platoon, plus deliveries to no vehicle.
    pub totals: crate::WireCounts,
    /// Deliveries to receivers that are no vehicle of the run (counted as injected).
    pub to_no_vehicle: crate::WireCounts,
    /// Platoon 0's vehicles, leader first.
    pub per_vehicle: Vec<VehicleWire>,
}

/// One vehicle's link packets over a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VehicleWire {
    /// The vehicle (0 = leader).
    pub vehicle: u16,
    /// Its counts.
    #[serde(flatten)]
    pub counts: crate::WireCounts,
}

impl Summary {
    /// The largest |spacing error| of any follower (m).
    pub fn max_spacing_error_m(&self) -> f64 {
        self.vehicles
            .iter()
            .map(|v| v.spacing_error_m.max_abs)
            .fold(0.0, f64::max)
    }

    /// The largest |gap error| of any follower (m).
    pub fn max_gap_error_m(&self) -> f64 {
        self.vehicles
            .iter()
            .map(|v| v.gap_error_m.max_abs)
            .fold(0.0, f64::max)
    }

    /// The last follower's largest |gap error| over the first's: above 1, errors grew along
    /// the platoon in this run (string instability, measured). None for one follower or a
    /// first follower that never left its gap.
    pub fn gap_error_growth(&self) -> Option<f64> {
        let (first, last) = (self.vehicles.first()?, self.vehicles.last()?);
        let ratio = last.gap_error_m.max_abs / first.gap_error_m.max_abs;
        (self.vehicles.len() > 1 && ratio.is_finite()).then_some(ratio)
    }
}

/// One platoon of a fleet, in brief.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlatoonBrief {
    /// Its index.
    pub platoon: u16,
    /// Broadcasts of its followers.
    pub triggers_total: u64,
    /// Its largest spacing error (m).
    #[serde(deserialize_with = "nullable")]
    pub max_spacing_error_m: f64,
    /// Its smallest gap (m).
    #[serde(deserialize_with = "nullable")]
    pub min_gap_m: f64,
    /// Its safety class.
    pub class: SafetyClass,
}

/// What `summary.json` says about a whole fleet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetOverview {
    /// Number of platoons.
    pub platoons: usize,
    /// Number of vehicles.
    pub vehicles: usize,
    /// Broadcasts of every follower.
    pub triggers_total: u64,
    /// A gap reached zero in some platoon.
    pub collided: bool,
    /// The smallest gap of any platoon (m).
    #[serde(deserialize_with = "nullable")]
    pub min_gap_m: f64,
    /// The largest deceleration any follower needed (m/s^2).
    #[serde(deserialize_with = "nullable")]
    pub max_deceleration_mps2: f64,
    /// The worst class of any platoon.
    pub class: SafetyClass,
    /// When a gap of any platoon first reached zero (s); absent without a collision.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_collision_t_s: Option<f64>,
    /// Every platoon.
    pub per_platoon: Vec<PlatoonBrief>,
}

fn paper() -> String {
    "paper".into()
}
