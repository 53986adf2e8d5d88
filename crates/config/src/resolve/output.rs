//! `[output]`: the per-step files.
use super::checks::bad;
use crate::error::KeyError;
use crate::schema::OutputConfig;

/// `output.decimate` keeps at least every step.
pub(crate) fn check(o: &OutputConfig) -> Result<(), KeyError> {
    if o.decimate == 0 {
        return bad("output.decimate", "must be at least 1 (every step)");
    }
    Ok(())
}
