//! The 802.11p medium of one platoon's channel: the load each vehicle's radio sees, counted from
//! the run (the vehicles' own transmissions, the rest of the fleet, SUMO's background traffic
//! and the configured other traffic), the channel busy ratio it measures, and the access layer's
//! reactive decentralised congestion control (ETSI TS 102 687), which spaces a vehicle's
//! transmissions by at least the `T_off` of the state its CBR puts it in.
use platoon_model::State;
use platoon_radio::LoadFamily;
use platoon_v2v::Packet;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::sync::Arc;

/// Where the channel's load comes from (`[channel] load`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LoadSource {
    /// The configured traffic alone (`[channel.radio]`'s density and beacon rate), constant: the
    /// radio's model at that load, whatever the run's vehicles send.
    Fixed,
    /// The configured traffic plus every transmitter of the run within the radio's interferer
    /// range of a receiver: the platoon's vehicles and the fleet's at the rate measured over the
    /// last window, SUMO's background vehicles at the background rate.
    #[default]
    Scenario,
}

/// The beacon rate of the traffic the run does not simulate (`[channel] background_beacons`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackgroundBeacons {
    /// `[channel.radio] beacon_hz`.
    #[default]
    Fixed,
    /// The platoon's mean rate so far (transmissions per beaconing vehicle and second since the
    /// start; the configured rate in the first window): every vehicle on the road beacons as the
    /// platoon does, at other times.
    Platoon,
}

/// Reactive DCC's states: a vehicle whose measured CBR is below `cbr_thresholds[0]` waits at
/// least `t_off_s[0]` between two transmissions, below `cbr_thresholds[1]` `t_off_s[1]`, and so
/// on; at or above the last threshold the last `t_off_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct Dcc {
    /// The CBR limits of the states, increasing (one fewer than `t_off_s`).
    pub cbr_thresholds: Vec<f64>,
    /// The least time between two transmissions in each state (s), not decreasing.
    pub t_off_s: Vec<f64>,
}

impl Dcc {
    /// The state a vehicle measuring `cbr` is in (0: relaxed).
    pub fn state(&self, cbr: f64) -> usize {
        self.cbr_thresholds.partition_point(|&limit| cbr >= limit)
    }
}

/// The 802.11p radio of a channel (`[channel] model = "80211p"`).
#[derive(Debug, Clone)]
pub struct RadioSpec {
    /// The model at every load, shared by every channel of a configuration.
    pub family: Arc<LoadFamily>,
    /// Where the load comes from.
    pub load: LoadSource,
    /// The rate of the traffic the run does not simulate.
    pub background_beacons: BackgroundBeacons,
    /// Reactive DCC in the access layer, if on.
    pub dcc: Option<Dcc>,
    /// The window the vehicles' beacon rates are measured over, in steps (>= 1).
    pub window_steps: u64,
    /// The step (s).
    pub dt: f64,
}

impl PartialEq for RadioSpec {
    fn eq(&self, other: &Self) -> bool {
        self.family.params() == other.family.params()
            && self.load == other.load
            && self.background_beacons == other.background_beacons
            && self.dcc == other.dcc
            && self.window_steps == other.window_steps
            && self.dt == other.dt
    }
}

/// What the radio measured over a run (`summary.json`'s `channel`): the load and the channel
/// busy ratio the platoon's radios saw, and what DCC did.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RadioStats {
    /// Vehicle-steps measured.
    pub samples: u64,
    /// Mean load a vehicle's radio saw (packets per second per metre of road).
    pub mean_load: f64,
    /// Mean channel busy ratio the vehicles measured.
    pub mean_cbr: f64,
    /// Largest channel busy ratio a vehicle measured.
    pub max_cbr: f64,
    /// Packets the vehicles put on the air.
    pub transmissions: u64,
    /// Packets DCC held back for a later step.
    pub dcc_deferred: u64,
    /// Held-back packets DCC dropped because a newer one of the same vehicle replaced them.
    pub dcc_dropped: u64,
}

impl RadioStats {
    /// The six numbers a channel process reports with DONE (`ControlMsg::counts`): the means
    /// and the largest CBR as their bits, then the three counts. `samples` is not among them
    /// (every vehicle measures every step: the receiver knows it).
    pub fn to_counts(&self) -> [u64; 6] {
        [
            self.mean_load.to_bits(),
            self.mean_cbr.to_bits(),
            self.max_cbr.to_bits(),
            self.transmissions,
            self.dcc_deferred,
            self.dcc_dropped,
        ]
    }

    /// The stats [`RadioStats::to_counts`] reported, over `samples` vehicle-steps.
    pub fn from_counts(c: [u64; 6], samples: u64) -> RadioStats {
        RadioStats {
            samples,
            mean_load: f64::from_bits(c[0]),
            mean_cbr: f64::from_bits(c[1]),
            max_cbr: f64::from_bits(c[2]),
            transmissions: c[3],
            dcc_deferred: c[4],
            dcc_dropped: c[5],
        }
    }

    /// Adds another platoon's (a fleet's summary).
    pub fn merge(&mut self, other: &RadioStats) {
        let n = self.samples + other.samples;
        if n > 0 {
            let w =
                |a: f64, b: f64| (a * self.samples as f64 + b * other.samples as f64) / n as f64;
            self.mean_load = w(self.mean_load, other.mean_load);
            self.mean_cbr = w(self.mean_cbr, other.mean_cbr);
        }
        self.samples = n;
        self.max_cbr = self.max_cbr.max(other.max_cbr);
        self.transmissions += other.transmissions;
        self.dcc_deferred += other.dcc_deferred;
        self.dcc_dropped += other.dcc_dropped;
    }
}

/// The medium's state across steps.
#[derive(Debug, Clone)]
pub(crate) struct Medium {
    pub(crate) spec: RadioSpec,
    /// Per vehicle: the steps of its transmissions within the window, oldest first.
    sent: Vec<VecDeque<u64>>,
    /// Per vehicle, at the current step: the load its radio sees, where that is on the model's
    /// grid, and the CBR it measures.
    load: Vec<f64>,
    point: Vec<platoon_radio::LoadPoint>,
    cbr: Vec<f64>,
    /// Scratch: the vehicles' rates at the current step.
    rates: Vec<f64>,
    /// The rest of the fleet this step: (road position, beacon rate).
    fleet: Vec<(f64, f64)>,
    /// DCC: per vehicle, the packet held back and the step since which it is held, whether
    /// the packet it sends at the current step was held from an earlier one, and the step of
    /// its last transmission.
    held: Vec<Option<(Packet, u64)>>,
    late: Vec<bool>,
    last_sent: Vec<Option<u64>>,
    sum_load: f64,
    sum_cbr: f64,
    stats: RadioStats,
}

/// What DCC did to a packet.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Gated {
    /// Held back (to be sent later unless a newer one replaces it).
    Deferred(Packet),
    /// A held-back packet dropped for a newer one.
    Dropped(Packet),
}

impl Medium {
    pub(crate) fn new(spec: RadioSpec, vehicles: usize) -> Medium {
        Medium {
            spec,
            sent: vec![VecDeque::new(); vehicles],
            load: vec![f64::NAN; vehicles],
            point: vec![Default::default(); vehicles],
            cbr: vec![0.0; vehicles],
            rates: Vec::with_capacity(vehicles),
            fleet: Vec::new(),
            held: vec![None; vehicles],
            late: vec![false; vehicles],
            last_sent: vec![None; vehicles],
            sum_load: 0.0,
            sum_cbr: 0.0,
            stats: RadioStats::default(),
        }
    }

    /// Vehicle `v`'s beacon rate over the window before step `k` (Hz): its transmissions in
    /// steps `k - window ..= k - 1` (in the first window, over the steps so far; 0 at step 0),
    /// whatever happened at step `k` itself.
    pub(crate) fn rate(&self, v: usize, k: u64) -> f64 {
        let steps = k.min(self.spec.window_steps);
        if steps == 0 {
            return 0.0;
        }
        // The steps are increasing: two binary searches.
        let sent = &self.sent[v];
        let count = sent.partition_point(|&s| s < k) - sent.partition_point(|&s| s < k - steps);
        count as f64 / (steps as f64 * self.spec.dt)
    }

    /// Whether vehicle `v`'s packet on the air at the current step was held back by DCC from
    /// an earlier step.
    pub(crate) fn sent_late(&self, v: usize) -> bool {
        self.late.get(v).copied().unwrap_or(false)
    }

    pub(crate) fn set_fleet(&mut self, all: &[(f64, f64)], own: std::ops::Range<usize>) {
        self.fleet.clear();
        self.fleet.extend(
            all.iter()
                .enumerate()
                .filter(|(i, _)| !own.contains(i))
                .map(|(_, x)| *x),
        );
    }

    /// Measures, at step `k`, the load each vehicle's radio sees and its CBR.
    pub(crate) fn measure(&mut self, k: u64, states: &[State], background: &[f64]) {
        let vehicles = states.len().min(self.load.len());
        let own_load = self.spec.family.own_load();
        if self.spec.load == LoadSource::Scenario {
            let mut rates = std::mem::take(&mut self.rates);
            rates.clear();
            rates.extend((0..vehicles).map(|v| self.rate(v, k)));
            let p = self.spec.family.params();
            let background_hz = match self.spec.background_beacons {
                BackgroundBeacons::Fixed => p.beacon_hz,
                // Their long-run rate: the platoon's transmissions so far per vehicle and
                // second (other vehicles manoeuvre at other times than the platoon, so its
                // bursts are not theirs); the configured rate in the first window.
                // Over the vehicles that beacon at all (in a graph where nobody listens to the
                // last vehicle, it sends nothing).
                BackgroundBeacons::Platoon if k >= self.spec.window_steps => {
                    let beaconing = self.last_sent.iter().filter(|l| l.is_some()).count();
                    self.stats.transmissions as f64
                        / (beaconing.max(1) as f64 * k as f64 * self.spec.dt)
                }
                BackgroundBeacons::Platoon => p.beacon_hz,
            };
            let uniform = p.density_veh_per_m * background_hz;
            let reach = p.interferer_range_m;
            for r in 0..vehicles {
                let x = states[r][0];
                let near = |y: f64| (y - x).abs() <= reach;
                let counted = if reach > 0.0 {
                    let own: f64 = (0..vehicles)
                        .filter(|&i| near(states[i][0]))
                        .map(|i| rates[i])
                        .sum();
                    let fleet: f64 = self
                        .fleet
                        .iter()
                        .filter(|(y, _)| near(*y))
                        .map(|(_, hz)| hz)
                        .sum();
                    let sumo = background.iter().filter(|&&y| near(y)).count() as f64;
                    (own + fleet + sumo * background_hz) / (2.0 * reach)
                } else {
                    0.0
                };
                self.locate(r, uniform + counted);
            }
            self.rates = rates;
        } else {
            for r in 0..vehicles {
                self.locate(r, own_load);
            }
        }
        for v in 0..vehicles {
            self.sum_load += self.load[v];
            self.sum_cbr += self.cbr[v];
            self.stats.max_cbr = self.stats.max_cbr.max(self.cbr[v]);
        }
        self.stats.samples += vehicles as u64;
    }

    /// Vehicle `v`'s radio sees `load`: where it is on the grid and the CBR there, computed
    /// again only when the load changed (a beacon entering or leaving the window, a vehicle
    /// coming into or out of range).
    fn locate(&mut self, v: usize, load: f64) {
        if load.to_bits() != self.load[v].to_bits() {
            let family = &self.spec.family;
            self.load[v] = load;
            self.point[v] = family.point(load);
            self.cbr[v] = family.cbr_at(self.point[v]);
        }
    }

    /// The access layer at step `k`: which of `tx` (and of the packets held back before) go on
    /// the air now, into `on_air`; what DCC held back or dropped, into `gated`.
    pub(crate) fn access(
        &mut self,
        k: u64,
        tx: &[Packet],
        on_air: &mut Vec<Packet>,
        gated: &mut Vec<Gated>,
    ) {
        self.late.fill(false);
        let Some(dcc) = &self.spec.dcc else {
            on_air.extend_from_slice(tx);
            return;
        };
        let dt = self.spec.dt;
        // A vehicle may send at step k once T_off has passed since its last transmission (a
        // minimum: at the first step at or after it, up to rounding).
        let may_send = |last: Option<u64>, cbr: f64| {
            last.is_none_or(|l| (k - l) as f64 * dt >= dcc.t_off_s[dcc.state(cbr)] - 1e-9)
        };
        // The newest packet of each vehicle: this step's replaces one held back.
        for p in tx {
            let v = p.sender.index();
            if v >= self.held.len() {
                on_air.push(*p);
                continue;
            }
            if let Some((old, _)) = self.held[v].replace((*p, k)) {
                gated.push(Gated::Dropped(old));
                self.stats.dcc_dropped += 1;
            }
        }
        for v in 0..self.held.len() {
            let Some((p, since)) = self.held[v] else {
                continue;
            };
            if may_send(self.last_sent[v], self.cbr[v]) {
                on_air.push(p);
                self.held[v] = None;
                self.late[v] = since < k;
            } else if since == k {
                gated.push(Gated::Deferred(p));
                self.stats.dcc_deferred += 1;
            }
        }
        on_air.sort_by_key(|p| p.sender);
    }

    /// Records that `on_air` went on the air at step `k`, but for the senders that sense their
    /// channel jammed (`jammed`, the DoS included): they defer, and send nothing.
    pub(crate) fn record(&mut self, k: u64, on_air: &[Packet], jammed: &[bool]) {
        let keep_from = k.saturating_sub(self.spec.window_steps);
        let mut sent = 0;
        for p in on_air {
            let v = p.sender.index();
            if v < self.sent.len() && !jammed.get(v).copied().unwrap_or(false) {
                self.sent[v].push_back(k);
                self.last_sent[v] = Some(k);
                sent += 1;
            }
        }
        for s in &mut self.sent {
            while s.front().is_some_and(|&x| x < keep_from) {
                s.pop_front();
            }
        }
        self.stats.transmissions += sent;
    }

    /// The delivery ratio of a packet over `distance_m` to vehicle `receiver`, at the load its
    /// radio sees.
    pub(crate) fn pdr(&self, distance_m: f64, receiver: usize) -> f64 {
        self.spec.family.pdr_at(self.point[receiver], distance_m)
    }

    /// [`Medium::pdr`] with jammers' `interference_dbm` at the receiver (exactly `pdr` for
    /// `-inf`).
    pub(crate) fn pdr_with_interference(
        &self,
        distance_m: f64,
        receiver: usize,
        interference_dbm: f64,
    ) -> f64 {
        self.spec.family.pdr_with_interference_at(
            self.point[receiver],
            distance_m,
            interference_dbm,
        )
    }

    /// The load vehicle `v`'s radio saw at the last step (packets/s/m).
    #[cfg(test)]
    pub(crate) fn load(&self, v: usize) -> f64 {
        self.load[v]
    }

    /// The CBR each vehicle measured at the last step.
    pub(crate) fn cbr(&self) -> &[f64] {
        &self.cbr
    }

    pub(crate) fn stats(&self) -> RadioStats {
        let n = self.stats.samples.max(1) as f64;
        RadioStats {
            mean_load: self.sum_load / n,
            mean_cbr: self.sum_cbr / n,
            ..self.stats
        }
    }
}
