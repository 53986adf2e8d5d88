//! The longitudinal vehicle model of the platoon, as a pure library (no I/O, clocks or threads).
//!
//! Each vehicle has the third-order model of Han et al. (2024), Section II-A:
//!
//! ```text
//! p' = v,   v' = a,   a' = (u - a) / tau(t)
//! ```
//!
//! with a power-train time constant `tau(t)` that may vary over time ([`TauSchedule`]). The leader is
//! an exogenous reference that follows a velocity profile ([`LeaderProfile`]); see reading R4.
//!
//! # Discretisation
//!
//! Every plant (the native one here and, later, SUMO) advances with step `dt` the same way
//! ([`plant_step`]): over `[k dt, (k+1) dt)` the acceleration `a[k]` is held constant, so position
//! and velocity follow SUMO's *ballistic* update, and the engine lag is integrated exactly for the
//! command `u[k]` held over the step (zero-order hold) with the time constant `tau(k dt)`:
//!
//! ```text
//! p[k+1] = p[k] + v[k] dt + a[k] dt^2 / 2
//! v[k+1] = v[k] + a[k] dt
//! a[k+1] = u[k] + (a[k] - u[k]) exp(-dt / tau(k dt))
//! ```
//!
//! The acceleration sequence is therefore exact for piecewise-constant commands, and position and
//! velocity converge to the continuous solution with error O(dt). The open-loop estimators of the
//! controllers use the exact flow of the nominal model `x' = A x` ([`FreeFlow`]).
#![warn(missing_docs)]

/// Typed vehicle identifiers.
pub mod id;
/// Velocity profiles of the leader.
pub mod leader;
/// Time-varying power-train time constants.
pub mod tau;

pub use id::VehicleId;
pub use leader::{LeaderProfile, ProfileError};
pub use tau::{TauError, TauSchedule};

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// A vehicle's longitudinal state `[p, v, a]` (m, m/s, m/s^2).
pub type State = Vector3<f64>;

/// Advances one vehicle by one step `dt` under the command `u` held over the step.
///
/// See the crate documentation for the exact update. `tau` is the time constant at the start of
/// the step; it must be positive.
#[inline]
pub fn plant_step(x: &State, u: f64, tau: f64, dt: f64) -> State {
    let (p, v, a) = (x[0], x[1], x[2]);
    State::new(
        p + v * dt + 0.5 * a * dt * dt,
        v + a * dt,
        u + (a - u) * (-dt / tau).exp(),
    )
}

/// How the followers' plant is discretised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum Discretisation {
    /// [`plant_step`]: a ballistic move with the acceleration at the start of the step, then
    /// the exact zero-order-hold lag (the paper's model, sampled exactly).
    #[default]
    Exact,
    /// [`plant_step_plexe`]: SUMO's `CC` car-following model (Plexe), a backward-Euler lag
    /// first, then a ballistic move with the new acceleration.
    Plexe,
}

impl Discretisation {
    /// One step of a follower under this discretisation.
    #[inline]
    pub fn step(self, x: &State, u: f64, tau: f64, dt: f64) -> State {
        match self {
            Self::Exact => plant_step(x, u, tau, dt),
            Self::Plexe => plant_step_plexe(x, u, tau, dt),
        }
    }
}

/// One step as SUMO 1.28 moves a vehicle of its `CC` car-following model (Plexe's first-order
/// lag engine, ballistic update), operation by operation so that the numbers are SUMO's:
///
/// ```text
/// alpha = dt / (tau + dt)
/// a_e   = alpha u + (1 - alpha) a        backward-Euler lag of tau a' + a = u
/// v'    = max(0, v + a_e dt)
/// a'    = (v' - v) / dt
/// p'    = p + (v + a' dt / 2) dt
/// ```
///
/// SUMO also clamps the command and `a_e` to the vehicle type's acceleration limits; this plant
/// has none. Its lag acts like the exact one with `tau + dt / 2`.
#[inline]
pub fn plant_step_plexe(x: &State, u: f64, tau: f64, dt: f64) -> State {
    let (p, v, a) = (x[0], x[1], x[2]);
    let alpha = dt / (tau + dt);
    let a_e = alpha * u + (1.0 - alpha) * a;
    let v_next = (v + a_e * dt).max(0.0);
    let a_next = (v_next - v) / dt;
    State::new(p + (v + 0.5 * (a_next * dt)) * dt, v_next, a_next)
}

/// Advances the leader by one step with the profile's acceleration `a_ref` held over the step.
///
/// The leader's state carries the acceleration it applies during the step that starts now, so
/// ballistic integration reproduces the piecewise-linear velocity profile exactly when the
/// profile's breakpoints are multiples of `dt`.
#[inline]
pub fn leader_step(x: &State, a_ref: f64, dt: f64) -> State {
    let (p, v, a) = (x[0], x[1], x[2]);
    State::new(p + v * dt + 0.5 * a * dt * dt, v + a * dt, a_ref)
}

/// The exact flow over one step of the nominal open-loop model `x' = A x` with
/// `A = [[0,1,0],[0,0,1],[0,0,-1/tau]]`: what the estimators (2) of the paper integrate between
/// samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeFlow {
    phi: Matrix3<f64>,
}

impl FreeFlow {
    /// The transition matrix `exp(A dt)` for the nominal time constant `tau`.
    pub fn new(tau: f64, dt: f64) -> Self {
        let e = (-dt / tau).exp();
        let g = tau * (1.0 - e); // integral of e^{-s/tau} over [0, dt]
        #[rustfmt::skip]
        let phi = Matrix3::new(
            1.0, dt,  tau * (dt - g),
            0.0, 1.0, g,
            0.0, 0.0, e,
        );
        Self { phi }
    }

    /// The state one step later.
    #[inline]
    pub fn advance(&self, x: &State) -> State {
        self.phi * x
    }

    /// The transition matrix itself.
    pub fn matrix(&self) -> &Matrix3<f64> {
        &self.phi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact continuous solution of the lag model for a constant input u and constant tau.
    fn exact(x0: &State, u: f64, tau: f64, t: f64) -> State {
        let e = (-t / tau).exp();
        let da = x0[2] - u;
        State::new(
            x0[0] + x0[1] * t + 0.5 * u * t * t + da * tau * (t - tau * (1.0 - e)),
            x0[1] + u * t + da * tau * (1.0 - e),
            u + da * e,
        )
    }

    #[test]
    fn acceleration_is_exact_for_constant_input() {
        let (tau, dt, u) = (0.5, 0.01, 2.0);
        let mut x = State::new(0.0, 15.0, -1.0);
        for k in 1..=1000 {
            x = plant_step(&x, u, tau, dt);
            let want = exact(&State::new(0.0, 15.0, -1.0), u, tau, k as f64 * dt)[2];
            assert!((x[2] - want).abs() < 1e-12, "step {k}: {} vs {want}", x[2]);
        }
    }

    #[test]
    fn position_and_velocity_converge_with_first_order_error() {
        let (tau, u, t_end) = (0.34, 1.5, 5.0);
        let x0 = State::new(3.0, 12.0, 0.5);
        let want = exact(&x0, u, tau, t_end);
        let err = |dt: f64| {
            let steps = (t_end / dt).round() as usize;
            let mut x = x0;
            for _ in 0..steps {
                x = plant_step(&x, u, tau, dt);
            }
            (x - want).abs().max()
        };
        let (e1, e2) = (err(0.01), err(0.005));
        assert!(e1 < 0.05, "error at dt=0.01 is {e1}");
        let ratio = e1 / e2;
        assert!(
            (1.8..2.2).contains(&ratio),
            "halving dt should halve the error, ratio {ratio}"
        );
    }

    #[test]
    fn ballistic_update_is_exact_for_held_acceleration() {
        // With u equal to a, the acceleration stays constant and the update is exact kinematics.
        let mut x = State::new(0.0, 10.0, 2.0);
        for _ in 0..100 {
            x = plant_step(&x, 2.0, 0.5, 0.01);
        }
        assert!((x[0] - (10.0 + 0.5 * 2.0)).abs() < 1e-12);
        assert!((x[1] - 12.0).abs() < 1e-12);
    }

    #[test]
    fn free_flow_matches_exact_solution_with_zero_input() {
        let (tau, dt) = (0.5, 0.02);
        let flow = FreeFlow::new(tau, dt);
        let x0 = State::new(1.0, 15.0, 2.0);
        let mut x = x0;
        for _ in 0..50 {
            x = flow.advance(&x);
        }
        let want = exact(&x0, 0.0, tau, 1.0);
        assert!((x - want).abs().max() < 1e-10, "{x:?} vs {want:?}");
    }

    #[test]
    fn leader_step_reproduces_piecewise_linear_velocity() {
        let profile = LeaderProfile::paper();
        let dt = 0.01;
        let mut x = State::new(20.0, 15.0, profile.step_acceleration(0, dt));
        for k in 0..5500 {
            let t_next = (k + 1) as f64 * dt;
            x = leader_step(&x, profile.step_acceleration(k + 1, dt), dt);
            assert!(
                (x[1] - profile.velocity_at(t_next)).abs() < 1e-9,
                "t={t_next}"
            );
        }
        // distance: 15*55 + area of the two ramps (+50 m each way) + 20 s at +10 m/s
        assert!(
            (x[0] - (20.0 + 15.0 * 55.0 + 25.0 + 200.0 + 25.0)).abs() < 1e-8,
            "{}",
            x[0]
        );
    }
}
