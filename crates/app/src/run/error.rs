//! [`RunError`]: why a run failed, by kind, and [`NodeFailure`], a process that failed.
use super::*;
use crate::error::OtherError;

/// Why [`run`] failed, by kind: what a caller branches on (the Python package raises one
/// exception class per kind). Each message is the one `platoon run` prints.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
    /// The config (or what the run's options make of it) is refused (`platoon run` exits 2).
    #[error(transparent)]
    Config(#[from] platoon_config::ConfigError),
    /// A process of a co-simulated run failed: it could not start, died, stalled, reported a
    /// failure or broke the contract.
    #[error(transparent)]
    Node(Box<NodeFailure>),
    /// The co-simulation failed with no process to blame (iceoryx2, the contract version).
    #[error(transparent)]
    Cosim(Box<platoon_runtime::CosimError>),
    /// The run directory or one of its files.
    #[error(transparent)]
    Output(#[from] platoon_output::error::OutputError),
    /// The SUMO plant could not be set up (the bridge, its venv, the network, `plant.json`).
    #[error(transparent)]
    Sumo(#[from] crate::sumo::SumoError),
    /// Anything else (options that do not go together, a figure that could not be drawn, a
    /// scenario the simulation refused, a sink's failure).
    #[error(transparent)]
    Other(OtherError),
}

operation_error!(RunError);

impl From<platoon_sim::ScenarioError> for RunError {
    fn from(e: platoon_sim::ScenarioError) -> Self {
        Self::Other(OtherError::wrap(e))
    }
}

impl RunError {
    /// The config error this is, if it is one (`platoon run` exits 2 on it): the run's, or
    /// the one SUMO's set-up found.
    pub fn config(&self) -> Option<&platoon_config::ConfigError> {
        match self {
            Self::Config(c) => Some(c),
            Self::Sumo(s) => s.config(),
            _ => None,
        }
    }

    /// The output error this is, if it is one: the run directory's, or one SUMO's set-up or
    /// the FCD conversion met.
    pub fn output(&self) -> Option<&platoon_output::error::OutputError> {
        match self {
            Self::Output(o) => Some(o),
            Self::Sumo(s) => s.output(),
            _ => None,
        }
    }

    /// A co-simulation's failure, typed: [`RunError::Node`] when a process is to blame (its
    /// log in `logs`, the run directory's `logs/`), else [`RunError::Cosim`].
    pub fn from_runtime(error: platoon_runtime::CosimError, logs: &Path) -> Self {
        use platoon_runtime::CosimError as R;
        let (step, message) = match &error {
            R::Spawn {
                command, source, ..
            } => (None, format!("could not start ({command}): {source}")),
            R::Died { step, status, .. } => (Some(*step), format!("exited: {status}")),
            R::Stalled {
                step,
                waited_s,
                what,
                ..
            } => (
                Some(*step),
                format!("published nothing for step {step} within {waited_s} s ({what})"),
            ),
            R::Failed { step, reason, .. } => (Some(*step), reason.clone()),
            R::Contract { message, .. } => (None, message.clone()),
            _ => return Self::Cosim(Box::new(error)),
        };
        let Some(node) = error.node() else {
            return Self::Cosim(Box::new(error));
        };
        let log = logs.join(format!("{node}.log"));
        Self::Node(Box::new(NodeFailure {
            node,
            step,
            log: log.is_file().then_some(log),
            message,
            error,
        }))
    }
}

/// A process of a co-simulated run that failed: which, when, where its log is and what it
/// said. Its message and causes are the run's (`error`'s), with the last lines of the log.
#[derive(Debug)]
pub struct NodeFailure {
    /// The node: `plant`, `controller`, `injector` or `channel` (a plug-in runs as one).
    pub node: &'static str,
    /// The step the run was at, when known.
    pub step: Option<u64>,
    /// Its log (stdout and stderr) in the run directory, when it wrote one.
    pub log: Option<PathBuf>,
    /// What went wrong, in a line: its reason, its exit status, what it did not publish.
    pub message: String,
    /// The run's error, as the orchestrator reported it.
    pub error: platoon_runtime::CosimError,
}

impl std::fmt::Display for NodeFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.error.fmt(f)
    }
}

impl std::error::Error for NodeFailure {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        std::error::Error::source(&self.error)
    }
}
