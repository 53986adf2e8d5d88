//! The configuration of the 802.11p model ([`Params80211p`]), its checks and the quantities that
//! follow from it alone (path loss, sensing radius), and why a model cannot be built ([`Error`]).
use crate::propagation::PathLoss;

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
        let path_loss = self.path_loss();
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

impl Params80211p {
    /// WINNER+ B1 path loss with these parameters' geometry (carrier, antenna and environment
    /// heights).
    pub(crate) fn path_loss(&self) -> PathLoss {
        PathLoss::new(
            self.carrier_ghz,
            self.antenna_height_m,
            self.environment_height_m,
        )
    }

    /// Mean path loss (dB, WINNER+ B1 line of sight) over `distance_m` with these parameters'
    /// geometry: what a jammer's power loses on its way to a receiver.
    pub fn path_loss_db(&self, distance_m: f64) -> f64 {
        self.path_loss().db(distance_m)
    }
}
