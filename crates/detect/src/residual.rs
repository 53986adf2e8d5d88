//! The model-based residual: how far a claim is from where the sender's last accepted packet
//! says it can be, in the metric of the uncertainty of that prediction.

use crate::{check, predict, Detector, Observation, ParamError, Verdict};
use nalgebra::{Matrix3, Vector3};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// The detector's name and `kind`.
pub(crate) const NAME: &str = "residual";

/// `[detection.residual]`: the false-alarm rate and the noise model. Every key is optional.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct ResidualParams {
    /// The false-alarm rate per packet the threshold is set for (default 1e-3): the threshold is
    /// the chi-square(3) quantile at `1 - alpha`. In (0, 0.5].
    pub alpha: f64,
    /// Spectral density `q` of the white jerk that drives the process noise (m^2/s^5; default
    /// 5). A jerk `j(t)` the model does not know adds at most `∫ j^2 dt / q` to the statistic
    /// over the interval between two packets: a constant 10 m/s^3 over the longest interval of
    /// an event-triggered sender of the paper, 0.3 s, adds 6; the lag of the paper's power train
    /// (tau >= 0.34 s) turns a command step of 2 m/s^2 into at most `2^2 / (2 tau q)` = 1.2.
    /// Both stay under the threshold for alpha = 1e-3, 16.27. > 0.
    pub jerk_psd: f64,
    /// Standard deviation of a claimed position's error (m; default 0.1). > 0.
    pub sigma_p_m: f64,
    /// Standard deviation of a claimed speed's error (m/s; default 0.1). > 0.
    pub sigma_v_mps: f64,
    /// Standard deviation of a claimed acceleration's error (m/s^2; default 0.6). It also
    /// covers a jump in acceleration the white jerk cannot: the paper's leader switches between
    /// 0 and ±2 m/s^2 at once, which adds at most `(2 / 0.6)^2` = 11 to the statistic. > 0.
    pub sigma_a_mps2: f64,
}

impl Default for ResidualParams {
    fn default() -> Self {
        Self {
            alpha: 1e-3,
            jerk_psd: 5.0,
            sigma_p_m: 0.1,
            sigma_v_mps: 0.1,
            sigma_a_mps2: 0.6,
        }
    }
}

impl ResidualParams {
    /// Checks every field; the error names the field at fault.
    pub fn validate(&self) -> Result<(), ParamError> {
        let p = self;
        check(
            NAME,
            "alpha",
            p.alpha,
            p.alpha > 0.0 && p.alpha <= 0.5,
            "must be in (0, 0.5]",
        )?;
        check(
            NAME,
            "jerk_psd",
            p.jerk_psd,
            p.jerk_psd > 0.0,
            "must be > 0",
        )?;
        check(
            NAME,
            "sigma_p_m",
            p.sigma_p_m,
            p.sigma_p_m > 0.0,
            "must be > 0",
        )?;
        check(
            NAME,
            "sigma_v_mps",
            p.sigma_v_mps,
            p.sigma_v_mps > 0.0,
            "must be > 0",
        )?;
        check(
            NAME,
            "sigma_a_mps2",
            p.sigma_a_mps2,
            p.sigma_a_mps2 > 0.0,
            "must be > 0",
        )?;
        Ok(())
    }

    /// The threshold of the statistic: the chi-square(3) quantile at `1 - alpha` (16.27 for
    /// the default 1e-3).
    pub fn threshold(&self) -> f64 {
        chi2_3_quantile(1.0 - self.alpha)
    }
}

/// The chi-square quantile with 3 degrees of freedom at probability `p` in (0, 1).
fn chi2_3_quantile(p: f64) -> f64 {
    match ChiSquared::new(3.0) {
        Ok(chi2) => chi2.inverse_cdf(p),
        // 3 degrees of freedom are always valid.
        Err(_) => f64::NAN,
    }
}

/// The residual test. From the last accepted packet `x = [p, v, a]` at step `s`, the claim of
/// step `k'` (its [`platoon_v2v::Packet::step`]) is predicted at constant acceleration over
/// `T = (k' - s) dt`, `x̂ = F x` with `F = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]]`; the innovation
/// `e = claim - x̂` has the covariance
///
/// ```text
/// S = F R F' + Q(T) + R,   R = diag(sigma_p^2, sigma_v^2, sigma_a^2),
/// Q(T) = q [[T^5/20, T^4/8, T^3/6], [T^4/8, T^3/3, T^2/2], [T^3/6, T^2/2, T]]
/// ```
///
/// (measurement noise on both packets, white jerk of density `q` in between). The score is
/// `e' S^-1 e`, chi-square with 3 degrees of freedom for a sender that moves as the model says;
/// flagged above [`ResidualParams::threshold`]. No earlier packet: not flagged, score NaN. A
/// packet not newer than the last is compared with it as if at the same step (the packet
/// checks refuse those). Stateless: the caller's `last` is the memory.
#[derive(Debug, Clone)]
pub struct Residual {
    params: ResidualParams,
    threshold: f64,
}

impl Residual {
    /// The test with these parameters, checked.
    pub fn new(params: ResidualParams) -> Result<Self, ParamError> {
        params.validate()?;
        let threshold = params.threshold();
        check(
            NAME,
            "alpha",
            params.alpha,
            threshold.is_finite() && threshold > 0.0,
            "gives no finite chi-square quantile",
        )?;
        Ok(Self { params, threshold })
    }

    /// Its parameters.
    pub fn params(&self) -> &ResidualParams {
        &self.params
    }

    /// The threshold of the statistic (the chi-square(3) quantile at `1 - alpha`).
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// The statistic `e' S^-1 e` of a claim against the last accepted state `T` seconds
    /// earlier (NaN when it cannot be computed: a non-finite input).
    pub fn statistic(&self, last: &Vector3<f64>, claim: &Vector3<f64>, t: f64) -> f64 {
        let p = &self.params;
        let e = claim - predict(last, t);
        #[rustfmt::skip]
        let f = Matrix3::new(
            1.0, t,   0.5 * t * t,
            0.0, 1.0, t,
            0.0, 0.0, 1.0,
        );
        let r = Matrix3::from_diagonal(&Vector3::new(
            p.sigma_p_m.powi(2),
            p.sigma_v_mps.powi(2),
            p.sigma_a_mps2.powi(2),
        ));
        let (t2, t3) = (t * t, t * t * t);
        let (t4, t5) = (t3 * t, t3 * t2);
        #[rustfmt::skip]
        let q = Matrix3::new(
            t5 / 20.0, t4 / 8.0, t3 / 6.0,
            t4 / 8.0,  t3 / 3.0, t2 / 2.0,
            t3 / 6.0,  t2 / 2.0, t,
        ) * p.jerk_psd;
        let s = f * r * f.transpose() + q + r;
        match s.cholesky() {
            Some(c) => e.dot(&c.solve(&e)),
            None => f64::NAN,
        }
    }
}

impl Detector for Residual {
    fn name(&self) -> &'static str {
        NAME
    }

    /// Nothing to test before a first accepted packet from the sender.
    fn inspect(&mut self, obs: &Observation) -> Verdict {
        obs.last.map_or(Verdict::NOT_TESTED, |last| {
            let t = obs.packet.step.saturating_sub(last.step) as f64 * obs.dt;
            Verdict::above(
                self.statistic(&last.state, &obs.packet.state, t),
                self.threshold,
            )
        })
    }
}
