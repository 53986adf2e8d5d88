//! Write an attack injector for `platoon run --injector` in Rust.
//!
//! Implement [`Injector`] (one method per step: the step's states and broadcasts in, what each
//! receiver gets out) and hand it to [`run`] from `main`. Everything else of
//! `docs/injector-contract.md` is done for you: the ports of the run named by `PLATOON_RUN_ID`,
//! READY, waiting on wake-ups (never busy polling), one rx sample per step with its `count`,
//! waking the controller, DONE, STOP/ABORT, and exiting when `platoon run` is gone.
//!
//! ```no_run
//! use platoon_injector::{run, Injector, LinkPacket, Step};
//!
//! /// Forwards everything except what vehicle 2 sends.
//! struct DropTwo;
//!
//! impl Injector for DropTwo {
//!     fn step(&mut self, step: &Step<'_>, rx: &mut Vec<LinkPacket>) -> Result<(), String> {
//!         rx.extend(step.tx.iter().filter(|it| it.packet.sender != 2));
//!         Ok(())
//!     }
//! }
//!
//! fn main() -> Result<(), platoon_injector::Error> {
//!     run(|_scenario| DropTwo)
//! }
//! ```
//!
//! `examples/dos_jammer.rs` reproduces the built-in DoS channel byte for byte;
//! `examples/follow_jammer.rs` jams one vehicle wherever it drives (an attack the built-in
//! channel does not have). Both run in the tests through `platoon run --injector`.
#![warn(missing_docs)]

pub use platoon_runtime::injector::{Injector, Step};
pub use platoon_sim::Scenario;
pub use platoon_wire::{LinkPacket, V2vPacket, VehicleState};

use std::path::PathBuf;

/// Why an injector could not run.
#[derive(thiserror::Error)]
pub enum Error {
    /// Not started by `platoon run --injector` (a variable of its environment is missing).
    #[error(
        "{0} is not set: run this program as `platoon run CONFIG --injector \"PROGRAM ARGS\"`"
    )]
    NotInARun(&'static str),
    /// The run's config could not be read.
    #[error("the run's config: {0}")]
    Config(#[from] platoon_config::ConfigError),
    /// The run failed or stopped this injector.
    #[error("{0}")]
    Run(#[from] platoon_runtime::RunError),
}

/// As its message: `fn main() -> Result<(), Error>` prints an error with `Debug`, and the run
/// quotes the injector's last lines of stderr.
impl std::fmt::Debug for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// Runs the injector `make` builds from the run's scenario (read from `PLATOON_CONFIG`) as the
/// injector of the run `PLATOON_RUN_ID`, until the run ends. With `--injector-mode after`
/// (`PLATOON_INJECTOR_INPUT=gated`) each [`Step::tx`] holds what survived the built-in channel:
/// deliveries and jammed notices; forward the notices you want the receivers to see.
/// A run of another contract version (`PLATOON_CONTRACT_VERSION`) is refused at once, naming
/// both versions.
pub fn run<I: Injector>(make: impl FnOnce(&Scenario) -> I) -> Result<(), Error> {
    platoon_runtime::session::check_contract_version()?;
    let run_id = std::env::var("PLATOON_RUN_ID").map_err(|_| Error::NotInARun("PLATOON_RUN_ID"))?;
    let config: PathBuf = std::env::var_os("PLATOON_CONFIG")
        .ok_or(Error::NotInARun("PLATOON_CONFIG"))?
        .into();
    let (_, scenario) = platoon_config::load(&config)?;
    let mut injector = make(&scenario);
    let ports = platoon_runtime::injector::Ports::from_env();
    match platoon_runtime::injector::run_on(ports, &run_id, &scenario, &mut injector) {
        // Stopped by the run (it failed elsewhere, or `platoon run` is gone): nothing to add.
        Err(platoon_runtime::RunError::Aborted(_) | platoon_runtime::RunError::Orphaned) => Ok(()),
        other => other.map_err(Error::from),
    }
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
