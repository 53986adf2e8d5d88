//! WINNER+ B1 line-of-sight path loss, as the 802.11p model uses it.

/// Speed of light as the WINNER+ breakpoint distance is computed with (m/s).
const LIGHT_SPEED: f64 = 3e8;
/// Distances below this are evaluated at it (the model's near-field floor, m).
const MIN_DISTANCE_M: f64 = 3.0;

/// WINNER+ B1 (urban micro-cell) line-of-sight path loss with both antennas at the same height:
/// `22.7 log10 d + 27 + 20 log10 f` below the breakpoint `4 h' h' f / c` (`h'` the antenna
/// height above the environment), `40 log10 d + 7.56 - 34.6 log10 h' + 2.7 log10 f` from it
/// (`f` in GHz), never below free space, `20 log10 d + 46.4 + 20 log10 (f / 5)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PathLoss {
    near: f64,
    far: f64,
    free: f64,
    breakpoint_m: f64,
}

impl PathLoss {
    /// At carrier `carrier_ghz`, both antennas `antenna_height_m` high in an environment
    /// `environment_height_m` high.
    pub(crate) fn new(carrier_ghz: f64, antenna_height_m: f64, environment_height_m: f64) -> Self {
        let f = carrier_ghz;
        let h = antenna_height_m - environment_height_m;
        PathLoss {
            near: 27.0 + 20.0 * f.log10(),
            far: 7.56 - 2.0 * 17.3 * h.log10() + 2.7 * f.log10(),
            free: 46.4 + 20.0 * (f / 5.0).log10(),
            breakpoint_m: 4.0 * h * h * f * 1e9 / LIGHT_SPEED,
        }
    }

    /// Path loss (dB) over `distance_m` (either sign).
    pub(crate) fn db(&self, distance_m: f64) -> f64 {
        let d = distance_m.abs().max(MIN_DISTANCE_M);
        let lg = d.log10();
        let winner = if d < self.breakpoint_m {
            22.7 * lg + self.near
        } else {
            40.0 * lg + self.far
        };
        winner.max(20.0 * lg + self.free)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_geometry() {
        // The paper's geometry, `Params80211p::default()`'s.
        let pl = PathLoss::new(5.89, 1.5, 0.5);
        // h' = 1 m at 5.89 GHz: breakpoint 78.5 m.
        assert!((pl.breakpoint_m - 78.5333333).abs() < 1e-6);
        // With these constants free space exceeds the near formula below the breakpoint and the
        // far one up to ~81 m, so it is the loss up to there.
        let free = |d: f64| 20.0 * d.log10() + 46.4 + 20.0 * (5.89f64 / 5.0).log10();
        let near = 22.7 * 50f64.log10() + 27.0 + 20.0 * 5.89f64.log10();
        assert!(free(50.0) > near);
        assert!((pl.db(50.0) - free(50.0)).abs() < 1e-12);
        assert!((pl.db(80.0) - free(80.0)).abs() < 1e-12);
        let far = 40.0 * 3.0 + 7.56 + 2.7 * 5.89f64.log10();
        assert!((pl.db(-1000.0) - far).abs() < 1e-12);
        // The floor at 3 m.
        assert_eq!(pl.db(0.0), free(3.0));
        // Monotone in distance.
        let mut last = 0.0;
        for d in 0..3000 {
            let v = pl.db(d as f64);
            assert!(v >= last);
            last = v;
        }
    }
}
