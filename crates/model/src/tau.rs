use serde::{Deserialize, Serialize};

/// Why a tau schedule was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TauError {
    /// tau must be positive and finite everywhere.
    #[error("tau must be positive and finite (knot {index} has {value})")]
    NotPositive {
        /// Index of the knot.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// Knot times must be finite and increase strictly.
    #[error("knot times must be finite and increase strictly (knot {index})")]
    BadTimes {
        /// Index of the knot.
        index: usize,
    },
    /// No knots.
    #[error("a schedule needs at least one knot")]
    Empty,
}

/// How tau varies between knots `(t, tau)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Holds each knot's value until the next knot.
    Step,
    /// Linear ramps between knots.
    Linear,
    /// Smoothstep (C1, zero slope at knots) between knots.
    Smooth,
}

/// A power-train time constant over time. Before the first knot the first value holds, after the
/// last the last value holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TauSchedule {
    knots: Vec<(f64, f64)>,
    interpolation: Interpolation,
}

impl TauSchedule {
    /// A constant tau.
    pub fn constant(tau: f64) -> Result<Self, TauError> {
        Self::new(vec![(0.0, tau)], Interpolation::Step)
    }

    /// A schedule through knots `(t, tau)`.
    pub fn new(knots: Vec<(f64, f64)>, interpolation: Interpolation) -> Result<Self, TauError> {
        if knots.is_empty() {
            return Err(TauError::Empty);
        }
        for (index, &(t, tau)) in knots.iter().enumerate() {
            if !t.is_finite() || (index > 0 && t <= knots[index - 1].0) {
                return Err(TauError::BadTimes { index });
            }
            if !(tau.is_finite() && tau > 0.0) {
                return Err(TauError::NotPositive { index, value: tau });
            }
        }
        Ok(Self {
            knots,
            interpolation,
        })
    }

    /// Fig. 5(a) of the paper: 0.34 s until 20 s, 0.82 s from 35 s. The paper does not give the
    /// middle (docs/paper-readings.md#R9); we take a linear ramp.
    pub fn paper() -> Self {
        Self {
            knots: vec![(0.0, 0.34), (20.0, 0.34), (35.0, 0.82)],
            interpolation: Interpolation::Linear,
        }
    }

    /// The knots.
    pub fn knots(&self) -> &[(f64, f64)] {
        &self.knots
    }

    /// The interpolation between knots.
    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    /// tau at time t (always positive).
    pub fn at(&self, t: f64) -> f64 {
        let i = self.knots.partition_point(|&(tk, _)| tk <= t);
        if i == 0 {
            return self.knots[0].1;
        }
        if i == self.knots.len() {
            return self.knots[i - 1].1;
        }
        let ((t0, y0), (t1, y1)) = (self.knots[i - 1], self.knots[i]);
        let s = (t - t0) / (t1 - t0);
        match self.interpolation {
            Interpolation::Step => y0,
            Interpolation::Linear => y0 + (y1 - y0) * s,
            Interpolation::Smooth => y0 + (y1 - y0) * s * s * (3.0 - 2.0 * s),
        }
    }

    /// The smallest and largest tau the schedule takes.
    pub fn range(&self) -> (f64, f64) {
        self.knots
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(_, y)| {
                (lo.min(y), hi.max(y))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_schedule_matches_fig5a() {
        let s = TauSchedule::paper();
        assert_eq!(s.at(0.0), 0.34);
        assert_eq!(s.at(19.99), 0.34);
        assert!((s.at(27.5) - 0.58).abs() < 1e-12);
        assert_eq!(s.at(35.0), 0.82);
        assert_eq!(s.at(55.0), 0.82);
        assert_eq!(s.range(), (0.34, 0.82));
    }

    #[test]
    fn step_and_smooth_interpolation() {
        let knots = vec![(0.0, 0.4), (10.0, 0.8)];
        let step = TauSchedule::new(knots.clone(), Interpolation::Step).unwrap();
        assert_eq!(step.at(9.9), 0.4);
        assert_eq!(step.at(10.0), 0.8);
        let smooth = TauSchedule::new(knots, Interpolation::Smooth).unwrap();
        assert!((smooth.at(5.0) - 0.6).abs() < 1e-12);
        assert!(smooth.at(1.0) < 0.4 + 0.4 * 0.1, "smoothstep starts flat");
    }

    #[test]
    fn rejects_non_positive_tau() {
        assert_eq!(
            TauSchedule::constant(0.0),
            Err(TauError::NotPositive {
                index: 0,
                value: 0.0
            })
        );
        assert!(TauSchedule::new(vec![(0.0, 0.5), (0.0, 0.6)], Interpolation::Linear).is_err());
        assert!(TauSchedule::constant(f64::NAN).is_err());
    }
}
