//! What the Rust SDKs for plug-ins (`platoon-injector-sdk`, `platoon-controller-sdk`) share: finding
//! the run a program was started in, and their error.
use crate::RunError;
use platoon_sim::Scenario;
use std::path::PathBuf;

/// Why a plug-in could not run.
#[derive(thiserror::Error)]
pub enum PluginError {
    /// Not started by `platoon run` (a variable of its environment is missing).
    #[error(
        "{variable} is not set: run this program as `platoon run CONFIG --{role} \"PROGRAM ARGS\"`"
    )]
    NotInARun {
        /// The missing variable.
        variable: &'static str,
        /// The plug-in's option of `platoon run` (`injector`, `controller`).
        role: &'static str,
    },
    /// The run's config could not be read.
    #[error("the run's config: {0}")]
    Config(#[from] platoon_config::ConfigError),
    /// The run failed or stopped this plug-in.
    #[error("{0}")]
    Run(#[from] RunError),
}

/// As its message: `fn main() -> Result<(), PluginError>` prints an error with `Debug`, and
/// the run quotes the plug-in's last lines of stderr.
impl std::fmt::Debug for PluginError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// The run this program was started in as the plug-in `role` (`platoon run --<role>`): its id
/// (`PLATOON_RUN_ID`) and its scenario (read from `PLATOON_CONFIG`). A run of another contract
/// version (`PLATOON_CONTRACT_VERSION`) is refused, naming both versions.
pub fn the_run(role: &'static str) -> Result<(String, Scenario), PluginError> {
    crate::session::check_contract_version()?;
    let missing = |variable| PluginError::NotInARun { variable, role };
    let run_id = std::env::var("PLATOON_RUN_ID").map_err(|_| missing("PLATOON_RUN_ID"))?;
    let config: PathBuf = std::env::var_os("PLATOON_CONFIG")
        .ok_or_else(|| missing("PLATOON_CONFIG"))?
        .into();
    let (_, scenario) = platoon_config::load(&config)?;
    Ok((run_id, scenario))
}

/// How a plug-in's loop ended, for its `main`: stopped by the run (it failed elsewhere, or
/// `platoon run` is gone) is no error of its own.
pub fn ended(result: Result<(), RunError>) -> Result<(), PluginError> {
    match result {
        Err(RunError::Aborted(_) | RunError::Orphaned) => Ok(()),
        other => other.map_err(PluginError::from),
    }
}
