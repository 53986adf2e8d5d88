//! Maneuvers in the controllers (`[maneuvers]`): the protocol of `platoon-maneuver` run for
//! one platoon's vehicles, its messages on their packets (one a packet: a vehicle with a
//! message to send broadcasts at that step), and how a joiner drives until it is admitted.
//!
//! A join is at the tail: the joiner is a follower of the scenario that starts outside the
//! formation, behind the vehicle ahead of it. Until the leader accepts it, it keeps the ACC's
//! headway on its radar; once accepted, the ACC closes to the platoon's spacing (its headway
//! shrinking to the platoon's over the ACC's `opening_s`); in position
//! (its gap within `in_position_m` of the platoon's, closing slower than `in_position_mps`) it
//! says so, and on the leader's update it takes the law, blended from its ACC command as on the
//! way back from a fallback. Members keep their copies of the formation from the leader's
//! updates.
use platoon_maneuver::{Formation, Joiner, JoinerPhase, JoinerState, Leader, Member};
pub use platoon_maneuver::{Message, Timing};
use platoon_model::VehicleId;
use std::collections::VecDeque;

/// A join: follower `vehicle` asks at step `at_step` for the slot behind the vehicle ahead of
/// it (at the tail, from the lane behind the platoon), or behind member `behind` (from the
/// lane beside the platoon's: in the middle, or at the tail).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoinSpec {
    /// The joiner.
    pub vehicle: VehicleId,
    /// When it asks.
    pub at_step: u64,
    /// The member whose slot behind it joins, from the lane beside; `None`: at the tail,
    /// from behind the platoon in its lane.
    pub behind: Option<VehicleId>,
}

/// A leave: member `vehicle` tells the leader at step `at_step` that it leaves; on the
/// leader's update it leaves the lane, and the member behind it closes up to the one ahead.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeaveSpec {
    /// The leaver.
    pub vehicle: VehicleId,
    /// When it tells the leader.
    pub at_step: u64,
}

/// A merge: the vehicles from follower `head` on start as a platoon of their own, headed by
/// `head` on its ACC behind the platoon's tail; at step `at_step` the head asks the leader to
/// merge its platoon behind the tail, and on the leader's update both are one platoon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MergeSpec {
    /// The rear platoon's head; its tail is the run's last vehicle.
    pub head: VehicleId,
    /// When it asks.
    pub at_step: u64,
}

/// A split: member `head` tells the leader at step `at_step` that it heads the members behind
/// it off as a platoon of their own; on the leader's update it drives on its ACC behind the
/// members ahead (its headway opening from the platoon's to the ACC's over the ACC's
/// `opening_s`), and the members behind it take it as their leader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitSpec {
    /// The member that heads the part behind.
    pub head: VehicleId,
    /// When it tells the leader.
    pub at_step: u64,
}

/// A platoon's maneuvers and how its vehicles judge them.
#[derive(Debug, Clone, PartialEq)]
pub struct ManeuverParams {
    /// The protocol's timing.
    pub timing: Timing,
    /// The joins, each at the tail.
    pub joins: Vec<JoinSpec>,
    /// The leaves, of members the run starts with.
    pub leaves: Vec<LeaveSpec>,
    /// A merge of a second platoon behind this one (at most one, with no joins or leaves).
    pub merge: Option<MergeSpec>,
    /// A split of this platoon (at most one, with no joins, leaves or merge).
    pub split: Option<SplitSpec>,
    /// A joiner is in position when its gap is within this of the platoon's (m)...
    pub in_position_m: f64,
    /// ...and it closes on the vehicle ahead at most this fast (m/s).
    pub in_position_mps: f64,
    /// Members a platoon may have, the leader counted.
    pub max_members: usize,
    /// The leader drops an in-position report whose sender's beacon puts it farther than
    /// [`REPORT_TOLERANCE`] x `in_position_m` from its slot, and a join or merge request from
    /// a vehicle it never heard beaconing before.
    pub check_reports: bool,
}

/// How far from its slot, in `in_position_m`, a vehicle's beacon may put it and its
/// in-position report still be taken (`check_reports`): room for the beacons' age and noise
/// beside the joiner's own radar judgement.
pub const REPORT_TOLERANCE: f64 = 3.0;

impl ManeuverParams {
    /// Checks the joins against a platoon of `followers` followers; the key and the reason
    /// when wrong.
    pub fn validate(&self, followers: usize) -> Result<(), (&'static str, String)> {
        let mut joiners: Vec<u16> = self.joins.iter().map(|j| j.vehicle.0).collect();
        joiners.sort_unstable();
        if let Some(w) = joiners.windows(2).find(|w| w[0] == w[1]) {
            return Err(("joins", format!("vehicle {} joins twice", w[0])));
        }
        // The joiners are the last vehicles: a join is at the tail.
        let first = followers + 1 - joiners.len();
        for (i, &v) in joiners.iter().enumerate() {
            if usize::from(v) != first + i {
                return Err((
                    "joins",
                    format!(
                        "vehicle {v} cannot join: joins are at the tail, so the joiners are \
                         the platoon's last vehicles ({first} to {followers} for {} joins)",
                        joiners.len()
                    ),
                ));
            }
        }
        if first < 2 {
            return Err((
                "joins",
                "the platoon needs a follower besides the joiners".into(),
            ));
        }
        let mut leavers: Vec<u16> = self.leaves.iter().map(|l| l.vehicle.0).collect();
        leavers.sort_unstable();
        if let Some(w) = leavers.windows(2).find(|w| w[0] == w[1]) {
            return Err(("leaves", format!("vehicle {} leaves twice", w[0])));
        }
        for &v in &leavers {
            if v == 0 || usize::from(v) >= first {
                return Err((
                    "leaves",
                    format!(
                        "vehicle {v} cannot leave: the leavers are followers the run starts \
                         with (1 to {}; the leader heads the platoon to the end)",
                        first - 1
                    ),
                ));
            }
        }
        for j in &self.joins {
            if let Some(b) = j.behind {
                if usize::from(b.0) >= first || leavers.contains(&b.0) {
                    return Err((
                        "joins",
                        format!(
                            "vehicle {} cannot join behind vehicle {}: the slot is behind a \
                             member that stays (the leader or followers 1 to {}, none that \
                             leaves)",
                            j.vehicle.0,
                            b.0,
                            first - 1
                        ),
                    ));
                }
            }
        }
        if !joiners.is_empty() && leavers.contains(&(first as u16 - 1)) {
            return Err((
                "leaves",
                format!(
                    "vehicle {} cannot leave: the first joiner asks for the slot behind it",
                    first - 1
                ),
            ));
        }
        if leavers.len() + 1 >= first {
            return Err((
                "leaves",
                "the platoon needs a follower that stays besides the joiners".into(),
            ));
        }
        let regroups = [
            ("merge", self.merge.map(|m| m.head)),
            ("split", self.split.map(|m| m.head)),
        ];
        for (key, head) in regroups {
            let Some(head) = head else { continue };
            let others = !self.joins.is_empty()
                || !self.leaves.is_empty()
                || (self.merge.is_some() && self.split.is_some());
            if others {
                return Err((
                    key,
                    format!(
                        "a run with a {key} has no joins, leaves or other regrouping (the \
                         platoons of a merge or a split are numbered consecutively)"
                    ),
                ));
            }
            let head = usize::from(head.0);
            if head < 2 || head >= followers {
                return Err((
                    key,
                    format!(
                        "vehicle {head} cannot head the rear platoon: each platoon needs a \
                         follower, so the head is one of vehicles 2 to {}",
                        followers.saturating_sub(1)
                    ),
                ));
            }
        }
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !positive(self.in_position_m) {
            return Err((
                "in_position_m",
                format!("must be > 0 (got {})", self.in_position_m),
            ));
        }
        if !positive(self.in_position_mps) {
            return Err((
                "in_position_mps",
                format!("must be > 0 (got {})", self.in_position_mps),
            ));
        }
        if self.timing.tries == 0 || self.timing.reply_steps == 0 {
            return Err(("reply_s", "a reply needs a step and a try at least".into()));
        }
        Ok(())
    }

    /// The leader's formation as the run starts: every follower but the joiners (and the
    /// rear platoon of a merge), in order.
    pub fn initial_formation(&self, followers: usize) -> Formation {
        match self.merge {
            Some(m) => Formation::in_order(m.head.index() - 1),
            None => Formation::in_order(followers - self.joins.len()),
        }
    }
}

/// The headway a joiner keeps on its ACC: the ACC's (never below the platoon's) while
/// outside; once accepted (`approaching_s` ago), shrinking to the platoon's over the ACC's
/// `opening_s`, so that its command has no step.
pub(crate) fn joiner_headway(
    acc: &crate::fallback::AccParams,
    platoon: f64,
    approaching_s: Option<f64>,
) -> f64 {
    let outside = acc.headway_s.max(platoon);
    match approaching_s {
        None => outside,
        Some(t) => outside - (outside - platoon) * crate::fallback::opened(acc, t),
    }
}

/// The headway the head of a platoon that split off keeps on its ACC, `since_s` after the
/// split: growing from the platoon's to the ACC's (never below the platoon's) over the ACC's
/// `opening_s`, so that its command has no step.
pub(crate) fn split_headway(acc: &crate::fallback::AccParams, platoon: f64, since_s: f64) -> f64 {
    let apart = acc.headway_s.max(platoon);
    platoon + (apart - platoon) * crate::fallback::opened(acc, since_s)
}

/// One follower's part.
#[derive(Debug, Clone)]
enum Machine {
    /// A member, and the steps it asks to leave or to split at (until it asks).
    Member {
        member: Member,
        leave_at: Option<u64>,
        split_at: Option<u64>,
    },
    Joiner {
        joiner: Joiner,
        at_step: u64,
        /// It joins from the lane beside the platoon's.
        beside: bool,
    },
}

#[derive(Debug, Clone)]
struct Role {
    machine: Machine,
    inbox: Vec<Message>,
    outbox: VecDeque<Message>,
}

/// The protocol for one platoon: the leader's machine and every follower's.
#[derive(Debug, Clone)]
pub(crate) struct Maneuvers {
    params: ManeuverParams,
    leader: Leader,
    leader_in: Vec<Message>,
    leader_out: VecDeque<Message>,
    roles: Vec<Role>,
    scratch: Vec<Message>,
    /// The last step's messages the machines dropped as old: (receiver, place in its inbox).
    dropped: Vec<(VehicleId, usize)>,
}

impl Maneuvers {
    /// The machines of a platoon of `followers` followers.
    pub(crate) fn new(params: &ManeuverParams, followers: usize) -> Self {
        let formation = params.initial_formation(followers);
        // The rear platoon of a merge, from its head to the last vehicle.
        let rear = Formation::new(
            params
                .merge
                .map_or(0..0, |m| m.head.0..followers as u16 + 1)
                .map(VehicleId)
                .collect(),
        )
        .unwrap_or_else(|_| formation.clone());
        let roles = (1..=followers)
            .map(|i| {
                let id = VehicleId::follower(i);
                let merge = params.merge.filter(|m| i >= m.head.index());
                let machine = match params.joins.iter().find(|j| j.vehicle == id) {
                    _ if merge.is_some_and(|m| m.head == id) => Machine::Joiner {
                        joiner: Joiner::merging(
                            id,
                            VehicleId::LEADER,
                            VehicleId(id.0 - 1),
                            VehicleId::follower(followers),
                            params.timing,
                        ),
                        beside: false,
                        at_step: merge.map_or(0, |m| m.at_step),
                    },
                    _ if merge.is_some() => Machine::Member {
                        member: Member::new(id, rear.clone(), params.timing),
                        leave_at: None,
                        split_at: None,
                    },
                    Some(j) => Machine::Joiner {
                        joiner: Joiner::new(
                            id,
                            VehicleId::LEADER,
                            j.behind.unwrap_or(VehicleId(id.0 - 1)),
                            params.timing,
                        ),
                        beside: j.behind.is_some(),
                        at_step: j.at_step,
                    },
                    None => Machine::Member {
                        member: Member::new(id, formation.clone(), params.timing),
                        leave_at: params
                            .leaves
                            .iter()
                            .find(|l| l.vehicle == id)
                            .map(|l| l.at_step),
                        split_at: params.split.filter(|p| p.head == id).map(|p| p.at_step),
                    },
                };
                Role {
                    machine,
                    inbox: Vec::new(),
                    outbox: VecDeque::new(),
                }
            })
            .collect();
        Self {
            leader: Leader::new(formation, params.max_members, params.timing),
            params: params.clone(),
            leader_in: Vec::new(),
            leader_out: VecDeque::new(),
            roles,
            scratch: Vec::new(),
            dropped: Vec::new(),
        }
    }

    /// The messages the machines dropped as old at the last step (their sequence filters: a
    /// replay, a duplicate, one numbered below a message taken), as (receiver, place among the
    /// messages [`Maneuvers::heard`] gave it that step).
    pub(crate) fn dropped_as_old(&self) -> &[(VehicleId, usize)] {
        &self.dropped
    }

    /// The message vehicle `v`'s packet carries at this step, if it has one to send.
    pub(crate) fn next_message(&mut self, v: VehicleId) -> Option<Message> {
        match v.index() {
            0 => self.leader_out.pop_front(),
            i => self.roles[i - 1].outbox.pop_front(),
        }
    }

    /// Vehicle `receiver` got `m` (on a packet its checks accepted; the leader's are not
    /// checked).
    pub(crate) fn heard(&mut self, receiver: VehicleId, m: Message) {
        match receiver.index() {
            0 => self.leader_in.push(m),
            i => {
                if let Some(r) = self.roles.get_mut(i - 1) {
                    r.inbox.push(m);
                }
            }
        }
    }

    /// The leader ejects `member` at step `k` (revoked by the misbehaviour authority), through
    /// the leave protocol: its formation update goes out with its next packets.
    pub(crate) fn eject(&mut self, k: u64, member: VehicleId) {
        let out = &mut self.scratch;
        out.clear();
        self.leader.eject(k, member, out);
        self.leader_out.extend(out.drain(..));
    }

    /// Step `k`: every machine acts on what its vehicle received; `ready[i - 1]` is follower
    /// `i`'s controller's judgement: a joiner's that it is in its slot, a member's that the gap
    /// it opens is open.
    pub(crate) fn step(&mut self, k: u64, ready: &[bool]) {
        let out = &mut self.scratch;
        out.clear();
        self.leader.step(k, &self.leader_in, out);
        self.leader_out.extend(out.drain(..));
        self.leader_in.clear();
        self.dropped.clear();
        let leader = self.leader.dropped_as_old().iter();
        self.dropped.extend(leader.map(|&i| (VehicleId::LEADER, i)));
        for (fi, (role, &ready)) in self.roles.iter_mut().zip(ready).enumerate() {
            match &mut role.machine {
                Machine::Member {
                    member,
                    leave_at,
                    split_at,
                } => {
                    if leave_at.is_some_and(|at| k >= at) {
                        *leave_at = None;
                        member.leave(k, out);
                    }
                    if split_at.is_some_and(|at| k >= at) {
                        *split_at = None;
                        member.split(k, out);
                    }
                    member.step(k, &role.inbox, ready, out);
                    let dropped = member.dropped_as_old().iter();
                    let id = VehicleId::follower(fi + 1);
                    self.dropped.extend(dropped.map(|&i| (id, i)));
                }
                Machine::Joiner {
                    joiner, at_step, ..
                } => {
                    if k >= *at_step {
                        joiner.request(k, out);
                    }
                    joiner.step(k, &role.inbox, ready, out);
                    let dropped = joiner.dropped_as_old().iter();
                    let id = VehicleId::follower(fi + 1);
                    self.dropped.extend(dropped.map(|&i| (id, i)));
                }
            }
            role.inbox.clear();
            role.outbox.extend(out.drain(..));
        }
    }

    /// Where follower `i` stands: a member (always, for the members the run starts with), or
    /// a joiner outside or approaching.
    pub(crate) fn phase(&self, i: VehicleId) -> JoinerPhase {
        match &self.roles[i.index() - 1].machine {
            Machine::Member { .. } => JoinerPhase::Member,
            Machine::Joiner { joiner, .. } => joiner.phase(),
        }
    }

    /// Follower `i`'s copy of the formation, members in road order from its head: a member's
    /// own; a joiner's once it joined, the one the leader's update described (the leader's);
    /// none for a joiner outside.
    pub(crate) fn formation(&self, i: VehicleId) -> Option<&Formation> {
        match &self.roles[i.index() - 1].machine {
            Machine::Member { member, .. } => Some(member.formation()),
            Machine::Joiner { joiner, .. } if joiner.phase() == JoinerPhase::Member => {
                Some(self.leader.formation())
            }
            Machine::Joiner { .. } => None,
        }
    }

    /// The joiner follower `i` opens a gap ahead of it for (a member asked to), if any.
    pub(crate) fn opening_for(&self, i: VehicleId) -> Option<VehicleId> {
        match &self.roles[i.index() - 1].machine {
            Machine::Member { member, .. } => member.opening_for(),
            Machine::Joiner { .. } => None,
        }
    }

    /// Whether follower `i` is a joiner in the lane beside the platoon's: one that joins
    /// behind a member, until it reports in position (it then moves into its slot) and again
    /// once its join has failed.
    pub(crate) fn beside(&self, i: VehicleId) -> bool {
        match &self.roles[i.index() - 1].machine {
            Machine::Joiner {
                joiner,
                beside: true,
                ..
            } => !matches!(
                joiner.state(),
                JoinerState::InPosition { .. } | JoinerState::Joined { .. }
            ),
            _ => false,
        }
    }

    /// Whether follower `i` is a joiner from the lane beside (`behind` given).
    pub(crate) fn joins_from_beside(&self, i: VehicleId) -> bool {
        matches!(
            self.roles[i.index() - 1].machine,
            Machine::Joiner { beside: true, .. }
        )
    }

    /// Whether joiner `i` makes for its slot: at the tail once accepted, from the lane beside
    /// once accepted too (it moves up beside the slot while the gap opens, then into it).
    pub(crate) fn approaching(&self, i: VehicleId) -> bool {
        match &self.roles[i.index() - 1].machine {
            Machine::Joiner { joiner, .. } => matches!(
                joiner.state(),
                JoinerState::WaitingForGap { .. }
                    | JoinerState::Approaching { .. }
                    | JoinerState::InPosition { .. }
            ),
            Machine::Member { .. } => false,
        }
    }

    /// Whether follower `i` heads a platoon of its own: the rear platoon's head until its
    /// merge is announced, a member once its split is.
    pub(crate) fn heads(&self, i: VehicleId) -> bool {
        match &self.roles[i.index() - 1].machine {
            Machine::Joiner { joiner, .. } => {
                joiner.tail().is_some() && joiner.phase() != JoinerPhase::Member
            }
            Machine::Member { member, .. } => member.heads(),
        }
    }

    /// The vehicle follower `i` takes as its leader: the head of its copy of the formation (a
    /// joiner's: the platoon's leader; a head's: itself).
    pub(crate) fn head_of(&self, i: VehicleId) -> VehicleId {
        match &self.roles[i.index() - 1].machine {
            Machine::Member { member, .. } => member.formation().head(),
            Machine::Joiner { .. } => VehicleId::LEADER,
        }
    }

    /// Whether a member may open a gap for a joiner (a join in the middle). While it opens,
    /// it heads the members behind it (Plexe's rule: they take it as their leader, so their
    /// gaps hold while it slows) and they follow it.
    pub(crate) fn opens_gaps(&self) -> bool {
        self.params.joins.iter().any(|j| j.behind.is_some())
    }

    /// The member opening a gap ahead of follower `i`, as `i` knows it: the leader asked it to
    /// (`i` overheard the "open gap"), the join is not over, and it is ahead of `i` in `i`'s
    /// copy of the formation (none for a joiner).
    pub(crate) fn opener_ahead(&self, i: VehicleId) -> Option<VehicleId> {
        let Machine::Member { member, .. } = &self.roles[i.index() - 1].machine else {
            return None;
        };
        let opener = member.opener()?;
        let formation = member.formation();
        std::iter::successors(formation.predecessor(i), |&a| formation.predecessor(a))
            .take_while(|a| !a.is_leader())
            .find(|&a| a == opener)
    }

    /// Whether a platoon may head part of the vehicles (a merge, a split).
    pub(crate) fn has_heads(&self) -> bool {
        self.params.merge.is_some() || self.params.split.is_some()
    }

    /// Whether `receiver` counts `sender` as a member of its platoon: the sender is in the
    /// receiver's copy of the formation (the leader's own for the leader; none for a joiner
    /// outside, which counts only the leader).
    pub(crate) fn counts_as_member(&self, receiver: VehicleId, sender: VehicleId) -> bool {
        if sender.is_leader() {
            return true;
        }
        match receiver.index() {
            0 => self.leader.formation().contains(sender),
            _ => self.formation(receiver).is_some_and(|f| f.contains(sender)),
        }
    }

    /// The followers that are not members when the run starts: the joiners and the rear
    /// platoon of a merge.
    pub(crate) fn outside(params: &ManeuverParams, followers: usize) -> Vec<VehicleId> {
        let rear = params
            .merge
            .map_or(0..0, |m| m.head.0..followers as u16 + 1);
        (params.joins.iter().map(|j| j.vehicle))
            .chain(rear.map(VehicleId))
            .collect()
    }

    /// Whether follower `i` left the platoon (its leave announced, as its copy says).
    pub(crate) fn has_left(&self, i: VehicleId) -> bool {
        match &self.roles[i.index() - 1].machine {
            Machine::Member { member, .. } => member.has_left(),
            Machine::Joiner { .. } => false,
        }
    }

    /// The vehicle follower `i` follows by its copy of the formation: the member ahead of it
    /// (a joiner's, the member ahead of its slot; none for a vehicle that left).
    pub(crate) fn predecessor(&self, i: VehicleId) -> Option<VehicleId> {
        match &self.roles[i.index() - 1].machine {
            Machine::Member { member, .. } => member.formation().predecessor(i),
            Machine::Joiner { joiner, .. } => Some(joiner.behind()),
        }
    }

    /// The join the leader runs (the joiner and the member its slot is behind), when it checks
    /// in-position reports.
    pub(crate) fn checked_slot(&self) -> Option<(VehicleId, VehicleId)> {
        match self.leader.state() {
            platoon_maneuver::LeaderState::Joining { joiner, behind, .. }
                if self.params.check_reports =>
            {
                Some((joiner, behind))
            }
            _ => None,
        }
    }

    /// Whether the leader checks the messages it receives (`check_reports`).
    pub(crate) fn checks_messages(&self) -> bool {
        self.params.check_reports
    }

    /// Whether a gap error of `error` m (the slot's, from beacons) is plausible for a report
    /// that the sender is in its slot.
    pub(crate) fn plausible_report(&self, error: f64) -> bool {
        error.abs() <= REPORT_TOLERANCE * self.params.in_position_m
    }

    /// Whether follower `i` is in position, from its radar's `reading` at speed `v` (the
    /// platoon's `spacing`, `headway` and the length of the vehicle ahead).
    pub(crate) fn in_position(
        &self,
        reading: Option<crate::fallback::Reading>,
        v: f64,
        spacing: f64,
        headway: f64,
        length_ahead: f64,
    ) -> bool {
        reading.is_some_and(|r| {
            let e = crate::fallback::gap_error(r, headway, v, spacing, length_ahead);
            e.abs() <= self.params.in_position_m && r.closing.abs() <= self.params.in_position_mps
        })
    }
}
