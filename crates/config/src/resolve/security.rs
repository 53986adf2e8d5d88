//! `[security]`: signed V2V (docs/security.md).
use super::checks::{bad, finite, positive};
use crate::error::KeyError;
use crate::schema::{SecurityConfig, SecurityPolicyConfig};
use platoon_control::{SecurityParams, SecurityPolicy};

/// `[security]` as the controllers' settings (none when absent): positive periods, whole
/// milliseconds.
pub(crate) fn security(s: Option<&SecurityConfig>) -> Result<Option<SecurityParams>, KeyError> {
    let Some(s) = s else {
        return Ok(None);
    };
    let ms = |key: &str, x: f64, zero: bool| -> Result<u64, KeyError> {
        let x = if zero {
            finite(key, x)?
        } else {
            positive(key, x)?
        };
        if x < 0.0 {
            return bad(key, "must be >= 0");
        }
        let v = x * 1e3;
        if (v - v.round()).abs() > 1e-6 * v.max(1.0) || v > 1e15 {
            return bad(
                key,
                format!("must be a whole number of milliseconds (got {x} s)"),
            );
        }
        Ok(v.round() as u64)
    };
    Ok(Some(SecurityParams {
        policy: match s.policy {
            SecurityPolicyConfig::Every => SecurityPolicy::Every,
            SecurityPolicyConfig::OnDemand => SecurityPolicy::OnDemand,
        },
        certificate_period_ms: ms(
            "security.certificate_period_s",
            s.certificate_period_s,
            false,
        )?,
        pseudonym_change_ms: ms("security.pseudonym_change_s", s.pseudonym_change_s, true)?,
        freshness_ms: ms("security.freshness_s", s.freshness_s, false)?,
        seed: s.seed,
        // Scenario::replica gives each platoon of a fleet its own.
        platoon: 0,
    }))
}
