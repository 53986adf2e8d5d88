//! [`SecurityHeader`]: what a signed packet carries besides its payload, its byte encoding,
//! and what it adds on the wire here and in the standards.

use crate::cert::SIGNATURE_LEN;
use crate::{Certificate, HashedId8, Refusal};

/// The header format's version, its first byte.
pub const VERSION: u8 = 1;

/// What [`SecurityHeader`] adds to a packet signed with a digest, in this crate's encoding
/// (bytes): version, signer kind, generation time, the digest, the signature.
pub const DIGEST_HEADER_LEN: usize = 2 + 8 + HashedId8::LEN + SIGNATURE_LEN;

/// What [`SecurityHeader`] adds to a packet that carries its signer's full certificate, in
/// this crate's encoding (bytes).
pub const CERTIFICATE_HEADER_LEN: usize = 2 + 8 + Certificate::LEN + SIGNATURE_LEN;

/// What IEEE 1609.2 / ETSI TS 103 097 add around a payload signed with a digest (bytes), for
/// a radio model's packet size. Counted from the standard's ASN.1 in its COER encoding, for a
/// CAM-sized payload (128 to 255 bytes): the outer `Ieee1609Dot2Data` (version, content
/// choice: 2), `SignedData`'s hash algorithm (1), the payload's own `Ieee1609Dot2Data`
/// wrapper (preamble, version, choice, 2-byte length: 5), `HeaderInfo` (preamble 1, PSID 2,
/// `generationTime` 8), the signer choice and `HashedId8` (9), and the signature (choice,
/// x-only r as a curve point choice and 32 bytes, s 32 bytes: 66). Our own count, not a
/// measurement of a reference encoder: the literature's figures for a signed CAM are close
/// to it (about 90 to 100 bytes).
pub const STANDARD_DIGEST_OVERHEAD: usize = 94;

/// What IEEE 1609.2 / ETSI TS 103 097 add around a payload that carries its signer's
/// certificate (bytes): [`STANDARD_DIGEST_OVERHEAD`] less the digest (8), plus the
/// certificate sequence's length (2) and an authorization ticket. The ticket's size depends
/// on its permissions and region; 131 bytes is an ETSI authorization ticket with one
/// application permission, a compressed key and no region, within the 120 to 150 bytes
/// deployments report. An estimate, not a measurement.
pub const STANDARD_CERTIFICATE_OVERHEAD: usize = STANDARD_DIGEST_OVERHEAD - 8 + 2 + 131;

/// Who signed: a digest of the signer's certificate, or the certificate itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignerId {
    /// The signer's certificate digest: the receiver must know the certificate already.
    Digest(HashedId8),
    /// The signer's full certificate: a receiver learns it (once it chains to its root).
    Certificate(Certificate),
}

impl SignerId {
    /// The signer's certificate digest, whichever form the header carries.
    pub fn digest(&self) -> HashedId8 {
        match self {
            SignerId::Digest(d) => *d,
            SignerId::Certificate(c) => c.digest(),
        }
    }

    fn code(&self) -> u8 {
        match self {
            SignerId::Digest(_) => 0,
            SignerId::Certificate(_) => 1,
        }
    }
}

/// The security header of a signed V2V packet, after the payload on the wire:
///
/// ```text
/// version (1) | signer kind (1: 0 digest, 1 certificate) | generation time, ms (8, big-endian)
///             | digest (8) or certificate (122) | ECDSA P-256 signature r || s (64)
/// ```
///
/// The signature is over SHA-256 of the payload followed by the header's fields before it,
/// with the signer's digest in place of a certificate (the digest commits to the certificate):
/// `payload || version || kind || generation time || digest`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SecurityHeader {
    /// When the sender signed (ms of the run's time).
    pub generated_ms: u64,
    /// Who signed.
    pub signer: SignerId,
    /// The signature, r || s, big-endian.
    pub signature: [u8; SIGNATURE_LEN],
}

impl SecurityHeader {
    /// Its encoded size: [`DIGEST_HEADER_LEN`] or [`CERTIFICATE_HEADER_LEN`].
    pub fn encoded_len(&self) -> usize {
        match self.signer {
            SignerId::Digest(_) => DIGEST_HEADER_LEN,
            SignerId::Certificate(_) => CERTIFICATE_HEADER_LEN,
        }
    }

    /// Appends its encoding to `out`.
    pub fn encode(&self, out: &mut Vec<u8>) {
        out.push(VERSION);
        out.push(self.signer.code());
        out.extend_from_slice(&self.generated_ms.to_be_bytes());
        match &self.signer {
            SignerId::Digest(d) => out.extend_from_slice(&d.0),
            SignerId::Certificate(c) => out.extend_from_slice(&c.encode()),
        }
        out.extend_from_slice(&self.signature);
    }

    /// Its encoding.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.encoded_len());
        self.encode(&mut out);
        out
    }

    /// The header `bytes` encode, all of them: [`Refusal::Truncated`] if they end early
    /// (an empty header, a signature cut short), [`Refusal::Malformed`] for an unknown
    /// version, signer kind or certificate kind, or bytes after the signature. Never panics.
    pub fn decode(bytes: &[u8]) -> Result<SecurityHeader, Refusal> {
        let (&version, rest) = bytes.split_first().ok_or(Refusal::Truncated)?;
        if version != VERSION {
            return Err(Refusal::Malformed);
        }
        let (&kind, rest) = rest.split_first().ok_or(Refusal::Truncated)?;
        let signer_len = match kind {
            0 => HashedId8::LEN,
            1 => Certificate::LEN,
            _ => return Err(Refusal::Malformed),
        };
        let expected = 8 + signer_len + SIGNATURE_LEN;
        if rest.len() < expected {
            return Err(Refusal::Truncated);
        }
        if rest.len() > expected {
            return Err(Refusal::Malformed);
        }
        let (time, rest) = rest.split_at(8);
        let (signer, signature) = rest.split_at(signer_len);
        let mut word = [0; 8];
        word.copy_from_slice(time);
        let signer = if kind == 0 {
            let mut d = [0; HashedId8::LEN];
            d.copy_from_slice(signer);
            SignerId::Digest(HashedId8(d))
        } else {
            SignerId::Certificate(Certificate::decode(signer)?)
        };
        let mut sig = [0; SIGNATURE_LEN];
        sig.copy_from_slice(signature);
        Ok(SecurityHeader {
            generated_ms: u64::from_be_bytes(word),
            signer,
            signature: sig,
        })
    }

    /// The bytes the signature covers (it is over their SHA-256), for `payload` under a
    /// header with these fields.
    pub fn signed_message(payload: &[u8], generated_ms: u64, signer: &SignerId) -> Vec<u8> {
        let mut m = Vec::with_capacity(payload.len() + 2 + 8 + HashedId8::LEN);
        m.extend_from_slice(payload);
        m.extend_from_slice(&[VERSION, signer.code()]);
        m.extend_from_slice(&generated_ms.to_be_bytes());
        m.extend_from_slice(&signer.digest().0);
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sizes_are_what_the_docs_say() {
        assert_eq!(DIGEST_HEADER_LEN, 82);
        assert_eq!(CERTIFICATE_HEADER_LEN, 196);
        assert_eq!(STANDARD_DIGEST_OVERHEAD, 2 + 1 + 5 + (1 + 2 + 8) + 9 + 66);
        assert_eq!(STANDARD_CERTIFICATE_OVERHEAD, 219);
    }

    #[test]
    fn unknown_versions_and_kinds_are_malformed_and_short_ones_truncated() {
        assert_eq!(SecurityHeader::decode(&[]), Err(Refusal::Truncated));
        assert_eq!(SecurityHeader::decode(&[VERSION]), Err(Refusal::Truncated));
        assert_eq!(SecurityHeader::decode(&[2, 0]), Err(Refusal::Malformed));
        assert_eq!(
            SecurityHeader::decode(&[VERSION, 2]),
            Err(Refusal::Malformed)
        );
        let mut digest = vec![0u8; DIGEST_HEADER_LEN];
        digest[0] = VERSION;
        assert!(SecurityHeader::decode(&digest).is_ok());
        assert_eq!(
            SecurityHeader::decode(&digest[..DIGEST_HEADER_LEN - 1]),
            Err(Refusal::Truncated)
        );
        digest.push(0);
        assert_eq!(SecurityHeader::decode(&digest), Err(Refusal::Malformed));
    }

    use proptest::prelude::*;

    /// Random bytes, or bytes shaped like a header (the version, a signer kind of 0 to 2, a
    /// length near a real header's) so that decoding goes past its first checks.
    fn header_like() -> impl Strategy<Value = Vec<u8>> {
        let shaped = (0u8..3, 0usize..CERTIFICATE_HEADER_LEN + 4, any::<u8>()).prop_flat_map(
            |(kind, len, cert_kind)| {
                proptest::collection::vec(any::<u8>(), len).prop_map(move |mut b| {
                    if let Some(v) = b.get_mut(0) {
                        *v = VERSION;
                    }
                    if let Some(k) = b.get_mut(1) {
                        *k = kind;
                    }
                    if let Some(c) = b.get_mut(10) {
                        *c = cert_kind % 4;
                    }
                    b
                })
            },
        );
        prop_oneof![proptest::collection::vec(any::<u8>(), 0..256), shaped]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2048, failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn decoding_any_bytes_never_panics_and_what_decodes_encodes_back(bytes in header_like()) {
            match SecurityHeader::decode(&bytes) {
                Ok(h) => {
                    prop_assert_eq!(h.encoded_len(), bytes.len());
                    prop_assert_eq!(h.to_bytes(), bytes);
                }
                Err(r) => {
                    prop_assert!(matches!(r, Refusal::Truncated | Refusal::Malformed), "{:?}", r);
                    // Bytes of this version and a known signer kind that end before a
                    // whole header are truncated, whatever they hold.
                    let whole = match (bytes.first(), bytes.get(1)) {
                        (None, _) | (Some(&VERSION), None) => usize::MAX,
                        (Some(&VERSION), Some(0)) => DIGEST_HEADER_LEN,
                        (Some(&VERSION), Some(1)) => CERTIFICATE_HEADER_LEN,
                        _ => 0,
                    };
                    if bytes.len() < whole {
                        prop_assert_eq!(r, Refusal::Truncated);
                    }
                }
            }
        }

        #[test]
        fn decoding_any_certificate_bytes_never_panics(
            bytes in proptest::collection::vec(any::<u8>(), 0..2 * Certificate::LEN),
        ) {
            if let Ok(c) = Certificate::decode(&bytes) {
                let encoded = c.encode();
                prop_assert_eq!(encoded.as_slice(), bytes.as_slice());
                // A key that is no point is refused as malformed, never a panic.
                let _ = c.public_key();
            }
        }
    }
}
