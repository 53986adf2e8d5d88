//! [`RunError`]: why a run failed, by kind, and [`NodeFailure`], a process that failed.
use super::*;

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
    Sumo(anyhow::Error),
    /// Anything else (options that do not go together, a figure that could not be drawn).
    #[error(transparent)]
    Other(anyhow::Error),
}

impl From<anyhow::Error> for RunError {
    /// Its kind when it is a config or output error as it was raised; with a context (words
    /// that the message keeps) it stays [`RunError::Other`].
    fn from(e: anyhow::Error) -> Self {
        let bare = |e: &anyhow::Error| e.chain().count() == 1;
        if bare(&e) && e.is::<platoon_config::ConfigError>() {
            return Self::Config(e.downcast().expect("checked"));
        }
        if e.is::<platoon_output::error::OutputError>()
            && e.chain()
                .next()
                .is_some_and(|c| c.is::<platoon_output::error::OutputError>())
        {
            return Self::Output(e.downcast().expect("checked"));
        }
        Self::Other(e)
    }
}

impl RunError {
    /// The config error this is, if it is one (`platoon run` exits 2 on it), also one that a
    /// context wrapped.
    pub fn config(&self) -> Option<&platoon_config::ConfigError> {
        match self {
            Self::Config(c) => Some(c),
            Self::Other(e) | Self::Sumo(e) => e.downcast_ref(),
            _ => None,
        }
    }

    /// A SUMO set-up error: its kind when it is a config or output error, else [`RunError::Sumo`].
    pub(super) fn sumo(e: anyhow::Error) -> Self {
        match Self::from(e) {
            Self::Other(e) => Self::Sumo(e),
            kind => kind,
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
