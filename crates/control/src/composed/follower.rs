//! One follower's way through the pipeline at a step: whom it takes as its leader (the head
//! of its part), whom it follows and the room it keeps to it, its law's command on what it
//! knows, the command its place in the platoon calls for, then the fallback machine and the
//! guard.
use super::{Composition, Law, View};
use crate::checks::{Heard, PacketChecks};
use crate::fallback::Role;
use crate::fallback::{acc_command, gap_error, FallbackMachine, Radar, RadarTruth, Reading};
use crate::fallback::{Return, Situation};
use crate::maneuvers::Maneuvers;
use crate::room::{v2v_reading, Ramp};
use crate::{FollowerStep, Mode};
use platoon_maneuver::JoinerPhase;
use platoon_model::{State, VehicleId};

#[derive(Debug, Clone)]
pub(super) struct Follower {
    pub(super) id: VehicleId,
    pub(super) seq: u32,
    pub(super) last_sent: Option<(u64, State)>,
    pub(super) step: FollowerStep,
    pub(super) fallback: FallbackMachine,
    pub(super) radar: Radar,
    /// Whom it steers on: its head, the member it follows and the room it keeps to it.
    pub(super) targets: Targets,
    /// Where it stood in the platoon, and since when (`[maneuvers]`).
    standing: Standing,
}

/// Whom a follower steers on: the stage between what it heard and its law.
#[derive(Debug, Clone)]
pub(super) struct Targets {
    /// Whom it takes as its leader: the platoon's, or the member heading its part of a split
    /// platoon.
    pub(super) head: VehicleId,
    /// Whether it heads the followers behind it (on a cut-in's ACC, with a split).
    pub(super) leading: bool,
    /// The member it follows ([`View::ahead`]).
    pub(super) ahead: VehicleId,
    /// How much more room than its law's it keeps to the vehicle ahead (m): a gap it opens for
    /// a joiner, or room a member that left (or a joiner that moved in) ahead of it left it to
    /// close (negative: room it has to give). Its law sees the radar's gap less this.
    pub(super) offset_m: f64,
    /// How the offset moves.
    pub(super) offset: Option<Ramp>,
    /// The joiner it opened a gap for at the step before (`[maneuvers]`).
    opening: Option<VehicleId>,
    /// Its part of the platoon as its law saw it at the last step ([`View::part`]), when
    /// `in_part`.
    part: Vec<VehicleId>,
    in_part: bool,
}

/// Where a follower stood in the platoon at the step before, and since when: what the
/// maneuver step's role for it changes.
#[derive(Debug, Clone)]
struct Standing {
    /// Whether it was a member of the formation.
    member: bool,
    /// A joiner: the step it began approaching its slot.
    approaching_since: Option<u64>,
    /// A member that split off the members behind it: the step it began heading them.
    heading_since: Option<u64>,
    /// Whether it left the platoon.
    left: bool,
    /// A member that left: the step it did (its ACC's headway opens from then) and its
    /// speed then (its cruise control's set speed).
    left_since: Option<(u64, f64)>,
}

/// What every follower shares at step `k`.
pub(super) struct Shared<'a> {
    pub(super) k: u64,
    pub(super) parts: &'a Composition,
    pub(super) checks: &'a PacketChecks,
    pub(super) man: Option<&'a Maneuvers>,
    pub(super) states: &'a [State],
    /// What each vehicle's radar sees, leader first.
    pub(super) truths: &'a [Option<RadarTruth>],
    pub(super) jammed: &'a [bool],
    /// Whether the platoon splits behind a car that cut in.
    pub(super) split: bool,
    /// Every vehicle of the platoon in order (a split part is a slice of it).
    pub(super) ids: &'a [VehicleId],
}

/// Where a follower stands in the platoon at a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Place {
    /// A member following the platoon's law.
    Member,
    /// A member that split off the members behind it: it heads them on its ACC.
    SplitOff,
    /// A joiner, outside the platoon or approaching its slot.
    Joiner,
    /// It left the platoon.
    Left,
}

impl Follower {
    /// Follower `i`, returning from a fallback as `law` does.
    pub(super) fn new(
        i: usize,
        parts: &Composition,
        back: Return,
        man: Option<&Maneuvers>,
    ) -> Self {
        let id = VehicleId::follower(i);
        let mut f = Self {
            id,
            seq: 0,
            last_sent: None,
            step: FollowerStep::default(),
            fallback: FallbackMachine::new(parts.fallback.of(i), back),
            radar: Radar::new(parts.fallback.radar.seed, i as u16),
            targets: Targets {
                head: VehicleId::LEADER,
                leading: false,
                ahead: VehicleId(i as u16 - 1),
                offset_m: 0.0,
                offset: None,
                opening: None,
                part: Vec::new(),
                in_part: false,
            },
            standing: Standing {
                member: true,
                approaching_since: None,
                heading_since: None,
                left: false,
                left_since: None,
            },
        };
        if let Some(m) = man {
            // A joiner follows the member of its slot; the rear platoon of a merge, its head.
            f.targets.ahead = m.predecessor(id).unwrap_or(f.targets.ahead);
            f.targets.head = m.head_of(id);
            f.targets.leading = m.heads(id);
        }
        f
    }

    /// Its part of the platoon as its law saw it at the last step ([`View::part`]).
    pub(super) fn part(&self) -> Option<&[VehicleId]> {
        self.targets.in_part.then_some(&self.targets.part[..])
    }

    /// Its part of the platoon with `head` as its leader ([`View::part`]): its copy of the
    /// formation from `head` on in a platoon that negotiates maneuvers (none for a joiner),
    /// else, while a member ahead heads it, every vehicle from that member on; in either, it
    /// stands right behind the member it follows ([`View::ahead`]), as its radar does: until
    /// it switches to the one its formation puts ahead of it, and, once it follows a joiner
    /// that moved in, before the leader's update says so.
    fn arrange_part(&mut self, s: &Shared<'_>, head: VehicleId) {
        let part = match s.man {
            Some(m) => m.formation(self.id).map(|f| {
                let members = f.members();
                let at = members.iter().position(|&v| v == head).unwrap_or(0);
                &members[at..]
            }),
            None if head.is_leader() => None,
            None => s.ids.get(head.index()..),
        };
        self.targets.in_part = part.is_some();
        self.targets.part.clear();
        let Some(part) = part else { return };
        let known = part.contains(&self.targets.ahead);
        for &v in part {
            match v == self.id {
                // A joiner its radar already follows, before the leader's update: where the
                // update will put it.
                true if !known && self.targets.ahead != VehicleId::LEADER => {
                    self.targets.part.extend([self.targets.ahead, self.id])
                }
                true if !known => self.targets.part.push(v),
                true => {}
                false => {
                    self.targets.part.push(v);
                    if v == self.targets.ahead {
                        self.targets.part.push(self.id);
                    }
                }
            }
        }
        if !self.targets.part.contains(&self.id) {
            // It heads the part: the formation's order.
            self.targets.part.clear();
            self.targets.part.extend_from_slice(part);
        }
    }

    /// Step `s.k`: its command, with `reading` its radar's of this step.
    pub(super) fn step(
        &mut self,
        law: &mut dyn Law,
        reading: Option<(Reading, u64)>,
        s: &Shared<'_>,
    ) -> f64 {
        let (k, fb) = (s.k, &s.parts.fallback);
        let own = s.states[self.id.index()];
        let head = self.take_head(s);
        let rebased = head.map_or(VehicleId::LEADER, |(j, _)| j) != self.targets.head;
        self.targets.head = head.map_or(VehicleId::LEADER, |(j, _)| j);
        let place = self.place(s.man);
        let opening_for = s.man.and_then(|m| m.opening_for(self.id));
        let switched = self.follow_next(s, place, opening_for, &own);
        self.open_for(s, switched, opening_for, &own);
        self.arrange_part(s, self.targets.head);
        let lawful = self.law_command(law, s, head, &own);
        let reading = self.reading_for(s, place, reading, &own);
        let length_ahead = fb.length(self.targets.ahead.index());
        let just_split = place == Place::SplitOff && self.standing.heading_since.is_none();
        let (lawful, joined) = self.command_at(s, place, lawful, reading, &own);
        let just_left = place == Place::Left && !self.standing.left;
        self.standing.left = place == Place::Left;
        let member = place == Place::Member;
        self.standing.member = member;
        let attacked = law
            .triggering()
            .is_some_and(|t| t.attacked(k, self.step.triggered, s.jammed[self.id.index()]));
        let jammed = s.jammed[self.id.index()] || attacked;
        let affected = (jammed || s.checks.distrusts(self.id, k) || self.silent(s))
            && law.uses_v2v()
            && member;
        let beside = s.man.is_some_and(|m| m.beside(self.id));
        let situation = Situation {
            k,
            dt: s.parts.dt,
            params: fb,
            affected,
            // A law on the radar alone follows whoever is ahead anyway.
            cut_in: reading.is_some_and(|r| r.intruder) && law.uses_v2v() && member,
            law: lawful,
            q: law.tracking_error(),
            reading: reading.filter(|_| !beside),
            speed: own[1],
            spacing: s.parts.spacing,
            headway: s.parts.headway,
            length_ahead,
            rebased: rebased || joined || switched || just_left || just_split,
        };
        let (mode, u, guard) = self
            .fallback
            .step(&situation, |offset| law.command_offset(offset));
        let role = match place {
            Place::Member => Role::Member,
            Place::Left => Role::Left,
            _ if beside => Role::Beside,
            _ => Role::Outside,
        };
        if let Some(t) = law.triggering() {
            t.settle(&own, affected, self.fallback.offset(k));
        }
        law.end_step();
        if let Some(o) = self.targets.offset {
            self.targets.offset_m = o.at(k + 1);
            if o.done(k + 1) && o.to == 0.0 {
                self.targets.offset = None;
            }
        }
        self.step.u = u;
        self.step.affected = affected;
        self.step.mode = mode;
        self.step.role = role;
        self.step.guard = guard;
        self.step.head = self.targets.head;
        // It heads while on the car's ACC, while an attack's fallback interrupts that with the
        // car still ahead, and on its way back to its law once the car left, until it has
        // closed up: the members behind it keep following it until then.
        let status = self.step.status();
        let returning = self.targets.leading && status == Mode::Blend;
        self.targets.leading = s.split && (status == Mode::CutIn || situation.cut_in || returning)
            || s.man
                .is_some_and(|m| m.heads(self.id) || m.opens_gaps() && opening_for.is_some());
        u
    }

    /// The member heading its part, with what it last heard from it: the nearest member ahead
    /// that announced itself as a head (no search in a platoon that never splits); with a
    /// merge or a split maneuver, the head of its copy of the formation; in a middle join,
    /// the member ahead opening the gap, once its packets say so and as long as it knows the
    /// leader asked it to open (a head announced without that is not believed).
    fn take_head<'a>(&self, s: &Shared<'a>) -> Option<(VehicleId, &'a Heard)> {
        let ahead = if s.split { 1..self.id.index() } else { 1..1 };
        let head = ahead.rev().map(VehicleId::follower).find_map(|j| {
            let h = s.checks.heard_from(self.id, j)?;
            h.heads(j).then_some((j, h))
        });
        let head = match s.man.filter(|m| m.has_heads()) {
            Some(m) => Some(m.head_of(self.id))
                .filter(|&j| j != VehicleId::LEADER && j != self.id)
                .and_then(|j| Some((j, s.checks.heard_from(self.id, j)?))),
            None => head,
        };
        match s.man.filter(|m| m.opens_gaps()) {
            Some(m) if head.is_none() => m.opener_ahead(self.id).and_then(|j| {
                let h = s.checks.heard_from(self.id, j)?;
                h.heads(j).then_some((j, h))
            }),
            _ => head,
        }
    }

    fn place(&self, man: Option<&Maneuvers>) -> Place {
        let Some(m) = man else {
            return Place::Member;
        };
        match m.phase(self.id) {
            _ if m.has_left(self.id) => Place::Left,
            JoinerPhase::Member if m.heads(self.id) => Place::SplitOff,
            JoinerPhase::Member => Place::Member,
            JoinerPhase::Outside | JoinerPhase::Approaching => Place::Joiner,
        }
    }

    /// A member follows whom its copy of the formation puts ahead of it, from the step its
    /// radar (the one its law reads) sees that vehicle: after a member ahead left (out of the
    /// lane), or once the joiner it opened a gap for moved in. The room between is taken up
    /// gradually (`offset`). Whether it switched.
    fn follow_next(
        &mut self,
        s: &Shared<'_>,
        place: Place,
        opening_for: Option<VehicleId>,
        own: &State,
    ) -> bool {
        let (k, dt, fb) = (s.k, s.parts.dt, &s.parts.fallback);
        let next = opening_for.or(s.man.and_then(|m| m.predecessor(self.id)));
        let (Place::Member, Some(next), Some(r)) = (place, next, s.truths[self.id.index()]) else {
            return false;
        };
        if next == self.targets.ahead {
            return false;
        }
        let gap_to = |j: VehicleId| {
            v2v_reading(s.checks, self.id, j, k, dt, own, fb.length(j.index())).map(|v| v.gap)
        };
        let (Some(to_next), Some(to_old)) = (gap_to(next), gap_to(self.targets.ahead)) else {
            return false;
        };
        if (r.gap - to_next).abs() >= (r.gap - to_old).abs() {
            return false;
        }
        self.targets.ahead = next;
        let seen = Reading {
            gap: r.gap,
            closing: r.closing,
            intruder: r.intruder,
        };
        let length = fb.length(next.index());
        let room = gap_error(seen, s.parts.headway, own[1], s.parts.spacing, length);
        self.targets.offset = Some(Ramp::new(room, 0.0, k, fb.closing_mps, dt));
        self.targets.offset_m = room;
        true
    }

    /// A member asked to open a gap for a joiner makes room for one more vehicle; if the
    /// joiner never comes, it closes it again.
    fn open_for(
        &mut self,
        s: &Shared<'_>,
        switched: bool,
        opening_for: Option<VehicleId>,
        own: &State,
    ) {
        if !switched && opening_for != self.targets.opening {
            let target = match opening_for {
                Some(_) => s.parts.spacing + s.parts.headway * own[1],
                None => 0.0,
            };
            if self.targets.opening.is_none_or(|j| j != self.targets.ahead) {
                let fb = &s.parts.fallback;
                let ramp = Ramp::new(
                    self.targets.offset_m,
                    target,
                    s.k,
                    fb.closing_mps,
                    s.parts.dt,
                );
                self.targets.offset = Some(ramp);
            }
        }
        self.targets.opening = opening_for;
    }

    /// Its law's command on what it knows. The law follows a virtual vehicle `offset` behind
    /// the one ahead, moving with the offset: its gap, closing speed and packet are the ahead
    /// vehicle's, shifted.
    /// Whether the vehicle it follows, or its leader, has had no packet accepted for longer
    /// than `[fallback] silence_s` (never without it; the leader is not counted when it is the
    /// vehicle followed already, or when this follower does not hear it).
    fn silent(&self, s: &Shared<'_>) -> bool {
        let Some(n) = s.parts.fallback.silence_steps else {
            return false;
        };
        let quiet = |j: VehicleId| {
            s.checks
                .heard_from(self.id, j)
                .is_some_and(|h| s.k.saturating_sub(h.step.unwrap_or(0)) > u64::from(n))
        };
        quiet(self.targets.ahead)
            || (self.targets.head != self.targets.ahead && quiet(self.targets.head))
    }

    fn law_command(
        &self,
        law: &mut dyn Law,
        s: &Shared<'_>,
        head: Option<(VehicleId, &Heard)>,
        own: &State,
    ) -> f64 {
        let (k, dt) = (s.k, s.parts.dt);
        let (rate, accel) = self.targets.offset.map_or((0.0, 0.0), |o| o.motion(k, dt));
        let radar = match s.truths[self.id.index()] {
            Some(t) if self.targets.offset_m != 0.0 => Some(RadarTruth {
                gap: t.gap - self.targets.offset_m,
                closing: t.closing + rate,
                ..t
            }),
            t => t,
        };
        let heard = s.checks.heard_from(self.id, self.targets.ahead);
        let shifted = heard
            .filter(|_| self.targets.offset_m != 0.0)
            .map(|h| Heard {
                state: State::new(
                    h.state[0] - self.targets.offset_m,
                    h.state[1] - rate,
                    h.state[2] - accel,
                ),
                u: h.u - accel,
                ..*h
            });
        let view = View {
            k,
            dt,
            id: self.id,
            vehicles: s.ids.len(),
            own: *own,
            last_u: self.fallback.last_u(),
            radar,
            ahead: self.targets.ahead,
            ahead_heard: shifted.as_ref().or(heard),
            neighbours: s.checks.neighbours(self.id),
            heard: s.checks.heard(self.id),
            head,
            part: self.part(),
            room: State::new(self.targets.offset_m, rate, accel),
        };
        law.command(&view)
    }

    /// What its radar tells its place's command: a joiner drives on its radar (maneuvers
    /// module docs), or beside the platoon on what it hears of the member of its slot; the
    /// members read the radar as their fallback does.
    fn reading_for(
        &self,
        s: &Shared<'_>,
        place: Place,
        reading: Option<(Reading, u64)>,
        own: &State,
    ) -> Option<Reading> {
        let fb = &s.parts.fallback;
        let (k, dt) = (s.k, s.parts.dt);
        let length_ahead = fb.length(self.targets.ahead.index());
        let heard_ahead = || {
            v2v_reading(
                s.checks,
                self.id,
                self.targets.ahead,
                k,
                dt,
                own,
                length_ahead,
            )
        };
        let beside = s.man.is_some_and(|m| m.beside(self.id));
        let from_beside = s.man.is_some_and(|m| m.joins_from_beside(self.id));
        let member = place == Place::Member;
        match beside {
            true => heard_ahead(),
            // Just moved in, its radar not read yet on the lane: what it heard until now.
            false if from_beside && !member => reading.map(|(r, _)| r).or_else(heard_ahead),
            false => reading
                .filter(|_| fb.uses_radar() || !member)
                .map(|(r, _)| r),
        }
    }

    /// The command its place calls for, and whether it just joined: a member's law; a
    /// leaver's ACC (at the speed it left at, behind what is ahead on its lane); a member that split off
    /// heads the members behind it on its ACC, as a joiner drives to its slot, each with a
    /// headway that opens gently.
    fn command_at(
        &mut self,
        s: &Shared<'_>,
        place: Place,
        lawful: f64,
        reading: Option<Reading>,
        own: &State,
    ) -> (f64, bool) {
        let (k, dt, fb) = (s.k, s.parts.dt, &s.parts.fallback);
        let length_ahead = fb.length(self.targets.ahead.index());
        let acc = |headway| {
            acc_command(
                &fb.acc,
                reading,
                headway,
                own[1],
                s.parts.spacing,
                length_ahead,
            )
        };
        match place {
            // A member that left drives on its ACC: a cruise control holding the speed it
            // left at, unless the vehicle its radar sees ahead on its lane (the members that
            // left before it, once it is beside; its predecessor while it waits for a safe
            // gap) asks for less, the gap's headway opening from the platoon's as a split's
            // head's does.
            Place::Left => {
                let (since, set_speed) = *self.standing.left_since.get_or_insert((k, own[1]));
                let elapsed_s = (k - since) as f64 * dt;
                let headway = crate::maneuvers::split_headway(&fb.acc, s.parts.headway, elapsed_s);
                let cruise = ((set_speed - own[1]) / fb.acc.headway_s)
                    .clamp(-fb.acc.max_decel_mps2, fb.acc.max_accel_mps2);
                let u = match reading {
                    Some(_) => acc(headway).min(cruise),
                    None => cruise,
                };
                (u, false)
            }
            Place::SplitOff => {
                let since = *self.standing.heading_since.get_or_insert(k);
                let elapsed_s = (k - since) as f64 * dt;
                let headway = crate::maneuvers::split_headway(&fb.acc, s.parts.headway, elapsed_s);
                (acc(headway), false)
            }
            Place::Member => (lawful, !self.standing.member),
            Place::Joiner => {
                let approaching = s.man.is_some_and(|m| m.approaching(self.id));
                let since = approaching.then(|| *self.standing.approaching_since.get_or_insert(k));
                let elapsed_s = since.map(|since| (k - since) as f64 * dt);
                let headway = crate::maneuvers::joiner_headway(&fb.acc, s.parts.headway, elapsed_s);
                (acc(headway), false)
            }
        }
    }
}
