use platoon_attacks::channel::{ChannelSpec, LinkAttack};
use platoon_attacks::{Assumption2, DosSchedule};
use platoon_control::{ControllerParams, ParamsError};
use platoon_model::{LeaderProfile, State, TauSchedule};
use platoon_topology::Topology;

/// Why a scenario cannot run. The `key` names what is wrong in config terms.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// Controller parameters out of range.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// The injector could not be made, or failed during the run.
    #[error("injector: {0}")]
    Injector(#[from] platoon_attacks::inject::InjectError),
    /// The parts of the scenario disagree or a value is out of range.
    #[error("{key}: {message}")]
    Invalid {
        /// The offending part.
        key: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// Everything one run needs, already validated piecewise (see `platoon-config`).
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Number of steps; the run covers steps `0..=steps`, i.e. `[0, steps dt]`.
    pub steps: u64,
    /// Initial states, leader first.
    pub initial: Vec<State>,
    /// The leader's velocity profile.
    pub leader: LeaderProfile,
    /// Each follower's time-constant schedule (length N).
    pub taus: Vec<TauSchedule>,
    /// How the native plant moves the followers.
    pub discretisation: platoon_model::Discretisation,
    /// The communication graph.
    pub topology: Topology,
    /// Controller, trigger and spacing parameters (holds the step `dt`).
    pub control: ControllerParams,
    /// When the channel is jammed.
    pub dos: DosSchedule,
    /// Link-level attacks, applied in order after the DoS schedule.
    pub link_attacks: Vec<LinkAttack>,
    /// Jammers as transmitters (`[[channel.jammers]]`), every platoon's channel has them all.
    pub jammers: Vec<platoon_attacks::jammer::Jammer>,
    /// Seed of the channel's random losses.
    pub channel_seed: u64,
    /// The 802.11p radio, if the channel has one (its models shared by every platoon of a
    /// fleet).
    pub radio: Option<platoon_attacks::channel::RadioSpec>,
    /// Bounds to check the DoS schedule against, if given.
    pub assumption2: Option<Assumption2>,
    /// Vehicle length for gap computations (m); 0 treats vehicles as points. With
    /// [`Scenario::vehicles`] the members' own lengths replace it (cut-ins keep it as their
    /// default).
    pub vehicle_length: f64,
    /// Each member's vehicle class, leader first (`[vehicle_classes]`, N + 1 entries); empty:
    /// every vehicle `vehicle_length` long, without limits, its lag range the scenario's.
    pub vehicles: Vec<Vehicle>,
    /// Scripted cut-ins into every platoon of the fleet (the native plant's traffic; the SUMO
    /// plant's through [`crate::PlantSpec`]).
    pub cut_ins: Vec<crate::traffic::CutIn>,
    /// How the run's safety is classed.
    pub safety: crate::SafetyThresholds,
    /// How many copies of this platoon run side by side, and where.
    pub fleet: Fleet,
    /// This platoon's index in its fleet (0 for a single platoon): its rows carry it and its
    /// vehicles' global ids start at `platoon * (N + 1)`.
    pub platoon: u16,
}

/// One member's vehicle class, as the plant and the design use it (`[vehicle_classes]`,
/// docs/traffic.md#mixed-vehicles). Its true lag is the member's schedule in
/// [`Scenario::taus`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Vehicle {
    /// The class's name.
    pub class: String,
    /// Length (m), >= 0.
    pub length_m: f64,
    /// The largest acceleration the plant applies (m/s^2, > 0); `None`: unlimited.
    pub accel_max_mps2: Option<f64>,
    /// The largest deceleration the plant applies (m/s^2, > 0); `None`: unlimited.
    pub decel_max_mps2: Option<f64>,
    /// The largest deceleration while the guard brakes (m/s^2, >= `decel_max_mps2`); `None`:
    /// `decel_max_mps2`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub emergency_decel_mps2: Option<f64>,
    /// The engine lags the design must cover for this member, `(lo, hi)` (s): they contain
    /// its true schedule. Unused for the leader, which drives its profile.
    pub tau_range_s: (f64, f64),
}

impl Vehicle {
    /// The input the plant applies for command `u`: `u` held within the class's limits
    /// (first the acceleration, then the deceleration, the emergency one while the guard
    /// brakes, `guard`; the SUMO bridge's model does the same).
    #[inline]
    pub fn limit(&self, u: f64, guard: bool) -> f64 {
        let mut u = u;
        if let Some(a) = self.accel_max_mps2 {
            u = u.min(a);
        }
        let decel = match (guard, self.emergency_decel_mps2) {
            (true, Some(e)) => Some(e),
            _ => self.decel_max_mps2,
        };
        if let Some(d) = decel {
            u = u.max(-d);
        }
        u
    }
}

/// Identical, independent platoons on one road: platoon j drives on `lanes[j % lanes.len()]`,
/// `(j / lanes.len()) * gap_m` behind platoon 0, with channel seed `seed + j`. They share the
/// DoS schedule (one jammer, one channel) and nothing else.
#[derive(Debug, Clone, PartialEq)]
pub struct Fleet {
    /// Number of platoons, >= 1.
    pub platoons: usize,
    /// Lanes used in turn (for the SUMO plant).
    pub lanes: Vec<u32>,
    /// Distance between the leaders of consecutive platoons on one lane (m).
    pub gap_m: f64,
}

impl Fleet {
    /// One platoon.
    pub fn single(lane: u32) -> Self {
        Self {
            platoons: 1,
            lanes: vec![lane],
            gap_m: 0.0,
        }
    }

    /// The lane of platoon `j`.
    pub fn lane(&self, j: usize) -> u32 {
        self.lanes[j % self.lanes.len()]
    }

    /// How far platoon `j` starts behind platoon 0 (m).
    pub fn offset(&self, j: usize) -> f64 {
        (j / self.lanes.len()) as f64 * self.gap_m
    }
}

impl Scenario {
    /// The step length (s).
    pub fn dt(&self) -> f64 {
        self.control.dt
    }

    /// The desired spacing `l` (m): the standstill part with a time headway.
    pub fn spacing(&self) -> f64 {
        self.control.spacing
    }

    /// The time headway `h_t` of the spacing policy (s); 0 for constant spacing.
    pub fn headway(&self) -> f64 {
        self.control.headway
    }

    /// The spacing policy.
    pub fn spacing_policy(&self) -> platoon_control::SpacingPolicy {
        platoon_control::SpacingPolicy::from_headway(self.control.headway)
    }

    /// The end time `steps dt` (s).
    pub fn duration(&self) -> f64 {
        self.steps as f64 * self.dt()
    }

    /// What the channel (in process or in the injector process) needs.
    pub fn channel_spec(&self) -> ChannelSpec {
        ChannelSpec {
            dos: self.dos.clone(),
            attacks: self.link_attacks.clone(),
            seed: self.channel_seed,
            platoon: self.platoon,
            radio: self.radio.clone(),
            jammers: self.jammers.clone(),
            keys: self
                .control
                .security
                .map(|s| platoon_attacks::channel::ChannelKeys {
                    seed: s.seed,
                    platoon: s.platoon,
                }),
        }
    }

    /// The smallest and largest engine lag of any follower over the run, and the nominal one
    /// (s): the range a robust design must cover. With vehicle classes, every follower's
    /// class range too (their union's hull).
    pub fn tau_range(&self) -> (f64, f64) {
        let tau = self.control.tau_nominal;
        self.taus
            .iter()
            .map(|t| t.range())
            .chain(self.vehicles.iter().skip(1).map(|v| v.tau_range_s))
            .fold((tau, tau), |(a, b), (x, y)| (a.min(x), b.max(y)))
    }

    /// Each follower's own lag range (s, follower 1 first): its class's `tau_range_s` with
    /// vehicle classes, else the hull of its schedule and the nominal lag.
    pub fn member_tau_ranges(&self) -> Vec<(f64, f64)> {
        let tau = self.control.tau_nominal;
        self.taus
            .iter()
            .enumerate()
            .map(|(f, t)| match self.vehicles.get(f + 1) {
                Some(v) => v.tau_range_s,
                None => {
                    let (x, y) = t.range();
                    (tau.min(x), tau.max(y))
                }
            })
            .collect()
    }

    /// The length of vehicle `j` (0: the leader), m.
    pub fn length(&self, j: usize) -> f64 {
        self.vehicles
            .get(j)
            .map_or(self.vehicle_length, |v| v.length_m)
    }

    /// Every vehicle's length (m), leader first.
    pub fn lengths(&self) -> Vec<f64> {
        (0..self.vehicles_per_platoon())
            .map(|j| self.length(j))
            .collect()
    }

    /// The input the plant applies to follower `i` (>= 1) for command `u` (`guard`: the guard
    /// overrode it): `u` itself without vehicle classes, else held within its class's limits
    /// ([`Vehicle::limit`]).
    #[inline]
    pub fn applied(&self, i: usize, u: f64, guard: bool) -> f64 {
        self.vehicles.get(i).map_or(u, |v| v.limit(u, guard))
    }

    /// Vehicles per platoon, N + 1.
    pub fn vehicles_per_platoon(&self) -> usize {
        self.topology.followers() + 1
    }

    /// Vehicles in the whole fleet.
    pub fn vehicles(&self) -> usize {
        self.fleet.platoons * self.vehicles_per_platoon()
    }

    /// Whether a follower that runs its ACC on a car that cut in heads the followers behind it
    /// (`[fallback.cut_in] split`).
    pub fn splits(&self) -> bool {
        self.control.fallback.cut_in.is_some_and(|c| c.split)
    }

    /// Whether the run has two platoons for a while (`[maneuvers.merge]` until the merge,
    /// `[maneuvers.split]` from the split): the rear one's followers take its head as their
    /// leader.
    pub fn regroups(&self) -> bool {
        self.control
            .maneuvers
            .as_ref()
            .is_some_and(|m| m.merge.is_some() || m.split.is_some())
    }

    /// Whether vehicles change lanes during the run: members leave (`[[maneuvers.leaves]]`),
    /// a joiner comes from the lane beside (`[[maneuvers.joins]] behind`), or the leader may
    /// eject a member (revoked by the misbehaviour authority, `[security.reports]`, or named in
    /// a forged leave notice, `forge_maneuver`). The plant then
    /// keeps who is on the platoon's lane and the radars see the lane, not the platoon's order.
    pub fn changes_lanes(&self) -> bool {
        // A member the misbehaviour authority revokes is ejected and leaves the lane; so is
        // one in whose name a leave notice is forged.
        let ejects = self.control.security.is_some_and(|s| s.reports.is_some())
            || self.link_attacks.iter().any(|a| {
                a.kind
                    == platoon_attacks::channel::LinkAttackKind::ForgeManeuver {
                        message: platoon_maneuver::MessageKind::LeaveNotice,
                    }
            });
        self.control.maneuvers.as_ref().is_some_and(|m| {
            !m.leaves.is_empty() || m.joins.iter().any(|j| j.behind.is_some()) || ejects
        })
    }

    /// Whether follower `i` starts in the lane beside the platoon's (a joiner with `behind`).
    pub fn starts_beside(&self, i: usize) -> bool {
        self.control.maneuvers.as_ref().is_some_and(|m| {
            m.joins
                .iter()
                .any(|j| usize::from(j.vehicle.0) == i && j.behind.is_some())
        })
    }

    /// Who hears whom on the V2V channel: the topology's links and, when the platoon splits
    /// behind a car that cut in (`[fallback.cut_in] split`), every follower also hears every
    /// member ahead of it ([`Topology::hearing_all_ahead`]); with `[maneuvers]` every vehicle
    /// hears every other ([`Topology::hearing_everyone`]). The channel carries these links;
    /// the controllers' laws keep [`Scenario::topology`].
    pub fn hearing(&self) -> Topology {
        if self.control.maneuvers.is_some() {
            // Maneuvers: a joiner asks the leader, the leader answers and announces.
            self.topology.hearing_everyone()
        } else if self.splits() {
            self.topology.hearing_all_ahead()
        } else {
            self.topology.clone()
        }
    }

    /// Platoon `j` of the fleet: this scenario shifted `fleet.offset(j)` back, with its own
    /// channel seed, radar noise, pseudonyms (`[security]`) and index. Platoon 0 of a fleet is the scenario itself.
    pub fn replica(&self, j: usize) -> Scenario {
        let shift = self.fleet.offset(j);
        let mut s = self.clone();
        if shift != 0.0 {
            for x in &mut s.initial {
                x[0] -= shift;
            }
        }
        s.channel_seed = self.channel_seed.wrapping_add(j as u64);
        // Each platoon's radars draw their own noise.
        s.control.fallback.radar.seed = self.control.fallback.radar.seed.wrapping_add(j as u64);
        // Each platoon's vehicles sign with pseudonyms of their own, of the fleet's one PKI.
        if let Some(security) = s.control.security.as_mut() {
            security.platoon = j as u16;
        }
        s.platoon = j as u16;
        s
    }

    /// Every platoon of the fleet.
    pub fn replicas(&self) -> Vec<Scenario> {
        (0..self.fleet.platoons).map(|j| self.replica(j)).collect()
    }

    /// The attack intervals that fall within the run, `[0, steps dt]`.
    pub fn attacks_in_run(&self) -> Vec<platoon_attacks::Interval> {
        self.dos.clipped(self.duration()).intervals().to_vec()
    }

    /// Checks that the parts agree.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        self.control.validate()?;
        let n = self.topology.followers();
        let invalid = |key, message| Err(ScenarioError::Invalid { key, message });
        if self.initial.len() != n + 1 {
            return invalid(
                "platoon.initial_states",
                format!("the topology has {n} followers, so {} states (leader first) are needed, got {}", n + 1, self.initial.len()),
            );
        }
        if let Some(i) = self
            .initial
            .iter()
            .position(|x| x.iter().any(|v| !v.is_finite()))
        {
            return invalid("platoon.initial_states", format!("state {i} is not finite"));
        }
        if self.taus.len() != n {
            return invalid(
                "plant.tau",
                format!("need {n} tau schedules, got {}", self.taus.len()),
            );
        }
        if self.steps == 0 {
            return invalid(
                "simulation.duration_s",
                "the run needs at least one step".into(),
            );
        }
        if self.fleet.platoons == 0
            || self.fleet.lanes.is_empty()
            || self.fleet.platoons * (n + 1) > usize::from(u16::MAX)
        {
            return invalid(
                "fleet.platoons",
                format!(
                    "needs 1 to {} platoons and at least one lane",
                    usize::from(u16::MAX) / (n + 1)
                ),
            );
        }
        if !(self.vehicle_length.is_finite() && self.vehicle_length >= 0.0) {
            return invalid("platoon.vehicle_length_m", "must be finite and >= 0".into());
        }
        if !self.vehicles.is_empty() && self.vehicles.len() != n + 1 {
            return invalid(
                "platoon.members",
                format!(
                    "{} members for {} vehicles (the leader first)",
                    self.vehicles.len(),
                    n + 1
                ),
            );
        }
        for v in &self.vehicles {
            let positive = |x: Option<f64>| x.is_none_or(|x| x.is_finite() && x > 0.0);
            let (lo, hi) = v.tau_range_s;
            let fine = v.length_m.is_finite()
                && v.length_m >= 0.0
                && positive(v.accel_max_mps2)
                && positive(v.decel_max_mps2)
                && lo.is_finite()
                && lo > 0.0
                && hi.is_finite()
                && hi >= lo;
            if !fine {
                return invalid(
                    "vehicle_classes",
                    format!(
                        "class {:?}: a length >= 0, limits > 0, 0 < lo <= hi",
                        v.class
                    ),
                );
            }
        }
        Ok(())
    }
}
