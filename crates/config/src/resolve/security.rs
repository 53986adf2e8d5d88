//! `[security]`: signed V2V (docs/security.md).
use super::checks::{bad, finite, positive};
use crate::error::KeyError;
use crate::schema::{
    GroupConfig, GroupMacConfig, ReportsConfig, SecurityConfig, SecurityPolicyConfig,
};
use platoon_control::group_key::{GroupMac, GroupParams};
use platoon_control::security::{FalseReports, ReportParams};
use platoon_control::{SecurityParams, SecurityPolicy};
use platoon_model::VehicleId;

/// `[security]` as the controllers' settings (none when absent): positive periods, whole
/// milliseconds; `detecting`: the run has detectors, whose flags reports need; `maneuvers`:
/// it has `[maneuvers]`, `regroups`: a merge or a split among them; `followers` the
/// platoon's.
pub(crate) fn security(
    s: Option<&SecurityConfig>,
    (detecting, maneuvers, regroups): (bool, bool, bool),
    followers: usize,
) -> Result<Option<SecurityParams>, KeyError> {
    let Some(s) = s else {
        return Ok(None);
    };
    let ms = |key: &str, x: f64, zero: bool| -> Result<u64, KeyError> {
        let x = if zero {
            finite(key, x)?
        } else {
            positive(key, x)?
        };
        if x < 0.0 {
            return bad(key, "must be >= 0");
        }
        let v = x * 1e3;
        if (v - v.round()).abs() > 1e-6 * v.max(1.0) || v > 1e15 {
            return bad(
                key,
                format!("must be a whole number of milliseconds (got {x} s)"),
            );
        }
        Ok(v.round() as u64)
    };
    Ok(Some(SecurityParams {
        policy: match s.policy {
            SecurityPolicyConfig::Every => SecurityPolicy::Every,
            SecurityPolicyConfig::OnDemand => SecurityPolicy::OnDemand,
        },
        certificate_period_ms: ms(
            "security.certificate_period_s",
            s.certificate_period_s,
            false,
        )?,
        pseudonym_change_ms: ms("security.pseudonym_change_s", s.pseudonym_change_s, true)?,
        freshness_ms: ms("security.freshness_s", s.freshness_s, false)?,
        seed: s.seed,
        // Scenario::replica gives each platoon of a fleet its own.
        platoon: 0,
        reports: s
            .reports
            .as_ref()
            .map(|r| reports(r, (detecting, maneuvers), followers, &ms))
            .transpose()?,
        group: s
            .group
            .as_ref()
            .map(|g| group(g, maneuvers, regroups))
            .transpose()?,
    }))
}

/// `[security.group]`, checked.
fn group(g: &GroupConfig, maneuvers: bool, regroups: bool) -> Result<GroupParams, KeyError> {
    if g.mac == GroupMacConfig::Maneuvers && !maneuvers {
        return bad(
            "security.group.mac",
            "\"maneuvers\" tags the maneuver messages, and this run has none: add [maneuvers], \
             or set mac = \"all\" to tag every member's beacons",
        );
    }
    if regroups {
        return bad(
            "security.group",
            "a merge or a split with a group key is not modelled yet (the rear platoon's \
             members would need the key of the platoon they merge into, or a key of their \
             own): remove [security.group] or the merge/split",
        );
    }
    Ok(GroupParams {
        mac: match g.mac {
            GroupMacConfig::Maneuvers => GroupMac::Maneuvers,
            GroupMacConfig::All => GroupMac::All,
        },
    })
}

/// `[security.reports]`, checked.
fn reports(
    r: &ReportsConfig,
    (detecting, maneuvers): (bool, bool),
    followers: usize,
    ms: &dyn Fn(&str, f64, bool) -> Result<u64, KeyError>,
) -> Result<ReportParams, KeyError> {
    if !detecting {
        return bad(
            "security.reports",
            "reports are filed when a detector flags a packet: add a detector ([detection] \
             with `plausibility`, `radar_cross` or `residual`)",
        );
    }
    if !maneuvers {
        return bad(
            "security.reports",
            "a revoked member is ejected through the leave protocol: add [maneuvers] (without \
             it the member would stay in the lane, its packets refused, and the followers \
             behind it would steer on what they last heard of it)",
        );
    }
    let loss = finite("security.reports.loss", r.loss)?;
    if !(0.0..1.0).contains(&loss) {
        return bad(
            "security.reports.loss",
            format!("must be a probability in [0, 1), got {loss}"),
        );
    }
    if r.quorum == 0 {
        return bad(
            "security.reports.quorum",
            "must be >= 1 (distinct reporting vehicles)",
        );
    }
    let false_reports = match &r.false_reports {
        None => None,
        Some(f) => {
            let key = "security.reports.false_reports";
            for (name, v) in [("reporter", f.reporter), ("accused", f.accused)] {
                if usize::from(v) > followers {
                    return bad(
                        &format!("{key}.{name}"),
                        format!("vehicle {v} does not exist (ids are 0 = leader to {followers})"),
                    );
                }
            }
            if f.reporter == f.accused {
                return bad(
                    &format!("{key}.accused"),
                    "the reporter would accuse itself: name another vehicle",
                );
            }
            let start = finite(&format!("{key}.start_s"), f.start_s)?;
            if start < 0.0 {
                return bad(&format!("{key}.start_s"), "must be >= 0");
            }
            if f.end_s.is_nan() || f.end_s <= start {
                return bad(
                    &format!("{key}.end_s"),
                    format!("must be after start_s = {start}"),
                );
            }
            let to_ms = |x: f64| (x * 1e3).round() as u64;
            Some(FalseReports {
                reporter: VehicleId(f.reporter),
                accused: VehicleId(f.accused),
                start_ms: to_ms(start),
                end_ms: if f.end_s.is_finite() {
                    to_ms(f.end_s)
                } else {
                    u64::MAX
                },
            })
        }
    };
    Ok(ReportParams {
        false_reports,
        latency_ms: ms("security.reports.latency_s", r.latency_s, true)?,
        loss,
        quorum: r.quorum as usize,
        window_ms: ms("security.reports.window_s", r.window_s, false)?,
        every_ms: ms("security.reports.every_s", r.every_s, false)?,
    })
}
