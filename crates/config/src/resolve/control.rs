//! `[control]`: the law, its keys, and how it fits the platoon (its spacing policy, its
//! vehicles' lengths, the topology, a split behind a cut-in, maneuvers).
use super::checks::{bad, finite, positive};
use super::platoon::Shape;
use crate::error::{KeyError, Reason};
use crate::schema::{Config, Control};
use nalgebra::RowVector3;
use platoon_control::{ControllerParams, FallbackParams, LawParams};
use platoon_model::VehicleId;
use platoon_sim::Vehicle;
use platoon_topology::Topology;

/// The paper's law's gain and weights (the paper's own with another law): `(K, beta1, beta2)`.
pub(crate) fn paper_gains(c: &Control) -> Result<(RowVector3<f64>, f64, f64), KeyError> {
    let k = c.paper_law();
    for (i, g) in k.gain.iter().enumerate() {
        finite(&format!("control.gain[{i}]"), *g)?;
    }
    let beta1 = positive("control.beta1", k.beta1)?;
    let beta2 = positive("control.beta2", k.beta2)?;
    Ok((
        RowVector3::new(k.gain[0], k.gain[1], k.gain[2]),
        beta1,
        beta2,
    ))
}

/// The law of `[control]`.
pub(crate) fn law(c: &Control) -> LawParams {
    c.law.clone()
}

/// Whether the platoon splits behind a car that cut in, `[fallback.cut_in] split`: as written,
/// or, absent, where a follower would otherwise steer on a vehicle ahead of the car: a law
/// that follows the head of its part ([`LawParams::follows_head`]) whose followers steer on a
/// vehicle ahead of their predecessor ([`steers_beyond_predecessor`]), in a run whose
/// `[maneuvers]` neither merge nor split (a maneuver's head is not also a cut-in's). `None`
/// without `[fallback.cut_in]`.
pub(crate) fn cut_in_split(c: &Config, law: &LawParams, topology: &Topology) -> Option<bool> {
    let h = c.fallback.cut_in.as_ref()?;
    Some(h.split.unwrap_or_else(|| {
        let regroups = c
            .maneuvers
            .as_ref()
            .is_some_and(|m| m.merge.is_some() || m.split.is_some());
        law.follows_head() && steers_beyond_predecessor(law, topology) && !regroups
    }))
}

/// Whether some follower of `law` on `topology` steers on a vehicle ahead of its predecessor:
/// the laws that read the leader (but follower 1, whose predecessor it is), the paper's law
/// where the graph has a follower hear a vehicle ahead of its predecessor.
fn steers_beyond_predecessor(law: &LawParams, topology: &Topology) -> bool {
    let n = topology.followers();
    if law.is_paper() {
        (2..=n).any(|i| {
            topology
                .in_neighbours(VehicleId(i as u16))
                .iter()
                .any(|j| j.index() + 1 < i)
        })
    } else {
        law.needs().1 && n >= 2
    }
}

/// The law fits the platoon: a split behind a cut-in needs a law that reads the leader, and
/// the field's laws keep one vehicle length and the platoon's spacing policy.
pub(crate) fn check_law(
    law: &LawParams,
    fallback: &FallbackParams,
    vehicles: &[Vehicle],
    shape: &Shape,
) -> Result<(), KeyError> {
    if !law.follows_head() && fallback.cut_in.is_some_and(|h| h.split) {
        return bad(
            "fallback.cut_in.split",
            format!(
                "law = \"{}\" has no leader to re-point (it reads its predecessor alone): \
                 split behind a cut-in works with the laws that follow the head of their part, \
                 control.law = \"paper\", \"path_cacc\", \"flatbed\" or \"consensus\"",
                law.name()
            ),
        );
    }
    if law.is_paper() {
        return Ok(());
    }
    let vehicle_length = shape.vehicle_length;
    if vehicles.iter().any(|v| v.length_m != vehicle_length) {
        return bad(
            "platoon.members",
            format!(
                "law = \"{}\" keeps one vehicle length (platoon.vehicle_length_m = \
                 {vehicle_length} m), but the members' classes give others: use law = \"paper\" \
                 with vehicle classes of other lengths",
                law.name()
            ),
        );
    }
    spacing_policy(law, shape)
}

/// The outputs measure every law against the platoon's spacing policy: it must be the one
/// the law keeps.
fn spacing_policy(law: &LawParams, shape: &Shape) -> Result<(), KeyError> {
    let Shape {
        spacing,
        headway,
        vehicle_length,
        ..
    } = *shape;
    let name = law.name();
    let Some((l, h)) = law.spacing_policy(vehicle_length) else {
        return bad(
            "control.headways_s",
            "the outputs need one time headway for every vehicle",
        );
    };
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
    if close(spacing, l) && close(headway, h) {
        return Ok(());
    }
    let policy = if h == 0.0 {
        "spacing_policy = \"constant\"".to_string()
    } else {
        format!("spacing_policy = \"time_headway\", time_headway_s = {h}")
    };
    bad(
        if !close(spacing, l) {
            "platoon.spacing_m"
        } else if headway > 0.0 && h > 0.0 {
            "platoon.time_headway_s"
        } else {
            "platoon.spacing_policy"
        },
        format!(
            "law = \"{name}\" keeps {l} m + {h} s x v front to front (its distances in \
             [control] plus platoon.vehicle_length_m), the platoon says {spacing} m + \
             {headway} s x v: set spacing_m = {l} and {policy} in [platoon], or change \
             the law's distances in [control]"
        ),
    )
}

/// The controller's own checks of `params` and of the topology it runs on, each error at the
/// key of the table it belongs to (`trigger.rho`, `topology.preset`, `control.adjacency`).
pub(crate) fn check_controller(
    params: &ControllerParams,
    topology: &Topology,
) -> Result<(), KeyError> {
    let e = match params
        .validate()
        .and_then(|()| platoon_control::check_topology(params, topology))
    {
        Ok(()) => return Ok(()),
        Err(e) => e,
    };
    const TRIGGER: [&str; 10] = [
        "phi",
        "rho",
        "eta",
        "mu",
        "period",
        "h",
        "rule",
        "min_interval_s",
        "position_m",
        "speed_mps",
    ];
    Err(match e.field {
        "preset" => KeyError::new("topology.preset", Reason::Unheard(e.message)),
        "maneuvers" => KeyError::new("maneuvers", Reason::LawWithoutManeuvers(e.message)),
        field if TRIGGER.contains(&field) => {
            KeyError::invalid(format!("trigger.{field}"), e.message)
        }
        field => KeyError::invalid(format!("control.{field}"), e.message),
    })
}
