//! The model across channel loads, for a channel whose load changes during a run.
//!
//! In Sepulcre et al.'s model the density `rho` and the beacon rate `lambda` enter through their
//! product, the packets sent per second per metre of road `q = rho lambda`: the offered load and
//! the CBR are proportional to it, and every interferer's same-slot and hidden-terminal terms are
//! rates summed over the interferers (checked in the tests below: the curves of (0.06 veh/m,
//! 20 Hz), (0.12, 10) and (0.24, 5) agree to 1e-3). A [`LoadFamily`] is one configuration's
//! models on a geometric grid of `q`, each built the first time a run needs it, and interpolates
//! between the two that bracket the load.
use crate::fer::{FerCurve, FER_TABLE};
use crate::params::{Error, Params80211p};
use crate::{Builder, Model};
use std::sync::OnceLock;

/// The beacon rate of the grid's models (Hz): `q` is reached with density `q / 10`.
const GRID_HZ: f64 = 10.0;
/// The smallest load of the grid (packets/s/m): one packet a second per kilometre, where no
/// interferer is left within a kilometre. Lower loads take this model.
const GRID_MIN: f64 = 1e-3;
/// The largest: one vehicle a metre at 10 Hz (CBR 0.84). Higher loads take this model.
const GRID_MAX: f64 = GRID_HZ;
/// Grid points per doubling of the load.
const PER_OCTAVE: f64 = 4.0;

/// One configuration of the 802.11p model (power, rate, packet size, radio and propagation) at
/// every channel load: [`LoadFamily::pdr`] and [`LoadFamily::cbr`] take the load as packets per
/// second per metre of road. The configuration's own load (`density_veh_per_m * beacon_hz`) is
/// a grid point with exactly the model [`Model::new`] builds for it, so a run at that load
/// reproduces the single model bit for bit. `Send + Sync`: share one behind an `Arc`.
#[derive(Debug)]
pub struct LoadFamily {
    params: Params80211p,
    fer: FerCurve,
    /// The loads of the grid, increasing.
    loads: Vec<f64>,
    /// Its models, built on first use.
    models: Vec<OnceLock<Model>>,
}

impl LoadFamily {
    /// Validates `params` and prepares the grid (no model is built yet).
    pub fn new(params: Params80211p) -> Result<LoadFamily, Error> {
        params.validate()?;
        let fer = FerCurve::parse(FER_TABLE).map_err(Error::FerTable)?;
        let own = params.density_veh_per_m * params.beacon_hz;
        let steps = ((GRID_MAX / GRID_MIN).log2() * PER_OCTAVE).ceil() as i32;
        let mut loads: Vec<f64> = (0..=steps)
            .map(|i| (GRID_MIN * 2f64.powf(f64::from(i) / PER_OCTAVE)).min(GRID_MAX))
            .collect();
        if own > 0.0 {
            // The configuration's own load replaces the grid point nearest to it.
            let nearest = (0..loads.len())
                .min_by(|&a, &b| {
                    (loads[a] / own)
                        .ln()
                        .abs()
                        .total_cmp(&(loads[b] / own).ln().abs())
                })
                .unwrap_or(0);
            loads[nearest] = own;
            loads.sort_by(f64::total_cmp);
            loads.dedup();
        }
        Ok(LoadFamily {
            models: loads.iter().map(|_| OnceLock::new()).collect(),
            params,
            fer,
            loads,
        })
    }

    /// The configuration (its density and beacon rate give [`LoadFamily::own_load`]).
    pub fn params(&self) -> &Params80211p {
        &self.params
    }

    /// The configuration's own load, `density_veh_per_m * beacon_hz` (packets/s/m).
    pub fn own_load(&self) -> f64 {
        self.params.density_veh_per_m * self.params.beacon_hz
    }

    /// The grid model `i`, built now if it is the first call.
    fn model(&self, i: usize) -> &Model {
        self.models[i].get_or_init(|| {
            let q = self.loads[i];
            let params = if q == self.own_load() {
                self.params
            } else {
                Params80211p {
                    density_veh_per_m: q / GRID_HZ,
                    beacon_hz: GRID_HZ,
                    ..self.params
                }
            };
            // The fields but the load were validated in `new`, and the grid's densities are in
            // (0, 1]: building cannot fail.
            Builder::new(params, self.fer.clone()).build()
        })
    }

    /// Where `load` falls on the grid: the two models around it and the weight of the upper one
    /// (0 at a grid point). A run that asks several things at one load locates it once.
    pub fn point(&self, load: f64) -> LoadPoint {
        let last = self.loads.len() - 1;
        let (lo, hi, t) = if load.is_nan() || load <= self.loads[0] {
            (0, 0, 0.0)
        } else if load >= self.loads[last] {
            (last, last, 0.0)
        } else {
            let hi = self.loads.partition_point(|&q| q <= load);
            let lo = hi - 1;
            if self.loads[lo] == load {
                (lo, lo, 0.0)
            } else {
                let t = (load / self.loads[lo]).ln() / (self.loads[hi] / self.loads[lo]).ln();
                (lo, hi, t)
            }
        };
        LoadPoint { lo, hi, t }
    }

    /// `f` of the two models around `at`, interpolated (the lower one's alone at a grid point).
    fn mix(&self, at: LoadPoint, f: impl Fn(&Model) -> f64) -> f64 {
        let a = f(self.model(at.lo));
        if at.t == 0.0 {
            return a;
        }
        a + (f(self.model(at.hi)) - a) * at.t
    }

    /// The model nearest to `load` on the grid (for its table, range and airtime).
    pub fn nearest(&self, load: f64) -> &Model {
        let at = self.point(load);
        self.model(if at.t < 0.5 { at.lo } else { at.hi })
    }

    /// The delivery ratio over `distance_m` when the channel carries `load` packets per second
    /// per metre: the two bracketing models' ratios interpolated in the logarithm of the load.
    pub fn pdr(&self, distance_m: f64, load: f64) -> f64 {
        self.pdr_at(self.point(load), distance_m)
    }

    /// [`LoadFamily::pdr`] at a located load.
    pub fn pdr_at(&self, at: LoadPoint, distance_m: f64) -> f64 {
        self.mix(at, |m| m.pdr(distance_m))
    }

    /// [`LoadFamily::pdr`] with a jammer's `interference_dbm` at the receiver
    /// ([`Model::pdr_with_interference`]); exactly `pdr` for `-inf`.
    pub fn pdr_with_interference(&self, distance_m: f64, load: f64, interference_dbm: f64) -> f64 {
        self.pdr_with_interference_at(self.point(load), distance_m, interference_dbm)
    }

    /// [`LoadFamily::pdr_with_interference`] at a located load.
    pub fn pdr_with_interference_at(
        &self,
        at: LoadPoint,
        distance_m: f64,
        interference_dbm: f64,
    ) -> f64 {
        if interference_dbm.is_nan() || interference_dbm == f64::NEG_INFINITY {
            return self.pdr_at(at, distance_m);
        }
        self.mix(at, |m| {
            m.pdr_with_interference(distance_m, interference_dbm)
        })
    }

    /// The channel busy ratio at `load`, interpolated like [`LoadFamily::pdr`].
    pub fn cbr(&self, load: f64) -> f64 {
        self.cbr_at(self.point(load))
    }

    /// [`LoadFamily::cbr`] at a located load.
    pub fn cbr_at(&self, at: LoadPoint) -> f64 {
        self.mix(at, Model::cbr)
    }
}

/// A load located on a [`LoadFamily`]'s grid ([`LoadFamily::point`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoadPoint {
    lo: usize,
    hi: usize,
    t: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_depends_on_density_and_rate_through_their_product() {
        let base = Params80211p::default();
        let at = |rho: f64, hz: f64| {
            Model::new(Params80211p {
                density_veh_per_m: rho,
                beacon_hz: hz,
                ..base
            })
            .unwrap()
        };
        let (a, b, c) = (at(0.06, 20.0), at(0.12, 10.0), at(0.24, 5.0));
        for d in [0.0, 10.0, 50.0, 100.0, 200.0, 300.0, 400.0] {
            assert!((a.pdr(d) - b.pdr(d)).abs() < 1e-3, "{d} m");
            assert!((c.pdr(d) - b.pdr(d)).abs() < 1e-3, "{d} m");
        }
        assert!((a.cbr() - c.cbr()).abs() < 1e-9);
    }

    #[test]
    fn the_own_load_is_the_single_model_bit_for_bit() {
        let params = Params80211p {
            density_veh_per_m: 0.07,
            ..Params80211p::default()
        };
        let family = LoadFamily::new(params).unwrap();
        let single = Model::new(params).unwrap();
        for d in [0.0, 3.3, 17.0, 120.5, 399.0, 1e4] {
            assert_eq!(family.pdr(d, family.own_load()), single.pdr(d));
        }
        assert_eq!(family.cbr(0.7), single.cbr());
    }

    #[test]
    fn more_load_means_less_delivery_and_a_busier_channel() {
        let family = LoadFamily::new(Params80211p::default()).unwrap();
        let loads = [0.0, 0.01, 0.1, 0.35, 0.6, 1.3, 3.0, 20.0];
        for w in loads.windows(2) {
            assert!(family.cbr(w[0]) <= family.cbr(w[1]), "{w:?}");
            for d in [10.0, 100.0, 250.0] {
                assert!(
                    family.pdr(d, w[0]) >= family.pdr(d, w[1]) - 1e-12,
                    "{w:?} {d} m"
                );
            }
        }
        // Between grid points the interpolation stays within the bracketing models.
        let LoadPoint { lo, hi, t } = family.point(0.35);
        assert!(t > 0.0 && t < 1.0 && lo + 1 == hi);
        let p = family.pdr(150.0, 0.35);
        let (a, b) = (family.model(lo).pdr(150.0), family.model(hi).pdr(150.0));
        assert!(p <= a && p >= b);
        // Out of the grid: the end models; not a number: the lowest load.
        assert_eq!(family.pdr(80.0, 1e-9), family.pdr(80.0, 0.0));
        assert_eq!(family.cbr(f64::NAN), family.cbr(0.0));
    }

    #[test]
    fn no_other_traffic_is_a_valid_configuration() {
        let quiet = Params80211p {
            density_veh_per_m: 0.0,
            ..Params80211p::default()
        };
        let model = Model::new(quiet).unwrap();
        assert!(model.pdr(50.0) > 0.99 && model.cbr() < 0.01);
        let family = LoadFamily::new(quiet).unwrap();
        assert_eq!(family.own_load(), 0.0);
        assert!(family.pdr(50.0, 0.0) > 0.99);
    }
}
