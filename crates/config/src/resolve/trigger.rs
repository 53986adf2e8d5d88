//! `[trigger]`: when a follower broadcasts, how often that is checked, and the resilient
//! mechanism.
use super::checks::{finite, steps_of};
use crate::error::KeyError;
use crate::schema::{RuleConfig, Trigger};
use platoon_control::{CamRule, TriggerRule};

/// `[trigger]` on a step of `dt`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Triggering {
    /// The rule.
    pub rule: TriggerRule,
    /// Whether the resilient mechanism (11) wraps it.
    pub resilient: bool,
    /// The resilient mechanism's sampling period `h` in steps.
    pub h_steps: u32,
    /// How often the rule is checked, in steps.
    pub check_steps: u32,
}

/// The check period `[trigger]` means: `check_period_s`, or the step.
pub(crate) fn check_period(t: &Trigger, dt: f64) -> f64 {
    t.check_period_s.unwrap_or(dt)
}

/// `[trigger]` on a step of `dt`: every period a whole number of steps.
pub(crate) fn triggering(t: &Trigger, dt: f64) -> Result<Triggering, KeyError> {
    let check_steps = steps_of("trigger.check_period_s", check_period(t, dt), dt)?;
    let h_steps = steps_of("trigger.h_s", t.h_s, dt)?;
    Ok(Triggering {
        rule: rule(&t.rule, dt)?,
        resilient: t.resilient,
        h_steps,
        check_steps,
    })
}

/// `[trigger] rule` and its keys.
fn rule(r: &RuleConfig, dt: f64) -> Result<TriggerRule, KeyError> {
    Ok(match *r {
        RuleConfig::Dynamic {
            phi,
            rho,
            eta,
            theta0,
        } => TriggerRule::Dynamic {
            phi: finite("trigger.phi", phi)?,
            rho: finite("trigger.rho", rho)?,
            eta: finite("trigger.eta", eta)?,
            theta0: finite("trigger.theta0", theta0)?,
        },
        RuleConfig::Static {} => TriggerRule::Static,
        RuleConfig::Mixed { mu, alpha } => TriggerRule::Mixed {
            mu: finite("trigger.mu", mu)?,
            alpha: finite("trigger.alpha", alpha)?,
        },
        RuleConfig::Cam {
            min_interval_s,
            max_interval_s,
            position_m,
            speed_mps,
        } => TriggerRule::Cam(CamRule {
            min_steps: steps_of(
                "trigger.min_interval_s",
                finite("trigger.min_interval_s", min_interval_s)?,
                dt,
            )?,
            max_steps: steps_of(
                "trigger.max_interval_s",
                finite("trigger.max_interval_s", max_interval_s)?,
                dt,
            )?,
            position_m: finite("trigger.position_m", position_m)?,
            speed_mps: finite("trigger.speed_mps", speed_mps)?,
        }),
        RuleConfig::Periodic { period_s } => TriggerRule::Periodic {
            period_steps: steps_of(
                "trigger.period_s",
                finite("trigger.period_s", period_s)?,
                dt,
            )?,
        },
    })
}
