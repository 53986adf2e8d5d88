use crate::{DosSchedule, ScheduleError};
use serde::{Deserialize, Serialize};

/// Assumption 2 of the paper (De Persis and Tesi's DoS frequency and duration bounds): for every
/// window `[t1, t2)` with `t2 >= t1 >= 0`,
///
/// ```text
/// |A(t1, t2)| <= D1 + (t2 - t1) / D2        (duration)
///  N(t1, t2)  <= T1 + (t2 - t1) / T2        (frequency)
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct Assumption2 {
    /// Chattering bound on the number of attacks.
    pub T1: f64,
    /// Average dwell time between attack starts (s).
    pub T2: f64,
    /// Chattering bound on the attack duration (s).
    pub D1: f64,
    /// Inverse of the largest long-run fraction of attacked time (> 1).
    pub D2: f64,
}

/// A window `[t1, t2)` and the two sides of an inequality of Assumption 2 on it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Window {
    /// Window start.
    pub t1: f64,
    /// Window end (for the frequency bound, the supremum: the window ends just after `t2`).
    pub t2: f64,
    /// `|A(t1,t2)|` or `N(t1,t2)` on the window.
    pub value: f64,
    /// The right-hand side `D1 + (t2-t1)/D2` or `T1 + (t2-t1)/T2`.
    pub bound: f64,
}

impl Window {
    /// `bound - value`: negative when the window violates the bound.
    pub fn margin(&self) -> f64 {
        self.bound - self.value
    }
}

/// The verdict of [`Assumption2::check`], with the tightest window of each bound.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Assumption2Report {
    /// Both bounds hold on every window.
    pub holds: bool,
    /// The window with the smallest duration margin (None without attacks).
    pub worst_duration: Option<Window>,
    /// The window with the smallest frequency margin (None without attacks).
    pub worst_frequency: Option<Window>,
}

impl Assumption2 {
    /// The bounds of the paper's design (Section IV: T1 = 2, T2 = 9.46 s, D1 = 6 s,
    /// D2 = 11.33; reading the bounds (16) at its gains).
    pub const PAPER: Assumption2 = Assumption2 {
        T1: 2.0,
        T2: 9.46,
        D1: 6.0,
        D2: 11.33,
    };

    /// Checks the parameter ranges of the assumption (T1, T2, D1 > 0, D2 > 1).
    pub fn validate(&self) -> Result<(), ScheduleError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !(ok(self.T1) && ok(self.T2) && ok(self.D1) && self.D2.is_finite() && self.D2 > 1.0) {
            return Err(ScheduleError::BadAssumption(format!(
                "Assumption 2 needs T1, T2, D1 > 0 and D2 > 1 (got T1={}, T2={}, D1={}, D2={})",
                self.T1, self.T2, self.D1, self.D2
            )));
        }
        Ok(())
    }

    /// Checks the schedule restricted to `[0, horizon)` exactly, over every window.
    ///
    /// Method. Duration: `f(t1,t2) = |A(t1,t2)| - (t2-t1)/D2` can only grow by moving `t1` back to
    /// the start of the attack it lies in (or forward to the next start, when it lies in a gap)
    /// and `t2` to the end of the attack it lies in, so its supremum is attained at
    /// `t1 = a_i`, `t2 = a_j + d_j`, `i <= j`. Frequency: `N(t1,t2) - (t2-t1)/T2` is largest for
    /// `t1 = a_i` and `t2` just after `a_j`, so its supremum is `(j-i+1) - (a_j-a_i)/T2`. Both
    /// maxima over `i <= j` split into a term in `i` and a term in `j`, so one pass with a
    /// running maximum finds them in O(n).
    pub fn check(&self, schedule: &DosSchedule, horizon: f64) -> Assumption2Report {
        let clipped = schedule.clipped(horizon);
        let iv = clipped.intervals();
        let mut worst_duration: Option<Window> = None;
        let mut worst_frequency: Option<Window> = None;
        // Running maxima over i <= j of a_i/D2 - S_{i-1} and a_i/T2 - i, with their arg.
        let (mut best_d, mut best_d_i) = (f64::NEG_INFINITY, 0usize);
        let (mut best_f, mut best_f_i) = (f64::NEG_INFINITY, 0usize);
        let mut cumulative = 0.0; // S_{j-1}
        for (j, a) in iv.iter().enumerate() {
            let cand_d = a.start / self.D2 - cumulative;
            if cand_d > best_d {
                (best_d, best_d_i) = (cand_d, j);
            }
            let cand_f = a.start / self.T2 - j as f64;
            if cand_f > best_f {
                (best_f, best_f_i) = (cand_f, j);
            }
            cumulative += a.duration();
            let (t1, t2) = (iv[best_d_i].start, a.end);
            let w = Window {
                t1,
                t2,
                value: clipped.active_time(t1, t2),
                bound: self.D1 + (t2 - t1) / self.D2,
            };
            if worst_duration.is_none_or(|old| w.margin() < old.margin()) {
                worst_duration = Some(w);
            }
            let (t1, t2) = (iv[best_f_i].start, a.start);
            let w = Window {
                t1,
                t2,
                value: (j - best_f_i + 1) as f64,
                bound: self.T1 + (t2 - t1) / self.T2,
            };
            if worst_frequency.is_none_or(|old| w.margin() < old.margin()) {
                worst_frequency = Some(w);
            }
        }
        // A tiny tolerance absorbs rounding in the sums; a violation by one interval is many
        // orders of magnitude larger.
        let ok = |w: &Option<Window>| w.is_none_or(|w| w.margin() >= -1e-9);
        Assumption2Report {
            holds: ok(&worst_duration) && ok(&worst_frequency),
            worst_duration,
            worst_frequency,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle::{bounds_on_grid, run, Oracle, Verdict};
    use proptest::prelude::*;
    use proptest::test_runner::TestCaseError;

    const PAPER: Assumption2 = Assumption2::PAPER;

    #[test]
    fn no_attack_holds() {
        let r = PAPER.check(&DosSchedule::none(), 55.0);
        assert!(r.holds);
        assert!(r.worst_duration.is_none());
    }

    #[test]
    fn three_attacks_closer_than_t2_violate_frequency() {
        // Three starts within 9.46 s: N = 3 > 2 + 9/9.46.
        let s = DosSchedule::from_intervals(&[(0.0, 0.5), (4.0, 0.5), (9.0, 0.5)]).unwrap();
        let r = PAPER.check(&s, 55.0);
        assert!(!r.holds);
        let w = r.worst_frequency.unwrap();
        assert_eq!((w.t1, w.t2, w.value), (0.0, 9.0, 3.0));
        assert!(w.margin() < 0.0);
        // Moving the third attack to 9.5 s (beyond T2 from the first) makes it admissible.
        let s = DosSchedule::from_intervals(&[(0.0, 0.5), (4.0, 0.5), (9.5, 0.5)]).unwrap();
        assert!(PAPER.check(&s, 55.0).holds);
    }

    #[test]
    fn an_attack_one_interval_too_long_violates_duration() {
        // One attack may last at most D1 / (1 - 1/D2) = 6.58 s.
        let max = PAPER.D1 / (1.0 - 1.0 / PAPER.D2);
        let ok = DosSchedule::from_intervals(&[(10.0, max - 0.01)]).unwrap();
        assert!(PAPER.check(&ok, 55.0).holds);
        let bad = DosSchedule::from_intervals(&[(10.0, max + 0.01)]).unwrap();
        let r = PAPER.check(&bad, 55.0);
        assert!(!r.holds);
        assert!(r.worst_duration.unwrap().margin() < 0.0);
        assert!(r.worst_frequency.unwrap().margin() >= 0.0);
    }

    #[test]
    fn bunching_violates_even_when_totals_fit() {
        // |A(0,55)| = 10 and N(0,55) = 7 satisfy the totals (10.85, 7.81) but four attacks in
        // the first 12 s break the frequency bound on [0, 12).
        let s = DosSchedule::from_intervals(&[
            (0.0, 1.0),
            (4.0, 1.0),
            (8.0, 1.0),
            (12.0, 1.0),
            (30.0, 2.0),
            (40.0, 2.0),
            (50.0, 2.0),
        ])
        .unwrap();
        assert_eq!(s.active_time(0.0, 55.0), 10.0);
        assert_eq!(s.count(0.0, 55.0), 7);
        assert!(!PAPER.check(&s, 55.0).holds);
    }

    /// The paper's bounds rounded to multiples of 2^-10, as the oracle needs.
    fn paper_on_grid() -> Assumption2 {
        let grid = |x: f64| (x * 1024.0).round() / 1024.0;
        Assumption2 {
            T1: grid(PAPER.T1),
            T2: grid(PAPER.T2),
            D1: grid(PAPER.D1),
            D2: grid(PAPER.D2),
        }
    }

    #[test]
    fn exact_check_agrees_with_the_oracle_on_hand_written_schedules() {
        let bounds = paper_on_grid();
        let schedules = [
            vec![
                (1.0, 1.5),
                (5.0, 1.5),
                (16.0, 1.5),
                (22.0, 1.5),
                (30.0, 1.5),
                (42.0, 1.5),
                (49.0, 1.0),
            ],
            vec![(0.0, 3.0), (3.5, 3.0), (7.0, 3.0)],
            vec![(2.0, 6.0), (20.0, 0.1)],
        ];
        for pairs in schedules {
            let (v, attacks) = compare(&pairs, 55.0, &bounds).unwrap();
            assert_eq!(attacks, pairs.len(), "{pairs:?}");
            assert!(v.duration_margin.is_some(), "{pairs:?}");
        }
    }

    /// The checker against the brute-force oracle (`crate::oracle`) on one schedule given as
    /// `(start, duration)` pairs: the same verdict, the same tightest margins, and reported
    /// windows whose values are what the oracle measures on them. Returns the oracle's verdict and
    /// the number of attacks.
    ///
    /// The checker works in f64 and accepts margins down to -1e-9; the oracle is exact. Margins
    /// must agree to 1e-9 (the checker's rounding on these sizes is ~1e-13). The verdicts must
    /// be equal unless an exact margin lies within 1e-6 of zero, which no schedule on the
    /// quarter-second grid with parameters on a 1/8 grid can produce: their margins are
    /// rationals with denominators dividing 1024, so they are 0 (an exact tie, where both say
    /// "holds") or at least 1/1024 away from it.
    fn compare(
        pairs: &[(f64, f64)],
        horizon: f64,
        bounds: &Assumption2,
    ) -> Result<(Verdict, usize), TestCaseError> {
        let schedule = DosSchedule::from_intervals(pairs).unwrap();
        let report = bounds.check(&schedule, horizon);
        let ends: Vec<(f64, f64)> = pairs.iter().map(|&(a, d)| (a, a + d)).collect();
        let oracle = Oracle::new(&ends, horizon);
        let v = oracle.check(bounds);
        let near_zero = |m: Option<f64>| m.is_some_and(|m| m.abs() < 1e-6 && m != 0.0);
        if !near_zero(v.duration_margin) && !near_zero(v.frequency_margin) {
            prop_assert_eq!(
                report.holds,
                v.holds(),
                "{:?}: {:?} vs {:?}",
                pairs,
                report,
                v
            );
        }
        prop_assert_eq!(report.worst_duration.is_some(), oracle.any_attack());
        prop_assert_eq!(report.worst_frequency.is_some(), oracle.any_attack());
        if let (Some(w), Some(m)) = (report.worst_duration, v.duration_margin) {
            prop_assert!((w.margin() - m).abs() < 1e-9, "duration {:?} vs {}", w, m);
            prop_assert!(
                (w.value - oracle.attack_time(w.t1, w.t2)).abs() < 1e-9,
                "{:?}",
                w
            );
            prop_assert!((w.bound - (bounds.D1 + (w.t2 - w.t1) / bounds.D2)).abs() < 1e-12);
        }
        if let (Some(w), Some(m)) = (report.worst_frequency, v.frequency_margin) {
            prop_assert!((w.margin() - m).abs() < 1e-9, "frequency {:?} vs {}", w, m);
            // The reported value counts the starts up to and including t2.
            prop_assert_eq!(
                w.value,
                oracle.switches_through(w.t1, w.t2) as f64,
                "{:?}",
                w
            );
            prop_assert!((w.bound - (bounds.T1 + (w.t2 - w.t1) / bounds.T2)).abs() < 1e-12);
        }
        Ok((v, oracle.attacks()))
    }

    #[test]
    fn exact_check_agrees_with_the_oracle_on_grid_schedules() {
        // Up to 8 attacks (overlapping, touching, past the horizon) with starts and durations
        // on a quarter-second grid and parameters on a 1/8 grid: every float in the checker is
        // then nearly exact and the bounds often hold with exact equality, the case where the
        // open and closed window ends decide the verdict.
        let quarter = |lo: u32, hi: u32| (lo..=hi).prop_map(|k| f64::from(k) / 4.0);
        let strategy = (
            prop::collection::vec((quarter(0, 44 * 4), quarter(1, 8 * 4)), 0..=8),
            quarter(20 * 4, 40 * 4),
            prop_oneof![bounds_on_grid(2), bounds_on_grid(8)],
        );
        let t = run(1024, strategy, |(pairs, horizon, bounds)| {
            compare(&pairs, horizon, &bounds)
        });
        assert!(t.holds > 0 && t.violates > 0, "{t:?}");
        assert!(t.duration_violated > 0 && t.frequency_violated > 0, "{t:?}");
        assert!(t.tight > 0, "{t:?}");
    }

    #[test]
    fn exact_check_agrees_with_the_oracle_on_arbitrary_schedules() {
        // Starts and durations anywhere (to 2^-40 s) and parameters on a 1/1024 grid.
        let fine =
            |lo: f64, hi: f64| (lo..hi).prop_map(|x| (x * 2f64.powi(40)).round() / 2f64.powi(40));
        let strategy = (
            prop::collection::vec((fine(0.0, 44.0), fine(0.01, 8.0)), 0..=8),
            fine(20.0, 40.0),
            bounds_on_grid(1024),
        );
        let t = run(1024, strategy, |(pairs, horizon, bounds)| {
            compare(&pairs, horizon, &bounds)
        });
        assert!(t.holds > 0 && t.violates > 0, "{t:?}");
        assert!(t.duration_violated > 0 && t.frequency_violated > 0, "{t:?}");
    }
}
