//! The V2V messages every part of the pure core speaks: what a vehicle broadcasts ([`Packet`])
//! and what one receiver got ([`Delivery`]).
//!
//! Controllers (`platoon-control`) make and consume them; the channel and the attacks
//! (`platoon-attacks`) gate, drop, delay or alter them on the way. Neither depends on the other
//! for these two types. Their wire form is `platoon_wire::V2vPacket`.
#![warn(missing_docs)]

pub use platoon_maneuver::Message;
use platoon_model::{State, VehicleId};

/// A V2V broadcast: the sender's sampled state at a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Packet {
    /// Who sent it.
    pub sender: VehicleId,
    /// The sender's sequence number, +1 per broadcast (the first is 1).
    pub seq: u32,
    /// The step at which the state was sampled.
    pub step: u64,
    /// The sampled state `[p, v, a]`.
    pub state: State,
    /// The sender's latest commanded acceleration when it sampled (m/s^2): its command of the
    /// step before (for the leader, the acceleration it applied over the step before; 0 at
    /// step 0), as Plexe sends it. For laws with a feed-forward of the predecessor's or the
    /// leader's input (PATH CACC, Ploeg et al.); the paper's law does not read it.
    pub u: f64,
    /// The head of the platoon the sender drives in: the leader (`VehicleId::LEADER`), or the
    /// sender itself when it heads the part of a split platoon behind a vehicle that cut in
    /// (`[fallback.cut_in] split`); a follower behind such a head announces that head. Receivers
    /// behind a member that announces itself take it as their leader.
    pub head: VehicleId,
    /// A maneuver message riding on this broadcast (`[[maneuvers]]`): a vehicle with one to
    /// send broadcasts at that step, one message a packet, so the channel, its losses and
    /// every attack act on maneuvers as on beacons.
    pub maneuver: Option<Message>,
}

impl Packet {
    /// A plain beacon: `sender`'s state sampled at `step`, its `seq`-th broadcast, with no
    /// commanded acceleration (`u` 0), the leader as head and no maneuver message.
    pub fn beacon(sender: VehicleId, seq: u32, step: u64, state: State) -> Self {
        Self {
            sender,
            seq,
            step,
            state,
            u: 0.0,
            head: VehicleId::LEADER,
            maneuver: None,
        }
    }

    /// Whether the sender heads a split platoon (it announces itself as its head).
    pub fn heads(&self) -> bool {
        self.head == self.sender && !self.sender.is_leader()
    }
}

/// A packet as it reached one receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Delivery {
    /// Who received it.
    pub receiver: VehicleId,
    /// What was received (possibly altered or old).
    pub packet: Packet,
}
