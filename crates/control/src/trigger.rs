use nalgebra::RowVector3;
use serde::{Deserialize, Serialize};

/// When a follower broadcasts its state, checked every `check_steps` steps on its own
/// estimation error `eps_i = x^_i - x_i` and neighbourhood error `q_i`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum TriggerRule {
    /// Time-triggered: every `period_steps` steps.
    Periodic {
        /// Broadcast period in steps.
        period_steps: u32,
    },
    /// Static ETM (21): `beta1 |eps|^2 - beta2 |q|^2 > 0` (strict, docs/paper-readings.md#R12).
    Static,
    /// Dynamic ETM (4) with the internal variable (12):
    /// `beta1 |eps|^2 - beta2 |q|^2 - phi theta > 0`,
    /// `theta' = -rho theta - eta (beta1 |eps|^2 - beta2 |q|^2)`.
    ///
    /// `theta` is integrated exactly over each step for the error terms held (zero-order hold)
    /// and clipped at 0 (reading R11); it is frozen while the vehicle is affected by an attack.
    Dynamic {
        /// Weight `phi_i` of theta in the condition.
        phi: f64,
        /// Decay rate `rho_i`.
        rho: f64,
        /// Gain `eta_i` of the static condition in theta's dynamics.
        eta: f64,
        /// Initial value `theta_i(0)`.
        theta0: f64,
    },
    /// Baseline for Table I's third row (reading R13): a static ETM with an exponentially
    /// decaying offset, in the manner of Seyboth, Dimarogonas and Johansson, "Event-based
    /// broadcasting for multi-agent average consensus", Automatica 49(1), 2013:
    /// `beta1 |eps|^2 - beta2 |q|^2 > beta1 mu exp(-alpha t)`.
    Mixed {
        /// Offset at t = 0 (m^2 in the units of |eps|^2).
        mu: f64,
        /// Decay rate of the offset (1/s).
        alpha: f64,
    },
}

/// Everything a follower controller needs besides the graph.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerParams {
    /// The law the followers run: the paper's (the fields below) or one of the field's, which
    /// beacon with the periodic [`TriggerRule`] and use `fallback`, `dt`, `spacing` and
    /// `leader_broadcast_steps` too.
    pub law: crate::LawParams,
    /// Controller gain `K` (the law is `u = -K q`).
    pub gain: RowVector3<f64>,
    /// Weight of `|eps|^2` in the triggering conditions.
    pub beta1: f64,
    /// Weight of `|q|^2` in the triggering conditions.
    pub beta2: f64,
    /// The triggering rule.
    pub rule: TriggerRule,
    /// Wrap the rule in the resilient mechanism (11): after a broadcast that falls in an attack,
    /// sample every `h_steps` until one gets through.
    pub resilient: bool,
    /// The resilient sampling period `h` in steps.
    pub h_steps: u32,
    /// How often the event condition is checked, in steps (docs/paper-readings.md#R10).
    pub check_steps: u32,
    /// What to do while affected by an attack, and how to come back.
    pub fallback: crate::FallbackParams,
    /// Step length (s).
    pub dt: f64,
    /// Nominal time constant used by the estimators (s).
    pub tau_nominal: f64,
    /// Desired spacing `l` between consecutive vehicles (m).
    pub spacing: f64,
    /// Time headway `h_t` of the spacing policy (s): the desired gap to a vehicle `m` places
    /// ahead is `m (l + h_t v)` with `v` the speed of the rear one of the two (its estimate);
    /// 0 is constant spacing (the paper).
    pub headway: f64,
    /// The leader broadcasts every this many steps (1: every step, docs/paper-readings.md#R5).
    pub leader_broadcast_steps: u32,
}

/// Why controller parameters were rejected; the field names match the config keys.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct ParamsError {
    /// The offending parameter.
    pub field: &'static str,
    /// What is wrong with it.
    pub message: String,
}

impl ControllerParams {
    /// Checks ranges: positive finite step, tau, betas; positive periods; the conditions
    /// `phi, eta >= 0`, `1 > rho > phi (1 - eta) >= 0` of the paper for the dynamic rule.
    pub fn validate(&self) -> Result<(), ParamsError> {
        let err = |field, message: String| Err(ParamsError { field, message });
        let pos = |x: f64| x.is_finite() && x > 0.0;
        if self.law != crate::LawParams::Paper {
            self.law
                .validate()
                .map_err(|(field, message)| ParamsError { field, message })?;
            if !matches!(self.rule, TriggerRule::Periodic { .. }) {
                return err(
                    "rule",
                    format!(
                        "the {} rule needs the paper's law (its estimators); law = \"{}\" \
                         beacons periodically: rule = \"periodic\" with period_s",
                        self.rule.name(),
                        self.law.name()
                    ),
                );
            }
        } else if self.gain.iter().any(|g| !g.is_finite()) {
            return err("gain", "must be finite".into());
        }
        if self.law == crate::LawParams::Paper && (!pos(self.beta1) || !pos(self.beta2)) {
            return err(
                "beta",
                format!(
                    "beta1, beta2 must be > 0 (got {}, {})",
                    self.beta1, self.beta2
                ),
            );
        }
        if !(self.headway.is_finite() && self.headway >= 0.0) {
            return err(
                "headway",
                format!("must be finite and >= 0 (got {})", self.headway),
            );
        }
        if !pos(self.dt) || !pos(self.tau_nominal) || !self.spacing.is_finite() {
            return err(
                "dt",
                "step, nominal tau and spacing must be finite, step and tau > 0".into(),
            );
        }
        if self.h_steps == 0 || self.check_steps == 0 || self.leader_broadcast_steps == 0 {
            return err("h", "periods must be at least one step".into());
        }
        match self.rule {
            TriggerRule::Periodic { period_steps: 0 } => {
                return err("period", "must be at least one step".into())
            }
            TriggerRule::Dynamic {
                phi,
                rho,
                eta,
                theta0,
            } => {
                let finite = [phi, rho, eta, theta0].iter().all(|x| x.is_finite());
                if !finite || phi < 0.0 || eta < 0.0 || theta0 < 0.0 {
                    return err("phi", "phi, eta, theta0 must be finite and >= 0".into());
                }
                if !(rho < 1.0 && rho > phi * (1.0 - eta)) {
                    return err(
                        "rho",
                        format!(
                            "needs 1 > rho > phi (1 - eta) >= 0 (got rho={rho}, phi (1 - eta)={})",
                            phi * (1.0 - eta)
                        ),
                    );
                }
            }
            TriggerRule::Mixed { mu, alpha }
                if !(mu.is_finite() && mu >= 0.0 && alpha.is_finite() && alpha >= 0.0) =>
            {
                return err("mu", "mu and alpha must be finite and >= 0".into());
            }
            _ => {}
        }
        Ok(())
    }
}

impl TriggerRule {
    /// The rule's name as used in configs and outputs.
    pub fn name(&self) -> &'static str {
        match self {
            TriggerRule::Periodic { .. } => "periodic",
            TriggerRule::Static => "static",
            TriggerRule::Dynamic { .. } => "dynamic",
            TriggerRule::Mixed { .. } => "mixed",
        }
    }
}
