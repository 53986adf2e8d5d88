//! `[leader]`: the leader's reference and how often it broadcasts.
use super::checks::{bad, finite, steps_of};
use crate::error::KeyError;
use crate::schema::{Leader, LeaderProfileConfig};
use platoon_model::{LeaderProfile, State};

/// `leader.profile`.
pub(crate) fn profile(profile: &LeaderProfileConfig) -> Result<LeaderProfile, KeyError> {
    Ok(match profile {
        LeaderProfileConfig::Paper {} => LeaderProfile::paper(),
        LeaderProfileConfig::Constant { speed_mps } => {
            LeaderProfile::constant(finite("leader.profile.speed_mps", *speed_mps)?)
        }
        LeaderProfileConfig::Waypoints { points } => {
            LeaderProfile::from_waypoints(points.iter().map(|w| (w[0], w[1])).collect())
                .or_else(|e| bad("leader.profile.points", e.to_string()))?
        }
    })
}

/// The profile starts at the speed the leader's initial state gives it.
pub(crate) fn check_start(leader: &LeaderProfile, initial: &[State]) -> Result<(), KeyError> {
    if (leader.velocity_at(0.0) - initial[0][1]).abs() > 1e-9 {
        return bad(
            "leader.profile",
            format!(
                "starts at {} m/s but platoon.initial_states[0] gives the leader {} m/s",
                leader.velocity_at(0.0),
                initial[0][1]
            ),
        );
    }
    Ok(())
}

/// `leader.broadcast_period_s` in steps of `dt` (absent: every step).
pub(crate) fn broadcast_steps(l: &Leader, dt: f64) -> Result<u32, KeyError> {
    match l.broadcast_period_s {
        None => Ok(1),
        Some(s) => steps_of("leader.broadcast_period_s", s, dt),
    }
}
