//! A brute-force oracle for Assumption 2, for the tests only.
//!
//! It shares nothing with [`crate::Assumption2::check`] or with [`crate::DosSchedule`] (no
//! sorting and merging of intervals, no `clipped`, `active_time` or `count`, no running maxima):
//! it takes the raw attack intervals, paints them onto the line and tries every window between
//! two instants that matter, in exact integer arithmetic.
//!
//! # The schedule
//!
//! Attacks are the half-open intervals `[start, end)` given (in any order, overlapping or
//! touching), restricted to `[0, horizon)`, as the checker restricts them. The *event points*
//! are `0`, the horizon, and every start and end in `[0, horizon]`. Between two consecutive event
//! points no interval begins or ends, so each *segment* `[p_k, p_{k+1})` is jammed throughout or
//! not at all: jammed when some interval contains `p_k` (`start <= p_k < end`).
//!
//! An off-to-on switch happens at `p_k` when segment `k` is jammed and segment `k - 1` is not;
//! at `p_0 = 0` when segment 0 is jammed: the channel is taken to be free before time 0 (the
//! crate's convention, as De Persis and Tesi's first transition `h_0 >= 0`). Touching intervals
//! `[a, b)`, `[b, c)` therefore switch once, at `a`: the channel never turns on at `b`.
//!
//! # Why the event points are enough (the supremum over windows `[t1, t2)`)
//!
//! Duration. `|A(t1, t2)| - (t2 - t1) / D2 = F(t2) - F(t1)` with `F(t) = |A(0, t)| - t / D2`,
//! which is continuous and linear on each segment. For `t1 <= t2`, moving `t1` to the better
//! end of its segment and `t2` to the better end of its own never lowers `F(t2) - F(t1)` (when
//! both lie in one segment, `F(t2) - F(t1) = slope * (t2 - t1)` is at most its value at
//! `(p_k, p_k)` or `(p_k, p_{k+1})`). Beyond the horizon nothing is jammed and `F` decreases. So
//! the supremum is a maximum over pairs of event points `p_i <= p_j`, with `|A|` counted on the
//! half-open `[p_i, p_j)`, and the bound holds iff it holds on those windows.
//!
//! Frequency. `N(t1, t2)` counts switches in the half-open `[t1, t2)`, so the supremum of
//! `N(t1, t2) - (t2 - t1) / T2` is not attained: a window ending at a switch gains it only when
//! extended past it. The supremum over half-open windows equals the maximum over *closed* windows
//! `[t1, t2]` of `Nc(t1, t2) - (t2 - t1) / T2`, `Nc` counting switches in `[t1, t2]`: each closed
//! window is the limit of `[t1, t2 + eps)`, whose count is `Nc` once `eps` is below the next
//! switch, and each half-open window counts at most what its closure counts on the same length.
//! On closed windows, raising `t1` to the first switch at or after it, or lowering `t2` to the
//! last switch at or before it, keeps `Nc` and shortens the window, so the maximum is at a pair
//! of switches, which are event points. The bound `N <= T1 + (t2 - t1) / T2` holds on every
//! half-open window iff `Nc <= T1 + (t2 - t1) / T2` on every closed window between event points
//! (equality there is allowed: every half-open window then still satisfies the bound).
//!
//! # Exactness
//!
//! Times are integers in units of 2^-60 s (every f64 in `[2^-8, 512)` is one exactly, and so is
//! any multiple of 2^-60 below 512); the parameters are integers in units of 2^-10. Each
//! inequality is multiplied out to integers (no division), so the verdict is exact, and equality
//! holds when it really does. A time or parameter that is not such an integer is refused.

use crate::Assumption2;
use proptest::prelude::*;
use proptest::test_runner::{TestCaseError, TestRunner};
use std::cell::RefCell;

/// log2 of the time unit's inverse: times are integers in units of 2^-60 s.
const TIME_BITS: u32 = 60;
/// log2 of the parameter unit's inverse: parameters are integers in units of 2^-10.
const PARAM_BITS: u32 = 10;

/// `x * 2^bits` as an exact integer in `[0, 2^limit_bits)`, or a panic.
fn exact(x: f64, bits: u32, limit_bits: u32, what: &str) -> i128 {
    // Multiplying by a power of two is exact (no overflow at these sizes).
    let scaled = x * (1u128 << bits) as f64;
    assert!(
        scaled >= 0.0 && scaled.fract() == 0.0 && scaled < (1u128 << limit_bits) as f64,
        "the oracle needs {what} = {x} to be a multiple of 2^-{bits} in [0, 2^{})",
        limit_bits - bits
    );
    scaled as i128
}

/// A time in units of 2^-60 s, below 512 s.
fn time(t: f64) -> i128 {
    exact(t, TIME_BITS, TIME_BITS + 9, "a time")
}

/// A parameter of Assumption 2 in units of 2^-10, below 64.
fn param(x: f64) -> i128 {
    exact(x, PARAM_BITS, PARAM_BITS + 6, "a parameter")
}

/// The exact verdict on one schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Verdict {
    /// `|A(t1, t2)| <= D1 + (t2 - t1) / D2` on every window.
    pub(crate) duration_holds: bool,
    /// `N(t1, t2) <= T1 + (t2 - t1) / T2` on every window.
    pub(crate) frequency_holds: bool,
    /// The smallest `bound - value` of the duration inequality over nonempty windows (None
    /// without attacks), rounded once from the exact value.
    pub(crate) duration_margin: Option<f64>,
    /// The smallest `bound - value` of the frequency inequality, as a supremum (over closed
    /// windows, above); None without attacks.
    pub(crate) frequency_margin: Option<f64>,
    /// Some bound holds with exact equality on its tightest window.
    pub(crate) tight: bool,
}

impl Verdict {
    /// Both bounds hold.
    pub(crate) fn holds(&self) -> bool {
        self.duration_holds && self.frequency_holds
    }
}

/// The schedule painted onto its event points (module docs).
#[derive(Debug, Clone)]
pub(crate) struct Oracle {
    /// `0`, the horizon, and every start and end in between: sorted, distinct.
    points: Vec<i128>,
    /// `jammed[k]`: the segment `[points[k], points[k + 1])` is under attack.
    jammed: Vec<bool>,
    /// `switch[k]`: an off-to-on transition at `points[k]`.
    switch: Vec<bool>,
}

impl Oracle {
    /// From raw attack intervals `(start, end)`, `end > start`, in any order, on `[0, horizon)`.
    pub(crate) fn new(intervals: &[(f64, f64)], horizon: f64) -> Self {
        let h = time(horizon);
        assert!(
            intervals.len() < 1 << 16,
            "too many intervals for the oracle"
        );
        let raw: Vec<(i128, i128)> = intervals
            .iter()
            .map(|&(s, e)| {
                assert!(e > s, "an empty interval [{s}, {e})");
                (time(s), time(e))
            })
            .collect();
        let mut points = vec![0, h];
        for &(s, e) in &raw {
            points.extend([s, e]);
        }
        points.retain(|&p| p <= h);
        points.sort_unstable();
        points.dedup();
        let jammed: Vec<bool> = points
            .windows(2)
            .map(|seg| raw.iter().any(|&(s, e)| s <= seg[0] && seg[0] < e))
            .collect();
        let switch = (0..points.len())
            .map(|k| k < jammed.len() && jammed[k] && (k == 0 || !jammed[k - 1]))
            .collect();
        Self {
            points,
            jammed,
            switch,
        }
    }

    /// Whether anything is jammed in `[0, horizon)`.
    pub(crate) fn any_attack(&self) -> bool {
        self.jammed.iter().any(|&j| j)
    }

    /// The number of attacks in `[0, horizon)`: off-to-on switches.
    pub(crate) fn attacks(&self) -> usize {
        self.switch.iter().filter(|&&s| s).count()
    }

    /// `|A(t1, t2)|` on the half-open `[t1, t2)`, summed exactly and rounded once.
    pub(crate) fn attack_time(&self, t1: f64, t2: f64) -> f64 {
        let (a, b) = (time(t1), time(t2));
        let total: i128 = self
            .points
            .windows(2)
            .zip(&self.jammed)
            .filter(|(_, &j)| j)
            .map(|(seg, _)| (seg[1].min(b) - seg[0].max(a)).max(0))
            .sum();
        total as f64 / (1u128 << TIME_BITS) as f64
    }

    /// Switches in the closed `[t1, t2]`: `N(t1, t2 + eps)` for every small enough `eps > 0`.
    pub(crate) fn switches_through(&self, t1: f64, t2: f64) -> usize {
        let (a, b) = (time(t1), time(t2));
        self.points
            .iter()
            .zip(&self.switch)
            .filter(|&(&p, &s)| s && a <= p && p <= b)
            .count()
    }

    /// Assumption 2 on every window, by brute force over every pair of event points.
    pub(crate) fn check(&self, bounds: &Assumption2) -> Verdict {
        let (t1, t2, d1, d2) = (
            param(bounds.T1),
            param(bounds.T2),
            param(bounds.D1),
            param(bounds.D2),
        );
        assert!(t1 > 0 && t2 > 0 && d1 > 0 && d2 > 1 << PARAM_BITS);
        // With L and A in units of 2^-60 and the parameters in units of 2^-10,
        //   (D1 + L/D2 - A) * 2^70 * d2 = d1 d2 2^60 + L 2^20 - A d2 2^10,
        //   (T1 + L/T2 - N) * 2^70 * t2 = t1 t2 2^60 + L 2^20 - N t2 2^70,
        // all below 2^110 here (L, A < 2^69; parameters < 2^16; N < 2^17).
        let duration_scale = (1i128 << 70) * d2;
        let frequency_scale = (1i128 << 70) * t2;
        let mut duration_min: Option<i128> = None;
        let mut frequency_min: Option<i128> = None;
        let p = &self.points;
        for i in 0..p.len() {
            let mut attacked = 0i128; // |A(p_i, p_j)|, half-open
            let mut switches = 0i128; // switches in [p_i, p_j], closed
            for j in i..p.len() {
                if j > i && self.jammed[j - 1] {
                    attacked += p[j] - p[j - 1];
                }
                if self.switch[j] {
                    switches += 1;
                }
                let len = p[j] - p[i];
                if j > i {
                    let m = d1 * d2 * (1 << 60) + (len << 20) - attacked * d2 * (1 << 10);
                    duration_min = Some(duration_min.map_or(m, |old| old.min(m)));
                }
                let m = t1 * t2 * (1 << 60) + (len << 20) - switches * t2 * (1 << 70);
                frequency_min = Some(frequency_min.map_or(m, |old| old.min(m)));
            }
        }
        let any = self.any_attack();
        let margin =
            |min: Option<i128>, scale: i128| min.filter(|_| any).map(|m| m as f64 / scale as f64);
        Verdict {
            duration_holds: duration_min.is_none_or(|m| m >= 0),
            frequency_holds: frequency_min.is_none_or(|m| m >= 0),
            duration_margin: margin(duration_min, duration_scale),
            frequency_margin: margin(frequency_min, frequency_scale),
            tight: duration_min == Some(0) || frequency_min == Some(0),
        }
    }
}

/// Parameters of Assumption 2 on a grid of `1/den`: T1 in [1/8, 4] (below 1 any attack breaks
/// the frequency bound), T2 in [1/2, 16], D1 in [1/8, 8], D2 in (1, 16] (each rounded up to the
/// grid).
pub(crate) fn bounds_on_grid(den: u32) -> impl Strategy<Value = Assumption2> {
    let step = move |lo: u32, hi: u32| (lo..=hi).prop_map(move |k| f64::from(k) / f64::from(den));
    (
        step(den.div_ceil(8), 4 * den),
        step(den.div_ceil(2), 16 * den),
        step(den.div_ceil(8), 8 * den),
        step(den + 1, 16 * den),
    )
        .prop_map(|(t1, t2, d1, d2)| Assumption2 {
            T1: t1,
            T2: t2,
            D1: d1,
            D2: d2,
        })
}

/// How often each outcome of the oracle came up in a [`run`].
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct Tally {
    pub(crate) cases: usize,
    pub(crate) holds: usize,
    pub(crate) violates: usize,
    pub(crate) duration_violated: usize,
    pub(crate) frequency_violated: usize,
    /// A bound met with exact equality.
    pub(crate) tight: usize,
    /// A bound met with a margin in (0, 1e-6]: pushed right up to it.
    pub(crate) near: usize,
    /// Attacks in `[0, horizon)`, summed over the cases.
    pub(crate) attacks: usize,
}

/// Runs `test` on `cases` values of `strategy` (a fresh seed each run; a failure panics with the
/// shrunk case) and tallies the verdicts it returns with the number of attacks.
pub(crate) fn run<S: Strategy>(
    cases: u32,
    strategy: S,
    test: impl Fn(S::Value) -> Result<(Verdict, usize), TestCaseError>,
) -> Tally {
    let tally = RefCell::new(Tally::default());
    let mut runner = TestRunner::new(ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let result = runner.run(&strategy, |value| {
        let (v, attacks) = test(value)?;
        let near = |m: Option<f64>| m.is_some_and(|m| m > 0.0 && m <= 1e-6);
        let mut t = tally.borrow_mut();
        t.cases += 1;
        t.holds += usize::from(v.holds());
        t.violates += usize::from(!v.holds());
        t.duration_violated += usize::from(!v.duration_holds);
        t.frequency_violated += usize::from(!v.frequency_holds);
        t.tight += usize::from(v.tight);
        t.near += usize::from(near(v.duration_margin) || near(v.frequency_margin));
        t.attacks += attacks;
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let t = tally.into_inner();
    eprintln!("oracle tally: {t:?}");
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    const B: Assumption2 = Assumption2 {
        T1: 2.0,
        T2: 8.0,
        D1: 2.0,
        D2: 2.0,
    };

    #[test]
    fn the_oracle_on_hand_worked_schedules() {
        // One attack of 4 s: |A| = 4 = D1 + 4/D2 on [a, a + 4), exactly on the bound.
        let v = Oracle::new(&[(1.0, 5.0)], 20.0).check(&B);
        assert!(v.holds() && v.tight);
        assert_eq!(v.duration_margin, Some(0.0));
        assert_eq!(v.frequency_margin, Some(1.0)); // T1 - 1 on [1, 1]
                                                   // 4.25 s breaks it by 0.125.
        let v = Oracle::new(&[(1.0, 5.25)], 20.0).check(&B);
        assert!(!v.duration_holds && v.frequency_holds);
        assert_eq!(v.duration_margin, Some(-0.125));
        // Three starts at 0, 4, 8: N = 3 on [0, 8 + eps) against 2 + (8 + eps)/8, which holds
        // for every eps > 0: the supremum 3 is not attained, and equality is allowed.
        let o = Oracle::new(&[(0.0, 0.5), (4.0, 4.5), (8.0, 8.5)], 20.0);
        assert_eq!(o.switches_through(0.0, 8.0), 3);
        let v = o.check(&B);
        assert!(v.frequency_holds && v.tight);
        assert_eq!(v.frequency_margin, Some(0.0));
        // A third start just before 8 s violates it.
        let v = Oracle::new(&[(0.0, 0.5), (4.0, 4.5), (7.75, 8.0)], 20.0).check(&B);
        assert!(!v.frequency_holds);
        assert_eq!(v.frequency_margin, Some(-1.0 / 32.0));
        // Touching and overlapping intervals are one attack: one switch, at 0; the part beyond
        // the horizon does not count.
        let o = Oracle::new(&[(2.0, 3.0), (0.0, 2.0), (1.0, 2.5), (9.0, 30.0)], 10.0);
        assert_eq!(o.switches_through(0.0, 10.0), 2);
        assert_eq!(o.attack_time(0.0, 10.0), 4.0);
        assert_eq!(o.attack_time(0.5, 9.5), 3.0);
        // Nothing in [0, horizon): holds, no margins.
        let v = Oracle::new(&[(12.0, 13.0)], 10.0).check(&B);
        assert!(v.holds() && v.duration_margin.is_none() && v.frequency_margin.is_none());
    }
}
