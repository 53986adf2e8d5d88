//! The in-process co-simulation of one platoon scenario, and its metrics. Pure: no I/O, clocks or
//! threads, so it is the oracle every other runtime (iceoryx2, SUMO) must agree with bit for bit.
//!
//! One step `k` is the shape of `DESIGN.md`: plant states → controllers decide who broadcasts →
//! the network (here the DoS schedule, in process) gates each link → controllers apply what
//! arrived and compute `u[k]` → the plant advances to `k + 1`.
#![warn(missing_docs)]

mod metrics;
mod network;
mod scenario;

pub use metrics::{ErrorStats, MetricsAccumulator, Safety, Summary, VehicleSummary};
pub use network::DosNetwork;
pub use scenario::{Scenario, ScenarioError};

use platoon_control::{Delivery, Packet, PlatoonController};
use platoon_model::{leader_step, plant_step, State, VehicleId};

/// One vehicle at one step: what `trajectories.csv` holds.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StepRow {
    /// Step index k.
    pub step: u64,
    /// Time k dt (s).
    pub t: f64,
    /// Vehicle (0 = leader).
    pub vehicle: u16,
    /// Position (m).
    pub p: f64,
    /// Velocity (m/s).
    pub v: f64,
    /// Acceleration (m/s^2).
    pub a: f64,
    /// Command over the step (the leader: its reference acceleration).
    pub u: f64,
    /// Internal variable theta_i (NaN for the leader).
    pub theta: f64,
    /// Spacing error `p_i - p_0 + i l` (m): positive means too close to the leader.
    pub spacing_error: f64,
    /// Velocity error `v_i - v_0` (m/s).
    pub velocity_error: f64,
    /// The vehicle broadcast at this step.
    pub triggered: bool,
    /// The channel was jammed at this step.
    pub under_attack: bool,
    /// The vehicle was affected by an attack (`A*`: input per the attack-input option).
    pub affected: bool,
}

/// A scenario being run step by step.
#[derive(Debug, Clone)]
pub struct Simulation {
    scenario: Scenario,
    controller: PlatoonController,
    network: DosNetwork,
    states: Vec<State>,
    step: u64,
    tx: Vec<Packet>,
    deliveries: Vec<Delivery>,
    jammed: Vec<bool>,
    rows: Vec<StepRow>,
}

impl Simulation {
    /// Prepares a run of `scenario` from its initial states.
    pub fn new(scenario: Scenario) -> Result<Self, ScenarioError> {
        scenario.validate()?;
        let controller = PlatoonController::new(
            scenario.control.clone(),
            &scenario.topology,
            &scenario.initial,
        )?;
        let mut states = scenario.initial.clone();
        states[0][2] = scenario.leader.step_acceleration(0, scenario.dt());
        let n = scenario.topology.followers();
        Ok(Self {
            network: DosNetwork::new(scenario.dos.clone()),
            controller,
            states,
            step: 0,
            tx: Vec::with_capacity(n + 1),
            deliveries: Vec::new(),
            jammed: vec![false; n + 1],
            rows: Vec::with_capacity(n + 1),
            scenario,
        })
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The controllers (e.g. for their reject counts).
    pub fn controller(&self) -> &PlatoonController {
        &self.controller
    }

    /// The next step to run.
    pub fn next_step(&self) -> u64 {
        self.step
    }

    /// Whether every step `0..=steps` has run.
    pub fn is_done(&self) -> bool {
        self.step > self.scenario.steps
    }

    /// Runs step k and returns one row per vehicle (leader first) for it.
    pub fn step(&mut self) -> &[StepRow] {
        let k = self.step;
        let sc = &self.scenario;
        let dt = sc.dt();
        let t = k as f64 * dt;

        self.tx.clear();
        self.controller.transmit(k, &self.states, &mut self.tx);
        self.deliveries.clear();
        let jam = self
            .network
            .gate(t, &sc.topology, &self.tx, &mut self.deliveries);
        self.jammed.fill(jam);
        self.controller
            .receive(k, &self.states, &self.deliveries, &self.jammed);

        self.rows.clear();
        let x0 = self.states[0];
        self.rows.push(StepRow {
            step: k,
            t,
            vehicle: 0,
            p: x0[0],
            v: x0[1],
            a: x0[2],
            u: x0[2],
            theta: f64::NAN,
            spacing_error: 0.0,
            velocity_error: 0.0,
            triggered: self.tx.first().is_some_and(|p| p.sender.is_leader()),
            under_attack: jam,
            affected: false,
        });
        for (i, x) in self.states.iter().enumerate().skip(1) {
            let s = self.controller.follower_step(VehicleId(i as u16));
            self.rows.push(StepRow {
                step: k,
                t,
                vehicle: i as u16,
                p: x[0],
                v: x[1],
                a: x[2],
                u: s.u,
                theta: s.theta,
                spacing_error: x[0] - x0[0] + i as f64 * sc.spacing(),
                velocity_error: x[1] - x0[1],
                triggered: s.triggered,
                under_attack: jam,
                affected: s.affected,
            });
        }

        // Plant: every follower under its own tau schedule, the leader on its profile.
        let u = self.controller.commands();
        for (i, x) in self.states.iter_mut().enumerate().skip(1) {
            *x = plant_step(x, u[i - 1], sc.taus[i - 1].at(t), dt);
        }
        self.states[0] = leader_step(
            &self.states[0],
            sc.leader.step_acceleration(k as usize + 1, dt),
            dt,
        );
        self.step += 1;
        &self.rows
    }
}

/// Runs a whole scenario, calling `each` with the rows of every step, and returns its summary.
pub fn run(scenario: Scenario, mut each: impl FnMut(&[StepRow])) -> Result<Summary, ScenarioError> {
    let mut sim = Simulation::new(scenario)?;
    let mut metrics = MetricsAccumulator::new(sim.scenario());
    while !sim.is_done() {
        let rows = sim.step();
        metrics.push(rows);
        each(rows);
    }
    Ok(metrics.finish(sim.controller().rejected()))
}
