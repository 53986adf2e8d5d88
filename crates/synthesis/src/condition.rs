//! Theorem 1's condition (13) as a matrix: the followers' model, the coupling of graph and
//! spacing policy, the Lyapunov matrix's forms and `Psi`. The SDPs that search for a
//! certificate (`lmi`) and the re-check of one (`certificate`) both assemble it.
use crate::sdp::dm;
use nalgebra::{DMatrix, Matrix3, RowVector3, Vector3};

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
