//! The V2V channel between the controllers: what each receiver gets from each broadcast, under the
//! DoS schedule and the link-level attack models. Pure and seeded: the in-process runner and the
//! iceoryx2 injector process run this same code, so they deliver the same packets bit for bit.
mod events;

use crate::jammer::Jammers;
pub use crate::medium::{BackgroundBeacons, Dcc, LoadSource, RadioSpec, RadioStats};
use crate::medium::{Gated, Medium};
use crate::DosSchedule;
use events::event;
pub use events::{Action, ChannelEvent};
use platoon_maneuver::{Body, Message, MessageKind};
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;
use platoon_v2v::{Delivery, Packet};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::VecDeque;

/// One link-level attack model.
#[derive(Debug, Clone, PartialEq)]
pub enum LinkAttackKind {
    /// Each packet on each targeted link is lost with probability `loss`.
    Bernoulli {
        /// Loss probability in `[0, 1]`.
        loss: f64,
    },
    /// Burst loss: a two-state (good/bad) Markov chain per link, advanced once per packet on
    /// that link; a packet is lost with `loss_good` or `loss_bad` depending on the state.
    GilbertElliott {
        /// Probability of going from good to bad.
        p_good_bad: f64,
        /// Probability of going from bad to good.
        p_bad_good: f64,
        /// Loss probability in the good state.
        loss_good: f64,
        /// Loss probability in the bad state.
        loss_bad: f64,
    },
    /// Every targeted packet arrives `steps` steps late (the receiver propagates it open-loop).
    Delay {
        /// Delay in steps, >= 1.
        steps: u32,
    },
    /// A jammer (e.g. a drone) at `position_m + speed_mps t` along the road: a vehicle within
    /// `radius_m` of it can neither send nor receive, and senses its channel jammed.
    RangeJamming {
        /// Jammer position at t = 0 (m, road coordinate of the platoon).
        position_m: f64,
        /// Jammer speed (m/s).
        speed_mps: f64,
        /// Jamming radius (m).
        radius_m: f64,
    },
    /// The targeted senders' packets are replaced by the ones they sent `lag_steps` earlier, with
    /// their old sequence numbers (a receiver that checks sequence numbers refuses them).
    Replay {
        /// How far back the replayed packet was captured (steps), >= 1.
        lag_steps: u64,
    },
    /// False data injection: `offset` is added to the state in the targeted senders' packets.
    FalseData {
        /// Offset on `[p, v, a]`.
        offset: [f64; 3],
    },
    /// Random false data: zero-mean normal noise with standard deviation `std` (per component)
    /// is added to the state, drawn per packet and link from the channel's seeded stream (per
    /// packet for an insider, [`LinkAttack::acts_as`]).
    RandomOffset {
        /// Standard deviation on `[p, v, a]`, >= 0.
        std: [f64; 3],
    },
    /// A slow drift: the offset `rate (t - start_s)` grows linearly from the attack's start
    /// (sized to stay inside sensor noise, it hides from plausibility checks for a while).
    Drift {
        /// Growth of the offset on `[p, v, a]` per second.
        rate: [f64; 3],
    },
    /// Feigned braking: the claimed acceleration is replaced by `accel` (e.g. -6 m/s^2);
    /// position and speed stay true.
    FeignedBraking {
        /// The claimed acceleration (m/s^2).
        accel: f64,
    },
    /// The claimed acceleration multiplied by `factor`; position and speed stay true.
    AccelScale {
        /// The factor.
        factor: f64,
    },
    /// A forged formation update: the targeted senders' packets announce that the sender heads
    /// a platoon split behind a cut-in (`Packet::head` = the sender), so the followers behind it
    /// that split (`[fallback.cut_in] split`) take it as their leader; the state stays true.
    ForgedHead,
    /// A jammer that reacts to maneuver messages: every targeted packet that carries one of the
    /// kinds in `kinds` (a set of [`MessageKind::bit`]s) is lost (a maneuver jammed half way:
    /// the move-in, say).
    JamManeuvers {
        /// The kinds jammed.
        kinds: u16,
    },
    /// A forged maneuver message: the targeted senders' packets carry `message` from the
    /// sender to its leader (a join request nobody made, a leave notice nobody sent, an
    /// in-position report of a joiner that is not in its slot), with the highest sequence
    /// number (so the receiver takes it, and drops that sender's later messages as old); the
    /// state stays true.
    ForgeManeuver {
        /// What it says: [`MessageKind::JoinRequest`] (for the slot behind the vehicle numbered
        /// just ahead of the sender), [`MessageKind::LeaveNotice`], [`MessageKind::InPosition`]
        /// or [`MessageKind::SplitNotice`].
        message: MessageKind,
    },
}

impl LinkAttackKind {
    /// The config name of the model.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Bernoulli { .. } => "bernoulli",
            Self::GilbertElliott { .. } => "gilbert_elliott",
            Self::Delay { .. } => "delay",
            Self::RangeJamming { .. } => "range_jamming",
            Self::Replay { .. } => "replay",
            Self::FalseData { .. } => "false_data",
            Self::RandomOffset { .. } => "random_offset",
            Self::Drift { .. } => "drift",
            Self::FeignedBraking { .. } => "feigned_braking",
            Self::AccelScale { .. } => "accel_scale",
            Self::ForgedHead => "forged_head",
            Self::JamManeuvers { .. } => "jam_maneuvers",
            Self::ForgeManeuver { .. } => "forge_maneuver",
        }
    }

    /// Whether the model alters what a packet says (its state, or the formation it announces):
    /// the kinds an insider can be given.
    pub fn alters_state(&self) -> bool {
        matches!(
            self,
            Self::FalseData { .. }
                | Self::RandomOffset { .. }
                | Self::Drift { .. }
                | Self::FeignedBraking { .. }
                | Self::AccelScale { .. }
                | Self::ForgedHead
                | Self::ForgeManeuver { .. }
        )
    }

    /// Alters `packet` as the model says at `since_s` after the attack's start (drawing from
    /// `rng` for the random offset); false for the kinds that do not alter what it says.
    fn alter(&self, since_s: f64, packet: &mut Packet, rng: &mut ChaCha8Rng) -> bool {
        let state = &mut packet.state;
        match *self {
            Self::FalseData { offset } => *state += State::from(offset),
            Self::RandomOffset { std } => {
                let z = [normal(rng), normal(rng), normal(rng)];
                *state += State::new(std[0] * z[0], std[1] * z[1], std[2] * z[2]);
            }
            Self::Drift { rate } => {
                *state += State::new(rate[0] * since_s, rate[1] * since_s, rate[2] * since_s);
            }
            Self::FeignedBraking { accel } => state[2] = accel,
            Self::AccelScale { factor } => state[2] *= factor,
            Self::ForgedHead => packet.head = packet.sender,
            Self::ForgeManeuver { message } => {
                let body = match message {
                    // The slot behind the vehicle numbered just ahead of the sender: for a
                    // joiner numbered after the platoon, its tail.
                    MessageKind::JoinRequest => Body::JoinRequest {
                        behind: VehicleId(packet.sender.0.saturating_sub(1)),
                    },
                    MessageKind::InPosition => Body::InPosition,
                    MessageKind::SplitNotice => Body::SplitNotice,
                    _ => Body::LeaveNotice,
                };
                packet.maneuver = Some(Message {
                    sender: packet.sender,
                    to: VehicleId::LEADER,
                    seq: u16::MAX,
                    body,
                });
            }
            Self::JamManeuvers { .. }
            | Self::Bernoulli { .. }
            | Self::GilbertElliott { .. }
            | Self::Delay { .. }
            | Self::RangeJamming { .. }
            | Self::Replay { .. } => return false,
        }
        true
    }
}

/// A standard normal draw (Box-Muller, two uniform draws): no distribution crate, and the same
/// numbers on every platform the channel runs on.
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1 = 1.0 - rng.gen::<f64>(); // (0, 1]: ln is finite
    let u2 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A link attack, active on `[start_s, end_s)` for the links it targets.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkAttack {
    /// The model.
    pub kind: LinkAttackKind,
    /// Start of activity (s).
    pub start_s: f64,
    /// End of activity (s, exclusive; infinity for the whole run).
    pub end_s: f64,
    /// Targeted senders (empty: all).
    pub senders: Vec<VehicleId>,
    /// Targeted receivers (empty: all).
    pub receivers: Vec<VehicleId>,
    /// Whom the attacker acts as ([`ActsAs`]): for the kinds that alter what packets say, an
    /// insider alters each packet once, when it goes on the air, so every receiver gets the
    /// same lie (one draw per packet for the random offset) and every receiver is targeted;
    /// outsiders and thieves alter each link's copy on its own. In a signed run
    /// ([`ChannelSpec::keys`]) an insider signs its lie with its own key and a thief with the
    /// member's it stole; an outsider's alterations keep the seal they break. Other kinds act
    /// as outsiders, whatever this says.
    pub acts_as: ActsAs,
}

/// Whom an attack acts as (issue 52's attacker model): what keys it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ActsAs {
    /// No valid key: its forgeries and alterations fail verification in a signed run.
    #[default]
    Outsider,
    /// A platoon member lying in its own name, with its own key.
    Insider,
    /// A ghost or a Sybil holding the key of a compromised member, `key_of`: it signs what it
    /// alters with that member's current pseudonym.
    Thief {
        /// The member whose key it stole.
        key_of: VehicleId,
    },
}

impl ActsAs {
    /// Its name in configs and datasets.
    pub fn name(self) -> &'static str {
        match self {
            Self::Outsider => "outsider",
            Self::Insider => "insider",
            Self::Thief { .. } => "thief",
        }
    }
}

/// The keys a signed run's channel derives ([`platoon_security::Keyring`], from `[security]`'s
/// seed and the platoon's place in its fleet), so its insiders and thieves can sign.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChannelKeys {
    /// `[security] seed`.
    pub seed: u64,
    /// The platoon of the fleet whose pseudonyms these are.
    pub platoon: u16,
}

impl LinkAttack {
    /// An attack on every link for the whole run.
    pub fn everywhere(kind: LinkAttackKind) -> Self {
        Self {
            kind,
            start_s: 0.0,
            end_s: f64::INFINITY,
            senders: Vec::new(),
            receivers: Vec::new(),
            acts_as: ActsAs::Outsider,
        }
    }

    /// Whether it alters packets at their sender, once per packet.
    fn lies_at_source(&self) -> bool {
        self.acts_as == ActsAs::Insider && self.kind.alters_state()
    }

    fn active(&self, t: f64) -> bool {
        t >= self.start_s && t < self.end_s
    }

    fn targets(&self, sender: VehicleId, receiver: VehicleId) -> bool {
        (self.senders.is_empty() || self.senders.contains(&sender))
            && (self.receivers.is_empty() || self.receivers.contains(&receiver))
    }
}

/// Everything the channel needs: the DoS schedule, the link attacks (applied in order) and a seed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ChannelSpec {
    /// When the whole channel is jammed.
    pub dos: DosSchedule,
    /// Link-level attacks, applied in this order to each (packet, receiver).
    pub attacks: Vec<LinkAttack>,
    /// Seed of the ChaCha8 generator behind the random losses.
    pub seed: u64,
    /// The platoon this channel serves (its log rows carry it).
    pub platoon: u16,
    /// IEEE 802.11p delivery against distance and load (`[channel] model = "80211p"`): every
    /// packet on every link is delivered with the model's probability for the link's distance
    /// at the load the receiver's radio sees; `None`: an ideal radio.
    pub radio: Option<RadioSpec>,
    /// Jammers as transmitters (`[[channel.jammers]]`), see [`crate::jammer`].
    pub jammers: Vec<crate::jammer::Jammer>,
    /// A signed run's keys (`[security]`), which insiders and thieves sign with; `None`:
    /// unsigned, or nobody on the channel holds a key.
    pub keys: Option<ChannelKeys>,
}

/// One step of one platoon on the channel: what [`Channel::gate`] gates.
#[derive(Debug, Clone, Copy)]
pub struct ChannelStep<'a> {
    /// The step.
    pub k: u64,
    /// Its time (s).
    pub t: f64,
    /// Who hears whom: each broadcast goes to its sender's out-neighbours.
    pub topology: &'a Topology,
    /// Every vehicle's true state at step k, leader first.
    pub states: &'a [State],
    /// The packets broadcast at step k.
    pub tx: &'a [Packet],
}

/// The channel's state across steps: random generator, Gilbert-Elliott states, packets in flight
/// and the history replay draws from.
#[derive(Debug, Clone)]
pub struct Channel {
    spec: ChannelSpec,
    rng: ChaCha8Rng,
    /// The radio's losses' own stream.
    radio_rng: ChaCha8Rng,
    /// The random offsets' own stream: their draws never shift the losses'.
    noise_rng: ChaCha8Rng,
    /// The 802.11p medium's load and DCC, with the radio.
    medium: Option<Medium>,
    /// The packets that go on the air at the current step (after DCC).
    on_air: Vec<Packet>,
    /// This step's broadcasts that some vehicle listens to.
    addressed: Vec<Packet>,
    gated: Vec<Gated>,
    /// Per link (sender * n + receiver): in the bad state.
    bad: Vec<bool>,
    vehicles: usize,
    /// Delayed deliveries with their due step, in send order.
    in_flight: VecDeque<(u64, Delivery)>,
    /// Recent packets per sender, oldest first.
    history: Vec<VecDeque<Packet>>,
    max_lag: u64,
    /// SUMO's background vehicles this step (`bg<b>` at index b), road positions in the
    /// platoon's coordinates (NaN: not on the road).
    background: Vec<f64>,
    /// The jammers as transmitters.
    jammers: Jammers,
    /// Per link (sender * n + receiver), with jammers: its last packet was lost to jamming.
    jam_out: Vec<bool>,
    /// The platoon's keys, in a signed run with insiders or thieves.
    keys: Option<platoon_security::Keyring>,
}

impl Channel {
    /// A channel for `vehicles` vehicles (leader included).
    pub fn new(spec: ChannelSpec, vehicles: usize) -> Self {
        let max_lag = spec
            .attacks
            .iter()
            .filter_map(|a| match a.kind {
                LinkAttackKind::Replay { lag_steps } => Some(lag_steps),
                _ => None,
            })
            .max()
            .unwrap_or(0);
        Self {
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
            radio_rng: {
                // Its own stream: the radio's draws never shift the link attacks'.
                let mut r = ChaCha8Rng::seed_from_u64(spec.seed);
                r.set_stream(1);
                r
            },
            noise_rng: {
                // Far from the jammers' streams (2 + their index).
                let mut r = ChaCha8Rng::seed_from_u64(spec.seed);
                r.set_stream(1 << 32);
                r
            },
            medium: spec.radio.clone().map(|r| Medium::new(r, vehicles)),
            on_air: Vec::with_capacity(vehicles),
            addressed: Vec::with_capacity(vehicles),
            gated: Vec::new(),
            bad: vec![false; vehicles * vehicles],
            vehicles,
            in_flight: VecDeque::new(),
            history: vec![VecDeque::new(); vehicles],
            max_lag,
            background: Vec::new(),
            // Every platoon of a fleet meets the same random jammers: their streams come from
            // the fleet's seed (platoon j's channel seed is the fleet's + j).
            jammers: Jammers::new(
                &spec.jammers,
                spec.seed.wrapping_sub(u64::from(spec.platoon)),
            ),
            jam_out: if spec.jammers.is_empty() {
                Vec::new()
            } else {
                vec![false; vehicles * vehicles]
            },
            // Only a channel with someone to sign derives the keys.
            keys: spec
                .keys
                .filter(|_| {
                    spec.attacks
                        .iter()
                        .any(|a| a.kind.alters_state() && a.acts_as != ActsAs::Outsider)
                })
                .map(|k| platoon_security::Keyring::new(k.seed, k.platoon, vehicles)),
            spec,
        }
    }

    /// Tells the channel where SUMO's background vehicles are at the coming step: `positions_m[b]`
    /// is vehicle `bg<b>`'s road position in the platoon's coordinates (NaN: not on the road).
    /// They load the 802.11p channel and may carry jammers. Without a call: none.
    pub fn set_background(&mut self, positions_m: &[f64]) {
        self.background.clear();
        self.background.extend_from_slice(positions_m);
    }

    /// SUMO's background vehicles as last given to [`Channel::set_background`].
    pub fn background(&self) -> &[f64] {
        &self.background
    }

    /// Whether this channel's load counts the rest of the fleet (give it with
    /// [`Channel::set_fleet`] before each step).
    pub fn counts_fleet(&self) -> bool {
        self.medium
            .as_ref()
            .is_some_and(|m| m.spec.load == LoadSource::Scenario)
    }

    /// Tells the channel where every vehicle of the fleet is and how often it beacons at the
    /// coming step: `all[i] = (road position, rate in Hz)` (from [`Channel::beacon_rate`] of
    /// each platoon's channel), of which `own` are this platoon's (skipped: it counts its own).
    pub fn set_fleet(&mut self, all: &[(f64, f64)], own: std::ops::Range<usize>) {
        if let Some(m) = &mut self.medium {
            m.set_fleet(all, own);
        }
    }

    /// Vehicle `v`'s beacon rate as the radio measured it over the window before step `k`
    /// (Hz; 0 without the 802.11p radio).
    pub fn beacon_rate(&self, v: VehicleId, k: u64) -> f64 {
        self.medium
            .as_ref()
            .filter(|_| v.index() < self.vehicles)
            .map_or(0.0, |m| m.rate(v.index(), k))
    }

    /// The channel busy ratio each vehicle's radio measured at the last step (empty without the
    /// 802.11p radio).
    pub fn cbr(&self) -> &[f64] {
        self.medium.as_ref().map_or(&[], |m| m.cbr())
    }

    /// What the 802.11p radio measured so far (`None` without it).
    pub fn radio_stats(&self) -> Option<RadioStats> {
        self.medium.as_ref().map(Medium::stats)
    }

    /// The spec.
    pub fn spec(&self) -> &ChannelSpec {
        &self.spec
    }

    /// Gates `step`: its packets broadcast over its topology, with the true vehicle states (for
    /// position-dependent attacks). Appends what each receiver gets to `out`, sets `jammed[v]`
    /// for every vehicle that senses its channel jammed, and appends to `log` every packet that
    /// was not delivered as sent.
    pub fn gate(
        &mut self,
        step: &ChannelStep<'_>,
        out: &mut Vec<Delivery>,
        jammed: &mut [bool],
        log: &mut Vec<ChannelEvent>,
    ) {
        let ChannelStep {
            k,
            t,
            topology,
            states,
            tx,
        } = *step;
        let at = (k, self.spec.platoon);
        let dos = self.spec.dos.is_active(t);
        jammed.fill(dos);
        for a in &self.spec.attacks {
            if let LinkAttackKind::RangeJamming {
                position_m,
                speed_mps,
                radius_m,
            } = a.kind
            {
                if a.active(t) {
                    let centre = position_m + speed_mps * t;
                    for (j, x) in jammed.iter_mut().zip(states) {
                        *j |= (x[0] - centre).abs() <= radius_m;
                    }
                }
            }
        }
        self.jammers.step(t, states, &self.background, jammed);
        while self.in_flight.front().is_some_and(|(due, _)| *due <= k) {
            let (_, d) = self.in_flight.pop_front().expect("checked non-empty");
            log.push(event(
                at,
                &d.packet,
                d.receiver,
                Action::DeliveredLate,
                None,
            ));
            out.push(d);
        }
        // The radio: the load each vehicle sees, then the access layer (DCC) picks what goes on
        // the air at this step.
        let mut on_air = std::mem::take(&mut self.on_air);
        on_air.clear();
        match &mut self.medium {
            Some(m) => {
                m.measure(k, states, &self.background);
                self.gated.clear();
                // A broadcast no vehicle of the topology listens to is not sent (on the wire
                // a controller publishes one item per link, so an injector process never
                // sees it): it neither loads the channel nor counts in the sender's rate.
                let mut addressed = std::mem::take(&mut self.addressed);
                addressed.clear();
                addressed.extend(
                    tx.iter()
                        .filter(|p| !topology.out_neighbours(p.sender).is_empty()),
                );
                m.access(k, &addressed, &mut on_air, &mut self.gated);
                self.addressed = addressed;
                for g in &self.gated {
                    let (p, action) = match g {
                        Gated::Deferred(p) => (p, Action::DccDeferred),
                        Gated::Dropped(p) => (p, Action::DroppedDcc),
                    };
                    for &receiver in topology.out_neighbours(p.sender) {
                        log.push(event(at, p, receiver, action, None));
                    }
                }
                m.record(k, &on_air, jammed);
            }
            None => on_air.extend_from_slice(tx),
        }
        for sent in &mut on_air {
            // Insiders lie once per packet, before it reaches any link (a broadcast nobody
            // listens to is not sent: see above).
            let lied = !topology.out_neighbours(sent.sender).is_empty() && self.lie(k, t, sent);
            let sent = &*sent;
            for &receiver in topology.out_neighbours(sent.sender) {
                if dos {
                    log.push(event(at, sent, receiver, Action::DroppedDos, None));
                    continue;
                }
                if jammed[sent.sender.index()] || jammed[receiver.index()] {
                    log.push(event(at, sent, receiver, Action::DroppedJammed, None));
                    self.jam_cut(sent.sender, receiver);
                    continue;
                }
                let (xs, xr) = (states[sent.sender.index()][0], states[receiver.index()][0]);
                if self.medium.is_none() && self.jammers.blocks(xs, xr) {
                    log.push(event(at, sent, receiver, Action::DroppedInterference, None));
                    self.jam_cut(sent.sender, receiver);
                    continue;
                }
                if let Some(m) = &self.medium {
                    // Distance between the antennas, front to front (the platoon's vehicles
                    // share one length).
                    let d = (states[sent.sender.index()][0] - states[receiver.index()][0]).abs();
                    let u = self.radio_rng.gen::<f64>();
                    let jam = self
                        .jammers
                        .interference_dbm(m.spec.family.params(), xs, xr);
                    if u >= m.pdr_with_interference(d, receiver.index(), jam) {
                        // Lost to the jammer if the radio alone would have delivered it.
                        let action = if jam > f64::NEG_INFINITY && u < m.pdr(d, receiver.index()) {
                            Action::DroppedInterference
                        } else {
                            Action::DroppedRadio
                        };
                        log.push(event(at, sent, receiver, action, None));
                        if action == Action::DroppedInterference {
                            self.jam_cut(sent.sender, receiver);
                        }
                        continue;
                    }
                }
                if self
                    .medium
                    .as_ref()
                    .is_some_and(|m| m.sent_late(sent.sender.index()))
                {
                    // Held back by DCC: it arrives late (unless an attack drops it).
                    let before = out.len();
                    self.link(step, *sent, lied, receiver, out, log);
                    if out.len() > before {
                        log.push(event(at, sent, receiver, Action::DeliveredLate, None));
                    }
                    continue;
                }
                self.link(step, *sent, lied, receiver, out, log);
            }
            if self.max_lag > 0 {
                let h = &mut self.history[sent.sender.index()];
                h.push_back(*sent);
                // Keep one packet older than the largest lag: it is what a replay then sends.
                while h.len() > 1 && h[1].step + self.max_lag <= k {
                    h.pop_front();
                }
            }
        }
        self.on_air = on_air;
    }

    /// The insiders' lies in `packet` as it goes on the air at time `t` (in the attacks'
    /// order); whether there was any.
    fn lie(&mut self, k: u64, t: f64, packet: &mut Packet) -> bool {
        let mut lied = false;
        for a in &self.spec.attacks {
            if a.lies_at_source()
                && a.active(t)
                && (a.senders.is_empty() || a.senders.contains(&packet.sender))
            {
                lied |= a.kind.alter(t - a.start_s, packet, &mut self.noise_rng);
            }
        }
        if lied {
            // The insider signs its lie with its own key.
            reseal(self.keys.as_mut(), k, packet, None);
        }
        lied
    }

    /// One packet on one link through the attack models at `step`; `lied`: an insider altered
    /// it (logged as altered on every link it goes through).
    fn link(
        &mut self,
        step: &ChannelStep<'_>,
        mut packet: Packet,
        lied: bool,
        receiver: VehicleId,
        out: &mut Vec<Delivery>,
        log: &mut Vec<ChannelEvent>,
    ) {
        let (k, t) = (step.k, step.t);
        let at = (k, self.spec.platoon);
        let link = packet.sender.index() * self.vehicles + receiver.index();
        if lied {
            log.push(event(at, &packet, receiver, Action::Altered, None));
        }
        for a in &self.spec.attacks {
            if a.lies_at_source() || !a.active(t) || !a.targets(packet.sender, receiver) {
                continue;
            }
            match a.kind {
                LinkAttackKind::Bernoulli { loss } => {
                    if self.rng.gen::<f64>() < loss {
                        log.push(event(at, &packet, receiver, Action::DroppedLoss, None));
                        return;
                    }
                }
                LinkAttackKind::GilbertElliott {
                    p_good_bad,
                    p_bad_good,
                    loss_good,
                    loss_bad,
                } => {
                    let flip = self.rng.gen::<f64>();
                    let bad = &mut self.bad[link];
                    *bad = if *bad {
                        flip >= p_bad_good
                    } else {
                        flip < p_good_bad
                    };
                    let loss = if *bad { loss_bad } else { loss_good };
                    if self.rng.gen::<f64>() < loss {
                        log.push(event(at, &packet, receiver, Action::DroppedLoss, None));
                        return;
                    }
                }
                LinkAttackKind::Delay { steps } => {
                    let due = k + u64::from(steps);
                    log.push(event(at, &packet, receiver, Action::Delayed, Some(due)));
                    self.in_flight
                        .push_back((due, Delivery { receiver, packet }));
                    return;
                }
                LinkAttackKind::RangeJamming { .. } => {} // applied per vehicle in `gate`
                LinkAttackKind::JamManeuvers { kinds } => {
                    if packet
                        .maneuver
                        .is_some_and(|m| m.body.kind().bit() & kinds != 0)
                    {
                        log.push(event(at, &packet, receiver, Action::DroppedJammed, None));
                        return;
                    }
                }
                LinkAttackKind::Replay { lag_steps } => {
                    let wanted = k.saturating_sub(lag_steps);
                    if let Some(old) = self.history[packet.sender.index()]
                        .iter()
                        .rev()
                        .find(|p| p.step <= wanted)
                    {
                        packet = *old;
                        log.push(event(
                            at,
                            &packet,
                            receiver,
                            Action::Replayed,
                            Some(old.step),
                        ));
                    }
                }
                LinkAttackKind::FalseData { .. }
                | LinkAttackKind::RandomOffset { .. }
                | LinkAttackKind::Drift { .. }
                | LinkAttackKind::FeignedBraking { .. }
                | LinkAttackKind::AccelScale { .. }
                | LinkAttackKind::ForgedHead
                | LinkAttackKind::ForgeManeuver { .. } => {
                    a.kind
                        .alter(t - a.start_s, &mut packet, &mut self.noise_rng);
                    if let ActsAs::Thief { key_of } = a.acts_as {
                        reseal(self.keys.as_mut(), k, &mut packet, Some(key_of));
                    }
                    log.push(event(at, &packet, receiver, Action::Altered, None));
                }
            }
        }
        if let Some(cut) = self.jam_out.get_mut(link) {
            if *cut {
                *cut = false;
                log.push(event(at, &packet, receiver, Action::Restored, None));
            }
        }
        out.push(Delivery { receiver, packet });
    }

    /// A packet on link `sender -> receiver` was lost to jamming (tracked with jammers only).
    fn jam_cut(&mut self, sender: VehicleId, receiver: VehicleId) {
        if let Some(cut) = self
            .jam_out
            .get_mut(sender.index() * self.vehicles + receiver.index())
        {
            *cut = true;
        }
    }
}

/// Signs `packet` again after an alteration at step `k`, as its seal's signer would have
/// (the same time, the same form) with the key of `vehicle` (`None`: the signer's own) of the
/// signer's pseudonym epoch. Nothing to do without keys, or for a packet that carries no seal
/// of the platoon's keys. An insider (`vehicle` `None`), a member, also tags its lie again
/// with the group key of the tag's epoch (`[security.group]`), which it held when it was a
/// member; a thief holds no group key: the tag it forwards no longer holds.
fn reseal(
    keys: Option<&mut platoon_security::Keyring>,
    k: u64,
    packet: &mut Packet,
    vehicle: Option<VehicleId>,
) {
    let (Some(keys), Some(seal)) = (keys, packet.seal) else {
        return;
    };
    let Ok(header) = platoon_security::SecurityHeader::decode(seal.as_bytes()) else {
        return;
    };
    // At most one pseudonym change a step: the signer's epoch is among the first k + 1.
    let Some(mut slot) = keys.holder(header.signer.digest(), k as usize + 1) else {
        return;
    };
    if let Some(v) = vehicle {
        slot.vehicle = v.index();
    }
    let group = packet
        .group
        .map(|g| platoon_security::GroupField::decode(g.as_bytes()));
    if let (None, Some(Ok(mut field))) = (vehicle, group) {
        if let Some(tag) = &mut field.tag {
            *tag = keys.group_key(tag.epoch).tag(&packet.payload_bytes());
            packet.group = platoon_v2v::GroupSeal::new(&field.encode());
        }
    }
    if let Some(signed) = keys.sign_like(slot, &packet.signed_bytes(), &header) {
        packet.seal = platoon_v2v::Seal::new(&signed.to_bytes());
    }
}

/// Lets every platoon's channel of a fleet hear the others before step `k` is gated:
/// `platoons` are each platoon's channel with its vehicles' true states (leader first), in fleet
/// order; `beacons` is scratch. Nothing to do unless the channels count the fleet in their load.
/// The in-process runner and the injector process both call it, so their loads agree.
pub fn hear_fleet(
    k: u64,
    platoons: &mut [(&mut Channel, &[State])],
    beacons: &mut Vec<(f64, f64)>,
) {
    if platoons.len() < 2 || !platoons[0].0.counts_fleet() {
        return;
    }
    // Where each vehicle is and how often it has been beaconing, before any platoon steps.
    beacons.clear();
    for (channel, states) in platoons.iter() {
        beacons.extend(
            states
                .iter()
                .enumerate()
                .map(|(v, x)| (x[0], channel.beacon_rate(VehicleId(v as u16), k))),
        );
    }
    let mut from = 0;
    for (channel, states) in platoons.iter_mut() {
        channel.set_fleet(beacons, from..from + states.len());
        from += states.len();
    }
}

#[cfg(test)]
mod tests;
