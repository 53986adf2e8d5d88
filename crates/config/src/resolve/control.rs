//! `[control]`, `[fallback]`, `[radar]`, `[guard]` and `[detection]`: what the followers run.
use super::{bad, finite, steps_of, Invalid};
use crate::schema::*;

/// `[fallback]`, `[radar]` and `[guard]` (and the older `control.attack_input`).
pub(super) fn fallback(
    c: &Config,
    dt: f64,
    vehicle_length: f64,
) -> Result<platoon_control::FallbackParams, Invalid> {
    let f = &c.fallback;
    let mode = match (c.control.attack_input, f.mode) {
        (Some(old), Some(new)) if old != new => {
            return bad(
                "control.attack_input",
                format!(
                    "is the older name of fallback.mode, which says {:?}: set only fallback.mode",
                    new
                ),
            )
        }
        (_, Some(m)) | (Some(m), None) => m,
        (None, None) => platoon_control::FallbackMode::Zero,
    };
    let steps = |key: &str, s: f64| -> Result<u32, Invalid> {
        if s == 0.0 {
            Ok(0)
        } else {
            steps_of(key, s, dt)
        }
    };
    let r = &c.radar;
    let g = &c.guard;
    let acc = platoon_control::FallbackMode::Acc;
    let uses_radar =
        g.enabled || mode == acc || f.per_vehicle.as_ref().is_some_and(|p| p.contains(&acc));
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
        vehicle_length,
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

/// `[detection]`: the detectors in their tables' order and the reaction.
pub(super) fn detection(
    d: Option<&DetectionConfig>,
    dt: f64,
) -> Result<platoon_control::DetectionParams, Invalid> {
    let Some(d) = d else {
        return Ok(Default::default());
    };
    let tables = platoon_detect::Detection {
        plausibility: d.plausibility,
        radar_cross: d.radar_cross,
        residual: d.residual,
    };
    tables.validate().or_else(|e| {
        bad(
            &format!("detection.{}.{}", e.detector, e.field),
            e.to_string(),
        )
    })?;
    let specs = tables.specs();
    if specs.is_empty() && d.plugin.is_empty() {
        return bad(
            "detection",
            "turns no detector on: add [detection.plausibility], [detection.radar_cross] or \
             [detection.residual] (an empty table takes the defaults), name a plug-in's \
             detectors in plugin = [...], or remove [detection]",
        );
    }
    for (i, name) in d.plugin.iter().enumerate() {
        let key = format!("detection.plugin[{i}]");
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return bad(
                &key,
                format!("{name:?} is not a detector name (letters, digits, _ and - only)"),
            );
        }
        if platoon_detect::DetectorSpec::NAMES.contains(&name.as_str()) {
            return bad(
                &key,
                format!("{name:?} is a built-in detector: turn it on with [detection.{name}]"),
            );
        }
        if d.plugin[..i].contains(name) {
            return bad(&key, format!("names {name:?} twice"));
        }
    }
    if specs.len() + d.plugin.len() > platoon_control::screening::MAX_DETECTORS {
        return bad(
            "detection.plugin",
            format!(
                "makes {} detectors; a platoon runs at most {}",
                specs.len() + d.plugin.len(),
                platoon_control::screening::MAX_DETECTORS
            ),
        );
    }
    let quiet = finite("detection.quiet_s", d.quiet_s)?;
    if quiet < 0.0 {
        return bad("detection.quiet_s", format!("must be >= 0 s (got {quiet})"));
    }
    let quiet_steps = (quiet / dt).round();
    if quiet_steps > f64::from(u32::MAX) {
        return bad("detection.quiet_s", "is longer than any run");
    }
    Ok(platoon_control::DetectionParams {
        specs,
        reaction: d.reaction,
        quiet_steps: quiet_steps as u32,
        plugin: d.plugin.clone(),
    })
}
