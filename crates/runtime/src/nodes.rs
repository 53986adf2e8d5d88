//! The plant, controller and (Rust) injector processes, written on [`crate::session`]. Each
//! composes the pure core and blocks on its wake-up listener between samples; none of them
//! busy-polls. The built-in channel is an injector on the SDK ([`crate::injector`]), the
//! built-in controller a controller on the SDK ([`crate::controller`]).
use crate::ipc::{Inlet, Outlet};
use crate::session::{
    contract, packet_from_wire, packet_to_wire, reporting, states_from_wire, Numbering,
};
use crate::{monotonic_ns, RunError};
use platoon_attacks::channel::{Channel, ChannelEvent};
use platoon_control::fallback::{radar_truth, RadarTruth};
use platoon_control::{Delivery, Packet};
use platoon_model::VehicleId;
use platoon_sim::{Plant, Scenario};
use platoon_wire::{Command, ControlMsg, LinkPacket, Node, Service, V2vPacket, VehicleState};
use std::path::Path;

/// The native plant process: integrates every vehicle with the model of `platoon-sim`.
pub fn plant(run_id: &str, scenario: &Scenario) -> Result<(), RunError> {
    reporting(run_id, Node::Plant, |ctx, k| {
        let e = &ctx.endpoint;
        let num = Numbering::of(scenario);
        let states_out: Outlet<VehicleState> = e.fixed_outlet(
            &e.open_step_service(Service::States)?,
            Service::States,
            num.vehicles(),
        )?;
        let mut commands: Inlet<Command> =
            Inlet::new(&e.open_step_service(Service::Commands)?, Node::Controller)?;
        let mut plants: Vec<Plant> = scenario.replicas().iter().map(Plant::new).collect();
        let mut buf = Vec::with_capacity(num.vehicles());
        let mut u = vec![0.0; num.followers()];
        if !ctx.ready()? {
            return Ok(());
        }
        let mut truth = Vec::new();
        let publish = |k: u64,
                       plants: &[Plant],
                       buf: &mut Vec<VehicleState>,
                       truth: &mut Vec<Option<RadarTruth>>| {
            buf.clear();
            for p in plants {
                // What a radar sees natively: the platoon's predecessor.
                radar_truth(p.states(), scenario.vehicle_length, truth);
                buf.extend(p.states().iter().zip(truth.iter()).map(|(x, t)| {
                    let (flags, gap, closing) =
                        t.map_or((0, 0.0, 0.0), |t| (VehicleState::AHEAD, t.gap, t.closing));
                    VehicleState {
                        vehicle: 0, // numbered below
                        flags,
                        p: x[0],
                        v: x[1],
                        a: x[2],
                        gap,
                        closing,
                    }
                }));
            }
            for (g, s) in buf.iter_mut().enumerate() {
                s.vehicle = g as u32;
            }
            states_out.send(k, scenario.dt(), buf)
        };
        publish(0, &plants, &mut buf, &mut truth)?;
        let n = num.per_platoon - 1;
        loop {
            let got = commands.take(*k)?;
            let Some(cmds) = got else {
                if !ctx.wait()? {
                    return Ok(());
                }
                continue;
            };
            commands_into(&cmds, num, &mut u)?;
            for (plant, u) in plants.iter_mut().zip(u.chunks(n)) {
                plant.advance(*k, u);
            }
            if *k == scenario.steps {
                return ctx.done(ControlMsg::new(ControlMsg::DONE, Node::Plant, *k));
            }
            *k += 1;
            publish(*k, &plants, &mut buf, &mut truth)?;
        }
    })
}

/// Checks a command batch (one finite command per follower) and copies it into `u`.
fn commands_into(cmds: &[Command], num: Numbering, u: &mut [f64]) -> Result<(), RunError> {
    if cmds.len() != u.len() {
        return Err(contract(
            Node::Controller,
            format!("{} commands for {} followers", cmds.len(), u.len()),
        ));
    }
    for c in cmds {
        match num.split(c.vehicle) {
            Some((j, i)) if !i.is_leader() && c.u.is_finite() => {
                u[j * (num.per_platoon - 1) + i.index() - 1] = c.u;
            }
            _ => {
                return Err(contract(
                    Node::Controller,
                    format!("bad command for vehicle {}: {}", c.vehicle, c.u),
                ))
            }
        }
    }
    Ok(())
}

/// The controller service: every follower's triggering rule, estimators and control law, for
/// every platoon: the controllers [`platoon_control::build`] makes from the config, on the
/// controller SDK ([`crate::controller`]) like any third-party one.
pub fn controller(run_id: &str, scenario: &Scenario) -> Result<(), RunError> {
    crate::controller::run(run_id, scenario, |s| {
        platoon_control::build(&s.control, &s.topology, &s.initial).map_err(|e| e.to_string())
    })
}

/// The built-in attack injector: the channel of `platoon-attacks` between the controllers, one
/// per platoon, written on the injector SDK ([`crate::injector`]) like any third-party one.
/// Writes its log (every packet not delivered as sent) to `log` as CSV.
pub fn injector(run_id: &str, scenario: &Scenario, log: Option<&Path>) -> Result<(), RunError> {
    let mut channel = ChannelInjector::new(scenario, log)?;
    crate::injector::run(run_id, scenario, &mut channel)
}

/// The same channel in front of a third-party injector (`--injector-mode after`): reads `tx`,
/// publishes `gated`.
pub fn channel(run_id: &str, scenario: &Scenario, log: Option<&Path>) -> Result<(), RunError> {
    let mut channel = ChannelInjector::new(scenario, log)?;
    crate::injector::run_on(
        crate::injector::Ports::CHANNEL,
        run_id,
        scenario,
        &mut channel,
    )
}

/// The config's DoS schedule and link attacks as an [`crate::injector::Injector`].
pub struct ChannelInjector {
    num: Numbering,
    topology: platoon_topology::Topology,
    dt: f64,
    channels: Vec<Channel>,
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

impl ChannelInjector {
    /// The channel of every platoon of `scenario`, logging to `log`.
    pub fn new(scenario: &Scenario, log: Option<&Path>) -> Result<Self, RunError> {
        let num = Numbering::of(scenario);
        let writer = match log {
            Some(p) => Some(csv::Writer::from_path(p).map_err(|e| {
                contract(Node::Injector, format!("cannot write {}: {e}", p.display()))
            })?),
            None => None,
        };
        Ok(Self {
            num,
            topology: scenario.topology.clone(),
            dt: scenario.dt(),
            channels: scenario
                .replicas()
                .iter()
                .map(|s| Channel::new(s.channel_spec(), num.per_platoon))
                .collect(),
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

    /// Every platoon's channel.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// What the channel was told about the background traffic so far.
    pub fn background_seen(&self) -> &BackgroundSeen {
        &self.seen
    }
}

impl crate::injector::Injector for ChannelInjector {
    fn step(
        &mut self,
        step: &crate::injector::Step<'_>,
        items: &mut Vec<LinkPacket>,
    ) -> Result<(), String> {
        let num = self.num;
        let n1 = num.per_platoon;
        let states = states_from_wire(step.states, num.vehicles()).map_err(|e| e.to_string())?;
        // One item per link: the broadcasts are the runs of equal (sender, seq).
        for p in &mut self.packets {
            p.clear();
        }
        for it in step.tx {
            let Some((j, sender)) = num.split(it.packet.sender) else {
                continue;
            };
            let mut p = packet_from_wire(&it.packet);
            p.sender = sender;
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
        if self.channels.len() > 1 {
            // Every platoon's radios hear the others, as in platoon_sim::FleetSimulation.
            let mut platoons: Vec<(&mut Channel, &[platoon_model::State])> =
                self.channels.iter_mut().zip(states.chunks(n1)).collect();
            platoon_attacks::channel::hear_fleet(step.k, &mut platoons, &mut self.beacons);
        }
        for (j, channel) in self.channels.iter_mut().enumerate() {
            self.deliveries.clear();
            channel.set_background(&self.background);
            channel.gate(
                step.k,
                step.k as f64 * self.dt,
                &self.topology,
                &states[j * n1..(j + 1) * n1],
                &self.packets[j],
                &mut self.deliveries,
                &mut self.jammed,
                &mut self.events,
            );
            items.extend(self.deliveries.iter().map(|d| {
                let mut packet = packet_to_wire(&d.packet, monotonic_ns());
                packet.sender = num.global(j, d.packet.sender);
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
                w.serialize(ev)
                    .map_err(|e| format!("writing the channel log: {e}"))?;
            }
        }
        Ok(())
    }

    fn done_counts(&self) -> [u64; 6] {
        let mut all = self.channels.iter().filter_map(Channel::radio_stats);
        let Some(mut sum) = all.next() else {
            return [0; 6];
        };
        for s in all {
            sum.merge(&s);
        }
        sum.to_counts()
    }

    fn finish(&mut self) -> Result<(), String> {
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
                .map_err(|e| format!("writing the channel log: {e}")),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::injector::{Injector, Step};
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

    fn step<'a>(k: u64, states: &'a [VehicleState], traffic: &'a [TrafficVehicle]) -> Step<'a> {
        Step {
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
        let mut sut = ChannelInjector::new(&scenario, None).unwrap();
        let s = states(&scenario);
        let mut rx = Vec::new();
        sut.step(&step(0, &s, &[]), &mut rx).unwrap();
        assert!(sut.channels().iter().all(|c| c.background().is_empty()));
        assert_eq!(sut.background_seen().steps, 0);

        let absent = TrafficVehicle {
            index: 1,
            flags: 0,
            p: f64::NAN,
        };
        let first = [on_road(0, -40.0), absent, on_road(2, 310.5)];
        sut.step(&step(1, &s, &first), &mut rx).unwrap();
        for c in sut.channels() {
            let b = c.background();
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
