//! A platoon's keys in a run, all from its `[security]` seed: the PKI (a root and an
//! authorization authority, the same for every platoon of a fleet) and each vehicle's
//! pseudonyms, an epoch of pseudonyms (one per vehicle) at the start and one more at every
//! pseudonym change ([`Keyring`]).
//!
//! Whoever needs a vehicle's key derives it here from the seed: the vehicles that sign their
//! broadcasts, an insider that signs its lie with its own key, a thief that signs with a
//! member's stolen key, the misbehaviour authority that knows which vehicle holds which
//! pseudonym, and the ground truth, which tells from a delivered packet's signature whose key
//! made it. They draw the same keys at the same seed because they draw them in one order.
//!
//! The order: a ChaCha20 stream seeded with the seed gives the root, then the authority; the
//! pseudonyms follow on that stream for platoon 0, and on ChaCha20 stream `j` of the same seed
//! for platoon `j` of a fleet (its own keys, the fleet's PKI). An epoch is `vehicles`
//! pseudonyms in vehicle order.
//!
//! A platoon's group keys (`[security.group]`) come from the seed too, each epoch's from a
//! generator of its own ([`Keyring::group_key`]): the leader draws the key it renews to, and an
//! insider on the channel, a member, holds the key of the epochs it was a member in. The
//! ephemeral keys of the joins' key agreements come from a stream of their own
//! ([`Keyring::party_rng`]).

use crate::{sign, Credential, HashedId8, Pki, SecurityHeader, Validity};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

/// Where a key sits in a [`Keyring`]: its epoch (0 before the first pseudonym change) and
/// its vehicle (0 = the leader).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct KeySlot {
    /// The pseudonym epoch.
    pub epoch: usize,
    /// The vehicle.
    pub vehicle: usize,
}

/// A platoon's PKI and pseudonyms (module docs). Epochs are drawn when asked for, in order.
#[derive(Debug, Clone)]
pub struct Keyring {
    seed: u64,
    platoon: u16,
    pki: Pki,
    rng: ChaCha20Rng,
    validity: Validity,
    vehicles: usize,
    epochs: Vec<Vec<Credential>>,
}

impl Keyring {
    /// The keys of platoon `platoon` (0 outside fleets) of `vehicles` vehicles at `seed`, with
    /// epoch 0 drawn. Certificates are valid for the whole run.
    pub fn new(seed: u64, platoon: u16, vehicles: usize) -> Keyring {
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        let validity = Validity::new(0, u64::MAX);
        let pki = Pki::generate(&mut rng, validity);
        if platoon > 0 {
            rng = ChaCha20Rng::seed_from_u64(seed);
            rng.set_stream(u64::from(platoon));
        }
        let mut keys = Keyring {
            seed,
            platoon,
            pki,
            rng,
            validity,
            vehicles,
            epochs: Vec::new(),
        };
        keys.draw_epoch();
        keys
    }

    /// A generator for `purpose` and `index`, from the seed and the platoon alone (SHA-256 of
    /// them as its ChaCha20 key): independent of the PKI's and the pseudonyms' stream.
    fn derived(&self, purpose: &[u8], index: u64) -> ChaCha20Rng {
        use sha2::{Digest, Sha256};
        let mut h = Sha256::new();
        h.update(b"platoon keyring v1");
        h.update(purpose);
        h.update(self.seed.to_be_bytes());
        h.update(self.platoon.to_be_bytes());
        h.update(index.to_be_bytes());
        ChaCha20Rng::from_seed(h.finalize().into())
    }

    /// The platoon's group key of `epoch` (1 at the start, +1 at every renewal).
    pub fn group_key(&self, epoch: u32) -> crate::GroupKey {
        crate::GroupKey::generate(&mut self.derived(b"group key", u64::from(epoch)), epoch)
    }

    /// The generator of the platoon's ephemeral keys for the joins' key agreements.
    pub fn party_rng(&self) -> ChaCha20Rng {
        self.derived(b"key agreement", 0)
    }

    /// The PKI.
    pub fn pki(&self) -> &Pki {
        &self.pki
    }

    /// The vehicles an epoch has a pseudonym for.
    pub fn vehicles(&self) -> usize {
        self.vehicles
    }

    /// The epochs drawn so far (at least one).
    pub fn epochs(&self) -> usize {
        self.epochs.len()
    }

    /// The pseudonyms of the next epoch, drawn now (a pseudonym change).
    pub fn draw_epoch(&mut self) -> &[Credential] {
        let next = (0..self.vehicles)
            .map(|_| self.pki.pseudonym(&mut self.rng, self.validity))
            .collect();
        self.epochs.push(next);
        self.epochs.last().expect("just pushed")
    }

    /// The pseudonym of `slot`, if that epoch was drawn and the vehicle exists.
    pub fn pseudonym(&self, slot: KeySlot) -> Option<&Credential> {
        self.epochs.get(slot.epoch)?.get(slot.vehicle)
    }

    /// Whose pseudonym has certificate digest `digest`, drawing further epochs until there
    /// are `max_epochs` if it is not among those drawn; `None` for a key outside the platoon.
    pub fn holder(&mut self, digest: HashedId8, max_epochs: usize) -> Option<KeySlot> {
        let mut epoch = 0;
        loop {
            if epoch == self.epochs.len() {
                if epoch >= max_epochs {
                    return None;
                }
                self.draw_epoch();
            }
            if let Some(vehicle) = self.epochs[epoch].iter().position(|c| c.digest() == digest) {
                return Some(KeySlot { epoch, vehicle });
            }
            epoch += 1;
        }
    }

    /// Whose key made `header`'s signature of `payload`: the holder of the pseudonym it names
    /// ([`Keyring::holder`]) if the signature holds under that pseudonym's key, else `None`
    /// (a forgery, a key of another PKI, or a packet altered after signing).
    pub fn signed_by(
        &mut self,
        payload: &[u8],
        header: &SecurityHeader,
        max_epochs: usize,
    ) -> Option<KeySlot> {
        let slot = self.holder(header.signer.digest(), max_epochs)?;
        let key = crate::PublicKey::of(self.pseudonym(slot)?.signing_key().verifying_key());
        let message = SecurityHeader::signed_message(payload, header.generated_ms, &header.signer);
        key.verifies(&message, &header.signature).then_some(slot)
    }

    /// `payload` signed with the pseudonym of `slot` in the form of `like` (its time; the
    /// signer's digest, or the full certificate if `like` carries one): what the holder of
    /// that key sends in place of the packet `like` sealed. `None` if `slot` was not drawn.
    pub fn sign_like(
        &self,
        slot: KeySlot,
        payload: &[u8],
        like: &SecurityHeader,
    ) -> Option<SecurityHeader> {
        let attach = matches!(like.signer, crate::SignerId::Certificate(_));
        Some(sign::sign_as(
            self.pseudonym(slot)?,
            payload,
            like.generated_ms,
            attach,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AttachRule, Signer};

    #[test]
    fn the_same_seed_draws_the_same_keys_and_platoons_their_own() {
        let mut a = Keyring::new(7, 0, 3);
        let b = Keyring::new(7, 0, 3);
        let other = Keyring::new(7, 1, 3);
        assert_eq!(a.pki().root().digest(), other.pki().root().digest());
        for v in 0..3 {
            let slot = KeySlot {
                epoch: 0,
                vehicle: v,
            };
            let digest = a.pseudonym(slot).unwrap().digest();
            assert_eq!(digest, b.pseudonym(slot).unwrap().digest());
            assert_ne!(digest, other.pseudonym(slot).unwrap().digest());
        }
        // A later epoch is found by drawing up to it, and only so far.
        let mut later = b.clone();
        later.draw_epoch();
        let third = later.draw_epoch()[1].digest();
        assert_eq!(a.holder(third, 2), None);
        assert_eq!(
            a.holder(third, 3),
            Some(KeySlot {
                epoch: 2,
                vehicle: 1
            })
        );
        assert_eq!(a.epochs(), 3);
    }

    #[test]
    fn a_signature_names_the_key_that_made_it_and_an_altered_payload_none() {
        let mut keys = Keyring::new(1, 0, 3);
        let slot = KeySlot {
            epoch: 0,
            vehicle: 2,
        };
        let mut signer = Signer::new(keys.pseudonym(slot).unwrap().clone(), AttachRule::STANDARD);
        let header = signer.sign(b"the truth", 40);
        assert_eq!(keys.signed_by(b"the truth", &header, 1), Some(slot));
        assert_eq!(keys.signed_by(b"a lie", &header, 1), None);
        // The insider signs its lie in the form its truth had: the same time and signer form.
        let lie = keys.sign_like(slot, b"a lie", &header).unwrap();
        assert_eq!(lie.generated_ms, 40);
        assert_eq!(lie.signer, header.signer);
        assert_eq!(keys.signed_by(b"a lie", &lie, 1), Some(slot));
        // A thief signs with another member's key.
        let stolen = KeySlot {
            epoch: 0,
            vehicle: 1,
        };
        let theirs = keys.sign_like(stolen, b"a lie", &header).unwrap();
        assert_eq!(keys.signed_by(b"a lie", &theirs, 1), Some(stolen));
        // A key of another seed is nobody's here.
        let mut outsider = Keyring::new(2, 0, 3);
        let foreign = outsider.sign_like(slot, b"a lie", &header).unwrap();
        assert_eq!(keys.signed_by(b"a lie", &foreign, 4), None);
        assert_eq!(outsider.signed_by(b"a lie", &foreign, 1), Some(slot));
    }

    #[test]
    fn group_keys_are_the_seeds_and_the_platoons_own_per_epoch() {
        let (a, b) = (Keyring::new(7, 0, 3), Keyring::new(7, 0, 5));
        assert_eq!(
            a.group_key(1),
            b.group_key(1),
            "the seed's, whatever the size"
        );
        assert_eq!(a.group_key(2).epoch(), 2);
        assert_ne!(a.group_key(1), a.group_key(2));
        assert_ne!(a.group_key(1), Keyring::new(7, 1, 3).group_key(1));
        assert_ne!(a.group_key(1), Keyring::new(8, 0, 3).group_key(1));
        let tag = a.group_key(1).tag(b"x");
        assert_eq!(b.group_key(1).check(b"x", &tag), Ok(()));
    }
}
