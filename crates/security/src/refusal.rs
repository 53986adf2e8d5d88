//! [`Refusal`]: why a receiver did not accept a signed packet.

/// Why a receiver refused a signed packet (or a certificate), one reason per check, in the
/// order the verifier makes them. Each has a stable [`name`](Refusal::name) for a dataset's
/// column and a stable [`code`](Refusal::code) for a wire field; neither is ever reused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
pub enum Refusal {
    /// The header (or a certificate in it) ends before its last field: a truncated signature,
    /// a certificate cut short, an empty header.
    #[error("the security header is truncated")]
    Truncated,
    /// Bytes that are no header of this version: an unknown version or signer kind, an unknown
    /// certificate kind, bytes after the signature, a public key that is no P-256 point.
    #[error("the security header is malformed")]
    Malformed,
    /// Signed with a digest the receiver has never seen in full (it needs the certificate).
    #[error("signed with the digest of a certificate the receiver does not know")]
    UnknownCertificate,
    /// The certificate's issuer is no authority the receiver holds under its root (a
    /// certificate from another PKI), or an authority that its root did not sign.
    #[error("the certificate does not chain to the receiver's root")]
    ForeignRoot,
    /// A certificate of the wrong kind for its use: a root's or an authority's certificate
    /// signing a packet, a pseudonym issued by the root itself, an authority issued by an
    /// authority, a root that is not self-signed.
    #[error("the certificate is of the wrong kind for its use")]
    WrongKind,
    /// The certificate's issuer signature does not verify: its fields were altered.
    #[error("the certificate's signature does not verify")]
    BadCertificateSignature,
    /// The packet's signature does not verify over its payload and header: payload or header
    /// altered, or signed with another key; also a signature that is no valid (r, s) pair.
    #[error("the packet's signature does not verify")]
    BadSignature,
    /// The certificate (or its issuer's) is not valid yet at the receiver's time.
    #[error("the certificate is not valid yet")]
    NotYetValid,
    /// The certificate (or its issuer's) has expired at the receiver's time.
    #[error("the certificate has expired")]
    Expired,
    /// The certificate (or its issuer's) is on the receiver's revocation list.
    #[error("the certificate is revoked")]
    Revoked,
    /// The packet's generation time is further from the receiver's time than the verifier's
    /// freshness window allows (a replay, or a sender's clock far off).
    #[error("the packet is outside the freshness window")]
    Stale,
    /// A message the platoon's group key protects (`[security.group]`) carries no tag: sent
    /// by a vehicle that holds no group key (an outsider, a thief, a ghost), or stripped.
    #[error("the message carries no group-key tag")]
    Untagged,
    /// The message's group-key tag does not verify: altered after tagging, or tagged with a
    /// key that is not the group's.
    #[error("the message's group-key tag does not verify")]
    BadTag,
    /// A tag of another epoch than the receiver's group key: a key the leader renewed since
    /// (a vehicle that left), or a renewal the receiver has not received yet.
    #[error("the message's tag is of another group-key epoch than the receiver's")]
    WrongEpoch,
}

impl Refusal {
    /// Every reason, in code order.
    pub const ALL: [Refusal; 14] = [
        Refusal::Truncated,
        Refusal::Malformed,
        Refusal::UnknownCertificate,
        Refusal::ForeignRoot,
        Refusal::WrongKind,
        Refusal::BadCertificateSignature,
        Refusal::BadSignature,
        Refusal::NotYetValid,
        Refusal::Expired,
        Refusal::Revoked,
        Refusal::Stale,
        Refusal::Untagged,
        Refusal::BadTag,
        Refusal::WrongEpoch,
    ];

    /// Its stable name, snake_case, for a dataset's column.
    pub fn name(self) -> &'static str {
        match self {
            Refusal::Truncated => "truncated",
            Refusal::Malformed => "malformed",
            Refusal::UnknownCertificate => "unknown_certificate",
            Refusal::ForeignRoot => "foreign_root",
            Refusal::WrongKind => "wrong_kind",
            Refusal::BadCertificateSignature => "bad_certificate_signature",
            Refusal::BadSignature => "bad_signature",
            Refusal::NotYetValid => "not_yet_valid",
            Refusal::Expired => "expired",
            Refusal::Revoked => "revoked",
            Refusal::Stale => "stale",
            Refusal::Untagged => "untagged",
            Refusal::BadTag => "bad_tag",
            Refusal::WrongEpoch => "wrong_epoch",
        }
    }

    /// Its stable code, 1 to 14 (0 is left for "accepted" in a wire field).
    pub fn code(self) -> u8 {
        match self {
            Refusal::Truncated => 1,
            Refusal::Malformed => 2,
            Refusal::UnknownCertificate => 3,
            Refusal::ForeignRoot => 4,
            Refusal::WrongKind => 5,
            Refusal::BadCertificateSignature => 6,
            Refusal::BadSignature => 7,
            Refusal::NotYetValid => 8,
            Refusal::Expired => 9,
            Refusal::Revoked => 10,
            Refusal::Stale => 11,
            Refusal::Untagged => 12,
            Refusal::BadTag => 13,
            Refusal::WrongEpoch => 14,
        }
    }

    /// The reason with this [`code`](Refusal::code), if any.
    pub fn from_code(code: u8) -> Option<Refusal> {
        Refusal::ALL.into_iter().find(|r| r.code() == code)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn names_and_codes_are_distinct_and_codes_round_trip() {
        let names: HashSet<_> = Refusal::ALL.iter().map(|r| r.name()).collect();
        assert_eq!(names.len(), Refusal::ALL.len());
        for (i, r) in Refusal::ALL.into_iter().enumerate() {
            assert_eq!(usize::from(r.code()), i + 1, "{r:?}");
            assert_eq!(Refusal::from_code(r.code()), Some(r));
        }
        assert_eq!(Refusal::from_code(0), None);
        assert_eq!(Refusal::from_code(15), None);
    }
}
