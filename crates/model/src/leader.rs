use serde::{Deserialize, Serialize};

/// Why a leader profile was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProfileError {
    /// Fewer than one waypoint.
    #[error("a velocity profile needs at least one waypoint")]
    Empty,
    /// A time or velocity is NaN or infinite.
    #[error("waypoint {index} is not finite")]
    NotFinite {
        /// Index of the waypoint.
        index: usize,
    },
    /// Waypoint times must increase strictly.
    #[error(
        "waypoint times must increase strictly (waypoint {index} is at or before the previous one)"
    )]
    NotIncreasing {
        /// Index of the offending waypoint.
        index: usize,
    },
    /// The first waypoint must be at t = 0.
    #[error("the first waypoint must be at t = 0")]
    DoesNotStartAtZero,
}

/// The leader's reference: a piecewise-linear velocity through waypoints `(t, v)`, constant
/// before the first and after the last. Its acceleration is the slope of the current segment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LeaderProfile {
    waypoints: Vec<(f64, f64)>,
}

impl LeaderProfile {
    /// Builds a profile from `(t, v)` waypoints starting at t = 0 with strictly increasing times.
    pub fn from_waypoints(waypoints: Vec<(f64, f64)>) -> Result<Self, ProfileError> {
        if waypoints.is_empty() {
            return Err(ProfileError::Empty);
        }
        for (index, &(t, v)) in waypoints.iter().enumerate() {
            if !t.is_finite() || !v.is_finite() {
                return Err(ProfileError::NotFinite { index });
            }
            if index > 0 && t <= waypoints[index - 1].0 {
                return Err(ProfileError::NotIncreasing { index });
            }
        }
        if waypoints[0].0 != 0.0 {
            return Err(ProfileError::DoesNotStartAtZero);
        }
        Ok(Self { waypoints })
    }

    /// Constant speed.
    pub fn constant(v: f64) -> Self {
        Self {
            waypoints: vec![(0.0, v)],
        }
    }

    /// The profile of Section IV as docs/paper-readings.md#R4 reads it: 15 m/s, +2 m/s^2 on
    /// [10, 15), 25 m/s, -2 m/s^2 on [35, 40), 15 m/s.
    pub fn paper() -> Self {
        Self {
            waypoints: vec![
                (0.0, 15.0),
                (10.0, 15.0),
                (15.0, 25.0),
                (35.0, 25.0),
                (40.0, 15.0),
            ],
        }
    }

    /// The waypoints.
    pub fn waypoints(&self) -> &[(f64, f64)] {
        &self.waypoints
    }

    fn segment(&self, t: f64) -> Option<usize> {
        // Index i such that waypoints[i].0 <= t < waypoints[i+1].0.
        let i = self.waypoints.partition_point(|&(tw, _)| tw <= t);
        (i >= 1 && i < self.waypoints.len()).then(|| i - 1)
    }

    /// Reference velocity at time t.
    pub fn velocity_at(&self, t: f64) -> f64 {
        match self.segment(t) {
            Some(i) => {
                let ((t0, v0), (t1, v1)) = (self.waypoints[i], self.waypoints[i + 1]);
                v0 + (v1 - v0) * (t - t0) / (t1 - t0)
            }
            None if t < self.waypoints[0].0 => self.waypoints[0].1,
            None => self.waypoints[self.waypoints.len() - 1].1,
        }
    }

    /// Reference acceleration at time t (the slope of the segment holding t).
    pub fn acceleration_at(&self, t: f64) -> f64 {
        match self.segment(t) {
            Some(i) => {
                let ((t0, v0), (t1, v1)) = (self.waypoints[i], self.waypoints[i + 1]);
                (v1 - v0) / (t1 - t0)
            }
            None => 0.0,
        }
    }

    /// The acceleration the leader holds over step k, `[k dt, (k+1) dt)`: the slope at the
    /// middle of the step, so a breakpoint on a step boundary never depends on rounding.
    pub fn step_acceleration(&self, k: usize, dt: f64) -> f64 {
        self.acceleration_at((k as f64 + 0.5) * dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_profile_values() {
        let p = LeaderProfile::paper();
        assert_eq!(p.velocity_at(5.0), 15.0);
        assert_eq!(p.velocity_at(12.5), 20.0);
        assert_eq!(p.velocity_at(20.0), 25.0);
        assert_eq!(p.velocity_at(37.5), 20.0);
        assert_eq!(p.velocity_at(50.0), 15.0);
        assert_eq!(p.acceleration_at(12.0), 2.0);
        assert_eq!(p.acceleration_at(36.0), -2.0);
        assert_eq!(p.acceleration_at(20.0), 0.0);
        assert_eq!(p.acceleration_at(54.0), 0.0);
    }

    #[test]
    fn rejects_bad_waypoints() {
        assert_eq!(
            LeaderProfile::from_waypoints(vec![]),
            Err(ProfileError::Empty)
        );
        assert_eq!(
            LeaderProfile::from_waypoints(vec![(0.0, 1.0), (0.0, 2.0)]),
            Err(ProfileError::NotIncreasing { index: 1 })
        );
        assert_eq!(
            LeaderProfile::from_waypoints(vec![(1.0, 1.0)]),
            Err(ProfileError::DoesNotStartAtZero)
        );
        assert_eq!(
            LeaderProfile::from_waypoints(vec![(0.0, f64::NAN)]),
            Err(ProfileError::NotFinite { index: 0 })
        );
    }
}
