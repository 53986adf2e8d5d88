use platoon_attacks::channel::{ChannelSpec, LinkAttack};
use platoon_attacks::{Assumption2, DosSchedule};
use platoon_control::{ControllerParams, ParamsError};
use platoon_model::{LeaderProfile, State, TauSchedule};
use platoon_topology::Topology;

/// Why a scenario cannot run. The `key` names what is wrong in config terms.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// Controller parameters out of range.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// The parts of the scenario disagree or a value is out of range.
    #[error("{key}: {message}")]
    Invalid {
        /// The offending part.
        key: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// Everything one run needs, already validated piecewise (see `platoon-config`).
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Number of steps; the run covers steps `0..=steps`, i.e. `[0, steps dt]`.
    pub steps: u64,
    /// Initial states, leader first.
    pub initial: Vec<State>,
    /// The leader's velocity profile.
    pub leader: LeaderProfile,
    /// Each follower's time-constant schedule (length N).
    pub taus: Vec<TauSchedule>,
    /// The communication graph.
    pub topology: Topology,
    /// Controller, trigger and spacing parameters (holds the step `dt`).
    pub control: ControllerParams,
    /// When the channel is jammed.
    pub dos: DosSchedule,
    /// Link-level attacks, applied in order after the DoS schedule.
    pub link_attacks: Vec<LinkAttack>,
    /// Seed of the channel's random losses.
    pub channel_seed: u64,
    /// Bounds to check the DoS schedule against, if given.
    pub assumption2: Option<Assumption2>,
    /// Vehicle length for gap computations (m); 0 treats vehicles as points.
    pub vehicle_length: f64,
    /// How the run's safety is classed.
    pub safety: crate::SafetyThresholds,
}

impl Scenario {
    /// The step length (s).
    pub fn dt(&self) -> f64 {
        self.control.dt
    }

    /// The desired spacing `l` (m).
    pub fn spacing(&self) -> f64 {
        self.control.spacing
    }

    /// The end time `steps dt` (s).
    pub fn duration(&self) -> f64 {
        self.steps as f64 * self.dt()
    }

    /// What the channel (in process or in the injector process) needs.
    pub fn channel_spec(&self) -> ChannelSpec {
        ChannelSpec {
            dos: self.dos.clone(),
            attacks: self.link_attacks.clone(),
            seed: self.channel_seed,
        }
    }

    /// The attack intervals that fall within the run, `[0, steps dt]`.
    pub fn attacks_in_run(&self) -> Vec<platoon_attacks::Interval> {
        self.dos.clipped(self.duration()).intervals().to_vec()
    }

    /// Checks that the parts agree.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        self.control.validate()?;
        let n = self.topology.followers();
        let invalid = |key, message| Err(ScenarioError::Invalid { key, message });
        if self.initial.len() != n + 1 {
            return invalid(
                "platoon.initial_states",
                format!("the topology has {n} followers, so {} states (leader first) are needed, got {}", n + 1, self.initial.len()),
            );
        }
        if let Some(i) = self
            .initial
            .iter()
            .position(|x| x.iter().any(|v| !v.is_finite()))
        {
            return invalid("platoon.initial_states", format!("state {i} is not finite"));
        }
        if self.taus.len() != n {
            return invalid(
                "plant.tau",
                format!("need {n} tau schedules, got {}", self.taus.len()),
            );
        }
        if self.steps == 0 {
            return invalid(
                "simulation.duration_s",
                "the run needs at least one step".into(),
            );
        }
        if !(self.vehicle_length.is_finite() && self.vehicle_length >= 0.0) {
            return invalid("platoon.vehicle_length_m", "must be finite and >= 0".into());
        }
        Ok(())
    }
}
