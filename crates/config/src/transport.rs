//! How the processes of a run are connected: the one type `platoon run --transport`, campaign
//! files (`transport = ...`) and the campaign executor share.

use serde::{Deserialize, Serialize};

/// How the processes of a run are connected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Transport {
    /// Separate processes over iceoryx2 shared memory.
    Iceoryx2,
    /// One process, no IPC.
    Inproc,
}

impl Transport {
    /// What a campaign or search file runs on when it does not say: in process (`platoon run`
    /// says iceoryx2).
    pub fn file_default() -> Self {
        Transport::Inproc
    }

    /// Its name in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Transport::Inproc => "inproc",
            Transport::Iceoryx2 => "iceoryx2",
        }
    }
}
