//! The maneuver step of the pipeline: the protocol's machines ([`crate::maneuvers`]) with
//! what they keep per vehicle besides: what the leader last heard of each vehicle (for its
//! check of requests and in-position reports, `[maneuvers] check_reports`) and each
//! follower's judgement of its slot.
use super::follower::Follower;
use super::Composition;
use crate::checks::PacketChecks;
use crate::fallback::{gap_error, Reading};
use crate::maneuvers::Maneuvers;
use crate::room::v2v_reading;
use crate::Delivery;
use platoon_maneuver::{Body, JoinerPhase, Message};
use platoon_model::State;

#[derive(Debug, Clone)]
pub(super) struct ManeuverStage {
    pub(super) machines: Maneuvers,
    /// Each follower's judgement of its slot this step (joiners only), or of the gap it opens.
    in_position: Vec<bool>,
    /// The last state the leader heard from each vehicle (step, state).
    leader_heard: Vec<Option<(u64, State)>>,
    /// This step's deliveries whose message went to a machine, in order: (receiver, the
    /// delivery's place in the step's rx), to name those the machines dropped as old.
    carried: Vec<(platoon_model::VehicleId, usize)>,
}

impl ManeuverStage {
    pub(super) fn new(params: &crate::ManeuverParams, followers: usize) -> Self {
        Self {
            machines: Maneuvers::new(params, followers),
            in_position: vec![false; followers],
            leader_heard: vec![None; followers + 1],
            carried: Vec::new(),
        }
    }

    /// Gives receiver `d.receiver` the message `m` of the step's delivery `j`.
    pub(super) fn hand_over(&mut self, j: usize, d: &Delivery, m: Message) {
        self.machines.heard(d.receiver, m);
        self.carried.push((d.receiver, j));
    }

    /// After [`ManeuverStage::step`]: the places in the step's rx of the deliveries whose
    /// message a machine dropped as old (its sequence filter).
    pub(super) fn dropped_as_old(&self) -> impl Iterator<Item = usize> + '_ {
        self.machines.dropped_as_old().iter().filter_map(|&(r, i)| {
            self.carried
                .iter()
                .filter(|(to, _)| *to == r)
                .nth(i)
                .map(|&(_, j)| j)
        })
    }

    /// Starts a step's deliveries.
    pub(super) fn begin_step(&mut self) {
        self.carried.clear();
    }

    /// A delivery to the leader at step `k`: only maneuver messages reach it; with
    /// `check_reports` it drops a request from a vehicle it never heard beaconing and an
    /// in-position report that the joiner's beacon contradicts (counted among `checks`'
    /// refusals and noted as inspections), and hands the rest to its machine.
    pub(super) fn leader_receives(
        &mut self,
        (k, j): (u64, usize),
        d: &Delivery,
        states: &[State],
        checks: &mut PacketChecks,
        parts: &Composition,
    ) {
        let man = &mut self.machines;
        let checking = man.checks_messages();
        let sender = d.packet.sender.index();
        // Whether the leader had heard the sender beacon before this packet.
        let known = self.leader_heard.get(sender).is_some_and(Option::is_some);
        if checking {
            let last = self.leader_heard.get_mut(sender);
            if let Some(last) = last.filter(|l| l.is_none_or(|(s, _)| s < d.packet.step)) {
                *last = Some((d.packet.step, d.packet.state));
            }
        }
        let Some(m) = d.packet.maneuver else { return };
        let request = matches!(m.body, Body::JoinRequest { .. } | Body::MergeRequest { .. });
        // A request to join (or to merge) from a vehicle the leader never heard beaconing: a
        // vehicle that is not there.
        let ghost = checking && !known && request;
        let error = self.report_error(k, d, &m, states, parts);
        let implausible = !ghost && error.is_some_and(|e| !self.machines.plausible_report(e));
        // What the checks tested: every request, a report from the slot's joiner.
        if checking && (error.is_some() || request) {
            checks.note_leader_check(k, d, ghost || implausible);
        }
        if ghost {
            checks.refuse_unknown_sender();
        } else if implausible {
            checks.refuse_implausible_state();
        } else {
            self.hand_over(j, d, m);
        }
    }

    /// A report that the slot's joiner is in position, checked against its own beacon and the
    /// last beacon of the member it follows, both brought to step `k`: the slot's gap error
    /// (none for any other message).
    fn report_error(
        &self,
        k: u64,
        d: &Delivery,
        m: &Message,
        states: &[State],
        parts: &Composition,
    ) -> Option<f64> {
        let (joiner, behind) = self.machines.checked_slot()?;
        if m.sender != joiner || m.body != Body::InPosition {
            return None;
        }
        let at = |(s, x): (u64, State)| x[0] + x[1] * (k.saturating_sub(s)) as f64 * parts.dt;
        // The leader knows its own state.
        let ahead = match behind.is_leader() {
            true => Some((k, states[0])),
            false => self.leader_heard[behind.index()],
        }?;
        let own = (d.packet.step, d.packet.state);
        let length = parts.fallback.length(behind.index());
        let gap = at(ahead) - at(own) - length;
        let seen = Reading {
            gap,
            closing: 0.0,
            intruder: false,
        };
        Some(gap_error(
            seen,
            parts.headway,
            own.1[1],
            parts.spacing,
            length,
        ))
    }

    /// Step `k`'s judgements (a joiner's that it is in its slot, a member's that the gap it
    /// opens is open), then every machine's step on them.
    pub(super) fn step(
        &mut self,
        k: u64,
        states: &[State],
        followers: &[Follower],
        readings: &[Option<(Reading, u64)>],
        checks: &PacketChecks,
        parts: &Composition,
    ) {
        let man = &self.machines;
        let (dt, spacing, headway) = (parts.dt, parts.spacing, parts.headway);
        let fb = &parts.fallback;
        for ((f, ready), reading) in followers.iter().zip(&mut self.in_position).zip(readings) {
            let own = states[f.id.index()];
            let reading = reading.map(|(r, _)| r);
            let behind = man.predecessor(f.id).unwrap_or(f.targets.ahead);
            let length = fb.length(behind.index());
            *ready = if man.opening_for(f.id).is_some() {
                // The gap it opens is open: its offset arrived at the room it opens, and its
                // radar's gap has caught up with it.
                f.targets.offset.is_some_and(|o| o.done(k) && o.to > 0.0)
                    && man.in_position(
                        reading.map(|r| Reading {
                            gap: r.gap - f.targets.offset_m,
                            ..r
                        }),
                        own[1],
                        spacing,
                        headway,
                        fb.length(f.targets.ahead.index()),
                    )
            } else if man.phase(f.id) == JoinerPhase::Member {
                // Not asked to open a gap (yet): nothing is open.
                false
            } else {
                // A joiner beside the platoon judges its slot from V2V.
                let seen = match man.beside(f.id) {
                    true => v2v_reading(checks, f.id, behind, k, dt, &own, length),
                    false => reading,
                };
                man.in_position(seen, own[1], spacing, headway, length)
            };
        }
        self.machines.step(k, &self.in_position);
    }
}
