//! [`Certificate`]: a simulated PKI's certificate, its fixed encoding and its digest.

use crate::ecdsa::{self, PublicKey};
use crate::{HashedId8, Refusal};
use p256::ecdsa::{SigningKey, VerifyingKey};

/// A compressed P-256 point's size (bytes): the sign byte and x.
pub const PUBLIC_KEY_LEN: usize = 33;

/// An ECDSA P-256 signature's size (bytes): r and s, 32 bytes each, big-endian.
pub const SIGNATURE_LEN: usize = 64;

/// What a certificate's holder may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CertKind {
    /// The root CA: self-signed, signs authorities' certificates.
    Root,
    /// An authorization authority (AA): signed by the root, issues pseudonyms.
    Authority,
    /// A vehicle's pseudonym (an authorization ticket): issued by an AA, signs packets.
    Pseudonym,
}

impl CertKind {
    fn code(self) -> u8 {
        match self {
            CertKind::Root => 0,
            CertKind::Authority => 1,
            CertKind::Pseudonym => 2,
        }
    }

    fn from_code(code: u8) -> Option<CertKind> {
        match code {
            0 => Some(CertKind::Root),
            1 => Some(CertKind::Authority),
            2 => Some(CertKind::Pseudonym),
            _ => None,
        }
    }
}

/// When a certificate is valid, in the run's time (ms since its start): `from_ms <= t <
/// until_ms`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Validity {
    /// The first instant it is valid (ms).
    pub from_ms: u64,
    /// The first instant it is no longer valid (ms).
    pub until_ms: u64,
}

impl Validity {
    /// Valid from `from_ms` (inclusive) until `until_ms` (exclusive).
    pub fn new(from_ms: u64, until_ms: u64) -> Self {
        Self { from_ms, until_ms }
    }

    /// Valid at every time a run can reach.
    pub const ALWAYS: Validity = Validity {
        from_ms: 0,
        until_ms: u64::MAX,
    };

    /// Whether it is valid at `now_ms`; else the refusal ([`Refusal::NotYetValid`] or
    /// [`Refusal::Expired`]).
    pub fn check(&self, now_ms: u64) -> Result<(), Refusal> {
        if now_ms < self.from_ms {
            Err(Refusal::NotYetValid)
        } else if now_ms >= self.until_ms {
            Err(Refusal::Expired)
        } else {
            Ok(())
        }
    }
}

/// A certificate of the simulated PKI, in the spirit of IEEE 1609.2's explicit certificates
/// (no identity: a pseudonym names nobody). Its encoding is fixed, [`Certificate::LEN`] bytes:
///
/// ```text
/// kind (1) | issuer HashedId8 (8) | subject key, compressed P-256 (33)
///          | valid from, ms (8, big-endian) | valid until, ms (8, big-endian) | signature (64)
/// ```
///
/// The issuer signs (ECDSA P-256, SHA-256, RFC 6979) every byte before the signature; a root
/// signs its own with issuer [`HashedId8::SELF`]. Its [digest](Certificate::digest) covers
/// the whole encoding, signature included.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Certificate {
    /// What its holder may do.
    pub kind: CertKind,
    /// The issuer's certificate digest ([`HashedId8::SELF`] for a root).
    pub issuer: HashedId8,
    /// The holder's public key, a compressed SEC1 P-256 point.
    pub subject_key: [u8; PUBLIC_KEY_LEN],
    /// When it is valid.
    pub validity: Validity,
    /// The issuer's signature over the encoding's first [`Certificate::SIGNED_LEN`] bytes.
    pub signature: [u8; SIGNATURE_LEN],
}

impl Certificate {
    /// Its size on the wire (bytes).
    pub const LEN: usize = Self::SIGNED_LEN + SIGNATURE_LEN;

    /// How many of its bytes the issuer signs: all before the signature.
    pub const SIGNED_LEN: usize = 1 + HashedId8::LEN + PUBLIC_KEY_LEN + 8 + 8;

    /// A certificate for `subject` of `kind`, signed by `issuer_key` (whose certificate's
    /// digest is `issuer`).
    pub(crate) fn signed(
        kind: CertKind,
        issuer: HashedId8,
        subject: &VerifyingKey,
        validity: Validity,
        issuer_key: &SigningKey,
    ) -> Certificate {
        let fields = Certificate {
            kind,
            issuer,
            subject_key: ecdsa::compressed(subject),
            validity,
            signature: [0; SIGNATURE_LEN],
        };
        Certificate::sign_fields(&fields, issuer, issuer_key)
    }

    /// `fields` with `issuer` as issuer and `issuer_key`'s signature.
    pub(crate) fn sign_fields(
        fields: &Certificate,
        issuer: HashedId8,
        issuer_key: &SigningKey,
    ) -> Certificate {
        let mut cert = Certificate { issuer, ..*fields };
        cert.signature = ecdsa::sign(issuer_key, &cert.signed_part());
        cert
    }

    /// The bytes its issuer signs.
    pub fn signed_part(&self) -> [u8; Self::SIGNED_LEN] {
        let mut out = [0; Self::SIGNED_LEN];
        out[0] = self.kind.code();
        out[1..9].copy_from_slice(&self.issuer.0);
        out[9..42].copy_from_slice(&self.subject_key);
        out[42..50].copy_from_slice(&self.validity.from_ms.to_be_bytes());
        out[50..58].copy_from_slice(&self.validity.until_ms.to_be_bytes());
        out
    }

    /// Its encoding, [`Certificate::LEN`] bytes.
    pub fn encode(&self) -> [u8; Self::LEN] {
        let mut out = [0; Self::LEN];
        out[..Self::SIGNED_LEN].copy_from_slice(&self.signed_part());
        out[Self::SIGNED_LEN..].copy_from_slice(&self.signature);
        out
    }

    /// The certificate `bytes` encode, exactly [`Certificate::LEN`] of them:
    /// [`Refusal::Truncated`] if fewer, [`Refusal::Malformed`] if more or of an unknown kind.
    /// Only the syntax is checked (the key and signature are the verifier's); never panics.
    pub fn decode(bytes: &[u8]) -> Result<Certificate, Refusal> {
        let bytes: &[u8; Self::LEN] = match bytes.len() {
            n if n < Self::LEN => return Err(Refusal::Truncated),
            n if n > Self::LEN => return Err(Refusal::Malformed),
            _ => bytes.try_into().map_err(|_| Refusal::Malformed)?,
        };
        let kind = CertKind::from_code(bytes[0]).ok_or(Refusal::Malformed)?;
        let (mut issuer, mut subject_key, mut signature) = ([0; 8], [0; 33], [0; 64]);
        issuer.copy_from_slice(&bytes[1..9]);
        subject_key.copy_from_slice(&bytes[9..42]);
        signature.copy_from_slice(&bytes[58..]);
        let word = |at: usize| {
            let mut w = [0; 8];
            w.copy_from_slice(&bytes[at..at + 8]);
            u64::from_be_bytes(w)
        };
        Ok(Certificate {
            kind,
            issuer: HashedId8(issuer),
            subject_key,
            validity: Validity::new(word(42), word(50)),
            signature,
        })
    }

    /// Its digest: the last 8 bytes of SHA-256 over [`Certificate::encode`].
    pub fn digest(&self) -> HashedId8 {
        HashedId8::of(&self.encode())
    }

    /// The holder's public key; [`Refusal::Malformed`] if the bytes are no P-256 point.
    pub fn public_key(&self) -> Result<PublicKey, Refusal> {
        PublicKey::from_compressed(&self.subject_key)
    }

    /// Whether `issuer` signed it; else [`Refusal::BadCertificateSignature`].
    pub fn check_signed_by(&self, issuer: &PublicKey) -> Result<(), Refusal> {
        self.check_signed_through(None, issuer)
    }

    /// [`Certificate::check_signed_by`] through `memo` if there is one.
    pub(crate) fn check_signed_through(
        &self,
        memo: Option<&mut ecdsa::SignatureMemo>,
        issuer: &PublicKey,
    ) -> Result<(), Refusal> {
        if ecdsa::verifies(memo, issuer, &self.signed_part(), &self.signature) {
            Ok(())
        } else {
            Err(Refusal::BadCertificateSignature)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_encoding_is_122_bytes() {
        assert_eq!(Certificate::SIGNED_LEN, 58);
        assert_eq!(Certificate::LEN, 122);
    }

    #[test]
    fn validity_is_half_open() {
        let v = Validity::new(10, 20);
        assert_eq!(v.check(9), Err(Refusal::NotYetValid));
        assert_eq!(v.check(10), Ok(()));
        assert_eq!(v.check(19), Ok(()));
        assert_eq!(v.check(20), Err(Refusal::Expired));
    }

    #[test]
    fn decode_refuses_short_long_and_unknown_kinds() {
        let mut bytes = [0u8; Certificate::LEN];
        assert!(Certificate::decode(&bytes).is_ok());
        assert_eq!(Certificate::decode(&bytes[..121]), Err(Refusal::Truncated));
        assert_eq!(Certificate::decode(&[0; 123]), Err(Refusal::Malformed));
        bytes[0] = 3;
        assert_eq!(Certificate::decode(&bytes), Err(Refusal::Malformed));
    }
}
