//! Theorem 1's certificates as `certificate.json` holds them, and their re-check independent
//! of the solver.
use crate::condition::{psi, Coupling, Lyapunov, Plant3, Plants};
use crate::error::LmiError;
use nalgebra::{DMatrix, Matrix3, RowVector3};
use serde::{Deserialize, Serialize};

/// Everything needed to re-check Theorem 1 for one design, as `certificate.json` holds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Certificate {
    /// Which condition: "theorem1" (one tau) or "theorem2" ((13) at both ends of the 1/tau
    /// range with one P: since (13) is affine in 1/tau, it then holds for every tau between,
    /// even time-varying; our reading of Theorem 2, docs/paper-readings.md#R18).
    pub condition: String,
    /// The gain K (u = -K q).
    pub k: [f64; 3],
    /// The decay parameter c.
    pub c: f64,
    /// beta1 / beta2.
    pub ratio: f64,
    /// P (row-major 3x3), positive definite: the common Lyapunov matrix (`I_N kron P`), or
    /// `P_1` of a block-diagonal certificate.
    pub p: [[f64; 3]; 3],
    /// A block-diagonal Lyapunov matrix `diag(P_1, ..., P_N)`, one 3x3 block per follower
    /// (`V = sum_i e_i^T P_i e_i`), in place of `I_N kron P`; absent for a common P.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p_blocks: Option<Vec<[[f64; 3]; 3]>>,
    /// H = L + diag(pinning), row-major N x N.
    pub h: Vec<Vec<f64>>,
    /// The time headway of the spacing policy (s) the condition was imposed with; absent (0)
    /// for constant spacing.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub headway: f64,
    /// The taus at which (13) is imposed (s): the nominal one, or the ends of the range.
    pub taus: Vec<f64>,
    /// The largest eigenvalue of (13) when issued (negative).
    pub max_eigenvalue: f64,
    /// The smallest eigenvalue of P when issued (positive).
    pub p_min_eigenvalue: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// P, K and the coupling of a certificate.
type Parts = (Matrix3<f64>, RowVector3<f64>, Coupling);

/// The result of re-checking a certificate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// (13) is negative definite and P positive definite.
    pub holds: bool,
    /// Largest eigenvalue of (13): the margin is its negative.
    pub max_eigenvalue: f64,
    /// Smallest eigenvalue of P (of every block).
    pub p_min_eigenvalue: f64,
    /// `sqrt(lambda_max / lambda_min)` of the whole Lyapunov matrix: how much the tracking
    /// error may grow before it decays (`|e(t)| <= growth e^(-c t / 2 ...) |e(0)|`), the price of
    /// a certificate whose blocks differ.
    pub transient_growth: f64,
}

impl Certificate {
    fn parts(&self) -> Result<Parts, LmiError> {
        let n = self.h.len();
        if n == 0 || self.h.iter().any(|row| row.len() != n) {
            return Err(LmiError::Bad("h must be a non-empty square matrix".into()));
        }
        let finite = self
            .p
            .iter()
            .flatten()
            .chain(&self.k)
            .all(|x| x.is_finite())
            && self.h.iter().flatten().all(|x| x.is_finite())
            && self.ratio.is_finite()
            && self.headway.is_finite()
            && self.headway >= 0.0
            && self.c.is_finite()
            && !self.taus.is_empty()
            && self.taus.iter().all(|t| t.is_finite() && *t > 0.0);
        if !finite {
            return Err(LmiError::Bad(
                "every number of a certificate must be finite (at least one tau > 0, headway >= 0)"
                    .into(),
            ));
        }
        let p = Matrix3::from_fn(|i, j| self.p[i][j]);
        let h = DMatrix::from_fn(n, n, |i, j| self.h[i][j]);
        Ok((
            p,
            RowVector3::from(self.k),
            Coupling::time_headway(h, self.headway),
        ))
    }

    /// The Lyapunov blocks as issued: the common P alone, or one per follower (checked for
    /// number and finiteness).
    fn blocks(&self, p: Matrix3<f64>, n: usize) -> Result<Vec<Matrix3<f64>>, LmiError> {
        match &self.p_blocks {
            None => Ok(vec![p]),
            Some(b) => {
                if b.len() != n || b.iter().flatten().flatten().any(|x| !x.is_finite()) {
                    return Err(LmiError::Bad(format!(
                        "p_blocks must hold one finite 3x3 block per follower ({n})"
                    )));
                }
                Ok(b.iter().map(|m| Matrix3::from_fn(|i, j| m[i][j])).collect())
            }
        }
    }

    /// [`Verdict::transient_growth`] alone, from the blocks' eigenvalues (no (13) to assemble).
    pub fn transient_growth(&self) -> Result<f64, LmiError> {
        let (p, _, g) = self.parts()?;
        let (lo, hi) = eigen_range(&symmetrised(&self.blocks(p, g.followers())?));
        Ok((hi / lo).sqrt())
    }

    /// Re-assembles (13) from the certificate's numbers and checks its eigenvalues.
    pub fn verify(&self) -> Result<Verdict, LmiError> {
        let (p, k, g) = self.parts()?;
        let n = g.followers();
        let mc = g.matrix();
        let raw = self.blocks(p, n)?;
        let symmetric = raw.iter().all(|b| (b - b.transpose()).amax() < 1e-9);
        let blocks = symmetrised(&raw);
        let x = (blocks.len() > 1).then(|| {
            let mut x = DMatrix::zeros(3 * n, 3 * n);
            for (i, b) in blocks.iter().enumerate() {
                x.view_mut((3 * i, 3 * i), (3, 3)).copy_from(b);
            }
            x
        });
        let max_eigenvalue = self
            .taus
            .iter()
            .map(|&tau| {
                let plant = Plant3::new(tau);
                match &x {
                    None => psi(
                        Lyapunov::Common(&blocks[0]),
                        self.ratio,
                        self.c,
                        &k,
                        &mc,
                        Plants::Same(&plant),
                    ),
                    Some(x) => psi(
                        Lyapunov::Full(x),
                        self.ratio,
                        self.c,
                        &k,
                        &mc,
                        Plants::Same(&plant),
                    ),
                }
                .symmetric_eigenvalues()
                .max()
            })
            .fold(f64::NEG_INFINITY, f64::max);
        let (p_min_eigenvalue, p_max_eigenvalue) = eigen_range(&blocks);
        Ok(Verdict {
            holds: max_eigenvalue < 0.0 && p_min_eigenvalue > 0.0 && symmetric,
            max_eigenvalue,
            p_min_eigenvalue,
            transient_growth: (p_max_eigenvalue / p_min_eigenvalue).sqrt(),
        })
    }
}

/// `(B + B^T) / 2` of each block.
fn symmetrised(blocks: &[Matrix3<f64>]) -> Vec<Matrix3<f64>> {
    blocks.iter().map(|b| (b + b.transpose()) * 0.5).collect()
}

/// The smallest and largest eigenvalue over symmetric blocks.
fn eigen_range(blocks: &[Matrix3<f64>]) -> (f64, f64) {
    blocks
        .iter()
        .flat_map(|b| {
            b.symmetric_eigenvalues()
                .iter()
                .copied()
                .collect::<Vec<_>>()
        })
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), e| {
            (lo.min(e), hi.max(e))
        })
}
