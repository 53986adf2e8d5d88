//! `[detection]`: the detectors every follower runs and the reaction to a flag.
use super::checks::{bad, finite};
use crate::error::KeyError;
use crate::schema::DetectionConfig;

/// `[detection]`: the detectors in their tables' order and the reaction.
pub(crate) fn detection(
    d: Option<&DetectionConfig>,
    dt: f64,
) -> Result<platoon_control::DetectionParams, KeyError> {
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
