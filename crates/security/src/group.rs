//! A platoon's group key (issue 52, item 3's pure core): agreed with each member at its join,
//! a MAC on intra-platoon messages, renewed on every leave.
//!
//! - At a join, the joiner sends an ephemeral P-256 public key ([`KeyShare`]) with its
//!   request, the leader answers with its own: both derive the same [`PairwiseKey`] (ECDH,
//!   then HKDF-SHA256 over the shared secret, bound to the member's id), which an
//!   eavesdropper on the channel cannot.
//! - The leader sends the current [`GroupKey`] wrapped under that pairwise key
//!   ([`WrappedKey`]: ChaCha20-Poly1305, the key's epoch as its nonce and associated data).
//! - Members tag intra-platoon messages with the group key ([`Tag`]: HMAC-SHA256 truncated to
//!   16 bytes, over the epoch and the payload); a receiver checks the tag, so a vehicle
//!   outside the platoon, even one with a valid pseudonym, cannot pass as a member.
//! - On a leave the leader draws a new key of the next epoch and sends it wrapped to every
//!   remaining member ([`KeyServer::remove`]): the leaver's key no longer tags anything a
//!   member accepts.
//!
//! Pure: every key comes from the caller's seeded RNG; the same draws give the same keys.

use chacha20poly1305::aead::{Aead, KeyInit, Payload};
use chacha20poly1305::{ChaCha20Poly1305, Key, Nonce};
use hkdf::Hkdf;
use hmac::{Hmac, Mac};
use p256::elliptic_curve::sec1::ToEncodedPoint;
use rand::{CryptoRng, RngCore};
use sha2::Sha256;
use std::collections::BTreeMap;

/// A key share's size: a compressed SEC1 P-256 point (bytes).
pub const SHARE_LEN: usize = 33;
/// A group key's size (bytes).
pub const KEY_LEN: usize = 32;
/// A message tag's MAC size (bytes), HMAC-SHA256 truncated.
pub const TAG_LEN: usize = 16;
/// A wrapped key's sealed size: the key and the AEAD's 16-byte tag (bytes).
pub const SEALED_LEN: usize = KEY_LEN + 16;

/// The HKDF `info` prefix and the wrap's associated data prefix: what the keys are for.
const LABEL: &[u8] = b"platoon group key v1";

/// Why a group-key operation failed. Each has a stable [`name`](GroupError::name).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum GroupError {
    /// The peer's key share is no P-256 point.
    #[error("the key share is no P-256 point")]
    BadShare,
    /// A wrapped key does not open under the pairwise key: altered, or meant for another.
    #[error("the wrapped group key does not open under this pairwise key")]
    BadWrap,
    /// A renewal that is not newer than the key held.
    #[error("a group key of epoch {got} does not renew epoch {held}")]
    NotNewer {
        /// The epoch held.
        held: u32,
        /// The epoch offered.
        got: u32,
    },
    /// A tag of another epoch than the key's.
    #[error("a tag of epoch {got} under a key of epoch {expected}")]
    WrongEpoch {
        /// The key's epoch.
        expected: u32,
        /// The tag's.
        got: u32,
    },
    /// A tag that does not verify: the payload altered, or tagged without the group key.
    #[error("the message's tag does not verify")]
    BadTag,
    /// A member holds no group key yet (not admitted).
    #[error("no group key held yet")]
    NoKey,
}

impl GroupError {
    /// A stable snake_case name, for a dataset's column.
    pub fn name(self) -> &'static str {
        match self {
            GroupError::BadShare => "bad_share",
            GroupError::BadWrap => "bad_wrap",
            GroupError::NotNewer { .. } => "not_newer",
            GroupError::WrongEpoch { .. } => "wrong_epoch",
            GroupError::BadTag => "bad_tag",
            GroupError::NoKey => "no_key",
        }
    }
}

/// An ephemeral ECDH public key, as a join request or accept carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyShare(pub [u8; SHARE_LEN]);

/// One side of a key agreement: an ephemeral P-256 key.
#[derive(Clone)]
pub struct Party {
    secret: p256::SecretKey,
}

impl std::fmt::Debug for Party {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Party")
            .field("share", &self.share())
            .finish_non_exhaustive()
    }
}

impl Party {
    /// A fresh ephemeral key from `rng`.
    pub fn new<R: RngCore + CryptoRng>(rng: &mut R) -> Party {
        Party {
            secret: p256::SecretKey::random(rng),
        }
    }

    /// Its public share.
    pub fn share(&self) -> KeyShare {
        let point = self.secret.public_key().to_encoded_point(true);
        let mut out = [0; SHARE_LEN];
        out.copy_from_slice(point.as_bytes());
        KeyShare(out)
    }

    /// The pairwise key with the holder of `peer`, for `member`'s slot (both sides pass the
    /// same member id).
    pub fn agree(&self, peer: &KeyShare, member: u32) -> Result<PairwiseKey, GroupError> {
        let peer = p256::PublicKey::from_sec1_bytes(&peer.0).map_err(|_| GroupError::BadShare)?;
        let shared = p256::ecdh::diffie_hellman(self.secret.to_nonzero_scalar(), peer.as_affine());
        let hk = Hkdf::<Sha256>::new(None, shared.raw_secret_bytes());
        let mut info = LABEL.to_vec();
        info.extend_from_slice(&member.to_be_bytes());
        let mut key = [0; KEY_LEN];
        hk.expand(&info, &mut key)
            .expect("32 bytes is a valid HKDF-SHA256 output length");
        Ok(PairwiseKey(key))
    }
}

/// The key a member and its leader share after the join's agreement.
#[derive(Clone, PartialEq, Eq)]
pub struct PairwiseKey([u8; KEY_LEN]);

impl std::fmt::Debug for PairwiseKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PairwiseKey(..)")
    }
}

impl PairwiseKey {
    fn cipher(&self) -> ChaCha20Poly1305 {
        ChaCha20Poly1305::new(Key::from_slice(&self.0))
    }

    /// Nonce and associated data for a key of `epoch`: each epoch is wrapped at most once
    /// under one pairwise key, so the nonce never repeats.
    fn nonce_and_aad(epoch: u32) -> ([u8; 12], Vec<u8>) {
        let mut nonce = [0; 12];
        nonce[8..].copy_from_slice(&epoch.to_be_bytes());
        let mut aad = LABEL.to_vec();
        aad.extend_from_slice(&epoch.to_be_bytes());
        (nonce, aad)
    }

    /// `key` sealed under this pairwise key.
    pub fn wrap(&self, key: &GroupKey) -> WrappedKey {
        let (nonce, aad) = Self::nonce_and_aad(key.epoch);
        let sealed = self
            .cipher()
            .encrypt(
                Nonce::from_slice(&nonce),
                Payload {
                    msg: &key.key,
                    aad: &aad,
                },
            )
            .expect("ChaCha20-Poly1305 seals 32 bytes");
        let mut out = [0; SEALED_LEN];
        out.copy_from_slice(&sealed);
        WrappedKey {
            epoch: key.epoch,
            sealed: out,
        }
    }

    /// The group key `wrapped` seals ([`GroupError::BadWrap`] if it does not open).
    pub fn unwrap(&self, wrapped: &WrappedKey) -> Result<GroupKey, GroupError> {
        let (nonce, aad) = Self::nonce_and_aad(wrapped.epoch);
        let key = self
            .cipher()
            .decrypt(
                Nonce::from_slice(&nonce),
                Payload {
                    msg: &wrapped.sealed,
                    aad: &aad,
                },
            )
            .map_err(|_| GroupError::BadWrap)?;
        let mut out = [0; KEY_LEN];
        out.copy_from_slice(&key);
        Ok(GroupKey {
            epoch: wrapped.epoch,
            key: out,
        })
    }
}

/// A group key sealed for one member.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WrappedKey {
    /// The key's epoch (1 at the platoon's start, +1 per renewal), in the clear.
    pub epoch: u32,
    /// The sealed key.
    pub sealed: [u8; SEALED_LEN],
}

/// The platoon's group key of one epoch.
#[derive(Clone, PartialEq, Eq)]
pub struct GroupKey {
    epoch: u32,
    key: [u8; KEY_LEN],
}

impl std::fmt::Debug for GroupKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GroupKey(epoch {})", self.epoch)
    }
}

/// A message's tag under the group key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tag {
    /// The epoch of the key that made it.
    pub epoch: u32,
    /// HMAC-SHA256 over the epoch and the payload, its first [`TAG_LEN`] bytes.
    pub mac: [u8; TAG_LEN],
}

impl GroupKey {
    /// A key of `epoch` from `rng`.
    pub fn generate<R: RngCore + CryptoRng>(rng: &mut R, epoch: u32) -> GroupKey {
        let mut key = [0; KEY_LEN];
        rng.fill_bytes(&mut key);
        GroupKey { epoch, key }
    }

    /// Its epoch.
    pub fn epoch(&self) -> u32 {
        self.epoch
    }

    fn mac(&self, payload: &[u8]) -> Hmac<Sha256> {
        let mut mac =
            <Hmac<Sha256> as Mac>::new_from_slice(&self.key).expect("HMAC takes any key length");
        mac.update(&self.epoch.to_be_bytes());
        mac.update(payload);
        mac
    }

    /// `payload`'s tag.
    pub fn tag(&self, payload: &[u8]) -> Tag {
        let full = self.mac(payload).finalize().into_bytes();
        let mut mac = [0; TAG_LEN];
        mac.copy_from_slice(&full[..TAG_LEN]);
        Tag {
            epoch: self.epoch,
            mac,
        }
    }

    /// Whether `tag` is this key's over `payload` (in constant time).
    pub fn check(&self, payload: &[u8], tag: &Tag) -> Result<(), GroupError> {
        if tag.epoch != self.epoch {
            return Err(GroupError::WrongEpoch {
                expected: self.epoch,
                got: tag.epoch,
            });
        }
        self.mac(payload)
            .verify_truncated_left(&tag.mac)
            .map_err(|_| GroupError::BadTag)
    }
}

/// The leader's side: a pairwise key per member, the current group key.
#[derive(Debug, Clone)]
pub struct KeyServer {
    members: BTreeMap<u32, PairwiseKey>,
    key: GroupKey,
}

impl KeyServer {
    /// A platoon's first key (epoch 1), no member yet.
    pub fn new<R: RngCore + CryptoRng>(rng: &mut R) -> KeyServer {
        KeyServer::starting(GroupKey::generate(rng, 1))
    }

    /// A platoon whose first key is `key` (drawn by the caller: a run's come from its
    /// [`crate::Keyring`]), no member yet.
    pub fn starting(key: GroupKey) -> KeyServer {
        KeyServer {
            members: BTreeMap::new(),
            key,
        }
    }

    /// Admits `member`, whose join request carried `share`: the leader's share for the accept
    /// and the current group key wrapped for the member.
    pub fn admit<R: RngCore + CryptoRng>(
        &mut self,
        member: u32,
        share: &KeyShare,
        rng: &mut R,
    ) -> Result<(KeyShare, WrappedKey), GroupError> {
        let party = Party::new(rng);
        let pairwise = party.agree(share, member)?;
        let wrapped = pairwise.wrap(&self.key);
        self.members.insert(member, pairwise);
        Ok((party.share(), wrapped))
    }

    /// `member` left: a new key of the next epoch, wrapped for every member that stays (in
    /// member order). Removing a vehicle that is no member renews nothing.
    pub fn remove<R: RngCore + CryptoRng>(
        &mut self,
        member: u32,
        rng: &mut R,
    ) -> Vec<(u32, WrappedKey)> {
        let next = GroupKey::generate(rng, self.key.epoch + 1);
        self.remove_to(member, next)
    }

    /// [`KeyServer::remove`] with the next key drawn by the caller (`next`, whose epoch
    /// should follow the current one's). Removing a vehicle that is no member renews nothing.
    pub fn remove_to(&mut self, member: u32, next: GroupKey) -> Vec<(u32, WrappedKey)> {
        if self.members.remove(&member).is_none() {
            return Vec::new();
        }
        self.key = next;
        self.members
            .iter()
            .map(|(m, pairwise)| (*m, pairwise.wrap(&self.key)))
            .collect()
    }

    /// The current group key.
    pub fn key(&self) -> &GroupKey {
        &self.key
    }

    /// The members holding a pairwise key, in order.
    pub fn members(&self) -> impl Iterator<Item = u32> + '_ {
        self.members.keys().copied()
    }

    /// Whether `member` holds a pairwise key (it was admitted and has not left).
    pub fn is_member(&self, member: u32) -> bool {
        self.members.contains_key(&member)
    }
}

/// A member's side: its ephemeral key until admitted, then its pairwise and group keys.
#[derive(Debug, Clone)]
pub struct KeyHolder {
    member: u32,
    party: Party,
    pairwise: Option<PairwiseKey>,
    key: Option<GroupKey>,
}

impl KeyHolder {
    /// A vehicle that will ask to join as `member`, with a fresh ephemeral key.
    pub fn new<R: RngCore + CryptoRng>(member: u32, rng: &mut R) -> KeyHolder {
        KeyHolder {
            member,
            party: Party::new(rng),
            pairwise: None,
            key: None,
        }
    }

    /// The share its join request carries.
    pub fn share(&self) -> KeyShare {
        self.party.share()
    }

    /// The leader admitted it: `leader` is the accept's share, `wrapped` the group key.
    pub fn admitted(&mut self, leader: &KeyShare, wrapped: &WrappedKey) -> Result<(), GroupError> {
        let pairwise = self.party.agree(leader, self.member)?;
        let key = pairwise.unwrap(wrapped)?;
        self.pairwise = Some(pairwise);
        self.key = Some(key);
        Ok(())
    }

    /// The leader renewed the group key.
    pub fn renew(&mut self, wrapped: &WrappedKey) -> Result<(), GroupError> {
        let pairwise = self.pairwise.as_ref().ok_or(GroupError::NoKey)?;
        let held = self.key.as_ref().map_or(0, |k| k.epoch);
        if wrapped.epoch <= held {
            return Err(GroupError::NotNewer {
                held,
                got: wrapped.epoch,
            });
        }
        self.key = Some(pairwise.unwrap(wrapped)?);
        Ok(())
    }

    /// The group key it holds.
    pub fn key(&self) -> Result<&GroupKey, GroupError> {
        self.key.as_ref().ok_or(GroupError::NoKey)
    }
}

/// The group-key fields a packet carries (`platoon_v2v::GroupSeal`'s bytes,
/// docs/security.md#a-group-key-at-join): a tag under the group key, a joiner's or the
/// leader's key share, and a group key wrapped for one member (the accept's, or a renewal's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GroupField {
    /// The sender's tag over the packet's payload.
    pub tag: Option<Tag>,
    /// A key share: a join or merge request's (the joiner's), or a join accept's (the
    /// leader's).
    pub share: Option<KeyShare>,
    /// A group key wrapped for the member it names.
    pub wrapped: Option<(u32, WrappedKey)>,
}

/// The longest encoded [`GroupField`] (bytes): its flags, a tag (epoch and MAC), a share and
/// a wrapped key (member, epoch and the sealed key).
pub const GROUP_FIELD_LEN: usize = 1 + (4 + TAG_LEN) + SHARE_LEN + (4 + 4 + SEALED_LEN);

impl GroupField {
    const TAG: u8 = 1;
    const SHARE: u8 = 2;
    const WRAPPED: u8 = 4;

    /// Whether it carries nothing (a packet without group fields carries none at all).
    pub fn is_empty(&self) -> bool {
        self.tag.is_none() && self.share.is_none() && self.wrapped.is_none()
    }

    /// Its bytes: a flags byte (bit 0 a tag, bit 1 a share, bit 2 a wrapped key), then the
    /// fields present in that order, integers big-endian.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(GROUP_FIELD_LEN);
        let flag = |present: bool, bit: u8| if present { bit } else { 0 };
        out.push(
            flag(self.tag.is_some(), Self::TAG)
                | flag(self.share.is_some(), Self::SHARE)
                | flag(self.wrapped.is_some(), Self::WRAPPED),
        );
        if let Some(t) = &self.tag {
            out.extend_from_slice(&t.epoch.to_be_bytes());
            out.extend_from_slice(&t.mac);
        }
        if let Some(s) = &self.share {
            out.extend_from_slice(&s.0);
        }
        if let Some((member, w)) = &self.wrapped {
            out.extend_from_slice(&member.to_be_bytes());
            out.extend_from_slice(&w.epoch.to_be_bytes());
            out.extend_from_slice(&w.sealed);
        }
        out
    }

    /// The field `bytes` encode: `Truncated` if they end early (or are empty), `Malformed`
    /// for unknown flags or bytes after the last field. A share that is no P-256 point is
    /// found when it is used ([`GroupError::BadShare`]).
    pub fn decode(bytes: &[u8]) -> Result<GroupField, crate::Refusal> {
        use crate::Refusal;
        let (&flags, mut rest) = bytes.split_first().ok_or(Refusal::Truncated)?;
        if flags & !(Self::TAG | Self::SHARE | Self::WRAPPED) != 0 {
            return Err(Refusal::Malformed);
        }
        let mut take = |n: usize| -> Result<&[u8], Refusal> {
            if rest.len() < n {
                return Err(Refusal::Truncated);
            }
            let (head, tail) = rest.split_at(n);
            rest = tail;
            Ok(head)
        };
        let u32_of = |b: &[u8]| u32::from_be_bytes(b.try_into().expect("4 bytes"));
        let mut field = GroupField::default();
        if flags & Self::TAG != 0 {
            let epoch = u32_of(take(4)?);
            let mut mac = [0; TAG_LEN];
            mac.copy_from_slice(take(TAG_LEN)?);
            field.tag = Some(Tag { epoch, mac });
        }
        if flags & Self::SHARE != 0 {
            let mut share = [0; SHARE_LEN];
            share.copy_from_slice(take(SHARE_LEN)?);
            field.share = Some(KeyShare(share));
        }
        if flags & Self::WRAPPED != 0 {
            let member = u32_of(take(4)?);
            let epoch = u32_of(take(4)?);
            let mut sealed = [0; SEALED_LEN];
            sealed.copy_from_slice(take(SEALED_LEN)?);
            field.wrapped = Some((member, WrappedKey { epoch, sealed }));
        }
        if !rest.is_empty() {
            return Err(Refusal::Malformed);
        }
        Ok(field)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A leader and members 1..=n admitted, from one seed.
    fn platoon(n: u32, seed: u64) -> (KeyServer, Vec<KeyHolder>, ChaCha8Rng) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut leader = KeyServer::new(&mut rng);
        let mut members = Vec::new();
        for m in 1..=n {
            let mut holder = KeyHolder::new(m, &mut rng);
            let (share, wrapped) = leader.admit(m, &holder.share(), &mut rng).unwrap();
            holder.admitted(&share, &wrapped).unwrap();
            members.push(holder);
        }
        (leader, members, rng)
    }

    #[test]
    fn members_admitted_hold_the_leaders_key_and_tag_for_each_other() {
        let (leader, members, _) = platoon(4, 1);
        for m in &members {
            assert_eq!(m.key().unwrap(), leader.key());
        }
        let tag = members[0].key().unwrap().tag(b"beacon");
        assert_eq!(members[3].key().unwrap().check(b"beacon", &tag), Ok(()));
        assert_eq!(
            members[3].key().unwrap().check(b"beacoN", &tag),
            Err(GroupError::BadTag)
        );
        let mut forged = tag;
        forged.mac[0] ^= 1;
        assert_eq!(
            leader.key().check(b"beacon", &forged),
            Err(GroupError::BadTag)
        );
        // The same seed, the same keys; another seed, another key.
        assert_eq!(platoon(4, 1).0.key(), leader.key());
        assert_ne!(platoon(4, 2).0.key(), leader.key());
    }

    #[test]
    fn an_outsider_can_neither_open_the_wrap_nor_tag() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut leader = KeyServer::new(&mut rng);
        let joiner = KeyHolder::new(1, &mut rng);
        let (share, wrapped) = leader.admit(1, &joiner.share(), &mut rng).unwrap();
        // The eavesdropper saw both shares and the wrap: its own ECDH with either share gives
        // another pairwise key.
        let eve = Party::new(&mut rng);
        for s in [share, joiner.share()] {
            let guess = eve.agree(&s, 1).unwrap();
            assert_eq!(guess.unwrap(&wrapped), Err(GroupError::BadWrap));
        }
        // A key of its own tags nothing the leader accepts.
        let own = GroupKey::generate(&mut rng, 1);
        assert_eq!(
            leader.key().check(b"x", &own.tag(b"x")),
            Err(GroupError::BadTag)
        );
        // A wrap altered in transit, or meant for another slot, does not open.
        let mut altered = wrapped;
        altered.sealed[5] ^= 0x40;
        let mut j = joiner.clone();
        assert_eq!(j.admitted(&share, &altered), Err(GroupError::BadWrap));
        let mut elsewhere = KeyHolder {
            member: 2,
            ..joiner
        };
        assert_eq!(
            elsewhere.admitted(&share, &wrapped),
            Err(GroupError::BadWrap)
        );
        let mut bad = share;
        bad.0[0] = 0x07;
        assert_eq!(eve.agree(&bad, 1).map(|_| ()), Err(GroupError::BadShare));
    }

    #[test]
    fn a_leave_renews_the_key_and_shuts_the_leaver_out() {
        let (mut leader, mut members, mut rng) = platoon(4, 5);
        let leaver = members.remove(1); // member 2
        let renewals = leader.remove(2, &mut rng);
        assert_eq!(leader.key().epoch(), 2);
        assert_eq!(
            renewals.iter().map(|(m, _)| *m).collect::<Vec<_>>(),
            vec![1, 3, 4]
        );
        for (holder, (_, wrapped)) in members.iter_mut().zip(&renewals) {
            holder.renew(wrapped).unwrap();
            assert_eq!(holder.key().unwrap(), leader.key());
            // A renewal replayed is refused.
            assert_eq!(
                holder.renew(wrapped),
                Err(GroupError::NotNewer { held: 2, got: 2 })
            );
        }
        // The leaver's key, epoch 1: its tags are of the old epoch, and were they relabelled,
        // they do not verify.
        let old = leaver.key().unwrap().tag(b"brake");
        assert_eq!(
            members[0].key().unwrap().check(b"brake", &old),
            Err(GroupError::WrongEpoch {
                expected: 2,
                got: 1
            })
        );
        let relabelled = Tag { epoch: 2, ..old };
        assert_eq!(
            members[0].key().unwrap().check(b"brake", &relabelled),
            Err(GroupError::BadTag)
        );
        // The leaver cannot open the new key's wraps meant for others.
        let mut l = leaver.clone();
        assert!(matches!(l.renew(&renewals[0].1), Err(GroupError::BadWrap)));
        // Removing a vehicle that is no member renews nothing.
        assert!(leader.remove(9, &mut rng).is_empty());
        assert_eq!(leader.key().epoch(), 2);
    }

    #[test]
    fn a_vehicle_not_admitted_holds_no_key() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let mut waiting = KeyHolder::new(1, &mut rng);
        assert_eq!(waiting.key().map(|_| ()), Err(GroupError::NoKey));
        let leader = KeyServer::new(&mut rng);
        let wrapped = PairwiseKey([0; KEY_LEN]).wrap(leader.key());
        assert_eq!(waiting.renew(&wrapped), Err(GroupError::NoKey));
    }

    #[test]
    fn a_group_field_round_trips_and_bad_bytes_are_refused() {
        use crate::Refusal;
        let (leader, members, mut rng) = platoon(2, 9);
        let tag = members[0].key().unwrap().tag(b"x");
        let joiner = KeyHolder::new(3, &mut rng);
        let wrapped = PairwiseKey([1; KEY_LEN]).wrap(leader.key());
        let fields = [
            GroupField::default(),
            GroupField {
                tag: Some(tag),
                ..GroupField::default()
            },
            GroupField {
                share: Some(joiner.share()),
                wrapped: Some((3, wrapped)),
                ..GroupField::default()
            },
            GroupField {
                tag: Some(tag),
                share: Some(joiner.share()),
                wrapped: Some((7, wrapped)),
            },
        ];
        for f in fields {
            let bytes = f.encode();
            assert!(bytes.len() <= GROUP_FIELD_LEN);
            assert_eq!(GroupField::decode(&bytes), Ok(f));
            // Every shorter prefix is truncated, a byte more is malformed.
            for n in 0..bytes.len() {
                assert_eq!(GroupField::decode(&bytes[..n]), Err(Refusal::Truncated));
            }
            let mut longer = bytes.clone();
            longer.push(0);
            assert_eq!(GroupField::decode(&longer), Err(Refusal::Malformed));
        }
        assert_eq!(GroupField::decode(&[8]), Err(Refusal::Malformed));
        assert_eq!(fields[3].encode().len(), GROUP_FIELD_LEN);
    }

    proptest::proptest! {
        /// Whatever bytes a packet's group fields hold, decoding them never panics, and what
        /// decodes encodes back to the same bytes.
        #[test]
        fn decoding_any_group_bytes_never_panics(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..130)) {
            if let Ok(field) = GroupField::decode(&bytes) {
                proptest::prop_assert_eq!(field.encode(), bytes);
            }
        }
    }
}
