//! The largest decay `c` Theorem 1 certifies for a gain: bisections over `c` of the SDPs of
//! [`crate::lmi`].
use crate::certificate::Certificate;
use crate::condition::Coupling;
use crate::error::LmiError;
use crate::lmi::{min_ratio, min_ratio_with, Feasibility, LyapunovForm, Query};

/// The largest decay c (to `tol`) for which (13) is feasible with gain `k`, by bisection on
/// `[0, c_max]`; `None` if it is infeasible already at c = 0.
pub fn theorem1_max_decay(
    k: [f64; 3],
    g: &Coupling,
    taus: &[f64],
    c_max: f64,
    tol: f64,
) -> Result<Option<Certificate>, LmiError> {
    let delta = 1e-6;
    let Feasibility::Feasible(best) = min_ratio(k, 0.0, g, taus, delta, LyapunovForm::Common)?
    else {
        return Ok(None);
    };
    bisect(best, (c_max, tol), |mid| {
        // At the edge of feasibility an answer that fails the re-check, or the solver's
        // numerical trouble, counts as infeasible: the decay returned is certified either way,
        // at worst smaller than the true largest.
        let query = Query {
            k,
            c: mid,
            g,
            taus,
            delta,
        };
        match min_ratio_with(&query, LyapunovForm::Common, 1) {
            Ok(Feasibility::Feasible(c)) => Ok(Some(c)),
            Ok(Feasibility::Infeasible)
            | Err(LmiError::NotCertified(_))
            | Err(LmiError::Solver(_)) => Ok(None),
            Err(e) => Err(e),
        }
    })
}

/// Like [`theorem1_max_decay`], with beta1/beta2 kept at or below `ratio_cap` (a decay bought
/// with an ever larger ratio is useless to the trigger), with the Lyapunov matrix of the
/// `form` given. `None` if even c = 0 needs more.
pub fn max_decay_within_ratio(
    k: [f64; 3],
    g: &Coupling,
    taus: &[f64],
    ratio_cap: f64,
    (c_max, tol): (f64, f64),
    form: LyapunovForm,
) -> Result<Option<Certificate>, LmiError> {
    let delta = 1e-6;
    let within = |c: f64| -> Result<Option<Certificate>, LmiError> {
        let retries = match form {
            LyapunovForm::Common if c != 0.0 => 1,
            _ => u32::MAX,
        };
        let query = Query {
            k,
            c,
            g,
            taus,
            delta,
        };
        match min_ratio_with(&query, form, retries) {
            Ok(Feasibility::Feasible(cert)) if cert.ratio <= ratio_cap => Ok(Some(cert)),
            // At the edge of feasibility, a numerical failure counts as infeasible.
            Ok(_) | Err(LmiError::NotCertified(_)) | Err(LmiError::Solver(_)) => Ok(None),
            Err(e) => Err(e),
        }
    };
    let Some(best) = within(0.0)? else {
        return Ok(None);
    };
    bisect(best, (c_max, tol), within)
}

/// Bisection on `[0, c_max]` to `tol` for the largest decay `within` certifies (`None`: not
/// at that decay), from `best`, the certificate at c = 0.
fn bisect(
    mut best: Certificate,
    (c_max, tol): (f64, f64),
    mut within: impl FnMut(f64) -> Result<Option<Certificate>, LmiError>,
) -> Result<Option<Certificate>, LmiError> {
    let (mut lo, mut hi) = (0.0, c_max);
    while hi - lo > tol {
        let mid = 0.5 * (lo + hi);
        match within(mid)? {
            Some(c) => {
                lo = mid;
                best = c;
            }
            None => hi = mid,
        }
    }
    Ok(Some(best))
}
