//! The Gaussian functions the model is built from, and Gauss-Hermite quadrature for expectations
//! over a normal variable.

use std::f64::consts::{PI, SQRT_2};

/// Upper tail of the standard normal, `Q(z) = P(Z > z)`, accurate in both tails (through
/// `erfc`, so `Q(30)` is about 5e-198, not 0).
pub(crate) fn upper_tail(z: f64) -> f64 {
    if z < -9.0 {
        // 1 - Q(-9) is 1 to within 1e-19, below double precision next to 1.
        return 1.0;
    }
    0.5 * libm::erfc(z / SQRT_2)
}

/// Standard normal cumulative distribution, `P(Z <= z)`.
pub(crate) fn cdf(z: f64) -> f64 {
    upper_tail(-z)
}

/// Standard normal density.
pub(crate) fn density(z: f64) -> f64 {
    if z.abs() > 40.0 {
        return 0.0;
    }
    (-0.5 * z * z).exp() / (2.0 * PI).sqrt()
}

/// Nodes and weights of the `n`-point Gauss-Hermite rule for a standard normal variable: for a
/// smooth `f`, `E[f(Z)] ~ sum_k w_k f(z_k)`, exact for polynomials of degree below `2 n`. The
/// weights sum to one.
///
/// The nodes are the roots of the degree-`n` Hermite polynomial, found by Newton's method on the
/// orthonormal three-term recurrence from the classical asymptotic first guesses (each root seeds
/// the next); the rule is symmetric, so only the positive half is searched.
pub(crate) fn gauss_hermite(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1, "a quadrature rule needs a node");
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let pi_quarter = PI.powf(-0.25);
    // Orthonormal Hermite polynomials (weight exp(-x^2)) at `t`: (p_n, p_{n-1}).
    let eval = |t: f64| {
        let (mut p1, mut p2) = (pi_quarter, 0.0);
        for j in 1..=n {
            let p3 = p2;
            p2 = p1;
            p1 = t * (2.0 / j as f64).sqrt() * p2 - ((j - 1) as f64 / j as f64).sqrt() * p3;
        }
        (p1, p2)
    };
    let nf = n as f64;
    let half = n.div_ceil(2);
    let mut guess = 0.0;
    for i in 0..half {
        guess = match i {
            0 => (2.0 * nf + 1.0).sqrt() - 1.85575 * (2.0 * nf + 1.0).powf(-1.0 / 6.0),
            1 => guess - 1.14 * nf.powf(0.426) / guess,
            2 => 1.86 * guess - 0.86 * x[0],
            3 => 1.91 * guess - 0.91 * x[1],
            _ => 2.0 * guess - x[i - 2],
        };
        let mut t = guess;
        let mut derivative = 1.0;
        for _ in 0..100 {
            let (p, p_prev) = eval(t);
            derivative = (2.0 * nf).sqrt() * p_prev;
            let step = p / derivative;
            t -= step;
            if step.abs() <= 1e-15 * t.abs().max(1.0) {
                break;
            }
        }
        let (_, p_prev) = eval(t);
        derivative = if p_prev != 0.0 {
            (2.0 * nf).sqrt() * p_prev
        } else {
            derivative
        };
        guess = t;
        x[i] = t;
        x[n - 1 - i] = -t;
        w[i] = 2.0 / (derivative * derivative);
        w[n - 1 - i] = w[i];
    }
    // From the weight exp(-x^2) to the standard normal: z = sqrt(2) x, weights over sqrt(pi).
    let nodes = x.iter().map(|t| SQRT_2 * t).collect();
    let weights = w.iter().map(|v| v / PI.sqrt()).collect();
    (nodes, weights)
}

/// `10 log10(10^(a/10) + 10^(b/10))` without overflow.
pub(crate) fn power_sum_dbm(a: f64, b: f64) -> f64 {
    let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
    hi + 10.0 * (10f64.powf((lo - hi) / 10.0)).ln_1p() / std::f64::consts::LN_10
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tails_and_cdf_agree_with_known_values() {
        assert!((cdf(0.0) - 0.5).abs() < 1e-16);
        assert!((cdf(1.959963984540054) - 0.975).abs() < 1e-12);
        assert!((upper_tail(5.0) - 2.866515718791939e-7).abs() < 1e-18);
        assert!((upper_tail(30.0) / 4.906713927148187e-198 - 1.0).abs() < 1e-10);
        assert_eq!(upper_tail(-10.0), 1.0);
        assert!((density(1.0) - 0.24197072451914337).abs() < 1e-16);
    }

    #[test]
    fn gauss_hermite_integrates_the_normal_moments() {
        for n in [1, 2, 5, 12, 20, 40] {
            let (z, w) = gauss_hermite(n);
            let moment = |k: i32| -> f64 { z.iter().zip(&w).map(|(z, w)| w * z.powi(k)).sum() };
            assert!((moment(0) - 1.0).abs() < 1e-12, "n = {n}");
            if n >= 2 {
                assert!((moment(2) - 1.0).abs() < 1e-12, "n = {n}");
            }
            if n >= 3 {
                assert!((moment(4) - 3.0).abs() < 1e-11, "n = {n}");
            }
            if n >= 4 {
                assert!((moment(6) - 15.0).abs() < 1e-10, "n = {n}");
            }
            assert!(
                moment(1).abs() < 1e-12 && moment(3).abs() < 1e-12,
                "n = {n}"
            );
        }
    }
}
