//! `[maneuvers]`: joins, leaves, a merge or a split, and the protocol's timing.
use super::checks::{bad, finite, steps_of};
use super::simulation::Grid;
use crate::error::{KeyError, Num};
use crate::schema::{HeadAt, ManeuversConfig};
use platoon_model::VehicleId;

/// `[maneuvers]` for a platoon of `followers` followers at a step of `dt` s; `cut_in_splits`:
/// `[fallback.cut_in] split`, when there is a `[fallback.cut_in]`.
pub(crate) fn maneuvers(
    m: Option<&ManeuversConfig>,
    followers: usize,
    grid: Grid,
    cut_in_splits: Option<bool>,
) -> Result<Option<platoon_control::ManeuverParams>, KeyError> {
    let Some(m) = m else {
        return Ok(None);
    };
    let (dt, duration) = (grid.dt, grid.duration);
    // The step of a maneuver's `at_s`: inside the run, or it never takes effect.
    let step_of = |key: &str, t: f64| -> Result<u64, KeyError> {
        let t = finite(key, t)?;
        if t < 0.0 {
            return bad(key, format!("must be >= 0, got {}", Num(t)));
        }
        if t >= duration {
            return bad(
                key,
                format!(
                    "{} s is not before the run's end (simulation.duration_s = {} s): it would \
                     never happen",
                    Num(t),
                    Num(duration)
                ),
            );
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
    let head_at = |what: &str, g: &Option<HeadAt>| -> Result<Option<(VehicleId, u64)>, KeyError> {
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
    if m.tries == 0 {
        return bad(
            "maneuvers.tries",
            "must be at least 1: a message that wants an answer is sent once at least",
        );
    }
    let params = platoon_control::ManeuverParams {
        timing: platoon_maneuver::Timing {
            reply_steps: u64::from(steps_of("maneuvers.reply_s", m.reply_s, dt)?),
            tries: m.tries,
            maneuver_steps: timeout_steps(m.timeout_s, dt)?,
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
    if let Some(max) = m.max_members {
        let start = params.initial_formation(followers).members().len();
        if max < start {
            return bad(
                "maneuvers.max_members",
                format!(
                    "{max} is fewer than the {start} members the platoon starts with (the \
                     leader counted): the leader would admit nobody; at least {start}"
                ),
            );
        }
    }
    Ok(Some(params))
}

/// `maneuvers.timeout_s` in steps of `dt`: at least one step; a timeout longer than any run
/// saturates (a join that never times out), so that no deadline can overflow.
fn timeout_steps(t: f64, dt: f64) -> Result<u64, KeyError> {
    let key = "maneuvers.timeout_s";
    if finite(key, t)? < dt {
        return bad(
            key,
            format!(
                "{} s is shorter than a step (simulation.dt_s = {} s): a join would be called \
                 off as it is accepted",
                Num(t),
                Num(dt)
            ),
        );
    }
    // `as` saturates at u64::MAX, which the state machines' deadlines keep (saturating adds).
    Ok((t / dt).round() as u64)
}
