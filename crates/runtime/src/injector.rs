//! The injector SDK: write an attack injector as one method per step.
//!
//! Implement [`Injector`] and call [`run`] from your program's `main` (the `platoon-injector`
//! crate wraps this with the environment `platoon run --injector` gives). [`run`] does the whole
//! contract of `docs/injector-contract.md`: it opens the ports, reports READY, waits for START,
//! blocks on its wake-up listener (no busy polling), hands you every step's states and tx batch
//! in order (and, when the plant publishes it, the background traffic), publishes exactly one rx
//! sample per step (with its `count`, even when empty) and
//! wakes the controller, reports DONE after the last step, and exits on STOP, ABORT or when
//! `platoon run` is gone. An error you return names the injector and the step in the run's
//! summary. The built-in channel ([`crate::nodes::ChannelInjector`]) is written on this SDK.
use crate::ipc::{Inlet, Outlet};
use crate::session::{check_traffic, contract, reporting, Numbering};
use crate::RunError;
use platoon_sim::Scenario;
use platoon_wire::{ControlMsg, LinkPacket, Node, Service, TrafficVehicle, VehicleState};

/// What an injector sees at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct Step<'a> {
    /// The step.
    pub k: u64,
    /// Its time (s).
    pub t: f64,
    /// Every vehicle's state at step k as the plant published it: platoon by platoon, leader
    /// first (vehicle `i` of platoon `j` is `j * (N + 1) + i`).
    pub states: &'a [VehicleState],
    /// The broadcasts of step k, one item per link (`kind = DELIVERY`, `receiver` = the
    /// out-neighbour the packet is meant for).
    pub tx: &'a [LinkPacket],
    /// The plant's background traffic at step k (SUMO's `bg<b>` as item b, every step the same
    /// vehicles; `TrafficVehicle::position` is NaN for one not on the road): empty when the
    /// run has none (the native plant, or SUMO without `[sumo] background_vehicles`). Checked
    /// before you see it; ignore it if your injector does not need it.
    pub traffic: &'a [TrafficVehicle],
}

/// An attack injector: decides, every step, what each receiver gets.
pub trait Injector {
    /// Pushes into `rx` (empty on entry) what the receivers get at `step.k`: deliveries
    /// (`kind = DELIVERY`: forward, drop by leaving out, alter, delay, replay or invent packets)
    /// and jammed notices (`kind = JAMMED` to a receiver whose channel was jammed this step).
    /// An error stops the run and names the injector.
    fn step(&mut self, step: &Step<'_>, rx: &mut Vec<LinkPacket>) -> Result<(), String>;

    /// Called once after the last step (flush logs here).
    fn finish(&mut self) -> Result<(), String> {
        Ok(())
    }

    /// Six numbers reported to the orchestrator with DONE (`ControlMsg::counts`), read after
    /// [`Injector::finish`]; the built-in channel reports its radio's measurements (see
    /// `RadioStats::to_counts`). Third-party injectors leave it.
    fn done_counts(&self) -> [u64; 6] {
        [0; 6]
    }
}

/// Which node an injector is and which services it reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ports {
    /// Its role in the run.
    pub role: Node,
    /// What it reads: `tx` (the broadcasts), or `gated` (what survived the built-in channel).
    pub input: Service,
    /// What it publishes: `rx` for the controllers, or `gated` for the injector after it.
    pub output: Service,
}

impl Ports {
    /// The injector of the run, reading the broadcasts (`--injector-mode replace`).
    pub const INJECTOR: Ports = Ports {
        role: Node::Injector,
        input: Service::Tx,
        output: Service::Rx,
    };
    /// The injector after the built-in channel (`--injector-mode after`).
    pub const AFTER_CHANNEL: Ports = Ports {
        role: Node::Injector,
        input: Service::Gated,
        output: Service::Rx,
    };
    /// The built-in channel in front of a third-party injector.
    pub const CHANNEL: Ports = Ports {
        role: Node::Channel,
        input: Service::Tx,
        output: Service::Gated,
    };

    /// The injector's ports as `platoon run` says in `PLATOON_INJECTOR_INPUT` (`tx`, the
    /// default, or `gated`).
    pub fn from_env() -> Ports {
        match std::env::var("PLATOON_INJECTOR_INPUT").as_deref() {
            Ok("gated") => Ports::AFTER_CHANNEL,
            _ => Ports::INJECTOR,
        }
    }
}

/// Runs `injector` as the injector process of run `run_id` of `scenario` until the run ends.
pub fn run(run_id: &str, scenario: &Scenario, injector: &mut dyn Injector) -> Result<(), RunError> {
    run_on(Ports::INJECTOR, run_id, scenario, injector)
}

/// [`run`] on the given ports.
pub fn run_on(
    ports: Ports,
    run_id: &str,
    scenario: &Scenario,
    injector: &mut dyn Injector,
) -> Result<(), RunError> {
    reporting(run_id, ports.role, |ctx, k| {
        let e = &ctx.endpoint;
        let vehicles = Numbering::of(scenario).vehicles();
        let mut states_in: Inlet<VehicleState> =
            Inlet::new(&e.open_step_service(Service::States)?, Node::Plant)?;
        let from = if ports.input == Service::Gated {
            Node::Channel
        } else {
            Node::Controller
        };
        let mut tx_in: Inlet<LinkPacket> = Inlet::new(&e.open_step_service(ports.input)?, from)?;
        // Only when the run has background traffic (the orchestrator created the service).
        let mut traffic_in: Option<Inlet<TrafficVehicle>> = e
            .open_optional_step_service(Service::Traffic)?
            .map(|s| Inlet::new(&s, Node::Plant))
            .transpose()?;
        let mut traffic_count: Option<usize> = None;
        let rx_out: Outlet<LinkPacket> = e.outlet(
            &e.open_step_service(ports.output)?,
            ports.output,
            4 * vehicles,
        )?;
        let fail = |m: String| contract(ports.role, m);
        let mut states: Option<Vec<VehicleState>> = None;
        let mut items: Vec<LinkPacket> = Vec::with_capacity(4 * vehicles);
        if !ctx.ready()? {
            return Ok(());
        }
        loop {
            if states.is_none() {
                states = states_in.take(*k)?;
            }
            if let Some(s) = &states {
                if let Some(tx) = tx_in.take(*k)? {
                    // Published before the states of step k, so here by now.
                    let traffic = match &mut traffic_in {
                        Some(inlet) => {
                            let t = inlet.take(*k)?.ok_or_else(|| {
                                contract(
                                    Node::Plant,
                                    format!(
                                        "no traffic sample for step {k} (the plant publishes \
                                         it before the states of the step)"
                                    ),
                                )
                            })?;
                            check_traffic(&t, traffic_count, *k)?;
                            traffic_count = Some(t.len());
                            t
                        }
                        None => Vec::new(),
                    };
                    items.clear();
                    let step = Step {
                        k: *k,
                        t: *k as f64 * scenario.dt(),
                        states: s,
                        tx: &tx,
                        traffic: &traffic,
                    };
                    injector.step(&step, &mut items).map_err(fail)?;
                    rx_out.send(*k, scenario.dt(), &items)?;
                    states = None;
                    if *k == scenario.steps {
                        injector.finish().map_err(fail)?;
                        let mut done = ControlMsg::new(ControlMsg::DONE, ports.role, *k);
                        done.counts = injector.done_counts();
                        return ctx.done(done);
                    }
                    *k += 1;
                    continue;
                }
            }
            if !ctx.wait()? {
                return Ok(());
            }
        }
    })
}
