//! A controller composed of parts a user can swap one at a time: a [`Law`] (what command from
//! what a follower knows), a [`Beaconing`] (who broadcasts when: [`Periodic`] beacons, or a
//! triggering scheme of the user's), the shared packet checks
//! ([`crate::checks`]) and the fallback of [`crate::fallback`] while a follower is affected.
//!
//! The field's CACC laws ([`crate::laws`]) run on it; so does any law a user writes: implement
//! [`Law`] and hand it to [`ComposedController::new`]. Each follower uses, per neighbour, the
//! last packet it accepted, as it is: no prediction between beacons (what Plexe does).
//!
//! While a follower whose law reads V2V ([`Law::uses_v2v`]) senses its channel jammed it is
//! affected: it applies its fallback
//! (`zero`, `hold`, `acc` on its radar, or `predict`: the law on what it last heard), stays in
//! it `dwell` steps after the last jammed one, then blends from the fallback's command to the
//! law's over `blend` steps (the command's mismatch at the hand-over shrinks linearly to 0).
//! The emergency-braking guard applies in every mode.

use crate::checks::{Heard, PacketChecks};
use crate::fallback::{acc_command, FallbackMachine, Radar, RadarTruth, Return, Situation, Truths};
use crate::room::{v2v_reading, Ramp};
use crate::screening::{read_radars, sensed, Detector};
use crate::{Controller, Delivery, FallbackParams, FollowerStep, Packet};
use platoon_maneuver::JoinerPhase;
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;

/// What one follower knows when its law decides at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The step.
    pub k: u64,
    /// The step length (s).
    pub dt: f64,
    /// The follower (1-based).
    pub id: VehicleId,
    /// Vehicles in its platoon, the leader included.
    pub vehicles: usize,
    /// Its own measured state `[p, v, a]` (p: front bumper).
    pub own: State,
    /// Its own command of the step before (m/s^2).
    pub last_u: f64,
    /// What an ideal radar sees of the vehicle ahead (bumper-to-bumper gap, closing speed), as
    /// the plant measured it (`None`: nothing ahead). After a member ahead left, the gap less
    /// the room still to close (`[maneuvers]`): the law closes it gradually.
    pub radar: Option<RadarTruth>,
    /// The member it follows: the vehicle ahead of it (`id - 1`), or, after members ahead of
    /// it left, the member ahead of it in the formation.
    pub ahead: VehicleId,
    /// The last packet accepted from `ahead` (in a platoon that negotiates maneuvers, from
    /// whichever member it is, a neighbour in the graph or not).
    pub ahead_heard: Option<&'a Heard>,
    /// Who it hears from, in the order of `heard`.
    pub neighbours: &'a [VehicleId],
    /// The last packet accepted from each neighbour (at first the initial state).
    pub heard: &'a [Heard],
    /// The member that heads its part of a split platoon (`[fallback.cut_in] split`), with
    /// the last packet accepted from it; `None` while the platoon's leader heads it.
    pub head: Option<(VehicleId, &'a Heard)>,
}

impl View<'_> {
    /// The last packet accepted from vehicle `j`, if `j` is a neighbour.
    pub fn from(&self, j: VehicleId) -> Option<&Heard> {
        self.neighbours
            .iter()
            .position(|&n| n == j)
            .map(|s| &self.heard[s])
    }

    /// The last packet accepted from the member it follows ([`View::ahead`]), if it hears it.
    pub fn predecessor(&self) -> Option<&Heard> {
        self.ahead_heard
    }

    /// The last packet accepted from its leader: the member that heads its part of a split
    /// platoon ([`View::head`]), else the platoon's leader if it is a neighbour.
    pub fn leader(&self) -> Option<&Heard> {
        match self.head {
            Some((_, h)) => Some(h),
            None => self.from(VehicleId::LEADER),
        }
    }
}

/// A control law: a follower's command from what it knows. Pure: no I/O, no clocks; the same
/// views give the same commands.
pub trait Law: std::fmt::Debug + Send + dyn_clone::DynClone {
    /// The command `u_i[k]` (m/s^2).
    fn command(&mut self, view: &View<'_>) -> f64;

    /// Whether it reads V2V packets at all: a law on the radar alone (an ACC) is never
    /// affected by a jammed channel, so it never falls back.
    fn uses_v2v(&self) -> bool {
        true
    }
}

dyn_clone::clone_trait_object!(Law);

/// When a follower broadcasts: a part of a [`ComposedController`] of its own, so a triggering
/// scheme can be tried with any law. Pure, like a [`Law`].
pub trait Beaconing: std::fmt::Debug + Send + dyn_clone::DynClone {
    /// Whether follower `id` broadcasts at step `k`, with its state `own` now and what it last
    /// broadcast (`(step, state)`, `None` before its first).
    fn fires(&mut self, k: u64, id: VehicleId, own: &State, last: Option<(u64, &State)>) -> bool;
}

dyn_clone::clone_trait_object!(Beaconing);

/// Every follower broadcasts every `steps` steps, from step 0 (CAM-like beacons).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Periodic {
    /// The period in steps, >= 1.
    pub steps: u32,
}

impl Beaconing for Periodic {
    fn fires(&mut self, k: u64, _: VehicleId, _: &State, _: Option<(u64, &State)>) -> bool {
        k.is_multiple_of(u64::from(self.steps.max(1)))
    }
}

/// ETSI's CAM rules as beacons (the first at step 0).
impl Beaconing for crate::CamRule {
    fn fires(&mut self, k: u64, _: VehicleId, own: &State, last: Option<(u64, &State)>) -> bool {
        last.is_none_or(|(step, x)| crate::CamRule::fires(self, k - step, own, x))
    }
}

/// The parts a [`ComposedController`] is made of besides its law.
#[derive(Debug, Clone)]
pub struct Composition {
    /// Step length (s).
    pub dt: f64,
    /// When followers broadcast (e.g. [`Periodic`]).
    pub beaconing: Box<dyn Beaconing>,
    /// The leader broadcasts every this many steps.
    pub leader_broadcast_steps: u32,
    /// The platoon's spacing `l` (m, front to front): the `acc` fallback keeps `l + h v`...
    pub spacing: f64,
    /// ...with `h` never below the platoon's own time headway (s; 0 for constant spacing).
    pub headway: f64,
    /// What a follower does while affected, and how it comes back (`closing_mps` unused: the
    /// way back blends commands, not spacing offsets).
    pub fallback: FallbackParams,
    /// Misbehaviour detection in the receive path (off by default).
    pub detection: crate::DetectionParams,
    /// The platoon's maneuvers (`[maneuvers]`: joins at the tail; none by default).
    pub maneuvers: Option<crate::ManeuverParams>,
}

#[derive(Debug, Clone)]
struct Follower {
    id: VehicleId,
    seq: u32,
    last_sent: Option<(u64, State)>,
    step: FollowerStep,
    fallback: FallbackMachine,
    radar: Radar,
    /// Whom it takes as its leader: the platoon's, or the member heading its part of a split
    /// platoon.
    head: VehicleId,
    /// Whether it heads the followers behind it (on a cut-in's ACC, with a split).
    leading: bool,
    /// Whether it was a member of the formation at the step before (`[maneuvers]`).
    member: bool,
    /// A joiner: the step it began approaching its slot.
    approaching_since: Option<u64>,
    /// A member that split off the members behind it: the step it began heading them.
    heading_since: Option<u64>,
    /// The member it follows ([`View::ahead`]).
    ahead: VehicleId,
    /// How much more room than its law's it keeps to the vehicle ahead (m): a gap it opens for
    /// a joiner, or room a member that left (or a joiner that moved in) ahead of it left it to
    /// close (negative: room it has to give). Its law sees the radar's gap less this.
    offset_m: f64,
    /// How the offset moves.
    offset: Option<Ramp>,
    /// The joiner it opened a gap for at the step before (`[maneuvers]`).
    opening: Option<VehicleId>,
    /// Whether it left the platoon (`[maneuvers]`).
    left: bool,
}

/// One platoon's followers, each running the same [`Law`] on its own copy (module docs).
#[derive(Debug, Clone)]
pub struct ComposedController {
    parts: Composition,
    laws: Vec<Box<dyn Law>>,
    followers: Vec<Follower>,
    checks: PacketChecks,
    leader: crate::seam::LeaderBeacon,
    commands: Vec<f64>,
    truths: Truths,
    /// Each follower's radar reading of this step, read once for the detectors and the
    /// fallback.
    readings: Vec<Option<(crate::fallback::Reading, u64)>>,
    /// The maneuver protocol's machines (`[maneuvers]`).
    maneuvers: Option<crate::maneuvers::Maneuvers>,
    /// Each follower's judgement of its slot this step (joiners only).
    in_position: Vec<bool>,
    /// The last state the leader heard from each vehicle (step, state), for its check of
    /// in-position reports and join requests (`[maneuvers] check_reports`).
    leader_heard: Vec<Option<(u64, State)>>,
}

impl ComposedController {
    /// Controllers for the followers of `topology` running `law` (each its own clone), with
    /// the initial states (`initial[0]` is the leader) as what was last heard.
    pub fn new(
        law: Box<dyn Law>,
        parts: Composition,
        topology: &Topology,
        initial: &[State],
    ) -> Result<Self, crate::ParamsError> {
        Self::with_detectors(law, parts, topology, initial, Vec::new())
    }

    /// [`ComposedController::new`] with misbehaviour detectors of the caller's after those of
    /// `parts.detection`, under its reaction ([`crate::screening`]).
    pub fn with_detectors(
        law: Box<dyn Law>,
        parts: Composition,
        topology: &Topology,
        initial: &[State],
        detectors: Vec<Box<dyn Detector>>,
    ) -> Result<Self, crate::ParamsError> {
        let n = topology.followers();
        let err = |field, message| crate::ParamsError { field, message };
        if initial.len() != n + 1 {
            return Err(err(
                "initial_states",
                format!(
                    "need {} states (leader + {n} followers), got {}",
                    n + 1,
                    initial.len()
                ),
            ));
        }
        if !(parts.dt.is_finite() && parts.dt > 0.0) {
            return Err(err("dt", format!("must be > 0 (got {})", parts.dt)));
        }
        if parts.leader_broadcast_steps == 0 {
            return Err(err(
                "broadcast_period_s",
                "the leader's beacons need a period of at least one step".into(),
            ));
        }
        parts
            .fallback
            .validate(n)
            .map_err(|(field, message)| err(field, message))?;
        if let Some(m) = &parts.maneuvers {
            m.validate(n)
                .map_err(|(field, message)| err(field, message))?;
        }
        let followers = (1..=n)
            .map(|i| Follower {
                id: VehicleId::follower(i),
                seq: 0,
                last_sent: None,
                step: FollowerStep::default(),
                fallback: FallbackMachine::new(parts.fallback.of(i), Return::CommandBlend),
                radar: Radar::new(parts.fallback.radar.seed, i as u16),
                head: VehicleId::LEADER,
                leading: false,
                member: true,
                approaching_since: None,
                heading_since: None,
                ahead: VehicleId(i as u16 - 1),
                offset_m: 0.0,
                offset: None,
                opening: None,
                left: false,
            })
            .collect::<Vec<_>>();
        let maneuvers = parts
            .maneuvers
            .as_ref()
            .map(|m| crate::maneuvers::Maneuvers::new(m, n));
        let mut followers = followers;
        if let Some(m) = &maneuvers {
            // A joiner follows the member of its slot; the rear platoon of a merge, its head.
            for f in &mut followers {
                f.ahead = m.predecessor(f.id).unwrap_or(f.ahead);
                f.head = m.head_of(f.id);
                f.leading = m.heads(f.id);
            }
        }
        Ok(Self {
            laws: (0..n).map(|_| law.clone()).collect(),
            followers,
            checks: crate::screening::checks(
                &parts.detection,
                detectors,
                topology,
                initial,
                parts.dt,
                crate::screening::Hearing::of(
                    parts.fallback.cut_in.is_some_and(|c| c.split),
                    parts.maneuvers.is_some(),
                ),
            )?,
            leader: Default::default(),
            commands: vec![0.0; n],
            truths: Truths::default(),
            readings: Vec::with_capacity(n),
            maneuvers,
            in_position: vec![false; n],
            leader_heard: vec![None; n + 1],
            parts,
        })
    }
}

impl Controller for ComposedController {
    fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>) {
        let mut maneuvers = self.maneuvers.as_mut();
        let mut message = |v| maneuvers.as_mut().and_then(|m| m.next_message(v));
        let every = self.parts.leader_broadcast_steps;
        let leader_message = message(VehicleId::LEADER);
        self.leader
            .transmit_with(k, every, states, leader_message, out);
        for f in &mut self.followers {
            f.step = FollowerStep::default();
            let own = &states[f.id.index()];
            let last = f.last_sent.as_ref().map(|(step, x)| (*step, x));
            // A head beacons at the leader's rate as well: the followers behind it take its
            // packets as their leader's.
            let heads = f.leading && k.is_multiple_of(u64::from(self.parts.leader_broadcast_steps));
            let maneuver = message(f.id);
            if self.parts.beaconing.fires(k, f.id, own, last) | heads | maneuver.is_some() {
                f.seq += 1;
                f.step.triggered = true;
                f.last_sent = Some((k, *own));
                out.push(Packet {
                    sender: f.id,
                    seq: f.seq,
                    step: k,
                    state: *own,
                    u: f.fallback.last_u(),
                    head: if f.leading { f.id } else { f.head },
                    maneuver,
                });
            }
        }
    }

    fn set_radar_truth(&mut self, truth: &[Option<RadarTruth>]) {
        self.truths.give(truth, self.followers.len() + 1);
    }

    fn receive(&mut self, k: u64, states: &[State], rx: &[Delivery], jammed: &[bool]) -> &[f64] {
        let fb = &self.parts.fallback;
        let truths = self.truths.take(states, |j| fb.length(j), true);
        let radar_on = fb.uses_radar();
        // The radars first: the detectors read them too.
        let radar_any = radar_on || self.checks.reads_radar() || self.maneuvers.is_some();
        let radars = self.followers.iter_mut().map(|f| &mut f.radar);
        read_radars(k, &fb.radar, radar_any, radars, truths, &mut self.readings);
        self.checks.begin_step();
        for d in rx {
            if d.receiver.is_leader() {
                // Only maneuvers reach the leader: its machine reads their messages.
                let Some(man) = self.maneuvers.as_mut() else {
                    continue;
                };
                let slot = man.checked_slot();
                let checking = man.checks_messages();
                // Whether the leader had heard the sender beacon before this packet.
                let known = self
                    .leader_heard
                    .get(d.packet.sender.index())
                    .is_some_and(Option::is_some);
                if checking {
                    let last = self.leader_heard.get_mut(d.packet.sender.index());
                    if let Some(last) = last.filter(|l| l.is_none_or(|(s, _)| s < d.packet.step)) {
                        *last = Some((d.packet.step, d.packet.state));
                    }
                }
                let Some(m) = d.packet.maneuver else { continue };
                let request = matches!(
                    m.body,
                    platoon_maneuver::Body::JoinRequest { .. }
                        | platoon_maneuver::Body::MergeRequest { .. }
                );
                // A request to join (or to merge) from a vehicle the leader never heard
                // beaconing: a vehicle that is not there.
                let ghost = checking && !known && request;
                // A report that the joiner is in its slot, checked against its own beacon and
                // the last beacon of the member it follows, both brought to this step.
                let at = |(s, x): (u64, State)| {
                    x[0] + x[1] * (k.saturating_sub(s)) as f64 * self.parts.dt
                };
                let error = match slot {
                    Some((joiner, behind))
                        if m.sender == joiner && m.body == platoon_maneuver::Body::InPosition =>
                    {
                        // The leader knows its own state.
                        let ahead = match behind.is_leader() {
                            true => Some((k, states[0])),
                            false => self.leader_heard[behind.index()],
                        };
                        ahead.map(|b| {
                            let own = (d.packet.step, d.packet.state);
                            let gap = at(b) - at(own) - fb.length(behind.index());
                            let seen = crate::fallback::Reading {
                                gap,
                                closing: 0.0,
                                intruder: false,
                            };
                            let h = self.parts.headway;
                            crate::fallback::gap_error(
                                seen,
                                h,
                                own.1[1],
                                self.parts.spacing,
                                fb.length(behind.index()),
                            )
                        })
                    }
                    _ => None,
                };
                let implausible = !ghost && error.is_some_and(|e| !man.plausible_report(e));
                // What the checks tested: every request, a report from the slot's joiner.
                let tested = checking && (error.is_some() || request);
                if tested {
                    self.checks.note_leader_check(k, d, ghost || implausible);
                }
                if ghost {
                    self.checks.refuse_unknown_sender();
                } else if implausible {
                    self.checks.refuse_implausible_state();
                } else {
                    man.heard(d.receiver, m);
                }
                continue;
            }
            let sensed = sensed(k, self.parts.dt, d, states, &self.readings, |j| {
                fb.length(j)
            });
            let admitted = self.checks.admit_sensed(k, d, sensed).is_some();
            if let (true, Some(m), Some(man)) =
                (admitted, d.packet.maneuver, self.maneuvers.as_mut())
            {
                man.heard(d.receiver, m);
            }
        }
        if let Some(man) = self.maneuvers.as_mut() {
            let (dt, spacing, headway) = (self.parts.dt, self.parts.spacing, self.parts.headway);
            for ((f, ready), reading) in self
                .followers
                .iter()
                .zip(&mut self.in_position)
                .zip(&self.readings)
            {
                let own = states[f.id.index()];
                let reading = reading.map(|(r, _)| r);
                let behind = man.predecessor(f.id).unwrap_or(f.ahead);
                let length = fb.length(behind.index());
                *ready = if man.opening_for(f.id).is_some() {
                    // The gap it opens is open: its offset arrived at the room it opens, and its
                    // radar's gap has caught up with it.
                    f.offset.is_some_and(|o| o.done(k) && o.to > 0.0)
                        && man.in_position(
                            reading.map(|r| crate::fallback::Reading {
                                gap: r.gap - f.offset_m,
                                ..r
                            }),
                            own[1],
                            spacing,
                            headway,
                            fb.length(f.ahead.index()),
                        )
                } else if man.phase(f.id) == JoinerPhase::Member {
                    // Not asked to open a gap (yet): nothing is open.
                    false
                } else {
                    // A joiner beside the platoon judges its slot from V2V.
                    let seen = match man.beside(f.id) {
                        true => v2v_reading(&self.checks, f.id, behind, k, dt, &own, length),
                        false => reading,
                    };
                    man.in_position(seen, own[1], spacing, headway, length)
                };
            }
            man.step(k, &self.in_position);
        }
        let n1 = self.followers.len() + 1;
        let split = fb.cut_in.is_some_and(|c| c.split);
        for (((f, law), u_out), reading) in self
            .followers
            .iter_mut()
            .zip(&mut self.laws)
            .zip(self.commands.iter_mut())
            .zip(&self.readings)
        {
            let own = states[f.id.index()];
            let truth = truths[f.id.index()];
            // The nearest member ahead that announced itself as a head leads it (no search
            // in a platoon that never splits); with a merge, the head of its copy of the
            // formation.
            let ahead = if split { 1..f.id.index() } else { 1..1 };
            let head = ahead.rev().map(VehicleId::follower).find_map(|j| {
                let h = self.checks.heard_from(f.id, j)?;
                h.heads(j).then_some((j, h))
            });
            let head = match self.maneuvers.as_ref().filter(|m| m.has_heads()) {
                Some(m) => Some(m.head_of(f.id))
                    .filter(|&j| j != VehicleId::LEADER && j != f.id)
                    .and_then(|j| Some((j, self.checks.heard_from(f.id, j)?))),
                None => head,
            };
            // While a member ahead opens a gap for a joiner it heads the members behind it: they
            // follow it once its packets say so, as long as they know the leader asked it to
            // open (a head announced without that is not believed).
            let head = match self.maneuvers.as_ref().filter(|m| m.opens_gaps()) {
                Some(m) if head.is_none() => m.opener_ahead(f.id).and_then(|j| {
                    let h = self.checks.heard_from(f.id, j)?;
                    h.heads(j).then_some((j, h))
                }),
                _ => head,
            };
            let rebased = head.map_or(VehicleId::LEADER, |(j, _)| j) != f.head;
            f.head = head.map_or(VehicleId::LEADER, |(j, _)| j);
            let man = self.maneuvers.as_ref();
            let phase = man.map_or(JoinerPhase::Member, |m| m.phase(f.id));
            let left = man.is_some_and(|m| m.has_left(f.id));
            let beside = man.is_some_and(|m| m.beside(f.id));
            // A member that split off the members behind it heads them on its ACC.
            let split_off = phase == JoinerPhase::Member && man.is_some_and(|m| m.heads(f.id));
            let member = phase == JoinerPhase::Member && !left && !split_off;
            let opening_for = man.and_then(|m| m.opening_for(f.id));
            let (dt, spacing, headway) = (self.parts.dt, self.parts.spacing, self.parts.headway);
            // A member follows whom its copy of the formation puts ahead of it, from the step its
            // radar (the one its law reads) sees that vehicle: after a member ahead left (out of
            // the lane), or once the joiner it opened a gap for moved in. The room between is
            // taken up gradually (`offset`).
            let next = opening_for.or(man.and_then(|m| m.predecessor(f.id)));
            let mut switched = false;
            if let (true, Some(next), Some(r)) = (member, next, truth) {
                if next != f.ahead {
                    let gap_to = |j: VehicleId| {
                        v2v_reading(&self.checks, f.id, j, k, dt, &own, fb.length(j.index()))
                            .map(|v| v.gap)
                    };
                    if let (Some(to_next), Some(to_old)) = (gap_to(next), gap_to(f.ahead)) {
                        if (r.gap - to_next).abs() < (r.gap - to_old).abs() {
                            f.ahead = next;
                            switched = true;
                            let seen = crate::fallback::Reading {
                                gap: r.gap,
                                closing: r.closing,
                                intruder: r.intruder,
                            };
                            let length = fb.length(next.index());
                            let room =
                                crate::fallback::gap_error(seen, headway, own[1], spacing, length);
                            f.offset = Some(Ramp::new(room, 0.0, k, fb.closing_mps, dt));
                            f.offset_m = room;
                        }
                    }
                }
            }
            // A member asked to open a gap for a joiner makes room for one more vehicle; if the
            // joiner never comes, it closes it again.
            if !switched && opening_for != f.opening {
                let target = match opening_for {
                    Some(_) => spacing + headway * own[1],
                    None => 0.0,
                };
                if f.opening.is_none_or(|j| j != f.ahead) {
                    f.offset = Some(Ramp::new(f.offset_m, target, k, fb.closing_mps, dt));
                }
            }
            f.opening = opening_for;
            // The law follows a virtual vehicle `offset` behind the one ahead, moving with the
            // offset: its gap, closing speed and packet are the ahead vehicle's, shifted.
            let (rate, accel) = f.offset.map_or((0.0, 0.0), |o| o.motion(k, dt));
            let radar = match truth {
                Some(t) if f.offset_m != 0.0 => Some(RadarTruth {
                    gap: t.gap - f.offset_m,
                    closing: t.closing + rate,
                    ..t
                }),
                t => t,
            };
            let heard = self.checks.heard_from(f.id, f.ahead);
            let shifted = heard.filter(|_| f.offset_m != 0.0).map(|h| Heard {
                state: State::new(
                    h.state[0] - f.offset_m,
                    h.state[1] - rate,
                    h.state[2] - accel,
                ),
                u: h.u - accel,
                ..*h
            });
            let view = View {
                k,
                dt,
                id: f.id,
                vehicles: n1,
                own,
                last_u: f.fallback.last_u(),
                radar,
                ahead: f.ahead,
                ahead_heard: shifted.as_ref().or(heard),
                neighbours: self.checks.neighbours(f.id),
                heard: self.checks.heard(f.id),
                head,
            };
            let lawful = law.command(&view);
            // A joiner drives on its radar (maneuvers module docs), or beside the platoon on
            // what it hears of the member of its slot; the members read the radar as their
            // fallback does.
            let length_ahead = fb.length(f.ahead.index());
            let heard_ahead =
                || v2v_reading(&self.checks, f.id, f.ahead, k, dt, &own, length_ahead);
            let from_beside = man.is_some_and(|m| m.joins_from_beside(f.id));
            let reading = match beside {
                true => heard_ahead(),
                // Just moved in, its radar not read yet on the lane: what it heard until now.
                false if from_beside && !member => reading.map(|(r, _)| r).or_else(heard_ahead),
                false => reading.filter(|_| radar_on || !member).map(|(r, _)| r),
            };
            let just_split = split_off && f.heading_since.is_none();
            let (lawful, joined) = match phase {
                // A leaver drives on at its speed in the next lane.
                _ if left => (0.0, false),
                JoinerPhase::Member if split_off => {
                    let since = *f.heading_since.get_or_insert(k);
                    let elapsed_s = (k - since) as f64 * dt;
                    let headway = crate::maneuvers::split_headway(&fb.acc, headway, elapsed_s);
                    let acc = acc_command(&fb.acc, reading, headway, own[1], spacing, length_ahead);
                    (acc, false)
                }
                JoinerPhase::Member => (lawful, !f.member),
                JoinerPhase::Outside | JoinerPhase::Approaching => {
                    let approaching = man.is_some_and(|m| m.approaching(f.id));
                    let since = approaching.then(|| *f.approaching_since.get_or_insert(k));
                    let elapsed_s = since.map(|since| (k - since) as f64 * dt);
                    let headway = crate::maneuvers::joiner_headway(&fb.acc, headway, elapsed_s);
                    let acc = acc_command(&fb.acc, reading, headway, own[1], spacing, length_ahead);
                    (acc, false)
                }
            };
            let just_left = left && !f.left;
            f.left = left;
            f.member = member;
            let affected = (jammed[f.id.index()] || self.checks.distrusts(f.id, k))
                && law.uses_v2v()
                && member;
            let situation = Situation {
                k,
                dt,
                params: fb,
                affected,
                // A law on the radar alone follows whoever is ahead anyway.
                cut_in: reading.is_some_and(|r| r.intruder) && law.uses_v2v() && member,
                law: lawful,
                q: State::zeros(),
                reading: reading.filter(|_| !beside),
                speed: own[1],
                spacing,
                headway: self.parts.headway,
                length_ahead,
                rebased: rebased || joined || switched || just_left || just_split,
            };
            let (mode, u, guard) = f.fallback.step(&situation, |_| lawful);
            let mode = match (member, left, beside) {
                (true, _, _) => mode,
                (false, true, _) => crate::Mode::Left,
                (false, false, true) => crate::Mode::Beside,
                (false, false, false) => crate::Mode::Outside,
            };
            if let Some(o) = f.offset {
                f.offset_m = o.at(k + 1);
                if o.done(k + 1) && o.to == 0.0 {
                    f.offset = None;
                }
            }
            f.step.u = u;
            f.step.affected = affected;
            f.step.mode = mode;
            f.step.guard = guard;
            f.step.head = f.head;
            // It heads while on the car's ACC, and while an attack's fallback interrupts that
            // with the car still ahead.
            f.leading = split && (mode == crate::Mode::CutIn || situation.cut_in)
                || man.is_some_and(|m| m.heads(f.id) || m.opens_gaps() && opening_for.is_some());
            *u_out = u;
        }
        &self.commands
    }

    fn commands(&self) -> &[f64] {
        &self.commands
    }

    fn follower_step(&self, i: VehicleId) -> FollowerStep {
        self.followers[i.index() - 1].step
    }

    fn checks(&self) -> Option<&PacketChecks> {
        Some(&self.checks)
    }
}

#[cfg(test)]
mod tests;
