//! The LMI conditions of Han et al. (2024), on a real SDP solver (clarabel), with certificates
//! that anyone can re-check; and the DoS tolerance bounds (16).
//!
//! * [`theorem1_min_ratio`]: for a given gain K and decay c, the smallest `beta1 / beta2` for
//!   which LMI (13) holds, with the P that certifies it. For a fixed K the LMI is linear in
//!   (P, beta1/beta2), so this is an exact SDP (docs/paper-readings.md#R16).
//! * [`Certificate::verify`]: re-assembles (13) from a certificate's numbers and checks its
//!   eigenvalues, independently of the solver.
//! * [`closed_loop_spectrum`]: eigenvalues of `I_N kron A(tau) - H kron B(tau) K` over a tau range.
//! * [`dos_bounds`]: the bounds (16) on T2 and D2 (readings R20, R21).
//! * [`common_decay`]: a common quadratic Lyapunov function for sampled loops (a platoon
//!   formation's, at the ends of its lag range), with its decay rate.
//! * [`string_stability()`](fn@string_stability): whether spacing errors grow along a long platoon
//!   (see [`mod@string_stability`]).
//!
//! Readings of the paper (docs/paper-readings.md): `Tr(X)` is `He(X) = X + X^T` (R8);
//! u = -K q (R1); K is 1x3 (R2).
//! Pure: no I/O, clocks or threads.
#![warn(missing_docs)]

mod certificate;
mod condition;
mod decay;
mod design;
mod discrete;
mod error;
mod lmi;
mod mixed;
mod sdp;
mod spectrum;
pub mod string_stability;

pub use design::{design_theorem1, Design, DesignSpec};
pub use discrete::{cascade_decay, common_decay, Decay};
pub use sdp::SdpError;
pub use string_stability::{string_stability, StringStability, TauStringStability};

pub use certificate::{Certificate, Verdict};
pub use condition::{psi, psi_theorem1, Coupling, Lyapunov, Plant3, Plants};
pub use decay::{max_decay_within_ratio, theorem1_max_decay};
pub use error::LmiError;
pub use lmi::{min_ratio, theorem1_min_ratio, Feasibility, LyapunovForm, P_MAX};
pub use mixed::{check_mixed, mixed_max_real, MixedCheck, MIXED_MAX_FREE};
pub use spectrum::{closed_loop_spectrum, growth_rate, Spectrum};

/// The bounds (16): the smallest T2 and D2 for which Assumption 2 guarantees stability, given
/// the decay `varsigma1`, the growth `varsigma2` under attack, the chosen `varsigma_star` in
/// (0, varsigma1), the gain scheduler `phi` and the resilient period `h`:
/// `T2 > (2 ln phi + (varsigma1 + varsigma2) h) / varsigma_star` and
/// `D2 > (varsigma1 + varsigma2) / (varsigma1 - varsigma_star)` (reading R21).
pub fn dos_bounds(
    varsigma1: f64,
    varsigma2: f64,
    varsigma_star: f64,
    phi: f64,
    h: f64,
) -> Result<(f64, f64), LmiError> {
    if !(varsigma1 > 0.0 && varsigma_star > 0.0 && varsigma_star < varsigma1) {
        return Err(LmiError::Bad(format!(
            "the bounds need 0 < varsigma* < varsigma1 (got varsigma* = {varsigma_star}, varsigma1 = {varsigma1})"
        )));
    }
    if !(varsigma2 >= 0.0 && phi >= 1.0 && h >= 0.0) {
        return Err(LmiError::Bad(format!(
            "the bounds need varsigma2 >= 0, phi >= 1 and h >= 0 (got {varsigma2}, {phi}, {h})"
        )));
    }
    let t2 = (2.0 * phi.ln() + (varsigma1 + varsigma2) * h) / varsigma_star;
    let d2 = (varsigma1 + varsigma2) / (varsigma1 - varsigma_star);
    Ok((t2, d2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_reproduce_the_papers_figures() {
        // Section IV: varsigma1 = 0.41, varsigma2 = 0.27, varsigma* = 0.35, phi = 5.2, h = 0.02.
        let (t2, d2) = dos_bounds(0.41, 0.27, 0.35, 5.2, 0.02).unwrap();
        assert_eq!(format!("{t2:.2}"), "9.46");
        assert_eq!(format!("{d2:.2}"), "11.33");
    }

    #[test]
    fn bounds_refuse_a_star_above_the_decay() {
        assert!(dos_bounds(0.3, 0.27, 0.35, 5.2, 0.02).is_err());
    }
}
