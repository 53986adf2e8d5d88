//! `[[cut_ins]]`: the scripted vehicles that cut into the platoon's lane.
use super::checks::{bad, finite};
use super::geometry::{self, Layout};
use crate::error::{KeyError, Num};
use crate::schema::Config;

/// `[[cut_ins]]`: the scripted cut-ins, each checked against the platoon and the run.
pub(crate) fn cut_ins(
    c: &Config,
    layout: &Layout<'_>,
    vehicle_length: f64,
    duration: f64,
) -> Result<Vec<platoon_sim::traffic::CutIn>, KeyError> {
    let mut out = Vec::with_capacity(c.cut_ins.len());
    for i in 0..c.cut_ins.len() {
        let x = cut_in(c, i, vehicle_length, duration)?;
        geometry::cut_in(c, layout, i, &x, &out)?;
        out.push(x);
    }
    Ok(out)
}

/// `[[cut_ins]]` entry `i`, key by key.
fn cut_in(
    c: &Config,
    i: usize,
    vehicle_length: f64,
    duration: f64,
) -> Result<platoon_sim::traffic::CutIn, KeyError> {
    let n = c.platoon.followers;
    let x = &c.cut_ins[i];
    let key = |k: &str| format!("cut_ins[{i}].{k}");
    let nonneg = |k: &str, v: f64| {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            bad(
                &key(k),
                format!("must be a finite number >= 0, got {}", Num(v)),
            )
        }
    };
    let at_s = nonneg("at_s", x.at_s)?;
    if at_s > duration {
        return bad(
            &key("at_s"),
            format!(
                "{} s is after the run's end (simulation.duration_s = {})",
                Num(at_s),
                Num(duration)
            ),
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
                format!("must be after at_s = {} (got {})", Num(at_s), Num(l)),
            )
        }
        l => l,
    };
    let length_m = match x.length_m {
        Some(l) if !(l.is_finite() && l > 0.0) => {
            return bad(&key("length_m"), format!("must be > 0 (got {})", Num(l)))
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
        aggressive: x.aggressive,
    })
}
