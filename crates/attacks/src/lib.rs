//! Denial-of-service attacks on the platoon's V2V channel (Section II-C of the paper), as a pure
//! library.
//!
//! * [`DosSchedule`]: the attack intervals `A_c = [a_c, a_c + d_c)`, normalised (sorted, merged),
//!   from explicit intervals, a periodic pattern or a seeded random generator.
//! * [`Assumption2`]: the frequency and duration bounds of De Persis and Tesi, checked **exactly**
//!   over every window `[t1, t2)` (docs/paper-readings.md#R22), not over sampled windows.
//! * [`RandomDos`]: a seeded generator whose schedules satisfy a given [`Assumption2`] by
//!   construction (the property tests check it, and the checker, against a brute-force oracle
//!   in exact arithmetic: `oracle.rs`).
//! * [`channel::Channel`]: the V2V channel under the DoS schedule and link-level attacks
//!   (Bernoulli and Gilbert-Elliott loss, delay, range jamming, replay, false data injection),
//!   and [`jammer::Jammers`], jammers as transmitters (placed, powered, with a behaviour).
//! * [`inject::Injector`]: the seam an attack of the caller's fills (one platoon, one step: the
//!   broadcasts in, what each receiver gets out); the built-in channel is one, and the same
//!   injector runs in process and as a co-simulation's injector process.
#![warn(missing_docs)]

mod assumption2;
pub mod channel;
pub mod inject;
pub mod jammer;
mod medium;
#[cfg(test)]
mod oracle;
mod random;

pub use assumption2::{Assumption2, Assumption2Report, Window};
pub use random::RandomDos;

use serde::{Deserialize, Serialize};

/// Why a schedule was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScheduleError {
    /// A start or duration is negative, NaN or infinite.
    #[error("attack interval {index} must have a finite start >= 0 and a finite duration > 0 (got start {start}, duration {duration})")]
    BadInterval {
        /// Index of the interval as given.
        index: usize,
        /// Its start.
        start: f64,
        /// Its duration.
        duration: f64,
    },
    /// A periodic pattern whose duration does not fit in its period.
    #[error(
        "a periodic attack needs 0 < duration < period (got duration {duration}, period {period})"
    )]
    BadPeriodic {
        /// Attack duration.
        duration: f64,
        /// Period.
        period: f64,
    },
    /// Parameters of Assumption 2 out of range.
    #[error("{0}")]
    BadAssumption(String),
}

/// One attack interval `[start, end)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Start `a_c` (s).
    pub start: f64,
    /// End `a_c + d_c` (s), exclusive.
    pub end: f64,
}

impl Interval {
    /// Its length `d_c`.
    pub fn duration(&self) -> f64 {
        self.end - self.start
    }
}

/// A DoS schedule: disjoint, sorted, non-adjacent attack intervals.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct DosSchedule {
    intervals: Vec<Interval>,
}

impl DosSchedule {
    /// No attack.
    pub fn none() -> Self {
        Self::default()
    }

    /// From `(start, duration)` pairs in any order; overlapping or touching intervals merge.
    pub fn from_intervals(pairs: &[(f64, f64)]) -> Result<Self, ScheduleError> {
        let mut intervals = Vec::with_capacity(pairs.len());
        for (index, &(start, duration)) in pairs.iter().enumerate() {
            if !(start.is_finite() && start >= 0.0 && duration.is_finite() && duration > 0.0) {
                return Err(ScheduleError::BadInterval {
                    index,
                    start,
                    duration,
                });
            }
            intervals.push(Interval {
                start,
                end: start + duration,
            });
        }
        intervals.sort_by(|a, b| a.start.total_cmp(&b.start));
        let mut merged: Vec<Interval> = Vec::with_capacity(intervals.len());
        for iv in intervals {
            match merged.last_mut() {
                Some(last) if iv.start <= last.end => last.end = last.end.max(iv.end),
                _ => merged.push(iv),
            }
        }
        Ok(Self { intervals: merged })
    }

    /// Attacks of length `duration` every `period`, the first at `offset`, until `horizon`.
    pub fn periodic(
        period: f64,
        duration: f64,
        offset: f64,
        horizon: f64,
    ) -> Result<Self, ScheduleError> {
        if !(period.is_finite() && duration > 0.0 && duration < period && offset >= 0.0) {
            return Err(ScheduleError::BadPeriodic { duration, period });
        }
        let mut pairs = Vec::new();
        let mut c = 0u32;
        loop {
            let start = offset + f64::from(c) * period;
            if start >= horizon {
                break;
            }
            pairs.push((start, duration));
            c += 1;
        }
        Self::from_intervals(&pairs)
    }

    /// The intervals, sorted and disjoint.
    pub fn intervals(&self) -> &[Interval] {
        &self.intervals
    }

    /// Whether the channel is jammed at time t.
    pub fn is_active(&self, t: f64) -> bool {
        let i = self.intervals.partition_point(|iv| iv.start <= t);
        i > 0 && t < self.intervals[i - 1].end
    }

    /// The schedule restricted to `[0, horizon)`.
    pub fn clipped(&self, horizon: f64) -> Self {
        let intervals = self
            .intervals
            .iter()
            .filter(|iv| iv.start < horizon)
            .map(|iv| Interval {
                start: iv.start,
                end: iv.end.min(horizon),
            })
            .collect();
        Self { intervals }
    }

    /// `|A(t1, t2)|`: total attack time within `[t1, t2)`.
    pub fn active_time(&self, t1: f64, t2: f64) -> f64 {
        // Folded from +0.0: `Sum for f64` starts from -0.0, so no attack would be "-0 s".
        self.intervals
            .iter()
            .map(|iv| (iv.end.min(t2) - iv.start.max(t1)).max(0.0))
            .fold(0.0, |total, d| total + d)
    }

    /// `N(t1, t2)`: number of off-to-on switches (attack starts) within `[t1, t2)`.
    pub fn count(&self, t1: f64, t2: f64) -> usize {
        self.intervals
            .iter()
            .filter(|iv| iv.start >= t1 && iv.start < t2)
            .count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_attack_is_no_time_not_minus_zero() {
        let t = DosSchedule::none().active_time(0.0, 10.0);
        assert!(t == 0.0 && t.is_sign_positive(), "{t:?}");
        let outside = DosSchedule::from_intervals(&[(20.0, 1.0)]).unwrap();
        assert!(outside.active_time(0.0, 10.0).is_sign_positive());
    }

    #[test]
    fn intervals_are_sorted_and_merged() {
        let s = DosSchedule::from_intervals(&[(5.0, 1.0), (1.0, 2.0), (2.5, 1.0)]).unwrap();
        assert_eq!(
            s.intervals(),
            &[
                Interval {
                    start: 1.0,
                    end: 3.5
                },
                Interval {
                    start: 5.0,
                    end: 6.0
                }
            ]
        );
        assert!(s.is_active(1.0));
        assert!(s.is_active(3.49));
        assert!(!s.is_active(3.5));
        assert!(!s.is_active(0.99));
        assert_eq!(s.active_time(0.0, 10.0), 3.5);
        assert_eq!(s.active_time(2.0, 5.5), 2.0);
        assert_eq!(s.count(0.0, 10.0), 2);
        assert_eq!(s.count(1.5, 10.0), 1);
    }

    #[test]
    fn bad_intervals_are_rejected() {
        assert!(DosSchedule::from_intervals(&[(1.0, 0.0)]).is_err());
        assert!(DosSchedule::from_intervals(&[(-1.0, 1.0)]).is_err());
        assert!(DosSchedule::from_intervals(&[(f64::NAN, 1.0)]).is_err());
        assert!(DosSchedule::periodic(1.0, 1.0, 0.0, 10.0).is_err());
    }

    #[test]
    fn periodic_schedule() {
        let s = DosSchedule::periodic(10.0, 2.0, 1.0, 35.0).unwrap();
        assert_eq!(s.intervals().len(), 4);
        assert_eq!(s.clipped(32.0).active_time(0.0, 100.0), 7.0);
    }
}
