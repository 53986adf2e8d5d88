//! The plant, controller and (Rust) injector processes. Each composes the pure core and blocks
//! on its wake-up listener between samples; none of them busy-polls.
use crate::ipc::{wait, ControlInlet, ControlOutlet, Endpoint, Inlet, Outlet};
use crate::{monotonic_ns, RunError};
use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::ipc;
use platoon_attacks::channel::{Channel, ChannelEvent};
use platoon_control::{Delivery, Packet, PlatoonController};
use platoon_model::{State, VehicleId};
use platoon_sim::{Plant, Scenario};
use platoon_wire::{Command, ControlMsg, LinkPacket, Node, Service, V2vPacket, VehicleState};
use std::path::Path;
use std::time::Duration;

/// How long a node sleeps between checks that its orchestrator is still there.
const TICK: Duration = Duration::from_millis(200);

/// What every node has: its endpoint, wake-up listener, the control channel and its status
/// outlet, and the pid of the orchestrator that started it.
struct Ctx {
    role: Node,
    endpoint: Endpoint,
    listener: Listener<ipc::Service>,
    control: ControlInlet,
    status: ControlOutlet,
    parent: u32,
    started: bool,
}

impl Ctx {
    fn new(run_id: &str, role: Node) -> Result<Self, RunError> {
        let endpoint = Endpoint::new(run_id, role)?;
        let control = ControlInlet::new(&endpoint.control_service(Service::Control, false)?)?;
        let status = endpoint.control_outlet(
            &endpoint.control_service(Service::Status, false)?,
            Service::Status,
        )?;
        Ok(Self {
            listener: endpoint.listener()?,
            role,
            endpoint,
            control,
            status,
            parent: std::os::unix::process::parent_id(),
            started: false,
        })
    }

    fn status(&self, kind: u32, step: u64) -> Result<(), RunError> {
        self.status.send(ControlMsg::new(kind, self.role, step))
    }

    /// Blocks until notified (or a tick passes). `Ok(false)` means STOP: exit cleanly.
    fn wait(&mut self) -> Result<bool, RunError> {
        wait(&self.listener, TICK)?;
        while let Some(m) = self.control.next()? {
            match m.kind {
                ControlMsg::START => self.started = true,
                ControlMsg::STOP => return Ok(false),
                ControlMsg::ABORT => return Err(RunError::Aborted(m.reason())),
                _ => {}
            }
        }
        if std::os::unix::process::parent_id() != self.parent {
            return Err(RunError::Orphaned);
        }
        Ok(true)
    }

    /// Reports READY and waits for START.
    fn ready(&mut self) -> Result<bool, RunError> {
        self.status(ControlMsg::READY, 0)?;
        while !self.started {
            if !self.wait()? {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// After the last step: report DONE (with `msg`) and wait for STOP.
    fn done(&mut self, msg: ControlMsg) -> Result<(), RunError> {
        self.status.send(msg)?;
        while self.wait()? {}
        Ok(())
    }

    /// Tells the orchestrator why this node stops.
    fn report(&self, step: u64, e: &RunError) {
        let _ = self
            .status
            .send(ControlMsg::new(ControlMsg::FAILED, self.role, step).with_reason(&e.to_string()));
    }
}

fn contract(node: Node, message: String) -> RunError {
    RunError::Contract {
        node: node.name(),
        message,
    }
}

/// Runs `body` and reports its failure on the status channel (the orchestrator names us).
fn reporting(
    run_id: &str,
    role: Node,
    body: impl FnOnce(&mut Ctx, &mut u64) -> Result<(), RunError>,
) -> Result<(), RunError> {
    let mut ctx = Ctx::new(run_id, role)?;
    let mut step = 0;
    let r = body(&mut ctx, &mut step);
    if let Err(e) = &r {
        if !matches!(e, RunError::Orphaned | RunError::Aborted(_)) {
            ctx.report(step, e);
        }
    }
    r
}

/// The native plant process: integrates every vehicle with the model of `platoon-sim`.
pub fn plant(run_id: &str, scenario: &Scenario) -> Result<(), RunError> {
    reporting(run_id, Node::Plant, |ctx, k| {
        let e = &ctx.endpoint;
        let n = scenario.topology.followers();
        let states_out: Outlet<VehicleState> = e.outlet(
            &e.open_step_service(Service::States)?,
            Service::States,
            n + 1,
        )?;
        let mut commands: Inlet<Command> =
            Inlet::new(&e.open_step_service(Service::Commands)?, Node::Controller)?;
        let mut plant = Plant::new(scenario);
        let mut buf = Vec::with_capacity(n + 1);
        let mut u = vec![0.0; n];
        if !ctx.ready()? {
            return Ok(());
        }
        let publish = |k: u64, plant: &Plant, buf: &mut Vec<VehicleState>| {
            buf.clear();
            buf.extend(
                plant
                    .states()
                    .iter()
                    .enumerate()
                    .map(|(i, x)| VehicleState {
                        vehicle: i as u32,
                        flags: 0,
                        p: x[0],
                        v: x[1],
                        a: x[2],
                    }),
            );
            states_out.send(k, scenario.dt(), buf)
        };
        publish(0, &plant, &mut buf)?;
        loop {
            let (got, _) = commands.take(*k)?;
            let Some(cmds) = got else {
                if !ctx.wait()? {
                    return Ok(());
                }
                continue;
            };
            commands_into(&cmds, &mut u)?;
            plant.advance(*k, &u);
            if *k == scenario.steps {
                return ctx.done(ControlMsg::new(ControlMsg::DONE, Node::Plant, *k));
            }
            *k += 1;
            publish(*k, &plant, &mut buf)?;
        }
    })
}

/// Checks a command batch (one finite command per follower) and copies it into `u`.
fn commands_into(cmds: &[Command], u: &mut [f64]) -> Result<(), RunError> {
    if cmds.len() != u.len() {
        return Err(contract(
            Node::Controller,
            format!("{} commands for {} followers", cmds.len(), u.len()),
        ));
    }
    for c in cmds {
        let i = c.vehicle as usize;
        if i == 0 || i > u.len() || !c.u.is_finite() {
            return Err(contract(
                Node::Controller,
                format!("bad command for vehicle {}: {}", c.vehicle, c.u),
            ));
        }
        u[i - 1] = c.u;
    }
    Ok(())
}

/// The controller service: every follower's triggering rule, estimators and control law.
pub fn controller(run_id: &str, scenario: &Scenario) -> Result<(), RunError> {
    reporting(run_id, Node::Controller, |ctx, k| {
        let e = &ctx.endpoint;
        let n = scenario.topology.followers();
        let mut states_in: Inlet<VehicleState> =
            Inlet::new(&e.open_step_service(Service::States)?, Node::Plant)?;
        let mut rx_in: Inlet<LinkPacket> =
            Inlet::new(&e.open_step_service(Service::Rx)?, Node::Injector)?;
        let links: usize = (0..=n)
            .map(|v| scenario.topology.out_neighbours(VehicleId(v as u16)).len())
            .sum();
        let tx_out: Outlet<LinkPacket> =
            e.outlet(&e.open_step_service(Service::Tx)?, Service::Tx, links)?;
        let cmd_out: Outlet<Command> = e.outlet(
            &e.open_step_service(Service::Commands)?,
            Service::Commands,
            n,
        )?;
        let mut controller = PlatoonController::new(
            scenario.control.clone(),
            &scenario.topology,
            &scenario.initial,
        )
        .map_err(|e| contract(Node::Controller, e.to_string()))?;
        let mut states: Option<Vec<State>> = None;
        let (mut tx, mut wire_tx, mut deliveries, mut jammed, mut cmds) = (
            Vec::new(),
            Vec::new(),
            Vec::new(),
            vec![false; n + 1],
            Vec::with_capacity(n),
        );
        if !ctx.ready()? {
            return Ok(());
        }
        loop {
            if states.is_none() {
                if let (Some(s), _) = states_in.take(*k)? {
                    let s = states_from_wire(&s, n + 1)?;
                    tx.clear();
                    controller.transmit(*k, &s, &mut tx);
                    wire_tx.clear();
                    let stamp = monotonic_ns();
                    for p in &tx {
                        let packet = packet_to_wire(p, stamp);
                        wire_tx.extend(scenario.topology.out_neighbours(p.sender).iter().map(
                            |r| LinkPacket {
                                receiver: u32::from(r.0),
                                kind: LinkPacket::DELIVERY,
                                packet,
                            },
                        ));
                    }
                    tx_out.send(*k, scenario.dt(), &wire_tx)?;
                    states = Some(s);
                }
            }
            if let Some(s) = &states {
                if let (Some(items), _) = rx_in.take(*k)? {
                    deliveries.clear();
                    jammed.fill(false);
                    for it in &items {
                        match it.kind {
                            LinkPacket::JAMMED => {
                                if let Some(j) = jammed.get_mut(it.receiver as usize) {
                                    *j = true;
                                }
                            }
                            _ => deliveries.push(delivery_from_wire(it)),
                        }
                    }
                    controller.receive(*k, s, &deliveries, &jammed);
                    cmds.clear();
                    cmds.extend((1..=n).map(|i| {
                        let f = controller.follower_step(VehicleId(i as u16));
                        Command {
                            vehicle: i as u32,
                            flags: u32::from(f.triggered) * Command::TRIGGERED
                                + u32::from(f.affected) * Command::AFFECTED,
                            u: f.u,
                            theta: f.theta,
                        }
                    }));
                    cmd_out.send(*k, scenario.dt(), &cmds)?;
                    states = None;
                    if *k == scenario.steps {
                        let r = controller.rejected();
                        let mut done = ControlMsg::new(ControlMsg::DONE, Node::Controller, *k);
                        done.counts = [r.non_finite, r.unknown_sender, r.future_step, r.stale_seq];
                        return ctx.done(done);
                    }
                    *k += 1;
                    continue; // the next states may already be here
                }
            }
            if !ctx.wait()? {
                return Ok(());
            }
        }
    })
}

/// Plant states from the wire, leader first; the plant must send every vehicle in order.
pub fn states_from_wire(s: &[VehicleState], vehicles: usize) -> Result<Vec<State>, RunError> {
    if s.len() != vehicles || s.iter().enumerate().any(|(i, x)| x.vehicle as usize != i) {
        return Err(contract(
            Node::Plant,
            format!(
                "a state batch must list vehicles 0..{vehicles} in order, got {} entries",
                s.len()
            ),
        ));
    }
    Ok(s.iter().map(|x| State::new(x.p, x.v, x.a)).collect())
}

/// A packet onto the wire.
pub fn packet_to_wire(p: &Packet, stamp_ns: u64) -> V2vPacket {
    V2vPacket {
        sender: u32::from(p.sender.0),
        seq: p.seq,
        step: p.step,
        stamp_ns,
        state: [p.state[0], p.state[1], p.state[2]],
    }
}

/// A packet off the wire. A sender id that does not fit a `VehicleId` becomes one no vehicle
/// has, so the controller refuses it as an unknown sender.
pub fn packet_from_wire(p: &V2vPacket) -> Packet {
    Packet {
        sender: VehicleId(u16::try_from(p.sender).unwrap_or(u16::MAX)),
        seq: p.seq,
        step: p.step,
        state: State::from(p.state),
    }
}

fn delivery_from_wire(it: &LinkPacket) -> Delivery {
    Delivery {
        receiver: VehicleId(u16::try_from(it.receiver).unwrap_or(u16::MAX)),
        packet: packet_from_wire(&it.packet),
    }
}

/// The Rust attack injector: the channel of `platoon-attacks` between the controllers. Writes
/// its log (every packet not delivered as sent) to `log` as CSV.
pub fn injector(run_id: &str, scenario: &Scenario, log: Option<&Path>) -> Result<(), RunError> {
    reporting(run_id, Node::Injector, |ctx, k| {
        let e = &ctx.endpoint;
        let n = scenario.topology.followers();
        let mut states_in: Inlet<VehicleState> =
            Inlet::new(&e.open_step_service(Service::States)?, Node::Plant)?;
        let mut tx_in: Inlet<LinkPacket> =
            Inlet::new(&e.open_step_service(Service::Tx)?, Node::Controller)?;
        let rx_out: Outlet<LinkPacket> =
            e.outlet(&e.open_step_service(Service::Rx)?, Service::Rx, 4 * (n + 1))?;
        let mut writer = match log {
            Some(p) => Some(csv::Writer::from_path(p).map_err(|e| {
                contract(Node::Injector, format!("cannot write {}: {e}", p.display()))
            })?),
            None => None,
        };
        let mut channel = Channel::new(scenario.channel_spec(), n + 1);
        let (mut states, mut deliveries, mut jammed, mut events, mut items) = (
            None::<Vec<State>>,
            Vec::new(),
            vec![false; n + 1],
            Vec::<ChannelEvent>::new(),
            Vec::new(),
        );
        if !ctx.ready()? {
            return Ok(());
        }
        loop {
            if states.is_none() {
                if let (Some(s), _) = states_in.take(*k)? {
                    states = Some(states_from_wire(&s, n + 1)?);
                }
            }
            if let Some(s) = &states {
                if let (Some(tx), _) = tx_in.take(*k)? {
                    // One item per link: the broadcasts are the runs of equal (sender, seq).
                    let mut packets: Vec<Packet> = Vec::new();
                    for it in &tx {
                        let p = packet_from_wire(&it.packet);
                        if packets
                            .last()
                            .is_none_or(|l| (l.sender, l.seq) != (p.sender, p.seq))
                        {
                            packets.push(p);
                        }
                    }
                    deliveries.clear();
                    events.clear();
                    channel.gate(
                        *k,
                        *k as f64 * scenario.dt(),
                        &scenario.topology,
                        s,
                        &packets,
                        &mut deliveries,
                        &mut jammed,
                        &mut events,
                    );
                    items.clear();
                    items.extend(deliveries.iter().map(|d| LinkPacket {
                        receiver: u32::from(d.receiver.0),
                        kind: LinkPacket::DELIVERY,
                        packet: packet_to_wire(&d.packet, monotonic_ns()),
                    }));
                    items.extend(jammed.iter().enumerate().filter(|(_, &j)| j).map(|(v, _)| {
                        LinkPacket {
                            receiver: v as u32,
                            kind: LinkPacket::JAMMED,
                            packet: V2vPacket::default(),
                        }
                    }));
                    rx_out.send(*k, scenario.dt(), &items)?;
                    if let Some(w) = &mut writer {
                        for ev in &events {
                            w.serialize(ev).map_err(|e| {
                                contract(Node::Injector, format!("writing the channel log: {e}"))
                            })?;
                        }
                    }
                    states = None;
                    if *k == scenario.steps {
                        if let Some(w) = &mut writer {
                            w.flush().map_err(|e| {
                                contract(Node::Injector, format!("writing the channel log: {e}"))
                            })?;
                        }
                        return ctx.done(ControlMsg::new(ControlMsg::DONE, Node::Injector, *k));
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
