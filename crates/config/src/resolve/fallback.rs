//! `[fallback]`, `[radar]` and `[guard]` (and the older `control.attack_input`): what a follower
//! does while affected by an attack, and how it comes back.
use super::checks::{bad, steps_of};
use crate::error::KeyError;
use crate::schema::Config;

/// Every follower's fallback: `fallback.mode`, or `control.attack_input`, its older name (not
/// both, unless they agree); the paper's `zero` without either.
pub(crate) fn mode(c: &Config) -> Result<platoon_control::FallbackMode, KeyError> {
    match (c.control.attack_input, c.fallback.mode) {
        (Some(old), Some(new)) if old != new => bad(
            "control.attack_input",
            format!(
                "is the older name of fallback.mode, which says {:?}: set only fallback.mode",
                new
            ),
        ),
        (_, Some(m)) | (Some(m), None) => Ok(m),
        (None, None) => Ok(platoon_control::FallbackMode::Zero),
    }
}

/// `[fallback]`, `[radar]` and `[guard]` (and the older `control.attack_input`).
pub(crate) fn fallback(
    c: &Config,
    dt: f64,
    vehicle_length: f64,
) -> Result<platoon_control::FallbackParams, KeyError> {
    let f = &c.fallback;
    let mode = mode(c)?;
    let steps = |key: &str, s: f64| -> Result<u32, KeyError> {
        if s == 0.0 {
            Ok(0)
        } else {
            steps_of(key, s, dt)
        }
    };
    let r = &c.radar;
    let g = &c.guard;
    let acc = platoon_control::FallbackMode::Acc;
    let uses_radar = g.enabled
        || f.cut_in.is_some()
        || mode == acc
        || f.per_vehicle.as_ref().is_some_and(|p| p.contains(&acc));
    let params = platoon_control::FallbackParams {
        mode,
        per_vehicle: f.per_vehicle.clone().unwrap_or_default(),
        dwell_steps: steps("fallback.dwell_s", f.dwell_s)?,
        blend_steps: steps("fallback.blend_s", f.blend_s)?,
        closing_mps: f.closing_mps,
        acc: f.acc,
        radar: platoon_control::fallback::RadarParams {
            range_m: r.range_m,
            // Checked against the step only where something reads the radar, so a config with
            // another dt needs no [radar] it does not use.
            period_steps: if uses_radar {
                steps_of("radar.period_s", r.period_s, dt)?
            } else {
                ((r.period_s / dt).round().max(1.0)).min(f64::from(u32::MAX)) as u32
            },
            noise_m: r.noise_m,
            noise_mps: r.noise_mps,
            dropout: r.dropout,
            seed: r.seed,
        },
        guard: g.enabled.then_some(platoon_control::fallback::GuardParams {
            ttc_s: g.ttc_s,
            decel_mps2: g.decel_mps2,
        }),
        cut_in: match &f.cut_in {
            Some(h) => Some(platoon_control::fallback::CutInParams {
                dwell_steps: steps("fallback.cut_in.dwell_s", h.dwell_s)?,
                blend_steps: steps("fallback.cut_in.blend_s", h.blend_s)?,
                // Absent: what the law and graph need, set by `control::cut_in_split`.
                split: h.split.unwrap_or(false),
            }),
            None => None,
        },
        vehicle_length,
        lengths: Vec::new(),
        silence_steps: f
            .silence_s
            .map(|x| steps_of("fallback.silence_s", x, dt))
            .transpose()?,
    };
    params
        .validate(c.platoon.followers)
        .or_else(|(key, message)| {
            let key = if key.starts_with("radar.") || key.starts_with("guard.") {
                key.to_string()
            } else {
                format!("fallback.{key}")
            };
            bad(&key, message)
        })?;
    Ok(params)
}
