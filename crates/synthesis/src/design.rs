//! Synthesis of K for Theorem 1: Remark 1's congruence (M = P^-1, U = K M) with its non-convex
//! block `-r M M` linearised around the last iterate (`M M >= M0 M + M M0 - M0^2`, a
//! convex-concave procedure: every iterate is feasible for the original condition), bisection on
//! r = beta1/beta2, and a gain bound `|U| <= k_max` with `M >= I`, so `|K| <= k_max` and the
//! design stays implementable at the run's step (readings R16 and R17 in
//! docs/paper-readings.md). The returned gain is then certified by the exact Theorem-1 SDP of
//! [`crate::theorem1_min_ratio`].
//!
//! With a time headway the congruence is no longer linear (the headway term of `K M` couples
//! `k1` with a row of `M = P^-1`), so the gain is designed on the constant-spacing condition of
//! the graph's first [`LEADING_DESIGN_FOLLOWERS`] followers (a long constant-spacing platoon may
//! admit no common P at all: that is the string instability the headway removes) and then
//! certified on the whole time-headway platoon: the certificate is exact, the design a
//! heuristic for it. With constant spacing the procedure runs on the whole graph, and where that
//! admits no common P, on the leading followers likewise. Where the common P of the whole
//! platoon is infeasible for the gain found, the certificate is the block-diagonal one
//! ([`LyapunovForm::BlockDiagonal`]).
use crate::certificate::Certificate;
use crate::condition::{Coupling, Plant3};
use crate::error::LmiError;
use crate::lmi::{min_ratio, Feasibility, LyapunovForm};
use crate::sdp::{dm, solve, sym_basis3, Lmi};
use nalgebra::{DMatrix, Matrix3};

/// What to design for.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignSpec {
    /// Decay parameter c.
    pub c: f64,
    /// The taus at which the condition must hold with one P: the nominal tau (Theorem 1), or
    /// the ends of the tau range (our reading of Theorem 2: robust to every tau between).
    pub taus: Vec<f64>,
    /// Bound on |K| (2-norm).
    pub k_max: f64,
    /// Largest ratio beta1/beta2 tried.
    pub ratio_max: f64,
    /// Bisection stops when the bracket is this narrow (relative).
    pub ratio_tol: f64,
    /// Lower bound on M = P^-1, which fixes the scale of (M, U); with |U| <= k_max m_min,
    /// |K| = |U M^-1| <= k_max. 0.01 works for the paper's graphs (1 and 0.1 are too tight).
    pub m_min: f64,
}

/// A designed gain and its exact certificate.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// K.
    pub k: [f64; 3],
    /// The exact Theorem-1 certificate of K (its smallest ratio).
    pub certificate: Certificate,
    /// SDPs solved.
    pub sdps: usize,
    /// The followers the procedure ran on (fewer than the platoon's with a time headway, or
    /// where the whole platoon admits no common P; the certificate is for the whole platoon).
    pub designed_on: usize,
}

impl Design {
    /// The largest decay rate c the design guarantees with beta1/beta2 kept within twice its
    /// own ratio, certified by the same kind of Lyapunov matrix as its certificate (common or
    /// one P per follower); c searched up to 5 to within 1e-3. `None` if even c = 0 needs more.
    pub fn guaranteed_decay(
        &self,
        g: &Coupling,
        taus: &[f64],
    ) -> Result<Option<Certificate>, LmiError> {
        crate::max_decay_within_ratio(
            self.k,
            g,
            taus,
            2.0 * self.certificate.ratio,
            (5.0, 1e-3),
            if self.certificate.p_blocks.is_some() {
                LyapunovForm::BlockDiagonal
            } else {
                LyapunovForm::Common
            },
        )
    }
}

/// The linearised Remark-1 matrix for M, U (1x3) around M0.
fn remark1(
    m: &Matrix3<f64>,
    u: &[f64; 3],
    m0: &Matrix3<f64>,
    r: f64,
    c: f64,
    h: &DMatrix<f64>,
    plant: &Plant3,
) -> DMatrix<f64> {
    let n = h.nrows();
    let s = 3 * n;
    let i_n = DMatrix::<f64>::identity(n, n);
    let bu = DMatrix::from_iterator(
        3,
        3,
        (plant.b * nalgebra::RowVector3::from(*u)).iter().copied(),
    );
    let am = dm(&(plant.a * m));
    let x11 = {
        let x = i_n.kronecker(&am) - h.kronecker(&bu);
        &x + x.transpose() + i_n.kronecker(&dm(m)) * c
    };
    let x12 = -h.kronecker(&bu);
    let lin = dm(&(m0 * m + m * m0 - m0 * m0));
    let ht_m = h.transpose().kronecker(&dm(m));
    let mut out = DMatrix::<f64>::zeros(3 * s, 3 * s);
    out.view_mut((0, 0), (s, s)).copy_from(&x11);
    out.view_mut((0, s), (s, s)).copy_from(&x12);
    out.view_mut((s, 0), (s, s)).copy_from(&x12.transpose());
    out.view_mut((0, 2 * s), (s, s)).copy_from(&ht_m);
    out.view_mut((2 * s, 0), (s, s))
        .copy_from(&ht_m.transpose());
    out.view_mut((s, s), (s, s))
        .copy_from(&(i_n.kronecker(&lin) * -r));
    out.view_mut((s, 2 * s), (s, s)).copy_from(&ht_m);
    out.view_mut((2 * s, s), (s, s))
        .copy_from(&ht_m.transpose());
    out.view_mut((2 * s, 2 * s), (s, s))
        .copy_from(&(DMatrix::<f64>::identity(s, s) * -1.0));
    out
}

/// One convex step: minimise t such that remark1(M, U; M0) <= t I at every vertex,
/// m_min I <= M <= m_max I, |U| <= k_max m_min, t >= -1. Returns (t, M, U).
fn ccp_step(
    m0: &Matrix3<f64>,
    r: f64,
    spec: &DesignSpec,
    h: &DMatrix<f64>,
    plants: &[Plant3],
) -> Result<(f64, Matrix3<f64>, [f64; 3]), LmiError> {
    let size = 9 * h.nrows();
    let mb = sym_basis3();
    let zero3 = Matrix3::zeros();
    // Variables x = (M's 6 entries, U's 3, t).
    let mut lmis = Vec::new();
    for plant in plants {
        let f0 = remark1(&zero3, &[0.0; 3], m0, r, spec.c, h, plant);
        let mut fi: Vec<DMatrix<f64>> = mb
            .iter()
            .map(|e| remark1(e, &[0.0; 3], m0, r, spec.c, h, plant) - &f0)
            .collect();
        for j in 0..3 {
            let mut u = [0.0; 3];
            u[j] = 1.0;
            fi.push(remark1(&zero3, &u, m0, r, spec.c, h, plant) - &f0);
        }
        fi.push(DMatrix::<f64>::identity(size, size) * -1.0); // F(x) - t I <= 0
        lmis.push(Lmi::nsd(&f0, &fi));
    }
    let m_part = |sign: f64| -> Vec<DMatrix<f64>> {
        (0..10)
            .map(|v| {
                if v < 6 {
                    dm(&mb[v]) * sign
                } else {
                    DMatrix::zeros(3, 3)
                }
            })
            .collect()
    };
    let mu = spec.m_min;
    // m_min I - M <= 0 and M - m_max I <= 0.
    lmis.push(Lmi::nsd(
        &(DMatrix::<f64>::identity(3, 3) * mu),
        &m_part(-1.0),
    ));
    lmis.push(Lmi::nsd(
        &(DMatrix::<f64>::identity(3, 3) * -1e4),
        &m_part(1.0),
    ));
    // [[k_max mu, U], [U^T, k_max mu I3]] >= 0  <=>  |U| <= k_max mu.
    let gu: Vec<DMatrix<f64>> = (0..10)
        .map(|v| {
            let mut g = DMatrix::<f64>::zeros(4, 4);
            if (6..9).contains(&v) {
                g[(0, v - 5)] = -1.0;
                g[(v - 5, 0)] = -1.0;
            }
            g
        })
        .collect();
    lmis.push(Lmi::nsd(
        &(DMatrix::<f64>::identity(4, 4) * -(spec.k_max * mu)),
        &gu,
    ));
    // t >= -1 keeps the problem bounded: -t <= 1.
    let mut row = vec![0.0; 10];
    row[9] = -1.0;
    let mut cost = vec![0.0; 10];
    cost[9] = 1.0;
    let x = solve(&lmis, &[(row, 1.0)], &cost)?
        .ok_or_else(|| LmiError::Solver("the convex step is infeasible".into()))?;
    let mut m = Matrix3::zeros();
    for (e, &v) in mb.iter().zip(&x) {
        m += e * v;
    }
    Ok((x[9], m, [x[6], x[7], x[8]]))
}

/// M and U of Remark 1.
type MU = (Matrix3<f64>, [f64; 3]);

/// Runs the convex-concave procedure at ratio `r` from `m0`; returns a feasible (M, U) if the
/// linearised condition reaches a negative t.
fn ccp(
    r: f64,
    mut m0: Matrix3<f64>,
    spec: &DesignSpec,
    h: &DMatrix<f64>,
    plant: &[Plant3],
    sdps: &mut usize,
) -> Result<Option<MU>, LmiError> {
    let mut last = f64::INFINITY;
    let mut last_drop = f64::INFINITY;
    for _ in 0..30 {
        *sdps += 1;
        // A numerical failure at this ratio counts as "not reached" (bisection stays
        // conservative); the final gain is always certified by the exact SDP.
        let (t, m, u) = match ccp_step(&m0, r, spec, h, plant) {
            Ok(x) => x,
            Err(LmiError::Solver(_)) => return Ok(None),
            Err(e) => return Err(e),
        };
        if t < -1e-6 {
            return Ok(Some((m, u)));
        }
        let drop = last - t;
        if drop < 1e-6 {
            return Ok(None); // no more progress
        }
        // The iterates' t falls about geometrically: where the drops shrink by rho, what is
        // left to fall is drop rho / (1 - rho). If that cannot bring t below 0, stop now
        // rather than crawl on (at an infeasible ratio this took most of a design's SDPs; the
        // verdict is the one crawling reached).
        let rho = drop / last_drop;
        if rho < 1.0 && drop * rho / (1.0 - rho) < t {
            return Ok(None);
        }
        last = t;
        last_drop = drop;
        m0 = m;
    }
    Ok(None)
}

/// Where the procedure does not run on the whole platoon, it runs on this many leading
/// followers (module docs).
pub const LEADING_DESIGN_FOLLOWERS: usize = 4;

/// The defaults used by `platoon design synthesize`.
impl Default for DesignSpec {
    fn default() -> Self {
        Self {
            c: 0.0,
            taus: vec![0.5],
            k_max: 20.0,
            ratio_max: 1e4,
            ratio_tol: 0.02,
            m_min: 0.01,
        }
    }
}

/// Designs K for Theorem 1 with coupling `g`: the smallest ratio the procedure reaches within
/// the gain bound, certified by the exact SDP (on `g`, time headway included; the procedure
/// itself runs on `g`'s graph with constant spacing, module docs). `Ok(None)`: nothing
/// feasible up to `ratio_max`.
pub fn design_theorem1(spec: &DesignSpec, g: &Coupling) -> Result<Option<Design>, LmiError> {
    if !(spec.k_max > 0.0
        && spec.ratio_max > 0.0
        && !spec.taus.is_empty()
        && spec.taus.iter().all(|t| t.is_finite() && *t > 0.0)
        && spec.c >= 0.0
        && spec.m_min > 0.0
        && spec.ratio_tol > 0.0)
    {
        return Err(LmiError::Bad(
            "need k_max > 0, ratio_max > 0, taus > 0, c >= 0, m_min > 0 and ratio_tol > 0".into(),
        ));
    }
    let plant: Vec<Plant3> = spec.taus.iter().map(|&t| Plant3::new(t)).collect();
    let mut sdps = 0;
    // The leading block of H: the first followers and whom they hear (for PF, PLF and TPSF
    // exactly the same preset with fewer followers).
    let lead = g.followers().min(LEADING_DESIGN_FOLLOWERS);
    let sub = g.h.view((0, 0), (lead, lead)).into_owned();
    // With a headway the procedure runs on the leading block; with constant spacing on the
    // whole graph, and on the leading block where that admits no common P (a long, string
    // unstable platoon), the gain then certified on the whole platoon with one P per follower
    // if need be.
    let (k, designed_on) = if g.headway > 0.0 {
        (ccp_design(spec, &sub, &plant, &mut sdps)?, lead)
    } else {
        match ccp_design(spec, &g.h, &plant, &mut sdps)? {
            Some(k) => return certify(spec, g, k, g.followers(), sdps).map(Some),
            None if lead < g.followers() => (ccp_design(spec, &sub, &plant, &mut sdps)?, lead),
            None => (None, g.followers()),
        }
    };
    let Some(k) = k else { return Ok(None) };
    match certify(spec, g, k, designed_on, sdps) {
        Ok(d) => Ok(Some(d)),
        Err(LmiError::NotCertified(_)) => Ok(None),
        Err(e) => Err(e),
    }
}

/// The procedure on graph `h`: the gain at the smallest ratio it reaches, or None.
fn ccp_design(
    spec: &DesignSpec,
    h: &DMatrix<f64>,
    plant: &[Plant3],
    sdps: &mut usize,
) -> Result<Option<[f64; 3]>, LmiError> {
    let Some((mut m_best, mut u_best)) = ccp(
        spec.ratio_max,
        Matrix3::identity() * spec.m_min,
        spec,
        h,
        plant,
        sdps,
    )?
    else {
        return Ok(None);
    };
    let (mut lo, mut hi) = (0.0, spec.ratio_max);
    while hi - lo > spec.ratio_tol * hi {
        let mid = 0.5 * (lo + hi);
        match ccp(mid, m_best, spec, h, plant, sdps)? {
            Some((m, u)) => {
                hi = mid;
                m_best = m;
                u_best = u;
            }
            None => lo = mid,
        }
    }
    let minv = m_best
        .try_inverse()
        .ok_or_else(|| LmiError::Solver("M is singular".into()))?;
    let k = nalgebra::RowVector3::from(u_best) * minv;
    Ok(Some([k[0], k[1], k[2]]))
}

/// The exact certificate of `k` on the whole platoon: the common P, else one P per follower.
/// `NotCertified` when neither exists (for a gain designed on the whole graph with constant
/// spacing that cannot happen: the procedure's iterates satisfy the condition; it is then a
/// solver error).
fn certify(
    spec: &DesignSpec,
    g: &Coupling,
    k: [f64; 3],
    designed_on: usize,
    mut sdps: usize,
) -> Result<Design, LmiError> {
    sdps += 1;
    let certificate = match min_ratio(k, spec.c, g, &spec.taus, 1e-6, LyapunovForm::Common)? {
        Feasibility::Feasible(c) => c,
        Feasibility::Infeasible if g.headway == 0.0 && designed_on == g.followers() => {
            return Err(LmiError::Solver(
                "the designed gain failed the exact Theorem-1 check".into(),
            ))
        }
        Feasibility::Infeasible => {
            sdps += 1;
            match min_ratio(k, spec.c, g, &spec.taus, 1e-6, LyapunovForm::BlockDiagonal)? {
                Feasibility::Feasible(c) => c,
                Feasibility::Infeasible => return Err(LmiError::NotCertified(f64::NAN)),
            }
        }
    };
    Ok(Design {
        k,
        certificate,
        sdps,
        designed_on,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_topology::{Preset, Topology};

    fn h(preset: Preset, n: usize) -> Coupling {
        Coupling::constant(Topology::preset(preset, n).unwrap().h_matrix())
    }

    /// TPSF with 20 followers admits no common P for the procedure; the gain designed
    /// on the first 4 is certified for all 20 with one P per follower.
    #[test]
    fn a_long_platoon_without_a_common_certificate_gets_a_block_diagonal_one() {
        let g = h(Preset::Tpsf, 20);
        let d = design_theorem1(&DesignSpec::default(), &g)
            .unwrap()
            .expect("a design");
        assert_eq!(d.designed_on, LEADING_DESIGN_FOLLOWERS);
        assert_eq!(d.certificate.condition, "theorem1-block-diagonal");
        assert_eq!(d.certificate.h.len(), 20);
        let v = d.certificate.verify().unwrap();
        assert!(v.holds, "{v:?}");
        // The transient growth, recomputed here from the 20 blocks as issued: sqrt of the
        // largest eigenvalue over all blocks by the smallest. It must be the verdict's (over all
        // blocks, not P_1's alone) and the certificate's own.
        let blocks = d.certificate.p_blocks.as_ref().expect("one P per follower");
        assert_eq!(blocks.len(), 20);
        let (lo, hi) = blocks
            .iter()
            .flat_map(|b| {
                let m = Matrix3::from_fn(|i, j| 0.5 * (b[i][j] + b[j][i]));
                m.symmetric_eigen()
                    .eigenvalues
                    .iter()
                    .copied()
                    .collect::<Vec<_>>()
            })
            .fold((f64::INFINITY, 0.0_f64), |(lo, hi), e| {
                (lo.min(e), hi.max(e))
            });
        let growth = (hi / lo).sqrt();
        assert!(
            (v.transient_growth - growth).abs() < 1e-9 * growth,
            "{v:?} vs {growth}"
        );
        assert_eq!(
            d.certificate.transient_growth().unwrap(),
            v.transient_growth
        );
        // 26.95: this design's growth as `design verify` prints it (two decimals), measured by
        // this code; the design is deterministic, so any change is a change of the design.
        assert!((v.transient_growth - 26.95).abs() < 0.005, "{v:?}");
        // The paper's 4 followers: designed on all of them, one common P.
        let d = design_theorem1(&DesignSpec::default(), &h(Preset::Tpsf, 4))
            .unwrap()
            .expect("a design");
        assert_eq!((d.designed_on, d.certificate.p_blocks.is_none()), (4, true));
    }

    #[test]
    fn a_robust_design_holds_at_both_ends_of_the_tau_range() {
        let spec = DesignSpec {
            taus: vec![0.34, 0.82],
            ratio_tol: 0.05,
            ..DesignSpec::default()
        };
        let d = design_theorem1(&spec, &h(Preset::Tpsf, 4))
            .unwrap()
            .expect("a design");
        assert_eq!(d.certificate.condition, "theorem2");
        assert_eq!(d.certificate.taus, vec![0.34, 0.82]);
        assert!(d.certificate.verify().unwrap().holds);
    }

    #[test]
    fn a_designed_gain_is_certified_within_its_bound_and_stabilises_every_tau() {
        let spec = DesignSpec {
            ratio_tol: 0.05,
            ..DesignSpec::default()
        };
        let g = h(Preset::Tpsf, 4);
        let d = design_theorem1(&spec, &g).unwrap().expect("a design");
        let norm = d.k.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(norm <= 20.0 + 1e-6, "|K| = {norm}");
        assert!(d.certificate.verify().unwrap().holds);
        let taus: Vec<f64> = (0..=48).map(|i| 0.34 + 0.01 * f64::from(i)).collect();
        for s in crate::closed_loop_spectrum(d.k, &g, &taus) {
            assert!(s.max_real < 0.0, "tau {}: {}", s.tau, s.max_real);
        }
    }
}
