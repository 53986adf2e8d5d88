//! The simulated PKI: a root CA, an authorization authority (AA) the root certifies, and the
//! vehicles' pseudonyms the AA issues ([`Credential`], [`Pki`]).
//!
//! Every key comes from the random number generator the caller passes in (a seeded
//! `rand_chacha::ChaCha20Rng` in a run), so a run's PKI is the same bit for bit at the same
//! seed.

use crate::{CertKind, Certificate, HashedId8, Validity, Verifier, VerifierConfig};
use p256::ecdsa::SigningKey;
use rand::{CryptoRng, RngCore};

/// A key pair with its certificate: the root's, an authority's or a vehicle's pseudonym.
#[derive(Debug, Clone)]
pub struct Credential {
    key: SigningKey,
    cert: Certificate,
    digest: HashedId8,
}

impl Credential {
    /// A new root CA with a self-signed certificate valid over `validity`.
    pub fn root<R: RngCore + CryptoRng>(rng: &mut R, validity: Validity) -> Credential {
        let key = SigningKey::random(rng);
        let cert = Certificate::signed(
            CertKind::Root,
            HashedId8::SELF,
            key.verifying_key(),
            validity,
            &key,
        );
        Credential::new(key, cert)
    }

    /// A new key pair of `kind` whose certificate this credential signs, valid over
    /// `validity`. Nothing stops a credential from issuing what the PKI's rules forbid (a
    /// pseudonym signing a pseudonym, a root signing a pseudonym): verifiers refuse those,
    /// and tests make them to see it.
    pub fn issue<R: RngCore + CryptoRng>(
        &self,
        kind: CertKind,
        rng: &mut R,
        validity: Validity,
    ) -> Credential {
        let key = SigningKey::random(rng);
        let cert = Certificate::signed(kind, self.digest, key.verifying_key(), validity, &self.key);
        Credential::new(key, cert)
    }

    /// `cert` with this credential as its issuer and signed by it, whatever its fields hold:
    /// a compromised or faulty issuer (an insider) certifying what it should not.
    pub fn certify(&self, cert: &Certificate) -> Certificate {
        Certificate::sign_fields(cert, self.digest, &self.key)
    }

    fn new(key: SigningKey, cert: Certificate) -> Credential {
        let digest = cert.digest();
        Credential { key, cert, digest }
    }

    /// Its certificate.
    pub fn certificate(&self) -> &Certificate {
        &self.cert
    }

    /// Its certificate's digest.
    pub fn digest(&self) -> HashedId8 {
        self.digest
    }

    pub(crate) fn signing_key(&self) -> &SigningKey {
        &self.key
    }
}

/// A root CA and one authorization authority under it: the PKI of a run.
#[derive(Debug, Clone)]
pub struct Pki {
    root: Credential,
    authority: Credential,
}

impl Pki {
    /// A new root and AA, both valid over `validity`.
    pub fn generate<R: RngCore + CryptoRng>(rng: &mut R, validity: Validity) -> Pki {
        let root = Credential::root(rng, validity);
        let authority = root.issue(CertKind::Authority, rng, validity);
        Pki { root, authority }
    }

    /// The root CA.
    pub fn root(&self) -> &Credential {
        &self.root
    }

    /// The authorization authority.
    pub fn authority(&self) -> &Credential {
        &self.authority
    }

    /// A new pseudonym the AA issues, valid over `validity`.
    pub fn pseudonym<R: RngCore + CryptoRng>(&self, rng: &mut R, validity: Validity) -> Credential {
        self.authority.issue(CertKind::Pseudonym, rng, validity)
    }

    /// A receiver's verifier that trusts this PKI's root and holds its AA's certificate.
    pub fn verifier(&self, config: VerifierConfig) -> Verifier {
        Verifier::trusting(&self.root, &self.authority, config)
    }
}
