//! The operations of `platoon` as a library, under every front-end (the `platoon` binary, the
//! Python package, a notebook, a Dask task): run a scenario in process or co-simulated over
//! iceoryx2, one platoon or a fleet, native or SUMO ([`run`]); LMI design: check a gain,
//! synthesise one, re-check a certificate, the DoS bounds ([`design`]); the paper's Section IV
//! experiments and ours ([`experiment`]); campaigns, their cells run by any executor and resumed
//! ([`campaign`]); the search for the worst admissible DoS ([`search`]); the SUMO set-up
//! ([`sumo`]). Results come back in memory; files are written only into the run (or campaign)
//! directory the caller names; progress is reported through [`Progress`], never drawn here.
//!
//! The pure core is below (`platoon-sim` runs a scenario in process with no files at all:
//! [`platoon_sim::run`]); the files of a run are `platoon-output`'s.
#![warn(missing_docs)]

mod bundle;
#[macro_use]
mod error;
pub mod campaign;
pub mod design;
pub mod experiment;
pub mod formations;
pub mod progress;
pub mod run;
pub mod search;
pub mod sumo;

pub use campaign::CampaignError;
pub use design::DesignError;
pub use error::{BoxError, OtherError};
pub use experiment::ExperimentError;
pub use progress::Progress;
pub use run::{RunError, RunOptions, RunOutcome, Stop};
pub use search::SearchError;

/// The `platoon` program that runs what needs a process of its own (a co-simulation's nodes,
/// co-simulated campaign cells, Dask workers' cells, a benchmark's runs): `$PLATOON_PROGRAM`
/// when set, else this executable. The Python package sets it to its `platoon` script, since
/// there this process is the Python interpreter.
pub fn platoon_program() -> Result<std::path::PathBuf, OtherError> {
    match std::env::var_os("PLATOON_PROGRAM").filter(|p| !p.is_empty()) {
        Some(p) => Ok(p.into()),
        None => {
            use error::Context;
            std::env::current_exe().context("locating the platoon binary")
        }
    }
}
