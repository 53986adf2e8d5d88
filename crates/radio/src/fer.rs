//! The receiver's frame error rate against Eb/No, and its average over a truncated normal
//! Eb/No in closed form.

use crate::math::{density, upper_tail};

/// Spacing of the lattice of interference-plus-noise levels (dB) the model averages the frame
/// error rate on; the curve's Eb/No points must be multiples of it.
pub(crate) const FLOOR_STEP_DB: f64 = 0.25;

/// The frame error rate table shipped with the crate (`data/fer_goubet2015.csv`).
pub(crate) const FER_TABLE: &str = include_str!("../data/fer_goubet2015.csv");

/// A frame error rate curve: piecewise linear in Eb/No (dB) between its points, constant beyond
/// the first and the last.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FerCurve {
    eb_no_db: Vec<f64>,
    fer: Vec<f64>,
}

impl FerCurve {
    /// Parses `eb_no_db,fer` lines (a header and `#` comments allowed) with strictly increasing
    /// Eb/No and error rates in [0, 1]; the error names the line.
    pub(crate) fn parse(text: &str) -> Result<Self, String> {
        let (mut eb_no_db, mut fer) = (Vec::new(), Vec::new());
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') || line.starts_with("eb_no_db") {
                continue;
            }
            let bad = |what: &str| format!("line {}: {what}: {line:?}", i + 1);
            let (x, y) = line
                .split_once(',')
                .ok_or_else(|| bad("expected `eb_no_db,fer`"))?;
            let x: f64 = x.trim().parse().map_err(|_| bad("Eb/No is not a number"))?;
            let y: f64 = y.trim().parse().map_err(|_| bad("FER is not a number"))?;
            if !x.is_finite() || eb_no_db.last().is_some_and(|&last| x <= last) {
                return Err(bad("Eb/No must be finite and strictly increasing"));
            }
            if ((x / FLOOR_STEP_DB).round() * FLOOR_STEP_DB - x).abs() > 1e-9 {
                return Err(bad("Eb/No must be a multiple of 0.25 dB"));
            }
            if !(0.0..=1.0).contains(&y) {
                return Err(bad("FER must be within [0, 1]"));
            }
            eb_no_db.push(x);
            fer.push(y);
        }
        if eb_no_db.len() < 2 {
            return Err("a FER curve needs at least two points".into());
        }
        Ok(FerCurve { eb_no_db, fer })
    }

    /// The error rate at `eb_no_db`.
    pub(crate) fn at(&self, eb_no_db: f64) -> f64 {
        let (x, y) = (&self.eb_no_db, &self.fer);
        let last = x.len() - 1;
        if eb_no_db <= x[0] {
            return y[0];
        }
        if eb_no_db >= x[last] {
            return y[last];
        }
        let i = x.partition_point(|&v| v <= eb_no_db) - 1;
        y[i] + (y[i + 1] - y[i]) * (eb_no_db - x[i]) / (x[i + 1] - x[i])
    }

    /// `E[FER(X) | X >= lower]` for `X ~ N(mean, sd^2)` (dB), in closed form: on each linear
    /// piece `a + b x` of the curve the truncated normal contributes `a P + b E[X; piece]`, both
    /// written with the normal tail and density at the piece's ends.
    pub(crate) fn mean_above(&self, mean: f64, sd: f64, lower: f64) -> f64 {
        let z_lower = (lower - mean) / sd;
        let mass_above = upper_tail(z_lower);
        if mass_above < 1e-300 {
            // All the probability sits at the truncation point.
            return self.at(lower);
        }
        let (x, y) = (&self.eb_no_db, &self.fer);
        let last = x.len() - 1;
        // Walk the pieces from the truncation point up: (lower, x0], [x_i, x_i+1], [x_last, inf).
        let mut z_from = z_lower;
        let mut tail_from = mass_above;
        let mut dens_from = density(z_lower);
        let mut sum = 0.0;
        for i in 0..=last + 1 {
            let z_to = if i <= last {
                (x[i] - mean) / sd
            } else {
                f64::INFINITY
            };
            if z_to <= z_from {
                continue;
            }
            let (tail_to, dens_to) = if z_to.is_finite() {
                (upper_tail(z_to), density(z_to))
            } else {
                (0.0, 0.0)
            };
            let mass = tail_from - tail_to;
            if i == 0 || i > last {
                // Constant pieces below the first point and above the last.
                sum += y[i.min(last)] * mass;
            } else {
                let slope = (y[i] - y[i - 1]) / (x[i] - x[i - 1]);
                // FER = y[i-1] + slope (X - x[i-1]) with X = mean + sd Z, and
                // E[Z; z_from < Z < z_to] = density(z_from) - density(z_to).
                sum += (y[i - 1] + slope * (mean - x[i - 1])) * mass
                    + slope * sd * (dens_from - dens_to);
            }
            z_from = z_to;
            tail_from = tail_to;
            dens_from = dens_to;
        }
        (sum / mass_above).clamp(0.0, 1.0)
    }
}

impl FerCurve {
    /// `E[FER(X - f) | X >= lower]` for `X ~ N(mean, sd^2)` at every `f = f0 + n df`,
    /// n in 0 .. count: the same closed form as [`FerCurve::mean_above`], but the curve's points,
    /// shifted by the `f`s, fall on one lattice of spacing `df` (the points are multiples of it,
    /// which `parse` checks for [`FLOOR_STEP_DB`]), so the normal tail and density are computed
    /// once per lattice point instead of once per point and shift.
    pub(crate) fn mean_above_shifted(
        &self,
        mean: f64,
        sd: f64,
        lower: f64,
        f0: f64,
        count: usize,
    ) -> Vec<f64> {
        let df = FLOOR_STEP_DB;
        let (x, y) = (&self.eb_no_db, &self.fer);
        let last = x.len() - 1;
        let z_lower = (lower - mean) / sd;
        let mass_above = upper_tail(z_lower);
        let shift = |n: usize| f0 + n as f64 * df;
        if mass_above < 1e-300 {
            return (0..count).map(|n| self.at(lower - shift(n))).collect();
        }
        // Lattice point m is x[0] + f0 + m df; point i of the curve shifted by f_n is m = n + k[i].
        let k: Vec<usize> = x
            .iter()
            .map(|xi| ((xi - x[0]) / df).round() as usize)
            .collect();
        let lattice = k[last] + count;
        let (mut tail, mut dens) = (Vec::with_capacity(lattice), Vec::with_capacity(lattice));
        for m in 0..lattice {
            let z = (x[0] + f0 + m as f64 * df - mean) / sd;
            tail.push(upper_tail(z));
            dens.push(density(z));
        }
        let dens_lower = density(z_lower);
        (0..count)
            .map(|n| {
                let f = shift(n);
                // Pieces from the truncation point up, as in `mean_above`.
                let mut z_from = z_lower;
                let mut tail_from = mass_above;
                let mut dens_from = dens_lower;
                let mut sum = 0.0;
                for i in 0..=last + 1 {
                    let (z_to, tail_to, dens_to) = if i <= last {
                        let m = n + k[i];
                        ((x[i] + f - mean) / sd, tail[m], dens[m])
                    } else {
                        (f64::INFINITY, 0.0, 0.0)
                    };
                    if z_to <= z_from {
                        continue;
                    }
                    let mass = tail_from - tail_to;
                    if i == 0 || i > last {
                        sum += y[i.min(last)] * mass;
                    } else {
                        let slope = (y[i] - y[i - 1]) / (x[i] - x[i - 1]);
                        sum += (y[i - 1] + slope * (mean - f - x[i - 1])) * mass
                            + slope * sd * (dens_from - dens_to);
                    }
                    z_from = z_to;
                    tail_from = tail_to;
                    dens_from = dens_to;
                }
                (sum / mass_above).clamp(0.0, 1.0)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve() -> FerCurve {
        FerCurve::parse(FER_TABLE).unwrap()
    }

    #[test]
    fn the_shipped_table_parses_and_interpolates() {
        let c = curve();
        assert_eq!(c.at(-5.0), 1.0);
        assert_eq!(c.at(7.5), 0.7);
        assert_eq!(c.at(40.0), 0.001);
        assert!((c.at(12.5) - 0.2075).abs() < 1e-12);
    }

    #[test]
    fn bad_tables_name_the_line() {
        assert!(FerCurve::parse("0,1\n0,0.5\n")
            .unwrap_err()
            .contains("line 2"));
        assert!(FerCurve::parse("0,1\n1,2\n")
            .unwrap_err()
            .contains("line 2"));
        assert!(FerCurve::parse("0;1\n").unwrap_err().contains("line 1"));
        assert!(FerCurve::parse("0,1\n").is_err());
    }

    /// The closed form against a fine midpoint rule over the truncated density.
    #[test]
    fn truncated_mean_matches_numerical_integration() {
        let c = curve();
        for &(mean, sd, lower) in &[
            (12.0, 3.0, 9.0),
            (30.0, 3.0, 12.0),
            (2.0, 3.0, 10.0),
            (14.0, 4.2, -50.0),
            (-20.0, 3.0, 11.0),
        ] {
            let h = 1e-3;
            let (mut num, mut den) = (0.0, 0.0);
            let mut x = lower + h / 2.0;
            while x < mean + 12.0 * sd + 60.0 {
                let p = density((x - mean) / sd);
                num += p * c.at(x);
                den += p;
                x += h;
            }
            let exact = c.mean_above(mean, sd, lower);
            let numeric = num / den;
            assert!(
                (exact - numeric).abs() < 1e-6,
                "{mean} {sd} {lower}: {exact} vs {numeric}"
            );
        }
    }

    #[test]
    fn shifted_means_agree_with_one_at_a_time() {
        let c = curve();
        for &(mean, lower) in &[
            (-40.0, -82.8),
            (-90.0, -82.8),
            (-200.0, -82.8),
            (-75.0, -82.8),
        ] {
            let f0 = -95.0;
            let all = c.mean_above_shifted(mean, 3.0, lower, f0, 700);
            for (n, v) in all.iter().enumerate() {
                let f = f0 + n as f64 * FLOOR_STEP_DB;
                let one = c.mean_above(mean - f, 3.0, lower - f);
                assert!((v - one).abs() < 1e-9, "{mean} {n}: {v} vs {one}");
            }
        }
        assert!(FerCurve::parse("0.1,1\n1,0\n")
            .unwrap_err()
            .contains("0.25 dB"));
    }

    #[test]
    fn far_tail_truncation_gives_the_value_at_the_bound() {
        let c = curve();
        assert!((c.mean_above(-500.0, 3.0, 12.5) - c.at(12.5)).abs() < 1e-12);
        // Deep but representable tail: close to the bound's value.
        assert!((c.mean_above(-60.0, 3.0, 12.5) - c.at(12.5)).abs() < 0.01);
    }
}
