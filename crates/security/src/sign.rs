//! The sender's side: [`Signer`] signs a vehicle's packets with its current pseudonym and
//! attaches the full certificate by the [`AttachRule`].

use crate::{ecdsa, Certificate, Credential, HashedId8, SecurityHeader, SignerId};

/// When a packet carries its signer's full certificate instead of the digest.
///
/// The standards' rule, which this follows: ETSI TS 103 097 with EN 302 637-2 (CAMs) attaches
/// the certificate once a second and otherwise the digest, and at once in the next message when
/// a new station is heard or a station asks for it (a receiver that met an unknown digest);
/// SAE J2945/1 (BSMs) does likewise. Here: a packet carries it when no packet of the current
/// pseudonym has yet, when [`AttachRule::period_ms`] has passed since the last one that did,
/// or when [`Signer::request_certificate`] was called since (a new neighbour, or a receiver's
/// request); so the first packet after a pseudonym change always carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AttachRule {
    /// The longest time between two packets that carry the certificate (ms).
    pub period_ms: u64,
}

impl AttachRule {
    /// The standards' once a second.
    pub const STANDARD: AttachRule = AttachRule { period_ms: 1000 };
}

impl Default for AttachRule {
    fn default() -> Self {
        AttachRule::STANDARD
    }
}

/// A vehicle's signing state: its current pseudonym and when it last attached its certificate.
#[derive(Debug, Clone)]
pub struct Signer {
    pseudonym: Credential,
    rule: AttachRule,
    last_attached_ms: Option<u64>,
    requested: bool,
}

impl Signer {
    /// Signs with `pseudonym`, attaching its certificate by `rule`.
    pub fn new(pseudonym: Credential, rule: AttachRule) -> Signer {
        Signer {
            pseudonym,
            rule,
            last_attached_ms: None,
            requested: false,
        }
    }

    /// The header for `payload` sent at `now_ms`, with the certificate if the rule says so
    /// (and then the rule's clock restarts at `now_ms`). Deterministic: RFC 6979 signatures.
    pub fn sign(&mut self, payload: &[u8], now_ms: u64) -> SecurityHeader {
        let attach = self.requested
            || self
                .last_attached_ms
                .is_none_or(|t| now_ms.saturating_sub(t) >= self.rule.period_ms);
        if attach {
            self.last_attached_ms = Some(now_ms);
            self.requested = false;
        }
        self.sign_with(payload, now_ms, attach)
    }

    /// The header for `payload` at `now_ms`, with the certificate if `attach`, whatever the
    /// rule says; the rule's state does not change.
    pub fn sign_with(&self, payload: &[u8], now_ms: u64, attach: bool) -> SecurityHeader {
        sign_as(&self.pseudonym, payload, now_ms, attach)
    }

    /// The next packet carries the certificate: a new neighbour appeared, or a receiver asked
    /// (it met this pseudonym's digest without knowing it).
    pub fn request_certificate(&mut self) {
        self.requested = true;
    }

    /// Switches to `next` (a pseudonym change) and returns the one it replaces; the next
    /// packet carries `next`'s certificate.
    pub fn change_pseudonym(&mut self, next: Credential) -> Credential {
        self.last_attached_ms = None;
        self.requested = false;
        std::mem::replace(&mut self.pseudonym, next)
    }

    /// The current pseudonym's digest.
    pub fn digest(&self) -> HashedId8 {
        self.pseudonym.digest()
    }

    /// The current pseudonym's certificate.
    pub fn certificate(&self) -> &Certificate {
        self.pseudonym.certificate()
    }
}

/// `payload` signed at `now_ms` with `pseudonym`, carrying its full certificate if `attach`
/// and else its digest.
pub(crate) fn sign_as(
    pseudonym: &Credential,
    payload: &[u8],
    now_ms: u64,
    attach: bool,
) -> SecurityHeader {
    let signer = if attach {
        SignerId::Certificate(*pseudonym.certificate())
    } else {
        SignerId::Digest(pseudonym.digest())
    };
    let message = SecurityHeader::signed_message(payload, now_ms, &signer);
    SecurityHeader {
        generated_ms: now_ms,
        signer,
        signature: ecdsa::sign(pseudonym.signing_key(), &message),
    }
}
