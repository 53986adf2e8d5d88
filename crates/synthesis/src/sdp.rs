//! The little SDP layer both the analysis and the synthesis use: linear matrix inequalities
//! `F0 + sum_i x_i F_i <= 0` as clarabel PSD-cone rows, scalar rows `a x <= b`, and a solve.
use nalgebra::{DMatrix, Matrix3};

/// Column-major upper triangle of a symmetric matrix, off-diagonals scaled by sqrt(2): clarabel's
/// PSD triangle format.
pub(crate) fn svec(m: &DMatrix<f64>) -> Vec<f64> {
    let n = m.nrows();
    let s2 = std::f64::consts::SQRT_2;
    let mut v = Vec::with_capacity(n * (n + 1) / 2);
    for j in 0..n {
        for i in 0..=j {
            v.push(if i == j { m[(i, j)] } else { s2 * m[(i, j)] });
        }
    }
    v
}

/// The symmetric basis of a 3x3 matrix: E_ab = e_a e_b^T + e_b e_a^T (a < b), e_a e_a^T.
pub(crate) fn sym_basis3() -> Vec<Matrix3<f64>> {
    let mut out = Vec::new();
    for a in 0..3 {
        for b in a..3 {
            let mut e = Matrix3::zeros();
            e[(a, b)] = 1.0;
            e[(b, a)] = 1.0;
            out.push(e);
        }
    }
    out
}

/// A 3x3 as a dynamic matrix.
pub(crate) fn dm(m: &Matrix3<f64>) -> DMatrix<f64> {
    DMatrix::from_iterator(3, 3, m.iter().copied())
}

/// The index of entry (p, q), p <= q, in [`svec`]'s order.
pub(crate) fn svec_index(p: usize, q: usize) -> usize {
    q * (q + 1) / 2 + p
}

/// One constraint `F0 + sum_i x_i F_i <= 0` (negative semidefinite).
#[cfg_attr(not(sdp_solver), allow(dead_code))]
pub(crate) struct Lmi {
    size: usize,
    b: Vec<f64>,
    /// Per variable, the non-zero entries of `svec(F_i)` in increasing index order.
    cols: Vec<Vec<(usize, f64)>>,
}

impl Lmi {
    /// `f0 + sum_i x_i fi[i] <= 0`; `fi` has one matrix per variable.
    pub(crate) fn nsd(f0: &DMatrix<f64>, fi: &[DMatrix<f64>]) -> Self {
        // clarabel: A x + s = b with s in the PSD cone; s = -F(x) = svec(-F0) - sum x_i svec(F_i).
        let sparse = |m: &DMatrix<f64>| {
            svec(m)
                .into_iter()
                .enumerate()
                .filter(|(_, v)| *v != 0.0)
                .collect()
        };
        Self {
            size: f0.nrows(),
            b: svec(&-f0),
            cols: fi.iter().map(sparse).collect(),
        }
    }

    /// Like [`Lmi::nsd`] with each `F_i` given by its upper-triangle entries `(p, q, value)`,
    /// `p <= q` (each pair at most once), for problems whose `F_i` are too many to hold dense.
    pub(crate) fn nsd_sparse(f0: &DMatrix<f64>, fi: Vec<Vec<(usize, usize, f64)>>) -> Self {
        let s2 = std::f64::consts::SQRT_2;
        let cols = fi
            .into_iter()
            .map(|entries| {
                let mut col: Vec<(usize, f64)> = entries
                    .into_iter()
                    .filter(|e| e.2 != 0.0)
                    .map(|(p, q, v)| (svec_index(p, q), if p == q { v } else { s2 * v }))
                    .collect();
                col.sort_by_key(|e| e.0);
                col
            })
            .collect();
        Self {
            size: f0.nrows(),
            b: svec(&-f0),
            cols,
        }
    }
}

/// Why the SDP solver gave no answer (infeasibility is an answer: `Ok(None)`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SdpError {
    /// The solver failed (numerical trouble, iteration limit).
    #[error("the SDP solver stopped with status {0}")]
    Solver(String),
    /// This build has no SDP solver (the system OpenBLAS was missing when it was built).
    #[error("this build of platoon has no SDP solver: install OpenBLAS (Debian: apt-get install libopenblas-dev; .ci/run does it) and rebuild")]
    NoSolver,
}

/// Without the system OpenBLAS there is no SDP solver (see build.rs): say what to install.
#[cfg(not(sdp_solver))]
pub(crate) fn solve(
    _lmis: &[Lmi],
    _rows: &[(Vec<f64>, f64)],
    _cost: &[f64],
) -> Result<Option<Vec<f64>>, SdpError> {
    Err(SdpError::NoSolver)
}

/// OpenBLAS on the calling thread alone, once per process, unless the user set
/// `OPENBLAS_NUM_THREADS`. The PSD blocks here are small (tens of rows): its thread pool costs
/// more than it gains on them, and its threads spin against each other when SDPs run side by
/// side (test threads, campaign cells). `platoon design check-gain` of the paper's K on a
/// 2-core machine, measured: 18.1 s alone with the pool, 12.2 s without; two at once 33 s
/// with it, 20.5 s without. Every BLAS call of platoon is clarabel's, inside `solve`, after
/// this.
#[cfg(sdp_solver)]
fn blas_on_one_thread() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        if std::env::var_os("OPENBLAS_NUM_THREADS").is_none() {
            extern "C" {
                fn openblas_set_num_threads(n: std::ffi::c_int);
            }
            // SAFETY: OpenBLAS is linked (build.rs, cfg `sdp_solver`) and no BLAS call runs
            // while this does: every one is in `solve`, which waits for this `Once` first.
            unsafe { openblas_set_num_threads(1) }
        }
    });
}

/// Minimises `cost . x` subject to the LMIs and the scalar rows `row . x <= b`. `Ok(None)`:
/// primal infeasible.
#[cfg(sdp_solver)]
pub(crate) fn solve(
    lmis: &[Lmi],
    rows: &[(Vec<f64>, f64)],
    cost: &[f64],
) -> Result<Option<Vec<f64>>, SdpError> {
    blas_on_one_thread();
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
    };
    let nvar = cost.len();
    let mut colptr = vec![0];
    let (mut rowval, mut nzval) = (Vec::new(), Vec::new());
    for j in 0..nvar {
        let mut offset = 0;
        for l in lmis {
            for &(i, v) in &l.cols[j] {
                rowval.push(offset + i);
                nzval.push(v);
            }
            offset += l.b.len();
        }
        for (i, (row, _)) in rows.iter().enumerate() {
            if row[j] != 0.0 {
                rowval.push(offset + i);
                nzval.push(row[j]);
            }
        }
        colptr.push(rowval.len());
    }
    let m = lmis.iter().map(|l| l.b.len()).sum::<usize>() + rows.len();
    let a = CscMatrix::new(m, nvar, colptr, rowval, nzval);
    let b: Vec<f64> = lmis
        .iter()
        .flat_map(|l| l.b.iter().copied())
        .chain(rows.iter().map(|(_, b)| *b))
        .collect();
    let mut cones: Vec<SupportedConeT<f64>> = lmis
        .iter()
        .map(|l| SupportedConeT::PSDTriangleConeT(l.size))
        .collect();
    if !rows.is_empty() {
        cones.push(SupportedConeT::NonnegativeConeT(rows.len()));
    }
    let q = CscMatrix::zeros((nvar, nvar));
    // Numerical trouble is retried with settings that trade speed for robustness before it is
    // reported: more regularisation, no equilibration, then no chordal decomposition.
    type Tune = fn(&mut DefaultSettingsBuilder<f64>);
    let attempts: [(&str, Tune); 4] = [
        ("default settings", |_| {}),
        ("stronger regularisation", |b| {
            b.static_regularization_constant(1e-6)
                .dynamic_regularization_eps(1e-11)
                .dynamic_regularization_delta(1e-6);
        }),
        ("no equilibration", |b| {
            b.equilibrate_enable(false)
                .static_regularization_constant(1e-6);
        }),
        ("no chordal decomposition", |b| {
            b.chordal_decomposition_enable(false)
                .static_regularization_constant(1e-6);
        }),
    ];
    let mut failures = Vec::new();
    for (what, tune) in attempts {
        let mut builder = DefaultSettingsBuilder::default();
        builder.verbose(false).max_iter(500);
        tune(&mut builder);
        let settings = builder
            .build()
            .map_err(|e| SdpError::Solver(e.to_string()))?;
        let mut solver = DefaultSolver::new(&q, cost, &a, &b, &cones, settings)
            .map_err(|e| SdpError::Solver(format!("{e:?}")))?;
        solver.solve();
        match solver.solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                return Ok(Some(solver.solution.x.clone()))
            }
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                return Ok(None)
            }
            other => failures.push(format!("{other:?} with {what}")),
        }
    }
    Err(SdpError::Solver(format!(
        "{} (the problem is badly scaled for this size: try a smaller --c, a gain of smaller norm, or fewer followers)",
        failures.join(", ")
    )))
}
