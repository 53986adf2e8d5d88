//! `[attack]`: the DoS schedule and the bounds of Assumption 2.
use super::checks::bad;
use crate::error::KeyError;
use crate::schema::{Attack, DosConfig};
use platoon_attacks::{DosSchedule, RandomDos};

/// The DoS schedule of `[attack]` over a run of `duration` s (and `assumption2`, checked).
pub(crate) fn dos(a: &Attack, duration: f64) -> Result<DosSchedule, KeyError> {
    if let Some(b) = &a.assumption2 {
        b.validate()
            .or_else(|e| bad("attack.assumption2", e.to_string()))?;
    }
    Ok(match &a.kind {
        DosConfig::None {} => DosSchedule::none(),
        DosConfig::Intervals { intervals } => {
            let pairs: Vec<(f64, f64)> = intervals.iter().map(|p| (p[0], p[1])).collect();
            DosSchedule::from_intervals(&pairs)
                .or_else(|e| bad("attack.intervals", e.to_string()))?
        }
        DosConfig::Periodic {
            period_s,
            duration_s,
            offset_s,
        } => DosSchedule::periodic(*period_s, *duration_s, *offset_s, duration)
            .or_else(|e| bad("attack.period_s", e.to_string()))?,
        DosConfig::Random {
            seed,
            min_gap_s,
            max_gap_s,
            min_duration_s,
            max_duration_s,
        } => {
            let Some(bounds) = &a.assumption2 else {
                return bad(
                    "attack.assumption2",
                    "is required with kind = \"random\" (the generator satisfies these bounds)",
                );
            };
            let generator = RandomDos {
                seed: *seed,
                min_gap: *min_gap_s,
                max_gap: *max_gap_s,
                min_duration: *min_duration_s,
                max_duration: *max_duration_s,
            };
            generator
                .generate(bounds, duration)
                .or_else(|e| bad("attack", e.to_string()))?
        }
    })
}
