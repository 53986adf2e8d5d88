//! Ground truth for every delivered packet, measured on the wire: what a receiver got, set
//! against what was broadcast (the links the controllers published) and against the plant's true
//! states. Pure, like [`crate::tally`]: the in-process runner and the iceoryx2 orchestrator both
//! have the step's states, links and deliveries, so both can feed it and get the same labels.
//!
//! A delivery of step `k` is looked up by its (sender, sequence number) among the packets
//! broadcast within the horizon, and labelled by the first rule that holds:
//!
//! | label | rule |
//! |---|---|
//! | [`Label::Forged`] | no packet with that (sender, seq) was broadcast (within the horizon) |
//! | [`Label::Altered`] | its state (or `u`, or sampling step, or the head it announces, or the maneuver message it carries) differs from the broadcast one, bit for bit |
//! | [`Label::Replayed`] | this receiver already got an identical copy (same (sender, seq), same content) |
//! | [`Label::Delayed`] | broadcast at an earlier step (its first delivery to this receiver) |
//! | [`Label::Lied`] | as broadcast, but the broadcast state is not the sender's true state at its sampling step |
//! | [`Label::Genuine`] | as broadcast, in its step, and true |
//!
//! What the labeler sees is the wire between the controllers and the channel: `Altered` means
//! the channel (or an injector) changed the packet, `Lied` that the sender's controller itself
//! broadcast a false state. The built-in channel's insider attacks (`insider = true`) alter every
//! copy of a packet alike, as if its sender had lied, but they act after the broadcast, so they
//! are labelled `Altered`: nothing on the wire can tell a sender's lie told by the channel from
//! a channel's alteration of every copy, and the labels say where the change happened.
//!
//! Labels come from the content, never from the sequence number alone: a forger that uses a
//! sender's next sequence number before the sender does delivers a packet no broadcast backs
//! (`Forged`); the sender's own packet with that number, broadcast later, is still `Genuine` to a
//! receiver that got the forgery first, since the receiver never got a copy of *it*.
//!
//! `Replayed` and `Delayed` are about the receiver: an old packet it never got is `Delayed`,
//! so a replay attack that replaces every packet of a sender by an older one is, after its first
//! lag's worth, a delay on the wire (the old packets had been replaced too).
//!
//! Memory is bounded: broadcasts, deliveries and true states are kept for `horizon` steps. A
//! delivery referring to a broadcast older than that is labelled `Forged` (nothing in memory
//! backs it; no controller should act on a packet that old), and `Replayed` only when the
//! receiver's earlier copy is within the horizon (else `Delayed`).
use platoon_control::{Delivery, Packet};
use platoon_model::{State, VehicleId};
use serde::{Deserialize, Serialize};
use std::collections::hash_map::Entry;
use std::collections::{HashMap, VecDeque};

/// Which parts of a packet differ from another (or from the truth): a bitmask.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Fields(pub u8);

impl Fields {
    /// The position.
    pub const P: Fields = Fields(1);
    /// The speed.
    pub const V: Fields = Fields(2);
    /// The acceleration.
    pub const A: Fields = Fields(4);
    /// The sender's last command `u`.
    pub const U: Fields = Fields(8);
    /// The sampling step.
    pub const STEP: Fields = Fields(16);
    /// The head of the platoon the sender announces ([`Packet::head`]).
    pub const HEAD: Fields = Fields(32);
    /// The maneuver message it carries ([`Packet::maneuver`]: `[maneuvers]`).
    pub const MANEUVER: Fields = Fields(64);

    /// The components of `[p, v, a]` that differ bit for bit.
    pub fn of_states(a: &State, b: &State) -> Fields {
        let mut f = 0;
        for i in 0..3 {
            if a[i].to_bits() != b[i].to_bits() {
                f |= 1 << i;
            }
        }
        Fields(f)
    }

    /// What differs between two packets: state components, `u`, sampling step, head, maneuver
    /// message.
    pub fn of_packets(a: &Packet, b: &Packet) -> Fields {
        let mut f = Self::of_states(&a.state, &b.state);
        if a.u.to_bits() != b.u.to_bits() {
            f.0 |= Self::U.0;
        }
        if a.step != b.step {
            f.0 |= Self::STEP.0;
        }
        if a.head != b.head {
            f.0 |= Self::HEAD.0;
        }
        if a.maneuver != b.maneuver {
            f.0 |= Self::MANEUVER.0;
        }
        f
    }

    /// Each field with its name in files, in bit order.
    pub const NAMED: [(Fields, &'static str); 7] = [
        (Self::P, "p"),
        (Self::V, "v"),
        (Self::A, "a"),
        (Self::U, "u"),
        (Self::STEP, "step"),
        (Self::HEAD, "head"),
        (Self::MANEUVER, "maneuver"),
    ];

    /// The names of the fields it holds, in bit order (`["p", "maneuver"]`).
    pub fn names(self) -> Vec<&'static str> {
        Self::NAMED
            .iter()
            .filter(|(f, _)| self.contains(*f))
            .map(|&(_, n)| n)
            .collect()
    }

    /// Nothing differs.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Every field of `other` is in `self`.
    pub fn contains(self, other: Fields) -> bool {
        self.0 & other.0 == other.0
    }
}

/// What happened to one delivered packet, by the table of the [module](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "label")]
pub enum Label {
    /// Broadcast at this step, delivered as broadcast, and true.
    Genuine,
    /// Delivered with `fields` changed from the broadcast.
    Altered {
        /// What changed.
        fields: Fields,
    },
    /// Delivered as broadcast, but the sender broadcast a false state (`fields` differ from its
    /// true state at the packet's sampling step).
    Lied {
        /// What is false.
        fields: Fields,
    },
    /// Delivered as broadcast, for the first time to this receiver, at a later step.
    Delayed,
    /// Delivered as broadcast, again to a receiver that already got it.
    Replayed,
    /// Never broadcast (within the horizon): a ghost, a forged identity or sequence number.
    Forged,
}

impl Label {
    /// Its name in files.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Genuine => "genuine",
            Self::Altered { .. } => "altered",
            Self::Lied { .. } => "lied",
            Self::Delayed => "delayed",
            Self::Replayed => "replayed",
            Self::Forged => "forged",
        }
    }

    /// Anything but genuine.
    pub fn is_misbehaviour(&self) -> bool {
        *self != Self::Genuine
    }
}

/// One labelled delivery.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Labelled {
    /// The step it was delivered at.
    pub step: u64,
    /// What was delivered.
    pub delivery: Delivery,
    /// What happened to it.
    pub label: Label,
    /// The claimed sender's true state at the packet's (claimed) sampling step; `None` when the
    /// sender is no vehicle of the platoon or that step is not in memory (in the future, or
    /// older than the horizon).
    pub truth: Option<State>,
}

/// Deliveries by label (per run, or per anything the caller sums).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LabelCounts {
    /// [`Label::Genuine`].
    pub genuine: u64,
    /// [`Label::Altered`].
    pub altered: u64,
    /// [`Label::Lied`].
    pub lied: u64,
    /// [`Label::Delayed`].
    pub delayed: u64,
    /// [`Label::Replayed`].
    pub replayed: u64,
    /// [`Label::Forged`].
    pub forged: u64,
}

impl LabelCounts {
    /// Counts one label.
    pub fn count(&mut self, label: &Label) {
        *match label {
            Label::Genuine => &mut self.genuine,
            Label::Altered { .. } => &mut self.altered,
            Label::Lied { .. } => &mut self.lied,
            Label::Delayed => &mut self.delayed,
            Label::Replayed => &mut self.replayed,
            Label::Forged => &mut self.forged,
        } += 1;
    }

    /// Adds `other`.
    pub fn add(&mut self, other: &LabelCounts) {
        self.genuine += other.genuine;
        self.altered += other.altered;
        self.lied += other.lied;
        self.delayed += other.delayed;
        self.replayed += other.replayed;
        self.forged += other.forged;
    }

    /// Every delivery.
    pub fn total(&self) -> u64 {
        self.genuine + self.altered + self.lied + self.delayed + self.replayed + self.forged
    }
}

/// A broadcast as the labeler remembers it.
#[derive(Debug, Clone, Copy)]
struct Sent {
    /// The step it was broadcast at.
    step: u64,
    packet: Packet,
}

/// Labels one platoon's deliveries step by step (vehicle indices within the platoon, leader 0),
/// keeping what it needs for `horizon` steps.
#[derive(Debug, Clone)]
pub struct TruthLabeler {
    horizon: u64,
    /// True states of steps `first..`, `vehicles` per step.
    states: VecDeque<State>,
    first: u64,
    vehicles: usize,
    /// Broadcasts by (sender, seq); `sent_order` lists their keys by step, to forget them.
    sent: HashMap<(u16, u32), Sent>,
    sent_order: VecDeque<(u64, (u16, u32))>,
    /// Deliveries by (receiver, sender, seq): the contents delivered under that key (a forger
    /// may have used the key first with other content); `got_order` as above.
    got: HashMap<(u16, u16, u32), Vec<Packet>>,
    got_order: VecDeque<(u64, (u16, u16, u32))>,
    totals: LabelCounts,
}

impl TruthLabeler {
    /// A labeler remembering `horizon` steps (at least 1), e.g. 10 s worth of steps.
    pub fn new(horizon: u64) -> Self {
        Self {
            horizon: horizon.max(1),
            states: VecDeque::new(),
            first: 0,
            vehicles: 0,
            sent: HashMap::new(),
            sent_order: VecDeque::new(),
            got: HashMap::new(),
            got_order: VecDeque::new(),
            totals: LabelCounts::default(),
        }
    }

    /// A labeler remembering `horizon_s` seconds of steps of `dt` seconds.
    pub fn for_seconds(horizon_s: f64, dt: f64) -> Self {
        Self::new((horizon_s / dt).ceil() as u64)
    }

    /// Deliveries labelled so far, by label.
    pub fn totals(&self) -> &LabelCounts {
        &self.totals
    }

    /// Labels step `k` (one call per step, in order; after a gap the true states before it are
    /// forgotten): `states[v]` is vehicle
    /// v's true state at `k` (as the plant gave it to the controllers), `links` the step's
    /// broadcasts as (receiver, packet), one per link, `deliveries` what the receivers got.
    /// Appends one [`Labelled`] per delivery to `out`, in their order.
    ///
    /// A broadcast is remembered by (sender, seq) from its first link (the controllers send the
    /// same packet on every link of a broadcast).
    pub fn label(
        &mut self,
        k: u64,
        states: &[State],
        links: impl Iterator<Item = (VehicleId, Packet)>,
        deliveries: &[Delivery],
        out: &mut Vec<Labelled>,
    ) {
        self.remember_states(k, states);
        self.forget(k);
        for (_, p) in links {
            let key = (p.sender.0, p.seq);
            if let Entry::Vacant(e) = self.sent.entry(key) {
                e.insert(Sent { step: k, packet: p });
                self.sent_order.push_back((k, key));
            }
        }
        for d in deliveries {
            let label = self.label_one(k, d);
            let p = &d.packet;
            let got = (d.receiver.0, p.sender.0, p.seq);
            match self.got.entry(got) {
                Entry::Vacant(e) => {
                    e.insert(vec![*p]);
                    self.got_order.push_back((k, got));
                }
                Entry::Occupied(mut e) => {
                    if !e.get().iter().any(|q| Fields::of_packets(q, p).is_empty()) {
                        e.get_mut().push(*p);
                    }
                }
            }
            self.totals.count(&label);
            out.push(Labelled {
                step: k,
                delivery: *d,
                label,
                truth: self.truth(p.sender, p.step),
            });
        }
    }

    /// The label of delivery `d` at step `k`, by the table of the [module](self), before it is
    /// remembered as got.
    fn label_one(&self, k: u64, d: &Delivery) -> Label {
        let p = &d.packet;
        let Some(sent) = self.sent.get(&(p.sender.0, p.seq)) else {
            return Label::Forged;
        };
        let changed = Fields::of_packets(&sent.packet, p);
        if !changed.is_empty() {
            return Label::Altered { fields: changed };
        }
        // Replayed: this receiver already got this very content (not merely a packet that
        // used the same sequence number, which a forger may have done first).
        let again = self
            .got
            .get(&(d.receiver.0, p.sender.0, p.seq))
            .is_some_and(|copies| copies.iter().any(|q| Fields::of_packets(q, p).is_empty()));
        if again {
            Label::Replayed
        } else if sent.step < k {
            Label::Delayed
        } else {
            match self.truth(p.sender, p.step) {
                Some(x) if !Fields::of_states(&x, &p.state).is_empty() => Label::Lied {
                    fields: Fields::of_states(&x, &p.state),
                },
                _ => Label::Genuine,
            }
        }
    }

    /// Vehicle `v`'s true state at step `step`, if remembered.
    pub fn truth(&self, v: VehicleId, step: u64) -> Option<State> {
        if v.index() >= self.vehicles || step < self.first {
            return None;
        }
        let at = usize::try_from(step - self.first).ok()?;
        self.states.get(at * self.vehicles + v.index()).copied()
    }

    fn remember_states(&mut self, k: u64, states: &[State]) {
        let last = self.first + (self.states.len() / self.vehicles.max(1)) as u64;
        if self.vehicles != states.len() || self.states.is_empty() || k != last {
            // The first step, a skipped step, or another platoon size: start over.
            self.states.clear();
            self.vehicles = states.len();
            self.first = k;
        }
        self.states.extend(states.iter().copied());
    }

    /// Forgets everything older than `horizon` steps before `k`.
    fn forget(&mut self, k: u64) {
        let oldest = k.saturating_sub(self.horizon);
        while self.first < oldest && !self.states.is_empty() {
            self.states.drain(..self.vehicles);
            self.first += 1;
        }
        while self.sent_order.front().is_some_and(|(s, _)| *s < oldest) {
            let (_, key) = self.sent_order.pop_front().expect("checked non-empty");
            self.sent.remove(&key);
        }
        while self.got_order.front().is_some_and(|(s, _)| *s < oldest) {
            let (_, key) = self.got_order.pop_front().expect("checked non-empty");
            self.got.remove(&key);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pk(sender: u16, seq: u32, step: u64, p: f64) -> Packet {
        Packet::beacon(VehicleId(sender), seq, step, State::new(p, 15.0, 0.0))
    }

    fn to(receiver: u16, packet: Packet) -> Delivery {
        Delivery {
            receiver: VehicleId(receiver),
            packet,
        }
    }

    /// Vehicles at 100, 90, 80 m at every step.
    fn states() -> Vec<State> {
        (0..3)
            .map(|i| State::new(100.0 - 10.0 * f64::from(i), 15.0, 0.0))
            .collect()
    }

    fn step(
        sut: &mut TruthLabeler,
        k: u64,
        tx: &[(u16, Packet)],
        deliveries: &[Delivery],
    ) -> Vec<Label> {
        let mut out = Vec::new();
        sut.label(
            k,
            &states(),
            tx.iter().map(|&(r, p)| (VehicleId(r), p)),
            deliveries,
            &mut out,
        );
        assert_eq!(out.len(), deliveries.len());
        out.iter().map(|l| l.label).collect()
    }

    #[test]
    fn every_kind_of_delivery_gets_its_label() {
        let mut sut = TruthLabeler::new(100);
        let leader = pk(0, 1, 0, 100.0);
        let f1 = pk(1, 1, 0, 90.0);
        // The leader to 1 and 2, follower 1 to 2; follower 1's packet reaches 2 late.
        let mut altered = leader;
        altered.state[2] = -6.0;
        let labels = step(
            &mut sut,
            0,
            &[(1, leader), (2, leader), (2, f1)],
            &[to(1, leader), to(2, altered)],
        );
        assert_eq!(
            labels,
            [Label::Genuine, Label::Altered { fields: Fields::A }]
        );
        // Step 1: the late packet, the leader's again to 1 (replayed), a ghost with a fresh
        // identity, a forged sequence number of follower 1, and follower 1 lying by 1 m.
        let ghost = pk(7, 1, 1, 95.0);
        let lie = pk(1, 2, 1, 91.0);
        let labels = step(
            &mut sut,
            1,
            &[(2, lie)],
            &[
                to(2, f1),
                to(1, leader),
                to(2, ghost),
                to(2, pk(1, 9, 1, 90.0)),
                to(2, lie),
            ],
        );
        assert_eq!(
            labels,
            [
                Label::Delayed,
                Label::Replayed,
                Label::Forged,
                Label::Forged,
                Label::Lied { fields: Fields::P }
            ]
        );
        let t = sut.totals();
        assert_eq!(
            (t.genuine, t.altered, t.lied, t.delayed, t.replayed, t.forged),
            (1, 1, 1, 1, 1, 2)
        );
        assert_eq!(t.total(), 7);
    }

    #[test]
    fn a_forger_using_the_next_sequence_number_first_leaves_the_genuine_packet_genuine() {
        let mut sut = TruthLabeler::new(100);
        let genuine0 = pk(1, 1, 0, 90.0);
        assert_eq!(
            step(&mut sut, 0, &[(2, genuine0)], &[to(2, genuine0)]),
            [Label::Genuine]
        );
        // A forger delivers seq 2 in follower 1's name before follower 1 sends it, twice.
        let mut forged = pk(1, 2, 1, 90.0);
        forged.maneuver = Some(platoon_maneuver::Message {
            sender: VehicleId(1),
            to: VehicleId(0),
            seq: 9,
            body: platoon_maneuver::Body::LeaveNotice,
        });
        assert_eq!(
            step(&mut sut, 1, &[], &[to(2, forged), to(2, forged)]),
            [Label::Forged, Label::Forged]
        );
        // Follower 1's own seq 2, a step later: genuine to the receiver that got the forgery,
        // and a copy of it again is a replay; the forgery again is still forged.
        let genuine2 = pk(1, 2, 2, 90.0);
        assert_eq!(
            step(
                &mut sut,
                2,
                &[(2, genuine2)],
                &[to(2, genuine2), to(2, genuine2), to(2, forged)]
            ),
            [
                Label::Genuine,
                Label::Replayed,
                Label::Altered {
                    fields: Fields(Fields::STEP.0 | Fields::MANEUVER.0)
                }
            ]
        );
    }

    #[test]
    fn a_labelled_delivery_carries_the_claimed_senders_truth_at_its_step() {
        let mut sut = TruthLabeler::new(100);
        let mut out = Vec::new();
        let mut x = states();
        sut.label(0, &x, std::iter::empty(), &[], &mut out);
        x[1][0] = 91.0;
        // Follower 1 claims at step 1 the state it had at step 0 (a stale sample).
        let stale = pk(1, 1, 0, 90.0);
        sut.label(
            1,
            &x,
            [(VehicleId(2), stale)].into_iter(),
            &[
                to(2, stale),
                to(2, pk(5, 1, 1, 0.0)),
                to(2, pk(1, 3, 9, 0.0)),
            ],
            &mut out,
        );
        assert_eq!(out[0].truth, Some(State::new(90.0, 15.0, 0.0)));
        assert_eq!(out[0].label, Label::Genuine, "true at its sampling step");
        assert_eq!(out[1].truth, None, "no such vehicle");
        assert_eq!(out[2].truth, None, "a step not yet run");
    }

    #[test]
    fn memory_is_bounded_by_the_horizon() {
        let mut sut = TruthLabeler::new(10);
        let old = pk(1, 1, 0, 90.0);
        step(&mut sut, 0, &[(2, old)], &[to(2, old)]);
        for k in 1..10 {
            let p = pk(1, k as u32 + 1, k, 90.0);
            assert_eq!(step(&mut sut, k, &[(2, p)], &[to(2, p)]), [Label::Genuine]);
        }
        let p = pk(1, 11, 10, 90.0);
        assert_eq!(
            step(&mut sut, 10, &[(2, p)], &[to(2, p), to(2, old)]),
            [Label::Genuine, Label::Replayed]
        );
        // Beyond the horizon nothing backs it any more.
        assert_eq!(step(&mut sut, 11, &[], &[to(2, old)]), [Label::Forged]);
        assert!(sut.sent.len() <= 11 && sut.got.len() <= 11);
        assert_eq!(sut.states.len(), 11 * 3);
        assert_eq!(sut.truth(VehicleId(1), 0), None);
        assert!(sut.truth(VehicleId(1), 1).is_some());
    }
}
