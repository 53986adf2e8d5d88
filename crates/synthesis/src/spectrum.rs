//! Closed-loop spectra over a range of engine lags, and the growth rate with the controls off.
use crate::condition::{kron, Coupling, Plant3};
use nalgebra::{DMatrix, Matrix3, RowVector3};
use serde::Serialize;

/// The growth rate of `V = e^T (I kron P) e` with the controls off (during attacks):
/// the smallest varsigma2 with `A^T P + P A <= varsigma2 P` (reading R20), i.e. the largest
/// eigenvalue of `P^-1/2 (A^T P + P A) P^-1/2`.
pub fn growth_rate(p: &Matrix3<f64>, tau: f64) -> f64 {
    let a = Plant3::new(tau).a;
    let eig = p.symmetric_eigen();
    let inv_sqrt = eig.eigenvectors
        * Matrix3::from_diagonal(&eig.eigenvalues.map(|x| 1.0 / x.sqrt()))
        * eig.eigenvectors.transpose();
    let m = inv_sqrt * (a.transpose() * p + p * a) * inv_sqrt;
    m.symmetric_eigenvalues().max()
}

/// Eigenvalues of the closed loop `I_N kron A(tau) - (I_N kron B(tau) K) M` at each tau
/// (`M = H kron I3` with constant spacing, see [`Coupling`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spectrum {
    /// tau (s).
    pub tau: f64,
    /// The largest real part of an eigenvalue (negative: stable).
    pub max_real: f64,
    /// The largest modulus (how fast the closed loop is; compare with 1 / dt).
    pub max_modulus: f64,
}

/// The closed-loop spectrum of gain `k` with coupling `g` at each of `taus`.
pub fn closed_loop_spectrum(k: [f64; 3], g: &Coupling, taus: &[f64]) -> Vec<Spectrum> {
    let n = g.followers();
    let kr = RowVector3::from(k);
    let mc = g.matrix();
    taus.iter()
        .map(|&tau| {
            let pl = Plant3::new(tau);
            let a = DMatrix::from_iterator(3, 3, pl.a.iter().copied());
            let bk = DMatrix::from_iterator(3, 3, (pl.b * kr).iter().copied());
            let acl =
                kron(&DMatrix::identity(n, n), &a) - kron(&DMatrix::identity(n, n), &bk) * &mc;
            let eig = acl.complex_eigenvalues();
            Spectrum {
                tau,
                max_real: eig.iter().map(|z| z.re).fold(f64::NEG_INFINITY, f64::max),
                max_modulus: eig.iter().map(|z| z.norm()).fold(0.0, f64::max),
            }
        })
        .collect()
}
