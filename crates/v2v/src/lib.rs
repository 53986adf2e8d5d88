//! The V2V messages every part of the pure core speaks: what a vehicle broadcasts ([`Packet`])
//! and what one receiver got ([`Delivery`]).
//!
//! Controllers (`platoon-control`) make and consume them; the channel and the attacks
//! (`platoon-attacks`) gate, drop, delay or alter them on the way. Neither depends on the other
//! for these two types. Their wire form is `platoon_wire::V2vPacket`.
#![warn(missing_docs)]

pub use platoon_maneuver::Message;
use platoon_maneuver::{Body, Change, Refusal};
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
    /// Its sender's seal (`[security]`, docs/security.md): the encoded security header of
    /// `platoon-security` over [`Packet::signed_bytes`], or `None` in a run without security
    /// (and on a packet forged from nothing). An attack that alters a packet's fields keeps
    /// the seal it had, which then fails verification.
    pub seal: Option<Seal>,
    /// Its group-key fields (`[security.group]`, docs/security.md#a-group-key-at-join): the
    /// encoded `platoon_security::GroupField` (a tag under the platoon's group key, a join's
    /// key share, a group key wrapped for a member), or `None`. Signed with the rest
    /// ([`Packet::signed_bytes`]); a tag covers [`Packet::payload_bytes`].
    pub group: Option<GroupSeal>,
}

/// The bytes of a packet's group-key fields (`platoon_security::GroupField`, the longest
/// `platoon_security::GROUP_FIELD_LEN` = 110 bytes, checked where the two meet), in room to
/// the wire packet's 8-byte alignment.
pub type GroupSeal = Opaque<116>;

/// What a packet's sender signs ([`Packet::signed_bytes`]): its payload, then its group-key
/// fields if it has any. Reads as a byte slice.
#[derive(Clone, Copy)]
pub struct SignedBytes {
    len: usize,
    bytes: [u8; Packet::PAYLOAD_LEN + 1 + GroupSeal::CAPACITY],
}

impl std::ops::Deref for SignedBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

/// The bytes of a security header riding on a [`Packet`]: the longest is a header that carries
/// its signer's certificate (`platoon_security::CERTIFICATE_HEADER_LEN`, checked where the two
/// meet).
pub type Seal = Opaque<196>;

/// Bytes riding on a [`Packet`] that this crate does not read (a [`Seal`], a [`GroupSeal`]): a
/// buffer of `N` bytes and the length used, so that a packet stays `Copy`. `platoon-security`
/// encodes and checks them.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Opaque<const N: usize> {
    len: u8,
    bytes: [u8; N],
}

impl<const N: usize> Opaque<N> {
    /// The room (bytes).
    pub const CAPACITY: usize = N;

    /// `bytes` (`None` if longer than [`Opaque::CAPACITY`]).
    pub fn new(bytes: &[u8]) -> Option<Self> {
        let mut out = [0; N];
        out.get_mut(..bytes.len())?.copy_from_slice(bytes);
        Some(Self {
            len: bytes.len() as u8,
            bytes: out,
        })
    }

    /// Its bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }
}

impl<const N: usize> std::fmt::Debug for Opaque<N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Opaque({} of {N} bytes)", self.len)
    }
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
            seal: None,
            group: None,
        }
    }

    /// What its sender signs (`[security]`): [`Packet::payload_bytes`], then, if the packet
    /// carries group-key fields, their length (1 byte) and bytes, so that the signature binds
    /// a join's key share and a member's tag to the packet. Without group fields, the payload
    /// alone: a run without `[security.group]` signs what it signed before.
    pub fn signed_bytes(&self) -> SignedBytes {
        let mut out = SignedBytes {
            len: Self::PAYLOAD_LEN,
            bytes: [0; Self::PAYLOAD_LEN + 1 + GroupSeal::CAPACITY],
        };
        out.bytes[..Self::PAYLOAD_LEN].copy_from_slice(&self.payload_bytes());
        if let Some(g) = &self.group {
            let b = g.as_bytes();
            out.bytes[Self::PAYLOAD_LEN] = b.len() as u8;
            out.bytes[Self::PAYLOAD_LEN + 1..][..b.len()].copy_from_slice(b);
            out.len += 1 + b.len();
        }
        out
    }

    /// The canonical bytes of what the packet says, every field but the seal and the group-key
    /// fields: what a group-key tag covers, and the start of what its sender signs
    /// ([`Packet::signed_bytes`]). Big-endian, fixed layout: sender (2), seq (4), step (8),
    /// the state's three and `u` as IEEE 754 bits (4 x 8), head (2), then the maneuver
    /// message: a kind byte (0 for none, else [`platoon_maneuver::MessageKind`]'s place + 1),
    /// its sender, recipient and sequence number (2 each) and four arguments (2 each; 0 where
    /// the kind has fewer). 63 bytes with or without a message.
    pub fn payload_bytes(&self) -> [u8; Self::PAYLOAD_LEN] {
        let mut out = [0u8; Self::PAYLOAD_LEN];
        let mut at = 0;
        let mut put = |bytes: &[u8]| {
            out[at..at + bytes.len()].copy_from_slice(bytes);
            at += bytes.len();
        };
        put(&self.sender.0.to_be_bytes());
        put(&self.seq.to_be_bytes());
        put(&self.step.to_be_bytes());
        for x in [self.state[0], self.state[1], self.state[2], self.u] {
            put(&x.to_bits().to_be_bytes());
        }
        put(&self.head.0.to_be_bytes());
        let (kind, m) = match &self.maneuver {
            None => (0, [0u16; 7]),
            Some(m) => {
                let (kind, args) = body_fields(&m.body);
                (
                    kind,
                    [
                        m.sender.0, m.to.0, m.seq, args[0], args[1], args[2], args[3],
                    ],
                )
            }
        };
        put(&[kind]);
        for x in m {
            put(&x.to_be_bytes());
        }
        out
    }

    /// The size of [`Packet::payload_bytes`].
    pub const PAYLOAD_LEN: usize = 2 + 4 + 8 + 4 * 8 + 2 + 1 + 7 * 2;

    /// Whether the sender heads a split platoon (it announces itself as its head).
    pub fn heads(&self) -> bool {
        self.head == self.sender && !self.sender.is_leader()
    }
}

/// A maneuver body's kind byte and up to four arguments, for [`Packet::payload_bytes`].
fn body_fields(b: &Body) -> (u8, [u16; 4]) {
    let kind = platoon_maneuver::MessageKind::ALL
        .iter()
        .position(|&k| k == b.kind())
        .map_or(0, |i| i as u8 + 1);
    let args = match *b {
        Body::JoinRequest { behind } => [behind.0, 0, 0, 0],
        Body::JoinAccept { behind, middle } => [behind.0, u16::from(middle), 0, 0],
        Body::JoinRefuse { reason } => [
            match reason {
                Refusal::Busy => 1,
                Refusal::Full => 2,
                Refusal::NoSlot => 3,
                Refusal::Member => 4,
            },
            0,
            0,
            0,
        ],
        Body::OpenGap { joiner } | Body::GapReady { joiner } | Body::Abort { joiner } => {
            [joiner.0, 0, 0, 0]
        }
        Body::MoveIn | Body::InPosition | Body::LeaveNotice | Body::SplitNotice => [0; 4],
        Body::Update { generation, change } => match change {
            Change::Joined { vehicle, behind } => [generation, 1, vehicle.0, behind.0],
            Change::Left { vehicle } => [generation, 2, vehicle.0, 0],
            Change::Merged { head, tail } => [generation, 3, head.0, tail.0],
            Change::Split { head } => [generation, 4, head.0, 0],
        },
        Body::MergeRequest { behind, tail } => [behind.0, tail.0, 0, 0],
    };
    (kind, args)
}

/// A packet as it reached one receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Delivery {
    /// Who received it.
    pub receiver: VehicleId,
    /// What was received (possibly altered or old).
    pub packet: Packet,
}
