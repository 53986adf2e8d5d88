//! The V2V channel between the controllers: what each receiver gets from each broadcast, under the
//! DoS schedule and the link-level attack models. Pure and seeded: the in-process runner and the
//! iceoryx2 injector process run this same code, so they deliver the same packets bit for bit.
use crate::jammer::Jammers;
pub use crate::medium::{BackgroundBeacons, Dcc, LoadSource, RadioSpec, RadioStats};
use crate::medium::{Gated, Medium};
use crate::DosSchedule;
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;
use platoon_v2v::{Delivery, Packet};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
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
    /// packet with [`LinkAttack::insider`]).
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
        }
    }

    /// Whether the model alters a packet's state (the kinds an insider can be given).
    pub fn alters_state(&self) -> bool {
        matches!(
            self,
            Self::FalseData { .. }
                | Self::RandomOffset { .. }
                | Self::Drift { .. }
                | Self::FeignedBraking { .. }
                | Self::AccelScale { .. }
        )
    }

    /// Alters `state` as the model says at `since_s` after the attack's start (drawing from
    /// `rng` for the random offset); false for the kinds that do not alter states.
    fn alter(&self, since_s: f64, state: &mut State, rng: &mut ChaCha8Rng) -> bool {
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
            Self::Bernoulli { .. }
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
    /// An insider (a platoon member lying about itself) rather than an outsider on the links:
    /// for the kinds that alter states, the alteration is made once per packet when it goes on
    /// the air, so every receiver gets the same lie (one draw per packet for the random offset),
    /// and every receiver is targeted. Outsiders alter each link's copy on its own. Other kinds
    /// ignore it.
    pub insider: bool,
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
            insider: false,
        }
    }

    /// Whether it alters packets at their sender, once per packet.
    fn lies_at_source(&self) -> bool {
        self.insider && self.kind.alters_state()
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
}

/// What the channel did to one packet on one link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Action {
    /// Dropped: the DoS schedule jams the channel.
    DroppedDos,
    /// Dropped: the sender or receiver is within a range jammer's radius.
    DroppedJammed,
    /// Dropped: a jammer's interference (in the SINR with the 802.11p radio; within a reactive
    /// jammer's radius with the ideal one) lost a packet the radio would have delivered.
    DroppedInterference,
    /// Delivered: the first packet through on a link after jamming losses on it (logged only
    /// with `[[channel.jammers]]`, so each link's outage can be read from the log).
    Restored,
    /// Dropped: random loss (Bernoulli or Gilbert-Elliott).
    DroppedLoss,
    /// Dropped: lost on the radio (802.11p: propagation, collision, busy receiver, below the
    /// sensing threshold), drawn from the model's delivery ratio at the link's distance.
    DroppedRadio,
    /// Held back by the sender's DCC (its `T_off` since its last transmission had not passed):
    /// sent at a later step unless a newer packet replaces it.
    DccDeferred,
    /// A packet DCC had held back, dropped for a newer one of the same sender.
    DroppedDcc,
    /// Held back; delivered at a later step.
    Delayed,
    /// A held-back packet delivered now.
    DeliveredLate,
    /// Replaced by an older packet of the same sender.
    Replayed,
    /// Its state was altered (false data injection).
    Altered,
}

/// One line of the injector log: `step, platoon, sender, receiver, seq, action, detail`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct ChannelEvent {
    /// The step at which it happened.
    pub step: u64,
    /// The platoon (sender and receiver are its vehicle indices, 0 = its leader).
    pub platoon: u16,
    /// The packet's sender.
    pub sender: u16,
    /// The link's receiver.
    pub receiver: u16,
    /// The packet's sequence number (after replay: the old one).
    pub seq: u32,
    /// What happened.
    pub action: Action,
    /// For `delayed`: the step of delivery; for `replayed`: the step the old packet was sampled.
    pub detail: Option<u64>,
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

    /// Gates step `k` (time `t`): `tx` are the packets broadcast at this step, `states` the true
    /// vehicle states (for position-dependent attacks). Appends what each receiver gets to `out`,
    /// sets `jammed[v]` for every vehicle that senses its channel jammed, and appends to `log`
    /// every packet that was not delivered as sent.
    #[allow(clippy::too_many_arguments)]
    pub fn gate(
        &mut self,
        k: u64,
        t: f64,
        topology: &Topology,
        states: &[State],
        tx: &[Packet],
        out: &mut Vec<Delivery>,
        jammed: &mut [bool],
        log: &mut Vec<ChannelEvent>,
    ) {
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
            let lied = !topology.out_neighbours(sent.sender).is_empty() && self.lie(t, sent);
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
                    self.link(k, t, *sent, lied, receiver, out, log);
                    if out.len() > before {
                        log.push(event(at, sent, receiver, Action::DeliveredLate, None));
                    }
                    continue;
                }
                self.link(k, t, *sent, lied, receiver, out, log);
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
    fn lie(&mut self, t: f64, packet: &mut Packet) -> bool {
        let mut lied = false;
        for a in &self.spec.attacks {
            if a.lies_at_source()
                && a.active(t)
                && (a.senders.is_empty() || a.senders.contains(&packet.sender))
            {
                lied |= a
                    .kind
                    .alter(t - a.start_s, &mut packet.state, &mut self.noise_rng);
            }
        }
        lied
    }

    /// One packet on one link through the attack models; `lied`: an insider altered it (logged
    /// as altered on every link it goes through).
    #[allow(clippy::too_many_arguments)]
    fn link(
        &mut self,
        k: u64,
        t: f64,
        mut packet: Packet,
        lied: bool,
        receiver: VehicleId,
        out: &mut Vec<Delivery>,
        log: &mut Vec<ChannelEvent>,
    ) {
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
                | LinkAttackKind::AccelScale { .. } => {
                    a.kind
                        .alter(t - a.start_s, &mut packet.state, &mut self.noise_rng);
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

fn event(
    (step, platoon): (u64, u16),
    p: &Packet,
    receiver: VehicleId,
    action: Action,
    detail: Option<u64>,
) -> ChannelEvent {
    ChannelEvent {
        step,
        platoon,
        sender: p.sender.0,
        receiver: receiver.0,
        seq: p.seq,
        action,
        detail,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_topology::Preset;

    fn pf(n: usize) -> Topology {
        Topology::preset(Preset::Pf, n).unwrap()
    }

    fn packet(sender: u16, seq: u32, step: u64) -> Packet {
        Packet {
            sender: VehicleId(sender),
            seq,
            step,
            state: State::new(f64::from(sender), 1.0, 0.0),
            u: 0.0,
        }
    }

    struct Out {
        deliveries: Vec<Delivery>,
        jammed: Vec<bool>,
        log: Vec<ChannelEvent>,
    }

    fn gate(c: &mut Channel, k: u64, tx: &[Packet], states: &[State]) -> Out {
        let mut o = Out {
            deliveries: Vec::new(),
            jammed: vec![false; states.len()],
            log: Vec::new(),
        };
        let topology = pf(states.len() - 1);
        c.gate(
            k,
            k as f64 * 0.01,
            &topology,
            states,
            tx,
            &mut o.deliveries,
            &mut o.jammed,
            &mut o.log,
        );
        o
    }

    fn states(n: usize) -> Vec<State> {
        (0..=n)
            .map(|i| State::new(-10.0 * i as f64, 15.0, 0.0))
            .collect()
    }

    fn channel(attacks: Vec<LinkAttack>) -> Channel {
        Channel::new(
            ChannelSpec {
                dos: DosSchedule::none(),
                attacks,
                seed: 1,
                platoon: 0,
                radio: None,
                jammers: Vec::new(),
            },
            4,
        )
    }

    fn radio(params: platoon_radio::Params80211p, load: LoadSource, dcc: Option<Dcc>) -> RadioSpec {
        RadioSpec {
            family: std::sync::Arc::new(platoon_radio::LoadFamily::new(params).unwrap()),
            load,
            background_beacons: BackgroundBeacons::Fixed,
            dcc,
            window_steps: 100,
            dt: 0.01,
        }
    }

    /// The ETSI reactive table the config defaults to.
    fn etsi() -> Dcc {
        Dcc {
            cbr_thresholds: vec![0.3, 0.4, 0.5, 0.65],
            t_off_s: vec![0.06, 0.1, 0.18, 0.26, 1.0],
        }
    }

    #[test]
    fn the_load_counts_the_platoons_measured_beacons_the_fleet_and_the_background() {
        let quiet = platoon_radio::Params80211p {
            density_veh_per_m: 0.0,
            ..Default::default()
        };
        let states = vec![
            State::new(100.0, 15.0, 0.0),
            State::new(80.0, 15.0, 0.0),
            State::new(60.0, 15.0, 0.0),
        ];
        let mut c = Channel::new(
            ChannelSpec {
                radio: Some(radio(quiet, LoadSource::Scenario, None)),
                ..channel(vec![]).spec().clone()
            },
            3,
        );
        assert!(c.counts_fleet());
        // The leader beacons every 5 steps (20 Hz), follower 1 every 10 (10 Hz); follower 2's
        // broadcasts have no listener in the predecessor-following graph, so they are not sent.
        for k in 0..200 {
            let tx: Vec<Packet> = [(0u16, 5), (1, 10), (2, 1)]
                .iter()
                .filter(|(_, every)| k % every == 0)
                .map(|&(v, _)| packet(v, k as u32, k))
                .collect();
            gate(&mut c, k, &tx, &states);
        }
        assert_eq!(c.beacon_rate(VehicleId(0), 200), 20.0);
        assert_eq!(c.beacon_rate(VehicleId(1), 200), 10.0);
        assert_eq!(c.beacon_rate(VehicleId(2), 200), 0.0);
        // 30 packets a second within 1000 m: 30 / 2000 m.
        let own = c.medium.as_ref().unwrap().load(1);
        assert!((own - 30.0 / 2000.0).abs() < 1e-12, "{own}");
        let cbr_alone = c.cbr()[1];
        // A fleet vehicle 500 m away at 10 Hz, one 5 km away (out of range), and two SUMO
        // background vehicles at the configured 10 Hz.
        c.set_fleet(&[(100.0, 7.0), (600.0, 10.0), (5100.0, 10.0)], 0..1);
        c.set_background(&[50.0, f64::NAN, 900.0]);
        gate(&mut c, 200, &[], &states);
        let load = c.medium.as_ref().unwrap().load(1);
        assert!(
            (load - (30.0 + 10.0 + 20.0) / 2000.0).abs() < 1e-12,
            "{load}"
        );
        assert!(c.cbr()[1] > cbr_alone);
        let stats = c.radio_stats().unwrap();
        assert_eq!(stats.transmissions, 40 + 20);
        assert_eq!(stats.samples, 3 * 201);
        // The fixed load is the configured traffic alone, whatever the vehicles send.
        let mut fixed = Channel::new(
            ChannelSpec {
                radio: Some(radio(
                    platoon_radio::Params80211p::default(),
                    LoadSource::Fixed,
                    None,
                )),
                ..channel(vec![]).spec().clone()
            },
            3,
        );
        gate(&mut fixed, 0, &[packet(0, 0, 0)], &states);
        assert_eq!(fixed.medium.as_ref().unwrap().load(1), 0.6);
        assert!(!fixed.counts_fleet());
    }

    #[test]
    fn dcc_spaces_a_vehicles_transmissions_by_t_off_and_sends_the_newest_late() {
        let mut c = Channel::new(
            ChannelSpec {
                radio: Some(radio(
                    platoon_radio::Params80211p {
                        density_veh_per_m: 0.0,
                        ..Default::default()
                    },
                    LoadSource::Fixed,
                    Some(etsi()),
                )),
                ..channel(vec![]).spec().clone()
            },
            2,
        );
        // The leader wants to send at every step; relaxed DCC lets it out every 6 (60 ms).
        let states = vec![State::new(10.0, 15.0, 0.0), State::new(0.0, 15.0, 0.0)];
        let mut delivered = Vec::new();
        let mut actions = Vec::new();
        for k in 0..13 {
            let o = gate(&mut c, k, &[packet(0, k as u32, k)], &states);
            delivered.extend(o.deliveries.iter().map(|d| (k, d.packet.seq)));
            actions.extend(o.log.iter().map(|e| (e.step, e.seq, e.action)));
        }
        // Sent at 0, 6, 12; at 6 and 12 the packet of that very step (the held one of step 5
        // is replaced at step 6 before it could go).
        let sent: Vec<u64> = delivered.iter().map(|d| d.0).collect();
        assert_eq!(sent, vec![0, 6, 12], "{delivered:?}");
        assert!(delivered.iter().all(|(k, seq)| u64::from(*seq) == *k));
        assert!(actions.contains(&(1, 1, Action::DccDeferred)));
        assert!(actions.contains(&(2, 1, Action::DroppedDcc)));
        let stats = c.radio_stats().unwrap();
        assert_eq!((stats.transmissions, stats.dcc_deferred), (3, 10));
        assert_eq!(stats.dcc_dropped, 10);
        // A packet held back and not replaced goes out late, when T_off has passed.
        let mut c = Channel::new(c.spec().clone(), 2);
        let mut late = Vec::new();
        for k in 0..8 {
            let tx: Vec<Packet> = [0u64, 2]
                .iter()
                .filter(|&&s| s == k)
                .map(|&s| packet(0, s as u32, s))
                .collect();
            let o = gate(&mut c, k, &tx, &states);
            late.extend(o.deliveries.iter().map(|d| (k, d.packet.step)));
            if k == 6 {
                assert!(o.log.iter().any(|e| e.action == Action::DeliveredLate));
            }
        }
        assert_eq!(late, vec![(0, 0), (6, 2)]);
        assert_eq!(etsi().state(0.29), 0);
        assert_eq!(etsi().state(0.3), 1);
        assert_eq!(etsi().state(0.9), 4);
    }

    #[test]
    fn the_80211p_radio_delivers_each_link_with_the_models_ratio_at_its_distance() {
        let model = platoon_radio::Model::new(platoon_radio::Params80211p {
            density_veh_per_m: 0.12,
            beacon_hz: 25.0,
            ..Default::default()
        })
        .unwrap();
        // Follower 1 is 50 m behind the leader, follower 2 400 m behind follower 1.
        let states = vec![
            State::new(450.0, 15.0, 0.0),
            State::new(400.0, 15.0, 0.0),
            State::new(0.0, 15.0, 0.0),
        ];
        let (near, far) = (model.pdr(50.0), model.pdr(400.0));
        assert!(near > 0.5 && far < near, "{near} {far}");
        let mut c = Channel::new(
            ChannelSpec {
                radio: Some(radio(*model.params(), LoadSource::Fixed, None)),
                ..channel(vec![]).spec().clone()
            },
            3,
        );
        let (mut got_near, mut got_far) = (0, 0);
        let steps = 4000;
        for k in 0..steps {
            let o = gate(&mut c, k, &[packet(0, 1, k), packet(1, 1, k)], &states);
            got_near += o.deliveries.iter().filter(|d| d.receiver.0 == 1).count();
            got_far += o.deliveries.iter().filter(|d| d.receiver.0 == 2).count();
            assert!(o.log.iter().all(|e| e.action == Action::DroppedRadio));
            assert_eq!(o.deliveries.len() + o.log.len(), 2);
        }
        // Within 4 standard deviations of the binomial.
        for (got, p) in [(got_near, near), (got_far, far)] {
            let n = steps as f64;
            let sd = (n * p * (1.0 - p)).sqrt().max(1.0);
            assert!(
                (got as f64 - n * p).abs() < 4.0 * sd,
                "{got} of {n} at p = {p}"
            );
        }
    }

    #[test]
    fn without_attacks_every_packet_reaches_every_out_neighbour() {
        let mut c = channel(vec![]);
        let o = gate(&mut c, 0, &[packet(0, 1, 0), packet(1, 1, 0)], &states(3));
        let got: Vec<(u16, u16)> = o
            .deliveries
            .iter()
            .map(|d| (d.packet.sender.0, d.receiver.0))
            .collect();
        assert_eq!(got, vec![(0, 1), (1, 2)]);
        assert!(o.log.is_empty() && o.jammed.iter().all(|j| !j));
    }

    #[test]
    fn dos_drops_everything_and_every_vehicle_senses_it() {
        let mut c = Channel::new(
            ChannelSpec {
                dos: DosSchedule::from_intervals(&[(0.0, 1.0)]).unwrap(),
                ..ChannelSpec::default()
            },
            4,
        );
        let o = gate(&mut c, 5, &[packet(0, 1, 5)], &states(3));
        assert!(o.deliveries.is_empty());
        assert!(o.jammed.iter().all(|j| *j));
        assert_eq!(o.log[0].action, Action::DroppedDos);
    }

    #[test]
    fn bernoulli_loss_is_seeded_and_has_its_rate() {
        let run = || {
            let mut c = channel(vec![LinkAttack::everywhere(LinkAttackKind::Bernoulli {
                loss: 0.3,
            })]);
            (0..2000)
                .map(|k| {
                    gate(&mut c, k, &[packet(1, k as u32 + 1, k)], &states(3))
                        .deliveries
                        .len()
                })
                .collect::<Vec<_>>()
        };
        let a = run();
        assert_eq!(a, run(), "the same seed gives the same losses");
        let rate = 1.0 - a.iter().sum::<usize>() as f64 / 2000.0;
        assert!((rate - 0.3).abs() < 0.04, "loss rate {rate}");
    }

    #[test]
    fn gilbert_elliott_loses_in_bursts() {
        let mut c = channel(vec![LinkAttack::everywhere(
            LinkAttackKind::GilbertElliott {
                p_good_bad: 0.05,
                p_bad_good: 0.2,
                loss_good: 0.0,
                loss_bad: 1.0,
            },
        )]);
        let lost: Vec<bool> = (0..5000)
            .map(|k| {
                gate(&mut c, k, &[packet(1, k as u32 + 1, k)], &states(3))
                    .deliveries
                    .is_empty()
            })
            .collect();
        let losses = lost.iter().filter(|l| **l).count();
        let bursts = lost.windows(2).filter(|w| !w[0] && w[1]).count();
        // Stationary bad share 0.05 / 0.25 = 0.2, mean burst 1 / 0.2 = 5 packets.
        let share = losses as f64 / 5000.0;
        assert!((share - 0.2).abs() < 0.05, "loss share {share}");
        assert!(losses as f64 / bursts as f64 > 3.0, "losses come in bursts");
    }

    #[test]
    fn delayed_packets_arrive_exactly_late() {
        let mut c = channel(vec![LinkAttack::everywhere(LinkAttackKind::Delay {
            steps: 3,
        })]);
        assert!(gate(&mut c, 0, &[packet(1, 1, 0)], &states(3))
            .deliveries
            .is_empty());
        assert!(gate(&mut c, 2, &[], &states(3)).deliveries.is_empty());
        let o = gate(&mut c, 3, &[], &states(3));
        assert_eq!(o.deliveries.len(), 1);
        assert_eq!(o.deliveries[0].packet.step, 0);
        assert_eq!(o.log[0].action, Action::DeliveredLate);
    }

    #[test]
    fn replay_sends_the_old_packet_with_its_old_sequence_number() {
        let mut a = LinkAttack::everywhere(LinkAttackKind::Replay { lag_steps: 10 });
        a.start_s = 0.15;
        let mut c = channel(vec![a]);
        gate(&mut c, 0, &[packet(1, 1, 0)], &states(3));
        gate(&mut c, 5, &[packet(1, 2, 5)], &states(3));
        let o = gate(&mut c, 16, &[packet(1, 3, 16)], &states(3));
        assert_eq!(
            o.deliveries[0].packet.seq, 2,
            "the packet of step 5 <= 16 - 10"
        );
        assert_eq!(o.log[0].action, Action::Replayed);
        assert_eq!(o.log[0].detail, Some(5));
    }

    #[test]
    fn false_data_offsets_only_the_targeted_sender() {
        let mut a = LinkAttack::everywhere(LinkAttackKind::FalseData {
            offset: [2.0, 0.0, 0.0],
        });
        a.senders = vec![VehicleId(1)];
        let mut c = channel(vec![a]);
        let o = gate(&mut c, 0, &[packet(0, 1, 0), packet(1, 1, 0)], &states(3));
        assert_eq!(o.deliveries[0].packet.state[0], 0.0);
        assert_eq!(o.deliveries[1].packet.state[0], 3.0);
    }

    /// Follower 1's packet to followers 2 and 3 (a two-predecessor graph) under `attacks`, at
    /// steps `0..steps`: what each receiver got, per step.
    fn two_receivers(attacks: Vec<LinkAttack>, steps: u64) -> (Vec<[State; 2]>, Vec<ChannelEvent>) {
        let topology = Topology::preset(platoon_topology::Preset::Tpsf, 3).unwrap();
        let mut c = channel(attacks);
        let (mut got, mut log) = (Vec::new(), Vec::new());
        for k in 0..steps {
            let mut out = Vec::new();
            c.gate(
                k,
                k as f64 * 0.01,
                &topology,
                &states(3),
                &[packet(1, k as u32 + 1, k)],
                &mut out,
                &mut [false; 4],
                &mut log,
            );
            assert_eq!(out.len(), 2);
            got.push([out[0].packet.state, out[1].packet.state]);
        }
        (got, log)
    }

    #[test]
    fn a_random_offset_is_seeded_zero_mean_per_link_and_one_lie_per_packet_for_an_insider() {
        let noisy = |insider| {
            vec![LinkAttack {
                insider,
                ..LinkAttack::everywhere(LinkAttackKind::RandomOffset {
                    std: [0.5, 0.1, 0.0],
                })
            }]
        };
        let (outsider, log) = two_receivers(noisy(false), 4000);
        assert_eq!(outsider, two_receivers(noisy(false), 4000).0, "seeded");
        assert_eq!(log.len(), 8000);
        assert!(log.iter().all(|e| e.action == Action::Altered));
        let sent = packet(1, 1, 0).state;
        let errors: Vec<State> = outsider.iter().flatten().map(|x| x - sent).collect();
        let n = errors.len() as f64;
        for (i, sd) in [0.5, 0.1].into_iter().enumerate() {
            let mean = errors.iter().map(|e| e[i]).sum::<f64>() / n;
            let var = errors.iter().map(|e| (e[i] - mean).powi(2)).sum::<f64>() / n;
            assert!(mean.abs() < 4.0 * sd / n.sqrt(), "mean {mean}");
            assert!((var.sqrt() / sd - 1.0).abs() < 0.05, "sd {}", var.sqrt());
        }
        assert!(errors.iter().all(|e| e[2] == 0.0));
        // An outsider's receivers get different noise; an insider's the same lie.
        assert!(outsider.iter().all(|[a, b]| a != b));
        let (insider, log) = two_receivers(noisy(true), 100);
        assert!(insider.iter().all(|[a, b]| a == b && *a != sent));
        assert_eq!(log.len(), 200);
        assert!(log.iter().all(|e| e.action == Action::Altered));
    }

    #[test]
    fn a_drift_grows_from_the_attacks_start() {
        let mut a = LinkAttack::everywhere(LinkAttackKind::Drift {
            rate: [0.1, 0.0, 0.0],
        });
        a.start_s = 0.5;
        let (got, log) = two_receivers(vec![a], 151);
        let sent = packet(1, 1, 0).state;
        assert_eq!(got[49][0], sent, "inactive before its start");
        assert_eq!(got[50][0], sent, "no offset yet at its start");
        assert!((got[150][0][0] - sent[0] - 0.1).abs() < 1e-12);
        assert_eq!(got[150][0].as_slice()[1..], sent.as_slice()[1..]);
        assert_eq!(log.len(), 2 * 101);
    }

    #[test]
    fn feigned_braking_and_a_scaled_acceleration_change_only_the_acceleration() {
        let mut sent = packet(1, 1, 0).state;
        sent[2] = 0.5;
        for (kind, a) in [
            (LinkAttackKind::FeignedBraking { accel: -6.0 }, -6.0),
            (LinkAttackKind::AccelScale { factor: 3.0 }, 1.5),
        ] {
            let mut c = channel(vec![LinkAttack::everywhere(kind)]);
            let mut tx = packet(1, 1, 0);
            tx.state = sent;
            let o = gate(&mut c, 0, &[tx], &states(3));
            let got = o.deliveries[0].packet.state;
            assert_eq!((got[0], got[1], got[2]), (sent[0], sent[1], a));
            assert_eq!(o.log[0].action, Action::Altered);
        }
    }

    #[test]
    fn the_new_kinds_draw_nothing_from_the_stream_of_the_old_ones() {
        let loss = || LinkAttack::everywhere(LinkAttackKind::Bernoulli { loss: 0.5 });
        let mut later = LinkAttack::everywhere(LinkAttackKind::RandomOffset { std: [1.0; 3] });
        later.start_s = 100.0;
        let drift = LinkAttack::everywhere(LinkAttackKind::Drift { rate: [1.0; 3] });
        let received = |attacks: Vec<LinkAttack>| {
            let mut c = channel(attacks);
            (0..500)
                .map(|k| {
                    gate(&mut c, k, &[packet(1, 1, k)], &states(3))
                        .deliveries
                        .len()
                })
                .collect::<Vec<_>>()
        };
        let alone = received(vec![loss()]);
        assert_eq!(alone, received(vec![loss(), later]));
        assert_eq!(alone, received(vec![drift, loss()]));
    }

    #[test]
    fn a_range_jammer_silences_the_vehicles_within_its_radius() {
        let mut c = channel(vec![LinkAttack::everywhere(LinkAttackKind::RangeJamming {
            position_m: -10.0,
            speed_mps: 0.0,
            radius_m: 5.0,
        })]);
        // Vehicle 1 sits at -10 m: it neither sends nor receives; 2 -> 3 still works.
        let tx = [packet(0, 1, 0), packet(1, 1, 0), packet(2, 1, 0)];
        let o = gate(&mut c, 0, &tx, &states(3));
        assert_eq!(o.jammed, vec![false, true, false, false]);
        let got: Vec<(u16, u16)> = o
            .deliveries
            .iter()
            .map(|d| (d.packet.sender.0, d.receiver.0))
            .collect();
        assert_eq!(got, vec![(2, 3)]);
        assert_eq!(o.log.len(), 2);
    }
}
