//! LMI (13) of Theorem 1 and its SDPs on clarabel (the certificates they issue are
//! [`crate::certificate`]'s).
use crate::certificate::Certificate;
use crate::sdp::{dm, solve, sym_basis3, Lmi, SdpError};
use nalgebra::{DMatrix, Matrix3, RowVector3, Vector3};
use std::collections::BTreeMap;

/// Why a design request could not be answered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LmiError {
    /// Inputs out of range.
    #[error("{0}")]
    Bad(String),
    /// The solver failed (numerical trouble, iteration limit).
    #[error("the SDP solver stopped with status {0}")]
    Solver(String),
    /// This build has no SDP solver (the system OpenBLAS was missing when it was built).
    #[error("{}", SdpError::NoSolver)]
    NoSolver,
    /// The solver reported a solution that fails the independent re-check (at the edge of
    /// feasibility): not a certificate.
    #[error("the solver's answer fails the independent re-check (largest eigenvalue {0:.3e})")]
    NotCertified(f64),
}

/// The SDP layer's failures, as the LMI layer reports them (the same words).
impl From<SdpError> for LmiError {
    fn from(e: SdpError) -> Self {
        match e {
            SdpError::Solver(status) => Self::Solver(status),
            SdpError::NoSolver => Self::NoSolver,
        }
    }
}

/// The nominal third-order model: `A = [[0,1,0],[0,0,1],[0,0,-1/tau]]`, `B = [0,0,1/tau]^T`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plant3 {
    /// A.
    pub a: Matrix3<f64>,
    /// B.
    pub b: Vector3<f64>,
}

impl Plant3 {
    /// The model with engine lag `tau`.
    pub fn new(tau: f64) -> Self {
        #[rustfmt::skip]
        let a = Matrix3::new(
            0.0, 1.0, 0.0,
            0.0, 0.0, 1.0,
            0.0, 0.0, -1.0 / tau,
        );
        Self {
            a,
            b: Vector3::new(0.0, 0.0, 1.0 / tau),
        }
    }
}

pub(crate) fn kron(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    a.kronecker(b)
}

pub(crate) fn he(x: &DMatrix<f64>) -> DMatrix<f64> {
    x + x.transpose()
}

/// What maps the tracking errors `e` (to the policy's desired distances from the leader) to the
/// neighbourhood errors: `q = M (e + eps)`, so the closed loop is
/// `e' = (I_N kron A) e - (I_N kron B K) M (e + eps)`. With constant spacing `M = H kron I3`
/// (the paper's (9)). With a time headway `h_t` (desired distance to a vehicle `m` places ahead
/// `m (l + h_t v)`, `v` the rear vehicle's speed) `M = H kron I3 + h_t (W kron E)` with
/// `E = e1 e2^T` (speed into the position slot), `W_ii` the sum of `i - j` over the neighbours
/// `j` ahead of `i` (the leader counted as `j = 0` where pinned) and `W_ij = -(j - i)` for a
/// neighbour `j` behind. Theorem 1's proof goes through unchanged with `M` in place of
/// `H kron I3`: (13) with `-H kron P B K` read as `-(I_N kron P B K) M` and `H^T kron I3` as `M^T`.
#[derive(Debug, Clone, PartialEq)]
pub struct Coupling {
    /// H = L + diag(pinning), N x N.
    pub h: DMatrix<f64>,
    /// The time headway h_t (s); 0 for constant spacing.
    pub headway: f64,
}

impl Coupling {
    /// Constant spacing on graph `h`.
    pub fn constant(h: DMatrix<f64>) -> Self {
        Self { h, headway: 0.0 }
    }

    /// A time headway `headway` (s) on graph `h`.
    pub fn time_headway(h: DMatrix<f64>, headway: f64) -> Self {
        Self { h, headway }
    }

    /// N.
    pub fn followers(&self) -> usize {
        self.h.nrows()
    }

    /// W (N x N) of the time headway (see [`Coupling`]), from H's links and pinning.
    pub fn headway_weights(&self) -> DMatrix<f64> {
        let n = self.followers();
        let mut w = DMatrix::zeros(n, n);
        for r in 0..n {
            let mut pin = self.h[(r, r)];
            for c in (0..n).filter(|&c| c != r) {
                let a = -self.h[(r, c)];
                pin -= a;
                if c < r {
                    w[(r, r)] += a * (r - c) as f64;
                } else {
                    w[(r, c)] = -a * (c - r) as f64;
                }
            }
            w[(r, r)] += pin * (r + 1) as f64;
        }
        w
    }

    /// M (3N x 3N).
    pub fn matrix(&self) -> DMatrix<f64> {
        let mut m = kron(&self.h, &DMatrix::identity(3, 3));
        if self.headway != 0.0 {
            let mut e = DMatrix::zeros(3, 3);
            e[(0, 1)] = 1.0;
            m += kron(&self.headway_weights(), &e) * self.headway;
        }
        m
    }
}

/// The matrix `Psi` of (13) for `P`, ratio `r = beta1 / beta2`, decay `c`, gain `k`, the
/// coupling `g` (graph and spacing policy) and plant: a 9N x 9N symmetric matrix that must be
/// negative definite.
pub fn psi_theorem1(
    p: &Matrix3<f64>,
    r: f64,
    c: f64,
    k: &RowVector3<f64>,
    g: &Coupling,
    plant: &Plant3,
) -> DMatrix<f64> {
    psi(
        Lyapunov::Common(p),
        r,
        c,
        k,
        &g.matrix(),
        Plants::Same(plant),
    )
}

/// `(I_N kron B) M` for a 3x3 `b`: block row i is `b` times block row i of `M`.
pub(crate) fn blockwise(b: &DMatrix<f64>, mc: &DMatrix<f64>) -> DMatrix<f64> {
    let m = mc.nrows();
    let mut out = DMatrix::<f64>::zeros(m, m);
    for i in 0..m / 3 {
        out.view_mut((3 * i, 0), (3, m))
            .copy_from(&(b * mc.view((3 * i, 0), (3, m))));
    }
    out
}

/// The Lyapunov matrix of (13): `I_N kron P` with a common `P`, or a general `X` (3N x 3N,
/// symmetric; the proof of Theorem 1 needs nothing of `X` but `X > 0`).
#[derive(Debug, Clone, Copy)]
pub enum Lyapunov<'a> {
    /// `I_N kron P`.
    Common(&'a Matrix3<f64>),
    /// `X`.
    Full(&'a DMatrix<f64>),
}

/// The followers' plants in (13).
#[derive(Debug, Clone, Copy)]
pub enum Plants<'a> {
    /// Every follower with this plant: `I_N kron A` and `I_N kron B K`.
    Same(&'a Plant3),
    /// Follower i with lag `taus[i]` (one each): `diag(A_i)` and `diag(B_i K)`.
    PerFollower(&'a [f64]),
}

/// (13) with the Lyapunov matrix `X` of `lyapunov`, ratio `r`, decay `c`, gain `k`, the
/// coupling's matrix `M` (`mc`) and the followers' `plants`:
/// `[[He(X diag(A_i) - X diag(B_i K) M) + c X, -X diag(B_i K) M, M^T], [., -r I, M^T],
/// [M, M, -I]]`, with the Kronecker forms `I_N kron A` and `I_N kron B K` for one plant.
pub fn psi(
    lyapunov: Lyapunov<'_>,
    r: f64,
    c: f64,
    k: &RowVector3<f64>,
    mc: &DMatrix<f64>,
    plants: Plants<'_>,
) -> DMatrix<f64> {
    let n = mc.nrows() / 3;
    let i_n = DMatrix::<f64>::identity(n, n);
    if let (Lyapunov::Common(p), Plants::Same(plant)) = (lyapunov, plants) {
        let pd = DMatrix::from_iterator(3, 3, p.iter().copied());
        let pa = DMatrix::from_iterator(3, 3, (p * plant.a).iter().copied());
        let pbk = DMatrix::from_iterator(3, 3, (p * plant.b * k).iter().copied());
        let pbkm = blockwise(&pbk, mc);
        let x11 = he(&(kron(&i_n, &pa) - &pbkm)) + kron(&i_n, &pd) * c;
        return assemble(&x11, &-pbkm, r, mc);
    }
    let common;
    let x = match lyapunov {
        Lyapunov::Common(p) => {
            common = kron(&i_n, &dm(p));
            &common
        }
        Lyapunov::Full(x) => x,
    };
    let m = mc.nrows();
    let mut a = DMatrix::<f64>::zeros(m, m);
    let mut bkm = DMatrix::<f64>::zeros(m, m);
    for i in 0..n {
        let plant = match plants {
            Plants::Same(plant) => *plant,
            Plants::PerFollower(taus) => Plant3::new(taus[i]),
        };
        a.view_mut((3 * i, 3 * i), (3, 3)).copy_from(&plant.a);
        let bk = dm(&(plant.b * k));
        bkm.view_mut((3 * i, 0), (3, m))
            .copy_from(&(bk * mc.view((3 * i, 0), (3, m))));
    }
    let xbkm = x * bkm;
    let x11 = he(&(x * a - &xbkm)) + x * c;
    assemble(&x11, &-xbkm, r, mc)
}

/// The 9N x 9N matrix of (13) from its (1,1) and (1,2) blocks.
pub(crate) fn assemble(
    x11: &DMatrix<f64>,
    x12: &DMatrix<f64>,
    r: f64,
    mc: &DMatrix<f64>,
) -> DMatrix<f64> {
    let m = mc.nrows();
    let ht_i = mc.transpose();
    let mut psi = DMatrix::<f64>::zeros(3 * m, 3 * m);
    psi.view_mut((0, 0), (m, m)).copy_from(x11);
    psi.view_mut((0, m), (m, m)).copy_from(x12);
    psi.view_mut((m, 0), (m, m)).copy_from(&x12.transpose());
    psi.view_mut((0, 2 * m), (m, m)).copy_from(&ht_i);
    psi.view_mut((2 * m, 0), (m, m)).copy_from(mc);
    psi.view_mut((m, m), (m, m))
        .copy_from(&(DMatrix::<f64>::identity(m, m) * -r));
    psi.view_mut((m, 2 * m), (m, m)).copy_from(&ht_i);
    psi.view_mut((2 * m, m), (m, m)).copy_from(mc);
    psi.view_mut((2 * m, 2 * m), (m, m))
        .copy_from(&(DMatrix::<f64>::identity(m, m) * -1.0));
    psi
}

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
