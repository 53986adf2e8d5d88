//! `[simulation]`: the time grid.
use super::checks::{bad, positive};
use crate::error::KeyError;
use crate::schema::Simulation;

/// Steps of a run at most (a year of simulated time at dt = 0.01 s would be 3e9).
pub(crate) const MAX_STEPS: f64 = 1e9;

/// The run's time grid.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid {
    /// The step (s).
    pub dt: f64,
    /// The run's length (s).
    pub duration: f64,
    /// Its steps.
    pub steps: u64,
}

/// `[simulation]`: a positive step, and a duration of a whole number of them.
pub(crate) fn grid(s: &Simulation) -> Result<Grid, KeyError> {
    let dt = positive("simulation.dt_s", s.dt_s)?;
    let duration = positive("simulation.duration_s", s.duration_s)?;
    let steps = (duration / dt).round();
    if steps > MAX_STEPS {
        return bad(
            "simulation.duration_s",
            format!("{duration} s in steps of {dt} s is {steps:e} steps, more than {MAX_STEPS:e}"),
        );
    }
    if (steps * dt - duration).abs() > 1e-9 * duration.max(1.0) {
        return bad(
            "simulation.duration_s",
            format!("{duration} s is not a whole number of steps of {dt} s"),
        );
    }
    Ok(Grid {
        dt,
        duration,
        steps: steps as u64,
    })
}
