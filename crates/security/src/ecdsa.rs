//! ECDSA P-256 over SHA-256, the one signature scheme of the crate: signing with RustCrypto's
//! `p256` (RFC 6979 deterministic nonces: the same key and message give the same signature,
//! so a seeded run is reproducible bit for bit), verifying with `ring` (assembly, about five
//! times faster here: the cost every receiver pays for every packet). Both are standard ECDSA:
//! a signature one makes, the other verifies (tested against `p256`'s own verifier).

use crate::cert::{PUBLIC_KEY_LEN, SIGNATURE_LEN};
use crate::Refusal;
use p256::ecdsa::signature::Signer as _;
use p256::ecdsa::{Signature, SigningKey, VerifyingKey};
use ring::signature::{UnparsedPublicKey, ECDSA_P256_SHA256_FIXED};
use sha2::{Digest, Sha256};
use std::collections::HashMap;

/// An uncompressed SEC1 point's size (bytes): 0x04, x, y.
const UNCOMPRESSED_LEN: usize = 65;

/// A P-256 public key ready to verify: the point uncompressed, as `ring` takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PublicKey([u8; UNCOMPRESSED_LEN]);

impl PublicKey {
    /// The key `bytes` (a compressed SEC1 point) encode; [`Refusal::Malformed`] if they are
    /// no point of the curve.
    pub fn from_compressed(bytes: &[u8; PUBLIC_KEY_LEN]) -> Result<Self, Refusal> {
        let key = VerifyingKey::from_sec1_bytes(bytes).map_err(|_| Refusal::Malformed)?;
        Ok(Self::of(&key))
    }

    /// The public half of a key at hand.
    pub(crate) fn of(key: &VerifyingKey) -> Self {
        let mut out = [0; UNCOMPRESSED_LEN];
        out.copy_from_slice(key.to_encoded_point(false).as_bytes());
        Self(out)
    }

    /// Whether `signature` (r || s) is this key's over SHA-256 of `message`.
    pub fn verifies(&self, message: &[u8], signature: &[u8; SIGNATURE_LEN]) -> bool {
        UnparsedPublicKey::new(&ECDSA_P256_SHA256_FIXED, &self.0)
            .verify(message, signature)
            .is_ok()
    }
}

/// Signature checks already made, shared by receivers that verify the same bytes: in a
/// simulation every receiver of a broadcast verifies the same signature over the same message
/// with the same key, and the outcome is a pure function of the three, so it is computed once.
/// Each receiver still makes its own trust checks (its store, validity, revocation,
/// freshness); only the ECDSA arithmetic is shared ([`crate::Verifier::check_shared`]). The
/// caller bounds its size ([`SignatureMemo::clear`], say every step).
#[derive(Debug, Clone, Default)]
pub struct SignatureMemo {
    outcomes: HashMap<[u8; 32], bool>,
}

impl SignatureMemo {
    /// An empty memo.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets every outcome.
    pub fn clear(&mut self) {
        self.outcomes.clear();
    }

    /// How many outcomes it holds.
    pub fn len(&self) -> usize {
        self.outcomes.len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.outcomes.is_empty()
    }

    /// [`PublicKey::verifies`], made once per key, message and signature (keyed by SHA-256
    /// over the three).
    pub fn verifies(
        &mut self,
        key: &PublicKey,
        message: &[u8],
        signature: &[u8; SIGNATURE_LEN],
    ) -> bool {
        let mut id = Sha256::new();
        id.update(key.0);
        id.update(signature);
        id.update(message);
        *self
            .outcomes
            .entry(id.finalize().into())
            .or_insert_with(|| key.verifies(message, signature))
    }
}

/// `key.verifies(message, signature)`, through `memo` if there is one.
pub(crate) fn verifies(
    memo: Option<&mut SignatureMemo>,
    key: &PublicKey,
    message: &[u8],
    signature: &[u8; SIGNATURE_LEN],
) -> bool {
    match memo {
        Some(memo) => memo.verifies(key, message, signature),
        None => key.verifies(message, signature),
    }
}

/// `key`'s signature (r || s) over SHA-256 of `message`, RFC 6979 deterministic.
pub(crate) fn sign(key: &SigningKey, message: &[u8]) -> [u8; SIGNATURE_LEN] {
    let signature: Signature = key.sign(message);
    let mut out = [0; SIGNATURE_LEN];
    out.copy_from_slice(&signature.to_bytes());
    out
}

/// The compressed SEC1 encoding of `key`.
pub(crate) fn compressed(key: &VerifyingKey) -> [u8; PUBLIC_KEY_LEN] {
    let mut out = [0; PUBLIC_KEY_LEN];
    out.copy_from_slice(key.to_encoded_point(true).as_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use p256::ecdsa::signature::Verifier as _;
    use proptest::prelude::*;
    use rand::SeedableRng;

    fn key(seed: u64) -> SigningKey {
        SigningKey::random(&mut rand_chacha::ChaCha20Rng::seed_from_u64(seed))
    }

    /// What `p256`'s own verifier says of the same signature.
    fn p256_verifies(key: &VerifyingKey, message: &[u8], signature: &[u8; 64]) -> bool {
        Signature::from_slice(signature).is_ok_and(|s| key.verify(message, &s).is_ok())
    }

    #[test]
    fn signing_is_deterministic() {
        let k = key(1);
        assert_eq!(sign(&k, b"platoon"), sign(&k, b"platoon"));
        assert_ne!(sign(&k, b"platoon"), sign(&k, b"platoons"));
    }

    #[test]
    fn compressed_keys_decompress_and_bad_points_are_malformed() {
        let k = key(2);
        let public = PublicKey::from_compressed(&compressed(k.verifying_key())).unwrap();
        assert_eq!(public, PublicKey::of(k.verifying_key()));
        assert_eq!(
            PublicKey::from_compressed(&[0xff; 33]),
            Err(Refusal::Malformed)
        );
        assert_eq!(
            PublicKey::from_compressed(&[0; 33]),
            Err(Refusal::Malformed)
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

        /// ring and p256 agree on every signature, genuine or altered, so signing with one
        /// and verifying with the other is sound.
        #[test]
        fn ring_and_p256_agree(
            seed in 0u64..4,
            message in proptest::collection::vec(any::<u8>(), 0..200),
            flip in proptest::option::of(0usize..64 * 8),
        ) {
            let k = key(seed);
            let mut signature = sign(&k, &message);
            if let Some(bit) = flip {
                signature[bit / 8] ^= 1 << (bit % 8);
            }
            let ring = PublicKey::of(k.verifying_key()).verifies(&message, &signature);
            prop_assert_eq!(ring, p256_verifies(k.verifying_key(), &message, &signature));
            prop_assert_eq!(ring, flip.is_none());
        }
    }
}
