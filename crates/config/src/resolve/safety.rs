//! `[safety]`: the deceleration thresholds that class a run's safety.
use super::checks::{bad, positive};
use crate::error::KeyError;
use crate::schema::SafetyConfig;
use platoon_sim::SafetyThresholds;

/// Positive thresholds, none <= negligible <= benign.
pub(crate) fn thresholds(sf: &SafetyConfig) -> Result<SafetyThresholds, KeyError> {
    positive("safety.none_decel_mps2", sf.none_decel_mps2)?;
    // positive() has ruled out NaN, so < is the negation of >=.
    if positive("safety.negligible_decel_mps2", sf.negligible_decel_mps2)? < sf.none_decel_mps2 {
        return bad("safety.negligible_decel_mps2", "must be >= none_decel_mps2");
    }
    if positive("safety.benign_decel_mps2", sf.benign_decel_mps2)? < sf.negligible_decel_mps2 {
        return bad(
            "safety.benign_decel_mps2",
            "must be >= negligible_decel_mps2",
        );
    }
    Ok(SafetyThresholds {
        none: sf.none_decel_mps2,
        negligible: sf.negligible_decel_mps2,
        benign: sf.benign_decel_mps2,
    })
}
