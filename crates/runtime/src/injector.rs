//! Injectors on the wire: the loop of an injector process, and the adapter of the pure seam to it.
//!
//! An attack written on the pure seam ([`platoon_attacks::inject::Injector`], one platoon, one
//! step) runs here as [`Platoons`]: one injector per platoon, the wire's numbering and packets
//! translated both ways. The built-in channel runs so ([`crate::nodes::injector`]), and any
//! injector of the seam runs both in process and in a co-simulation. An injector that works on
//! the wire itself implements [`WireInjector`]. [`run`] (the `platoon-injector-sdk` crate wraps it
//! with the environment `platoon run --injector` gives) does the whole
//! contract of `docs/injector-contract.md`: it opens the ports, reports READY, waits for START,
//! blocks on its wake-up listener (no busy polling), hands you every step's states and tx batch
//! in order (and, when the plant publishes it, the background traffic), publishes exactly one rx
//! sample per step (with its `count`, even when empty) and
//! wakes the controller, reports DONE after the last step, and exits on STOP, ABORT or when
//! `platoon run` is gone. An error you return names the injector and the step in the run's
//! summary.
use crate::ipc::{Inlet, Outlet};
use crate::session::{
    check_traffic, contract, packet_from_wire, packet_to_wire, reporting, states_from_wire,
    Numbering,
};
use crate::{monotonic_ns, CosimError};
use platoon_attacks::channel::{ChannelEvent, RadioStats};
use platoon_attacks::inject::{InjectError, Injector, Reception};
use platoon_control::{Delivery, Packet};
use platoon_model::VehicleId;
use platoon_sim::{InjectorFactory, Scenario};
use platoon_wire::{
    ControlMsg, LinkPacket, Node, Service, TrafficVehicle, V2vPacket, VehicleState,
};
use std::path::Path;

/// What an injector on the wire sees at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct WireStep<'a> {
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

/// An attack injector on the wire: decides, every step, what each receiver of the whole run
/// gets.
pub trait WireInjector {
    /// Pushes into `rx` (empty on entry) what the receivers get at `step.k`: deliveries
    /// (`kind = DELIVERY`: forward, drop by leaving out, alter, delay, replay or invent packets)
    /// and jammed notices (`kind = JAMMED` to a receiver whose channel was jammed this step).
    /// An error stops the run and names the injector.
    fn step(&mut self, step: &WireStep<'_>, rx: &mut Vec<LinkPacket>) -> Result<(), InjectError>;

    /// Called once after the last step (flush logs here).
    fn finish(&mut self) -> Result<(), InjectError> {
        Ok(())
    }

    /// What its radio measured, reported to the orchestrator with DONE (read after
    /// [`WireInjector::finish`]; the built-in channel with the 802.11p radio). Third-party
    /// injectors leave it.
    fn radio_stats(&self) -> Option<RadioStats> {
        None
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
pub fn run(
    run_id: &str,
    scenario: &Scenario,
    injector: &mut dyn WireInjector,
) -> Result<(), CosimError> {
    run_on(Ports::INJECTOR, run_id, scenario, injector)
}

/// [`run`] on the given ports.
pub fn run_on(
    ports: Ports,
    run_id: &str,
    scenario: &Scenario,
    injector: &mut dyn WireInjector,
) -> Result<(), CosimError> {
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
        let fail = |e: InjectError| contract(ports.role, e.to_string());
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
                    let step = WireStep {
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
                        done.counts = injector.radio_stats().map_or([0; 6], |r| r.to_counts());
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

/// Injectors of the pure seam, one per platoon, as one [`WireInjector`]: each platoon's
/// broadcasts and states in its own numbering (leader 0), its deliveries and jammed notices
/// back in the run's.
#[derive(Debug)]
pub struct Platoons {
    num: Numbering,
    topology: platoon_topology::Topology,
    dt: f64,
    injectors: Vec<Box<dyn Injector>>,
    writer: Option<csv::Writer<std::fs::File>>,
    packets: Vec<Vec<Packet>>,
    deliveries: Vec<Delivery>,
    jammed: Vec<bool>,
    events: Vec<ChannelEvent>,
    /// Every vehicle's (road position, measured beacon rate) for loads that count the fleet.
    beacons: Vec<(f64, f64)>,
    /// The background traffic's positions of the step (NaN: not on the road).
    background: Vec<f64>,
    seen: BackgroundSeen,
}

/// What the channel was told about the background traffic over a run, said in its log when
/// the run had any.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BackgroundSeen {
    /// Steps with a traffic sample.
    pub steps: u64,
    /// Background vehicles per sample.
    pub vehicles: usize,
    /// Positions on the road, summed over the steps.
    pub on_road: u64,
    /// Each vehicle's first and latest position on the road.
    pub first: Vec<f64>,
    /// See `first`.
    pub last: Vec<f64>,
}

impl BackgroundSeen {
    fn push(&mut self, positions: &[f64]) {
        if positions.is_empty() {
            return;
        }
        self.steps += 1;
        self.vehicles = positions.len();
        self.first.resize(positions.len(), f64::NAN);
        self.last.resize(positions.len(), f64::NAN);
        for (b, &p) in positions.iter().enumerate() {
            if p.is_finite() {
                self.on_road += 1;
                if self.first[b].is_nan() {
                    self.first[b] = p;
                }
                self.last[b] = p;
            }
        }
    }

    /// How far the vehicles seen on the road moved between their first and latest positions
    /// (least, greatest; m), if any was seen.
    pub fn moved_m(&self) -> Option<(f64, f64)> {
        self.first
            .iter()
            .zip(&self.last)
            .filter(|(f, _)| f.is_finite())
            .map(|(f, l)| l - f)
            .fold(None, |acc, d| match acc {
                None => Some((d, d)),
                Some((lo, hi)) => Some((d.min(lo), d.max(hi))),
            })
    }
}

impl Platoons {
    /// The injector `factory` makes for every platoon of `scenario` (from its replica),
    /// logging what they did to `log` (CSV).
    pub fn new(
        scenario: &Scenario,
        factory: &InjectorFactory,
        log: Option<&Path>,
    ) -> Result<Self, CosimError> {
        let num = Numbering::of(scenario);
        let writer = match log {
            // The header first, so that a log without rows has it too.
            Some(p) => Some(
                csv::WriterBuilder::new()
                    .has_headers(false)
                    .from_path(p)
                    .and_then(|mut w| {
                        w.write_record(ChannelEvent::COLUMNS)?;
                        Ok(w)
                    })
                    .map_err(|e| {
                        contract(Node::Injector, format!("cannot write {}: {e}", p.display()))
                    })?,
            ),
            None => None,
        };
        Ok(Self {
            num,
            topology: scenario.hearing(),
            dt: scenario.dt(),
            injectors: scenario
                .replicas()
                .iter()
                .map(|s| factory.make(s))
                .collect::<Result<_, _>>()
                .map_err(|e| contract(Node::Injector, e.to_string()))?,
            writer,
            packets: vec![Vec::new(); num.platoons],
            deliveries: Vec::new(),
            jammed: vec![false; num.per_platoon],
            events: Vec::new(),
            beacons: Vec::new(),
            background: Vec::new(),
            seen: BackgroundSeen::default(),
        })
    }

    /// Every platoon's injector.
    pub fn injectors(&self) -> &[Box<dyn Injector>] {
        &self.injectors
    }

    /// What the channel was told about the background traffic so far.
    pub fn background_seen(&self) -> &BackgroundSeen {
        &self.seen
    }
}

impl WireInjector for Platoons {
    fn step(
        &mut self,
        step: &WireStep<'_>,
        items: &mut Vec<LinkPacket>,
    ) -> Result<(), InjectError> {
        let num = self.num;
        let n1 = num.per_platoon;
        let states = states_from_wire(step.states, num.vehicles())
            .map_err(|e| InjectError::Input(e.to_string()))?;
        // One item per link: the broadcasts are the runs of equal (sender, seq).
        for p in &mut self.packets {
            p.clear();
        }
        for it in step.tx {
            let Some((j, _)) = num.split(it.packet.sender) else {
                continue;
            };
            let p = packet_from_wire(&it.packet, j, num);
            let list = &mut self.packets[j];
            if list
                .last()
                .is_none_or(|l| (l.sender, l.seq) != (p.sender, p.seq))
            {
                list.push(p);
            }
        }
        // The background traffic in the platoons' road coordinates (every platoon of a fleet
        // shares them); none without a traffic service.
        self.background.clear();
        self.background
            .extend(step.traffic.iter().map(|t| t.position()));
        self.seen.push(&self.background);
        self.events.clear();
        if self.injectors.len() > 1 {
            // Every platoon's radios hear the others, as in platoon_sim::FleetSimulation.
            let platoons = self
                .injectors
                .iter_mut()
                .map(|i| i.as_mut() as &mut dyn Injector)
                .zip(states.chunks(n1));
            platoon_attacks::inject::hear_fleet(step.k, platoons, &mut self.beacons);
        }
        for (j, injector) in self.injectors.iter_mut().enumerate() {
            self.deliveries.clear();
            self.jammed.fill(false);
            injector.step(
                &platoon_attacks::inject::Step {
                    k: step.k,
                    t: step.k as f64 * self.dt,
                    topology: &self.topology,
                    states: &states[j * n1..(j + 1) * n1],
                    tx: &self.packets[j],
                    background: &self.background,
                },
                &mut Reception {
                    deliveries: &mut self.deliveries,
                    jammed: &mut self.jammed,
                    log: &mut self.events,
                },
            )?;
            items.extend(self.deliveries.iter().map(|d| {
                let packet = packet_to_wire(&d.packet, monotonic_ns(), j, num);
                LinkPacket {
                    receiver: num.global(j, d.receiver),
                    kind: LinkPacket::DELIVERY,
                    packet,
                }
            }));
            items.extend(
                self.jammed
                    .iter()
                    .enumerate()
                    .filter(|(_, &x)| x)
                    .map(|(v, _)| LinkPacket {
                        receiver: num.global(j, VehicleId(v as u16)),
                        kind: LinkPacket::JAMMED,
                        packet: V2vPacket::default(),
                    }),
            );
        }
        if let Some(w) = &mut self.writer {
            for ev in &self.events {
                w.serialize(ev).map_err(|e| {
                    InjectError::output("the channel log", std::io::Error::other(e))
                })?;
            }
        }
        Ok(())
    }

    fn radio_stats(&self) -> Option<RadioStats> {
        let mut all = self.injectors.iter().filter_map(|i| i.radio_stats());
        let mut sum = all.next()?;
        for s in all {
            sum.merge(&s);
        }
        Some(sum)
    }

    fn finish(&mut self) -> Result<(), InjectError> {
        for injector in &mut self.injectors {
            injector.finish()?;
        }
        let s = &self.seen;
        if s.steps > 0 {
            // In the node's log (logs/injector.log or logs/channel.log of the run).
            let moved = s.moved_m().map_or(String::new(), |(lo, hi)| {
                format!(", each moved {lo:.1} m to {hi:.1} m")
            });
            eprintln!(
                "channel: background traffic: {} vehicles over {} steps, {} positions on the \
                 road{moved}",
                s.vehicles, s.steps, s.on_road
            );
        }
        match &mut self.writer {
            Some(w) => w
                .flush()
                .map_err(|e| InjectError::output("the channel log", e)),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_wire::TrafficVehicle;

    fn paper() -> Scenario {
        platoon_config::parse(platoon_config::PAPER_TOML, Path::new("paper.toml"))
            .unwrap()
            .1
    }

    fn states(scenario: &Scenario) -> Vec<VehicleState> {
        scenario
            .initial
            .iter()
            .enumerate()
            .map(|(i, x)| VehicleState {
                vehicle: i as u32,
                p: x[0],
                v: x[1],
                ..Default::default()
            })
            .collect()
    }

    fn on_road(index: u32, p: f64) -> TrafficVehicle {
        TrafficVehicle {
            index,
            flags: TrafficVehicle::ON_ROAD,
            p,
        }
    }

    fn step<'a>(k: u64, states: &'a [VehicleState], traffic: &'a [TrafficVehicle]) -> WireStep<'a> {
        WireStep {
            k,
            t: k as f64 * 0.01,
            states,
            tx: &[],
            traffic,
        }
    }

    /// The background traffic of a step reaches every platoon's channel before it gates, as
    /// positions with NaN for a vehicle not on the road; a run without traffic gives none.
    #[test]
    fn the_channel_is_told_where_the_background_traffic_is() {
        let scenario = paper();
        let mut sut = Platoons::new(&scenario, &InjectorFactory::builtin(), None).unwrap();
        let s = states(&scenario);
        let mut rx = Vec::new();
        sut.step(&step(0, &s, &[]), &mut rx).unwrap();
        assert!(sut
            .injectors()
            .iter()
            .all(|i| i.channel().unwrap().background().is_empty()));
        assert_eq!(sut.background_seen().steps, 0);

        let absent = TrafficVehicle {
            index: 1,
            flags: 0,
            p: f64::NAN,
        };
        let first = [on_road(0, -40.0), absent, on_road(2, 310.5)];
        sut.step(&step(1, &s, &first), &mut rx).unwrap();
        for i in sut.injectors() {
            let b = i.channel().unwrap().background();
            assert_eq!(b.len(), 3);
            assert_eq!((b[0], b[2]), (-40.0, 310.5));
            assert!(b[1].is_nan());
        }
        let moved = [on_road(0, -15.0), on_road(1, 100.0), on_road(2, 330.5)];
        sut.step(&step(2, &s, &moved), &mut rx).unwrap();
        let seen = sut.background_seen();
        assert_eq!((seen.steps, seen.vehicles, seen.on_road), (2, 3, 5));
        assert_eq!(seen.moved_m(), Some((0.0, 25.0)));
    }
}
