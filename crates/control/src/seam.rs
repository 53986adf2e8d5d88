//! The boundary every front-end drives: one platoon's follower controllers, whatever law,
//! triggering or fallback they use.
//!
//! A co-simulation step `k` is two calls with the network in between (the module docs of the
//! crate): [`Controller::transmit`] decides who broadcasts, [`Controller::receive`] takes what
//! the network delivered and returns every follower's command. Between them the caller may give
//! the plant's radar view ([`Controller::set_radar_truth`]). After `receive`,
//! [`Controller::follower_step`] reports what each follower did, for the outputs, and
//! [`Controller::rejected`] how many packets its checks refused.
//!
//! Implementations are pure and deterministic: the same calls give the same results bit for
//! bit, whoever makes them (the in-process runner and the iceoryx2 controller node). The paper's
//! controller is [`crate::PlatoonController`]; [`build`] makes the one a [`ControllerParams`]
//! names.

use crate::fallback::RadarTruth;
use crate::screening::Detector;
use crate::{
    ControllerParams, Delivery, FollowerStep, Packet, PacketChecks, ParamsError, RejectCounts,
};
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;

/// One platoon's follower controllers behind one boundary (module docs).
pub trait Controller: std::fmt::Debug + Send + dyn_clone::DynClone {
    /// Phase 1 of step `k`: `states[v]` is vehicle v's true state (leader at 0). Appends the
    /// packets broadcast at this step to `out`: the leader's first (if it broadcasts), then the
    /// followers' in order.
    fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>);

    /// What each vehicle's radar would see in the coming [`receive`](Self::receive) (leader
    /// first), as the plant measured it. Without it, controllers that read a radar take the
    /// platoon's predecessor from the states (what the native plant gives).
    fn set_radar_truth(&mut self, truth: &[Option<RadarTruth>]) {
        let _ = truth;
    }

    /// Phase 2 of step `k`: applies the packets the network delivered (`jammed[v]`: vehicle v
    /// sensed its channel jammed during this step) and returns `u_i[k]` for followers 1..=N
    /// (index i-1).
    fn receive(&mut self, k: u64, states: &[State], rx: &[Delivery], jammed: &[bool]) -> &[f64];

    /// The commands of the last [`receive`](Self::receive), followers 1..=N at index i-1.
    fn commands(&self) -> &[f64];

    /// What follower `i` (1-based) did in the last step.
    fn follower_step(&self, i: VehicleId) -> FollowerStep;

    /// The packet checks it runs, if it runs [`PacketChecks`]: what the methods below report
    /// by default (nothing without them).
    fn checks(&self) -> Option<&PacketChecks> {
        None
    }

    /// Packets refused so far, by reason.
    fn rejected(&self) -> RejectCounts {
        self.checks()
            .map(PacketChecks::rejected)
            .unwrap_or_default()
    }

    /// What the misbehaviour detectors said of each packet of the last
    /// [`receive`](Self::receive) (`[detection]`; empty without detectors).
    fn inspections(&self) -> &[crate::Inspection] {
        self.checks().map_or(&[], PacketChecks::inspections)
    }

    /// The detectors' names, in the order of every inspection's verdicts.
    fn detector_names(&self) -> &[&'static str] {
        self.checks().map_or(&[], PacketChecks::detector_names)
    }

    /// Packets the detectors saw, flagged and had refused so far.
    fn screened(&self) -> crate::screening::ScreenCounts {
        self.checks()
            .map(PacketChecks::screened)
            .unwrap_or_default()
    }
}

dyn_clone::clone_trait_object!(Controller);

/// The leader's beacons, which every built-in controller sends for it: its state every
/// `every` steps, with its acceleration over the step before as its command.
#[derive(Debug, Clone, Default)]
pub(crate) struct LeaderBeacon {
    seq: u32,
    last_u: f64,
}

impl LeaderBeacon {
    /// Step `k` (`states[0]` is the leader's): appends its packet to `out` when it is due.
    pub(crate) fn transmit(&mut self, k: u64, every: u32, states: &[State], out: &mut Vec<Packet>) {
        self.transmit_with(k, every, states, None, out);
    }

    /// [`LeaderBeacon::transmit`], also when not due if it carries a maneuver message.
    pub(crate) fn transmit_with(
        &mut self,
        k: u64,
        every: u32,
        states: &[State],
        maneuver: Option<crate::maneuvers::Message>,
        out: &mut Vec<Packet>,
    ) {
        if k.is_multiple_of(u64::from(every)) || maneuver.is_some() {
            self.seq += 1;
            out.push(Packet {
                sender: VehicleId::LEADER,
                seq: self.seq,
                step: k,
                state: states[0],
                u: self.last_u,
                head: VehicleId::LEADER,
                maneuver,
            });
        }
        self.last_u = states[0][2];
    }
}

/// The controller `params` names, for the followers of `topology` starting from `initial`
/// (leader first): the paper's [`crate::PlatoonController`], or one of the field's laws on a
/// [`crate::ComposedController`] (refused, naming the key, when the topology does not let a
/// follower hear whom its law reads).
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
    let Some(law) = params.law.law(params.fallback.vehicle_length) else {
        return Ok(Box::new(crate::PlatoonController::with_detectors(
            params.clone(),
            topology,
            initial,
            detectors,
        )?));
    };
    check_topology(params, topology)?;
    let err = |field, message| ParamsError { field, message };
    let beaconing: Box<dyn crate::Beaconing> = match params.rule {
        crate::TriggerRule::Periodic { period_steps } => Box::new(crate::composed::Periodic {
            steps: period_steps,
        }),
        crate::TriggerRule::Cam(cam) => Box::new(cam),
        _ => {
            return Err(err(
                "rule",
                "the field's laws beacon periodically or by CAM rules".into(),
            ))
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
    };
    Ok(Box::new(crate::ComposedController::with_detectors(
        law, parts, topology, initial, detectors,
    )?))
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
