//! The Rust SDK for controllers: write the controller service of `platoon run --controller`.
//!
//! Implement [`Controller`] for one platoon's followers (two methods per step, because the
//! network sits between them: [`Controller::transmit`] gets what the vehicles measured and
//! returns the broadcasts, [`Controller::receive`] gets what the network delivered and computes
//! every follower's command) and hand a builder to [`run`] from `main`; [`run`] builds one per
//! platoon of the run. Everything else of `docs/controller-contract.md` is done for you: the
//! ports of the run named by `PLATOON_RUN_ID`, READY, waiting on wake-ups (never busy polling),
//! one tx sample per step (each broadcast sent to every out-neighbour of its sender), sorting
//! the rx sample into deliveries and jammed notices, one commands sample per step, DONE with the
//! packets your checks refused, STOP/ABORT, and exiting when `platoon run` is gone.
//!
//! ```no_run
//! use platoon_controller_sdk::{run, Controller, Delivery, FollowerStep, Packet, RejectCounts};
//! use platoon_controller_sdk::{State, VehicleId};
//!
//! /// Every follower brakes gently, whatever it hears; nobody broadcasts but the leader.
//! #[derive(Debug, Clone)]
//! struct Brake {
//!     u: Vec<f64>,
//! }
//!
//! impl Controller for Brake {
//!     fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>) {
//!         out.push(Packet::beacon(VehicleId::LEADER, k as u32 + 1, k, states[0]));
//!     }
//!     fn receive(&mut self, _k: u64, _s: &[State], _d: &[Delivery], _j: &[bool]) -> &[f64] {
//!         self.u.fill(-0.5);
//!         &self.u
//!     }
//!     fn commands(&self) -> &[f64] {
//!         &self.u
//!     }
//!     fn follower_step(&self, i: VehicleId) -> FollowerStep {
//!         FollowerStep { u: self.u[i.index() - 1], ..FollowerStep::default() }
//!     }
//!     fn rejected(&self) -> RejectCounts {
//!         RejectCounts::default()
//!     }
//! }
//!
//! fn main() -> Result<(), platoon_controller_sdk::Error> {
//!     run(|platoon| {
//!         let n = platoon.topology.followers();
//!         Ok::<_, String>(Box::new(Brake { u: vec![0.0; n] }))
//!     })
//! }
//! ```
//!
//! `examples/paper_law.rs` re-implements the paper's controller (u = -K q with the dynamic
//! trigger, the resilient sampling (11) and u = 0 while affected) on this crate and reproduces
//! the built-in run of `configs/paper.toml` byte for byte; `examples/configured.rs` runs the
//! config's own controllers ([`platoon_control::build`], what the built-in controller service
//! runs) as a plug-in. Both run in the tests through `platoon run --controller`. The packet
//! checks every built-in controller applies are [`PacketChecks`], yours to reuse; the field's
//! laws on swappable parts are [`ComposedController`] with your own [`Law`].
#![warn(missing_docs)]

pub use platoon_control::{
    build, ComposedController, Composition, Controller, ControllerParams, Delivery, FallbackMode,
    FollowerStep, Law, Mode, Packet, PacketChecks, RejectCounts, TriggerRule, View,
};
pub use platoon_model::{FreeFlow, State, VehicleId};
pub use platoon_sim::Scenario;
pub use platoon_topology::Topology;

/// Why a controller service could not run.
pub use platoon_runtime::plugin::PluginError as Error;

/// Runs the controllers `make` builds as the controller service of the run `PLATOON_RUN_ID`
/// (its scenario read from `PLATOON_CONFIG`) until the run ends. `make` is called once per
/// platoon, in order, with that platoon's replica of the scenario ([`Scenario::replicas`]: its
/// own initial states; vehicle ids are the platoon's own, leader 0). An error of `make` stops
/// the run and names the controller, with its message. A run of another contract version
/// (`PLATOON_CONTRACT_VERSION`) is refused at once, naming both versions. In runs with
/// `[detection]` every controller's [`Controller::inspections`] go to the run, which measures
/// them against ground truth (`summary.json`'s `detection`, `detections.csv`); detectors of your
/// own are named in `[detection] plugin`, and [`Controller::detector_names`] must be the
/// config's names in order (the built-in tables' first), or empty.
pub fn run<E: std::fmt::Display>(
    mut make: impl FnMut(&Scenario) -> Result<Box<dyn Controller>, E>,
) -> Result<(), Error> {
    let (run_id, scenario) = platoon_runtime::plugin::the_run("controller")?;
    platoon_runtime::plugin::ended(platoon_runtime::controller::run(
        &run_id,
        &scenario,
        |platoon| make(platoon).map_err(|e| e.to_string()),
    ))
}
