//! `[[cut_ins]]`: the scripted vehicles that cut into the platoon's lane.
use super::checks::{bad, finite};
use crate::error::KeyError;
use crate::schema::Config;

/// `[[cut_ins]]`: the scripted cut-ins, each checked against the platoon and the run.
pub(crate) fn cut_ins(
    c: &Config,
    vehicle_length: f64,
    duration: f64,
) -> Result<Vec<platoon_sim::traffic::CutIn>, KeyError> {
    let n = c.platoon.followers;
    c.cut_ins
        .iter()
        .enumerate()
        .map(|(i, x)| {
            let key = |k: &str| format!("cut_ins[{i}].{k}");
            let nonneg = |k: &str, v: f64| {
                if v.is_finite() && v >= 0.0 {
                    Ok(v)
                } else {
                    bad(&key(k), format!("must be a finite number >= 0, got {v}"))
                }
            };
            let at_s = nonneg("at_s", x.at_s)?;
            if at_s > duration {
                return bad(
                    &key("at_s"),
                    format!("{at_s} s is after the run's end (simulation.duration_s = {duration})"),
                );
            }
            if !(1..=n).contains(&x.ahead_of) {
                return bad(
                    &key("ahead_of"),
                    format!("must name a follower, 1 to {n} (got {})", x.ahead_of),
                );
            }
            let speed_diff_mps = finite(&key("speed_diff_mps"), x.speed_diff_mps)?;
            let gap_m = x.gap_m.map(|g| nonneg("gap_m", g)).transpose()?;
            let decel_mps2 = nonneg("decel_mps2", x.decel_mps2)?;
            let brake_s = nonneg("brake_s", x.brake_s)?;
            let leave_s = match x.leave_s {
                Some(l) if !(l.is_finite() && l > at_s) => {
                    return bad(
                        &key("leave_s"),
                        format!("must be after at_s = {at_s} (got {l})"),
                    )
                }
                l => l,
            };
            let length_m = match x.length_m {
                Some(l) if !(l.is_finite() && l > 0.0) => {
                    return bad(&key("length_m"), format!("must be > 0 (got {l})"))
                }
                Some(l) => l,
                None => vehicle_length,
            };
            Ok(platoon_sim::traffic::CutIn {
                at_s,
                ahead_of: x.ahead_of,
                gap_m,
                speed_diff_mps,
                decel_mps2,
                brake_s,
                leave_s,
                length_m,
            })
        })
        .collect()
}
