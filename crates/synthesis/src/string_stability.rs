//! String stability: do spacing errors grow along the platoon?
//!
//! Linearised model of the closed loop without events (each follower sees its neighbours
//! exactly), u = -K q: in the Laplace domain every follower obeys
//! `D(s) E_i = -C(s) (H E)_i - k1 h_t s (W E)_i + Z_i` with `D(s) = tau s^3 + s^2` (the
//! third-order vehicle), `C(s) = k3 s^2 + k2 s + k1`, the time headway `h_t` and its weights `W`
//! ([`crate::Coupling`]; 0 for constant spacing), where `E` are the spacing errors to the
//! leader (to the policy's desired distances) and `Z` a disturbance. So `E = T(s) Z` with
//! `T(s) = (D(s) I + C(s) H + k1 h_t s W)^-1`. The amplification of a
//! disturbance entering at follower 1 on its way to follower N is
//! `max over w of |T_N1(jw)| / |T_11(jw)|` (on a log grid of 600 frequencies, 1e-3 to 1e3 rad/s):
//! above 1, errors grow along the platoon (string instability), and for predecessor following it
//! is exactly `max |G(jw)|^(N-1)` with the link transfer function
//! `G(s) = C(s) / (D(s) + C(s) + k1 h_t s)`. Pure, no solver: it holds without OpenBLAS.
use crate::Coupling;
use nalgebra::{Complex, DMatrix};
use serde::Serialize;

/// The string-stability evidence at one tau.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TauStringStability {
    /// The engine lag (s).
    pub tau: f64,
    /// `max |T_N1 / T_11|` over frequency: how much a disturbance at follower 1 grows by the
    /// last follower.
    pub amplification: f64,
    /// The frequency of that maximum (rad/s).
    pub at_rad_s: f64,
    /// `amplification^(1 / (N - 1))`: the growth per follower (above 1: string unstable).
    pub per_follower: f64,
}

/// String stability of a gain on a graph over a set of taus.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StringStability {
    /// Followers of the platoon analysed.
    pub followers: usize,
    /// Whether the amplification stays at or below 1 (within 1e-6) at every tau.
    pub string_stable: bool,
    /// Per tau.
    pub per_tau: Vec<TauStringStability>,
    /// How it was computed.
    pub method: &'static str,
}

/// The method, for reports.
pub const METHOD: &str = "max over w in [1e-3, 1e3] rad/s of |T_N1(jw)| / |T_11(jw)|, T(s) = (D(s) I + C(s) H + k1 h_t s W)^-1, D = tau s^3 + s^2, C = k3 s^2 + k2 s + k1, h_t the time headway (0: constant spacing) (linearised, no events)";

/// The string stability of gain `k` with coupling `g` (graph `H = L + diag(pinning)` and
/// spacing policy) at `taus`.
pub fn string_stability(k: [f64; 3], g: &Coupling, taus: &[f64]) -> StringStability {
    let h = &g.h;
    let n = h.nrows();
    let wc = (g.headway_weights() * (k[0] * g.headway)).map(|x| Complex::new(x, 0.0));
    let freqs: Vec<f64> = (0..600)
        .map(|i| 10f64.powf(-3.0 + 6.0 * f64::from(i) / 599.0))
        .collect();
    let hc = h.map(|x| Complex::new(x, 0.0));
    let per_tau: Vec<TauStringStability> = taus
        .iter()
        .map(|&tau| {
            let mut best = (0.0f64, 0.0f64);
            for &w in &freqs {
                let s = Complex::new(0.0, w);
                let d = s * s * (s * tau + 1.0);
                let c = s * s * k[2] + s * k[1] + k[0];
                let m = DMatrix::<Complex<f64>>::identity(n, n) * d + &hc * c + &wc * s;
                // Column 1 of T: solve (D I + C H) x = e_1.
                let mut e1 = nalgebra::DVector::<Complex<f64>>::zeros(n);
                e1[0] = Complex::new(1.0, 0.0);
                let Some(x) = m.lu().solve(&e1) else {
                    continue;
                };
                let ratio = x[n - 1].norm() / x[0].norm();
                if ratio.is_finite() && ratio > best.0 {
                    best = (ratio, w);
                }
            }
            let per = if n > 1 {
                best.0.powf(1.0 / (n - 1) as f64)
            } else {
                1.0
            };
            TauStringStability {
                tau,
                amplification: best.0,
                at_rad_s: best.1,
                per_follower: per,
            }
        })
        .collect();
    StringStability {
        followers: n,
        string_stable: per_tau.iter().all(|t| t.amplification <= 1.0 + 1e-6),
        per_tau,
        method: METHOD,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_topology::{Preset, Topology};

    const PAPER_K: [f64; 3] = [4.81, 9.12, 2.97];

    fn h(p: Preset, n: usize) -> Coupling {
        Coupling::constant(Topology::preset(p, n).unwrap().h_matrix())
    }

    /// The closed form for predecessor following: |G|^(N-1) at the same frequency.
    fn pf_link_peak(tau: f64) -> f64 {
        pf_headway_link_peak(tau, 0.0)
    }

    #[test]
    fn predecessor_following_with_the_papers_gain_is_string_unstable_and_matches_the_closed_form() {
        let r = string_stability(PAPER_K, &h(Preset::Pf, 10), &[0.34, 0.82]);
        assert!(!r.string_stable);
        for t in &r.per_tau {
            let expected = pf_link_peak(t.tau).powi(9);
            assert!(
                (t.amplification / expected - 1.0).abs() < 1e-6,
                "tau {}: {} vs {expected}",
                t.tau,
                t.amplification
            );
            assert!(t.per_follower > 1.0);
        }
    }

    /// The time-headway link of predecessor following: `C / (D + C + k1 h_t s)`.
    fn pf_headway_link_peak(tau: f64, ht: f64) -> f64 {
        (0..600)
            .map(|i| {
                let w = 10f64.powf(-3.0 + 6.0 * f64::from(i) / 599.0);
                let s = Complex::new(0.0, w);
                let d = s * s * (s * tau + 1.0);
                let c = s * s * PAPER_K[2] + s * PAPER_K[1] + PAPER_K[0];
                (c / (d + c + s * (PAPER_K[0] * ht))).norm()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_time_headway_makes_predecessor_following_string_stable_as_the_closed_form_says() {
        let g = |ht| Coupling::time_headway(h(Preset::Pf, 10).h, ht);
        for ht in [0.3, 1.0] {
            let r = string_stability(PAPER_K, &g(ht), &[0.34, 0.82]);
            for t in &r.per_tau {
                let expected = pf_headway_link_peak(t.tau, ht).powi(9);
                assert!(
                    (t.amplification / expected - 1.0).abs() < 1e-6,
                    "{ht} {t:?}"
                );
            }
        }
        // 0.3 s is not enough at the slow end of the tau range; 1 s is.
        assert!(!string_stability(PAPER_K, &g(0.3), &[0.34, 0.82]).string_stable);
        assert!(string_stability(PAPER_K, &g(1.0), &[0.34, 0.82]).string_stable);
        // Links both ways need less: BPF is string stable from about 0.5 s.
        let bpf = |ht| Coupling::time_headway(h(Preset::Bpf, 10).h, ht);
        assert!(!string_stability(PAPER_K, &bpf(0.0), &[0.5]).string_stable);
        assert!(string_stability(PAPER_K, &bpf(0.6), &[0.34, 0.5, 0.82]).string_stable);
    }

    #[test]
    fn leader_following_damps_errors_along_the_platoon() {
        let r = string_stability(PAPER_K, &h(Preset::Plf, 50), &[0.34, 0.5, 0.82]);
        assert!(r.string_stable, "{r:?}");
        assert!(r.per_tau.iter().all(|t| t.amplification < 1e-3), "{r:?}");
    }
}
