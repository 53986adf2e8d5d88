//! Building the controller a config names: the paper's law or one of the field's, on the one
//! follower pipeline ([`crate::ComposedController`]).
use crate::screening::Detector;
use crate::{Controller, ControllerParams, ParamsError};
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;

/// The controller `params` names, for the followers of `topology` starting from `initial`
/// (leader first): the paper's law ([`crate::PaperLaw`]) or one of the field's, on the one
/// follower pipeline [`crate::ComposedController`] (refused, naming the key, when the topology
/// does not let a follower hear whom a field's law reads).
pub fn build(
    params: &ControllerParams,
    topology: &Topology,
    initial: &[State],
) -> Result<Box<dyn Controller>, ParamsError> {
    build_with(params, topology, initial, Vec::new())
}

/// [`build`] with misbehaviour detectors of the caller's (any [`Detector`]) after those of
/// `params.detection`, under its reaction and quiet period (log, drop, fallback;
/// [`crate::screening`]): how a Rust user adds a detector to a built-in controller, e.g. in a
/// `platoon_sim::ControllerFactory`. The controller reads its radar every step for them.
pub fn build_with(
    params: &ControllerParams,
    topology: &Topology,
    initial: &[State],
    detectors: Vec<Box<dyn Detector>>,
) -> Result<Box<dyn Controller>, ParamsError> {
    params.validate()?;
    let (law, beaconing): (Box<dyn crate::Law>, Box<dyn crate::Beaconing>) =
        match params.law.law(params.fallback.vehicle_length) {
            // The paper's law triggers itself on its estimates.
            None => (
                Box::new(crate::PaperLaw::new(params)),
                Box::new(crate::Periodic { steps: 1 }),
            ),
            Some(law) => {
                check_topology(params, topology)?;
                (law, beaconing(params.rule)?)
            }
        };
    let parts = crate::Composition {
        dt: params.dt,
        beaconing,
        leader_broadcast_steps: params.leader_broadcast_steps,
        spacing: params.spacing,
        headway: params.headway,
        fallback: params.fallback.clone(),
        detection: params.detection.clone(),
        maneuvers: params.maneuvers.clone(),
        security: params.security,
    };
    Ok(Box::new(crate::ComposedController::with_detectors(
        law, parts, topology, initial, detectors,
    )?))
}

/// The beacons of the field's laws: periodic, or by ETSI's CAM rules.
fn beaconing(rule: crate::TriggerRule) -> Result<Box<dyn crate::Beaconing>, ParamsError> {
    match rule {
        crate::TriggerRule::Periodic { period_steps } => Ok(Box::new(crate::Periodic {
            steps: period_steps,
        })),
        crate::TriggerRule::Cam(cam) => Ok(Box::new(cam)),
        _ => Err(ParamsError {
            field: "rule",
            message: "the field's laws beacon periodically or by CAM rules".into(),
        }),
    }
}

/// Whether `topology` lets every follower hear whom the law of `params` reads (the field
/// `preset` for a predecessor or the leader missing, `adjacency` for a consensus row).
pub fn check_topology(params: &ControllerParams, topology: &Topology) -> Result<(), ParamsError> {
    let err = |field, message| ParamsError { field, message };
    let n = topology.followers();
    let (predecessor, leader) = params.law.needs();
    for i in 1..=n {
        let id = VehicleId::follower(i);
        let hears = |j: u16| topology.in_neighbours(id).contains(&VehicleId(j));
        let missing = if predecessor && !hears(id.0 - 1) {
            Some(("its predecessor", id.0 - 1))
        } else if leader && !hears(0) {
            Some(("the leader", 0))
        } else {
            None
        };
        if let Some((whom, j)) = missing {
            return Err(err(
                "preset",
                format!(
                    "law = \"{}\" needs every follower to hear {whom}, but follower {i} does \
                     not hear vehicle {j} in this topology",
                    params.law.name()
                ),
            ));
        }
    }
    if let crate::LawParams::Consensus(c) = &params.law {
        c.check(n + 1).map_err(|(field, m)| err(field, m))?;
        for i in 1..=n {
            for j in (0..=n).filter(|&j| j != i && c.adjacency[i][j] != 0.0) {
                if !topology
                    .in_neighbours(VehicleId::follower(i))
                    .contains(&VehicleId(j as u16))
                {
                    return Err(err(
                        "adjacency",
                        format!(
                            "consensus row {i} listens to vehicle {j}, whom follower {i} does \
                             not hear in this topology"
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}
