//! The Rust SDK for attack injectors: write an attack once, run it in process and in
//! `platoon run --injector`.
//!
//! Implement [`Injector`] (the pure seam of `platoon-attacks`: one platoon, one step; its
//! broadcasts and true states in, what each receiver gets out) and hand an
//! [`InjectorFactory`] that makes it to [`run`] from `main`: one injector per platoon of the
//! run, adapted to the wire for you. The same factory runs the attack in process, with no
//! process at all: in a run ([`platoon_sim::run_until_plugins`]), in a campaign or in
//! `platoon search` (`platoon_app`'s `LocalPool::injector`), with the same results.
//!
//! ```no_run
//! use platoon_injector_sdk::{run, InjectError, Injector, InjectorFactory, Reception, Step};
//!
//! /// Drops everything vehicle 2 sends.
//! #[derive(Debug, Clone)]
//! struct DropTwo;
//!
//! impl Injector for DropTwo {
//!     fn step(&mut self, step: &Step<'_>, out: &mut Reception<'_>) -> Result<(), InjectError> {
//!         for p in step.tx.iter().filter(|p| p.sender.0 != 2) {
//!             for &receiver in step.topology.out_neighbours(p.sender) {
//!                 out.deliveries.push(platoon_injector_sdk::Delivery { receiver, packet: *p });
//!             }
//!         }
//!         Ok(())
//!     }
//! }
//!
//! fn main() -> Result<(), platoon_injector_sdk::Error> {
//!     run(InjectorFactory::new(|_scenario| Ok(Box::new(DropTwo))))
//! }
//! ```
//!
//! An injector that works on the wire itself (the run's numbering, the jammed notices of the
//! channel before it with `--injector-mode after`) implements [`WireInjector`] and goes to
//! [`run_wire`]. Everything else of `docs/injector-contract.md` is done for you either way: the
//! ports of the run named by `PLATOON_RUN_ID`, READY, waiting on wake-ups (never busy
//! polling), one rx sample per step with its `count`, waking the controller, DONE, STOP/ABORT,
//! and exiting when `platoon run` is gone.
//!
//! `examples/link_cut.rs` cuts one link for a window on the pure seam;
//! `examples/dos_jammer.rs` reproduces the built-in DoS channel byte for byte on the wire;
//! `examples/follow_jammer.rs` jams one vehicle wherever it drives (an attack the built-in
//! channel does not have). They run in the tests through `platoon run --injector`.
#![warn(missing_docs)]

pub use platoon_attacks::channel::{Action, Channel, ChannelEvent, RadioStats};
pub use platoon_attacks::inject::{InjectError, Injector, Reception, Step};
pub use platoon_model::{State, VehicleId};
pub use platoon_runtime::injector::{WireInjector, WireStep};
pub use platoon_sim::{InjectorFactory, Scenario};
pub use platoon_topology::Topology;
pub use platoon_v2v::{Delivery, Packet};
pub use platoon_wire::{LinkPacket, V2vPacket, VehicleState};

/// Why an injector could not run.
pub use platoon_runtime::plugin::PluginError as Error;

/// Runs the injectors `factory` makes (one per platoon, from its replica of the scenario read
/// from `PLATOON_CONFIG`) as the injector of the run `PLATOON_RUN_ID`, until the run ends. A
/// run of another contract version (`PLATOON_CONTRACT_VERSION`) is refused at once, naming
/// both versions.
pub fn run(factory: InjectorFactory) -> Result<(), Error> {
    let (run_id, scenario) = platoon_runtime::plugin::the_run("injector")?;
    let ended = platoon_runtime::injector::Platoons::new(&scenario, &factory, None).and_then(
        |mut platoons| {
            let ports = platoon_runtime::injector::Ports::from_env();
            platoon_runtime::injector::run_on(ports, &run_id, &scenario, &mut platoons)
        },
    );
    platoon_runtime::plugin::ended(ended)
}

/// Runs the wire injector `make` builds from the run's scenario (read from `PLATOON_CONFIG`)
/// as the injector of the run `PLATOON_RUN_ID`, until the run ends. With `--injector-mode
/// after` (`PLATOON_INJECTOR_INPUT=gated`) each [`WireStep::tx`] holds what survived the
/// built-in channel: deliveries and jammed notices; forward the notices you want the
/// receivers to see. A run of another contract version (`PLATOON_CONTRACT_VERSION`) is refused
/// at once, naming both versions.
pub fn run_wire<I: WireInjector>(make: impl FnOnce(&Scenario) -> I) -> Result<(), Error> {
    let (run_id, scenario) = platoon_runtime::plugin::the_run("injector")?;
    let mut injector = make(&scenario);
    let ports = platoon_runtime::injector::Ports::from_env();
    platoon_runtime::plugin::ended(platoon_runtime::injector::run_on(
        ports,
        &run_id,
        &scenario,
        &mut injector,
    ))
}

/// Vehicle numbering on the wire: vehicle `i` of platoon `j` is `j * (N + 1) + i`.
#[derive(Debug, Clone, Copy)]
pub struct Numbering {
    /// N + 1.
    pub per_platoon: u32,
    /// Number of platoons.
    pub platoons: u32,
}

impl Numbering {
    /// The numbering of `scenario`.
    pub fn of(scenario: &Scenario) -> Self {
        Self {
            per_platoon: scenario.vehicles_per_platoon() as u32,
            platoons: scenario.fleet.platoons as u32,
        }
    }

    /// Every vehicle's wire id.
    pub fn all(&self) -> impl Iterator<Item = u32> {
        0..self.per_platoon * self.platoons
    }

    /// The wire id of vehicle `i` of platoon `j`.
    pub fn global(&self, j: u32, i: u32) -> u32 {
        j * self.per_platoon + i
    }

    /// Vehicle `i` (within its platoon) of a wire id.
    pub fn local(&self, id: u32) -> u32 {
        id % self.per_platoon
    }
}

/// A jammed notice for `receiver`.
pub fn jammed(receiver: u32) -> LinkPacket {
    LinkPacket {
        receiver,
        kind: LinkPacket::JAMMED,
        packet: V2vPacket::default(),
    }
}
