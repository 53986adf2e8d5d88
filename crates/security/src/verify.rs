//! The receiver's side: [`Verifier`] holds the trust store (the root, the authorities'
//! certificates, the pseudonyms seen in full, the revoked digests) and accepts a packet or
//! says why not ([`Refusal`]).

use crate::ecdsa::{self, PublicKey, SignatureMemo};
use crate::{CertKind, Certificate, Credential, HashedId8, Refusal, SecurityHeader, SignerId};
use std::collections::{BTreeMap, BTreeSet};

/// A verifier's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VerifierConfig {
    /// The largest difference between a packet's generation time and the receiver's time it
    /// accepts (ms); further is [`Refusal::Stale`].
    pub freshness_ms: u64,
}

impl Default for VerifierConfig {
    /// A second, the certificate period of the standards' attach rule.
    fn default() -> Self {
        VerifierConfig { freshness_ms: 1000 }
    }
}

/// Which packets have their signature verified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Policy {
    /// Every packet: the signature is verified before the packet is accepted.
    Every,
    /// Verify on demand: every check but the packet's signature (the header's syntax, the
    /// signer's certificate, its chain when it is new, validity, revocation, freshness); the
    /// caller verifies the signature ([`Verifier::verify_signature`]) when it acts on the
    /// packet. A certificate seen in full is always verified before it is learned.
    OnDemand,
}

/// Whether an accepted packet's signature was verified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignatureCheck {
    /// It was, and holds.
    Verified,
    /// It was not ([`Policy::OnDemand`]).
    Deferred,
}

/// What the verifier says of a packet it accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Accepted {
    /// The signer's certificate digest.
    pub signer: HashedId8,
    /// Whether this packet taught the verifier the signer's certificate.
    pub learned: bool,
    /// Whether its signature was verified.
    pub signature: SignatureCheck,
}

#[derive(Debug, Clone, Copy)]
struct Known {
    cert: Certificate,
    key: PublicKey,
}

/// A receiver's trust store and checks. Pure: the time is the caller's (`now_ms`, the run's
/// time), and two verifiers fed the same packets in the same order agree.
#[derive(Debug, Clone)]
pub struct Verifier {
    config: VerifierConfig,
    root_digest: HashedId8,
    root: Known,
    authorities: BTreeMap<HashedId8, Known>,
    pseudonyms: BTreeMap<HashedId8, Known>,
    revoked: BTreeSet<HashedId8>,
}

impl Verifier {
    /// A verifier that trusts `root`, which must be a self-signed root certificate
    /// ([`Refusal::WrongKind`], [`Refusal::Malformed`], [`Refusal::BadCertificateSignature`]
    /// otherwise). It holds no authority yet ([`Verifier::add_authority`]).
    pub fn new(root: &Certificate, config: VerifierConfig) -> Result<Verifier, Refusal> {
        if root.kind != CertKind::Root || root.issuer != HashedId8::SELF {
            return Err(Refusal::WrongKind);
        }
        let key = root.public_key()?;
        root.check_signed_by(&key)?;
        Ok(Verifier::with_root(Known { cert: *root, key }, config))
    }

    /// A verifier that trusts `root` and holds `authority`'s certificate, both the caller's
    /// own (no check: their keys are at hand).
    pub(crate) fn trusting(
        root: &Credential,
        authority: &Credential,
        config: VerifierConfig,
    ) -> Verifier {
        let known = |c: &Credential| Known {
            cert: *c.certificate(),
            key: PublicKey::of(c.signing_key().verifying_key()),
        };
        let mut verifier = Verifier::with_root(known(root), config);
        verifier
            .authorities
            .insert(authority.digest(), known(authority));
        verifier
    }

    fn with_root(root: Known, config: VerifierConfig) -> Verifier {
        Verifier {
            config,
            root_digest: root.cert.digest(),
            root,
            authorities: BTreeMap::new(),
            pseudonyms: BTreeMap::new(),
            revoked: BTreeSet::new(),
        }
    }

    /// Holds `cert`, an authorization authority's certificate, once it is one
    /// ([`Refusal::WrongKind`]) that the root signed ([`Refusal::ForeignRoot`] for another
    /// issuer, [`Refusal::BadCertificateSignature`]); returns its digest.
    pub fn add_authority(&mut self, cert: &Certificate) -> Result<HashedId8, Refusal> {
        if cert.issuer != self.root_digest {
            return Err(Refusal::ForeignRoot);
        }
        if cert.kind != CertKind::Authority {
            return Err(Refusal::WrongKind);
        }
        cert.check_signed_by(&self.root.key)?;
        let key = cert.public_key()?;
        let digest = cert.digest();
        self.authorities.insert(digest, Known { cert: *cert, key });
        Ok(digest)
    }

    /// Puts `digest` (a pseudonym's, or an authority's: then every pseudonym it issued) on the
    /// revocation list.
    pub fn revoke(&mut self, digest: HashedId8) {
        self.revoked.insert(digest);
    }

    /// Whether `digest` is on the revocation list.
    pub fn is_revoked(&self, digest: HashedId8) -> bool {
        self.revoked.contains(&digest)
    }

    /// Whether it has learned the pseudonym certificate with this digest.
    pub fn knows(&self, digest: HashedId8) -> bool {
        self.pseudonyms.contains_key(&digest)
    }

    /// How many pseudonym certificates it holds.
    pub fn known_pseudonyms(&self) -> usize {
        self.pseudonyms.len()
    }

    /// Forgets the pseudonym certificates expired at `now_ms`.
    pub fn prune(&mut self, now_ms: u64) {
        self.pseudonyms
            .retain(|_, k| now_ms < k.cert.validity.until_ms);
    }

    /// Checks a packet's `payload` and the header its sender attached, received at `now_ms`,
    /// by `policy`. A certificate in the header that chains to the root is learned (even if
    /// the packet's own signature then fails: the certificate is genuine).
    pub fn check(
        &mut self,
        payload: &[u8],
        header: &SecurityHeader,
        now_ms: u64,
        policy: Policy,
    ) -> Result<Accepted, Refusal> {
        self.check_through(None, payload, header, now_ms, policy)
    }

    /// [`Verifier::check`] with the signature checks (the packet's, a new certificate's) made
    /// through `memo`, which other receivers of the same packets share: the same outcome,
    /// computed once for all of them.
    pub fn check_shared(
        &mut self,
        memo: &mut SignatureMemo,
        payload: &[u8],
        header: &SecurityHeader,
        now_ms: u64,
        policy: Policy,
    ) -> Result<Accepted, Refusal> {
        self.check_through(Some(memo), payload, header, now_ms, policy)
    }

    fn check_through(
        &mut self,
        mut memo: Option<&mut SignatureMemo>,
        payload: &[u8],
        header: &SecurityHeader,
        now_ms: u64,
        policy: Policy,
    ) -> Result<Accepted, Refusal> {
        let signer = header.signer.digest();
        if self.revoked.contains(&signer) {
            return Err(Refusal::Revoked);
        }
        let learned = match &header.signer {
            SignerId::Certificate(cert) if !self.pseudonyms.contains_key(&signer) => {
                let key = self.chain(memo.as_deref_mut(), cert, now_ms)?;
                self.pseudonyms.insert(signer, Known { cert: *cert, key });
                true
            }
            _ => false,
        };
        let known = *self
            .pseudonyms
            .get(&signer)
            .ok_or(Refusal::UnknownCertificate)?;
        self.check_current(&known.cert, now_ms)?;
        if now_ms.abs_diff(header.generated_ms) > self.config.freshness_ms {
            return Err(Refusal::Stale);
        }
        let signature = match policy {
            Policy::Every => {
                verify_packet(memo, &known.key, payload, header)?;
                SignatureCheck::Verified
            }
            Policy::OnDemand => SignatureCheck::Deferred,
        };
        Ok(Accepted {
            signer,
            learned,
            signature,
        })
    }

    /// [`Verifier::check`] of a header still in bytes: decoding refusals first
    /// ([`Refusal::Truncated`], [`Refusal::Malformed`]). Never panics.
    pub fn check_bytes(
        &mut self,
        payload: &[u8],
        header: &[u8],
        now_ms: u64,
        policy: Policy,
    ) -> Result<Accepted, Refusal> {
        let header = SecurityHeader::decode(header)?;
        self.check(payload, &header, now_ms, policy)
    }

    /// Verifies the signature of a packet [`Verifier::check`] accepted with
    /// [`SignatureCheck::Deferred`] ([`Refusal::UnknownCertificate`] if it never did).
    pub fn verify_signature(&self, payload: &[u8], header: &SecurityHeader) -> Result<(), Refusal> {
        let known = self
            .pseudonyms
            .get(&header.signer.digest())
            .ok_or(Refusal::UnknownCertificate)?;
        verify_packet(None, &known.key, payload, header)
    }

    /// The key of `cert`, a pseudonym seen in full, once it chains to the root and is valid.
    fn chain(
        &self,
        memo: Option<&mut SignatureMemo>,
        cert: &Certificate,
        now_ms: u64,
    ) -> Result<PublicKey, Refusal> {
        if cert.kind != CertKind::Pseudonym || cert.issuer == self.root_digest {
            return Err(Refusal::WrongKind);
        }
        let issuer = self
            .authorities
            .get(&cert.issuer)
            .ok_or(Refusal::ForeignRoot)?;
        if self.revoked.contains(&cert.issuer) {
            return Err(Refusal::Revoked);
        }
        cert.check_signed_through(memo, &issuer.key)?;
        let key = cert.public_key()?;
        self.check_current(cert, now_ms)?;
        Ok(key)
    }

    /// Whether a learned pseudonym's certificate and its chain are valid at `now_ms` and its
    /// issuer not revoked.
    fn check_current(&self, cert: &Certificate, now_ms: u64) -> Result<(), Refusal> {
        if self.revoked.contains(&cert.issuer) {
            return Err(Refusal::Revoked);
        }
        let issuer = self
            .authorities
            .get(&cert.issuer)
            .ok_or(Refusal::ForeignRoot)?;
        cert.validity.check(now_ms)?;
        issuer.cert.validity.check(now_ms)?;
        self.root.cert.validity.check(now_ms)
    }
}

fn verify_packet(
    memo: Option<&mut SignatureMemo>,
    key: &PublicKey,
    payload: &[u8],
    header: &SecurityHeader,
) -> Result<(), Refusal> {
    let message = SecurityHeader::signed_message(payload, header.generated_ms, &header.signer);
    if ecdsa::verifies(memo, key, &message, &header.signature) {
        Ok(())
    } else {
        Err(Refusal::BadSignature)
    }
}
