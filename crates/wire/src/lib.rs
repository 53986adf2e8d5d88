//! The payloads that cross a process boundary in a platoon co-simulation, and the names of the
//! services that carry them. This crate is the contract between the processes: the controller
//! service, the plant (native or the SUMO bridge), the attack injector (ours or yours) and the
//! orchestrator. `bridge/platoon/wire.py` mirrors every type with `ctypes`, and tests on both
//! sides check size, alignment and every field offset against `bridge/wire_layout.json`.
//!
//! Every publish-subscribe service carries a slice of one element type with a [`StepHeader`]
//! user header, so one sample is one whole step in one direction (see `docs/injector-contract.md`).
#![warn(missing_docs)]

use iceoryx2::prelude::ZeroCopySend;

/// The version of this contract (payload layouts and their meaning). Every payload's type name
/// carries it (`platoon::v5::LinkPacket`), so iceoryx2 refuses to connect a process built for
/// another version, and `platoon run` tells every process it starts which version the run
/// speaks ([`CONTRACT_VERSION_ENV`]); the SDKs compare it with their own before opening anything
/// ([`check_contract_version`]). Raise it with any change of a payload's layout or meaning, and
/// say what changed in `docs/injector-contract.md` ("Contract versions").
///
/// - v1: the first published contract.
/// - v2: [`V2vPacket`] gained `u`, the sender's latest command (56 bytes, was 48). Later, still
///   v2: the optional [`Service::Traffic`] of [`TrafficVehicle`]s (a new service; no payload
///   of v2 changed, and a plug-in that does not open it is unaffected). Later, still v2: the
///   optional [`Service::Inspections`] of [`Inspection`]s (the same way: a new service).
///   Later, still v4: [`Inspection::flags`] bits 2-5 say what refused the packet, and an
///   inspection may record a packet the packet checks refused before any detector (bits that
///   were 0, and every reader tests bits).
///   Later, still v2: [`VehicleState::flags`] bits 8-31 name an intruder
///   ([`VehicleState::TARGET_SHIFT`]; bits that were 0, and every reader tests bits).
/// - v3: [`V2vPacket`] gained `head`, the head of the platoon the sender drives in (a platoon
///   split behind a car that cut in), and `reserved` (64 bytes, was 56); [`Command::flags`]
///   bits 8-23 say whom the follower took as its leader.
/// - v4: [`V2vPacket`] carries a maneuver message (`maneuver` and its fields in place of
///   `reserved`; 80 bytes, was 64): join and leave negotiated over V2V (`[maneuvers]`).
///   Later, still v4: the kinds [`V2vPacket::MERGE_REQUEST`], [`V2vPacket::UPDATE_MERGED`],
///   [`V2vPacket::SPLIT_NOTICE`] and [`V2vPacket::UPDATE_SPLIT`] (merges and splits of
///   platoons; no payload changed, and a reader drops a kind it does not know,
///   keeping the packet's beacon). Later, still v4: [`VehicleState::flags`] bit 3
///   ([`VehicleState::BESIDE`]) says the vehicle drives in the lane beside the platoon's, as
///   the plant has it (a bit that was 0, and every reader tests bits).
/// - v5: [`V2vPacket`] carries its sender's seal (`seal_len` and `seal`: the encoded security
///   header of a `[security]` run, docs/security.md; 280 bytes, was 80), and the controller's
///   [`ControlMsg::seals`] count what the seals did (288 bytes, was 184). Later, still v5:
///   the status kind [`ControlMsg::TIMING`], the controller's per-step crypto time before its
///   DONE (no payload changed; only the orchestrator reads status messages).
/// - v6: the controller's [`ControlMsg::reports`] count its misbehaviour reports (376 bytes,
///   was 288), and [`Command::flags`] bit 3 ([`Command::REVOKED`]) says the misbehaviour
///   authority revoked the vehicle (`[security.reports]`).
/// - v7: [`V2vPacket`] carries its group-key fields (`group_len` and `group`: a tag under the
///   platoon's group key, a join's key share, a wrapped group key; `[security.group]`,
///   docs/security.md; 400 bytes, was 280), and [`ControlMsg::seals`] counts the group key's
///   refusals, tags and renewals too (416 bytes, was 376).
pub const CONTRACT_VERSION: u32 = 7;

/// The environment variable in which `platoon run` gives every process it starts the contract
/// version of the run ([`CONTRACT_VERSION`]).
pub const CONTRACT_VERSION_ENV: &str = "PLATOON_CONTRACT_VERSION";

/// Where a plug-in's author reads what changed between contract versions.
pub const CONTRACT_DOC: &str = "docs/injector-contract.md";

/// Whether a process built for contract [`CONTRACT_VERSION`] may join a run whose
/// [`CONTRACT_VERSION_ENV`] is `run` (`None`: not started by `platoon run`, nothing to compare).
/// The error names both versions and the document to read.
pub fn check_contract_version(run: Option<&str>) -> Result<(), String> {
    let Some(run) = run else { return Ok(()) };
    match run.trim().parse::<u32>() {
        Ok(v) if v == CONTRACT_VERSION => Ok(()),
        Ok(v) => Err(format!(
            "this plug-in speaks platoon contract v{CONTRACT_VERSION}, but the run speaks v{v} \
             ({CONTRACT_VERSION_ENV}={v}): build it against the SDK of v{v} (see \
             \"Contract versions\" in {CONTRACT_DOC} for what changed)"
        )),
        Err(_) => Err(format!(
            "this plug-in speaks platoon contract v{CONTRACT_VERSION}, but {CONTRACT_VERSION_ENV} \
             is {run:?}, not a version number (see {CONTRACT_DOC})"
        )),
    }
}

/// The user header of every step sample: which step it belongs to, and how many items it holds.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::StepHeader")]
#[repr(C)]
pub struct StepHeader {
    /// Step index k.
    pub step: u64,
    /// Time k dt (s).
    pub time_s: f64,
    /// Number of items in the sample. Readers use this, not the slice length: the Python
    /// bindings of iceoryx2 0.10.0 report slice lengths in bytes (iceoryx2 issue #1533), so a
    /// Python-published slice looks `size_of::<T>()` times too long to Rust and vice versa.
    pub count: u64,
    /// `CLOCK_MONOTONIC` when the sample was published (ns): the orchestrator times each stage
    /// of a step from these. Never used by the control.
    pub stamp_ns: u64,
}

impl StepHeader {
    /// The header of a sample of `count` items at step `step` of length `dt`, published at
    /// `stamp_ns`.
    pub fn new(step: u64, dt: f64, count: usize, stamp_ns: u64) -> Self {
        Self {
            step,
            time_s: step as f64 * dt,
            count: count as u64,
            stamp_ns,
        }
    }
}

/// A vehicle's true state at a step (plant -> controller, injector, orchestrator).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::VehicleState")]
#[repr(C)]
pub struct VehicleState {
    /// Vehicle id (0 = leader).
    pub vehicle: u32,
    /// Bit 0: the vehicle collided in this step (SUMO plant); bit 1 ([`VehicleState::AHEAD`]):
    /// the plant sees a vehicle ahead of it, and `gap`, `closing` are about that one; bit 2
    /// ([`VehicleState::INTRUDER`]): that vehicle is not the platoon's predecessor; bit 3
    /// ([`VehicleState::BESIDE`]): the vehicle drives in the lane beside the platoon's; bits 8-31
    /// ([`VehicleState::TARGET_SHIFT`]), with `INTRUDER`: which vehicle it is.
    pub flags: u32,
    /// Position (m).
    pub p: f64,
    /// Velocity (m/s).
    pub v: f64,
    /// Acceleration (m/s^2).
    pub a: f64,
    /// What a radar would measure, as the plant sees it: the bumper-to-bumper gap to the
    /// vehicle ahead (m; the native plant: the platoon's predecessor; SUMO: its leader on the
    /// lane, whoever it is)...
    pub gap: f64,
    /// ...and the closing speed `v - v_ahead` (m/s).
    pub closing: f64,
}

impl VehicleState {
    /// `flags` bit: a vehicle ahead is seen (`gap`, `closing` are valid).
    pub const AHEAD: u32 = 2;
    /// `flags` bit: the vehicle ahead is not the platoon's predecessor (a cut-in).
    pub const INTRUDER: u32 = 4;
    /// `flags` bit: the vehicle drives in the lane beside the platoon's (a member that left, a
    /// joiner not yet moved in), as the plant has it: a vehicle whose role asks for the other
    /// lane changes only into a safe gap (`platoon_sim::lanes`), so this may lag its role.
    pub const BESIDE: u32 = 8;
    /// With [`VehicleState::INTRUDER`], `flags >> TARGET_SHIFT` names the vehicle ahead in the
    /// run's traffic: `1 + c` for the platoon's scripted cut-in c (plant.json's `cut_ins`
    /// entry c), `1 + C + b` for SUMO's background vehicle `bg<b>` (C: the number of cut-ins),
    /// 0 for a vehicle the plant does not name.
    pub const TARGET_SHIFT: u32 = 8;

    /// The `flags` bits naming intruder `code` (see [`VehicleState::TARGET_SHIFT`]).
    pub fn target_flags(code: u32) -> u32 {
        code << Self::TARGET_SHIFT
    }

    /// The intruder's code in `flags` (see [`VehicleState::TARGET_SHIFT`]).
    pub fn target_code(&self) -> u32 {
        self.flags >> Self::TARGET_SHIFT
    }
}

/// A V2V broadcast (controller -> injector, and inside [`LinkPacket`]).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::V2vPacket")]
#[repr(C)]
pub struct V2vPacket {
    /// Sender id (0 = leader).
    pub sender: u32,
    /// The sender's sequence number, +1 per broadcast.
    pub seq: u32,
    /// The step at which the state was sampled.
    pub step: u64,
    /// `CLOCK_MONOTONIC` at sending (ns), for latency measurements; never used by the control.
    pub stamp_ns: u64,
    /// The sampled state `[p, v, a]`.
    pub state: [f64; 3],
    /// The sender's latest commanded acceleration (m/s^2; `platoon_v2v::Packet::u`).
    pub u: f64,
    /// The head of the platoon the sender drives in, a wire id like `sender`: the leader, or
    /// the sender itself when it heads the part of a split platoon behind a car that cut in
    /// (`platoon_v2v::Packet::head`).
    pub head: u32,
    /// The maneuver message this broadcast carries ([`V2vPacket::NO_MANEUVER`]: none, and every
    /// maneuver field below 0; else one of the `V2vPacket::JOIN_REQUEST` ...
    /// `V2vPacket::LEAVE_NOTICE` codes).
    pub maneuver: u16,
    /// Its small argument: for an accept, 1 for a join in the middle; for a refusal, the
    /// reason (`V2vPacket::REFUSED_BUSY` ...); for an update, its generation; else 0.
    pub maneuver_arg: u16,
    /// Its addressee, a wire id like `sender` ([`V2vPacket::EVERYONE`]: every member).
    pub maneuver_to: u32,
    /// The sender's maneuver sequence number, +1 per message (the first is 1).
    pub maneuver_seq: u32,
    /// The vehicle it names, a wire id ([`V2vPacket::NOBODY`]: none): the member whose slot a
    /// request or an accept is behind, the joiner of an open gap, a gap ready or an abort, the
    /// vehicle an update says joined or left.
    pub maneuver_vehicle: u32,
    /// An update that says a vehicle joined: the member it follows; a merge request or update:
    /// the rear platoon's last vehicle ([`V2vPacket::NOBODY`] otherwise).
    pub maneuver_behind: u32,
    /// How many bytes of `seal` the seal holds (0: none, a run without `[security]`, or a
    /// packet an injector invented).
    pub seal_len: u32,
    /// The sender's seal (`platoon_v2v::Seal`): the encoded security header of a
    /// `[security]` run over the packet's other fields (docs/security.md), in its first
    /// `seal_len` bytes; the rest 0. An injector that alters a packet and forwards its seal
    /// makes it fail verification, as an outsider's would.
    pub seal: [u8; V2vPacket::SEAL_CAPACITY],
    /// How many bytes of `group` the group-key fields hold (0: none, a run without
    /// `[security.group]`, or a packet that carries none).
    pub group_len: u32,
    /// The sender's group-key fields (`platoon_v2v::GroupSeal`, docs/security.md): a tag
    /// under the platoon's group key, a join's key share, a group key wrapped for a member,
    /// in its first `group_len` bytes; the rest 0. Covered by the seal's signature.
    pub group: [u8; V2vPacket::GROUP_CAPACITY],
}

impl Default for V2vPacket {
    fn default() -> Self {
        Self {
            sender: 0,
            seq: 0,
            step: 0,
            stamp_ns: 0,
            state: [0.0; 3],
            u: 0.0,
            head: 0,
            maneuver: 0,
            maneuver_arg: 0,
            maneuver_to: 0,
            maneuver_seq: 0,
            maneuver_vehicle: 0,
            maneuver_behind: 0,
            seal_len: 0,
            seal: [0; V2vPacket::SEAL_CAPACITY],
            group_len: 0,
            group: [0; V2vPacket::GROUP_CAPACITY],
        }
    }
}

impl V2vPacket {
    /// The size of `seal` (bytes): the longest security header (`platoon_v2v::Seal::CAPACITY`).
    pub const SEAL_CAPACITY: usize = 196;
    /// The size of `group` (bytes): the longest group-key fields
    /// (`platoon_v2v::GroupSeal::CAPACITY`).
    pub const GROUP_CAPACITY: usize = 116;
    /// `maneuver`: the packet carries none.
    pub const NO_MANEUVER: u16 = 0;
    /// A vehicle outside the platoon asks the leader to join behind `maneuver_vehicle`.
    pub const JOIN_REQUEST: u16 = 1;
    /// The leader accepts the addressee's join behind `maneuver_vehicle`.
    pub const JOIN_ACCEPT: u16 = 2;
    /// The leader refuses the addressee's join (`maneuver_arg`: why).
    pub const JOIN_REFUSE: u16 = 3;
    /// The leader asks the addressee to open a gap for `maneuver_vehicle`.
    pub const OPEN_GAP: u16 = 4;
    /// The gap for `maneuver_vehicle` is open (to the leader).
    pub const GAP_READY: u16 = 5;
    /// The addressee moves into the gap (the leader to the joiner).
    pub const MOVE_IN: u16 = 6;
    /// The sender is in its slot (to the leader).
    pub const IN_POSITION: u16 = 7;
    /// The leader's update `maneuver_arg`: `maneuver_vehicle` joined behind `maneuver_behind`.
    pub const UPDATE_JOINED: u16 = 8;
    /// The leader's update `maneuver_arg`: `maneuver_vehicle` left.
    pub const UPDATE_LEFT: u16 = 9;
    /// The leader called the join of `maneuver_vehicle` off.
    pub const ABORT: u16 = 10;
    /// The sender leaves the platoon (to the leader).
    pub const LEAVE_NOTICE: u16 = 11;
    /// The sender, head of another platoon that ends at `maneuver_behind`, asks the leader to
    /// merge it behind `maneuver_vehicle`, the leader's tail.
    pub const MERGE_REQUEST: u16 = 12;
    /// The leader's update `maneuver_arg`: the platoon from `maneuver_vehicle` to
    /// `maneuver_behind` merged behind its tail.
    pub const UPDATE_MERGED: u16 = 13;
    /// The sender, a member, heads the members behind it off as a platoon of their own (to the
    /// leader).
    pub const SPLIT_NOTICE: u16 = 14;
    /// The leader's update `maneuver_arg`: the members from `maneuver_vehicle` on split off,
    /// headed by it.
    pub const UPDATE_SPLIT: u16 = 15;
    /// A refusal's reason: another maneuver is under way.
    pub const REFUSED_BUSY: u16 = 0;
    /// ... the platoon is full.
    pub const REFUSED_FULL: u16 = 1;
    /// ... the slot is behind a vehicle that is not a member.
    pub const REFUSED_NO_SLOT: u16 = 2;
    /// ... the vehicle is a member already.
    pub const REFUSED_MEMBER: u16 = 3;
    /// `maneuver_to`: every member.
    pub const EVERYONE: u32 = u32::MAX;
    /// `maneuver_vehicle`, `maneuver_behind`: no vehicle.
    pub const NOBODY: u32 = u32::MAX;
}

/// A packet on one link (sender -> receiver): the items of the tx batch (controller ->
/// injector: one per out-neighbour of each broadcast) and of the rx batch (injector ->
/// controller: what each receiver gets, plus `JAMMED` notices).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::LinkPacket")]
#[repr(C)]
pub struct LinkPacket {
    /// The receiving vehicle (for `JAMMED`: the vehicle that sensed jamming).
    pub receiver: u32,
    /// [`LinkPacket::DELIVERY`] or [`LinkPacket::JAMMED`].
    pub kind: u32,
    /// The packet as received (ignored for `JAMMED`).
    pub packet: V2vPacket,
}

impl LinkPacket {
    /// `packet` reached `receiver`.
    pub const DELIVERY: u32 = 0;
    /// `receiver` sensed its channel jammed in this step (the resilient mechanism needs it).
    pub const JAMMED: u32 = 1;
}

/// A follower's command and what its controller did (controller -> plant, orchestrator).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::Command")]
#[repr(C)]
pub struct Command {
    /// Follower id (>= 1).
    pub vehicle: u32,
    /// Bit 0: it broadcast in this step; bit 1: it was affected by an attack; bit 2: the
    /// emergency-braking guard overrode the command; bit 3: the misbehaviour authority revoked
    /// its certificates (`[security.reports]`; bit 24: it revoked the platoon's leader's);
    /// bits 4-7: its mode (0 coop, 1 zero,
    /// 2 hold, 3 predict, 4 acc, 5 blend, 6 cut_in, 7 outside, 8 left and 9 beside: in the lane
    /// beside the platoon's, where the plant puts it); bits 8-23: whom it took as its leader, a
    /// vehicle of its platoon (0: the platoon's leader; a member ahead heading a split).
    pub flags: u32,
    /// Commanded acceleration `u_i[k]` (m/s^2).
    pub u: f64,
    /// Its internal variable `theta_i` at the start of the step.
    pub theta: f64,
}

impl Command {
    /// `flags` bit: broadcast in this step.
    pub const TRIGGERED: u32 = 1;
    /// `flags` bit: affected by an attack.
    pub const AFFECTED: u32 = 2;
    /// `flags` bit: the emergency-braking guard overrode the command.
    pub const GUARD: u32 = 4;
    /// `flags` bit: the misbehaviour authority revoked its certificates.
    pub const REVOKED: u32 = 8;
    /// `flags` bit: the misbehaviour authority revoked its platoon's leader's certificates.
    pub const LEADER_REVOKED: u32 = 1 << 24;
    /// `flags` bits of the mode code: `(flags >> MODE_SHIFT) & MODE_MASK`.
    pub const MODE_SHIFT: u32 = 4;
    /// See [`Command::MODE_SHIFT`].
    pub const MODE_MASK: u32 = 0b1111;
    /// `flags` bits of whom it took as its leader (platoon-local id):
    /// `(flags >> HEAD_SHIFT) & HEAD_MASK`.
    pub const HEAD_SHIFT: u32 = 8;
    /// See [`Command::HEAD_SHIFT`].
    pub const HEAD_MASK: u32 = 0xFFFF;

    /// Whom it took as its leader ([`Command::HEAD_SHIFT`]).
    pub fn head(&self) -> u16 {
        ((self.flags >> Self::HEAD_SHIFT) & Self::HEAD_MASK) as u16
    }

    /// The flags of a follower's step.
    pub fn flags_of(
        triggered: bool,
        affected: bool,
        guard: bool,
        (revoked, leader_revoked): (bool, bool),
        mode_code: u32,
        head: u16,
    ) -> u32 {
        u32::from(triggered) * Self::TRIGGERED
            + u32::from(affected) * Self::AFFECTED
            + u32::from(guard) * Self::GUARD
            + u32::from(revoked) * Self::REVOKED
            + u32::from(leader_revoked) * Self::LEADER_REVOKED
            + ((mode_code & Self::MODE_MASK) << Self::MODE_SHIFT)
            + (u32::from(head) << Self::HEAD_SHIFT)
    }

    /// The mode code in `flags`.
    pub fn mode_code(&self) -> u32 {
        (self.flags >> Self::MODE_SHIFT) & Self::MODE_MASK
    }
}

/// A vehicle of the plant's background traffic at a step (plant -> injector, orchestrator, on
/// [`Service::Traffic`]): SUMO's `bg<index>`, which drives on the lanes no platoon uses and
/// loads the V2V channel. Only the SUMO plant with `[sumo] background_vehicles` publishes it.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::TrafficVehicle")]
#[repr(C)]
pub struct TrafficVehicle {
    /// Its index b (SUMO's `bg<b>`): item b of every traffic sample.
    pub index: u32,
    /// Bit 0 ([`TrafficVehicle::ON_ROAD`]): it is in the network at this step and `p` holds its
    /// position; otherwise (not inserted yet, or left the road) `p` is NaN.
    pub flags: u32,
    /// Position along the road (m) in the platoon's coordinates (SUMO's lane position minus
    /// the run's offset, as the platoon's [`VehicleState::p`]).
    pub p: f64,
}

impl TrafficVehicle {
    /// `flags` bit: on the road at this step (`p` is its position).
    pub const ON_ROAD: u32 = 1;

    /// Its position (m), NaN when it is not on the road.
    pub fn position(&self) -> f64 {
        if self.flags & Self::ON_ROAD != 0 {
            self.p
        } else {
            f64::NAN
        }
    }
}

/// What a follower's misbehaviour detectors said of one packet it received at a step, and what
/// its reaction did (controller -> orchestrator, on [`Service::Inspections`]): the orchestrator
/// joins it with what truly happened to the packet, as the in-process run does. Published only
/// in runs that measure detectors (`[detection]`), one item per inspected packet, in the order
/// the receivers got them (the rx batch's order).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::Inspection")]
#[repr(C)]
pub struct Inspection {
    /// The receiving follower (wire id).
    pub receiver: u32,
    /// The packet's sender as delivered (wire id; [`V2vPacket::sender`]).
    pub sender: u32,
    /// Its sequence number.
    pub seq: u32,
    /// Bit 0 ([`Inspection::FLAGGED`]): a detector flagged it; bit 1
    /// ([`Inspection::REFUSED`]): the reaction refused it; bits 2-7
    /// ([`Inspection::REFUSED_BY_SHIFT`], [`Inspection::REFUSED_BY_MASK`]): what refused it, a
    /// `platoon_control::RefusedBy` code (0: accepted, or not said; 1-6 the packet checks'
    /// reasons, in the order of `ControlMsg::counts`, for a packet no detector saw; 7 the
    /// reaction; 8 the leader's check of maneuver messages; 9 the receiver's maneuver machine
    /// dropped the message the packet carried as old, after the step's other items; 10-23 the
    /// seal of a `[security]` run, `platoon_security::Refusal` code + 9); bit `8 + d`
    /// ([`Inspection::DETECTOR_SHIFT`]): detector d (the run's `[detection]` order: built-in
    /// ones, then `plugin`) flagged it.
    pub flags: u32,
    /// The step it claims to have been sampled at.
    pub step: u64,
    /// The state `[p, v, a]` it claims.
    pub state: [f64; 3],
    /// Detector d's test statistic (larger: more suspicious); NaN when it had nothing to test
    /// or the run has fewer than `d + 1` detectors.
    pub scores: [f64; 8],
}

impl Inspection {
    /// `flags` bit: a detector flagged the packet.
    pub const FLAGGED: u32 = 1;
    /// `flags` bit: the reaction refused the packet.
    pub const REFUSED: u32 = 2;
    /// `flags` bit of detector d's flag: `1 << (DETECTOR_SHIFT + d)`.
    pub const DETECTOR_SHIFT: u32 = 8;
    /// The first of `flags`' bits that say what refused the packet.
    pub const REFUSED_BY_SHIFT: u32 = 2;
    /// `flags`' bits that say what refused the packet (a code 0-63 at
    /// [`Inspection::REFUSED_BY_SHIFT`]; bits 2-7 since v5, 2-5 before).
    pub const REFUSED_BY_MASK: u32 = 0x3F << Self::REFUSED_BY_SHIFT;

    /// The code of what refused the packet (0: accepted, or not said).
    pub fn refused_by(&self) -> u8 {
        ((self.flags & Self::REFUSED_BY_MASK) >> Self::REFUSED_BY_SHIFT) as u8
    }

    /// Whether detector `d` flagged the packet.
    pub fn flagged_by(&self, d: usize) -> bool {
        d < self.scores.len() && self.flags & (1 << (Self::DETECTOR_SHIFT + d as u32)) != 0
    }
}

/// Control and status messages (orchestrator <-> every node), one per sample.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("platoon::v7::ControlMsg")]
#[repr(C)]
pub struct ControlMsg {
    /// One of the `ControlMsg::*` kinds.
    pub kind: u32,
    /// The node it comes from or is about ([`Node`] as u32).
    pub node: u32,
    /// The step it refers to.
    pub step: u64,
    /// `DONE` from the controller: rejected packets by reason (non-finite, unknown sender,
    /// future step, stale, implausible sequence number, implausible state). `TIMING`: the
    /// percentiles of the time its seals spent signing per step (ns; see
    /// [`ControlMsg::TIMING`]).
    pub counts: [u64; 6],
    /// `DONE` from the controller in a `[security]` run: packets signed, deliveries whose
    /// signature held, then deliveries refused by `platoon_security::Refusal` code 1 to 14
    /// (docs/security.md), then (`[security.group]`) the tags made and the group key's
    /// renewals; all 0 otherwise. `TIMING`: in its first 6, the percentiles of
    /// the time its seals spent verifying per step (ns; see [`ControlMsg::TIMING`]).
    pub seals: [u64; 18],
    /// `DONE` from the controller in a `[security.reports]` run: reports filed, lost on the
    /// uplink, then those that arrived by the authority's outcome code 1 to 9
    /// (`platoon_security::ReportOutcome`); all 0 otherwise.
    pub reports: [u64; 11],
    /// `FAILED`/`ABORT`: a reason, UTF-8, NUL-padded.
    pub reason: [u8; 120],
}

impl ControlMsg {
    /// Orchestrator -> nodes: every node is ready; the plant publishes step 0.
    pub const START: u32 = 1;
    /// Orchestrator -> nodes: the run is over; exit cleanly.
    pub const STOP: u32 = 2;
    /// Orchestrator -> nodes: the run failed; exit now.
    pub const ABORT: u32 = 3;
    /// Node -> orchestrator: every port is open.
    pub const READY: u32 = 10;
    /// Node -> orchestrator: the last step is done (controller: with reject counts).
    pub const DONE: u32 = 11;
    /// Node -> orchestrator: the node cannot go on (reason given).
    pub const FAILED: u32 = 12;
    /// Controller -> orchestrator, right before its `DONE`, in a `[security]` run: what its
    /// seals' cryptography took per step, for timing.json's `sign` and `verify`: `counts` for
    /// signing, `seals[..6]` for verifying, each the number of steps, then the 50th, 90th,
    /// 99th and 99.9th percentiles (nearest rank) and the largest, in ns. Since v5 (a kind
    /// added; no payload changed, and only the orchestrator reads the status service).
    pub const TIMING: u32 = 13;

    /// A message of `kind` from or about `node`.
    pub fn new(kind: u32, node: Node, step: u64) -> Self {
        Self {
            kind,
            node: node as u32,
            step,
            counts: [0; 6],
            seals: [0; 18],
            reports: [0; 11],
            reason: [0; 120],
        }
    }

    /// With a reason (cut to 120 bytes on a character boundary).
    pub fn with_reason(mut self, reason: &str) -> Self {
        let mut end = reason.len().min(self.reason.len());
        while !reason.is_char_boundary(end) {
            end -= 1;
        }
        self.reason[..end].copy_from_slice(&reason.as_bytes()[..end]);
        self
    }

    /// The reason as text.
    pub fn reason(&self) -> String {
        let end = self.reason.iter().position(|&b| b == 0).unwrap_or(120);
        String::from_utf8_lossy(&self.reason[..end]).into_owned()
    }
}

/// The processes of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Node {
    /// Starts the others, records the run, stops everything.
    Orchestrator = 0,
    /// Integrates the vehicles (native, or the SUMO bridge).
    Plant = 1,
    /// Every vehicle's triggering rule, estimators and control law.
    Controller = 2,
    /// Gates every link: the attack injector.
    Injector = 3,
    /// The built-in channel run before a third-party injector (`--injector-mode after`): it
    /// reads `tx` and publishes `gated`, which the injector reads instead of `tx`.
    Channel = 4,
}

impl Node {
    /// All nodes.
    pub const ALL: [Node; 5] = [
        Node::Orchestrator,
        Node::Plant,
        Node::Controller,
        Node::Injector,
        Node::Channel,
    ];

    /// Its name in service names and messages.
    pub fn name(self) -> &'static str {
        match self {
            Node::Orchestrator => "orchestrator",
            Node::Plant => "plant",
            Node::Controller => "controller",
            Node::Injector => "injector",
            Node::Channel => "channel",
        }
    }

    /// From its number in [`ControlMsg::node`].
    pub fn from_u32(n: u32) -> Option<Node> {
        Node::ALL.get(n as usize).copied()
    }
}

/// The services of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Service {
    /// `[VehicleState]`, plant -> controller, injector, orchestrator; one sample per step.
    States,
    /// `[LinkPacket]`, controller -> injector, orchestrator: the packets broadcast at a step, one
    /// item per link (sender -> each out-neighbour), in broadcast order.
    Tx,
    /// `[LinkPacket]`, injector -> controller, orchestrator: what each receiver gets at a step
    /// (published every step, empty if everything was dropped).
    Rx,
    /// `[Command]`, controller -> plant, orchestrator.
    Commands,
    /// `[TrafficVehicle]`, plant -> injector (and the channel), orchestrator: the background
    /// traffic at a step, published before that step's states. Only the SUMO plant with
    /// background vehicles publishes it; the orchestrator creates it only then, so whether the
    /// service exists says whether a run has it.
    Traffic,
    /// `[LinkPacket]`, channel -> injector, with `--injector-mode after`: what survived the
    /// config's attacks (deliveries and jammed notices), the injector's input instead of `tx`.
    Gated,
    /// `[Inspection]`, controller -> orchestrator: what the followers' detectors said of the
    /// packets of a step, published just before that step's commands. Only runs that measure
    /// detectors (`[detection]`) have it; the orchestrator creates it only then.
    Inspections,
    /// `ControlMsg`, orchestrator -> nodes.
    Control,
    /// `ControlMsg`, nodes -> orchestrator.
    Status,
    /// Event service that wakes one node: every publisher notifies the nodes that read it.
    Wake(Node),
    /// A copy of one step stream for read-only observers (`observe/<leaf>`): the orchestrator
    /// republishes every recorded step there; the service overwrites what a slow observer has
    /// not read, so observers never hold the run up. No wake-ups: observers poll on a timer.
    Observe(Observed),
}

/// The step streams observers can read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Observed {
    /// `[VehicleState]` of every vehicle.
    States,
    /// `[LinkPacket]` broadcast (one item per link).
    Tx,
    /// `[LinkPacket]` as the injector delivered them (and jammed notices).
    Rx,
    /// `[Command]` of every follower.
    Commands,
}

impl Observed {
    /// All four.
    pub const ALL: [Observed; 4] = [
        Observed::States,
        Observed::Tx,
        Observed::Rx,
        Observed::Commands,
    ];

    /// The leaf of its service name.
    pub fn leaf(self) -> &'static str {
        match self {
            Observed::States => "states",
            Observed::Tx => "tx",
            Observed::Rx => "rx",
            Observed::Commands => "commands",
        }
    }
}

/// The iceoryx2 service name of `service` in run `run_id`: the only place names are made, so
/// runs with different ids never see each other.
pub fn service_name(run_id: &str, service: Service) -> String {
    let leaf = match service {
        Service::States => "states",
        Service::Tx => "tx",
        Service::Rx => "rx",
        Service::Commands => "commands",
        Service::Traffic => "traffic",
        Service::Gated => "gated",
        Service::Inspections => "inspections",
        Service::Control => "control",
        Service::Status => "status",
        Service::Wake(node) => return format!("platoon/{run_id}/wake/{}", node.name()),
        Service::Observe(o) => return format!("platoon/{run_id}/observe/{}", o.leaf()),
    };
    format!("platoon/{run_id}/{leaf}")
}

/// The wake-up service a node listens on: its own, except the channel, which shares the
/// injector's (both read what follows a tx sample; wake services have room for two listeners).
pub fn wake_listener_of(node: Node) -> Node {
    match node {
        Node::Channel => Node::Injector,
        other => other,
    }
}

/// The orchestrator is woken by the commands of every this-many-th step only (and by every
/// status message): it drains the other samples from its buffers then, so the pipeline's
/// processes keep the cores.
pub const ORCHESTRATOR_WAKE_EVERY: u64 = 16;

/// Whom a publisher on `service` wakes (notifies on their `Wake` service) after a sample.
/// The orchestrator reads every step service, but is only woken by commands (every
/// [`ORCHESTRATOR_WAKE_EVERY`] steps) and by status messages.
pub fn wakes(service: Service) -> &'static [Node] {
    match service {
        // The injector reads states too, but only once the tx batch (which follows) wakes it.
        Service::States => &[Node::Controller],
        // With `--injector-mode after` the channel node listens on the injector's wake-up too
        // (`wake_listener_of`), so a tx sample wakes it without a second notification.
        Service::Tx => &[Node::Injector],
        Service::Gated => &[Node::Injector],
        Service::Rx => &[Node::Controller],
        Service::Commands => &[Node::Plant, Node::Orchestrator],
        // Published before the states, which precede the tx batch that wakes the injector:
        // whoever reads it has it by then.
        Service::Traffic => &[],
        // Published before the commands, which wake the orchestrator.
        Service::Inspections => &[],
        Service::Control => &[Node::Plant, Node::Controller, Node::Injector],
        Service::Status => &[Node::Orchestrator],
        Service::Wake(_) | Service::Observe(_) => &[],
    }
}

/// Size, alignment and field offsets of one payload type, as `bridge/wire_layout.json` holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The `#[type_name]`.
    pub type_name: &'static str,
    /// `size_of`.
    pub size: usize,
    /// `align_of`.
    pub align: usize,
    /// `(field, offset)` in declaration order.
    pub fields: Vec<(&'static str, usize)>,
}

macro_rules! layout {
    ($t:ty, [$($f:ident),*]) => {
        Layout {
            // SAFETY: the name is read, not relied on; that every language's type of this
            // name has this layout is what `bridge/wire_layout.json` and its tests check.
            type_name: unsafe { <$t as ZeroCopySend>::type_name() },
            size: core::mem::size_of::<$t>(),
            align: core::mem::align_of::<$t>(),
            fields: vec![$((stringify!($f), core::mem::offset_of!($t, $f))),*],
        }
    };
}

/// The layout of every payload type.
pub fn layouts() -> Vec<Layout> {
    vec![
        layout!(StepHeader, [step, time_s, count, stamp_ns]),
        layout!(VehicleState, [vehicle, flags, p, v, a, gap, closing]),
        layout!(
            V2vPacket,
            [
                sender,
                seq,
                step,
                stamp_ns,
                state,
                u,
                head,
                maneuver,
                maneuver_arg,
                maneuver_to,
                maneuver_seq,
                maneuver_vehicle,
                maneuver_behind,
                seal_len,
                seal,
                group_len,
                group
            ]
        ),
        layout!(LinkPacket, [receiver, kind, packet]),
        layout!(Command, [vehicle, flags, u, theta]),
        layout!(TrafficVehicle, [index, flags, p]),
        layout!(
            Inspection,
            [receiver, sender, seq, flags, step, state, scores]
        ),
        layout!(
            ControlMsg,
            [kind, node, step, counts, seals, reports, reason]
        ),
    ]
}

/// [`CONTRACT_VERSION`] and [`layouts`] as the JSON of `bridge/wire_layout.json` (stable
/// order, one type per line).
pub fn layouts_json() -> String {
    let mut s = format!("{{\n  \"contract_version\": {CONTRACT_VERSION},\n  \"types\": {{\n");
    let all = layouts();
    for (i, l) in all.iter().enumerate() {
        let fields: Vec<String> = l
            .fields
            .iter()
            .map(|(f, o)| format!("[\"{f}\", {o}]"))
            .collect();
        s += &format!(
            "    \"{}\": {{\"size\": {}, \"align\": {}, \"fields\": [{}]}}{}\n",
            l.type_name,
            l.size,
            l.align,
            fields.join(", "),
            if i + 1 < all.len() { "," } else { "" }
        );
    }
    s + "  }\n}\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_committed_layout_file_is_the_rust_layout() {
        let committed = include_str!("../../../bridge/wire_layout.json");
        assert_eq!(
            committed,
            layouts_json(),
            "bridge/wire_layout.json is out of date: regenerate it with \
             `cargo run -- wire-layout > bridge/wire_layout.json` and update bridge/platoon/wire.py"
        );
    }

    #[test]
    fn every_type_name_carries_the_contract_version() {
        let names = [
            unsafe { StepHeader::type_name() },
            unsafe { VehicleState::type_name() },
            unsafe { V2vPacket::type_name() },
            unsafe { LinkPacket::type_name() },
            unsafe { Command::type_name() },
            unsafe { TrafficVehicle::type_name() },
            unsafe { Inspection::type_name() },
            unsafe { ControlMsg::type_name() },
        ];
        let prefix = format!("platoon::v{CONTRACT_VERSION}::");
        for name in names {
            let short = name.strip_prefix(&prefix).unwrap_or_else(|| {
                panic!("{name} does not carry contract v{CONTRACT_VERSION}: name it {prefix}...")
            });
            assert!(!short.contains(':'), "{name}");
        }
        let listed: Vec<_> = layouts().iter().map(|l| l.type_name).collect();
        assert_eq!(listed, names, "layouts() lists every payload type");
    }

    /// The numbers written right after each `prefix` in `text` (`v4`, `(`4`)`).
    fn numbers_after(text: &str, prefix: &str) -> Vec<u32> {
        text.match_indices(prefix)
            .filter_map(|(i, _)| {
                let rest = &text[i + prefix.len()..];
                let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
                digits.parse().ok()
            })
            .collect()
    }

    /// Issue 50, item 6: both contract docs said `PLATOON_CONTRACT_VERSION` is 3 while runs set
    /// 4. The version each contract doc states, the variable's value it gives, the newest row
    /// of its version table and the type names it shows are the code's.
    #[test]
    fn the_contract_docs_state_the_codes_contract_version() {
        let docs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs");
        for doc in ["injector-contract.md", "controller-contract.md"] {
            let text = std::fs::read_to_string(docs.join(doc))
                .unwrap_or_else(|e| panic!("reading docs/{doc}: {e}"));
            let described = numbers_after(&text, "This page describes platoon contract v");
            assert_eq!(described, [CONTRACT_VERSION], "docs/{doc}: its first line");
            let variable = text
                .lines()
                .find(|l| l.starts_with(&format!("| `{CONTRACT_VERSION_ENV}` |")))
                .unwrap_or_else(|| panic!("docs/{doc} has no row for {CONTRACT_VERSION_ENV}"));
            assert_eq!(
                numbers_after(variable, "(`"),
                [CONTRACT_VERSION],
                "docs/{doc}: the value the run gives {CONTRACT_VERSION_ENV}"
            );
            // Type names, but for the version table's rows of the versions before.
            let names: Vec<u32> = text
                .lines()
                .filter(|l| !l.starts_with("| v"))
                .flat_map(|l| numbers_after(l, "platoon::v"))
                .collect();
            assert!(
                names.iter().all(|&v| v == CONTRACT_VERSION),
                "docs/{doc} shows type names of another version: {names:?}"
            );
        }
        let injector = std::fs::read_to_string(docs.join("injector-contract.md")).unwrap();
        let table: Vec<u32> = injector
            .lines()
            .filter(|l| l.starts_with("| v"))
            .flat_map(|l| numbers_after(l, "| v"))
            .collect();
        assert_eq!(
            table.iter().max(),
            Some(&CONTRACT_VERSION),
            "docs/injector-contract.md#contract-versions: its newest row"
        );
    }

    #[test]
    fn a_plugin_of_another_contract_version_is_told_both_versions() {
        assert_eq!(check_contract_version(None), Ok(()));
        assert_eq!(
            check_contract_version(Some(&CONTRACT_VERSION.to_string())),
            Ok(())
        );
        let other = CONTRACT_VERSION + 1;
        let e = check_contract_version(Some(&other.to_string())).unwrap_err();
        for needle in [
            format!("speaks platoon contract v{CONTRACT_VERSION}"),
            format!("the run speaks v{other}"),
            CONTRACT_DOC.to_string(),
        ] {
            assert!(e.contains(&needle), "{needle:?} not in {e}");
        }
        let e = check_contract_version(Some("two")).unwrap_err();
        assert!(
            e.contains("\"two\"") && e.contains(CONTRACT_VERSION_ENV),
            "{e}"
        );
    }

    /// The payload table of the contract document names every type as it is on the wire, with
    /// its size.
    #[test]
    fn the_contract_doc_lists_every_type_with_its_size() {
        let doc = include_str!("../../../docs/injector-contract.md");
        for l in layouts() {
            let row = format!("| `{}` | {} |", l.type_name, l.size);
            assert!(
                doc.contains(&row),
                "docs/injector-contract.md has no payload row starting {row:?}"
            );
        }
        assert!(
            doc.contains(&format!("contract v{CONTRACT_VERSION}")),
            "docs/injector-contract.md does not say which contract version it describes"
        );
    }

    #[test]
    fn reasons_are_cut_on_character_boundaries() {
        let m = ControlMsg::new(ControlMsg::FAILED, Node::Plant, 3).with_reason(&"é".repeat(100));
        assert_eq!(m.reason(), "é".repeat(60));
        assert_eq!(Node::from_u32(m.node), Some(Node::Plant));
    }

    #[test]
    fn service_names_carry_the_run_id() {
        assert_eq!(service_name("r1", Service::Tx), "platoon/r1/tx");
        assert_eq!(service_name("r1", Service::Traffic), "platoon/r1/traffic");
        assert_eq!(
            service_name("r1", Service::Observe(Observed::Rx)),
            "platoon/r1/observe/rx"
        );
        assert_eq!(
            service_name("r1", Service::Wake(Node::Injector)),
            "platoon/r1/wake/injector"
        );
        assert_ne!(
            service_name("a", Service::States),
            service_name("b", Service::States)
        );
    }
}
