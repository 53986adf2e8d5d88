//! A platoon whose followers have different engine lags (a truck among cars): the closed loop
//! `e' = diag(A(tau_i)) e - diag(B(tau_i) K) M (e + eps)` is not the paper's Kronecker form, so
//! (13) at common taus does not cover it. (13) with a common `I_N kron P`, written with each
//! follower's own `A(tau_i)` and `B(tau_i)`, is affine in each `1/tau_i` separately; so it holds
//! for every combination of lags in the box `prod_i [lo_i, hi_i]` (time-varying too) exactly
//! when it holds at the box's `2^N` vertices, which [`check_mixed`] evaluates.
use crate::certificate::Certificate;
use crate::condition::{psi, Coupling, Lyapunov, Plant3, Plants};
use crate::error::LmiError;
use crate::lmi::P_MAX;
use crate::sdp::{dm, solve, sym_basis3, Lmi};
use nalgebra::{DMatrix, Matrix3, RowVector3};
use serde::Serialize;

/// Followers whose lag ranges are more than a point, at most: `2^MIXED_MAX_FREE` vertices.
pub const MIXED_MAX_FREE: usize = 12;

/// The largest real part of an eigenvalue of the closed loop with followers of lags `taus`.
pub fn mixed_max_real(k: [f64; 3], g: &Coupling, taus: &[f64]) -> f64 {
    let mc = g.matrix();
    let m = mc.nrows();
    let kr = RowVector3::from(k);
    let mut acl = DMatrix::<f64>::zeros(m, m);
    for (i, &tau) in taus.iter().enumerate() {
        let plant = Plant3::new(tau);
        acl.view_mut((3 * i, 3 * i), (3, 3)).copy_from(&plant.a);
        let bk = DMatrix::from_iterator(3, 3, (plant.b * kr).iter().copied());
        let rows = acl.view((3 * i, 0), (3, m)) - bk * mc.view((3 * i, 0), (3, m));
        acl.view_mut((3 * i, 0), (3, m)).copy_from(&rows);
    }
    acl.complex_eigenvalues()
        .iter()
        .map(|z| z.re)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// What [`check_mixed`] found over the vertices of the followers' lag box.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MixedCheck {
    /// Each follower's lag range `(lo, hi)` (s).
    pub tau_ranges: Vec<(f64, f64)>,
    /// The vertices evaluated (every combination of the ends of the ranges).
    pub vertices: usize,
    /// The largest real part of a closed-loop eigenvalue at any vertex (negative: every
    /// vertex's closed loop is stable; between vertices, see `certified`).
    pub worst_max_real: f64,
    /// The largest eigenvalue of (13) with the certificate's common P, ratio and c at any
    /// vertex; `None` without a common-P certificate.
    pub max_eigenvalue: Option<f64>,
    /// (13) holds at every vertex with the certificate's P: by affinity in each `1/tau_i`, the
    /// heterogeneous closed loop is certified for every lag in the box, time-varying too.
    pub certified: bool,
    /// The direct SDP: the smallest beta1/beta2 for which (13) holds at every vertex with a
    /// block-diagonal Lyapunov matrix of its own, one P per follower (`None`: infeasible for
    /// this gain and c).
    pub direct_min_ratio: Option<f64>,
    /// The largest eigenvalue of (13) at any vertex with the direct SDP's Lyapunov matrix and
    /// ratio, re-checked independently of the solver (negative: it holds, and by affinity for
    /// every lag in the box).
    pub direct_max_eigenvalue: Option<f64>,
    /// `sqrt(lambda_max / lambda_min)` of the direct SDP's Lyapunov matrix: how far the
    /// tracking error may grow before it decays.
    pub direct_transient_growth: Option<f64>,
}

/// Every vertex of the box `ranges`: each follower's lag at one end of its range.
fn vertices(ranges: &[(f64, f64)]) -> Vec<Vec<f64>> {
    let free: Vec<usize> = (0..ranges.len())
        .filter(|&i| ranges[i].1 > ranges[i].0)
        .collect();
    (0..1usize << free.len())
        .map(|v| {
            let mut taus: Vec<f64> = ranges.iter().map(|r| r.0).collect();
            for (b, &i) in free.iter().enumerate() {
                if v >> b & 1 == 1 {
                    taus[i] = ranges[i].1;
                }
            }
            taus
        })
        .collect()
}

/// The largest eigenvalue of (13) over `vertices` with `P`, ratio `r` and decay `c`.
fn worst_psi(
    p: &Matrix3<f64>,
    r: f64,
    c: f64,
    k: &RowVector3<f64>,
    mc: &DMatrix<f64>,
    vertices: &[Vec<f64>],
) -> f64 {
    vertices
        .iter()
        .map(|taus| {
            let psi = psi(Lyapunov::Common(p), r, c, k, mc, Plants::PerFollower(taus));
            ((&psi + psi.transpose()) * 0.5)
                .symmetric_eigenvalues()
                .max()
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// The direct SDP over the vertices: the smallest ratio `r` and a block-diagonal Lyapunov
/// matrix `diag(P_1, ..., P_N)` (`delta I <= P_i <= P_MAX I`, one P per follower, which the
/// heterogeneous platoon needs: one common P is infeasible for the shipped truck-car platoon)
/// with (13) `<= -delta I` at every vertex.
fn min_ratio_vertices(
    k: &RowVector3<f64>,
    c: f64,
    mc: &DMatrix<f64>,
    vertices: &[Vec<f64>],
    delta: f64,
) -> Result<Option<(f64, DMatrix<f64>)>, LmiError> {
    let basis = sym_basis3();
    let m = mc.nrows();
    let n = m / 3;
    let size = 3 * m;
    let zero = DMatrix::<f64>::zeros(m, m);
    let unit = |i: usize, e: &Matrix3<f64>| {
        let mut x = DMatrix::<f64>::zeros(m, m);
        x.view_mut((3 * i, 3 * i), (3, 3)).copy_from(e);
        x
    };
    let mut lmis = Vec::new();
    for taus in vertices {
        let psi0 = psi(
            Lyapunov::Full(&zero),
            0.0,
            c,
            k,
            mc,
            Plants::PerFollower(taus),
        );
        let mut fi: Vec<DMatrix<f64>> = Vec::with_capacity(6 * n + 1);
        for i in 0..n {
            for e in &basis {
                fi.push(
                    psi(
                        Lyapunov::Full(&unit(i, e)),
                        0.0,
                        c,
                        k,
                        mc,
                        Plants::PerFollower(taus),
                    ) - &psi0,
                );
            }
        }
        fi.push(
            psi(
                Lyapunov::Full(&zero),
                1.0,
                c,
                k,
                mc,
                Plants::PerFollower(taus),
            ) - &psi0,
        );
        lmis.push(Lmi::nsd(
            &(psi0 + DMatrix::<f64>::identity(size, size) * delta),
            &fi,
        ));
    }
    let nvar = 6 * n + 1;
    for i in 0..n {
        let block = |sign: f64| -> Vec<DMatrix<f64>> {
            (0..nvar)
                .map(|v| {
                    if v < 6 * n && v / 6 == i {
                        dm(&basis[v % 6]) * sign
                    } else {
                        DMatrix::zeros(3, 3)
                    }
                })
                .collect()
        };
        lmis.push(Lmi::nsd(
            &(DMatrix::<f64>::identity(3, 3) * delta),
            &block(-1.0),
        ));
        lmis.push(Lmi::nsd(
            &(DMatrix::<f64>::identity(3, 3) * -P_MAX),
            &block(1.0),
        ));
    }
    let mut cost = vec![0.0; nvar];
    cost[nvar - 1] = 1.0;
    let Some(x) = solve(&lmis, &[], &cost)? else {
        return Ok(None);
    };
    let mut lyapunov = DMatrix::<f64>::zeros(m, m);
    for i in 0..n {
        let mut p = Matrix3::zeros();
        for (e, &v) in basis.iter().zip(&x[6 * i..6 * i + 6]) {
            p += e * v;
        }
        lyapunov.view_mut((3 * i, 3 * i), (3, 3)).copy_from(&p);
    }
    Ok(Some((x[nvar - 1], lyapunov)))
}

/// Evaluates gain `k` with coupling `g` on followers whose lags lie in `ranges` (one per
/// follower): the closed-loop spectrum at every vertex of the box, (13) there with a common-P
/// `certificate`'s P, ratio and c, and the direct SDP at decay `c` (margin 1e-6). `None` when
/// more than [`MIXED_MAX_FREE`] ranges are more than a point.
pub fn check_mixed(
    k: [f64; 3],
    c: f64,
    g: &Coupling,
    ranges: &[(f64, f64)],
    certificate: Option<&Certificate>,
) -> Result<Option<MixedCheck>, LmiError> {
    let n = g.followers();
    if ranges.len() != n || ranges.iter().any(|&(lo, hi)| !(lo > 0.0 && hi >= lo)) {
        return Err(LmiError::Bad(format!(
            "need {n} lag ranges with 0 < lo <= hi, got {ranges:?}"
        )));
    }
    let free: Vec<usize> = (0..n).filter(|&i| ranges[i].1 > ranges[i].0).collect();
    if free.len() > MIXED_MAX_FREE {
        return Ok(None);
    }
    let mc = g.matrix();
    let kr = RowVector3::from(k);
    let all = vertices(ranges);
    let worst_max_real = all
        .iter()
        .map(|taus| mixed_max_real(k, g, taus))
        .fold(f64::NEG_INFINITY, f64::max);
    let positive = |p: &Matrix3<f64>| p.symmetric_eigenvalues().min() > 0.0;
    let (max_eigenvalue, certified) = match certificate {
        Some(cert) if cert.p_blocks.is_none() => {
            let p = Matrix3::from_fn(|i, j| 0.5 * (cert.p[i][j] + cert.p[j][i]));
            let top = worst_psi(&p, cert.ratio, cert.c, &kr, &mc, &all);
            (Some(top), top < 0.0 && positive(&p))
        }
        _ => (None, false),
    };
    let (direct_min_ratio, direct_max_eigenvalue, direct_growth) =
        match min_ratio_vertices(&kr, c, &mc, &all, 1e-6)? {
            Some((r, x)) => {
                // The independent re-check: (13) re-assembled at every vertex.
                let top = all
                    .iter()
                    .map(|taus| {
                        let psi = psi(
                            Lyapunov::Full(&x),
                            r,
                            c,
                            &kr,
                            &mc,
                            Plants::PerFollower(taus),
                        );
                        ((&psi + psi.transpose()) * 0.5)
                            .symmetric_eigenvalues()
                            .max()
                    })
                    .fold(f64::NEG_INFINITY, f64::max);
                let eig = ((&x + x.transpose()) * 0.5).symmetric_eigenvalues();
                let (lo, hi) = (eig.min(), eig.max());
                let top = if lo > 0.0 { top } else { f64::INFINITY };
                (Some(r), Some(top), Some((hi / lo).sqrt()))
            }
            None => (None, None, None),
        };
    Ok(Some(MixedCheck {
        tau_ranges: ranges.to_vec(),
        vertices: all.len(),
        worst_max_real,
        max_eigenvalue,
        certified,
        direct_min_ratio,
        direct_max_eigenvalue,
        direct_transient_growth: direct_growth,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pf(n: usize) -> Coupling {
        let mut h = DMatrix::zeros(n, n);
        for i in 0..n {
            h[(i, i)] = 1.0;
            if i > 0 {
                h[(i, i - 1)] = -1.0;
            }
        }
        Coupling::constant(h)
    }

    #[test]
    fn equal_lags_give_the_kronecker_form_and_its_spectrum() {
        let g = pf(4);
        let k = RowVector3::new(1.0, 2.0, 0.5);
        let p = Matrix3::new(3.0, 1.0, 0.2, 1.0, 2.0, 0.3, 0.2, 0.3, 1.0);
        let homogeneous = psi(
            Lyapunov::Common(&p),
            2.0,
            0.1,
            &k,
            &g.matrix(),
            Plants::Same(&Plant3::new(0.5)),
        );
        let mixed = psi(
            Lyapunov::Common(&p),
            2.0,
            0.1,
            &k,
            &g.matrix(),
            Plants::PerFollower(&[0.5; 4]),
        );
        assert!((homogeneous - mixed).amax() < 1e-12);
        let spectrum = crate::closed_loop_spectrum([1.0, 2.0, 0.5], &g, &[0.5]);
        let m = mixed_max_real([1.0, 2.0, 0.5], &g, &[0.5; 4]);
        assert!((spectrum[0].max_real - m).abs() < 1e-9, "{m}");
    }

    #[test]
    fn the_vertices_are_every_combination_of_the_free_ranges() {
        let g = pf(3);
        let c = check_mixed(
            [1.0, 2.0, 0.5],
            0.0,
            &g,
            &[(0.3, 0.5), (0.8, 0.8), (0.6, 1.0)],
            None,
        )
        .unwrap()
        .unwrap();
        assert_eq!(c.vertices, 4);
        assert_eq!(c.max_eigenvalue, None);
        assert!(!c.certified);
        assert!(check_mixed([1.0, 2.0, 0.5], 0.0, &g, &[(0.3, 0.5)], None).is_err());
    }
}
