//! The one follower pipeline every law runs on, composed of parts a user can swap one at a
//! time: a [`Law`] (what command from what a follower knows), a [`Beaconing`] (who broadcasts
//! when: [`Periodic`] beacons, or a triggering scheme of the user's; a law may trigger itself,
//! [`Triggering`]), the shared packet checks ([`crate::checks`]) and the fallback of
//! [`crate::fallback`] while a follower is affected.
//!
//! A follower's step is a short sequence of stages, each with its own state: what arrived
//! and whether to believe it (the packet checks and detectors; the leader's checks of
//! maneuver messages); the maneuver step (the protocol's machines, `maneuver_stage`); whom
//! it takes as its leader and whom it follows (the predecessor, the leader or the head of its
//! part, the member its formation puts ahead, with the room to it: `follower`); the law; the
//! command its place in the platoon calls for (a member's law, a joiner's or a splitter's
//! ACC, nothing for a leaver); the fallback machine and the guard.
//!
//! The paper's law ([`crate::PaperLaw`]: estimators, `u = -K q`, the event triggers and the
//! resilient mechanism), the field's CACC laws ([`crate::laws`]) and any law a user writes
//! run on it alike, so each gets maneuvers, the split behind a cut-in and the detectors:
//! implement [`Law`] and hand it to [`ComposedController::new`]. The field's laws use, per
//! neighbour, the last packet accepted, as it is: no prediction between beacons (what Plexe
//! does).
//!
//! While a follower whose law reads V2V ([`Law::uses_v2v`]) senses its channel jammed it is
//! affected: it applies its fallback
//! (`zero`, `hold`, `acc` on its radar, or `predict`: the law on what it last heard), stays in
//! it `dwell` steps after the last jammed one, then blends from the fallback's command to the
//! law's over `blend` steps (the command's mismatch at the hand-over shrinks linearly to 0).
//! The emergency-braking guard applies in every mode.

use crate::checks::PacketChecks;
use crate::fallback::{RadarTruth, Reading, Truths};
use crate::screening::{read_radars, sensed, Detector};
use crate::{Controller, Delivery, FollowerStep, Packet};
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;

mod follower;
mod leader_beacon;
mod maneuver_stage;
mod parts;

use follower::{Follower, Shared};
use maneuver_stage::ManeuverStage;
pub use parts::{Beaconing, Composition, Law, Periodic, Triggering, View};

/// One platoon's followers, each running the same [`Law`] on its own copy (module docs).
#[derive(Debug, Clone)]
pub struct ComposedController {
    parts: Composition,
    laws: Vec<Box<dyn Law>>,
    followers: Vec<Follower>,
    checks: PacketChecks,
    leader: leader_beacon::LeaderBeacon,
    commands: Vec<f64>,
    truths: Truths,
    /// Each follower's radar reading of this step, read once for the detectors and the
    /// fallback.
    readings: Vec<Option<(Reading, u64)>>,
    /// The maneuver protocol's machines and what they keep (`[maneuvers]`).
    maneuvers: Option<ManeuverStage>,
    /// Every vehicle of the platoon in order, the leader first.
    ids: Vec<VehicleId>,
    /// Per vehicle (the leader first): revoked by the misbehaviour authority.
    revoked: Vec<bool>,
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
        validate(&parts, n, initial)?;
        let maneuvers = parts.maneuvers.as_ref().map(|m| ManeuverStage::new(m, n));
        let machines = maneuvers.as_ref().map(|m| &m.machines);
        let back = law.way_back();
        let followers = (1..=n)
            .map(|i| Follower::new(i, &parts, back, machines))
            .collect::<Vec<_>>();
        let checks = crate::screening::checks(
            &parts.detection,
            detectors,
            topology,
            initial,
            parts.dt,
            crate::screening::Hearing::of(
                parts.fallback.cut_in.is_some_and(|c| c.split),
                parts.maneuvers.is_some(),
            ),
        )?
        .with_security(
            parts.security,
            n + 1,
            &(parts.maneuvers.as_ref())
                .map_or_else(Vec::new, |m| crate::maneuvers::Maneuvers::outside(m, n)),
        );
        let laws = followers
            .iter()
            .map(|f| {
                let mut law = law.clone();
                law.start(f.id, topology, checks.hearing(f.id), initial);
                law
            })
            .collect();
        Ok(Self {
            laws,
            followers,
            checks,
            leader: Default::default(),
            commands: vec![0.0; n],
            truths: Truths::default(),
            readings: Vec::with_capacity(n),
            maneuvers,
            ids: (0..=n).map(|i| VehicleId(i as u16)).collect(),
            revoked: vec![false; n + 1],
            parts,
        })
    }
}

/// The parts' own checks, naming the key: the number of initial states, the step, the
/// leader's beacon period, the fallback and the maneuvers.
fn validate(parts: &Composition, n: usize, initial: &[State]) -> Result<(), crate::ParamsError> {
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
    Ok(())
}

impl Controller for ComposedController {
    fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>) {
        let start = out.len();
        let every = self.parts.leader_broadcast_steps;
        let leader_message = self
            .maneuvers
            .as_mut()
            .and_then(|m| m.machines.next_message(VehicleId::LEADER));
        // A leader with a renewed group key to send broadcasts (`[security.group]`).
        let keys = self.checks.leader_has_keys_to_send();
        self.leader
            .transmit_with(k, every, states, leader_message, keys, out);
        for (f, law) in self.followers.iter_mut().zip(&mut self.laws) {
            let own = &states[f.id.index()];
            f.step = FollowerStep {
                theta: law.triggering().map_or(0.0, |t| t.theta()),
                ..FollowerStep::default()
            };
            let fires = match law.triggering() {
                Some(t) => t.fires(k, own, f.fallback.offset(k), f.part()),
                None => {
                    let last = f.last_sent.as_ref().map(|(step, x)| (*step, x));
                    self.parts.beaconing.fires(k, f.id, own, last)
                }
            };
            // A head beacons at the leader's rate as well: the followers behind it take its
            // packets as their leader's.
            let heads = f.targets.leading && k.is_multiple_of(u64::from(every));
            let maneuver = self
                .maneuvers
                .as_mut()
                .and_then(|m| m.machines.next_message(f.id));
            if fires | heads | maneuver.is_some() {
                f.seq += 1;
                f.step.triggered = true;
                f.last_sent = Some((k, *own));
                if let Some(t) = law.triggering() {
                    t.sent(k, own);
                }
                out.push(Packet {
                    sender: f.id,
                    seq: f.seq,
                    step: k,
                    state: *own,
                    u: f.fallback.last_u(),
                    head: if f.targets.leading {
                        f.id
                    } else {
                        f.targets.head
                    },
                    maneuver,
                    seal: None,
                    group: None,
                });
            }
        }
        // Every packet of the step signed by its sender (`[security]`).
        self.checks.seal(k, &mut out[start..]);
    }

    fn set_radar_truth(&mut self, truth: &[Option<RadarTruth>]) {
        self.truths.give(truth, self.followers.len() + 1);
    }

    fn receive(&mut self, k: u64, states: &[State], rx: &[Delivery], jammed: &[bool]) -> &[f64] {
        let fb = &self.parts.fallback;
        {
            let truths = self.truths.take(states, |j| fb.length(j), true);
            // The radars first: the detectors read them too.
            let radar_any =
                fb.uses_radar() || self.checks.reads_radar() || self.maneuvers.is_some();
            let radars = self.followers.iter_mut().map(|f| &mut f.radar);
            read_radars(k, &fb.radar, radar_any, radars, truths, &mut self.readings);
        }
        self.checks.begin_step();
        if let Some(man) = self.maneuvers.as_mut() {
            man.begin_step();
        }
        let grouped = self.checks.security().is_some_and(|s| s.group.is_some());
        for (j, d) in rx.iter().enumerate() {
            // The seal first (`[security]`): a refused packet goes nowhere. The leader acts on
            // every packet it hears (its maneuver machine, its checks of maneuver messages).
            // Who is in the platoon, as the receiver knows it (the group key's checks only).
            let membership = match self.maneuvers.as_ref().filter(|_| grouped) {
                None => (true, true),
                Some(m) => {
                    let (to, from) = (d.receiver, d.packet.sender);
                    (
                        to.is_leader() || !m.machines.has_left(to),
                        m.machines.counts_as_member(to, from),
                    )
                }
            };
            if !self.checks.authenticate(k, d, membership)
                || (d.receiver.is_leader() && !self.checks.confirm(k, d))
            {
                continue;
            }
            match self.maneuvers.as_mut() {
                // Only maneuvers reach the leader: its machine reads their messages.
                Some(man) if d.receiver.is_leader() => {
                    man.leader_receives((k, j), d, states, &mut self.checks, &self.parts)
                }
                _ => self.admit((k, j), d, states),
            }
        }
        self.report_and_revoke(k, rx);
        if let Some(man) = self.maneuvers.as_mut() {
            let (followers, readings) = (&self.followers, &self.readings);
            man.step(k, states, followers, readings, &self.checks, &self.parts);
            // The messages the machines dropped as old: recorded after the step's others.
            for j in man.dropped_as_old() {
                self.checks.note_dropped_message(k, &rx[j]);
            }
        }
        let shared = Shared {
            k,
            parts: &self.parts,
            checks: &self.checks,
            man: self.maneuvers.as_ref().map(|m| &m.machines),
            states,
            truths: self.truths.current(),
            jammed,
            split: self.parts.fallback.cut_in.is_some_and(|c| c.split),
            ids: &self.ids,
        };
        for (((f, law), u), reading) in self
            .followers
            .iter_mut()
            .zip(&mut self.laws)
            .zip(self.commands.iter_mut())
            .zip(&self.readings)
        {
            *u = f.step(law.as_mut(), *reading, &shared);
        }
        &self.commands
    }

    fn commands(&self) -> &[f64] {
        &self.commands
    }

    fn follower_step(&self, i: VehicleId) -> FollowerStep {
        FollowerStep {
            revoked: self.revoked[i.index()],
            leader_revoked: self.revoked[0],
            ..self.followers[i.index() - 1].step
        }
    }

    fn checks(&self) -> Option<&PacketChecks> {
        Some(&self.checks)
    }

    fn time_crypto(&mut self, clock: crate::CryptoClock) {
        self.checks.time_crypto(clock);
    }
}

impl ComposedController {
    /// Step `k`'s misbehaviour reports (`[security.reports]`): each packet of `rx` a
    /// follower's detector flagged is reported, with what the reporter's radar saw; then the
    /// authority decides on the reports that reached it, every receiver refuses the packets of
    /// a vehicle it revokes, and the leader ejects that vehicle through the leave protocol.
    fn report_and_revoke(&mut self, k: u64, rx: &[Delivery]) {
        if self.checks.reports().is_none() {
            return;
        }
        let now_ms = crate::security::SecurityParams::now_ms(k, self.parts.dt);
        let flagged: Vec<_> = self
            .checks
            .inspections()
            .iter()
            .filter(|i| i.flagged && !i.receiver.is_leader() && !i.refused_by_checks())
            .map(|i| {
                let detector = i.verdicts().iter().position(|v| v.flagged).unwrap_or(0);
                (*i, detector as u8 + 1)
            })
            .collect();
        for (i, detector) in flagged {
            let Some(d) = rx.iter().find(|d| {
                let p = &d.packet;
                d.receiver == i.receiver
                    && p.sender == i.sender
                    && p.seq == i.seq
                    && p.step == i.step
            }) else {
                continue;
            };
            let observed = self.readings[i.receiver.index() - 1]
                .filter(|(r, _)| !r.intruder)
                .map(|(r, _)| platoon_security::RadarObservation {
                    at_ms: now_ms,
                    gap_m: r.gap,
                    relative_speed_mps: -r.closing,
                });
            self.checks
                .report(k, i.receiver, &d.packet, detector, observed);
        }
        // An insider's false reports: a genuine packet of the accused as "evidence".
        let liar = (self.parts.security)
            .and_then(|s| s.reports?.false_reports)
            .filter(|f| (f.start_ms..f.end_ms).contains(&now_ms));
        if let Some(f) = liar {
            let heard = rx.iter().find(|d| {
                d.receiver == f.reporter && d.packet.sender == f.accused && d.packet.seal.is_some()
            });
            if let Some(d) = heard {
                self.checks.report(k, f.reporter, &d.packet, 0, None);
            }
        }
        for v in self.checks.decide(k) {
            if let Some(r) = self.revoked.get_mut(v.index()) {
                *r = true;
            }
            if let Some(man) = self.maneuvers.as_mut() {
                man.machines.eject(k, v);
            }
        }
    }

    /// Delivery `j` of step `k` to a follower: the packet checks and detectors, then its
    /// maneuver message to its machine and its packet to its law (refused ones are counted and
    /// go nowhere).
    fn admit(&mut self, (k, j): (u64, usize), d: &Delivery, states: &[State]) {
        let fb = &self.parts.fallback;
        let sensed = sensed(k, self.parts.dt, d, states, &self.readings, |j| {
            fb.length(j)
        });
        let Some((fi, slot)) = self.checks.admit_sensed(k, d, sensed) else {
            return;
        };
        if let (Some(m), Some(man)) = (d.packet.maneuver, self.maneuvers.as_mut()) {
            man.hand_over(j, d, m);
        }
        self.laws[fi].heard(k, slot, &d.packet);
    }
}

#[cfg(test)]
mod tests;
