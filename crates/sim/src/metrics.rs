//! The accumulators of a run's metrics, fed step by step (constant memory): one platoon's
//! ([`MetricsAccumulator`]) and a fleet's ([`FleetMetrics`]); they finish into a [`Summary`].
use crate::summary::*;
use crate::{Scenario, StepRow};
use platoon_attacks::{Assumption2, DosSchedule};
use platoon_control::RejectCounts;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Copy, Default)]
struct ErrorAcc {
    sum_abs: f64,
    sum_sq: f64,
    max_abs: f64,
    last: f64,
    n: u64,
}

impl ErrorAcc {
    fn push(&mut self, e: f64) {
        self.sum_abs += e.abs();
        self.sum_sq += e * e;
        self.max_abs = self.max_abs.max(e.abs());
        self.last = e;
        self.n += 1;
    }
    fn finish(&self) -> ErrorStats {
        let n = self.n.max(1) as f64;
        ErrorStats {
            mean_abs: self.sum_abs / n,
            max_abs: self.max_abs,
            rms: (self.sum_sq / n).sqrt(),
            final_abs: self.last.abs(),
        }
    }
}

#[derive(Debug, Clone)]
struct VehicleAcc {
    triggers: u64,
    last_trigger: Option<u64>,
    min_gap: Option<u64>,
    first_trigger: Option<u64>,
    spacing: ErrorAcc,
    gap: ErrorAcc,
    velocity: ErrorAcc,
    affected_steps: u64,
    min_accel: f64,
    mode_steps: [u64; platoon_control::Status::ALL.len()],
    mode: platoon_control::Status,
    switches: u64,
    guard_on: bool,
    guard_activations: u64,
    guard_steps: u64,
    saturated_steps: u64,
}

/// One link's outage: the step it began if it is out, and its past outages `(first, steps)`.
type LinkRuns = (Option<u64>, Vec<(u64, u64)>);

/// Accumulates a run's metrics step by step (constant memory), so long runs need not keep rows.
#[derive(Debug, Clone)]
pub struct MetricsAccumulator {
    dt: f64,
    law: &'static str,
    rule: &'static str,
    check_period: f64,
    spacing_policy: &'static str,
    spacing: f64,
    headway: f64,
    /// Every vehicle's length, leader first.
    lengths: Vec<f64>,
    /// The members have vehicle classes, whose limits the plant holds (saturation counts).
    limited: bool,
    dos: DosSchedule,
    assumption2: Option<Assumption2>,
    vehicles: Vec<VehicleAcc>,
    steps: u64,
    expected_steps: u64,
    attacked_steps: u64,
    /// Whether to measure the observed jamming (range jammers present), and its runs of
    /// jammed steps `(first, steps)`.
    observe: bool,
    /// Vehicles change lanes ([`Scenario::changes_lanes`]): the vehicle ahead on the lane is
    /// found by position.
    lanes: bool,
    /// Scratch: with `lanes`, each row's vehicle ahead on its lane (index into the rows;
    /// `None`: nobody ahead on that lane).
    fronts: Vec<Option<usize>>,
    observed: Vec<(u64, u64)>,
    /// With jammers as transmitters: per link (sender, receiver), the step its outage began if
    /// it is out, and its outages `(first step, steps)`.
    links: Option<BTreeMap<(u16, u16), LinkRuns>>,
    last_step: u64,
    last_t: f64,
    safety: Safety,
    /// The maneuvers (`[maneuvers]` only).
    maneuvers: Option<crate::maneuver_tally::ManeuverTally>,
    /// Scratch: each follower's gap to the vehicle ahead on its lane at this step (NaN beside
    /// the lane), for the maneuvers.
    gaps: Vec<f64>,
    /// Each scripted cut-in as the radars saw it on the platoon's lane.
    cut_ins: Vec<CutInRecord>,
}

impl MetricsAccumulator {
    /// An empty accumulator for `scenario`.
    pub fn new(scenario: &Scenario) -> Self {
        let n = scenario.topology.followers();
        Self {
            dt: scenario.dt(),
            law: scenario.control.law.name(),
            rule: scenario.control.rule.name(),
            check_period: f64::from(scenario.control.check_steps) * scenario.dt(),
            spacing_policy: scenario.spacing_policy().name(),
            spacing: scenario.spacing(),
            headway: scenario.headway(),
            lengths: scenario.lengths(),
            limited: !scenario.vehicles.is_empty(),
            dos: scenario.dos.clone(),
            assumption2: scenario.assumption2,
            vehicles: vec![
                VehicleAcc {
                    triggers: 0,
                    last_trigger: None,
                    min_gap: None,
                    first_trigger: None,
                    spacing: ErrorAcc::default(),
                    gap: ErrorAcc::default(),
                    velocity: ErrorAcc::default(),
                    affected_steps: 0,
                    min_accel: f64::INFINITY,
                    mode_steps: [0; platoon_control::Status::ALL.len()],
                    mode: platoon_control::Status::member(platoon_control::Mode::Coop),
                    switches: 0,
                    guard_on: false,
                    guard_activations: 0,
                    guard_steps: 0,
                    saturated_steps: 0,
                };
                n
            ],
            steps: 0,
            expected_steps: scenario.steps + 1,
            attacked_steps: 0,
            observe: !scenario.jammers.is_empty()
                || scenario.link_attacks.iter().any(|a| {
                    matches!(
                        a.kind,
                        platoon_attacks::channel::LinkAttackKind::RangeJamming { .. }
                    )
                }),
            observed: Vec::new(),
            lanes: scenario.changes_lanes(),
            fronts: Vec::new(),
            links: (!scenario.jammers.is_empty()).then(BTreeMap::new),
            last_step: 0,
            last_t: 0.0,
            safety: Safety {
                max_deceleration_mps2: 0.0,
                class: SafetyClass::None,
                thresholds: scenario.safety,
                collided: false,
                min_gap_m: f64::INFINITY,
                min_gap_vehicle: 0,
                min_gap_t_s: 0.0,
                min_ttc_s: None,
                first_collision_t_s: None,
                first_collision: None,
            },
            maneuvers: crate::maneuver_tally::ManeuverTally::new(scenario),
            gaps: Vec::new(),
            cut_ins: (scenario.cut_ins.iter().enumerate())
                .map(|(c, x)| CutInRecord {
                    cut_in: c as u16,
                    asked_t_s: x.at_s,
                    entered_t_s: None,
                    ahead_of: None,
                    waited_s: None,
                    last_seen_t_s: None,
                })
                .collect(),
        }
    }

    /// The cut-ins a member's radar has ahead on the platoon's lane at this step.
    fn see_cut_ins(&mut self, rows: &[StepRow]) {
        for r in rows.iter().filter(|r| r.beside != Some(true)) {
            let Some(crate::traffic::RadarTarget::CutIn(c)) = r.radar_target else {
                continue;
            };
            let Some(x) = self.cut_ins.get_mut(usize::from(c)) else {
                continue;
            };
            if x.entered_t_s.is_none() {
                x.entered_t_s = Some(r.t);
                x.ahead_of = Some(r.vehicle);
                x.waited_s = Some((r.t - x.asked_t_s).max(0.0));
            }
            x.last_seen_t_s = Some(r.t);
        }
    }

    /// A maneuver message broadcast at the step whose rows come next.
    pub fn push_broadcast(&mut self, m: platoon_control::maneuvers::Message) {
        if let Some(t) = &mut self.maneuvers {
            t.broadcast(m);
        }
    }

    /// Adds one step's rows (leader first, then followers in order).
    pub fn push(&mut self, rows: &[StepRow]) {
        let Some(leader) = rows.first() else { return };
        if !self.cut_ins.is_empty() {
            self.see_cut_ins(rows);
        }
        self.steps += 1;
        self.last_t = leader.t;
        self.last_step = leader.step;
        self.attacked_steps += u64::from(leader.under_attack);
        if self.observe && rows.iter().any(|r| r.under_attack) {
            match self.observed.last_mut() {
                Some((first, n)) if *first + *n == leader.step => *n += 1,
                _ => self.observed.push((leader.step, 1)),
            }
        }
        // The vehicle ahead on the lane: where vehicles change lanes, the nearest on the same
        // lane as the plant has it, in the road's order (a joiner moves in between members, a
        // leaver follows those that left before it).
        self.fronts.clear();
        if self.lanes {
            let mut order: Vec<usize> = (0..rows.len()).collect();
            order.sort_by(|&a, &b| rows[b].p.total_cmp(&rows[a].p));
            self.fronts.resize(rows.len(), None);
            // Each row's front: the last one seen ahead of it on its lane.
            let mut last = [None, None];
            for &i in &order {
                let lane = &mut last[usize::from(rows[i].beside == Some(true))];
                self.fronts[i] = *lane;
                *lane = Some(i);
            }
        }
        self.gaps.clear();
        self.gaps.resize(rows.len() - 1, f64::NAN);
        let mut front = Some(leader);
        for (i, r) in rows.iter().enumerate().skip(1) {
            if self.lanes {
                front = self.fronts[i].map(|f| &rows[f]);
            }
            let acc = &mut self.vehicles[r.vehicle as usize - 1];
            if r.triggered {
                acc.triggers += 1;
                // In whole steps, so inter-event times carry no rounding of t.
                if let Some(last) = acc.last_trigger {
                    let gap = r.step - last;
                    acc.min_gap = Some(acc.min_gap.map_or(gap, |m| m.min(gap)));
                } else {
                    acc.first_trigger = Some(r.step);
                }
                acc.last_trigger = Some(r.step);
            }
            // A joiner's errors count from the step it is admitted: outside, it has no slot;
            // a leaver's end with its leave.
            let left = r.mode.is_beside_the_lane();
            if let Some(front) = front.filter(|_| r.mode != platoon_control::Role::Outside && !left)
            {
                acc.spacing.push(r.spacing_error);
                acc.gap
                    .push(front.p - r.p - (self.spacing + self.headway * r.v));
                acc.velocity.push(r.velocity_error);
            }
            acc.affected_steps += u64::from(r.affected);
            acc.min_accel = acc.min_accel.min(r.a);
            acc.mode_steps[r.mode.code() as usize] += 1;
            acc.switches += u64::from(r.mode != acc.mode);
            acc.mode = r.mode;
            acc.guard_activations += u64::from(r.guard && !acc.guard_on);
            acc.guard_on = r.guard;
            acc.guard_steps += u64::from(r.guard);
            acc.saturated_steps += u64::from(r.saturated);
            // The nearest vehicle ahead on its lane: the predecessor, or one that cut in
            // between (on the platoon's lane).
            let behind = front.map(|f| (f.p - r.p - self.lengths[usize::from(f.vehicle)], f));
            let (gap, closing, cut_in, ahead) = match (r.intruder, behind) {
                (Some(t), b) if b.is_none_or(|(g, _)| t.gap < g) => (t.gap, t.closing, true, None),
                (_, Some((g, f))) => (g, r.v - f.v, false, Some(f)),
                _ => continue,
            };
            let beside = r.beside == Some(true);
            if closing > 0.0 {
                let ttc = gap.max(0.0) / closing;
                if self.safety.min_ttc_s.is_none_or(|m| ttc < m) {
                    self.safety.min_ttc_s = Some(ttc);
                }
            }
            if gap <= 0.0 && self.safety.first_collision_t_s.is_none() {
                self.safety.first_collision_t_s = Some(r.t);
                self.safety.first_collision = Some(crate::summary::Collision {
                    t_s: r.t,
                    collider: format!("follower {}", r.vehicle),
                    victim: match (cut_in, ahead.map(|f| f.vehicle)) {
                        (true, _) | (false, None) => "a car that cut in".to_string(),
                        (false, Some(0)) => "the leader".to_string(),
                        (false, Some(v)) => format!("follower {v}"),
                    },
                    lane: match beside {
                        true => "the lane beside the platoon's",
                        false => "the platoon's lane",
                    }
                    .to_string(),
                    gap_m: Some(gap),
                });
            }
            if !beside {
                self.gaps[i - 1] = gap;
            }
            if gap < self.safety.min_gap_m {
                self.safety.min_gap_m = gap;
                self.safety.min_gap_vehicle = r.vehicle;
                self.safety.min_gap_t_s = r.t;
            }
            front = Some(r);
        }
        if let Some(t) = &mut self.maneuvers {
            t.push(rows, &self.gaps);
        }
    }

    /// Adds one step of this platoon's channel log (with jammers as transmitters, the links'
    /// outages; otherwise nothing).
    pub fn push_channel(&mut self, events: &[platoon_attacks::channel::ChannelEvent]) {
        use platoon_attacks::channel::Action;
        let Some(links) = &mut self.links else { return };
        for e in events {
            match e.action {
                Action::DroppedJammed | Action::DroppedInterference => {
                    let (open, _) = links.entry((e.sender, e.receiver)).or_default();
                    open.get_or_insert(e.step);
                }
                Action::Restored => {
                    if let Some((open, done)) = links.get_mut(&(e.sender, e.receiver)) {
                        if let Some(first) = open.take() {
                            done.push((first, e.step - first));
                        }
                    }
                }
                _ => {}
            }
        }
    }

    fn link_outages(&self, horizon: f64) -> Vec<LinkOutage> {
        let Some(links) = &self.links else {
            return Vec::new();
        };
        links
            .iter()
            .map(|(&(sender, receiver), (open, done))| {
                let mut runs: Vec<(f64, f64)> = done
                    .iter()
                    .chain(open.map(|f| (f, self.last_step + 1 - f)).as_ref())
                    .filter(|(_, n)| *n > 0)
                    .map(|&(f, n)| (f as f64 * self.dt, n as f64 * self.dt))
                    .collect();
                runs.sort_by(|a, b| a.0.total_cmp(&b.0));
                let dos = DosSchedule::from_intervals(&runs).ok();
                LinkOutage {
                    sender,
                    receiver,
                    intervals: runs.len(),
                    jammed_time_s: runs.iter().map(|r| r.1).sum(),
                    longest_s: runs.iter().map(|r| r.1).fold(0.0, f64::max),
                    assumption2: self.assumption2.zip(dos).map(|(b, d)| b.check(&d, horizon)),
                }
            })
            .collect()
    }

    fn max_decel(&self) -> f64 {
        self.vehicles
            .iter()
            .map(|a| -a.min_accel)
            .fold(0.0, f64::max)
    }

    /// The summary; `complete` is true when every step `0..=steps` ran.
    pub fn finish(&self, rejected: RejectCounts) -> Summary {
        let horizon = self.last_t + self.dt;
        let vehicles: Vec<VehicleSummary> = self
            .vehicles
            .iter()
            .enumerate()
            .map(|(i, a)| VehicleSummary {
                vehicle: i as u16 + 1,
                triggers: a.triggers,
                min_inter_event_s: a.min_gap.map(|g| g as f64 * self.dt),
                mean_inter_event_s: match (a.first_trigger, a.last_trigger) {
                    (Some(f), Some(l)) if a.triggers > 1 => {
                        Some((l - f) as f64 * self.dt / (a.triggers - 1) as f64)
                    }
                    _ => None,
                },
                spacing_error_m: a.spacing.finish(),
                gap_error_m: a.gap.finish(),
                velocity_error_mps: a.velocity.finish(),
                affected_time_s: a.affected_steps as f64 * self.dt,
                min_acceleration_mps2: a.min_accel,
                mode_time_s: platoon_control::Status::ALL
                    .iter()
                    .zip(a.mode_steps)
                    .filter(|(_, n)| *n > 0)
                    .map(|(m, n)| (m.name().to_string(), n as f64 * self.dt))
                    .collect(),
                mode_switches: a.switches,
                guard_activations: a.guard_activations,
                guard_time_s: a.guard_steps as f64 * self.dt,
                saturated_time_s: self.limited.then_some(a.saturated_steps as f64 * self.dt),
            })
            .collect();
        let clipped = self.dos.clipped(horizon);
        Summary {
            complete: self.steps == self.expected_steps,
            error: None,
            fleet: None,
            steps: self.steps,
            dt_s: self.dt,
            duration_s: self.last_t,
            law: self.law.to_string(),
            rule: self.rule.to_string(),
            check_period_s: self.check_period,
            spacing_policy: self.spacing_policy.into(),
            time_headway_s: self.headway,
            triggers: vehicles
                .iter()
                .map(|v| (v.vehicle.to_string(), v.triggers))
                .collect(),
            triggers_total: vehicles.iter().map(|v| v.triggers).sum(),
            min_inter_event_s: vehicles
                .iter()
                .filter_map(|v| v.min_inter_event_s)
                .reduce(f64::min),
            attack: AttackSummary {
                applied: true,
                intervals: clipped.intervals().len(),
                attacked_time_s: clipped.active_time(0.0, horizon),
                attacked_steps: self.attacked_steps,
                assumption2_bounds: self.assumption2,
                assumption2: self.assumption2.map(|b| b.check(&self.dos, horizon)),
                observed: self.observe.then(|| {
                    let schedule: Vec<[f64; 2]> = self
                        .observed
                        .iter()
                        .map(|&(first, n)| [first as f64 * self.dt, n as f64 * self.dt])
                        .collect();
                    let pairs: Vec<(f64, f64)> = schedule.iter().map(|w| (w[0], w[1])).collect();
                    let dos = DosSchedule::from_intervals(&pairs).ok();
                    ObservedJamming {
                        intervals: schedule.len(),
                        jammed_time_s: self.observed.iter().map(|&(_, n)| n).sum::<u64>() as f64
                            * self.dt,
                        assumption2: self.assumption2.zip(dos).map(|(b, d)| b.check(&d, horizon)),
                        schedule,
                        links: self.link_outages(horizon),
                    }
                }),
            },
            safety: Safety {
                collided: self.safety.min_gap_m <= 0.0,
                max_deceleration_mps2: self.max_decel(),
                class: self
                    .safety
                    .thresholds
                    .class(self.max_decel(), self.safety.min_gap_m <= 0.0),
                ..self.safety.clone()
            },
            rejected_packets: rejected,
            wire: None,
            channel: None,
            detection: None,
            maneuvers: self.maneuvers.as_ref().map(|t| t.finish()),
            cut_ins: self.cut_ins.clone(),
            security: None,
            vehicles,
        }
    }
}

/// Metrics of every platoon of a fleet, from rows that come platoon by platoon.
#[derive(Debug, Clone)]
pub struct FleetMetrics {
    per: Vec<MetricsAccumulator>,
    vehicles_per_platoon: usize,
    wire: Vec<crate::WireCounts>,
    wire_outside: crate::WireCounts,
    wire_steps: u64,
    revoked: Vec<crate::summary::RevokedRecord>,
}

impl FleetMetrics {
    /// Empty accumulators for every platoon of `scenario`'s fleet.
    pub fn new(scenario: &Scenario) -> Self {
        Self {
            per: scenario
                .replicas()
                .iter()
                .map(MetricsAccumulator::new)
                .collect(),
            vehicles_per_platoon: scenario.vehicles_per_platoon(),
            wire: vec![crate::WireCounts::default(); scenario.vehicles()],
            wire_outside: crate::WireCounts::default(),
            wire_steps: 0,
            revoked: Vec::new(),
        }
    }

    /// The vehicles revoked so far (`[security.reports]`), in the order their rows first said
    /// so.
    pub fn revoked(&self) -> &[crate::summary::RevokedRecord] {
        &self.revoked
    }

    /// Adds one step of what happened on the wire.
    pub fn push_wire(&mut self, step: crate::StepWire<'_>) {
        for (acc, c) in self.wire.iter_mut().zip(step.per_vehicle) {
            acc.add(c);
        }
        for &(j, m) in step.maneuvers {
            if let Some(acc) = self.per.get_mut(usize::from(j)) {
                acc.push_broadcast(m);
            }
        }
        self.wire_outside.add(&step.outside);
        self.wire_steps += 1;
    }

    /// Adds one step of the channels' log (every platoon's; each row names its platoon).
    pub fn push_channel(&mut self, events: &[platoon_attacks::channel::ChannelEvent]) {
        for (j, acc) in self.per.iter_mut().enumerate() {
            let start = events.partition_point(|e| usize::from(e.platoon) < j);
            let end = events.partition_point(|e| usize::from(e.platoon) <= j);
            acc.push_channel(&events[start..end]);
        }
    }

    /// Adds one step's rows (every platoon's, platoon by platoon).
    pub fn push(&mut self, rows: &[StepRow]) {
        for r in rows.iter().filter(|r| r.revoked) {
            let known = |x: &crate::summary::RevokedRecord| {
                (x.platoon, x.vehicle) == (r.platoon, r.vehicle)
            };
            if !self.revoked.iter().any(known) {
                self.revoked.push(crate::summary::RevokedRecord {
                    platoon: r.platoon,
                    vehicle: r.vehicle,
                    step: r.step,
                    signed_a_lie: None,
                });
            }
        }
        for (acc, chunk) in self
            .per
            .iter_mut()
            .zip(rows.chunks(self.vehicles_per_platoon))
        {
            acc.push(chunk);
        }
    }

    /// The summary: platoon 0 in detail and, for a fleet, every platoon in brief.
    pub fn finish(&self, rejected: RejectCounts) -> Summary {
        let mut summary = self.per[0].finish(rejected);
        if self.wire_steps > 0 {
            let mut totals = self.wire_outside;
            for c in &self.wire {
                totals.add(c);
            }
            summary.wire = Some(WireSummary {
                totals,
                to_no_vehicle: self.wire_outside,
                per_vehicle: self.wire[..self.vehicles_per_platoon]
                    .iter()
                    .enumerate()
                    .map(|(i, c)| VehicleWire {
                        vehicle: i as u16,
                        counts: *c,
                    })
                    .collect(),
            });
        }
        if self.per.len() > 1 {
            let all: Vec<Summary> = self
                .per
                .iter()
                .map(|a| a.finish(RejectCounts::default()))
                .collect();
            let per_platoon: Vec<PlatoonBrief> = all
                .iter()
                .enumerate()
                .map(|(j, s)| PlatoonBrief {
                    platoon: j as u16,
                    triggers_total: s.triggers_total,
                    max_spacing_error_m: s.max_spacing_error_m(),
                    min_gap_m: s.safety.min_gap_m,
                    class: s.safety.class,
                })
                .collect();
            summary.fleet = Some(FleetOverview {
                platoons: all.len(),
                vehicles: all.len() * self.vehicles_per_platoon,
                triggers_total: all.iter().map(|s| s.triggers_total).sum(),
                collided: all.iter().any(|s| s.safety.collided),
                min_gap_m: all
                    .iter()
                    .map(|s| s.safety.min_gap_m)
                    .fold(f64::INFINITY, f64::min),
                max_deceleration_mps2: all
                    .iter()
                    .map(|s| s.safety.max_deceleration_mps2)
                    .fold(0.0, f64::max),
                class: all
                    .iter()
                    .map(|s| s.safety.class)
                    .max()
                    .unwrap_or(SafetyClass::None),
                first_collision_t_s: all
                    .iter()
                    .filter_map(|s| s.safety.first_collision_t_s)
                    .reduce(f64::min),
                per_platoon,
            });
        }
        summary
    }
}
