use crate::{Assumption2, DosSchedule, ScheduleError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// A seeded random DoS generator whose every output satisfies [`Assumption2`] by construction.
///
/// Attack `j` is proposed with a gap drawn uniformly from `[min_gap, max_gap]` after the previous
/// attack and a duration uniform in `[min_duration, max_duration]`. The start is then pushed later,
/// if needed, to the earliest instant at which both bounds still hold on every window that ends
/// with this attack (the incremental form of the O(n) check in [`Assumption2::check`]); the
/// duration is capped at `D1 / (1 - 1/D2)`, the longest a single attack may last. Windows that end
/// at an earlier attack are unaffected by later ones, so the whole schedule is admissible.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomDos {
    /// Seed of the ChaCha8 generator: the same seed gives the same schedule everywhere.
    pub seed: u64,
    /// Smallest quiet time between two attacks (s), > 0.
    pub min_gap: f64,
    /// Largest proposed quiet time between two attacks (s).
    pub max_gap: f64,
    /// Shortest proposed attack (s), > 0.
    pub min_duration: f64,
    /// Longest proposed attack (s).
    pub max_duration: f64,
}

impl RandomDos {
    /// Checks the parameter ranges.
    pub fn validate(&self) -> Result<(), ScheduleError> {
        let fine = self.min_gap.is_finite()
            && self.min_gap > 0.0
            && self.max_gap.is_finite()
            && self.max_gap >= self.min_gap
            && self.min_duration.is_finite()
            && self.min_duration > 0.0
            && self.max_duration.is_finite()
            && self.max_duration >= self.min_duration;
        if fine {
            Ok(())
        } else {
            Err(ScheduleError::BadAssumption(format!(
                "random DoS needs 0 < min_gap <= max_gap and 0 < min_duration <= max_duration \
                 (got gaps [{}, {}], durations [{}, {}])",
                self.min_gap, self.max_gap, self.min_duration, self.max_duration
            )))
        }
    }

    /// Draws a schedule on `[0, horizon)` admissible for `bounds`.
    pub fn generate(
        &self,
        bounds: &Assumption2,
        horizon: f64,
    ) -> Result<DosSchedule, ScheduleError> {
        self.validate()?;
        bounds.validate()?;
        if bounds.T1 < 1.0 {
            // A window of length ~0 around one attack start has N = 1 > T1.
            return Ok(DosSchedule::none());
        }
        let Assumption2 { T1, T2, D1, D2 } = *bounds;
        let longest = D1 / (1.0 - 1.0 / D2);
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut pairs = Vec::new();
        let mut prev_end = 0.0_f64;
        let mut best_f = f64::NEG_INFINITY; // max_{i<j} a_i/T2 - i
        let mut best_d = f64::NEG_INFINITY; // max_{i<j} a_i/D2 - S_{i-1}
        let mut cumulative = 0.0; // S_{j-1}
        for j in 0.. {
            let gap = rng.gen_range(self.min_gap..=self.max_gap);
            let mut d = rng.gen_range(self.min_duration..=self.max_duration);
            d = d.min(longest * (1.0 - 1e-9));
            let first = if j == 0 { gap.max(0.0) } else { prev_end + gap };
            // Frequency: (j + 1) - a_j/T2 + max(best_f, a_j/T2 - j) <= T1.
            let by_frequency = T2 * (j as f64 + 1.0 - T1 + best_f);
            // Duration: S_{j-1} + d (1 - 1/D2) - a_j/D2 + max(best_d, a_j/D2 - S_{j-1}) <= D1;
            // the a_j term of the max holds by the cap on d, the best_d term bounds a_j below.
            let by_duration = D2 * (cumulative + d * (1.0 - 1.0 / D2) + best_d - D1);
            // A little slack keeps rounding from landing exactly on a bound.
            let start = first.max(by_frequency + 1e-9).max(by_duration + 1e-9);
            if start + d > horizon {
                break;
            }
            best_f = best_f.max(start / T2 - j as f64);
            best_d = best_d.max(start / D2 - cumulative);
            cumulative += d;
            prev_end = start + d;
            pairs.push((start, d));
        }
        DosSchedule::from_intervals(&pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle::{bounds_on_grid, run, Oracle};
    use proptest::prelude::*;

    const PAPER: Assumption2 = Assumption2::PAPER;

    #[test]
    fn same_seed_same_schedule() {
        let g = RandomDos {
            seed: 7,
            min_gap: 0.5,
            max_gap: 5.0,
            min_duration: 0.2,
            max_duration: 3.0,
        };
        assert_eq!(
            g.generate(&PAPER, 200.0).unwrap(),
            g.generate(&PAPER, 200.0).unwrap()
        );
        let other = RandomDos {
            seed: 8,
            ..g.clone()
        };
        assert_ne!(
            g.generate(&PAPER, 200.0).unwrap(),
            other.generate(&PAPER, 200.0).unwrap()
        );
    }

    #[test]
    fn generated_schedules_satisfy_assumption_2_by_the_oracle() {
        // Random seeds, generator settings and bounds (T1 from 1/8: below 1 the generator must
        // give no attack); the bounds on a 1/1024 grid and the horizon below 512 s, as the
        // exact oracle needs. Every schedule must be admissible by the oracle, exactly (no
        // tolerance), and by the checker; and the generator must really have been held back by
        // the bounds: some schedules sit within 1e-6 of a bound.
        let strategy = (
            (
                any::<u64>(),
                0.01f64..5.0,
                0.0f64..10.0,
                0.01f64..4.0,
                0.0f64..10.0,
            ),
            bounds_on_grid(1024),
            1.0f64..500.0,
        );
        let t = run(
            512,
            strategy,
            |((seed, min_gap, extra_gap, min_duration, extra_duration), bounds, horizon)| {
                let g = RandomDos {
                    seed,
                    min_gap,
                    max_gap: min_gap + extra_gap,
                    min_duration,
                    max_duration: min_duration + extra_duration,
                };
                let s = g.generate(&bounds, horizon).unwrap();
                let ends: Vec<(f64, f64)> =
                    s.intervals().iter().map(|iv| (iv.start, iv.end)).collect();
                prop_assert!(ends.iter().all(|&(_, end)| end <= horizon));
                let oracle = Oracle::new(&ends, horizon);
                let v = oracle.check(&bounds);
                prop_assert!(v.holds(), "{:?} violates {:?}: {:?}", s, bounds, v);
                let r = bounds.check(&s, horizon);
                prop_assert!(r.holds, "{:?} violates {:?}: {:?}", s, bounds, r);
                prop_assert_eq!(oracle.attacks(), ends.len());
                if bounds.T1 < 1.0 {
                    prop_assert!(ends.is_empty());
                }
                Ok((v, ends.len()))
            },
        );
        assert_eq!(t.holds, t.cases, "{t:?}");
        assert!(t.near > 0 && t.attacks > t.cases, "{t:?}");
    }
}
