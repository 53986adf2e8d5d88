//! A platoon's group key in its controller (`[security.group]`, docs/security.md#a-group-key-at-join):
//! agreed at each join over the maneuver messages, a MAC on what the config protects, renewed
//! whenever a member leaves. The keys are `platoon_security::group`'s; this module decides
//! what each packet carries and what each receiver requires.
//!
//! - The members the run starts with were admitted before it: each holds a pairwise key with
//!   the leader and the group key of epoch 1.
//! - A joiner's join (or merge) request carries its key share; the leader's accept carries
//!   the leader's share and the group key wrapped under the pairwise key both derive. Both are
//!   signed with the rest of the packet, so nobody on the channel can swap a share.
//! - The protected messages carry a tag under the sender's group key: every maneuver message
//!   but the requests and the leader's answers to them (`GroupMac::Maneuvers`), and with
//!   `GroupMac::All` every packet of a sender the receiver counts as a member. A receiver
//!   refuses a protected message without a tag (`untagged`), with a tag of another epoch than
//!   its key (`wrong_epoch`) or one that does not verify (`bad_tag`).
//! - When a member leaves (its leave, an ejection, a join called off after the accept), the
//!   leader renews the key to the next epoch ([`Keyring::group_key`]) and sends it wrapped
//!   to every member that stays, one wrapped key on each of its packets (it broadcasts every
//!   step while any is left to send); it tags with the new key from then on, the members once
//!   their wrapped key arrives.
//!
//! Pure and seeded: the keys come from the `[security]` seed ([`Keyring`]).
use crate::Packet;
use platoon_maneuver::{Body, Change};
use platoon_model::VehicleId;
use platoon_security::{GroupField, KeyHolder, KeyServer, Keyring, Refusal, WrappedKey};
use platoon_v2v::GroupSeal;
use rand_chacha::ChaCha20Rng;
use std::collections::{BTreeMap, VecDeque};

// Where the two crates meet: the longest group fields fit a packet's.
const _: () = assert!(platoon_security::GROUP_FIELD_LEN <= GroupSeal::CAPACITY);

/// What a tag adds to a packet (bytes): the group fields' flags, the key's epoch and the
/// 16-byte MAC.
pub const TAG_BYTES: u32 = 1 + 4 + platoon_security::group::TAG_LEN as u32;

/// What the group key protects (`[security.group] mac`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GroupMac {
    /// The maneuver messages between members (`"maneuvers"`).
    Maneuvers,
    /// Those and every beacon of a member (`"all"`).
    All,
}

impl GroupMac {
    /// Its name in configs.
    pub fn name(self) -> &'static str {
        match self {
            Self::Maneuvers => "maneuvers",
            Self::All => "all",
        }
    }
}

/// `[security.group]`: a group key at join.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GroupParams {
    /// What its tag protects.
    pub mac: GroupMac,
}

/// Whether a maneuver message is protected by the group key: all but a request from outside
/// and the leader's answer to one (the joiner holds no key before the accept; the accept is
/// authenticated by its wrapped key and its signature).
fn protected(body: &Body) -> bool {
    !matches!(
        body,
        Body::JoinRequest { .. }
            | Body::MergeRequest { .. }
            | Body::JoinAccept { .. }
            | Body::JoinRefuse { .. }
    )
}

/// One platoon's group keys: the leader's server, every follower's holder.
#[derive(Debug, Clone)]
pub(crate) struct Grouping {
    params: GroupParams,
    server: KeyServer,
    /// Follower `i`'s keys at `holders[i - 1]`.
    holders: Vec<KeyHolder>,
    parties: ChaCha20Rng,
    /// The shares of the join requests the leader heard, by joiner.
    shares: BTreeMap<u16, platoon_security::KeyShare>,
    /// The accept's fields for each joiner the leader admitted (an accept sent again carries
    /// the same).
    accepts: BTreeMap<u16, (platoon_security::KeyShare, WrappedKey)>,
    /// Renewals still to send, in order.
    pending: VecDeque<(u32, WrappedKey)>,
    pub(crate) tagged: u64,
    pub(crate) renewals: u64,
}

impl Grouping {
    /// The keys of a platoon of `vehicles` vehicles (the leader first) whose followers in
    /// `outside` are not members yet (joiners, the rear platoon of a merge).
    pub(crate) fn new(
        params: GroupParams,
        keys: &Keyring,
        vehicles: usize,
        outside: &[VehicleId],
    ) -> Self {
        let mut server = KeyServer::starting(keys.group_key(1));
        let mut parties = keys.party_rng();
        let holders = (1..vehicles)
            .map(|i| {
                let mut holder = KeyHolder::new(i as u32, &mut parties);
                if !outside.contains(&VehicleId(i as u16)) {
                    // Admitted before the run: the same agreement as a join's.
                    let admitted = server
                        .admit(i as u32, &holder.share(), &mut parties)
                        .and_then(|(share, wrapped)| holder.admitted(&share, &wrapped));
                    debug_assert!(admitted.is_ok(), "a share of our own is a P-256 point");
                }
                holder
            })
            .collect();
        Self {
            params,
            server,
            holders,
            parties,
            shares: BTreeMap::new(),
            accepts: BTreeMap::new(),
            pending: VecDeque::new(),
            tagged: 0,
            renewals: 0,
        }
    }

    /// Whether the leader has a renewal left to send (it then broadcasts at this step).
    pub(crate) fn leader_has_keys_to_send(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Puts the group-key fields on `p`, about to be signed: a request's share, an accept's
    /// share and wrapped key, a renewal on a leader's packet, the sender's tag; then renews
    /// the key if the leader's message says a member left. `keys`: the next epochs' keys.
    pub(crate) fn fields(&mut self, p: &mut Packet, keys: &Keyring) {
        let mut field = GroupField::default();
        let body = p.maneuver.map(|m| m.body);
        let leader = p.sender.is_leader();
        if leader {
            if let Some(Body::JoinAccept { .. }) = body {
                let to = p.maneuver.map_or(VehicleId(u16::MAX), |m| m.to);
                if let Some((share, wrapped)) = self.accept_for(to) {
                    field.share = Some(share);
                    field.wrapped = Some((u32::from(to.0), wrapped));
                }
            }
            if field.wrapped.is_none() {
                field.wrapped = self.pending.pop_front();
            }
        } else if let Some(h) = self.holders.get(p.sender.index().wrapping_sub(1)) {
            if matches!(
                body,
                Some(Body::JoinRequest { .. } | Body::MergeRequest { .. })
            ) {
                field.share = Some(h.share());
            }
        }
        let wants_tag = match body {
            Some(b) if protected(&b) => true,
            _ => self.params.mac == GroupMac::All,
        };
        let key = if leader {
            Some(self.server.key())
        } else {
            self.holders
                .get(p.sender.index().wrapping_sub(1))
                .and_then(|h| h.key().ok())
        };
        if let (true, Some(key)) = (wants_tag, key) {
            field.tag = Some(key.tag(&p.payload_bytes()));
            self.tagged += 1;
        }
        if !field.is_empty() {
            p.group = GroupSeal::new(&field.encode());
        }
        // A member left (a leave, an ejection) or a join was called off after its accept:
        // from the next packet on, the leader tags with a key the leaver does not hold.
        let gone = match body {
            Some(Body::Update {
                change: Change::Left { vehicle },
                ..
            }) if leader => Some(vehicle),
            Some(Body::Abort { joiner }) if leader => Some(joiner),
            _ => None,
        };
        if let Some(v) = gone.filter(|v| self.server.is_member(u32::from(v.0))) {
            let next = keys.group_key(self.server.key().epoch() + 1);
            self.pending
                .extend(self.server.remove_to(u32::from(v.0), next));
            self.accepts.remove(&v.0);
            self.renewals += 1;
        }
    }

    /// The accept's fields for joiner `to`: those of an earlier accept, or a new admission if
    /// its request's share was heard (none: the joiner gets no key).
    fn accept_for(&mut self, to: VehicleId) -> Option<(platoon_security::KeyShare, WrappedKey)> {
        if let Some(a) = self.accepts.get(&to.0) {
            return Some(*a);
        }
        let share = self.shares.get(&to.0)?;
        let admitted = self
            .server
            .admit(u32::from(to.0), share, &mut self.parties)
            .ok()?;
        self.accepts.insert(to.0, admitted);
        Some(admitted)
    }

    /// Whether `p` carries key material for `receiver` (a request's share for the leader, a
    /// wrapped key for a follower): such a packet's signature is checked before it is used.
    pub(crate) fn carries_keys_for(&self, receiver: VehicleId, p: &Packet) -> bool {
        let Some(g) = &p.group else { return false };
        let Ok(field) = GroupField::decode(g.as_bytes()) else {
            return false;
        };
        if receiver.is_leader() {
            field.share.is_some()
        } else {
            field
                .wrapped
                .is_some_and(|(m, _)| m == u32::from(receiver.0))
        }
    }

    /// `receiver`'s check of `p`'s group-key fields (its signature already verified if it
    /// carries keys for the receiver): takes the keys meant for it, then, if it is a member
    /// holding a key (`membership.0`: it has not left), requires a valid tag of a protected
    /// message (`membership.1`: it counts the sender as a member, for [`GroupMac::All`]). A
    /// vehicle outside the platoon (a joiner before its accept, a leaver) checks no tag.
    pub(crate) fn receive(
        &mut self,
        receiver: VehicleId,
        p: &Packet,
        membership: (bool, bool),
    ) -> Result<(), Refusal> {
        let field = match &p.group {
            None => GroupField::default(),
            Some(g) => GroupField::decode(g.as_bytes())?,
        };
        let body = p.maneuver.map(|m| m.body);
        if receiver.is_leader() {
            if let (Some(share), Some(Body::JoinRequest { .. } | Body::MergeRequest { .. })) =
                (field.share, body)
            {
                self.shares.insert(p.sender.0, share);
            }
        } else if let Some(h) = self.holders.get_mut(receiver.index() - 1) {
            if let Some((m, wrapped)) = field.wrapped {
                if m == u32::from(receiver.0) && p.sender.is_leader() {
                    // An accept's key (agreed again if the joiner asked again after a join
                    // called off), or a renewal for a member. A wrap that does not open, or
                    // one older than the key held, changes nothing.
                    let held = h.key().map_or(0, |k| k.epoch());
                    let _ = match (field.share, body) {
                        (Some(share), Some(Body::JoinAccept { .. })) if wrapped.epoch >= held => {
                            h.admitted(&share, &wrapped)
                        }
                        _ => h.renew(&wrapped),
                    };
                }
            }
        }
        let required = match body {
            Some(b) if protected(&b) => true,
            _ => self.params.mac == GroupMac::All && membership.1,
        };
        let key = if receiver.is_leader() {
            Some(self.server.key())
        } else {
            self.holders
                .get(receiver.index() - 1)
                .and_then(|h| h.key().ok())
        };
        let (true, true, Some(key)) = (required && p.sender != receiver, membership.0, key) else {
            return Ok(());
        };
        let tag = field.tag.ok_or(Refusal::Untagged)?;
        key.check(&p.payload_bytes(), &tag).map_err(|e| match e {
            platoon_security::GroupError::WrongEpoch { .. } => Refusal::WrongEpoch,
            _ => Refusal::BadTag,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_maneuver::{Message, EVERYONE};
    use platoon_model::State;

    fn packet(from: u16, to: VehicleId, body: Body) -> Packet {
        let mut p = Packet::beacon(VehicleId(from), 1, 0, State::new(0.0, 20.0, 0.0));
        p.maneuver = Some(Message {
            sender: VehicleId(from),
            to,
            seq: 1,
            body,
        });
        p
    }

    const IN: (bool, bool) = (true, true);

    /// Sends `p` through the group's fields and has `to` receive it.
    fn send(g: &mut Grouping, keys: &Keyring, mut p: Packet, to: u16) -> Result<(), Refusal> {
        g.fields(&mut p, keys);
        g.receive(VehicleId(to), &p, IN)
    }

    #[test]
    fn a_join_gives_the_key_and_a_leave_shuts_the_leaver_out() {
        let keys = Keyring::new(3, 0, 4);
        let params = GroupParams {
            mac: GroupMac::Maneuvers,
        };
        let mut g = Grouping::new(params, &keys, 4, &[VehicleId(3)]);
        let leader = VehicleId::LEADER;
        // A member's message is tagged and taken; untagged or altered, refused.
        let notice = packet(1, leader, Body::LeaveNotice);
        assert_eq!(send(&mut g, &keys, notice, 0), Ok(()));
        assert_eq!(g.receive(leader, &notice, IN), Err(Refusal::Untagged));
        let mut tagged = notice;
        g.fields(&mut tagged, &keys);
        let mut altered = tagged;
        altered.state[1] = 30.0;
        assert_eq!(g.receive(leader, &altered, IN), Err(Refusal::BadTag));
        // The joiner holds no key: its messages carry no tag until its accept.
        let in_position = packet(3, leader, Body::InPosition);
        assert_eq!(send(&mut g, &keys, in_position, 0), Err(Refusal::Untagged));
        let request = packet(
            3,
            leader,
            Body::JoinRequest {
                behind: VehicleId(2),
            },
        );
        assert_eq!(send(&mut g, &keys, request, 0), Ok(()), "requests are open");
        let accept = packet(
            0,
            VehicleId(3),
            Body::JoinAccept {
                behind: VehicleId(2),
                middle: false,
            },
        );
        assert_eq!(send(&mut g, &keys, accept, 3), Ok(()));
        assert_eq!(send(&mut g, &keys, in_position, 0), Ok(()), "admitted");
        // Member 1 leaves: the key is renewed, and wrapped for 2 and 3 on the leader's next
        // packets.
        let update = packet(
            0,
            EVERYONE,
            Body::Update {
                generation: 2,
                change: Change::Left {
                    vehicle: VehicleId(1),
                },
            },
        );
        assert_eq!(
            send(&mut g, &keys, update, 2),
            Ok(()),
            "tagged before renewing"
        );
        assert_eq!(g.renewals, 1);
        assert!(g.leader_has_keys_to_send());
        // Before its wrapped key arrives, member 2 holds the old epoch.
        let gap = packet(
            2,
            leader,
            Body::GapReady {
                joiner: VehicleId(3),
            },
        );
        assert_eq!(send(&mut g, &keys, gap, 0), Err(Refusal::WrongEpoch));
        for to in [2, 3] {
            let beacon = Packet::beacon(leader, 2, 1, State::new(0.0, 20.0, 0.0));
            assert_eq!(send(&mut g, &keys, beacon, to), Ok(()));
        }
        assert!(!g.leader_has_keys_to_send());
        assert_eq!(send(&mut g, &keys, gap, 0), Ok(()), "renewed");
        // The leaver's tag is of the old epoch; a member's of the new one.
        assert_eq!(send(&mut g, &keys, notice, 0), Err(Refusal::WrongEpoch));
        assert_eq!(send(&mut g, &keys, notice, 2), Err(Refusal::WrongEpoch));
        // A vehicle outside the platoon checks nothing.
        assert_eq!(g.receive(VehicleId(1), &notice, (false, true)), Ok(()));
    }
}
