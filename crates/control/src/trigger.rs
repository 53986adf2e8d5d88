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
    /// ETSI EN 302 637-2's CAM generation rules ([`CamRule`]).
    Cam(CamRule),
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
    /// beacon with the periodic or the CAM [`TriggerRule`] and use `fallback`, `dt`,
    /// `spacing`, `headway` and `leader_broadcast_steps` too.
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
    /// Misbehaviour detection in the receive path (`[detection]`; off by default).
    pub detection: crate::DetectionParams,
    /// The platoon's maneuvers (`[maneuvers]`; none by default).
    pub maneuvers: Option<crate::ManeuverParams>,
    /// Signed V2V (`[security]`; none by default).
    pub security: Option<crate::SecurityParams>,
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
        if !self.law.is_paper() {
            self.law.validate()?;
            if !matches!(
                self.rule,
                TriggerRule::Periodic { .. } | TriggerRule::Cam(_)
            ) {
                return err(
                    "rule",
                    format!(
                        "the {} rule needs the paper's law (its estimators); law = \"{}\" \
                         beacons periodically (rule = \"periodic\" with period_s) or by \
                         ETSI's CAM rules (rule = \"cam\")",
                        self.rule.name(),
                        self.law.name()
                    ),
                );
            }
        } else if self.gain.iter().any(|g| !g.is_finite()) {
            return err("gain", "must be finite".into());
        }
        if matches!(self.law, crate::LawParams::Consensus(_))
            && self
                .maneuvers
                .as_ref()
                .is_some_and(|m| !m.leaves.is_empty() || m.merge.is_some() || m.split.is_some())
        {
            return err(
                "maneuvers",
                "the consensus law weighs its neighbours by vehicle for the whole run; a \
                 leave, a merge or a split needs a law on the predecessor and the leader (law = \
                 \"path_cacc\", \"ploeg\", \"flatbed\" or \"acc\")"
                    .into(),
            );
        }
        if self.law.is_paper() && (!pos(self.beta1) || !pos(self.beta2)) {
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
            TriggerRule::Cam(cam) => cam.validate()?,
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
            TriggerRule::Cam(_) => "cam",
            TriggerRule::Static => "static",
            TriggerRule::Dynamic { .. } => "dynamic",
            TriggerRule::Mixed { .. } => "mixed",
        }
    }
}

/// ETSI EN 302 637-2's CAM generation rules on a straight road: a new message when the
/// position moved more than `position_m` or the speed changed more than `speed_mps` since the
/// last one (the heading rule never fires), never sooner than `min_steps` after it nor later
/// than `max_steps`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CamRule {
    /// The shortest interval in steps (ETSI: 100 ms).
    pub min_steps: u32,
    /// The longest interval in steps (ETSI: 1 s).
    pub max_steps: u32,
    /// Displacement since the last message that triggers a new one (m; ETSI: 4).
    pub position_m: f64,
    /// Speed change since the last message that triggers a new one (m/s; ETSI: 0.5).
    pub speed_mps: f64,
}

impl CamRule {
    /// Whether a vehicle at `now`, which last sent `last` `since` steps ago, sends again.
    pub fn fires(
        &self,
        since: u64,
        now: &platoon_model::State,
        last: &platoon_model::State,
    ) -> bool {
        since >= u64::from(self.max_steps)
            || (since >= u64::from(self.min_steps)
                && ((now[0] - last[0]).abs() > self.position_m
                    || (now[1] - last[1]).abs() > self.speed_mps))
    }

    /// Checks ranges; the error names the config key (under `trigger.`).
    pub fn validate(&self) -> Result<(), ParamsError> {
        let err = |field, message| Err(ParamsError { field, message });
        if self.min_steps == 0 || self.max_steps < self.min_steps {
            return err(
                "min_interval_s",
                format!(
                    "needs 1 step <= min_interval_s <= max_interval_s (got {} and {} steps)",
                    self.min_steps, self.max_steps
                ),
            );
        }
        if !(self.position_m.is_finite() && self.position_m > 0.0) {
            return err(
                "position_m",
                format!("must be > 0 (got {})", self.position_m),
            );
        }
        if !(self.speed_mps.is_finite() && self.speed_mps > 0.0) {
            return err("speed_mps", format!("must be > 0 (got {})", self.speed_mps));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_model::State;

    const ETSI: CamRule = CamRule {
        min_steps: 10,
        max_steps: 100,
        position_m: 4.0,
        speed_mps: 0.5,
    };

    /// When a vehicle at constant speed `v` (m/s), sampled every 0.01 s, sends its CAMs.
    fn sends(v: f64, dv_per_step: f64, steps: u64) -> Vec<u64> {
        let mut last = (0, State::new(0.0, v, 0.0));
        let mut out = vec![0];
        for k in 1..steps {
            let now = State::new(v * k as f64 * 0.01, v + dv_per_step * k as f64, 0.0);
            if ETSI.fires(k - last.0, &now, &last.1) {
                out.push(k);
                last = (k, now);
            }
        }
        out
    }

    #[test]
    fn cams_follow_the_etsi_rules() {
        // 15 m/s: 4 m is passed after 27 steps (4.05 m).
        assert_eq!(sends(15.0, 0.0, 100), [0, 27, 54, 81]);
        // Standing still: every second.
        assert_eq!(sends(0.0, 0.0, 350), [0, 100, 200, 300]);
        // At 60 m/s the position rule would fire every 7 steps: never sooner than 100 ms.
        assert_eq!(sends(60.0, 0.0, 35), [0, 10, 20, 30]);
        // Slow, but the speed changes 0.5 m/s in 0.25 s: the speed rule.
        assert_eq!(sends(1.0, 0.02, 80), [0, 26, 52, 78]);
        assert!(ETSI.validate().is_ok());
        let bad = CamRule {
            min_steps: 20,
            ..ETSI
        };
        assert!(CamRule {
            max_steps: 10,
            ..bad
        }
        .validate()
        .is_err());
        assert!(CamRule {
            speed_mps: 0.0,
            ..ETSI
        }
        .validate()
        .is_err());
    }
}
