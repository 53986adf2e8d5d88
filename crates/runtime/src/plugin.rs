//! What the Rust SDKs for plug-ins (`platoon-injector-sdk`, `platoon-controller-sdk`) share:
//! finding the run a program was started in, the run's resolved facts (`facts.json`,
//! [`RunFacts`]), and their error.
use crate::CosimError;
use platoon_config::PlantKind;
use platoon_sim::Scenario;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The environment variable naming a run's `facts.json`.
pub const RUN_FACTS_ENV: &str = "PLATOON_RUN_FACTS";

/// The file of a run directory holding its [`RunFacts`].
pub const RUN_FACTS_FILE: &str = "facts.json";

/// What a run resolved from its scenario, written once by the orchestrator (`facts.json`,
/// named by `PLATOON_RUN_FACTS`) so that plug-ins in any language read it instead of
/// re-deriving it from the config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunFacts {
    /// Names the run's services.
    pub run_id: String,
    /// The wire contract version ([`platoon_wire::CONTRACT_VERSION`]).
    pub contract_version: u32,
    /// The step in seconds.
    pub dt_s: f64,
    /// The last step: the run has steps `0..=last_step`.
    pub last_step: u64,
    /// Number of platoons.
    pub platoons: usize,
    /// Followers per platoon (N).
    pub followers: usize,
    /// All vehicles of the fleet, `platoons * (N + 1)`.
    pub vehicles: usize,
    /// How wire ids are numbered ([`crate::session::Numbering`]).
    pub numbering: String,
    /// Each platoon's V2V graph (whose packets its controllers' laws use), in platoon order.
    pub topologies: Vec<Graph>,
    /// Each platoon's links on the channel (`Scenario::hearing`), in platoon order: its graph,
    /// plus every member ahead when it splits behind a car that cut in, or every link, the
    /// leader hearing the followers, when it negotiates maneuvers. Controllers publish
    /// one item per link of this graph and injectors deliver along it.
    pub hearing: Vec<Graph>,
    /// The detectors the run measures (`[detection]`), in the order of each inspection's
    /// verdicts; empty without detection.
    pub detectors: Vec<String>,
    /// The plant.
    pub plant: PlantKind,
}

/// One platoon's V2V graph as `platoon-topology` computes it: `adjacency[i][j]` = 1 when
/// follower i hears follower j (0-based), `pinning[i]` = 1 when follower i hears the leader.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Graph {
    /// The followers' adjacency, row by row.
    pub adjacency: Vec<Vec<f64>>,
    /// The followers' pinning to the leader.
    pub pinning: Vec<f64>,
    /// The followers the leader hears (1-based; on the channel of a platoon that negotiates
    /// maneuvers, `[maneuvers]`: every follower). Absent: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub leader_hears: Vec<u16>,
}

impl Graph {
    /// The graph of `topology`.
    pub fn of(topology: &platoon_topology::Topology) -> Self {
        let a = topology.adjacency();
        Self {
            adjacency: a
                .row_iter()
                .map(|row| row.iter().copied().collect())
                .collect(),
            pinning: topology.pinning().iter().copied().collect(),
            leader_hears: topology
                .in_neighbours(platoon_model::VehicleId::LEADER)
                .iter()
                .map(|v| v.0)
                .collect(),
        }
    }
}

impl RunFacts {
    /// The facts of the run `run_id` of `scenario` on `plant`.
    pub fn of(run_id: &str, scenario: &Scenario, plant: PlantKind) -> Self {
        let numbering = crate::session::Numbering::of(scenario);
        Self {
            run_id: run_id.to_string(),
            contract_version: platoon_wire::CONTRACT_VERSION,
            dt_s: scenario.dt(),
            last_step: scenario.steps,
            platoons: numbering.platoons,
            followers: numbering.per_platoon - 1,
            vehicles: numbering.vehicles(),
            numbering: "vehicle i of platoon j is j * (N + 1) + i".to_string(),
            topologies: scenario
                .replicas()
                .iter()
                .map(|s| Graph::of(&s.topology))
                .collect(),
            hearing: scenario
                .replicas()
                .iter()
                .map(|s| Graph::of(&s.hearing()))
                .collect(),
            detectors: scenario.control.detection.names(),
            plant,
        }
    }

    /// Reads the facts from `path` (a run's `facts.json`).
    pub fn read(path: &Path) -> Result<Self, PluginError> {
        let facts = |e: String| PluginError::Facts(format!("{}: {e}", path.display()));
        let text = std::fs::read_to_string(path).map_err(|e| facts(e.to_string()))?;
        serde_json::from_str(&text).map_err(|e| facts(e.to_string()))
    }
}

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
    /// The run's facts (`PLATOON_RUN_FACTS`) could not be read.
    #[error("the run's facts: {0}")]
    Facts(String),
    /// The run failed or stopped this plug-in.
    #[error(transparent)]
    Run(#[from] CosimError),
}

/// As its message: `fn main() -> Result<(), PluginError>` prints an error with `Debug`, and
/// the run quotes the plug-in's last lines of stderr.
impl std::fmt::Debug for PluginError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            // With its causes (iceoryx2's error): no one walks the chain of a `main`'s error.
            Self::Run(e) => std::fmt::Display::fmt(&crate::Causes(e), f),
            _ => std::fmt::Display::fmt(self, f),
        }
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
    Ok((run_id, run_scenario(&config)?))
}

/// The scenario of the run's config at `path`, typed: a key no layout of the config has (an
/// old `[control.<law>]` table, a misspelt key) is an error naming it, never a default.
fn run_scenario(path: &Path) -> Result<Scenario, PluginError> {
    Ok(platoon_config::load(path)?.1)
}

/// The facts of the run this program was started in as the plug-in `role`, read from
/// `PLATOON_RUN_FACTS`.
pub fn the_facts(role: &'static str) -> Result<RunFacts, PluginError> {
    let path: PathBuf = std::env::var_os(RUN_FACTS_ENV)
        .ok_or(PluginError::NotInARun {
            variable: RUN_FACTS_ENV,
            role,
        })?
        .into();
    RunFacts::read(&path)
}

/// How a plug-in's loop ended, for its `main`: stopped by the run (it failed elsewhere, or
/// `platoon run` is gone) is no error of its own.
pub fn ended(result: Result<(), CosimError>) -> Result<(), PluginError> {
    match result {
        Err(CosimError::Aborted(_) | CosimError::Orphaned) => Ok(()),
        other => other.map_err(PluginError::from),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_topology::{Preset, Topology};

    /// A fleet's facts are its scenario's, the graphs `platoon-topology`'s, and they survive
    /// `facts.json`.
    #[test]
    fn the_facts_of_a_fleet_match_its_scenario() {
        let text = format!(
            "{}\n[fleet]\nplatoons = 3\n",
            platoon_config::Embedded::Paper.text()
        );
        let (_, scenario) =
            platoon_config::parse(&text, Path::new("paper-fleet.toml")).expect("a valid config");
        let facts = RunFacts::of("r1", &scenario, PlantKind::Native);
        assert_eq!(facts.run_id, "r1");
        assert_eq!(facts.contract_version, platoon_wire::CONTRACT_VERSION);
        // 55 s at 10 ms: steps 0..=5500.
        assert_eq!((facts.last_step, facts.dt_s), (5500, 0.01));
        assert_eq!(facts.last_step, scenario.steps);
        assert_eq!(
            (facts.platoons, facts.followers, facts.vehicles),
            (3, 4, 15)
        );
        let tpsf = Graph::of(&Topology::preset(Preset::Tpsf, 4).unwrap());
        assert_eq!(tpsf.pinning, [1.0, 1.0, 0.0, 0.0]);
        assert_eq!(tpsf.adjacency[3], [0.0, 1.0, 1.0, 0.0]);
        assert_eq!(facts.topologies, vec![tpsf; 3]);
        assert!(facts.detectors.is_empty());
        let json = serde_json::to_string(&facts).unwrap();
        assert!(json.contains("\"plant\":\"native\""), "{json}");
        let back: RunFacts = serde_json::from_str(&json).unwrap();
        assert_eq!(back, facts);
    }

    /// Issue 50, item 6: a config in a layout the SDKs do not know (a law's keys in the old
    /// `[control.path_cacc]` table) stops a Rust plug-in, naming the key, where a Python one
    /// used to run on its defaults.
    #[test]
    fn a_config_in_an_old_layout_is_refused_naming_the_key() {
        let path =
            std::env::temp_dir().join(format!("platoon-old-layout-{}.toml", std::process::id()));
        std::fs::write(
            &path,
            "[control]\nlaw = \"path_cacc\"\n[control.path_cacc]\nspacing_m = 7.0\n",
        )
        .unwrap();
        let e = run_scenario(&path).unwrap_err().to_string();
        std::fs::remove_file(&path).unwrap();
        assert!(e.contains("control.path_cacc"), "{e}");
    }
}
