//! The session every process of an iceoryx2 run shares, below the built-in nodes and the SDKs:
//! a node's endpoint, wake-up listener and control/status channels (READY, START, DONE,
//! STOP/ABORT, orphan detection), failure reporting, the fleet's vehicle
//! numbering on the wire ([`Numbering`]) and the conversions between wire payloads and the pure
//! core's types. The injector and controller SDKs ([`crate::injector`], [`crate::controller`])
//! and the built-in nodes ([`crate::nodes`]) are written on it; none imports another's
//! internals.
use crate::ipc::{wait, ControlInlet, ControlOutlet, Endpoint};
use crate::CosimError;
use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::ipc;
use platoon_control::{Delivery, Packet};
use platoon_maneuver::{Body, Change, Message, Refusal, EVERYONE};
use platoon_model::{State, VehicleId};
use platoon_sim::Scenario;
use platoon_v2v::Opaque;
use platoon_wire::{
    ControlMsg, LinkPacket, Node, Service, TrafficVehicle, V2vPacket, VehicleState,
};
use std::time::Duration;

/// How long a node sleeps between checks that its orchestrator is still there.
const TICK: Duration = Duration::from_millis(200);

/// How long a node that reported FAILED waits for the orchestrator's ABORT before it exits.
const FAILED_WAIT: Duration = Duration::from_secs(10);

/// What every node has: its endpoint, wake-up listener, the control channel and its status
/// outlet, and the pid of the orchestrator that started it.
pub(crate) struct Ctx {
    role: Node,
    pub(crate) endpoint: Endpoint,
    listener: Listener<ipc::Service>,
    control: ControlInlet,
    status: ControlOutlet,
    parent: u32,
    started: bool,
}

impl Ctx {
    fn new(run_id: &str, role: Node) -> Result<Self, CosimError> {
        // Before opening anything: a process of another version cannot connect, and would only
        // say that the services are incompatible.
        check_contract_version()?;
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

    fn status(&self, kind: u32, step: u64) -> Result<(), CosimError> {
        self.status.send(ControlMsg::new(kind, self.role, step))
    }

    /// Blocks until notified (or a tick passes). `Ok(false)` means STOP: exit cleanly.
    pub(crate) fn wait(&mut self) -> Result<bool, CosimError> {
        wait(&self.listener, TICK)?;
        while let Some(m) = self.control.next()? {
            match m.kind {
                ControlMsg::START => self.started = true,
                ControlMsg::STOP => return Ok(false),
                ControlMsg::ABORT => return Err(CosimError::Aborted(m.reason())),
                _ => {}
            }
        }
        if std::os::unix::process::parent_id() != self.parent {
            return Err(CosimError::Orphaned);
        }
        Ok(true)
    }

    /// Reports READY and waits for START.
    pub(crate) fn ready(&mut self) -> Result<bool, CosimError> {
        self.status(ControlMsg::READY, 0)?;
        while !self.started {
            if !self.wait()? {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Sends the orchestrator a status message (a report besides READY, DONE and FAILED).
    pub(crate) fn report_status(&self, msg: ControlMsg) -> Result<(), CosimError> {
        self.status.send(msg)
    }

    /// After the last step: report DONE (with `msg`) and wait for STOP.
    pub(crate) fn done(&mut self, msg: ControlMsg) -> Result<(), CosimError> {
        self.status.send(msg)?;
        while self.wait()? {}
        Ok(())
    }

    /// Tells the orchestrator why this node stops, then waits for its ABORT (at most
    /// [`FAILED_WAIT`], or until it is gone): the report lives in this process's status
    /// publisher, and a process that exits at once may take it with it, leaving the run to name
    /// its exit instead of its report.
    fn report(&mut self, step: u64, e: &CosimError) {
        let sent = self.status.send(
            ControlMsg::new(ControlMsg::FAILED, self.role, step)
                .with_reason(&crate::Causes(e).to_string()),
        );
        if sent.is_err() {
            return;
        }
        let until = std::time::Instant::now() + FAILED_WAIT;
        while std::time::Instant::now() < until && matches!(self.wait(), Ok(true)) {}
    }
}

/// Whether this process speaks the contract version of the run that started it
/// (`PLATOON_CONTRACT_VERSION`, set by `platoon run` for every process; absent: nothing to
/// compare). The error names both versions and the document to read.
pub fn check_contract_version() -> Result<(), CosimError> {
    let run = std::env::var(platoon_wire::CONTRACT_VERSION_ENV).ok();
    platoon_wire::check_contract_version(run.as_deref()).map_err(CosimError::ContractVersion)
}

pub(crate) fn contract(node: Node, message: String) -> CosimError {
    CosimError::Contract {
        node: node.name(),
        message,
    }
}

/// Runs `body` and reports its failure on the status channel (the orchestrator names us).
pub(crate) fn reporting(
    run_id: &str,
    role: Node,
    body: impl FnOnce(&mut Ctx, &mut u64) -> Result<(), CosimError>,
) -> Result<(), CosimError> {
    let mut ctx = Ctx::new(run_id, role)?;
    let mut step = 0;
    let r = body(&mut ctx, &mut step);
    if let Err(e) = &r {
        if !matches!(e, CosimError::Orphaned | CosimError::Aborted(_)) {
            // The whole error into the log (stderr) first: the report's reason is cut to 120
            // bytes, and the process may be killed soon after the orchestrator reads it.
            eprintln!("{}: step {step}: {}", role.name(), crate::Causes(e));
            ctx.report(step, e);
        }
    }
    r
}

/// Vehicle numbering of a fleet: vehicle `i` of platoon `j` has the global id `j * (N + 1) + i`
/// on the wire; follower commands are indexed `j * N + i - 1`.
#[derive(Debug, Clone, Copy)]
pub struct Numbering {
    /// N + 1.
    pub per_platoon: usize,
    /// Number of platoons.
    pub platoons: usize,
}

impl Numbering {
    /// The numbering of `scenario`'s fleet.
    pub fn of(scenario: &Scenario) -> Self {
        Self {
            per_platoon: scenario.vehicles_per_platoon(),
            platoons: scenario.fleet.platoons,
        }
    }

    /// All vehicles.
    pub fn vehicles(&self) -> usize {
        self.per_platoon * self.platoons
    }

    /// All followers.
    pub fn followers(&self) -> usize {
        (self.per_platoon - 1) * self.platoons
    }

    /// The wire id of vehicle `i` of platoon `j`.
    pub fn global(&self, j: usize, i: VehicleId) -> u32 {
        (j * self.per_platoon + i.index()) as u32
    }

    /// Platoon and vehicle of a wire id, if it exists.
    pub fn split(&self, g: u32) -> Option<(usize, VehicleId)> {
        let g = g as usize;
        (g < self.vehicles()).then(|| {
            (
                g / self.per_platoon,
                VehicleId((g % self.per_platoon) as u16),
            )
        })
    }
}

/// Plant states from the wire, leader first; the plant must send every vehicle in order.
pub fn states_from_wire(s: &[VehicleState], vehicles: usize) -> Result<Vec<State>, CosimError> {
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

/// Checks a traffic sample of step `k` from the plant: background vehicle `b` as item `b`, a
/// finite position for every vehicle on the road, and `expected` items if given (the count
/// never changes during a run). The error names the plant.
pub fn check_traffic(
    items: &[TrafficVehicle],
    expected: Option<usize>,
    k: u64,
) -> Result<(), CosimError> {
    if let Some(n) = expected.filter(|&n| n != items.len()) {
        return Err(contract(
            Node::Plant,
            format!(
                "the traffic sample of step {k} lists {} background vehicles, not {n}",
                items.len()
            ),
        ));
    }
    for (b, it) in items.iter().enumerate() {
        if it.index as usize != b {
            return Err(contract(
                Node::Plant,
                format!(
                    "the traffic sample of step {k} has vehicle {} as item {b}: it lists the \
                     background vehicles 0..{} in order",
                    it.index,
                    items.len()
                ),
            ));
        }
        if it.flags & TrafficVehicle::ON_ROAD != 0 && !it.p.is_finite() {
            return Err(contract(
                Node::Plant,
                format!(
                    "the traffic sample of step {k} has background vehicle {b} on the road at \
                     p = {}",
                    it.p
                ),
            ));
        }
    }
    Ok(())
}

/// Sorts an rx batch into each platoon's deliveries and jammed notices (both cleared first).
/// Whatever the items hold, nothing panics: a receiver no vehicle has goes to platoon 0 as a
/// delivery to an unknown receiver (its controllers count it), a sender of another platoon or
/// of no vehicle becomes an unknown sender, a jammed notice for no vehicle is ignored.
pub fn deliveries_from_wire(
    items: &[LinkPacket],
    num: Numbering,
    deliveries: &mut [Vec<Delivery>],
    jammed: &mut [bool],
) {
    for d in deliveries.iter_mut() {
        d.clear();
    }
    jammed.fill(false);
    for it in items {
        let Some((j, receiver)) = num.split(it.receiver) else {
            if it.kind != LinkPacket::JAMMED {
                deliveries[0].push(Delivery {
                    receiver: VehicleId(u16::MAX),
                    packet: packet_from_wire(&it.packet, 0, num),
                });
            }
            continue;
        };
        match it.kind {
            LinkPacket::JAMMED => jammed[it.receiver as usize] = true,
            _ => {
                let packet = packet_from_wire(&it.packet, j, num);
                deliveries[j].push(Delivery { receiver, packet });
            }
        }
    }
}

/// A controller's inspection of a packet of platoon `j` onto the wire (wire ids; a vehicle the
/// platoon does not have, `u16::MAX`, becomes `u32::MAX`).
pub fn inspection_to_wire(
    i: &platoon_control::Inspection,
    j: usize,
    num: Numbering,
) -> platoon_wire::Inspection {
    use platoon_wire::Inspection as W;
    let global = |v: VehicleId| {
        if v.0 == u16::MAX {
            u32::MAX
        } else {
            num.global(j, v)
        }
    };
    let mut flags = u32::from(i.flagged) * W::FLAGGED + u32::from(i.refused) * W::REFUSED;
    flags |= u32::from(i.refused_by.map_or(0, |r| r.code())) << W::REFUSED_BY_SHIFT;
    let mut scores = [f64::NAN; 8];
    for (d, (v, score)) in i.verdicts().iter().zip(&mut scores).enumerate() {
        flags |= u32::from(v.flagged) << (W::DETECTOR_SHIFT + d as u32);
        *score = v.score;
    }
    W {
        receiver: global(i.receiver),
        sender: global(i.sender),
        seq: i.seq,
        flags,
        step: i.step,
        state: [i.state[0], i.state[1], i.state[2]],
        scores,
    }
}

/// Inspections of step `k` from the wire, sorted into each platoon's (`detectors` verdicts
/// each), in their order; ids of no vehicle of the platoon become `u16::MAX`, as
/// [`deliveries_from_wire`] makes them, so an inspection still joins its delivery.
pub fn inspections_from_wire(
    k: u64,
    items: &[platoon_wire::Inspection],
    num: Numbering,
    detectors: usize,
    out: &mut [Vec<platoon_control::Inspection>],
) {
    for o in out.iter_mut() {
        o.clear();
    }
    let mut verdicts = [platoon_control::screening::Verdict::NOT_TESTED; 8];
    let detectors = detectors.min(verdicts.len());
    for it in items {
        // As `deliveries_from_wire` sorts the deliveries they join.
        let (j, receiver, sender) = match num.split(it.receiver) {
            Some((j, receiver)) => match num.split(it.sender) {
                Some((js, i)) if js == j => (j, receiver, i),
                _ => (j, receiver, VehicleId(u16::MAX)),
            },
            None => (
                0,
                VehicleId(u16::MAX),
                VehicleId(u16::try_from(it.sender).unwrap_or(u16::MAX)),
            ),
        };
        for (d, v) in verdicts.iter_mut().enumerate().take(detectors) {
            *v = platoon_control::screening::Verdict {
                flagged: it.flagged_by(d),
                score: it.scores[d],
            };
        }
        // What refused it, when the controller said (a plug-in may not: then only `refused`);
        // a packet the checks refused reached no detector, and a record of a message dropped
        // as old carries no verdict.
        let by = platoon_control::RefusedBy::from_code(it.refused_by());
        let tested = match by {
            Some(b) if b.by_checks() || !b.refuses_packet() => 0,
            _ => detectors,
        };
        let i = platoon_control::Inspection::new(
            k,
            receiver,
            (sender, it.seq, it.step, State::from(it.state)),
            it.flags & platoon_wire::Inspection::FLAGGED != 0,
            it.flags & platoon_wire::Inspection::REFUSED != 0,
            &verdicts[..tested],
        );
        out[j].push(match by {
            Some(_) => i.with_refusal(by),
            None => i,
        });
    }
}

/// The link a tx item is of: its platoon, receiver and packet with the platoon's own sender
/// id; `None` when an id is of no vehicle or the two are of different platoons (such an item
/// links nobody).
pub fn link_from_wire(it: &LinkPacket, num: Numbering) -> Option<(usize, VehicleId, Packet)> {
    let (j, receiver) = num.split(it.receiver)?;
    let (js, _) = num.split(it.packet.sender)?;
    (j == js).then(|| (j, receiver, packet_from_wire(&it.packet, j, num)))
}

/// A packet of platoon `j` onto the wire: sender and head as wire ids.
pub fn packet_to_wire(p: &Packet, stamp_ns: u64, j: usize, num: Numbering) -> V2vPacket {
    let mut wire = V2vPacket {
        sender: num.global(j, p.sender),
        seq: p.seq,
        step: p.step,
        stamp_ns,
        state: [p.state[0], p.state[1], p.state[2]],
        u: p.u,
        // A head no vehicle has (one a receiver could not place) stays one.
        head: if p.head.0 == u16::MAX {
            u32::MAX
        } else {
            num.global(j, p.head)
        },
        ..maneuver_to_wire(p.maneuver.as_ref(), j, num)
    };
    opaque_to_wire(p.seal.as_ref(), &mut wire.seal_len, &mut wire.seal);
    opaque_to_wire(p.group.as_ref(), &mut wire.group_len, &mut wire.group);
    wire
}

/// Opaque bytes riding on a packet (its seal, its group-key fields) into a wire buffer and its
/// length field (none: both left 0).
fn opaque_to_wire<const N: usize>(o: Option<&Opaque<N>>, len: &mut u32, buf: &mut [u8; N]) {
    if let Some(o) = o {
        let bytes = o.as_bytes();
        *len = bytes.len() as u32;
        buf[..bytes.len()].copy_from_slice(bytes);
    }
}

/// Opaque bytes off the wire: none when `len` is 0. A length beyond the buffer says the bytes
/// are longer than any the sender makes: they become `overlong`, which the receiver refuses
/// as `malformed` whatever the buffer holds; never a panic.
fn opaque_from_wire<const N: usize>(len: u32, buf: &[u8; N], overlong: &[u8]) -> Option<Opaque<N>> {
    let len = len as usize;
    if len > N {
        return Opaque::new(overlong);
    }
    (len > 0).then(|| Opaque::new(&buf[..len]))?
}

/// The group-key fields of a wire packet whose `group_len` exceeds the buffer: flags no field
/// has, refused as `malformed`.
const OVERLONG_GROUP: [u8; 1] = [0xff];

/// The seal of a wire packet whose `seal_len` exceeds the buffer: a header version no header
/// has (0), refused as `malformed`.
const OVERLONG_SEAL: [u8; 1] = [0];

/// A maneuver message of platoon `j` as the maneuver fields of a [`V2vPacket`] (the others 0);
/// without one, every maneuver field 0 ([`V2vPacket::NO_MANEUVER`]).
fn maneuver_to_wire(m: Option<&Message>, j: usize, num: Numbering) -> V2vPacket {
    let id = |v: VehicleId| {
        if v.0 == u16::MAX {
            V2vPacket::NOBODY
        } else {
            num.global(j, v)
        }
    };
    let Some(m) = m else {
        return V2vPacket::default();
    };
    let (kind, arg, vehicle, behind) = match m.body {
        Body::JoinRequest { behind } => (V2vPacket::JOIN_REQUEST, 0, Some(behind), None),
        Body::JoinAccept { behind, middle } => (
            V2vPacket::JOIN_ACCEPT,
            u16::from(middle),
            Some(behind),
            None,
        ),
        Body::JoinRefuse { reason } => (V2vPacket::JOIN_REFUSE, refusal_code(reason), None, None),
        Body::OpenGap { joiner } => (V2vPacket::OPEN_GAP, 0, Some(joiner), None),
        Body::GapReady { joiner } => (V2vPacket::GAP_READY, 0, Some(joiner), None),
        Body::MoveIn => (V2vPacket::MOVE_IN, 0, None, None),
        Body::InPosition => (V2vPacket::IN_POSITION, 0, None, None),
        Body::Update {
            generation,
            change: Change::Joined { vehicle, behind },
        } => (
            V2vPacket::UPDATE_JOINED,
            generation,
            Some(vehicle),
            Some(behind),
        ),
        Body::Update {
            generation,
            change: Change::Left { vehicle },
        } => (V2vPacket::UPDATE_LEFT, generation, Some(vehicle), None),
        Body::Abort { joiner } => (V2vPacket::ABORT, 0, Some(joiner), None),
        Body::LeaveNotice => (V2vPacket::LEAVE_NOTICE, 0, None, None),
        Body::MergeRequest { behind, tail } => {
            (V2vPacket::MERGE_REQUEST, 0, Some(behind), Some(tail))
        }
        Body::Update {
            generation,
            change: Change::Merged { head, tail },
        } => (V2vPacket::UPDATE_MERGED, generation, Some(head), Some(tail)),
        Body::SplitNotice => (V2vPacket::SPLIT_NOTICE, 0, None, None),
        Body::Update {
            generation,
            change: Change::Split { head },
        } => (V2vPacket::UPDATE_SPLIT, generation, Some(head), None),
    };
    V2vPacket {
        maneuver: kind,
        maneuver_arg: arg,
        maneuver_to: if m.to == EVERYONE {
            V2vPacket::EVERYONE
        } else {
            id(m.to)
        },
        maneuver_seq: u32::from(m.seq),
        maneuver_vehicle: vehicle.map_or(V2vPacket::NOBODY, id),
        maneuver_behind: behind.map_or(V2vPacket::NOBODY, id),
        ..V2vPacket::default()
    }
}

fn refusal_code(r: Refusal) -> u16 {
    match r {
        Refusal::Busy => V2vPacket::REFUSED_BUSY,
        Refusal::Full => V2vPacket::REFUSED_FULL,
        Refusal::NoSlot => V2vPacket::REFUSED_NO_SLOT,
        Refusal::Member => V2vPacket::REFUSED_MEMBER,
    }
}

/// The maneuver message a [`V2vPacket`] carries, with the ids of platoon `j`; `None` without
/// one, and for one no receiver could act on (an unknown kind or reason, a sequence number
/// beyond 16 bits, a vehicle it needs that is of another platoon or of none): such a message is
/// dropped, the packet's beacon stays.
fn maneuver_from_wire(
    p: &V2vPacket,
    sender: VehicleId,
    j: usize,
    num: Numbering,
) -> Option<Message> {
    let id = |g: u32| match num.split(g) {
        Some((jg, i)) if jg == j => Some(i),
        _ => None,
    };
    let vehicle = || id(p.maneuver_vehicle);
    let body = match p.maneuver {
        V2vPacket::NO_MANEUVER => return None,
        V2vPacket::JOIN_REQUEST => Body::JoinRequest { behind: vehicle()? },
        V2vPacket::JOIN_ACCEPT => Body::JoinAccept {
            behind: vehicle()?,
            middle: match p.maneuver_arg {
                0 => false,
                1 => true,
                _ => return None,
            },
        },
        V2vPacket::JOIN_REFUSE => Body::JoinRefuse {
            reason: match p.maneuver_arg {
                V2vPacket::REFUSED_BUSY => Refusal::Busy,
                V2vPacket::REFUSED_FULL => Refusal::Full,
                V2vPacket::REFUSED_NO_SLOT => Refusal::NoSlot,
                V2vPacket::REFUSED_MEMBER => Refusal::Member,
                _ => return None,
            },
        },
        V2vPacket::OPEN_GAP => Body::OpenGap { joiner: vehicle()? },
        V2vPacket::GAP_READY => Body::GapReady { joiner: vehicle()? },
        V2vPacket::MOVE_IN => Body::MoveIn,
        V2vPacket::IN_POSITION => Body::InPosition,
        V2vPacket::UPDATE_JOINED => Body::Update {
            generation: p.maneuver_arg,
            change: Change::Joined {
                vehicle: vehicle()?,
                behind: id(p.maneuver_behind)?,
            },
        },
        V2vPacket::UPDATE_LEFT => Body::Update {
            generation: p.maneuver_arg,
            change: Change::Left {
                vehicle: vehicle()?,
            },
        },
        V2vPacket::ABORT => Body::Abort { joiner: vehicle()? },
        V2vPacket::LEAVE_NOTICE => Body::LeaveNotice,
        V2vPacket::MERGE_REQUEST => Body::MergeRequest {
            behind: vehicle()?,
            tail: id(p.maneuver_behind)?,
        },
        V2vPacket::UPDATE_MERGED => Body::Update {
            generation: p.maneuver_arg,
            change: Change::Merged {
                head: vehicle()?,
                tail: id(p.maneuver_behind)?,
            },
        },
        V2vPacket::SPLIT_NOTICE => Body::SplitNotice,
        V2vPacket::UPDATE_SPLIT => Body::Update {
            generation: p.maneuver_arg,
            change: Change::Split { head: vehicle()? },
        },
        _ => return None,
    };
    Some(Message {
        sender,
        to: if p.maneuver_to == V2vPacket::EVERYONE {
            EVERYONE
        } else {
            id(p.maneuver_to)?
        },
        seq: u16::try_from(p.maneuver_seq).ok()?,
        body,
    })
}

/// A packet off the wire with the ids of platoon `j`: a sender or head of another platoon or of
/// no vehicle becomes one no vehicle has (`u16::MAX`), so the controller refuses the packet as
/// from an unknown sender and never takes such a head.
pub fn packet_from_wire(p: &V2vPacket, j: usize, num: Numbering) -> Packet {
    let local = |g: u32| match num.split(g) {
        Some((jg, i)) if jg == j => i,
        _ => VehicleId(u16::MAX),
    };
    let sender = local(p.sender);
    Packet {
        sender,
        seq: p.seq,
        step: p.step,
        state: State::from(p.state),
        u: p.u,
        head: local(p.head),
        maneuver: maneuver_from_wire(p, sender, j, num),
        seal: opaque_from_wire(p.seal_len, &p.seal, &OVERLONG_SEAL),
        group: opaque_from_wire(p.group_len, &p.group, &OVERLONG_GROUP),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every maneuver message crosses the wire as it was, in any platoon of a fleet; one a
    /// receiver could not act on is dropped and the beacon kept.
    #[test]
    fn maneuver_messages_cross_the_wire_unchanged() {
        let num = Numbering {
            per_platoon: 5,
            platoons: 3,
        };
        let v = VehicleId;
        let bodies = [
            Body::JoinRequest { behind: v(3) },
            Body::JoinAccept {
                behind: v(1),
                middle: true,
            },
            Body::JoinRefuse {
                reason: Refusal::NoSlot,
            },
            Body::OpenGap { joiner: v(4) },
            Body::GapReady { joiner: v(4) },
            Body::MoveIn,
            Body::InPosition,
            Body::Update {
                generation: 7,
                change: Change::Joined {
                    vehicle: v(4),
                    behind: v(2),
                },
            },
            Body::Update {
                generation: 8,
                change: Change::Left { vehicle: v(2) },
            },
            Body::Abort { joiner: v(4) },
            Body::LeaveNotice,
            Body::MergeRequest {
                behind: v(2),
                tail: v(4),
            },
            Body::Update {
                generation: 9,
                change: Change::Merged {
                    head: v(3),
                    tail: v(4),
                },
            },
            Body::SplitNotice,
            Body::Update {
                generation: 10,
                change: Change::Split { head: v(3) },
            },
        ];
        for j in 0..3 {
            for (i, body) in bodies.into_iter().enumerate() {
                let m = Message {
                    sender: v(4),
                    to: if i % 2 == 0 { EVERYONE } else { v(0) },
                    seq: 40000 + i as u16,
                    body,
                };
                let packet = Packet {
                    sender: v(4),
                    seq: 9,
                    step: 12,
                    state: State::new(1.0, 2.0, 3.0),
                    u: 0.5,
                    head: v(0),
                    maneuver: Some(m),
                    // A seal of `[security]` (its bytes opaque here) crosses as it is.
                    seal: platoon_v2v::Seal::new(&[i as u8 + 1; 82]),
                    // So do group-key fields (every other packet: with and without).
                    group: (i % 2 == 0)
                        .then(|| platoon_v2v::GroupSeal::new(&[i as u8 + 7; 110]))
                        .flatten(),
                };
                let wire = packet_to_wire(&packet, 0, j, num);
                assert_eq!(packet_from_wire(&wire, j, num), packet, "{body:?}");
                // A vehicle of another platoon, or an unknown kind: the message goes.
                let mut bad = wire;
                bad.maneuver = 99;
                assert_eq!(packet_from_wire(&bad, j, num).maneuver, None);
                if wire.maneuver_vehicle != V2vPacket::NOBODY {
                    bad = wire;
                    bad.maneuver_vehicle = num.global((j + 1) % 3, v(1));
                    let got = packet_from_wire(&bad, j, num);
                    assert_eq!((got.maneuver, got.state), (None, packet.state));
                }
                if wire.maneuver_behind != V2vPacket::NOBODY {
                    bad = wire;
                    bad.maneuver_behind = num.global((j + 1) % 3, v(1));
                    assert_eq!(packet_from_wire(&bad, j, num).maneuver, None);
                }
            }
        }
        let plain = Packet {
            maneuver: None,
            ..packet_from_wire(&V2vPacket::default(), 0, num)
        };
        assert_eq!(
            packet_to_wire(&plain, 0, 0, num).maneuver,
            V2vPacket::NO_MANEUVER
        );
    }

    fn t(index: u32, flags: u32, p: f64) -> TrafficVehicle {
        TrafficVehicle { index, flags, p }
    }

    /// A malformed traffic sample is a contract error that names the plant, never a panic.
    #[test]
    fn a_malformed_traffic_sample_names_the_plant() {
        let on = TrafficVehicle::ON_ROAD;
        let good = [t(0, on, 1.0), t(1, 0, f64::NAN), t(2, on, -3.0)];
        assert!(check_traffic(&good, None, 4).is_ok());
        assert!(check_traffic(&good, Some(3), 4).is_ok());
        assert!(check_traffic(&[], None, 4).is_ok());
        for (items, expected, needle) in [
            (&good[..], Some(4), "lists 3 background vehicles, not 4"),
            (
                &[t(0, on, 1.0), t(2, on, 2.0)][..],
                None,
                "has vehicle 2 as item 1",
            ),
            (&[t(0, on, f64::NAN)][..], None, "on the road at p = NaN"),
            (
                &[t(0, on, f64::INFINITY)][..],
                None,
                "on the road at p = inf",
            ),
        ] {
            let e = check_traffic(items, expected, 7).unwrap_err();
            assert_eq!(e.node(), Some("plant"), "{e}");
            let text = e.to_string();
            assert!(text.contains(needle) && text.contains("step 7"), "{text}");
        }
    }

    /// A `seal_len` beyond the buffer is refused as `malformed`, even with a genuine header in
    /// the buffer (cut to the buffer, it would verify); within it the seal crosses as it is.
    #[test]
    fn a_seal_length_beyond_the_buffer_is_refused_as_malformed() {
        use platoon_control::security::{Sealing, SecurityParams};
        let num = Numbering {
            per_platoon: 3,
            platoons: 1,
        };
        let mut sealing = Sealing::new(SecurityParams::default(), 3, 0.01);
        let mut sent = [Packet::beacon(
            VehicleId(1),
            1,
            0,
            State::new(1.0, 2.0, 0.0),
        )];
        sealing.seal(0, &mut sent);
        let wire = packet_to_wire(&sent[0], 0, 0, num);
        // The first packet carries the certificate: the whole buffer.
        assert_eq!(wire.seal_len as usize, V2vPacket::SEAL_CAPACITY);
        for (len, expected) in [
            (V2vPacket::SEAL_CAPACITY as u32, Ok(())),
            (V2vPacket::SEAL_CAPACITY as u32 + 1, Err("malformed")),
            (u32::MAX, Err("malformed")),
            (100, Err("truncated")),
            (0, Err("truncated")),
        ] {
            let packet = packet_from_wire(
                &V2vPacket {
                    seal_len: len,
                    ..wire
                },
                0,
                num,
            );
            sealing.begin_step();
            let d = Delivery {
                receiver: VehicleId(2),
                packet,
            };
            assert_eq!(
                sealing.screen(0, &d).map_err(|r| r.name()),
                expected,
                "seal_len {len}"
            );
        }
    }

    /// A `group_len` beyond the buffer gives group fields the receiver refuses as `malformed`;
    /// one within it crosses as it is.
    #[test]
    fn a_group_length_beyond_the_buffer_is_malformed() {
        use platoon_security::{GroupField, Refusal};
        let num = Numbering {
            per_platoon: 3,
            platoons: 1,
        };
        let mut sent = Packet::beacon(VehicleId(1), 1, 0, State::new(1.0, 2.0, 0.0));
        let field = GroupField {
            share: Some(platoon_security::KeyShare([2; 33])),
            ..GroupField::default()
        };
        sent.group = platoon_v2v::GroupSeal::new(&field.encode());
        let wire = packet_to_wire(&sent, 0, 0, num);
        assert_eq!(packet_from_wire(&wire, 0, num), sent);
        for (len, expected) in [
            (
                V2vPacket::GROUP_CAPACITY as u32 + 1,
                Err(Refusal::Malformed),
            ),
            (u32::MAX, Err(Refusal::Malformed)),
            (20, Err(Refusal::Truncated)),
        ] {
            let got = packet_from_wire(
                &V2vPacket {
                    group_len: len,
                    ..wire
                },
                0,
                num,
            );
            let bytes = got.group.map(|g| g.as_bytes().to_vec()).unwrap();
            assert_eq!(GroupField::decode(&bytes), expected, "group_len {len}");
        }
        let none = packet_from_wire(
            &V2vPacket {
                group_len: 0,
                ..wire
            },
            0,
            num,
        );
        assert_eq!(none.group, None);
        assert_eq!(V2vPacket::GROUP_CAPACITY, platoon_v2v::GroupSeal::CAPACITY);
        const { assert!(platoon_security::GROUP_FIELD_LEN <= platoon_v2v::GroupSeal::CAPACITY) };
    }
}
