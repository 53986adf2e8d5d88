//! `[control]`, `[fallback]`, `[radar]`, `[guard]` and `[detection]`: what the followers run.
use super::{bad, finite, steps_of, Invalid};
use crate::schema::*;
use platoon_model::VehicleId;

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
                split: h.split,
            }),
            None => None,
        },
        vehicle_length,
        lengths: Vec::new(),
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

/// `[[cut_ins]]`: the scripted cut-ins, each checked against the platoon and the run.
pub(super) fn cut_ins(
    c: &Config,
    vehicle_length: f64,
    duration: f64,
) -> Result<Vec<platoon_sim::traffic::CutIn>, Invalid> {
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

/// `[maneuvers]` for a platoon of `followers` followers at a step of `dt` s; `cut_in_splits`:
/// `[fallback.cut_in] split`, when there is a `[fallback.cut_in]`.
pub(super) fn maneuvers(
    m: Option<&ManeuversConfig>,
    followers: usize,
    dt: f64,
    cut_in_splits: Option<bool>,
) -> Result<Option<platoon_control::ManeuverParams>, Invalid> {
    let Some(m) = m else {
        return Ok(None);
    };
    let step_of = |key: &str, t: f64| -> Result<u64, Invalid> {
        let t = finite(key, t)?;
        if t < 0.0 {
            return bad(key, format!("must be >= 0, got {t}"));
        }
        Ok((t / dt).round() as u64)
    };
    // (vehicle, step) of each entry of `[[maneuvers.<what>]]`, given as (vehicle, at_s).
    let at = |what: &str, list: &mut dyn Iterator<Item = (usize, f64)>| {
        let mut out = Vec::new();
        for (i, (vehicle, at_s)) in list.enumerate() {
            let key = format!("maneuvers.{what}[{i}]");
            if vehicle == 0 || vehicle > followers {
                return bad(
                    &format!("{key}.vehicle"),
                    format!("must be a follower, 1 to {followers} (got {vehicle})"),
                );
            }
            let step = step_of(&format!("{key}.at_s"), at_s)?;
            out.push((VehicleId(vehicle as u16), step));
        }
        Ok(out)
    };
    let mut joins = Vec::with_capacity(m.joins.len());
    let spec = at("joins", &mut m.joins.iter().map(|j| (j.vehicle, j.at_s)))?;
    for (i, ((vehicle, at_step), j)) in spec.into_iter().zip(&m.joins).enumerate() {
        let behind = match j.behind {
            Some(b) if b > followers => {
                return bad(
                    &format!("maneuvers.joins[{i}].behind"),
                    format!("must be a member, 0 to {followers} (got {b})"),
                )
            }
            Some(_) if cut_in_splits == Some(true) => {
                return bad(
                    &format!("maneuvers.joins[{i}].behind"),
                    "a join from the lane beside lets the member that opens its gap head the \
                     members behind it; it cannot also split behind a cut-in \
                     ([fallback.cut_in] split = false)",
                )
            }
            b => b.map(|b| VehicleId(b as u16)),
        };
        joins.push(platoon_control::JoinSpec {
            vehicle,
            at_step,
            behind,
        });
    }
    let leaves = at("leaves", &mut m.leaves.iter().map(|l| (l.vehicle, l.at_s)))?
        .into_iter()
        .map(|(vehicle, at_step)| platoon_control::LeaveSpec { vehicle, at_step })
        .collect();
    // (head, step) of `[maneuvers.<what>]`, a merge or a split.
    let head_at =
        |what: &str, g: &Option<crate::HeadAt>| -> Result<Option<(VehicleId, u64)>, Invalid> {
            let Some(g) = g else { return Ok(None) };
            if g.head == 0 || g.head > followers {
                return bad(
                    &format!("maneuvers.{what}.head"),
                    format!("must be a follower, 1 to {followers} (got {})", g.head),
                );
            }
            let step = step_of(&format!("maneuvers.{what}.at_s"), g.at_s)?;
            Ok(Some((VehicleId(g.head as u16), step)))
        };
    if let (Some(what), Some(true)) = (
        m.merge
            .as_ref()
            .map(|_| "merge")
            .or(m.split.as_ref().map(|_| "split")),
        cut_in_splits,
    ) {
        return bad(
            &format!("maneuvers.{what}"),
            "a run with a merge or a split keeps who heads whom in its formations; it cannot \
             also split behind a cut-in ([fallback.cut_in] split = false)"
                .to_string(),
        );
    }
    let merge = head_at("merge", &m.merge)?
        .map(|(head, at_step)| platoon_control::MergeSpec { head, at_step });
    let split = head_at("split", &m.split)?
        .map(|(head, at_step)| platoon_control::SplitSpec { head, at_step });
    let params = platoon_control::ManeuverParams {
        timing: platoon_maneuver::Timing {
            reply_steps: u64::from(steps_of("maneuvers.reply_s", m.reply_s, dt)?),
            tries: m.tries,
            maneuver_steps: step_of("maneuvers.timeout_s", m.timeout_s)?,
        },
        joins,
        leaves,
        merge,
        split,
        in_position_m: m.in_position_m,
        in_position_mps: m.in_position_mps,
        max_members: m.max_members.unwrap_or(followers + 1),
        check_reports: m.check_reports,
    };
    params
        .validate(followers)
        .or_else(|(field, message)| bad(&format!("maneuvers.{field}"), message))?;
    Ok(Some(params))
}
