//! A jammer's interference in the SINR: the delivery ratio when a constant extra power adds to
//! the noise floor at the receiver (`Model::pdr_with_interference`, on the table this module
//! builds).
//!
//! The approximation: the jammer's power at the receiver is its mean received power (its path
//! loss, not shadowed) and constant over the packet, so it raises the floor the propagation term
//! (`PRO`) is evaluated against from the noise to noise plus interference (power sum). The other
//! three terms (below sensing, receiver busy, collision) are the model's at that distance,
//! unchanged: the delivery ratio is `pdr(d) (1 - FER(d, floor)) / (1 - FER(d, noise))`, with
//! FER the frame error rate averaged over the shadowed signal as the model's `PRO` term does.
use crate::fer::{FerCurve, FER_TABLE, FLOOR_STEP_DB};
use crate::params::Params80211p;
use std::sync::OnceLock;

/// How far above the strongest signal of the table the interference levels go (dB): beyond it
/// every frame is lost.
const ABOVE_SIGNAL_DB: f64 = 40.0;

/// Per table distance and interference-plus-noise level, the share of the model's deliveries
/// that survive the interference, built the first time a model is asked for one.
#[derive(Debug, Clone, Default)]
pub(crate) struct InterferenceTable(OnceLock<Table>);

/// Derived from the model's parameters alone: two models are equal whether or not theirs has
/// been built.
impl PartialEq for InterferenceTable {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

#[derive(Debug, Clone)]
struct Table {
    /// Levels per distance: floor `noise_dbm + n FLOOR_STEP_DB`, n < levels.
    levels: usize,
    /// `keep[k * levels + n]`: `(1 - FER at level n) / (1 - FER at the noise)` at table point k.
    keep: Vec<f64>,
}

impl Table {
    /// The table of a model of `p` whose distance table has `points` points.
    fn new(p: &Params80211p, points: usize) -> Table {
        let fer = FerCurve::parse(FER_TABLE).expect("the model parsed it when it was built");
        let path_loss = p.path_loss();
        let offset = 10.0 * (p.bandwidth_mhz / p.data_rate_mbps).log10();
        let top_dbm = p.tx_power_dbm - path_loss.db(0.0);
        let levels = ((top_dbm + ABOVE_SIGNAL_DB - p.noise_dbm) / FLOOR_STEP_DB)
            .ceil()
            .max(1.0) as usize
            + 2;
        let mut keep = Vec::with_capacity(points * levels);
        for k in 0..points {
            let signal_dbm = p.tx_power_dbm - path_loss.db(k as f64 * p.table_step_m);
            let by_floor = fer.mean_above_shifted(
                signal_dbm + offset,
                p.shadowing_db,
                p.sensing_threshold_dbm + offset,
                p.noise_dbm,
                levels,
            );
            let alone = by_floor[0];
            keep.extend(by_floor.iter().map(|&f| {
                if alone >= 1.0 {
                    0.0
                } else {
                    ((1.0 - f) / (1.0 - alone)).clamp(0.0, 1.0)
                }
            }));
        }
        Table { levels, keep }
    }
}

impl InterferenceTable {
    /// The table of a model of `p` with `points` distance table points, built on the first
    /// call.
    pub(crate) fn keep(&self, p: &Params80211p, points: usize) -> Keep<'_> {
        Keep(self.0.get_or_init(|| Table::new(p, points)))
    }
}

/// [`InterferenceTable::keep`]'s table, built.
pub(crate) struct Keep<'a>(&'a Table);

impl Keep<'_> {
    /// The largest floor the table holds, in steps of `FLOOR_STEP_DB` above the noise
    /// (exclusive).
    pub(crate) fn top(&self) -> f64 {
        (self.0.levels - 1) as f64
    }

    /// The share surviving at table point `k` and floor `x` (`0 <= x < top()`), interpolated
    /// linearly between levels.
    pub(crate) fn at(&self, k: usize, x: f64) -> f64 {
        let n = x as usize;
        let f = x - n as f64;
        let row = &self.0.keep[k * self.0.levels..];
        row[n] + (row[n + 1] - row[n]) * f
    }
}

#[cfg(test)]
mod tests {
    use crate::{Model, Params80211p};

    fn model() -> Model {
        Model::new(Params80211p::default()).unwrap()
    }

    #[test]
    fn without_interference_it_is_the_models_pdr() {
        let m = model();
        for d in [0.0, 10.0, 55.5, 300.0, 5000.0, f64::NAN] {
            let want = m.pdr(d);
            for i in [f64::NEG_INFINITY, f64::NAN] {
                let got = m.pdr_with_interference(d, i);
                assert!(got == want || (got.is_nan() && want.is_nan()), "{d} {i}");
            }
            // Far below the noise: the floor is the noise, to rounding.
            let faint = m.pdr_with_interference(d, -250.0);
            assert!((faint - want).abs() < 1e-12, "{d}: {faint} {want}");
        }
    }

    #[test]
    fn strong_interference_stops_every_packet() {
        let m = model();
        for d in [0.0, 20.0, 200.0] {
            assert!(m.pdr(d) > 0.0);
            // Far above the strongest signal (about -34 dBm at 3 m).
            assert_eq!(m.pdr_with_interference(d, 20.0), 0.0);
            // 10 dB above the signal at that distance: next to nothing gets through.
            let signal = m.params().tx_power_dbm - m.path_loss_db(d);
            assert!(m.pdr_with_interference(d, signal + 10.0) < 1e-3, "{d}");
        }
    }

    #[test]
    fn monotone_in_interference_and_distance() {
        let m = model();
        for d in [5.0, 50.0, 150.0, 400.0] {
            let mut last = m.pdr(d);
            for i in (0..=160).map(|j| -130.0 + 0.5 * j as f64) {
                let p = m.pdr_with_interference(d, i);
                assert!((0.0..=1.0).contains(&p));
                assert!(p <= last + 1e-12, "{d} m at {i} dBm: {p} > {last}");
                last = p;
            }
        }
        for i in [-100.0, -90.0, -80.0, -70.0] {
            let mut last = 1.0;
            for d in (0..600).map(f64::from) {
                let p = m.pdr_with_interference(d, i);
                assert!(p <= last + 1e-9, "{i} dBm at {d} m: {p} > {last}");
                last = p;
            }
        }
        // Interference at the noise level (the floor 3 dB up) costs a far link more than a near.
        let loss = |d: f64| m.pdr(d) - m.pdr_with_interference(d, m.params().noise_dbm);
        assert!(loss(300.0) > loss(20.0));
    }

    #[test]
    fn equal_models_stay_equal_once_one_has_its_table() {
        let (a, b) = (model(), model());
        a.pdr_with_interference(10.0, -80.0);
        assert_eq!(a, b);
        assert_eq!(
            a.clone().pdr_with_interference(10.0, -80.0),
            a.pdr_with_interference(10.0, -80.0)
        );
    }
}
