//! Delivery of IEEE 802.11p broadcasts against distance and channel load, as a pure library (no
//! I/O, clocks or threads).
//!
//! This is the analytical model of Sepulcre, Gonzalez-Martin, Gozalvez, Molina-Masegosa and
//! Coll-Perales, "Analytical Models of the Performance of IEEE 802.11p Vehicle to Vehicle
//! Communications", IEEE TVT 71(1), 2022 (arXiv 2104.07923), written anew from its equations.
//! Vehicles stand on a line every `1 / density` metres, each broadcasting `beacon_hz` packets a
//! second; a packet sent over `d` metres is lost for the first of four reasons that applies:
//!
//! 1. **below sensing** (`SEN`): its received power, `Pt - PL(d)` plus normal shadowing, is below
//!    the sensing threshold, so the receiver does not even detect it;
//! 2. **receiver busy** (`RXB`): the receiver is already decoding (or, for an interferer closer
//!    than the transmitter that starts in the same slot, locks on to) another vehicle's packet;
//! 3. **propagation** (`PRO`): without interference the SNR is too low (the frame error rate of
//!    the receiver averaged over the shadowed SNR);
//! 4. **collision** (`COL`): another vehicle transmits during the packet, either in the same
//!    back-off slot although it senses the transmitter, or at any time within the packet's length
//!    when it does not sense it (a hidden terminal), and the SINR is too low.
//!
//! The packet delivery ratio is `1 - SEN - RXB - PRO - COL` ([`Model::pdr`]); the channel busy ratio
//! follows from the sensed transmissions ([`Model::cbr`]). The docs page `docs/channel-80211p.md`
//! has the equations in full, the parameters and the validation against the authors' published
//! simulations (`tests/published.rs`).
//!
//! [`Model::new`] does the model's integrals once per configuration and keeps a table of the four
//! error probabilities against distance, so [`Model::pdr`] is a lookup with linear interpolation
//! (a few nanoseconds). Building a model costs milliseconds: build one per configuration and share
//! it (it is `Send + Sync` and cheap to clone behind an `Arc`).
//!
//! ```
//! use platoon_radio::{Model, Params80211p};
//!
//! let model = Model::new(Params80211p { density_veh_per_m: 0.12, ..Params80211p::default() })?;
//! assert!(model.pdr(20.0) > 0.9);
//! assert!(model.pdr(400.0) < 0.1);
//! assert!(model.cbr() > 0.1 && model.cbr() < 0.3);
//! # Ok::<(), platoon_radio::Error>(())
//! ```
#![warn(missing_docs)]

mod fer;
mod interference;
mod load;
mod math;
mod params;
mod propagation;

pub use load::{LoadFamily, LoadPoint};
pub use params::{Error, Params80211p};

use fer::{FerCurve, FER_TABLE, FLOOR_STEP_DB};
use math::{cdf, gauss_hermite, power_sum_dbm, upper_tail};
use propagation::PathLoss;

/// Gauss-Hermite nodes for the average over the interferer's shadowing.
const INTERFERENCE_NODES: usize = 12;
/// Spacing of the mean received signal powers the interference factors are computed at (dB);
/// they are interpolated linearly in between.
const SIGNAL_STEP_DB: f64 = 0.5;
/// The table ends at the first distance where a packet is sensed with at most this probability
/// (the delivery ratio is then at most this too); [`Model::pdr`] is 0 from there on.
const SENSED_AT_RANGE: f64 = 1e-9;
/// The table never extends beyond this distance (m).
const MAX_RANGE_M: f64 = 20_000.0;
/// Sensing probabilities below this are left out of the autocorrelation of sensing.
const SENSING_NEGLIGIBLE: f64 = 1e-12;
/// The probabilities of the four ways a packet is lost at one distance, as fractions of all
/// packets sent (so they add up to `1 - PDR`): each counts the packets not already lost to the
/// ones before it, in the paper's order.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Losses {
    /// Received power below the sensing threshold (`SEN`).
    pub below_sensing: f64,
    /// Receiver busy with another packet (`RXB`).
    pub receiver_busy: f64,
    /// SNR too low without interference (`PRO`).
    pub propagation: f64,
    /// Collision with a concurrent or hidden transmission (`COL`).
    pub collision: f64,
}

impl Losses {
    /// The packet delivery ratio these losses leave: `1 - SEN - RXB - PRO - COL`.
    pub fn pdr(&self) -> f64 {
        (1.0 - self.below_sensing - self.receiver_busy - self.propagation - self.collision)
            .clamp(0.0, 1.0)
    }

    fn lerp(&self, other: &Losses, t: f64) -> Losses {
        let mix = |a: f64, b: f64| a + (b - a) * t;
        Losses {
            below_sensing: mix(self.below_sensing, other.below_sensing),
            receiver_busy: mix(self.receiver_busy, other.receiver_busy),
            propagation: mix(self.propagation, other.propagation),
            collision: mix(self.collision, other.collision),
        }
    }
}

/// The 802.11p model for one configuration: the channel busy ratio and a table of the losses
/// against distance, built once by [`Model::new`].
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    params: Params80211p,
    tx_duration_s: f64,
    offered_load: f64,
    cbr: f64,
    /// `losses[k]` at `k * table_step_m`; the last point is the range.
    losses: Vec<Losses>,
    /// `pdr[k]` of `losses[k]`, kept apart for the per-packet lookup.
    pdr: Vec<f64>,
    /// What survives a jammer's interference, built on first use.
    interference: interference::InterferenceTable,
}

/// Beyond the table: nothing is sensed.
const OUT_OF_RANGE: Losses = Losses {
    below_sensing: 1.0,
    receiver_busy: 0.0,
    propagation: 0.0,
    collision: 0.0,
};

impl Model {
    /// Validates `params` and evaluates the model at every table point from 0 m to the range
    /// (where a packet is sensed with probability at most 1e-9).
    pub fn new(params: Params80211p) -> Result<Model, Error> {
        params.validate()?;
        let fer = FerCurve::parse(FER_TABLE).map_err(Error::FerTable)?;
        Ok(Builder::new(params, fer).build())
    }

    /// The packet delivery ratio at `distance_m` (either sign, the model is symmetric): the table
    /// interpolated linearly, 0 beyond [`Model::range_m`] and for a distance that is not a number.
    pub fn pdr(&self, distance_m: f64) -> f64 {
        match self.locate(distance_m) {
            Some((i, t)) => self.pdr[i] + (self.pdr[i + 1] - self.pdr[i]) * t,
            None => 0.0,
        }
    }

    /// The four loss probabilities at `distance_m`, interpolated like [`Model::pdr`]; beyond the
    /// range every packet is below sensing.
    pub fn losses(&self, distance_m: f64) -> Losses {
        match self.locate(distance_m) {
            Some((i, t)) => self.losses[i].lerp(&self.losses[i + 1], t),
            None => OUT_OF_RANGE,
        }
    }

    /// The table interval holding `distance_m` and the position within it, if within the range.
    fn locate(&self, distance_m: f64) -> Option<(usize, f64)> {
        let x = distance_m.abs() / self.params.table_step_m;
        if x.is_nan() || x >= (self.pdr.len() - 1) as f64 {
            return None;
        }
        let i = x as usize;
        Some((i, x - i as f64))
    }

    /// The channel busy ratio: the fraction of time a vehicle senses the channel busy, from the
    /// paper's quadratic fit of the offered load ([`Model::offered_load`]).
    pub fn cbr(&self) -> f64 {
        self.cbr
    }

    /// The offered load: the fraction of time the channel would be sensed busy if transmissions
    /// never overlapped, `density * beacon_hz * tx duration * sum over positions of the sensing
    /// probability` (the paper's CBR before its fit for overlaps).
    pub fn offered_load(&self) -> f64 {
        self.offered_load
    }

    /// Airtime of one packet, s: preamble plus `(packet + header) * 8 / rate`.
    pub fn tx_duration_s(&self) -> f64 {
        self.tx_duration_s
    }

    /// Where the table ends, m: the first table point at which a packet is sensed with probability
    /// at most 1e-9. [`Model::pdr`] is 0 from there on.
    pub fn range_m(&self) -> f64 {
        (self.pdr.len() - 1) as f64 * self.params.table_step_m
    }

    /// The configuration this model was built for.
    pub fn params(&self) -> &Params80211p {
        &self.params
    }

    /// The table: `(distance_m, losses)` at every point from 0 m to the range.
    pub fn table(&self) -> impl Iterator<Item = (f64, Losses)> + '_ {
        let step = self.params.table_step_m;
        self.losses
            .iter()
            .enumerate()
            .map(move |(k, l)| (k as f64 * step, *l))
    }

    /// Path loss (dB, WINNER+ B1 line of sight) over `distance_m` with this model's geometry.
    pub fn path_loss_db(&self, distance_m: f64) -> f64 {
        self.params.path_loss().db(distance_m)
    }

    /// The packet delivery ratio at `distance_m` when an interferer adds `interference_dbm` of
    /// constant mean power at the receiver (a jammer's transmit power minus its path loss): the
    /// propagation term's frame error rate evaluated against noise plus interference instead of
    /// noise, the other losses unchanged (the approximation of `interference`). Exactly
    /// [`Model::pdr`] for `-inf` (or NaN: no interferer); 0 beyond the range or when the
    /// interference is 40 dB above the strongest signal. Interpolated linearly in distance and
    /// in the interference-plus-noise level (0.25 dB steps); the table behind it is built on the
    /// first call (tens of milliseconds), then a call costs a few tens of nanoseconds.
    pub fn pdr_with_interference(&self, distance_m: f64, interference_dbm: f64) -> f64 {
        if interference_dbm.is_nan() || interference_dbm == f64::NEG_INFINITY {
            return self.pdr(distance_m);
        }
        let Some((k, t)) = self.locate(distance_m) else {
            return 0.0;
        };
        let table = self.interference.keep(&self.params, self.pdr.len());
        let noise = self.params.noise_dbm;
        let x = (power_sum_dbm(interference_dbm, noise) - noise).max(0.0) / FLOOR_STEP_DB;
        // Beyond the table (an interference above every signal, or infinite): nothing gets
        // through.
        if !x.is_finite() || x >= table.top() {
            return 0.0;
        }
        let at = |k: usize| self.pdr[k] * table.at(k, x);
        let (a, b) = (at(k), at(k + 1));
        a + (b - a) * t
    }
}

/// The quantities every distance shares, and the model's evaluation at one distance.
struct Builder {
    p: Params80211p,
    fer: FerCurve,
    path_loss: PathLoss,
    tx_duration_s: f64,
    offered_load: f64,
    cbr: f64,
    /// Eb/No minus SINR, dB: `10 log10(bandwidth / rate)`.
    eb_no_offset_db: f64,
    /// Probability of sensing a transmission over each whole metre of distance, 0 ..= horizon.
    sensed: Vec<f64>,
    /// Normalised autocorrelation of the sensing probability along the road, per metre of lag.
    sensing_correlation: Vec<f64>,
    /// Distances from the receiver to the interferers on one side, m (`j / density`, j >= 1).
    interferer_m: Vec<f64>,
    /// Probability that the receiver senses each of them.
    interferer_sensed: Vec<f64>,
    /// Levels of interference plus noise at which the frame error rate is tabulated per signal
    /// power: `noise_dbm + n FLOOR_STEP_DB`, n < `floor_levels`.
    floor_levels: usize,
    /// For each interferer (outer) and Gauss-Hermite node of its shadowing (inner): the node's
    /// weight and its interference-plus-noise level as a fractional index into those levels.
    floors: Vec<Vec<(f64, f64)>>,
}

/// The interference factor of every interferer on a grid of mean received signal powers: row
/// `i` is for `top_dbm - i * SIGNAL_STEP_DB`, column `j` for the j-th nearest interferer on one
/// side. Rows are interpolated linearly for the signal power at a distance.
struct InterferenceRows {
    top_dbm: f64,
    rows: Vec<Vec<f64>>,
}

impl InterferenceRows {
    /// The factors at mean signal power `signal_dbm`, into `out`.
    fn at(&self, signal_dbm: f64, out: &mut [f64]) {
        let x = ((self.top_dbm - signal_dbm) / SIGNAL_STEP_DB).max(0.0);
        let i = (x as usize).min(self.rows.len() - 1);
        let (a, b) = (&self.rows[i], &self.rows[(i + 1).min(self.rows.len() - 1)]);
        let t = (x - i as f64).min(1.0);
        for (o, (a, b)) in out.iter_mut().zip(a.iter().zip(b)) {
            *o = a + (b - a) * t;
        }
    }
}

impl Builder {
    fn new(p: Params80211p, fer: FerCurve) -> Builder {
        let path_loss = p.path_loss();
        // Probability of sensing a transmission over each whole metre of distance up to the
        // horizon (the sequence is symmetric about the receiver).
        let horizon = p.sensing_horizon_m.round() as usize;
        let sensed: Vec<f64> = (0..=horizon)
            .map(|k| sensed_probability(&p, &path_loss, k as f64))
            .collect();
        let sensed_total = sensed[0] + 2.0 * sensed[1..].iter().sum::<f64>();
        let tx_duration_s = p.preamble_us * 1e-6
            + (p.packet_bytes + p.header_bytes) as f64 * 8.0 / (p.data_rate_mbps * 1e6);
        let offered_load = p.density_veh_per_m * p.beacon_hz * tx_duration_s * sensed_total;
        let cbr = cbr_fit(offered_load);
        let sensing_correlation = autocorrelation(&sensed);
        let spacing = 1.0 / p.density_veh_per_m;
        let count = (p.interferer_range_m * p.density_veh_per_m).round() as usize;
        let interferer_m: Vec<f64> = (1..=count).map(|j| j as f64 * spacing).collect();
        let interferer_dbm: Vec<f64> = interferer_m
            .iter()
            .map(|&r| p.tx_power_dbm - path_loss.db(r))
            .collect();
        let interferer_sensed = interferer_m
            .iter()
            .map(|&r| sensed_probability(&p, &path_loss, r))
            .collect();
        let (z, w) = gauss_hermite(INTERFERENCE_NODES);
        let floors: Vec<Vec<(f64, f64)>> = interferer_dbm
            .iter()
            .map(|&mean| {
                z.iter()
                    .zip(&w)
                    .map(|(zk, wk)| {
                        let floor = power_sum_dbm(mean + p.shadowing_db * zk, p.noise_dbm);
                        (*wk, (floor - p.noise_dbm) / FLOOR_STEP_DB)
                    })
                    .collect()
            })
            .collect();
        let floor_levels = floors
            .iter()
            .flatten()
            .map(|&(_, x)| x.ceil() as usize + 2)
            .max()
            .unwrap_or(1);
        Builder {
            eb_no_offset_db: 10.0 * (p.bandwidth_mhz / p.data_rate_mbps).log10(),
            p,
            fer,
            path_loss,
            tx_duration_s,
            offered_load,
            cbr,
            sensed,
            sensing_correlation,
            interferer_m,
            interferer_sensed,
            floor_levels,
            floors,
        }
    }

    fn build(self) -> Model {
        let p = &self.p;
        let step = p.table_step_m;
        // The table's last point: the first where a packet is sensed with at most
        // SENSED_AT_RANGE (the path loss grows with distance, so none after it is sensed more).
        let sensed_over = |d: f64| {
            let signal = p.tx_power_dbm - self.path_loss.db(d);
            upper_tail((p.sensing_threshold_dbm - signal) / p.shadowing_db)
        };
        let mut points = 1usize;
        while sensed_over(points as f64 * step) > SENSED_AT_RANGE
            && (points as f64 * step) < MAX_RANGE_M
        {
            points += 1;
        }
        let range = points as f64 * step;
        let top_dbm = p.tx_power_dbm - self.path_loss.db(0.0);
        let bottom_dbm = p.tx_power_dbm - self.path_loss.db(range);
        let rows = ((top_dbm - bottom_dbm) / SIGNAL_STEP_DB).ceil() as usize + 2;
        let interference = InterferenceRows {
            top_dbm,
            rows: (0..rows)
                .map(|i| self.interference(top_dbm - i as f64 * SIGNAL_STEP_DB))
                .collect(),
        };
        let mut factors = vec![0.0; self.interferer_m.len()];
        let losses: Vec<Losses> = (0..=points)
            .map(|k| self.at(k as f64 * step, &interference, &mut factors))
            .collect();
        let pdr = losses.iter().map(Losses::pdr).collect();
        Model {
            params: self.p,
            tx_duration_s: self.tx_duration_s,
            offered_load: self.offered_load,
            cbr: self.cbr,
            losses,
            pdr,
            interference: Default::default(),
        }
    }

    /// Mean frame error rate of a packet received with mean power `signal_dbm` when
    /// interference plus noise is `floor_dbm`, given that it was sensed: the shadowed power is
    /// normal and truncated at the sensing threshold, and Eb/No = SINR + 10 log10(B / R).
    fn frame_error(&self, signal_dbm: f64, floor_dbm: f64) -> f64 {
        let shift = self.eb_no_offset_db - floor_dbm;
        self.fer.mean_above(
            signal_dbm + shift,
            self.p.shadowing_db,
            self.p.sensing_threshold_dbm + shift,
        )
    }

    /// For a packet received with mean power `signal_dbm`, the probability that each interferer's
    /// packet, overlapping it, breaks a reception that noise alone would have let through: the
    /// frame error rate averaged over the interferer's shadowing (Gauss-Hermite), net of the
    /// error without it. The frame error rate is tabulated against the interference-plus-noise
    /// level every FLOOR_STEP_DB and interpolated linearly at the nodes.
    fn interference(&self, signal_dbm: f64) -> Vec<f64> {
        let p = &self.p;
        let offset = self.eb_no_offset_db;
        let by_floor = self.fer.mean_above_shifted(
            signal_dbm + offset,
            p.shadowing_db,
            p.sensing_threshold_dbm + offset,
            p.noise_dbm,
            self.floor_levels,
        );
        let alone = by_floor[0];
        if alone >= 1.0 - 1e-12 {
            return vec![0.0; self.floors.len()];
        }
        self.floors
            .iter()
            .map(|nodes| {
                let with: f64 = nodes
                    .iter()
                    .map(|&(weight, x)| {
                        let i = x as usize;
                        let t = x - i as f64;
                        weight * (by_floor[i] + (by_floor[i + 1] - by_floor[i]) * t)
                    })
                    .sum();
                ((with - alone) / (1.0 - alone)).clamp(0.0, 1.0)
            })
            .collect()
    }

    /// Probability of sensing a transmission over `distance_m`, from the per-metre table within
    /// the horizon.
    fn sensed_at(&self, distance_m: f64) -> f64 {
        let x = distance_m.abs();
        let i = x as usize;
        if i + 1 < self.sensed.len() {
            let s = &self.sensed;
            s[i] + (s[i + 1] - s[i]) * (x - i as f64)
        } else {
            sensed_probability(&self.p, &self.path_loss, x)
        }
    }

    /// Normalised sensing autocorrelation at a lag of `lag_m`, linear between whole metres and
    /// 0 beyond the computed lags.
    fn correlation(&self, lag_m: f64) -> f64 {
        let r = &self.sensing_correlation;
        let x = lag_m.abs();
        let i = x as usize;
        if i + 1 >= r.len() {
            return if i < r.len() { r[i] } else { 0.0 };
        }
        r[i] + (r[i + 1] - r[i]) * (x - i as f64)
    }

    /// The losses at `d` metres (`factors` is scratch space for the interference factors).
    fn at(&self, d: f64, interference: &InterferenceRows, factors: &mut [f64]) -> Losses {
        let p = &self.p;
        let signal_dbm = p.tx_power_dbm - self.path_loss.db(d);
        // Below sensing: the shadowed received power under the threshold.
        let sensed = upper_tail((p.sensing_threshold_dbm - signal_dbm) / p.shadowing_db);
        // Propagation: the frame error rate over the SNR of the sensed packet.
        let pro = self.frame_error(signal_dbm, p.noise_dbm);
        interference.at(signal_dbm, factors);

        let slot_s = p.slot_us * 1e-6;
        let (lambda, ttr) = (p.beacon_hz, self.tx_duration_s);
        let (mut rxb_keep, mut col_keep) = (1.0f64, 1.0f64);
        for ((&r, &rx_senses), &breaks) in self
            .interferer_m
            .iter()
            .zip(&self.interferer_sensed)
            .zip(factors.iter())
        {
            // The interferer stands at r on either side of the receiver; the transmitter at d.
            for tx_gap in [r + d, (r - d).abs()] {
                let senses_tx = self.sensed_at(tx_gap);
                // Its transmissions given that the transmitter found the channel idle: the
                // channel is idle for it too with a probability given by the correlation of
                // what the two sense.
                let idle = (1.0 - self.cbr * self.correlation(tx_gap)).max(1e-9);
                // It starts in the transmitter's slot (it senses the transmitter, so only a
                // simultaneous back-off end overlaps), or anywhere in a packet's airtime before
                // or during ours (it cannot sense the transmitter: a hidden terminal).
                let same_slot = slot_s * lambda * senses_tx / idle;
                let hidden = ttr * lambda * (1.0 - senses_tx) / idle;
                let closer = r < d;
                // Receiver busy: it locks onto a closer interferer starting in the same slot,
                // or is decoding a hidden terminal's packet that began before ours.
                let busy = if closer { same_slot * rx_senses } else { 0.0 } + hidden * rx_senses;
                // Collision: a farther interferer in the same slot, or a hidden terminal during
                // our packet (twice the window when the receiver cannot sense it, since then
                // one that began before ours does not make the receiver busy either).
                let collide = if closer { 0.0 } else { breaks * same_slot }
                    + breaks * hidden * (2.0 - rx_senses);
                rxb_keep *= 1.0 - busy.clamp(0.0, 1.0);
                col_keep *= 1.0 - collide.clamp(0.0, 1.0);
            }
        }
        let (rxb, col) = (1.0 - rxb_keep, 1.0 - col_keep);
        Losses {
            below_sensing: 1.0 - sensed,
            receiver_busy: rxb * sensed,
            propagation: pro * sensed * (1.0 - rxb),
            collision: col * sensed * (1.0 - rxb) * (1.0 - pro),
        }
    }
}

/// Probability that a transmission over `distance_m` is received above the sensing threshold.
fn sensed_probability(p: &Params80211p, path_loss: &PathLoss, distance_m: f64) -> f64 {
    cdf((p.tx_power_dbm - path_loss.db(distance_m) - p.sensing_threshold_dbm) / p.shadowing_db)
}

/// The paper's fit of the channel busy ratio to the offered load `u` (which ignores overlapping
/// transmissions): `-0.2481 u^2 + 0.913 u + 0.003844`, held at its maximum beyond its vertex.
fn cbr_fit(u: f64) -> f64 {
    const A: f64 = -0.2481;
    const B: f64 = 0.913;
    const C: f64 = 0.003844;
    let u = u.min(-B / (2.0 * A));
    A * u * u + B * u + C
}

/// Autocorrelation of the symmetric sequence `s[|x|]`, x in -n ..= n, at lags 0, 1, ...,
/// normalised to 1 at lag 0; terms below [`SENSING_NEGLIGIBLE`] are left out.
fn autocorrelation(s: &[f64]) -> Vec<f64> {
    let support = s.iter().rposition(|&v| v > SENSING_NEGLIGIBLE).unwrap_or(0);
    let full: Vec<f64> = (0..=2 * support).map(|i| s[i.abs_diff(support)]).collect();
    let dot = |lag: usize| -> f64 {
        full[..full.len() - lag]
            .iter()
            .zip(&full[lag..])
            .map(|(a, b)| a * b)
            .sum()
    };
    let zero = dot(0);
    if zero <= 0.0 {
        return vec![1.0];
    }
    (0..full.len()).map(|lag| dot(lag) / zero).collect()
}

#[cfg(test)]
mod tests;
