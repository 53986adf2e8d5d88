//! The checks every table's resolver shares: finite, positive, a whole number of steps.
use crate::error::{KeyError, Num, Reason};

/// `key` is wrong, as `message` says.
pub(crate) fn bad<T>(key: &str, message: impl Into<String>) -> Result<T, KeyError> {
    Err(KeyError::invalid(key, message))
}

/// `x`, if it is finite.
pub(crate) fn finite(key: &str, x: f64) -> Result<f64, KeyError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(KeyError::new(key, Reason::NotFinite(x)))
    }
}

/// `x`, if it is finite and above zero.
pub(crate) fn positive(key: &str, x: f64) -> Result<f64, KeyError> {
    if finite(key, x)? > 0.0 {
        Ok(x)
    } else {
        Err(KeyError::new(key, Reason::NotPositive(x)))
    }
}

/// A period as a whole number of steps of `dt`.
pub(crate) fn steps_of(key: &str, period: f64, dt: f64) -> Result<u32, KeyError> {
    positive(key, period)?;
    let reason = if period < dt * (1.0 - 1e-9) {
        Reason::ShorterThanStep {
            period_s: period,
            dt_s: dt,
        }
    } else {
        let n = (period / dt).round();
        if n > f64::from(u32::MAX) {
            return Err(KeyError::invalid(
                key,
                format!(
                    "{} s is more steps of {} s than a period may count (at most {} s)",
                    Num(period),
                    Num(dt),
                    Num(f64::from(u32::MAX) * dt)
                ),
            ));
        }
        if (n * dt - period).abs() <= 1e-9 * period.max(1.0) {
            return Ok(n as u32);
        }
        Reason::NotWholeSteps {
            period_s: period,
            dt_s: dt,
        }
    };
    Err(KeyError::new(key, reason))
}
