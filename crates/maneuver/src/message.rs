//! The maneuver messages and the sequence-number filter every receiver applies.
use platoon_model::VehicleId;
use std::collections::BTreeMap;

/// The addressee of a message for every member (a formation update, an abort).
pub const EVERYONE: VehicleId = VehicleId(u16::MAX);

/// A maneuver message. Sent on the V2V channel beside the beacons: everyone in range hears it,
/// only its addressee acts on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Message {
    /// Who sent it.
    pub sender: VehicleId,
    /// Whom it is for ([`EVERYONE`]: every member).
    pub to: VehicleId,
    /// The sender's maneuver sequence number, +1 per message (the first is 1). A receiver acts
    /// on each sender's messages in order, once: an older or repeated number is dropped.
    pub seq: u16,
    /// What it says.
    pub body: Body,
}

impl Message {
    /// Whether `me` is to act on it.
    pub fn is_for(&self, me: VehicleId) -> bool {
        self.to == me || (self.to == EVERYONE && self.sender != me)
    }
}

/// What a maneuver message says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Body {
    /// A vehicle outside the platoon asks its leader to join directly behind `behind` (the
    /// tail: a join at the back).
    JoinRequest {
        /// The member the joiner would follow.
        behind: VehicleId,
    },
    /// The leader accepts the addressee's join behind `behind`. At the tail the joiner
    /// approaches at once; in the middle it waits for [`Body::MoveIn`].
    JoinAccept {
        /// The member the joiner will follow.
        behind: VehicleId,
        /// Whether a member behind the slot opens a gap first (a join in the middle).
        middle: bool,
    },
    /// The leader refuses the addressee's join.
    JoinRefuse {
        /// Why.
        reason: Refusal,
    },
    /// The leader asks the addressee, the member behind the slot, to open a gap for `joiner`.
    OpenGap {
        /// Who will move into the gap.
        joiner: VehicleId,
    },
    /// The gap for `joiner` is open (the opener to the leader).
    GapReady {
        /// Whom the gap is for.
        joiner: VehicleId,
    },
    /// The gap is open: the addressee moves into it (the leader to the joiner).
    MoveIn,
    /// The sender is in its slot (the joiner to the leader).
    InPosition,
    /// The leader's formation changed: its `generation`th change is `change`. To
    /// [`EVERYONE`]; repeated a few times, as members may miss it.
    Update {
        /// How many changes the formation has had (the first change is 1).
        generation: u16,
        /// The change.
        change: Change,
    },
    /// The leader called the join of `joiner` off (it timed out): the opener closes its gap,
    /// the joiner stays out. To [`EVERYONE`].
    Abort {
        /// Whose join.
        joiner: VehicleId,
    },
    /// The sender leaves the platoon (a member to the leader).
    LeaveNotice,
    /// The head of another platoon asks this platoon's leader to merge: its platoon, from the
    /// sender to `tail`, would follow `behind`, this platoon's tail (a merge at the back, as
    /// Plexe's and VENTOS's). Accepted with [`Body::JoinAccept`], it goes on as a join at the
    /// tail and ends in [`Change::Merged`].
    MergeRequest {
        /// The member the head would follow: the tail.
        behind: VehicleId,
        /// The last vehicle of the sender's platoon.
        tail: VehicleId,
    },
    /// The sender, a member, heads the members behind it off as a platoon of their own (a
    /// member to the leader; ends in [`Change::Split`]).
    SplitNotice,
}

/// The kinds of [`Body`], by which an attack picks the messages it acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MessageKind {
    /// [`Body::JoinRequest`].
    JoinRequest,
    /// [`Body::JoinAccept`].
    JoinAccept,
    /// [`Body::JoinRefuse`].
    JoinRefuse,
    /// [`Body::OpenGap`].
    OpenGap,
    /// [`Body::GapReady`].
    GapReady,
    /// [`Body::MoveIn`].
    MoveIn,
    /// [`Body::InPosition`].
    InPosition,
    /// [`Body::Update`].
    Update,
    /// [`Body::Abort`].
    Abort,
    /// [`Body::LeaveNotice`].
    LeaveNotice,
    /// [`Body::MergeRequest`].
    MergeRequest,
    /// [`Body::SplitNotice`].
    SplitNotice,
}

impl MessageKind {
    /// Every kind, in the order of their bits in [`MessageKind::bit`].
    pub const ALL: [MessageKind; 12] = [
        Self::JoinRequest,
        Self::JoinAccept,
        Self::JoinRefuse,
        Self::OpenGap,
        Self::GapReady,
        Self::MoveIn,
        Self::InPosition,
        Self::Update,
        Self::Abort,
        Self::LeaveNotice,
        Self::MergeRequest,
        Self::SplitNotice,
    ];

    /// Its name in configs.
    pub fn name(self) -> &'static str {
        match self {
            Self::JoinRequest => "join_request",
            Self::JoinAccept => "join_accept",
            Self::JoinRefuse => "join_refuse",
            Self::OpenGap => "open_gap",
            Self::GapReady => "gap_ready",
            Self::MoveIn => "move_in",
            Self::InPosition => "in_position",
            Self::Update => "update",
            Self::Abort => "abort",
            Self::LeaveNotice => "leave_notice",
            Self::MergeRequest => "merge_request",
            Self::SplitNotice => "split_notice",
        }
    }

    /// The kind named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Its bit in a set of kinds (`u16`).
    pub fn bit(self) -> u16 {
        1 << (self as u16)
    }
}

impl Body {
    /// Its kind.
    pub fn kind(&self) -> MessageKind {
        match self {
            Body::JoinRequest { .. } => MessageKind::JoinRequest,
            Body::JoinAccept { .. } => MessageKind::JoinAccept,
            Body::JoinRefuse { .. } => MessageKind::JoinRefuse,
            Body::OpenGap { .. } => MessageKind::OpenGap,
            Body::GapReady { .. } => MessageKind::GapReady,
            Body::MoveIn => MessageKind::MoveIn,
            Body::InPosition => MessageKind::InPosition,
            Body::Update { .. } => MessageKind::Update,
            Body::Abort { .. } => MessageKind::Abort,
            Body::LeaveNotice => MessageKind::LeaveNotice,
            Body::MergeRequest { .. } => MessageKind::MergeRequest,
            Body::SplitNotice => MessageKind::SplitNotice,
        }
    }
}

/// A change of a formation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// `vehicle` joined directly behind `behind`.
    Joined {
        /// The new member.
        vehicle: VehicleId,
        /// The member it follows.
        behind: VehicleId,
    },
    /// `vehicle` left; the member behind it follows the one ahead.
    Left {
        /// The member that left.
        vehicle: VehicleId,
    },
    /// The platoon headed by `head` merged behind this one's tail. Platoons that merge are
    /// numbered consecutively: the front one from the run's leader to `head - 1`, the rear one
    /// from `head` to `tail`; so each side's copy becomes the whole formation.
    Merged {
        /// The rear platoon's head, now the member behind the front's tail.
        head: VehicleId,
        /// The rear platoon's last vehicle, now the tail.
        tail: VehicleId,
    },
    /// The members from `head` on left as a platoon of their own, `head` heading it: the
    /// copies of the members ahead of it keep the part ahead, the others the part from `head`.
    Split {
        /// The member that heads the part behind.
        head: VehicleId,
    },
}

/// Why a leader refuses a join.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// Another maneuver is under way.
    Busy,
    /// The platoon has as many members as it may.
    Full,
    /// The slot asked for is behind a vehicle that is not a member.
    NoSlot,
    /// The vehicle is a member already.
    Member,
}

/// What a receiver drops: for each sender, every sequence number at or below the last it
/// acted on (a replay, a duplicate, a message overtaken by a newer one).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SeqFilter {
    last: BTreeMap<VehicleId, u16>,
    /// The places in the current step's inbox of the messages dropped as old
    /// ([`SeqFilter::fresh_in`]).
    dropped: Vec<usize>,
}

impl SeqFilter {
    /// Whether `m` is new: if so, it is remembered.
    pub fn fresh(&mut self, m: &Message) -> bool {
        let last = self.last.entry(m.sender).or_insert(0);
        if m.seq > *last {
            *last = m.seq;
            true
        } else {
            false
        }
    }

    /// [`SeqFilter::fresh`] for the message at place `i` of a step's inbox, remembering the
    /// place when it is dropped as old ([`SeqFilter::dropped`]).
    pub fn fresh_in(&mut self, i: usize, m: &Message) -> bool {
        let fresh = self.fresh(m);
        if !fresh {
            self.dropped.push(i);
        }
        fresh
    }

    /// Starts a step: forgets the last step's dropped places.
    pub fn begin_step(&mut self) {
        self.dropped.clear();
    }

    /// The places in this step's inbox of the messages dropped as old, in order.
    pub fn dropped(&self) -> &[usize] {
        &self.dropped
    }
}

/// A sender's sequence numbers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Outbox {
    seq: u16,
}

impl Outbox {
    /// Appends a message from `sender` to `to` with the next sequence number.
    pub(crate) fn send(
        &mut self,
        out: &mut Vec<Message>,
        sender: VehicleId,
        to: VehicleId,
        body: Body,
    ) {
        self.seq = self.seq.saturating_add(1);
        out.push(Message {
            sender,
            to,
            seq: self.seq,
            body,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_replayed_or_older_message_is_dropped() {
        let m = |seq| Message {
            sender: VehicleId(3),
            to: VehicleId(0),
            seq,
            body: Body::InPosition,
        };
        let mut f = SeqFilter::default();
        assert!(f.fresh(&m(1)));
        assert!(!f.fresh(&m(1)), "a duplicate");
        assert!(f.fresh(&m(4)));
        assert!(!f.fresh(&m(2)), "an old one after a newer");
        // In a step's inbox, the places of those dropped are remembered until the next step.
        f.begin_step();
        assert!(!f.fresh_in(0, &m(3)) && f.fresh_in(1, &m(5)) && !f.fresh_in(2, &m(5)));
        assert_eq!(f.dropped(), [0, 2]);
        f.begin_step();
        assert!(f.dropped().is_empty());
        let other = Message {
            sender: VehicleId(4),
            ..m(1)
        };
        assert!(f.fresh(&other), "sequence numbers are per sender");
    }

    #[test]
    fn a_message_to_everyone_is_for_every_other_vehicle() {
        let m = Message {
            sender: VehicleId(0),
            to: EVERYONE,
            seq: 1,
            body: Body::MoveIn,
        };
        assert!(m.is_for(VehicleId(2)) && !m.is_for(VehicleId(0)));
        let unicast = Message {
            to: VehicleId(2),
            ..m
        };
        assert!(unicast.is_for(VehicleId(2)) && !unicast.is_for(VehicleId(3)));
    }
}
