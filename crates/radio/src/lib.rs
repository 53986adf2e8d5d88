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
mod propagation;

pub use load::{LoadFamily, LoadPoint};

use fer::{FerCurve, FER_TABLE, FLOOR_STEP_DB};
use math::{cdf, gauss_hermite, upper_tail};
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
/// The data rates of 802.11 OFDM in a 20 MHz channel (Mbps); a channel of `B` MHz scales them by
/// `B / 20` (3 .. 27 Mbps in 802.11p's 10 MHz).
const OFDM_RATES_20MHZ: [f64; 8] = [6.0, 9.0, 12.0, 18.0, 24.0, 36.0, 48.0, 54.0];

/// The configuration of the 802.11p model: the traffic, the radio and the channel. `default()`
/// is the paper's base case (0.06 veh/m, 10 Hz, 23 dBm, 6 Mbps, 190 bytes) with the paper's
/// radio and propagation constants.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct Params80211p {
    /// Vehicles per metre of road, evenly spaced (the paper: 0.06 and 0.12). In [0, 1] (0: no
    /// other traffic). As `[channel.radio]` of a run, the traffic besides the simulated
    /// vehicles (which `[channel] load = "scenario"` adds, counted from the run).
    pub density_veh_per_m: f64,
    /// Packets each vehicle broadcasts per second (the paper: 10 and 25). In (0, 100]. As
    /// `[channel.radio]` of a run, the beacon rate of that other traffic.
    pub beacon_hz: f64,
    /// Transmit power, dBm (the paper: 15, 23, 30). In [-10, 33].
    pub tx_power_dbm: f64,
    /// PHY data rate, Mbps: one of 802.11's OFDM rates for the channel's bandwidth (3, 4.5, 6, 9,
    /// 12, 18, 24, 27 in 10 MHz; the paper: 6, 18, 27).
    pub data_rate_mbps: f64,
    /// Payload of a packet, bytes (the paper: 190 and 500). In 1 ..= 2304.
    pub packet_bytes: u32,
    /// MAC and upper-layer headers added to each packet, bytes (the paper: 30). At most 1000.
    pub header_bytes: u32,
    /// PHY preamble and SIGNAL field, µs (802.11p in 10 MHz: 32 + 8 = 40). In [0, 1000].
    pub preamble_us: f64,
    /// Channel bandwidth, MHz (10). In (0, 160].
    pub bandwidth_mhz: f64,
    /// Background noise in the channel, dBm (-95: 10 MHz with a 9 dB noise figure).
    pub noise_dbm: f64,
    /// Carrier-sense (and reception) threshold, dBm (-85).
    pub sensing_threshold_dbm: f64,
    /// The MAC's slot time, µs (13 in 802.11p). In [0, 1000].
    pub slot_us: f64,
    /// Carrier frequency, GHz (5.89). In (0, 100].
    pub carrier_ghz: f64,
    /// Height of every antenna, m (1.5). Above `environment_height_m`, at most 100.
    pub antenna_height_m: f64,
    /// Effective height of the environment for WINNER+ B1, m (0.5). In [0, antenna height).
    pub environment_height_m: f64,
    /// Standard deviation of the log-normal shadowing, dB (3). In (0, 30].
    pub shadowing_db: f64,
    /// Interferers are counted up to this distance from the receiver, m (1000). In [0, 10000].
    pub interferer_range_m: f64,
    /// Sensing is summed up to this distance for the channel busy ratio and its correlation, m
    /// (1500). In [1, 10000].
    pub sensing_horizon_m: f64,
    /// Distance between the points of the precomputed table, m (1). In [0.1, 50].
    pub table_step_m: f64,
}

impl Default for Params80211p {
    fn default() -> Self {
        Params80211p {
            density_veh_per_m: 0.06,
            beacon_hz: 10.0,
            tx_power_dbm: 23.0,
            data_rate_mbps: 6.0,
            packet_bytes: 190,
            header_bytes: 30,
            preamble_us: 40.0,
            bandwidth_mhz: 10.0,
            noise_dbm: -95.0,
            sensing_threshold_dbm: -85.0,
            slot_us: 13.0,
            carrier_ghz: 5.89,
            antenna_height_m: 1.5,
            environment_height_m: 0.5,
            shadowing_db: 3.0,
            interferer_range_m: 1000.0,
            sensing_horizon_m: 1500.0,
            table_step_m: 1.0,
        }
    }
}

/// Why a model could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// A parameter is out of the range the model accepts.
    #[error("802.11p model: {name} = {value} is invalid: {requirement}")]
    Parameter {
        /// The field of [`Params80211p`] at fault.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// The frame error rate table shipped with the crate does not parse (a build defect).
    #[error("802.11p model: data/fer_goubet2015.csv: {0}")]
    FerTable(String),
}

impl Params80211p {
    /// How far a transmitter of `power_dbm` is heard above the sensing threshold, at the mean
    /// path loss of these parameters (no shadowing): within it, a receiver senses its channel
    /// busy (m; 0 when not even at 1 m).
    pub fn sensing_radius_m(&self, power_dbm: f64) -> f64 {
        let path_loss = PathLoss::new(self);
        let heard = |d: f64| power_dbm - path_loss.db(d) >= self.sensing_threshold_dbm;
        if !heard(1.0) {
            return 0.0;
        }
        let (mut lo, mut hi) = (1.0, 1.0e5);
        if heard(hi) {
            return hi;
        }
        // The path loss grows with distance: bisection to a millimetre.
        while hi - lo > 1e-3 {
            let mid = 0.5 * (lo + hi);
            if heard(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// Checks every field against its documented range; the error names the first at fault.
    pub fn validate(&self) -> Result<(), Error> {
        fn check(
            name: &'static str,
            value: f64,
            ok: bool,
            requirement: &'static str,
        ) -> Result<(), Error> {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(Error::Parameter {
                    name,
                    value,
                    requirement,
                })
            }
        }
        let p = self;
        let within = |v: f64, lo: f64, hi: f64| v >= lo && v <= hi;
        check(
            "density_veh_per_m",
            p.density_veh_per_m,
            p.density_veh_per_m >= 0.0 && p.density_veh_per_m <= 1.0,
            "vehicles per metre must be in [0, 1]",
        )?;
        check(
            "beacon_hz",
            p.beacon_hz,
            p.beacon_hz > 0.0 && p.beacon_hz <= 100.0,
            "must be in (0, 100] packets per second",
        )?;
        check(
            "tx_power_dbm",
            p.tx_power_dbm,
            within(p.tx_power_dbm, -10.0, 33.0),
            "must be in [-10, 33] dBm",
        )?;
        check(
            "bandwidth_mhz",
            p.bandwidth_mhz,
            p.bandwidth_mhz > 0.0 && p.bandwidth_mhz <= 160.0,
            "must be in (0, 160] MHz",
        )?;
        let scale = p.bandwidth_mhz / 20.0;
        check(
            "data_rate_mbps",
            p.data_rate_mbps,
            OFDM_RATES_20MHZ
                .iter()
                .any(|r| (r * scale - p.data_rate_mbps).abs() <= 1e-9 * r * scale),
            "must be an 802.11 OFDM rate for the bandwidth (in 10 MHz: 3, 4.5, 6, 9, 12, 18, 24, 27)",
        )?;
        check(
            "packet_bytes",
            p.packet_bytes as f64,
            (1..=2304).contains(&p.packet_bytes),
            "must be in 1 ..= 2304 bytes",
        )?;
        check(
            "header_bytes",
            p.header_bytes as f64,
            p.header_bytes <= 1000,
            "must be at most 1000 bytes",
        )?;
        check(
            "preamble_us",
            p.preamble_us,
            within(p.preamble_us, 0.0, 1000.0),
            "must be in [0, 1000] µs",
        )?;
        check("noise_dbm", p.noise_dbm, true, "must be finite")?;
        check(
            "sensing_threshold_dbm",
            p.sensing_threshold_dbm,
            true,
            "must be finite",
        )?;
        check(
            "slot_us",
            p.slot_us,
            within(p.slot_us, 0.0, 1000.0),
            "must be in [0, 1000] µs",
        )?;
        check(
            "carrier_ghz",
            p.carrier_ghz,
            p.carrier_ghz > 0.0 && p.carrier_ghz <= 100.0,
            "must be in (0, 100] GHz",
        )?;
        check(
            "environment_height_m",
            p.environment_height_m,
            p.environment_height_m >= 0.0,
            "must be at least 0 m",
        )?;
        check(
            "antenna_height_m",
            p.antenna_height_m,
            p.antenna_height_m > p.environment_height_m && p.antenna_height_m <= 100.0,
            "must be above environment_height_m and at most 100 m",
        )?;
        check(
            "shadowing_db",
            p.shadowing_db,
            p.shadowing_db > 0.0 && p.shadowing_db <= 30.0,
            "must be in (0, 30] dB",
        )?;
        check(
            "interferer_range_m",
            p.interferer_range_m,
            within(p.interferer_range_m, 0.0, 10_000.0),
            "must be in [0, 10000] m",
        )?;
        check(
            "sensing_horizon_m",
            p.sensing_horizon_m,
            within(p.sensing_horizon_m, 1.0, 10_000.0),
            "must be in [1, 10000] m",
        )?;
        check(
            "table_step_m",
            p.table_step_m,
            within(p.table_step_m, 0.1, 50.0),
            "must be in [0.1, 50] m",
        )?;
        Ok(())
    }
}

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
        PathLoss::new(&self.params).db(distance_m)
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
        let path_loss = PathLoss::new(&p);
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

/// `10 log10(10^(a/10) + 10^(b/10))` without overflow.
fn power_sum_dbm(a: f64, b: f64) -> f64 {
    let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
    hi + 10.0 * (10f64.powf((lo - hi) / 10.0)).ln_1p() / std::f64::consts::LN_10
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
