//! The checks every received packet passes before a controller may use it, shared by every
//! [`crate::Controller`] implementation (and open to users writing their own): finite, from a
//! neighbour, not from the future, newer than the last one accepted from that sender, a
//! plausible sequence number and a state the sender can have reached. A refused packet is
//! counted by reason and changes nothing.

use crate::{Delivery, Packet};
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;

/// Packets a controller refused, by reason. A refused packet never changes an estimate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RejectCounts {
    /// NaN or infinite state.
    pub non_finite: u64,
    /// The sender is not one of the receiver's neighbours (or the receiver is not a follower).
    pub unknown_sender: u64,
    /// Sampled at a step later than the current one.
    pub future_step: u64,
    /// Not newer than the last packet accepted from that sender: sampled at the same or an
    /// earlier step (a replay, a duplicate, or a delayed packet overtaken by a newer one).
    pub stale_seq: u64,
    /// A sequence number ahead of what the sender can have sent by the packet's step (a vehicle
    /// broadcasts at most once per step, so `seq <= step + 1`).
    pub implausible_seq: u64,
    /// A state no vehicle can reach from the sender's last accepted state in the elapsed time
    /// (|a| above [`PLAUSIBLE_ACCEL`], or a jump in speed or position beyond it).
    pub implausible_state: u64,
}

impl RejectCounts {
    /// Total of all reasons.
    pub fn total(&self) -> u64 {
        self.as_array().iter().sum()
    }

    /// The counts in wire order: non-finite, unknown sender, future step, stale, implausible
    /// sequence number, implausible state.
    pub fn as_array(&self) -> [u64; 6] {
        [
            self.non_finite,
            self.unknown_sender,
            self.future_step,
            self.stale_seq,
            self.implausible_seq,
            self.implausible_state,
        ]
    }

    /// From [`RejectCounts::as_array`]'s order.
    pub fn from_array([a, b, c, d, e, f]: [u64; 6]) -> Self {
        Self {
            non_finite: a,
            unknown_sender: b,
            future_step: c,
            stale_seq: d,
            implausible_seq: e,
            implausible_state: f,
        }
    }
}

/// What refused a delivery: a packet check (named as in [`RejectCounts`]), the detectors'
/// reaction or the leader's check of maneuver messages. The per-message dataset's `refused_by`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RefusedBy {
    /// [`RejectCounts::non_finite`].
    NonFinite,
    /// [`RejectCounts::unknown_sender`].
    UnknownSender,
    /// [`RejectCounts::future_step`].
    FutureStep,
    /// [`RejectCounts::stale_seq`]: the sequence filter (a replay, a duplicate, an overtaken
    /// packet).
    StaleSeq,
    /// [`RejectCounts::implausible_seq`].
    ImplausibleSeq,
    /// [`RejectCounts::implausible_state`].
    ImplausibleState,
    /// The detectors' reaction (`[detection] reaction`: a flag, or a distrusted sender).
    Reaction,
    /// The leader's check of maneuver messages (`[maneuvers] check_reports`: a request from a
    /// vehicle it never heard, a report its sender's beacon contradicts).
    CheckReports,
    /// The maneuver protocol's sequence filter: the message the packet carried was dropped as
    /// old by the receiver's machine (a replay, a duplicate, one numbered below a message it
    /// took); the packet itself was taken.
    ManeuverSeq,
    /// The seal of signed V2V (`[security]`, [`crate::security`]): the
    /// `platoon_security::Refusal` of this code (1-14), named by its name in files
    /// (`bad_signature`, ...). Checked before the packet checks.
    Seal(u8),
}

impl RefusedBy {
    /// Every reason but the seal's, in the order of [`RefusedBy::code`] (1 first).
    pub const ALL: [RefusedBy; 9] = [
        Self::NonFinite,
        Self::UnknownSender,
        Self::FutureStep,
        Self::StaleSeq,
        Self::ImplausibleSeq,
        Self::ImplausibleState,
        Self::Reaction,
        Self::CheckReports,
        Self::ManeuverSeq,
    ];

    /// Its name in files (`stale_seq`, ...; a seal's reason by its own name, `bad_signature`,
    /// ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::Seal(code) => platoon_security::Refusal::ALL
                .get(usize::from(code).wrapping_sub(1))
                .map_or("seal", |r| r.name()),
            Self::NonFinite => "non_finite",
            Self::UnknownSender => "unknown_sender",
            Self::FutureStep => "future_step",
            Self::StaleSeq => "stale_seq",
            Self::ImplausibleSeq => "implausible_seq",
            Self::ImplausibleState => "implausible_state",
            Self::Reaction => "reaction",
            Self::CheckReports => "check_reports",
            Self::ManeuverSeq => "maneuver_seq",
        }
    }

    /// Its code on the wire (1 to 9; a seal's reason `r`: [`RefusedBy::SEAL_CODES`] + r, 10
    /// to 23; 0 is no refusal).
    pub fn code(self) -> u8 {
        if let Self::Seal(r) = self {
            return Self::SEAL_CODES + r;
        }
        Self::ALL
            .iter()
            .position(|&r| r == self)
            .map_or(0, |i| i as u8 + 1)
    }

    /// Where the seal's reasons start on the wire: reason `r` (1-14) is code 9 + r.
    pub const SEAL_CODES: u8 = 9;

    /// The reason of code `code` (`None` for 0 or a code it does not know).
    pub fn from_code(code: u8) -> Option<Self> {
        if (Self::SEAL_CODES + 1..=Self::SEAL_CODES + platoon_security::Refusal::ALL.len() as u8)
            .contains(&code)
        {
            return Some(Self::Seal(code - Self::SEAL_CODES));
        }
        usize::from(code)
            .checked_sub(1)
            .and_then(|i| Self::ALL.get(i).copied())
    }

    /// One of the packet checks' reasons (before any detector saw the packet).
    pub fn by_checks(self) -> bool {
        !matches!(
            self,
            Self::Reaction | Self::CheckReports | Self::ManeuverSeq
        )
    }

    /// The packet itself was refused (`false` only for [`RefusedBy::ManeuverSeq`], which
    /// dropped the message it carried).
    pub fn refuses_packet(self) -> bool {
        self != Self::ManeuverSeq
    }
}

/// The largest acceleration any vehicle can have (m/s^2, 5 g): a packet whose state implies a
/// larger one since the sender's last accepted packet is refused as implausible.
pub const PLAUSIBLE_ACCEL: f64 = 50.0;

/// The last packet accepted from one neighbour (at first, the initial state, assumed delivered
/// at step 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Heard {
    /// The step it was sampled at (`None`: the initial state).
    pub step: Option<u64>,
    /// Its sequence number (0 for the initial state).
    pub seq: u32,
    /// The sampled state `[p, v, a]`.
    pub state: State,
    /// The sender's command it carried ([`Packet::u`]; 0 for the initial state).
    pub u: f64,
    /// The head it announced ([`Packet::head`]; the leader for the initial state).
    pub head: VehicleId,
}

impl Heard {
    /// Whether its sender announced that it heads a split platoon ([`Packet::heads`]).
    pub fn heads(&self, sender: VehicleId) -> bool {
        self.head == sender && !sender.is_leader()
    }
}

/// The packet checks of one platoon's followers: who each may hear from, the last packet
/// accepted from each of them, and the refusals so far.
#[derive(Debug, Clone)]
pub struct PacketChecks {
    /// Per follower: its graph's in-neighbours, then the members ahead it hears besides them
    /// when the platoon may split (`PacketChecks::hearing_all_ahead`).
    neighbours: Vec<Vec<VehicleId>>,
    /// Per follower: how many of `neighbours` are its graph's.
    graph: Vec<usize>,
    heard: Vec<Vec<Heard>>,
    rejected: RejectCounts,
    dt: f64,
    /// Misbehaviour detection after the checks (`[detection]`), if on.
    screening: Option<crate::screening::Screening>,
    /// Signed V2V (`[security]`), if on: the seals' checks before the others.
    sealing: Option<Box<crate::security::Sealing>>,
}

impl PacketChecks {
    /// Checks for the followers of `topology` (each hears its in-neighbours), with the initial
    /// states (`initial[0]` is the leader's) as what was last heard; `dt` is the step (s).
    pub fn new(topology: &Topology, initial: &[State], dt: f64) -> Self {
        let neighbours: Vec<Vec<VehicleId>> = (1..=topology.followers())
            .map(|i| topology.in_neighbours(VehicleId::follower(i)).to_vec())
            .collect();
        let heard = neighbours
            .iter()
            .map(|ns| {
                ns.iter()
                    .map(|j| Heard {
                        step: None,
                        seq: 0,
                        state: initial[j.index()],
                        u: 0.0,
                        head: VehicleId::LEADER,
                    })
                    .collect()
            })
            .collect();
        Self {
            graph: neighbours.iter().map(Vec::len).collect(),
            neighbours,
            heard,
            rejected: RejectCounts::default(),
            dt,
            screening: None,
            sealing: None,
        }
    }

    /// These checks with signed V2V (`[security]`; none: unchanged) for `vehicles` vehicles,
    /// the leader included: [`PacketChecks::seal`] signs what they send, every delivery's seal
    /// is checked before the other checks ([`crate::security`]).
    pub fn with_security(
        mut self,
        security: Option<crate::SecurityParams>,
        vehicles: usize,
        outside: &[VehicleId],
    ) -> Self {
        self.sealing = security.map(|p| {
            Box::new(crate::security::Sealing::with_outside(
                p, vehicles, self.dt, outside,
            ))
        });
        self
    }

    /// Whether the leader has a renewed group key left to send (`[security.group]`).
    pub fn leader_has_keys_to_send(&self) -> bool {
        self.sealing
            .as_ref()
            .is_some_and(|s| s.leader_has_keys_to_send())
    }

    /// Signs `packets` sent at step `k` with their senders' pseudonyms (`[security]`; nothing
    /// without it).
    pub fn seal(&mut self, k: u64, packets: &mut [Packet]) {
        if let Some(s) = &mut self.sealing {
            s.seal(k, packets);
        }
    }

    /// The seal's first check of delivery `d` at step `k` (`[security]`: in full, or all but
    /// the signature under `on_demand`); `true` without security. A refused packet is counted
    /// by its reason ([`PacketChecks::seals`]) and goes nowhere.
    /// With `[security.group]`, the group key's check follows (`membership`: the receiver is
    /// a member of its platoon, and it counts the sender as one).
    pub fn authenticate(&mut self, k: u64, d: &Delivery, membership: (bool, bool)) -> bool {
        let outcome = (self.sealing.as_mut()).map(|s| {
            s.screen(k, d)
                .and_then(|()| s.check_group(k, d, membership))
        });
        self.sealed(k, d, outcome)
    }

    /// Whether a seal's check let delivery `d` through; a refusal goes to the dataset's
    /// `refused_by` when the run measures detectors.
    fn sealed(
        &mut self,
        k: u64,
        d: &Delivery,
        outcome: Option<Result<(), platoon_security::Refusal>>,
    ) -> bool {
        match outcome {
            Some(Err(why)) => {
                if let Some(s) = &mut self.screening {
                    s.refusal(k, d.receiver, &d.packet, RefusedBy::Seal(why.code()));
                }
                false
            }
            _ => true,
        }
    }

    /// The signature check of a delivery its receiver acts on, under `on_demand` (`true`
    /// otherwise: [`PacketChecks::authenticate`] made it).
    pub fn confirm(&mut self, k: u64, d: &Delivery) -> bool {
        let outcome = self.sealing.as_mut().map(|s| s.confirm(k, d));
        self.sealed(k, d, outcome)
    }

    /// What the seals did so far (`[security]` only).
    pub fn seals(&self) -> Option<crate::security::SealCounts> {
        self.sealing.as_ref().map(|s| s.counts())
    }

    /// What the misbehaviour reports did so far (`[security.reports]` only).
    pub fn reports(&self) -> Option<&crate::security::ReportCounts> {
        self.sealing.as_ref().and_then(|s| s.reports())
    }

    /// The misbehaviour authority's revocations so far (`[security.reports]` only).
    pub fn revocations(&self) -> &[platoon_security::Revocation] {
        self.sealing.as_ref().map_or(&[], |s| s.revocations())
    }

    /// A follower's detector flagged a packet: a report to the authority
    /// ([`crate::security::Sealing::report`]; nothing without `[security.reports]`).
    pub fn report(
        &mut self,
        k: u64,
        reporter: VehicleId,
        packet: &Packet,
        detector: u8,
        observed: Option<platoon_security::RadarObservation>,
    ) {
        if let Some(s) = &mut self.sealing {
            s.report(k, reporter, packet, detector, observed);
        }
    }

    /// The authority's decisions at the end of step `k`: the vehicles it revoked, whose
    /// packets every receiver refuses from then on ([`crate::security::Sealing::decide`]).
    pub fn decide(&mut self, k: u64) -> Vec<VehicleId> {
        self.sealing.as_mut().map_or_else(Vec::new, |s| s.decide(k))
    }

    /// Times the seals' signing and verifying with the runtime's `clock` (`[security]`;
    /// nothing without it).
    pub fn time_crypto(&mut self, clock: crate::CryptoClock) {
        if let Some(s) = &mut self.sealing {
            s.time_with(clock);
        }
    }

    /// The time the seals' cryptography took so far by the clock of
    /// [`PacketChecks::time_crypto`] (`[security]` only).
    pub fn crypto_time(&self) -> Option<crate::CryptoTime> {
        self.sealing.as_ref().map(|s| s.crypto_time())
    }

    /// The signed V2V settings (`[security]` only).
    pub fn security(&self) -> Option<&crate::SecurityParams> {
        self.sealing.as_ref().map(|s| s.params())
    }

    /// These checks with every follower also hearing every member ahead of it that is not its
    /// graph's neighbour (`initial` as at [`PacketChecks::new`]): a platoon that may split
    /// behind a car that cut in ([`platoon_topology::Topology::hearing_all_ahead`]). Their
    /// packets pass the same checks; [`PacketChecks::neighbours`] and [`PacketChecks::heard`]
    /// still list the graph's neighbours only, [`PacketChecks::heard_from`] reaches them all.
    /// Before the detectors are added (their state is kept per neighbour).
    pub(crate) fn hearing_all_ahead(self, initial: &[State]) -> Self {
        self.hearing_also(initial, |fi| (1..=fi).map(VehicleId::follower).collect())
    }

    /// These checks with every follower also hearing every other vehicle, the leader and the
    /// members behind it included: a platoon that negotiates maneuvers
    /// ([`platoon_topology::Topology::hearing_everyone`]); as [`PacketChecks::hearing_all_ahead`]
    /// otherwise.
    pub(crate) fn hearing_everyone(self, initial: &[State]) -> Self {
        let n = self.neighbours.len();
        self.hearing_also(initial, |fi| {
            (0..=n)
                .filter(|&j| j != fi + 1)
                .map(|j| VehicleId(j as u16))
                .collect()
        })
    }

    /// These checks with follower `fi + 1` also hearing `also(fi)` (those not its graph's
    /// neighbours already), with the initial states as what was last heard.
    fn hearing_also(mut self, initial: &[State], also: impl Fn(usize) -> Vec<VehicleId>) -> Self {
        for (fi, (ns, heard)) in self.neighbours.iter_mut().zip(&mut self.heard).enumerate() {
            for j in also(fi) {
                if !ns.contains(&j) {
                    ns.push(j);
                    heard.push(Heard {
                        step: None,
                        seq: 0,
                        state: initial[j.index()],
                        u: 0.0,
                        head: VehicleId::LEADER,
                    });
                }
            }
        }
        self
    }

    /// These checks followed by the detectors of `detection` (nothing changes when none is
    /// on): see [`crate::screening`].
    pub fn with_detection(
        self,
        detection: &crate::DetectionParams,
    ) -> Result<Self, crate::screening::ParamError> {
        self.with_detection_and(detection, Vec::new())
    }

    /// [`PacketChecks::with_detection`] with the caller's `extra` detectors after those of
    /// `detection`, under its reaction (on when either has one).
    pub fn with_detection_and(
        mut self,
        detection: &crate::DetectionParams,
        extra: Vec<Box<dyn crate::screening::Detector>>,
    ) -> Result<Self, crate::screening::ParamError> {
        if detection.is_on() || !extra.is_empty() {
            self.screening = Some(crate::screening::Screening::new(
                detection,
                extra,
                &self.neighbours,
                self.dt,
            )?);
        }
        Ok(self)
    }

    /// These checks followed by detectors of the caller's own (any [`platoon_detect::Detector`],
    /// at most [`crate::screening::MAX_DETECTORS`]) and `reaction` with a quiet period of
    /// `quiet_steps`: for a controller of one's own, or to add to the built-in detectors'
    /// list (`Detectors::from_specs` then `push`).
    pub fn with_detectors(
        mut self,
        detectors: crate::screening::Detectors,
        reaction: crate::Reaction,
        quiet_steps: u32,
    ) -> Self {
        self.screening = (!detectors.is_empty()).then(|| {
            crate::screening::Screening::with(
                detectors,
                reaction,
                quiet_steps,
                &self.neighbours,
                self.dt,
            )
        });
        self
    }

    /// Starts step `k`'s deliveries: clears the last step's [`PacketChecks::inspections`].
    pub fn begin_step(&mut self) {
        if let Some(s) = &mut self.screening {
            s.begin_step();
        }
        if let Some(s) = &mut self.sealing {
            s.begin_step();
        }
    }

    /// [`PacketChecks::admit`], then, for a packet that passed, the detectors with what the
    /// receiver senses, and the reaction: a refused packet changes nothing.
    pub fn admit_sensed(
        &mut self,
        k: u64,
        d: &Delivery,
        sensed: crate::screening::Sensed,
    ) -> Option<(usize, usize)> {
        let (fi, s) = self.verify(k, d)?;
        if let Some(screening) = &mut self.screening {
            let heard = self.heard[fi][s];
            // The initial state counts as heard at step 0, as for the checks above.
            let last = Some(platoon_detect::Last {
                step: heard.step.unwrap_or(0),
                state: heard.state,
            });
            if screening.screen(k, (fi, s), d.receiver, &d.packet, last, sensed) {
                return None;
            }
        }
        self.heard[fi][s] = Heard::from(&d.packet);
        Some((fi, s))
    }

    /// Whether follower `i` (1-based) distrusts a neighbour at step `k` so much that it runs
    /// its fallback (`reaction = "fallback"`).
    pub fn distrusts(&self, i: VehicleId, k: u64) -> bool {
        self.screening
            .as_ref()
            .is_some_and(|s| s.affects(i.index() - 1, k))
    }

    /// What the detectors said of each packet of the current step (empty without detection).
    pub fn inspections(&self) -> &[crate::screening::Inspection] {
        self.screening.as_ref().map_or(&[], |s| s.log())
    }

    /// Whether a detector may read the radar: a controller reads it every step then.
    pub fn reads_radar(&self) -> bool {
        self.screening.as_ref().is_some_and(|s| s.reads_radar())
    }

    /// The detectors' names, in the order of every inspection's verdicts.
    pub fn detector_names(&self) -> &[&'static str] {
        self.screening.as_ref().map_or(&[], |s| s.names())
    }

    /// Packets inspected, flagged and refused by the reaction so far.
    pub fn screened(&self) -> crate::screening::ScreenCounts {
        self.screening
            .as_ref()
            .map(|s| s.counts())
            .unwrap_or_default()
    }

    /// Checks one delivery at step `k`. Accepted: recorded as the last heard from its sender,
    /// and `(i - 1, s)` returned, i the receiving follower and s the sender's place in
    /// [`PacketChecks::neighbours`]`(i)`. Refused: counted, `None`.
    pub fn admit(&mut self, k: u64, d: &Delivery) -> Option<(usize, usize)> {
        let (fi, s) = self.verify(k, d)?;
        self.heard[fi][s] = Heard::from(&d.packet);
        Some((fi, s))
    }

    /// The checks of [`PacketChecks::admit`] without recording the packet.
    fn verify(&mut self, k: u64, d: &Delivery) -> Option<(usize, usize)> {
        let checked = self.check(k, d);
        if let Err(why) = checked {
            let r = &mut self.rejected;
            *match why {
                RefusedBy::NonFinite => &mut r.non_finite,
                RefusedBy::FutureStep => &mut r.future_step,
                RefusedBy::UnknownSender => &mut r.unknown_sender,
                RefusedBy::StaleSeq => &mut r.stale_seq,
                RefusedBy::ImplausibleSeq => &mut r.implausible_seq,
                _ => &mut r.implausible_state,
            } += 1;
            if let Some(s) = &mut self.screening {
                s.refusal(k, d.receiver, &d.packet, why);
            }
        }
        // A packet the receiver will act on: its signature now, under `on_demand`.
        if checked.is_ok() && !self.confirm(k, d) {
            return None;
        }
        checked.ok()
    }

    /// The checks of [`PacketChecks::verify`]: the slot, or the first reason to refuse.
    fn check(&self, k: u64, d: &Delivery) -> Result<(usize, usize), RefusedBy> {
        let pk = &d.packet;
        if pk.state.iter().any(|x| !x.is_finite()) || !pk.u.is_finite() {
            return Err(RefusedBy::NonFinite);
        }
        if pk.step > k {
            return Err(RefusedBy::FutureStep);
        }
        let r = d.receiver.index();
        let slot = (r >= 1 && r <= self.neighbours.len())
            .then(|| {
                self.neighbours[r - 1]
                    .iter()
                    .position(|&j| j == pk.sender)
                    .map(|s| (r - 1, s))
            })
            .flatten();
        let Some((fi, s)) = slot else {
            return Err(RefusedBy::UnknownSender);
        };
        // Freshness by the sampling step, not by the sequence number alone: a forged packet
        // with a huge sequence number would otherwise lock the genuine sender out for good.
        // A forged packet that passes can hold off genuine ones of its own step
        // only, since steps ahead of the receiver's are refused above.
        let heard = self.heard[fi][s];
        if heard.step.is_some_and(|h| pk.step <= h) {
            return Err(RefusedBy::StaleSeq);
        }
        if u64::from(pk.seq) > pk.step + 1 {
            return Err(RefusedBy::ImplausibleSeq);
        }
        let since = heard.step.unwrap_or(0);
        if !plausible(&heard.state, &pk.state, (pk.step - since) as f64 * self.dt) {
            return Err(RefusedBy::ImplausibleState);
        }
        Ok((fi, s))
    }

    /// Whom follower `i` (1-based) hears from in its graph, in the order of
    /// [`PacketChecks::heard`].
    pub fn neighbours(&self, i: VehicleId) -> &[VehicleId] {
        &self.neighbours[i.index() - 1][..self.graph[i.index() - 1]]
    }

    /// Every vehicle follower `i` (1-based) accepts packets from, its graph's neighbours first
    /// (as [`PacketChecks::neighbours`]), then those it also hears in a platoon that may split
    /// or negotiates maneuvers: the slots of what it heard.
    pub fn hearing(&self, i: VehicleId) -> &[VehicleId] {
        &self.neighbours[i.index() - 1]
    }

    /// The last packet accepted by follower `i` (1-based) from each of its graph's neighbours.
    pub fn heard(&self, i: VehicleId) -> &[Heard] {
        &self.heard[i.index() - 1][..self.graph[i.index() - 1]]
    }

    /// The last packet accepted by follower `i` from vehicle `j`, a neighbour in its graph or,
    /// when the platoon may split behind a cut-in (`[fallback.cut_in] split`), any member ahead.
    pub fn heard_from(&self, i: VehicleId, j: VehicleId) -> Option<&Heard> {
        let fi = i.index() - 1;
        let s = self.neighbours[fi].iter().position(|&n| n == j)?;
        Some(&self.heard[fi][s])
    }

    /// Packets refused so far.
    pub fn rejected(&self) -> RejectCounts {
        self.rejected
    }

    /// Records, when the run measures detectors, that the leader checked a maneuver message
    /// of delivery `d` at step `k` (`[maneuvers] check_reports`) and whether it `refused` it:
    /// an inspection of the leader's, scored against ground truth apart from the detectors.
    pub fn note_leader_check(&mut self, k: u64, d: &Delivery, refused: bool) {
        if let Some(s) = &mut self.screening {
            s.note(k, d.receiver, &d.packet, refused);
        }
    }

    /// Records, when the run measures detectors, that the maneuver message of delivery `d`
    /// (step `k`) was dropped as old by its receiver's protocol machine (its sequence filter),
    /// the packet's beacon having been taken: not a refusal of the packet, not counted.
    pub fn note_dropped_message(&mut self, k: u64, d: &Delivery) {
        if let Some(s) = &mut self.screening {
            s.refusal(k, d.receiver, &d.packet, RefusedBy::ManeuverSeq);
        }
    }

    /// Counts a packet a receiver refused on a check of its own, beyond
    /// [`PacketChecks::admit`], as from a sender it does not know (the leader's check of a
    /// join request from a vehicle it never heard, `[maneuvers] check_reports`).
    pub fn refuse_unknown_sender(&mut self) {
        self.rejected.unknown_sender += 1;
    }

    /// Counts a packet a receiver refused on a check of its own as claiming what its sender
    /// cannot be (the leader's check of an in-position report against the sender's beacon).
    pub fn refuse_implausible_state(&mut self) {
        self.rejected.implausible_state += 1;
    }
}

/// A packet as a receiver last accepted it.
impl From<&Packet> for Heard {
    fn from(p: &Packet) -> Self {
        Self {
            step: Some(p.step),
            seq: p.seq,
            state: p.state,
            u: p.u,
            head: p.head,
        }
    }
}

/// Whether a vehicle at `from` can be at `to` after `t` seconds with |a| <= [`PLAUSIBLE_ACCEL`]
/// (|v - v0| <= A t, |p - p0 - v0 t| <= A t^2 / 2), with room for rounding.
fn plausible(from: &State, to: &State, t: f64) -> bool {
    let a = PLAUSIBLE_ACCEL;
    let tol = 1e-6 + 1e-12 * from[0].abs().max(to[0].abs());
    to[2].abs() <= a
        && (to[1] - from[1]).abs() <= a * t + tol
        && (to[0] - from[0] - from[1] * t).abs() <= 0.5 * a * t * t + tol
}
