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
use crate::{ControllerParams, Delivery, FollowerStep, Packet, ParamsError, RejectCounts};
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
    fn receive(
        &mut self,
        k: u64,
        states: &[State],
        deliveries: &[Delivery],
        jammed: &[bool],
    ) -> &[f64];

    /// The commands of the last [`receive`](Self::receive), followers 1..=N at index i-1.
    fn commands(&self) -> &[f64];

    /// What follower `i` (1-based) did in the last step.
    fn follower_step(&self, i: VehicleId) -> FollowerStep;

    /// Packets refused so far, by reason.
    fn rejected(&self) -> RejectCounts;
}

dyn_clone::clone_trait_object!(Controller);

/// The controller `params` names, for the followers of `topology` starting from `initial`
/// (leader first).
pub fn build(
    params: &ControllerParams,
    topology: &Topology,
    initial: &[State],
) -> Result<Box<dyn Controller>, ParamsError> {
    Ok(Box::new(crate::PlatoonController::new(
        params.clone(),
        topology,
        initial,
    )?))
}
