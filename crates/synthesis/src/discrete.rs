//! A common quadratic Lyapunov function for sampled loops: the LMI that certifies a formation
//! of a platoon (`platoon_control::formation_loop`: its one-step maps at every corner of the
//! members' lag box; a map is affine in each member's own lag term and `Phi -> Phi^T P Phi`
//! is matrix convex, so the LMI at the corners holds for any lags in the box, changing from
//! step to step as they may).
//!
//! For one-step maps `Phi_v` of a loop sampled every `dt` s, `A_v = (Phi_v - I) / dt`, the LMI
//! in a symmetric `P`
//!
//! ```text
//! A_v^T P + P A_v + dt A_v^T P A_v + 2 c P <= -delta I   for every v,   delta I <= P <= P_MAX I
//! ```
//!
//! is `Phi_v^T P Phi_v <= (1 - 2 c dt) P - delta dt I` divided by `dt` (written so, it does not
//! lose the margin to cancellation when `Phi_v` is near `I`): the norm `|z|_P` shrinks by at
//! least `sqrt(1 - 2 c dt)` a step whichever map acts, in any order, so at the rate `c` (1/s),
//! roughly. [`common_decay`] finds the largest such `c` by bisection, each answer re-checked by
//! the eigenvalues of the LMI at the solver's `P` before it is believed.
use crate::error::LmiError;
use crate::lmi::P_MAX;
use crate::sdp::{solve, Lmi};
use nalgebra::DMatrix;
use serde::Serialize;

/// The margin `delta` of the LMI.
const MARGIN: f64 = 1e-6;

/// The most maps [`common_decay`] puts in one SDP.
pub const MAX_MAPS: usize = 16;

/// What [`common_decay`] found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Decay {
    /// The largest spectral radius of the maps: below 1, each on its own is stable.
    pub spectral_radius: f64,
    /// The largest rate `c` (1/s, within 1 % of the bisection) at which a common `P` is
    /// certified (re-checked); `None`: none was, not even at `c = 0`.
    pub decay_per_s: Option<f64>,
}

/// The largest certified common decay of the one-step maps `phis` (square, of one size) of a
/// loop sampled every `dt` s, by one SDP over the whole state.
pub fn common_decay(phis: &[DMatrix<f64>], dt: f64) -> Result<Decay, LmiError> {
    let n = check_maps(phis, dt)?;
    if phis.len() > MAX_MAPS {
        return Err(LmiError::Bad(format!(
            "{} maps: one SDP takes at most {MAX_MAPS} (the corners of the lag box of {} \
             members; a loop that is no cascade with more members having a lag range is not \
             checked)",
            phis.len(),
            MAX_MAPS.ilog2()
        )));
    }
    let spectral_radius = spectral_radius(phis);
    let flows = flows(phis, dt, n);
    let decay_per_s = match spectral_radius < 1.0 {
        true => best_rate(&flows, dt, spectral_radius)?.map(|(c, _)| c),
        false => None,
    };
    Ok(Decay {
        spectral_radius,
        decay_per_s,
    })
}

/// [`common_decay`] for maps that are block lower triangular in blocks of `block` states (a
/// cascade: a platoon whose members read only vehicles ahead of them): one small SDP per
/// diagonal block, then the whole certified at once. With a `P_i` for each block at rates
/// `c_i`, `P = diag(s^(2i) P_i)` is a common `P` of the whole at any rate below `min c_i` for
/// `s` small enough (the coupling below the diagonal then weighs little); the rate is the
/// largest of 99, 95, 90, 80 and 50 % of `min c_i` that a scale `s` in 0.3, 0.1, ..., 1e-4
/// passes the re-check with, on the maps scaled by `diag(s^i)` (the same LMI, well
/// conditioned). Other maps: [`common_decay`].
pub fn cascade_decay(phis: &[DMatrix<f64>], dt: f64, block: usize) -> Result<Decay, LmiError> {
    let n = check_maps(phis, dt)?;
    let triangular = block > 0
        && n % block == 0
        && phis
            .iter()
            .all(|p| (0..n).all(|r| ((r / block + 1) * block..n).all(|c| p[(r, c)] == 0.0)));
    if !triangular {
        return common_decay(phis, dt);
    }
    let blocks = n / block;
    let mut radius: f64 = 0.0;
    let mut parts = Vec::with_capacity(blocks);
    for b in 0..blocks {
        let at = b * block;
        // A member's block depends on its own lag alone: the corners repeat it.
        let mut diagonal: Vec<DMatrix<f64>> = Vec::new();
        for p in phis {
            let d = p.view((at, at), (block, block)).into_owned();
            if !diagonal.contains(&d) {
                diagonal.push(d);
            }
        }
        let r = spectral_radius(&diagonal);
        radius = radius.max(r);
        if r.is_nan() || r >= 1.0 {
            return Ok(Decay {
                spectral_radius: spectral_radius(phis).max(radius),
                decay_per_s: None,
            });
        }
        match best_rate(&flows(&diagonal, dt, block), dt, r)? {
            Some(part) => parts.push(part),
            None => return common_decay(phis, dt),
        }
    }
    let slowest = parts.iter().map(|(c, _)| *c).fold(f64::INFINITY, f64::min);
    let mut p = DMatrix::zeros(n, n);
    for (b, (_, pb)) in parts.iter().enumerate() {
        p.view_mut((b * block, b * block), (block, block))
            .copy_from(pb);
    }
    // diag(s^i) Phi diag(s^-i): the coupling from block q to block r weighs s^(r - q); each
    // scale's flows made once, when first tried.
    let scales = [0.3f64, 0.1, 0.03, 0.01, 1e-3, 1e-4];
    let scaled = |s: f64| {
        let maps: Vec<DMatrix<f64>> = phis
            .iter()
            .map(|m| {
                DMatrix::from_fn(n, n, |r, q| {
                    m[(r, q)] * s.powi((r / block) as i32 - (q / block) as i32)
                })
            })
            .collect();
        flows(&maps, dt, n)
    };
    let mut made: Vec<Option<Vec<DMatrix<f64>>>> = vec![None; scales.len()];
    for fraction in [0.99, 0.95, 0.9, 0.8, 0.5] {
        let c = fraction * slowest;
        for (s, flows) in scales.iter().zip(&mut made) {
            if holds(flows.get_or_insert_with(|| scaled(*s)), &p, dt, c) {
                return Ok(Decay {
                    spectral_radius: radius,
                    decay_per_s: Some(c),
                });
            }
        }
    }
    common_decay(phis, dt)
}

fn check_maps(phis: &[DMatrix<f64>], dt: f64) -> Result<usize, LmiError> {
    let n = phis.first().map_or(0, DMatrix::nrows);
    let finite = phis.iter().all(|p| p.iter().all(|x| x.is_finite()));
    if n == 0
        || !finite
        || phis.iter().any(|p| p.nrows() != n || p.ncols() != n)
        || dt.is_nan()
        || dt <= 0.0
    {
        return Err(LmiError::Bad(format!(
            "a decay needs finite square maps of one size and dt > 0 (got {} maps, dt = {dt})",
            phis.len()
        )));
    }
    Ok(n)
}

/// The largest modulus of an eigenvalue of any of the maps (their entries are finite:
/// [`check_maps`]; a NaN all the same is kept).
fn spectral_radius(phis: &[DMatrix<f64>]) -> f64 {
    phis.iter()
        .flat_map(|p| {
            p.complex_eigenvalues()
                .iter()
                .map(|z| z.norm())
                .collect::<Vec<_>>()
        })
        .fold(
            0.0,
            |a: f64, b| if b.is_nan() { f64::NAN } else { a.max(b) },
        )
}

/// `(Phi - I) / dt` of each map.
fn flows(phis: &[DMatrix<f64>], dt: f64, n: usize) -> Vec<DMatrix<f64>> {
    phis.iter()
        .map(|p| (p - DMatrix::identity(n, n)) / dt)
        .collect()
}

/// The largest rate (within 1 %) at which a common `P` is certified, with that `P`; `None`
/// when none is at rate 0. The solver failing above rate 0 counts as no certificate there.
fn best_rate(
    flows: &[DMatrix<f64>],
    dt: f64,
    spectral_radius: f64,
) -> Result<Option<(f64, DMatrix<f64>)>, LmiError> {
    let Some(p0) = certified(flows, dt, 0.0)? else {
        return Ok(None);
    };
    let mut best = (0.0, p0);
    // No common P decays faster than the slowest map: rho^2 >= 1 - 2 c dt.
    let mut hi = (1.0 - spectral_radius * spectral_radius) / (2.0 * dt);
    while hi - best.0 > 0.01 * best.0.max(1e-3) {
        let c = 0.5 * (best.0 + hi);
        match certified(flows, dt, c) {
            Ok(Some(p)) => best = (c, p),
            Ok(None) | Err(LmiError::Solver(_)) => hi = c,
            Err(e) => return Err(e),
        }
    }
    Ok(Some(best))
}

/// The LMI's matrix for flow `a` at `P`: `A^T P + P A + dt A^T P A + 2 c P`.
fn lmi_at(a: &DMatrix<f64>, p: &DMatrix<f64>, dt: f64, c: f64) -> DMatrix<f64> {
    let ap = a.transpose() * p;
    &ap + ap.transpose() + (&ap * a) * dt + p * (2.0 * c)
}

/// The LMI's matrix at each element `E = e_i e_j^T + e_j e_i^T` (`i <= j`, column by column;
/// `e_i e_i^T` for `i = j`) of the symmetric basis, as upper-triangle entries: with `r_i` the
/// i-th row of `A`, `A^T E + E A` has `r_i` in row and column `j` and `r_j` in row and column
/// `i`, `A^T E A = r_i r_j^T + r_j r_i^T`, so each costs `n^2`, not a product of matrices.
fn basis_terms(a: &DMatrix<f64>, dt: f64, c: f64) -> Vec<Vec<(usize, usize, f64)>> {
    let n = a.nrows();
    let mut out = Vec::with_capacity(n * (n + 1) / 2);
    let mut m = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        for i in 0..=j {
            m.fill(0.0);
            let half = if i == j { 0.5 } else { 1.0 };
            // A^T E + E A: (A^T E)_{pq} = a_{ip} [q = j] + a_{jp} [q = i].
            for p in 0..n {
                m[(p, j)] += half * a[(i, p)];
                m[(p, i)] += half * a[(j, p)];
                m[(j, p)] += half * a[(i, p)];
                m[(i, p)] += half * a[(j, p)];
            }
            for p in 0..n {
                for q in 0..n {
                    m[(p, q)] += half * dt * (a[(i, p)] * a[(j, q)] + a[(j, p)] * a[(i, q)]);
                }
            }
            m[(i, j)] += 2.0 * c;
            m[(j, i)] += 2.0 * c * if i == j { 0.0 } else { 1.0 };
            let mut entries = Vec::new();
            for q in 0..n {
                for p in 0..=q {
                    if m[(p, q)] != 0.0 {
                        entries.push((p, q, m[(p, q)]));
                    }
                }
            }
            out.push(entries);
        }
    }
    out
}

/// A `P` for which the LMI holds at rate `c`, on the solver's word and the re-check; `None`
/// where there is none (or the solver's is not one).
fn certified(flows: &[DMatrix<f64>], dt: f64, c: f64) -> Result<Option<DMatrix<f64>>, LmiError> {
    let n = flows[0].nrows();
    // P = sum_k x_k E_k over the symmetric basis, `(i, j)` with `i <= j`, column by column.
    let basis: Vec<(usize, usize)> = (0..n).flat_map(|j| (0..=j).map(move |i| (i, j))).collect();
    let identity = DMatrix::<f64>::identity(n, n);
    let mut lmis: Vec<Lmi> = flows
        .iter()
        .map(|a| Lmi::nsd_sparse(&(&identity * MARGIN), basis_terms(a, dt, c)))
        .collect();
    // delta I - P <= 0 and P - P_MAX I <= 0.
    let entries = |v: f64| basis.iter().map(|&(i, j)| vec![(i, j, v)]).collect();
    lmis.push(Lmi::nsd_sparse(&(&identity * MARGIN), entries(-1.0)));
    lmis.push(Lmi::nsd_sparse(&(&identity * -P_MAX), entries(1.0)));
    let Some(x) = solve(&lmis, &[], &vec![0.0; basis.len()])? else {
        return Ok(None);
    };
    let mut p = DMatrix::zeros(n, n);
    for (&(i, j), xk) in basis.iter().zip(&x) {
        p[(i, j)] = *xk;
        p[(j, i)] = *xk;
    }
    Ok(holds(flows, &p, dt, c).then_some(p))
}

/// The re-check: `P > 0` and the LMI's matrix at most `-MARGIN / 2` for every flow, by their
/// eigenvalues (half the margin asked of the solver: an answer that rounding alone keeps below
/// zero is not believed).
fn holds(flows: &[DMatrix<f64>], p: &DMatrix<f64>, dt: f64, c: f64) -> bool {
    p.clone().symmetric_eigenvalues().min() > 0.0
        && flows.iter().all(|a| {
            let m = lmi_at(a, p, dt, c);
            ((&m + m.transpose()) * 0.5).symmetric_eigenvalues().max() <= -0.5 * MARGIN
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scalar loop `z' = (1 - a dt) z` decays at `a`: the certified rate is `a` within the
    /// bisection's 1 %, and never above it; an unstable map gets none.
    #[test]
    fn a_scalar_loop_is_certified_at_its_rate() {
        let dt = 0.01;
        let phi = DMatrix::from_element(1, 1, 1.0 - 0.5 * dt);
        let d = common_decay(&[phi], dt).unwrap();
        let c = d.decay_per_s.unwrap();
        // |z|^2 shrinks by (1 - a dt)^2 = 1 - 2 a dt + a^2 dt^2: c up to a - a^2 dt / 2.
        assert!(c <= 0.5 && c > 0.49, "{d:?}");
        let grows = DMatrix::from_element(1, 1, 1.0 + 0.1 * dt);
        let d = common_decay(&[grows], dt).unwrap();
        assert_eq!(d.decay_per_s, None);
        assert!(d.spectral_radius > 1.0);
    }

    /// Two maps, each stable on its own, whose switching is not: no common P exists (the
    /// classic pair of rotations that swap their fast and slow axes).
    #[test]
    fn maps_stable_alone_but_not_together_get_no_certificate() {
        let dt = 0.01;
        let flow1 = DMatrix::from_row_slice(2, 2, &[-0.1, 10.0, -0.1, -0.1]);
        let flow2 = DMatrix::from_row_slice(2, 2, &[-0.1, 0.1, -10.0, -0.1]);
        let maps: Vec<DMatrix<f64>> = [flow1, flow2]
            .iter()
            .map(|a| DMatrix::identity(2, 2) + a * dt)
            .collect();
        for m in &maps {
            let alone = common_decay(std::slice::from_ref(m), dt).unwrap();
            assert!(alone.decay_per_s.is_some(), "{alone:?}");
        }
        let both = common_decay(&maps, dt).unwrap();
        assert!(both.spectral_radius < 1.0);
        assert_eq!(both.decay_per_s, None, "{both:?}");
    }
}
