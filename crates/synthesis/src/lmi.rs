//! The SDPs of Theorem 1's LMI (13) on clarabel: the smallest `beta1 / beta2` for a gain and a
//! decay, and the certificates they issue ([`crate::certificate`]'s); (13) itself is
//! [`crate::condition`]'s.
use crate::certificate::Certificate;
use crate::condition::{psi, Coupling, Lyapunov, Plant3, Plants};
use crate::error::LmiError;
use crate::sdp::{dm, solve, sym_basis3, Lmi};
use nalgebra::{DMatrix, Matrix3, RowVector3};
use std::collections::BTreeMap;

/// The outcome of a Theorem-1 SDP.
#[derive(Debug, Clone, PartialEq)]
// Returned once per SDP (each of which takes milliseconds at least): boxing would buy nothing.
#[allow(clippy::large_enum_variant)]
pub enum Feasibility {
    /// A certificate.
    Feasible(Certificate),
    /// No P and ratio satisfy (13) for this K and c.
    Infeasible,
}

/// The largest eigenvalue the Lyapunov matrix P may have in [`min_ratio`] (its smallest is the
/// margin `delta`).
pub const P_MAX: f64 = 1e4;

/// The smallest `beta1 / beta2` for which (13) holds with gain `k` and decay `c` on graph `h`
/// at nominal `tau` (with margin `delta`: Psi <= -delta I, P >= delta I), or `Infeasible`.
pub fn theorem1_min_ratio(
    k: [f64; 3],
    c: f64,
    g: &Coupling,
    tau: f64,
    delta: f64,
) -> Result<Feasibility, LmiError> {
    min_ratio(k, c, g, &[tau], delta, LyapunovForm::Common)
}

/// Like [`theorem1_min_ratio`], with (13) imposed at every tau of `taus` (for the two ends of
/// a tau range this is our reading of Theorem 2: robust to any tau between) and the Lyapunov
/// matrix of the `form` given. [`LyapunovForm::BlockDiagonal`] holds where the common one is
/// infeasible (a cascade such as PF needs P_i that shrink along the platoon), at the price of a
/// transient growth `sqrt(lambda_max / lambda_min)` over all blocks (in
/// [`Verdict`](crate::Verdict)).
pub fn min_ratio(
    k: [f64; 3],
    c: f64,
    g: &Coupling,
    taus: &[f64],
    delta: f64,
    form: LyapunovForm,
) -> Result<Feasibility, LmiError> {
    min_ratio_with(
        &Query {
            k,
            c,
            g,
            taus,
            delta,
        },
        form,
        u32::MAX,
    )
}

/// The Lyapunov matrix a [`min_ratio`] SDP searches for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LyapunovForm {
    /// `I_N kron P`, one P for every follower: 7 variables.
    Common,
    /// `diag(P_1, ..., P_N)`, one P per follower: 6N + 1 variables, each `P_i` kept in
    /// `delta I <= P_i <= P_MAX I`. The constraint matrices are assembled sparse (each `P_i`
    /// touches the rows of follower i only), so N = 100 fits in memory.
    BlockDiagonal,
}

/// What a [`min_ratio`] SDP is asked: the smallest `beta1 / beta2` for which (13) holds with
/// gain `k` and decay `c` on coupling `g` at every tau of `taus`, with margin `delta`
/// (Psi <= -delta I, P >= delta I).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Query<'a> {
    pub(crate) k: [f64; 3],
    pub(crate) c: f64,
    pub(crate) g: &'a Coupling,
    pub(crate) taus: &'a [f64],
    pub(crate) delta: f64,
}

/// [`min_ratio`] with at most `retries` stricter margins for an answer that fails the re-check
/// (the bisections allow one: at the edge of feasibility they count a failure as infeasible
/// anyway, and the retries cost most of a bisection's time).
pub(crate) fn min_ratio_with(
    query: &Query<'_>,
    form: LyapunovForm,
    retries: u32,
) -> Result<Feasibility, LmiError> {
    check_inputs(query.c, query.taus, query.delta)?;
    let (lmis, blocks) = match form {
        LyapunovForm::Common => (common_lmis(query), 1),
        LyapunovForm::BlockDiagonal => (block_diagonal_lmis(query), query.g.followers()),
    };
    // Variables x = (each P's 6 entries, r).
    let nvar = 6 * blocks + 1;
    let mut cost = vec![0.0; nvar];
    cost[nvar - 1] = 1.0; // minimise r
    let Some(x) = solve(&lmis, &[], &cost)? else {
        return Ok(Feasibility::Infeasible);
    };
    let basis = sym_basis3();
    let ps: Vec<[[f64; 3]; 3]> = (0..blocks)
        .map(|i| {
            let mut p = Matrix3::zeros();
            for (e, &v) in basis.iter().zip(&x[6 * i..6 * i + 6]) {
                p += e * v;
            }
            rows3(&p)
        })
        .collect();
    let (suffix, p_blocks) = match form {
        LyapunovForm::Common => ("", None),
        LyapunovForm::BlockDiagonal => ("-block-diagonal", Some(ps.clone())),
    };
    let cert = Certificate {
        condition: condition(query.taus, suffix),
        k: query.k,
        c: query.c,
        ratio: x[nvar - 1],
        p: ps[0],
        p_blocks,
        h: rows(&query.g.h),
        headway: query.g.headway,
        taus: query.taus.to_vec(),
        max_eigenvalue: 0.0,
        p_min_eigenvalue: 0.0,
    };
    issue(cert, query.delta, retries, |stricter| {
        min_ratio_with(
            &Query {
                delta: stricter,
                ..*query
            },
            form,
            retries - 1,
        )
    })
}

/// The LMIs of [`LyapunovForm::Common`]: per tau, Psi(x) + delta I <= 0, and
/// delta I <= P <= P_MAX I.
fn common_lmis(query: &Query<'_>) -> Vec<Lmi> {
    let kr = RowVector3::from(query.k);
    let n = query.g.followers();
    let size = 9 * n;
    let basis = sym_basis3();
    let mc = query.g.matrix();
    let mut lmis = Vec::new();
    for &tau in query.taus {
        let plant = Plant3::new(tau);
        let psi0 = psi(
            Lyapunov::Common(&Matrix3::zeros()),
            0.0,
            query.c,
            &kr,
            &mc,
            Plants::Same(&plant),
        );
        let mut fi: Vec<DMatrix<f64>> = basis
            .iter()
            .map(|e| {
                psi(
                    Lyapunov::Common(e),
                    0.0,
                    query.c,
                    &kr,
                    &mc,
                    Plants::Same(&plant),
                ) - &psi0
            })
            .collect();
        fi.push(
            psi(
                Lyapunov::Common(&Matrix3::zeros()),
                1.0,
                query.c,
                &kr,
                &mc,
                Plants::Same(&plant),
            ) - &psi0,
        );
        lmis.push(Lmi::nsd(
            &(psi0 + DMatrix::<f64>::identity(size, size) * query.delta),
            &fi,
        ));
    }
    // P >= delta I:  delta I - P <= 0.
    let mut fp: Vec<DMatrix<f64>> = basis.iter().map(|e| -dm(e)).collect();
    fp.push(DMatrix::zeros(3, 3));
    lmis.push(Lmi::nsd(
        &(DMatrix::<f64>::identity(3, 3) * query.delta),
        &fp,
    ));
    // P <= P_MAX I: without a bound the smallest ratio may only be approached as P grows
    // without end, which leaves the interior-point method no optimum to converge to (PF with 3
    // followers, PLF with 8, BPF with 2 end in NumericalError without it). Any P in the box is
    // a valid certificate (re-checked before it is issued); the ratio is the smallest over the box.
    let mut fu: Vec<DMatrix<f64>> = basis.iter().map(dm).collect();
    fu.push(DMatrix::zeros(3, 3));
    lmis.push(Lmi::nsd(&(DMatrix::<f64>::identity(3, 3) * -P_MAX), &fu));
    lmis
}

fn check_inputs(c: f64, taus: &[f64], delta: f64) -> Result<(), LmiError> {
    if c.is_finite()
        && c >= 0.0
        && delta > 0.0
        && !taus.is_empty()
        && taus.iter().all(|t| t.is_finite() && *t > 0.0)
    {
        Ok(())
    } else {
        Err(LmiError::Bad(format!(
            "need c >= 0, taus > 0 and delta > 0 (got c = {c}, taus = {taus:?}, delta = {delta})"
        )))
    }
}

/// "theorem1" (one tau) or "theorem2" (the ends of a range), with `suffix`.
fn condition(taus: &[f64], suffix: &str) -> String {
    let theorem = if taus.len() == 1 {
        "theorem1"
    } else {
        "theorem2"
    };
    format!("{theorem}{suffix}")
}

/// A matrix as rows.
fn rows(h: &DMatrix<f64>) -> Vec<Vec<f64>> {
    h.row_iter().map(|r| r.iter().copied().collect()).collect()
}

/// Re-checks the solver's answer and issues it. An answer that does not pass the independent
/// check sits within the solver's tolerance of the boundary: it is asked again (`again`, with
/// a hundredfold margin, while `retries` and the margin allow), and only then reported; an
/// answer that fails the check is never returned.
fn issue(
    mut cert: Certificate,
    delta: f64,
    retries: u32,
    again: impl FnOnce(f64) -> Result<Feasibility, LmiError>,
) -> Result<Feasibility, LmiError> {
    let v = cert.verify()?;
    cert.max_eigenvalue = v.max_eigenvalue;
    cert.p_min_eigenvalue = v.p_min_eigenvalue;
    if v.holds {
        return Ok(Feasibility::Feasible(cert));
    }
    if retries > 0 && delta < MAX_MARGIN {
        match again(delta * 100.0) {
            // The stricter problem tripping the solver says no more than this answer did.
            Err(LmiError::Solver(_)) => {}
            other => return other,
        }
    }
    Err(LmiError::NotCertified(v.max_eigenvalue))
}

/// The LMIs of [`LyapunovForm::BlockDiagonal`], assembled sparse: per tau,
/// Psi(x) + delta I <= 0, and delta I <= P_i <= P_MAX I.
fn block_diagonal_lmis(query: &Query<'_>) -> Vec<Lmi> {
    let kr = RowVector3::from(query.k);
    let n = query.g.followers();
    let m = 3 * n;
    let basis = sym_basis3();
    let mc = query.g.matrix();
    let nvar = 6 * n + 1;
    let mut lmis = Vec::new();
    for &tau in query.taus {
        let plant = Plant3::new(tau);
        let bk = plant.b * kr;
        let psi0 = psi(
            Lyapunov::Full(&DMatrix::zeros(m, m)),
            0.0,
            query.c,
            &kr,
            &mc,
            Plants::Same(&plant),
        ) + DMatrix::<f64>::identity(3 * m, 3 * m) * query.delta;
        let mut cols: Vec<Vec<(usize, usize, f64)>> = Vec::with_capacity(nvar);
        for i in 0..n {
            // Block row i of (I kron B K) M.
            let bkm = dm(&bk) * mc.view((3 * i, 0), (3, m));
            for e in &basis {
                let ed = dm(e);
                // Rows 3i..3i+3 of X (I kron A) - X (I kron B K) M + (c / 2) X for X = e_i e_i^T
                // kron E; (1,1) is its He, (1,2) the second term alone.
                let coupled = &ed * &bkm;
                let mut strip = -&coupled;
                let own = dm(&(e * plant.a)) + &ed * (query.c / 2.0);
                let mut view = strip.view_mut((0, 3 * i), (3, 3));
                view += own;
                let mut acc: BTreeMap<(usize, usize), f64> = BTreeMap::new();
                for a in 0..3 {
                    let row = 3 * i + a;
                    for col in 0..m {
                        let v = strip[(a, col)];
                        if v != 0.0 {
                            let key = (row.min(col), row.max(col));
                            *acc.entry(key).or_default() += if row == col { 2.0 * v } else { v };
                        }
                        let w = -coupled[(a, col)];
                        if w != 0.0 {
                            *acc.entry((row, m + col)).or_default() += w;
                        }
                    }
                }
                cols.push(acc.into_iter().map(|((p, q), v)| (p, q, v)).collect());
            }
        }
        // r: -r I on the (2,2) block.
        cols.push((m..2 * m).map(|j| (j, j, -1.0)).collect());
        lmis.push(Lmi::nsd_sparse(&psi0, cols));
    }
    // delta I <= P_i <= P_MAX I: each touches its own 6 variables only.
    for i in 0..n {
        let block = |sign: f64| -> Vec<Vec<(usize, usize, f64)>> {
            (0..nvar)
                .map(|v| {
                    if v / 6 == i && v < 6 * n {
                        let e = &basis[v % 6];
                        (0..3)
                            .flat_map(|q| (0..=q).map(move |p| (p, q)))
                            .map(|(p, q)| (p, q, e[(p, q)] * sign))
                            .collect()
                    } else {
                        Vec::new()
                    }
                })
                .collect()
        };
        lmis.push(Lmi::nsd_sparse(
            &(DMatrix::<f64>::identity(3, 3) * query.delta),
            block(-1.0),
        ));
        lmis.push(Lmi::nsd_sparse(
            &(DMatrix::<f64>::identity(3, 3) * -P_MAX),
            block(1.0),
        ));
    }
    lmis
}

fn rows3(p: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [
        [p[(0, 0)], p[(0, 1)], p[(0, 2)]],
        [p[(1, 0)], p[(1, 1)], p[(1, 2)]],
        [p[(2, 0)], p[(2, 1)], p[(2, 2)]],
    ]
}

/// The largest margin [`min_ratio`] retries with when an answer fails the re-check.
const MAX_MARGIN: f64 = 1e-3;

#[cfg(test)]
mod tests;
