//! The predecessor's claim against the follower's own radar: the one measurement in a platoon
//! that an attacker on the radio cannot touch.

use crate::{check, Detector, Observation, ParamError, Verdict};

/// The detector's name and `kind`.
pub(crate) const NAME: &str = "radar_cross";

/// `[detection.radar_cross]`: the noise of the difference between claim and radar, and how many
/// standard deviations flag it. Every key is optional.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct RadarCrossParams {
    /// Standard deviation of the position difference (m; default 0.05, the gap noise of the
    /// controllers' radar model, `platoon_control::fallback::RadarParams`). Add the sender's
    /// position error when its claims are noisy (in quadrature). > 0.
    pub sigma_p_m: f64,
    /// Standard deviation of the speed difference (m/s; default 0.05, the radar model's
    /// closing-speed noise). > 0.
    pub sigma_v_mps: f64,
    /// Flagged beyond this many standard deviations in position or speed (default 4: a false
    /// alarm rate of about 1.3e-4 per packet for Gaussian noise). > 0.
    pub k_sigma: f64,
}

impl Default for RadarCrossParams {
    fn default() -> Self {
        Self {
            sigma_p_m: 0.05,
            sigma_v_mps: 0.05,
            k_sigma: 4.0,
        }
    }
}

impl RadarCrossParams {
    /// Checks every field; the error names the field at fault.
    pub fn validate(&self) -> Result<(), ParamError> {
        check(
            NAME,
            "sigma_p_m",
            self.sigma_p_m,
            self.sigma_p_m > 0.0,
            "must be > 0",
        )?;
        check(
            NAME,
            "sigma_v_mps",
            self.sigma_v_mps,
            self.sigma_v_mps > 0.0,
            "must be > 0",
        )?;
        check(
            NAME,
            "k_sigma",
            self.k_sigma,
            self.k_sigma > 0.0,
            "must be > 0",
        )?;
        Ok(())
    }
}

/// The radar cross-check. With a radar reading (the caller gives one only for the predecessor,
/// when the radar sees it), the claim brought forward to the receive step
/// ([`Observation::claim_now`]) is compared with what the radar says of the vehicle ahead:
///
/// ```text
/// p_radar = p_own + gap + length - closing age           (gap' = -closing)
/// v_radar = v_own - closing - (a_own - a_claimed) age    (closing' = a_own - a_ahead)
/// ```
///
/// with `age` the reading's [`crate::RadarReading::age_s`]. The score is the larger of
/// `|p_claim - p_radar| / sigma_p_m` and `|v_claim - v_radar| / sigma_v_mps`; flagged above
/// `k_sigma`. No radar reading: not flagged, score NaN (nothing tested). Stateless.
#[derive(Debug, Clone)]
pub struct RadarCross {
    params: RadarCrossParams,
}

impl RadarCross {
    /// The cross-check with these parameters, checked.
    pub fn new(params: RadarCrossParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { params })
    }

    /// Its parameters.
    pub fn params(&self) -> &RadarCrossParams {
        &self.params
    }
}

impl Detector for RadarCross {
    fn name(&self) -> &'static str {
        NAME
    }

    fn inspect(&mut self, obs: &Observation) -> Verdict {
        let Some(r) = obs.radar else {
            return Verdict::NOT_TESTED;
        };
        let p = &self.params;
        let claim = obs.claim_now();
        // The reading brought forward to this step: the receiver's own motion is known, the
        // vehicle ahead's acceleration is the claim's.
        let p_radar = obs.own[0] + r.gap_m + r.vehicle_length_m - r.closing_mps * r.age_s;
        let v_radar = obs.own[1] - r.closing_mps - (obs.own[2] - claim[2]) * r.age_s;
        let zp = ((claim[0] - p_radar) / p.sigma_p_m).abs();
        let zv = ((claim[1] - v_radar) / p.sigma_v_mps).abs();
        // f64::max drops a NaN: keep it, so that a non-finite input is flagged.
        let z = if zp.is_nan() || zv.is_nan() {
            f64::NAN
        } else {
            zp.max(zv)
        };
        Verdict::above(z, p.k_sigma)
    }
}
