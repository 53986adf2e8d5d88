//! The in-process co-simulation of one platoon scenario, and its metrics. Pure: no I/O, clocks or
//! threads, so it is the oracle every other runtime (iceoryx2, SUMO) must agree with bit for bit.
//!
//! One step `k` has the shape of reading R24 (docs/paper-readings.md): plant states →
//! controllers decide who broadcasts → the channel (DoS schedule and link attacks, in process)
//! gates each link → controllers apply what arrived and compute `u[k]` → the plant advances to
//! `k + 1`.
#![warn(missing_docs)]

pub mod detection;
mod factory;
pub mod lanes;
mod maneuver_tally;
mod metrics;
pub mod model_check;
mod scenario;
mod summary;
pub mod tally;
pub mod traffic;
pub mod truth;

pub use factory::{
    ControllerFactory, Factory, InjectorFactory, Make, MakeController, MakeInjector, Plugins,
};
pub use metrics::{FleetMetrics, MetricsAccumulator};
pub use scenario::{Fleet, Scenario, ScenarioError, Vehicle};
pub use summary::{
    Collision, ErrorStats, FleetOverview, FormationRecord, FormationStability, GroupSummary,
    LaneChangeRecord, LinkOutage, ManeuverRecord, ManeuversSummary, PlatoonBrief, ReportsSummary,
    RevokedRecord, Safety, SafetyClass, SafetyThresholds, SecuritySummary, Summary, VehicleSummary,
    VehicleWire, WireSummary,
};
pub use tally::WireCounts;

/// What happened on the wire in one step: per vehicle (platoon by platoon, leader first) and to
/// receivers that are no vehicle of the run.
#[derive(Debug, Clone, Copy)]
pub struct StepWire<'a> {
    /// Per vehicle.
    pub per_vehicle: &'a [WireCounts],
    /// Deliveries to no vehicle.
    pub outside: WireCounts,
    /// The maneuver messages broadcast, each once whatever its receivers: (platoon, message),
    /// in platoon-local vehicle ids.
    pub maneuvers: &'a [(u16, platoon_control::maneuvers::Message)],
}

use platoon_attacks::channel::{Channel, ChannelEvent};
use platoon_attacks::inject::{InjectError, Injector, Reception};
use platoon_control::{Controller, Delivery, FollowerStep, Packet};
use platoon_model::{leader_step, LeaderProfile, State, TauSchedule, VehicleId};
use std::ops::ControlFlow;

/// One vehicle at one step: what `trajectories.csv` holds.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepRow {
    /// Step index k.
    pub step: u64,
    /// Time k dt (s).
    pub t: f64,
    /// The platoon (0 unless the scenario is a fleet).
    pub platoon: u16,
    /// Vehicle within its platoon (0 = leader).
    pub vehicle: u16,
    /// Position (m).
    pub p: f64,
    /// Velocity (m/s).
    pub v: f64,
    /// Acceleration (m/s^2).
    pub a: f64,
    /// Command over the step as the plant applied it (the leader: its reference
    /// acceleration): with vehicle classes, the controller's command held within the
    /// member's acceleration limits.
    pub u: f64,
    /// Internal variable theta_i (NaN for the leader).
    pub theta: f64,
    /// Spacing error `p_i - p_0 + i l` (m): positive means too close to the leader.
    pub spacing_error: f64,
    /// Velocity error `v_i - v_0` (m/s).
    pub velocity_error: f64,
    /// The vehicle broadcast at this step.
    pub triggered: bool,
    /// The channel was jammed at this step.
    pub under_attack: bool,
    /// The vehicle was affected by an attack (`A*`: its fallback applies).
    pub affected: bool,
    /// What the vehicle did: `coop` (the cooperative law; the leader's rows), its fallback
    /// (`zero`, `hold`, `predict`, `acc`) or `blend` (on its way back).
    pub mode: platoon_control::Status,
    /// The emergency-braking guard overrode the command.
    pub guard: bool,
    /// The plant held the command within the member's class's limits (`u` is not what the
    /// controller commanded). Not a column of `trajectories.csv`; the summary counts it.
    #[serde(skip)]
    pub saturated: bool,
    /// The misbehaviour authority has revoked the vehicle's certificates
    /// (`[security.reports]`). Not a column of `trajectories.csv`: events.csv says when.
    #[serde(skip)]
    pub revoked: bool,
    /// What its radar saw of a vehicle from outside the platoon ahead of it (a cut-in), as
    /// the plant has it; the summary's safety counts the gap to it. Not a column of
    /// `trajectories.csv`.
    #[serde(skip)]
    pub intruder: Option<platoon_control::fallback::RadarTruth>,
    /// Who its radar had in front of it ([`traffic::RadarTarget`], within the radar's range,
    /// as the plant has it: the truth the radar measures, not its noisy reading). Only in runs
    /// with traffic that can touch the platoon; elsewhere `None`, and the column is not
    /// written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radar_target: Option<traffic::RadarTarget>,
    /// The gap to it (m; NaN: nothing seen). As `radar_target`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radar_gap_m: Option<f64>,
    /// Its relative speed, `v - v_ahead` (m/s; positive while closing in; NaN: nothing seen).
    /// As `radar_target`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radar_closing_mps: Option<f64>,
    /// Whom the vehicle took as its leader at this step, a vehicle of its platoon: 0, the
    /// platoon's leader (the leader's own row), or the member heading its part of a platoon
    /// split behind a car that cut in, as its controller reported it. Only in runs that split
    /// (`[fallback.cut_in] split`); elsewhere `None`, and the column is not written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head: Option<u16>,
    /// Whether the vehicle drives in the lane beside the platoon's at this step, as the plant
    /// has it (a member that left, a joiner not yet moved in; one that wants to change lanes
    /// stays where it is until the gap is safe: [`lanes`]). Only in runs where vehicles change
    /// lanes ([`Scenario::changes_lanes`]); elsewhere `None`, and the column is not written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beside: Option<bool>,
}

impl StepRow {
    /// The names of the radar's columns, written only in runs with traffic that can touch the
    /// platoon ([`StepRow::radar_target`]).
    pub const RADAR_COLUMNS: [&'static str; 3] =
        ["radar_target", "radar_gap_m", "radar_closing_mps"];

    /// The column of whom each vehicle took as its leader, written only in runs that split a
    /// platoon behind a cut-in ([`StepRow::head`]).
    pub const HEAD_COLUMN: &'static str = "head";

    /// The column of each vehicle's lane, written only in runs where vehicles change lanes
    /// ([`StepRow::beside`]).
    pub const LANE_COLUMN: &'static str = "beside";

    /// Every column a run may leave out: the radar's, the head's and the lane's.
    pub const OPTIONAL_COLUMNS: [&'static str; 5] = [
        Self::RADAR_COLUMNS[0],
        Self::RADAR_COLUMNS[1],
        Self::RADAR_COLUMNS[2],
        Self::HEAD_COLUMN,
        Self::LANE_COLUMN,
    ];

    /// This row with the radar's columns (`on`: nothing seen where it has none) or without.
    pub fn with_radar_columns(mut self, on: bool) -> Self {
        if on {
            self.radar_target
                .get_or_insert(traffic::RadarTarget::Nothing);
            self.radar_gap_m.get_or_insert(f64::NAN);
            self.radar_closing_mps.get_or_insert(f64::NAN);
        } else {
            (self.radar_target, self.radar_gap_m, self.radar_closing_mps) = (None, None, None);
        }
        self
    }
}

/// The native plant: every follower under its own tau schedule (exact ZOH lag), the leader on
/// its profile. The iceoryx2 plant process runs this same code.
#[derive(Debug, Clone)]
pub struct Plant {
    states: Vec<State>,
    traffic: traffic::Traffic,
    /// Every vehicle's length, leader first.
    lengths: Vec<f64>,
    /// The members' classes (empty: no limits).
    vehicles: Vec<scenario::Vehicle>,
    taus: Vec<TauSchedule>,
    discretisation: platoon_model::Discretisation,
    leader: LeaderProfile,
    dt: f64,
    /// Each vehicle in the lane beside the platoon's (`[maneuvers]` with lane changes), leader
    /// first; empty in runs where nobody changes lanes.
    off_lane: Vec<bool>,
    /// When a vehicle may change lanes.
    rule: lanes::LaneChangeRule,
}

impl Plant {
    /// The plant of `scenario` at step 0 (the leader's acceleration already that of step 0).
    pub fn new(scenario: &Scenario) -> Self {
        let mut states = scenario.initial.clone();
        states[0][2] = scenario.leader.step_acceleration(0, scenario.dt());
        let rule = lanes::LaneChangeRule::DEFAULT;
        let mut traffic = traffic::Traffic::new(&scenario.cut_ins, rule);
        let lengths = scenario.lengths();
        // A joiner from beside starts off the lane.
        let off_lane: Vec<bool> = match scenario.changes_lanes() {
            true => (0..scenario.initial.len())
                .map(|i| scenario.starts_beside(i))
                .collect(),
            false => Vec::new(),
        };
        traffic.arrive(0.0, &states, &lengths, &off_lane);
        Self {
            states,
            traffic,
            lengths,
            vehicles: scenario.vehicles.clone(),
            taus: scenario.taus.clone(),
            discretisation: scenario.discretisation,
            leader: scenario.leader.clone(),
            dt: scenario.dt(),
            off_lane,
            rule,
        }
    }

    /// Moves every follower that wants the other lane (`beside(i)`, i >= 1: the lane beside
    /// the platoon's, for a member that left, role [`platoon_control::Role::Left`], or a joiner
    /// waiting there, role [`platoon_control::Role::Beside`]; else the platoon's) into it when
    /// the gap there is safe ([`lanes::LaneChangeRule`]), in the order of their numbers, each
    /// seeing the lanes as those before it left them. A follower whose gap is not safe stays
    /// where it is (it asks again at the next step). Nothing happens in a run where nobody
    /// changes lanes.
    pub fn change_lanes(&mut self, beside: impl Fn(usize) -> bool) {
        if self.off_lane.is_empty() {
            return;
        }
        for i in 1..self.states.len() {
            let want = beside(i);
            if want == self.off_lane[i] {
                continue;
            }
            let vehicle = |j: usize| {
                let x = self.states[j];
                [x[0], x[1], self.lengths[j]]
            };
            let members = (0..self.states.len())
                .filter(|&j| j != i && self.off_lane[j] == want)
                .map(vehicle);
            // The cars that cut in, on that lane.
            let cars = (self.traffic.cars_on(want)).map(|c| [c.p, c.v, c.length_m]);
            if self.rule.safe_among(vehicle(i), members.chain(cars)) {
                self.off_lane[i] = want;
            }
        }
    }

    /// Whether vehicle `i` drives in the lane beside the platoon's (never in a run where
    /// nobody changes lanes).
    pub fn beside(&self, i: usize) -> bool {
        self.off_lane.get(i).copied().unwrap_or(false)
    }

    /// Every vehicle's lane (`true`: beside the platoon's), leader first; empty in a run where
    /// nobody changes lanes.
    pub fn lanes(&self) -> &[bool] {
        &self.off_lane
    }

    /// The states at the current step, leader first.
    pub fn states(&self) -> &[State] {
        &self.states
    }

    /// Advances from step `k` to `k + 1` with the followers' commands `u` (index i - 1), each
    /// held within its member's limits (with vehicle classes; the emergency braking's where
    /// `guard(i)`, the guard overrode follower i's command).
    pub fn advance(&mut self, k: u64, u: &[f64], guard: impl Fn(usize) -> bool) {
        let t = k as f64 * self.dt;
        // The cars that cut in, on what is ahead of them at step k.
        if !self.traffic.is_empty() {
            self.traffic
                .advance(t, self.dt, &self.states, &self.lengths, &self.off_lane);
        }
        for (i, x) in self.states.iter_mut().enumerate().skip(1) {
            let ui = self
                .vehicles
                .get(i)
                .map_or(u[i - 1], |v| v.limit(u[i - 1], guard(i)));
            *x = self
                .discretisation
                .step(x, ui, self.taus[i - 1].at(t), self.dt);
        }
        self.states[0] = leader_step(
            &self.states[0],
            self.leader.step_acceleration(k as usize + 1, self.dt),
            self.dt,
        );
        if !self.traffic.is_empty() {
            let next = (k + 1) as f64 * self.dt;
            self.traffic
                .arrive(next, &self.states, &self.lengths, &self.off_lane);
        }
    }

    /// The vehicles from outside the platoon (scripted cut-ins) and where they are.
    pub fn traffic(&self) -> &traffic::Traffic {
        &self.traffic
    }

    /// What every vehicle's radar sees now (leader first: `None`): the vehicle ahead on the
    /// lane, the predecessor or a cut-in ([`traffic::radar_truth`]).
    pub fn radar_truth(&self, out: &mut Vec<Option<platoon_control::fallback::RadarTruth>>) {
        traffic::radar_truth(
            &self.states,
            &self.lengths,
            &self.traffic,
            &self.off_lane,
            out,
        );
    }

    /// [`Plant::radar_truth`], and who each radar sees ([`traffic::radar_view`]).
    pub fn radar_view(
        &self,
        out: &mut Vec<Option<platoon_control::fallback::RadarTruth>>,
        targets: &mut Vec<traffic::RadarTarget>,
    ) {
        traffic::radar_view(
            &self.states,
            &self.lengths,
            &self.traffic,
            &self.off_lane,
            out,
            targets,
        );
    }
}

/// What a plant process outside Rust (the SUMO bridge) needs to reproduce [`Plant`]: the time
/// grid, the initial states (the leader's acceleration already that of step 0), the leader's
/// profile and each follower's tau schedule. Serialised as the `plant.json` of a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlantSpec {
    /// Step length (s).
    pub dt: f64,
    /// The run covers steps `0..=steps`.
    pub steps: u64,
    /// `[p, v, a]` per vehicle, platoon by platoon, leader first.
    pub initial: Vec<[f64; 3]>,
    /// The leaders' velocity profile (waypoints).
    pub leader: LeaderProfile,
    /// Each follower's tau schedule (knots and interpolation), platoon by platoon.
    pub taus: Vec<TauSchedule>,
    /// Vehicle length (m).
    pub vehicle_length: f64,
    /// Each member's class, platoon 0's leader first (absent from plant.json without
    /// `[vehicle_classes]`): its length and the limits the plant holds its input within.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub vehicles: Vec<scenario::Vehicle>,
    /// N + 1.
    pub vehicles_per_platoon: usize,
    /// Each platoon's lane (SUMO).
    pub lanes: Vec<u32>,
    /// The followers' radar range (m) when a fallback or the guard reads the radar: the plant
    /// then reports the vehicle ahead within it in every state.
    pub radar_range_m: Option<f64>,
    /// The scripted cut-ins into every platoon (absent from plant.json when there are none).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cut_ins: Vec<traffic::CutIn>,
    /// When a vehicle may change lanes, in runs where vehicles do (members, or cars that cut
    /// in; absent from plant.json otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lane_change: Option<lanes::LaneChangeRule>,
}

impl PlantSpec {
    /// The spec of the plant of `scenario`'s whole fleet.
    pub fn new(scenario: &Scenario) -> Self {
        let replicas = scenario.replicas();
        Self {
            dt: scenario.dt(),
            steps: scenario.steps,
            initial: replicas
                .iter()
                .flat_map(|r| Plant::new(r).states().to_vec())
                .map(|x| [x[0], x[1], x[2]])
                .collect(),
            leader: scenario.leader.clone(),
            taus: replicas.iter().flat_map(|r| r.taus.clone()).collect(),
            vehicle_length: scenario.vehicle_length,
            vehicles: scenario.vehicles.clone(),
            vehicles_per_platoon: scenario.vehicles_per_platoon(),
            lanes: (0..scenario.fleet.platoons)
                .map(|j| scenario.fleet.lane(j))
                .collect(),
            // Read when anything uses the radar, with cut-ins (the outputs say what the radars
            // saw of them, as the native plant's do) and with leaves (the lane decides who
            // follows whom).
            radar_range_m: (scenario.control.fallback.uses_radar()
                || scenario.control.detection.reads_radar()
                || !scenario.cut_ins.is_empty()
                || scenario.changes_lanes())
            .then_some(scenario.control.fallback.radar.range_m),
            cut_ins: scenario.cut_ins.clone(),
            // Members that change lanes, and cars that cut in, do so by this rule.
            lane_change: (scenario.changes_lanes() || !scenario.cut_ins.is_empty())
                .then_some(lanes::LaneChangeRule::DEFAULT),
        }
    }
}

/// What the stages of one platoon's step produced, which [`step_rows`] records.
#[derive(Debug, Clone, Copy)]
pub struct RowSources<'a> {
    /// The step.
    pub k: u64,
    /// The plant's states, leader first.
    pub states: &'a [State],
    /// Whether the leader broadcast.
    pub leader_triggered: bool,
    /// Who sensed jamming, by vehicle.
    pub jammed: &'a [bool],
    /// What the plant's radars saw (by vehicle, empty without traffic), of which the rows keep
    /// the intruders.
    pub ahead: &'a [Option<platoon_control::fallback::RadarTruth>],
    /// Who they saw (by vehicle; empty: the rows say nothing of the radar), kept within the
    /// radar's range.
    pub targets: &'a [traffic::RadarTarget],
    /// Each vehicle's lane as the plant has it (`true`: beside the platoon's; empty in runs
    /// where nobody changes lanes).
    pub beside: &'a [bool],
}

/// Assembles the rows of step `sources.k` from what the stages produced (`sources`) and each
/// follower's step (`follower(i)`, i >= 1). Both runtimes build their rows here, so their
/// trajectories agree bit for bit.
pub fn step_rows(
    scenario: &Scenario,
    sources: &RowSources<'_>,
    follower: impl Fn(usize) -> FollowerStep,
    out: &mut Vec<StepRow>,
) {
    let RowSources {
        k,
        states,
        leader_triggered,
        jammed,
        ahead,
        targets,
        beside,
    } = *sources;
    let lane = |i: usize| {
        scenario
            .changes_lanes()
            .then(|| beside.get(i) == Some(&true))
    };
    let range = scenario.control.fallback.radar.range_m;
    let radar = |i: usize| {
        let who = *targets.get(i)?;
        let seen = ahead
            .get(i)
            .copied()
            .flatten()
            .filter(|t| who != traffic::RadarTarget::Nothing && t.gap <= range);
        Some(match seen {
            Some(t) => (who, t.gap, t.closing),
            None => (traffic::RadarTarget::Nothing, f64::NAN, f64::NAN),
        })
    };
    let t = k as f64 * scenario.dt();
    let x0 = states[0];
    let (regroups, split) = (
        scenario.regroups(),
        scenario.splits() || scenario.regroups(),
    );
    out.push(StepRow {
        step: k,
        t,
        platoon: scenario.platoon,
        vehicle: 0,
        p: x0[0],
        v: x0[1],
        a: x0[2],
        u: x0[2],
        theta: f64::NAN,
        spacing_error: 0.0,
        velocity_error: 0.0,
        triggered: leader_triggered,
        under_attack: jammed[0],
        affected: false,
        mode: platoon_control::Status::member(platoon_control::Mode::Coop),
        guard: false,
        saturated: false,
        // The leader has no command of its own: its followers say it.
        revoked: states.len() > 1 && follower(1).leader_revoked,
        intruder: None,
        radar_target: radar(0).map(|r| r.0),
        radar_gap_m: radar(0).map(|r| r.1),
        radar_closing_mps: radar(0).map(|r| r.2),
        head: split.then_some(0),
        beside: lane(0),
    });
    // Where vehicles change lanes, a follower's slot is counted on the road: 1 + the members
    // ahead of it (a member that left gives up its slot, a joiner takes one once admitted).
    let slots: Vec<f64> = if scenario.changes_lanes() {
        let member = |m: platoon_control::Status| m.role() == platoon_control::Role::Member;
        let members: Vec<(f64, bool)> = (1..states.len())
            .map(|i| (states[i][0], member(follower(i).status())))
            .collect();
        members
            .iter()
            .map(|&(p, _)| 1.0 + members.iter().filter(|&&(q, m)| m && q > p).count() as f64)
            .collect()
    } else {
        Vec::new()
    };
    for (i, x) in states.iter().enumerate().skip(1) {
        let s = follower(i);
        let slot = slots.get(i - 1).copied().unwrap_or(i as f64);
        // Two platoons (before a merge, after a split): each follower against its own
        // platoon's head.
        // platoon's head (a head is ahead of its followers; anything else a controller says
        // is measured against the leader).
        let (x0, slot) = match s.head.index() {
            h if regroups && h != 0 && h < i => (states[h], slot - h as f64),
            _ => (x0, slot),
        };
        out.push(StepRow {
            step: k,
            t,
            platoon: scenario.platoon,
            vehicle: i as u16,
            p: x[0],
            v: x[1],
            a: x[2],
            u: scenario.applied(i, s.u, s.guard),
            theta: s.theta,
            // Against the policy's desired distance to the leader (or the head it follows),
            // slot (l + h_t v_i), measured in the plant (h_t = 0 adds exactly nothing).
            spacing_error: x[0] - x0[0] + slot * (scenario.spacing() + scenario.headway() * x[1]),
            velocity_error: x[1] - x0[1],
            triggered: s.triggered,
            under_attack: jammed[i],
            affected: s.affected,
            mode: s.status(),
            guard: s.guard,
            saturated: scenario.applied(i, s.u, s.guard).to_bits() != s.u.to_bits(),
            revoked: s.revoked,
            intruder: ahead.get(i).copied().flatten().filter(|t| t.intruder),
            radar_target: radar(i).map(|r| r.0),
            radar_gap_m: radar(i).map(|r| r.1),
            radar_closing_mps: radar(i).map(|r| r.2),
            head: split.then_some(s.head.0),
            beside: lane(i),
        });
    }
}

/// A scenario being run step by step.
#[derive(Debug, Clone)]
pub struct Simulation {
    scenario: Scenario,
    controller: Box<dyn Controller>,
    injector: Box<dyn Injector>,
    plant: Plant,
    step: u64,
    tx: Vec<Packet>,
    deliveries: Vec<Delivery>,
    jammed: Vec<bool>,
    log: Vec<ChannelEvent>,
    rows: Vec<StepRow>,
    /// What the radars saw at this step, with traffic on the lane (else empty).
    radar: Vec<Option<platoon_control::fallback::RadarTruth>>,
    /// Who they saw (as `radar`).
    targets: Vec<traffic::RadarTarget>,
    wire: Vec<WireCounts>,
    wire_counter: tally::WireCounter,
    /// Who hears whom ([`Scenario::hearing`]): the links the channel carries.
    hearing: platoon_topology::Topology,
    /// The detectors measured against ground truth (`[detection]` only).
    detection: Option<detection::DetectionRecorder>,
}

impl Simulation {
    /// Prepares a run of `scenario` from its initial states, with the controller its config
    /// names.
    pub fn new(scenario: Scenario) -> Result<Self, ScenarioError> {
        Self::with(scenario, &ControllerFactory::builtin())
    }

    /// Prepares a run of `scenario` with the controller `factory` makes for it (a law or a
    /// whole controller of the caller's, in process) and the built-in channel.
    pub fn with(scenario: Scenario, factory: &ControllerFactory) -> Result<Self, ScenarioError> {
        Self::with_plugins(
            scenario,
            &Plugins {
                controller: factory.clone(),
                ..Plugins::default()
            },
        )
    }

    /// Prepares a run of `scenario` with the controller and the injector `plugins` make for it.
    pub fn with_plugins(scenario: Scenario, plugins: &Plugins) -> Result<Self, ScenarioError> {
        scenario.validate()?;
        let controller = plugins.controller.make(&scenario)?;
        let injector = plugins.injector.make(&scenario)?;
        let n = scenario.topology.followers();
        let detection = (!controller.detector_names().is_empty()).then(|| {
            detection::DetectionRecorder::new(
                scenario.platoon,
                controller.detector_names(),
                scenario.control.detection.reaction,
                scenario.dt(),
            )
            .signed(scenario.control.security.as_ref(), n + 1)
        });
        Ok(Self {
            injector,
            plant: Plant::new(&scenario),
            controller,
            step: 0,
            tx: Vec::with_capacity(n + 1),
            deliveries: Vec::new(),
            jammed: vec![false; n + 1],
            log: Vec::new(),
            rows: Vec::with_capacity(n + 1),
            radar: Vec::new(),
            targets: Vec::new(),
            wire: vec![WireCounts::default(); n + 1],
            wire_counter: tally::WireCounter::default(),
            detection,
            hearing: scenario.hearing(),
            scenario,
        })
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The plant: the platoon's states and the traffic around it.
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// The controllers (e.g. for their reject counts).
    pub fn controller(&self) -> &dyn Controller {
        self.controller.as_ref()
    }

    /// Lends the controller's seals the runtime's `clock` ([`Controller::time_crypto`]).
    pub fn time_crypto(&mut self, clock: platoon_control::CryptoClock) {
        self.controller.time_crypto(clock);
    }

    /// The next step to run.
    pub fn next_step(&self) -> u64 {
        self.step
    }

    /// Whether every step `0..=steps` has run.
    pub fn is_done(&self) -> bool {
        self.step > self.scenario.steps
    }

    /// What the channel did in the last step to packets it did not deliver as sent.
    pub fn channel_log(&self) -> &[ChannelEvent] {
        &self.log
    }

    /// What happened on the wire in the last step, per vehicle.
    pub fn wire(&self) -> &[WireCounts] {
        &self.wire
    }

    /// The built-in channel (its radio's measured load, CBR and beacon rates); `None` with an
    /// injector of the caller's.
    pub fn channel(&self) -> Option<&Channel> {
        self.injector.channel()
    }

    /// The injector.
    pub fn injector(&self) -> &dyn Injector {
        self.injector.as_ref()
    }

    /// The detectors measured against ground truth so far (`[detection]` only).
    pub fn detection(&self) -> Option<detection::DetectionSummary> {
        let d = self.detection.as_ref()?;
        Some(d.summary())
    }

    /// The packets the detectors inspected at the last step, with their ground truth
    /// (`[detection]` only; the per-message dataset).
    pub fn scored(&self) -> &[detection::Scored] {
        self.detection.as_ref().map_or(&[], |d| d.scored())
    }

    /// Runs step k and returns one row per vehicle (leader first) for it.
    ///
    /// # Panics
    ///
    /// If the injector fails (never the built-in channel): with an injector of the caller's,
    /// use [`Simulation::try_step`].
    pub fn step(&mut self) -> &[StepRow] {
        self.try_step().expect("the injector failed")
    }

    /// Runs step k and returns one row per vehicle (leader first) for it, or why the injector
    /// failed (the simulation is then left in the middle of step k).
    pub fn try_step(&mut self) -> Result<&[StepRow], InjectError> {
        let k = self.step;
        let sc = &self.scenario;
        let t = k as f64 * sc.dt();
        let states = self.plant.states();

        self.tx.clear();
        self.controller.transmit(k, states, &mut self.tx);
        self.deliveries.clear();
        self.log.clear();
        self.jammed.fill(false);
        self.injector.step(
            &platoon_attacks::inject::Step {
                k,
                t,
                topology: &self.hearing,
                states,
                tx: &self.tx,
                background: &[],
            },
            &mut Reception {
                deliveries: &mut self.deliveries,
                jammed: &mut self.jammed,
                log: &mut self.log,
            },
        )?;
        if k == sc.steps {
            self.injector.finish()?;
        }
        self.radar.clear();
        self.targets.clear();
        if !self.plant.traffic().is_empty() || sc.changes_lanes() {
            // The radars see the lane: a vehicle that cut in hides the predecessor, one that
            // left uncovers the member ahead of it.
            self.plant.radar_view(&mut self.radar, &mut self.targets);
            self.controller.set_radar_truth(&self.radar);
        }
        self.controller
            .receive(k, states, &self.deliveries, &self.jammed);
        // In process nothing is ever delivered to a vehicle that does not exist.
        let mut outside = WireCounts::default();
        self.wire_counter.count(
            tally::links(&self.hearing, &self.tx),
            &self.deliveries,
            &self.jammed,
            &mut self.wire,
            &mut outside,
        );

        if let Some(d) = &mut self.detection {
            d.record(
                k,
                states,
                tally::links(&self.hearing, &self.tx),
                &self.deliveries,
                self.controller.inspections(),
            );
        }

        let leader_triggered = self.tx.first().is_some_and(|p| p.sender.is_leader());
        let controller = self.controller.as_ref();
        self.rows.clear();
        // The rows name the radars' targets in runs with traffic (what the iceoryx2 run's
        // plant reports on the wire).
        let seen = if self.plant.traffic().is_empty() {
            0
        } else {
            self.radar.len()
        };
        step_rows(
            sc,
            &RowSources {
                k,
                states,
                leader_triggered,
                jammed: &self.jammed,
                ahead: &self.radar[..seen],
                targets: &self.targets[..seen.min(self.targets.len())],
                beside: self.plant.lanes(),
            },
            |i| controller.follower_step(VehicleId(i as u16)),
            &mut self.rows,
        );
        // Each vehicle into the lane its role asks for, where the gap there is safe.
        self.plant.change_lanes(|i| {
            controller
                .follower_step(VehicleId(i as u16))
                .status()
                .is_beside_the_lane()
        });
        let controller = &self.controller;
        self.plant.advance(k, controller.commands(), |i| {
            controller.follower_step(VehicleId(i as u16)).guard
        });
        self.step += 1;
        Ok(&self.rows)
    }
}

/// A fleet of identical, independent platoons (see [`Fleet`]) run in step: one [`Simulation`]
/// per platoon. With one platoon it is exactly [`Simulation`].
#[derive(Debug, Clone)]
pub struct FleetSimulation {
    sims: Vec<Simulation>,
    rows: Vec<StepRow>,
    log: Vec<ChannelEvent>,
    wire: Vec<WireCounts>,
    /// The maneuver messages broadcast in the last step, (platoon, message).
    maneuvers: Vec<(u16, platoon_control::maneuvers::Message)>,
    /// Every vehicle's (road position, measured beacon rate), for channels that count the
    /// fleet in their load.
    beacons: Vec<(f64, f64)>,
}

impl FleetSimulation {
    /// Prepares every platoon of `scenario`'s fleet.
    pub fn new(scenario: &Scenario) -> Result<Self, ScenarioError> {
        Self::with(scenario, &ControllerFactory::builtin())
    }

    /// Prepares every platoon of `scenario`'s fleet with the controllers `factory` makes (one
    /// per platoon, from its replica) and the built-in channel.
    pub fn with(scenario: &Scenario, factory: &ControllerFactory) -> Result<Self, ScenarioError> {
        Self::with_plugins(
            scenario,
            &Plugins {
                controller: factory.clone(),
                ..Plugins::default()
            },
        )
    }

    /// Prepares every platoon of `scenario`'s fleet with the controllers and injectors
    /// `plugins` make (one each per platoon, from its replica).
    pub fn with_plugins(scenario: &Scenario, plugins: &Plugins) -> Result<Self, ScenarioError> {
        scenario.validate()?;
        let sims = scenario
            .replicas()
            .into_iter()
            .map(|r| Simulation::with_plugins(r, plugins))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            rows: Vec::with_capacity(scenario.vehicles()),
            log: Vec::new(),
            wire: Vec::with_capacity(scenario.vehicles()),
            maneuvers: Vec::new(),
            beacons: Vec::new(),
            sims,
        })
    }

    /// What the platoons' 802.11p radios measured so far, over the fleet (`None` without it).
    pub fn radio_stats(&self) -> Option<platoon_attacks::channel::RadioStats> {
        let mut all = self.sims.iter().filter_map(|s| s.injector.radio_stats());
        let mut sum = all.next()?;
        for s in all {
            sum.merge(&s);
        }
        Some(sum)
    }

    /// The platoons.
    pub fn platoons(&self) -> &[Simulation] {
        &self.sims
    }

    /// Whether every step has run.
    pub fn is_done(&self) -> bool {
        self.sims[0].is_done()
    }

    /// Runs one step of every platoon; returns their rows, platoon by platoon.
    ///
    /// # Panics
    ///
    /// If an injector fails (never the built-in channel): with an injector of the caller's,
    /// use [`FleetSimulation::try_step`].
    pub fn step(&mut self) -> &[StepRow] {
        self.try_step().expect("the injector failed")
    }

    /// Runs one step of every platoon; returns their rows, platoon by platoon, or why an
    /// injector failed.
    pub fn try_step(&mut self) -> Result<&[StepRow], InjectError> {
        self.rows.clear();
        self.log.clear();
        self.wire.clear();
        if self.sims.len() > 1 {
            let k = self.sims[0].step;
            let platoons = self.sims.iter_mut().map(|s| {
                let Simulation {
                    injector, plant, ..
                } = s;
                (injector.as_mut() as &mut dyn Injector, plant.states())
            });
            platoon_attacks::inject::hear_fleet(k, platoons, &mut self.beacons);
        }
        self.maneuvers.clear();
        for (j, s) in self.sims.iter_mut().enumerate() {
            self.rows.extend_from_slice(s.try_step()?);
            self.log.extend_from_slice(s.channel_log());
            self.wire.extend_from_slice(s.wire());
            self.maneuvers.extend(
                s.tx.iter()
                    .filter_map(|p| p.maneuver.map(|m| (j as u16, m))),
            );
        }
        Ok(&self.rows)
    }

    /// The rows of the last step, platoon by platoon.
    pub fn rows(&self) -> &[StepRow] {
        &self.rows
    }

    /// What happened on the wire in the last step (every vehicle, platoon by platoon).
    pub fn wire(&self) -> StepWire<'_> {
        StepWire {
            per_vehicle: &self.wire,
            outside: WireCounts::default(),
            maneuvers: &self.maneuvers,
        }
    }

    /// What the channels did in the last step to packets they did not deliver as sent.
    pub fn channel_log(&self) -> &[ChannelEvent] {
        &self.log
    }

    /// Packets refused by the controllers of every platoon.
    pub fn rejected(&self) -> platoon_control::RejectCounts {
        let mut sum = [0u64; 6];
        for s in &self.sims {
            for (a, x) in sum.iter_mut().zip(s.controller().rejected().as_array()) {
                *a += x;
            }
        }
        platoon_control::RejectCounts::from_array(sum)
    }

    /// Lends every platoon's seals the runtime's `clock`, to time their signing and verifying
    /// ([`FleetSimulation::crypto_time`]; `[security]` runs only, nothing changes otherwise).
    pub fn time_crypto(&mut self, clock: platoon_control::CryptoClock) {
        for s in &mut self.sims {
            s.time_crypto(clock);
        }
    }

    /// The time every platoon's seals spent signing and verifying so far, by the clock of
    /// [`FleetSimulation::time_crypto`] (`[security]` only).
    pub fn crypto_time(&self) -> Option<platoon_control::CryptoTime> {
        self.sims
            .iter()
            .filter_map(|s| s.controller().crypto_time())
            .reduce(|a, b| a.plus(&b))
    }

    /// What the seals of signed V2V (and the misbehaviour reports) did over every platoon
    /// (`[security]` only), with the vehicles `revoked` ([`FleetMetrics::revoked`]).
    pub fn security(&self, revoked: &[summary::RevokedRecord]) -> Option<SecuritySummary> {
        let params = (self.sims.iter()).find_map(|s| s.controller().checks()?.security())?;
        let counts = (self.sims.iter())
            .filter_map(|s| s.controller().seals())
            .fold(platoon_control::SealCounts::default(), |a, b| a.plus(&b));
        Some(SecuritySummary::of(params, &counts, revoked))
    }
}

/// Runs a whole scenario in process (every platoon of its fleet), calling `each` with the
/// rows of every step (platoon by platoon, leader first), and returns its summary: platoon 0 in
/// detail, the fleet in brief, and the wire tally, as `platoon run --transport inproc` records
/// them.
pub fn run(scenario: Scenario, mut each: impl FnMut(&[StepRow])) -> Result<Summary, ScenarioError> {
    run_until(&scenario, |sim| {
        each(sim.rows());
        ControlFlow::Continue(())
    })
}

/// The in-process step loop every front-end shares: steps `scenario`'s fleet and hands `each`
/// the simulation after every step (its rows, what happened on the wire, the channel's log),
/// until the last step or until `each` breaks (the summary then says `complete: false`).
pub fn run_until(
    scenario: &Scenario,
    each: impl FnMut(&FleetSimulation) -> ControlFlow<()>,
) -> Result<Summary, ScenarioError> {
    run_until_with(scenario, &ControllerFactory::builtin(), each)
}

/// [`run_until`] with the controllers `factory` makes.
pub fn run_until_with(
    scenario: &Scenario,
    factory: &ControllerFactory,
    each: impl FnMut(&FleetSimulation) -> ControlFlow<()>,
) -> Result<Summary, ScenarioError> {
    let plugins = Plugins {
        controller: factory.clone(),
        ..Plugins::default()
    };
    run_until_plugins(scenario, &plugins, each)
}

/// [`run_until`] with the controllers and the injectors `plugins` make (an attack of the
/// caller's in process: runs, campaigns, searches). An injector that fails ends the run with
/// its error.
pub fn run_until_plugins(
    scenario: &Scenario,
    plugins: &Plugins,
    each: impl FnMut(&FleetSimulation) -> ControlFlow<()>,
) -> Result<Summary, ScenarioError> {
    let sim = FleetSimulation::with_plugins(scenario, plugins)?;
    run_fleet(scenario, sim, each)
}

/// [`run_until`] with the seals' cryptography timed by the runtime's `clock` (`[security]`
/// runs; `each` reads [`FleetSimulation::crypto_time`]): what the in-process runner reports in
/// timing.json. The clock changes nothing the run computes.
pub fn run_until_timed(
    scenario: &Scenario,
    clock: platoon_control::CryptoClock,
    each: impl FnMut(&FleetSimulation) -> ControlFlow<()>,
) -> Result<Summary, ScenarioError> {
    let mut sim = FleetSimulation::with_plugins(scenario, &Plugins::default())?;
    sim.time_crypto(clock);
    run_fleet(scenario, sim, each)
}

/// Steps `sim` (`scenario`'s fleet) until the last step or until `each` breaks.
fn run_fleet(
    scenario: &Scenario,
    mut sim: FleetSimulation,
    mut each: impl FnMut(&FleetSimulation) -> ControlFlow<()>,
) -> Result<Summary, ScenarioError> {
    let mut metrics = FleetMetrics::new(scenario);
    while !sim.is_done() {
        sim.try_step()?;
        metrics.push_wire(sim.wire());
        metrics.push_channel(sim.channel_log());
        metrics.push(sim.rows());
        if each(&sim).is_break() {
            break;
        }
    }
    let mut summary = metrics.finish(sim.rejected());
    summary.channel = sim.radio_stats();
    summary.detection = sim.platoons()[0].detection();
    summary.security = sim.security(metrics.revoked());
    summary.judge_revocations();
    Ok(summary)
}
