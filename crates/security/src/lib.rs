//! Signed V2V for the pure core (issue 52, part 1): a simulated PKI, pseudonym certificates,
//! ECDSA P-256 security headers, and their verification with a reason for every refusal.
//!
//! - [`pki`]: a root CA, an authorization authority (AA) the root certifies and the vehicles'
//!   pseudonyms the AA issues ([`Pki`], [`Credential`]), every key from a seeded RNG the
//!   caller passes in.
//! - [`cert`]: the [`Certificate`] (kind, issuer digest, compressed P-256 key, validity, the
//!   issuer's signature; 122 bytes) and its [`HashedId8`] digest ([`id`]).
//! - [`header`]: the [`SecurityHeader`] a signed packet carries (generation time, the signer's
//!   digest or full certificate, the signature over SHA-256 of payload and header), its byte
//!   encoding and decoding (never panics), and what it adds on the wire here
//!   ([`DIGEST_HEADER_LEN`] 82 bytes, [`CERTIFICATE_HEADER_LEN`] 196) and in IEEE 1609.2 /
//!   ETSI TS 103 097 ([`STANDARD_DIGEST_OVERHEAD`] 94, [`STANDARD_CERTIFICATE_OVERHEAD`] 219).
//! - [`ecdsa`]: ECDSA P-256 over SHA-256: signing with RustCrypto's `p256` (RFC 6979,
//!   deterministic), verifying with `ring` (about five times faster here); a [`SignatureMemo`]
//!   that lets the receivers of one broadcast share its signature check.
//! - [`sign`]: a vehicle's [`Signer`], its pseudonym changes and the standards' rule for when
//!   the full certificate rides along ([`AttachRule`]: once a second, after a change, on
//!   request).
//! - [`keyring`]: a platoon's keys in a run, all from its seed ([`Keyring`]): what the
//!   vehicles sign with, and what insiders, thieves, the misbehaviour authority and the
//!   ground truth derive to sign as a vehicle or to tell whose key signed a packet.
//! - [`group`]: a platoon's group key, agreed with each member at its join (ECDH P-256, then
//!   HKDF-SHA256; the key wrapped with ChaCha20-Poly1305), HMAC tags on intra-platoon
//!   messages, renewed on every leave ([`KeyServer`], [`KeyHolder`]).
//! - [`misbehaviour`]: misbehaviour reports (signed, the accused's signed packets as
//!   evidence), the reporters' [`Uplink`] and the misbehaviour [`Authority`], which revokes a
//!   vehicle reported by a quorum of other vehicles ([`AuthorityRule`]).
//! - [`verify`]: a receiver's [`Verifier`] (trust store, revocation list, learned pseudonyms)
//!   and its [`Policy`] (every packet, or on demand); a refusal is a [`Refusal`] with a stable
//!   name and code for a dataset.
//!
//! Pure: no I/O, no clocks (times are the run's, in ms, passed in), no threads, no global RNG.
//! Signatures are RFC 6979 deterministic, so a run signs the same bytes at the same seed.
//!
//! Cost (`cargo bench -p platoon-security`, criterion's medians on the project's 2-core VM,
//! shared with other builds; an 80-byte payload, the size of `platoon_wire::V2vPacket`): see
//! the crate's README.md.
#![warn(missing_docs)]

pub mod cert;
pub mod ecdsa;
pub mod group;
pub mod header;
pub mod id;
pub mod keyring;
pub mod misbehaviour;
pub mod pki;
pub mod refusal;
pub mod sign;
pub mod verify;

pub use cert::{CertKind, Certificate, Validity};
pub use ecdsa::{PublicKey, SignatureMemo};
pub use group::{
    GroupError, GroupField, GroupKey, KeyHolder, KeyServer, KeyShare, Tag, WrappedKey,
    GROUP_FIELD_LEN,
};
pub use header::{
    SecurityHeader, SignerId, CERTIFICATE_HEADER_LEN, DIGEST_HEADER_LEN,
    STANDARD_CERTIFICATE_OVERHEAD, STANDARD_DIGEST_OVERHEAD,
};
pub use id::HashedId8;
pub use keyring::{KeySlot, Keyring};
pub use misbehaviour::{
    Authority, AuthorityRule, Evidence, RadarObservation, Report, ReportOutcome, Revocation,
    SignedReport, Uplink, VehicleKey,
};
pub use pki::{Credential, Pki};
pub use refusal::Refusal;
pub use sign::{AttachRule, Signer};
pub use verify::{Accepted, Policy, SignatureCheck, Verifier, VerifierConfig};
