//! [`HashedId8`]: how a certificate is named on the wire.

use sha2::{Digest, Sha256};
use std::fmt;

/// A certificate's short name: the last 8 bytes of SHA-256 over its whole encoding, as IEEE
/// 1609.2's `HashedId8` (the low-order 8 bytes of the hash). A packet signed "with a digest"
/// carries this instead of its 122-byte certificate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct HashedId8(pub [u8; 8]);

impl HashedId8 {
    /// Its size on the wire (bytes).
    pub const LEN: usize = 8;

    /// The issuer field of a self-signed (root) certificate: eight zero bytes, 1609.2's `self`.
    pub const SELF: Self = Self([0; 8]);

    /// The digest of `encoding`: the last 8 bytes of its SHA-256.
    pub fn of(encoding: &[u8]) -> Self {
        let hash = Sha256::digest(encoding);
        let mut id = [0; 8];
        id.copy_from_slice(&hash[32 - Self::LEN..]);
        Self(id)
    }
}

impl fmt::Display for HashedId8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.iter().try_for_each(|b| write!(f, "{b:02x}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_digest_is_the_last_eight_bytes_of_sha256() {
        // SHA-256("abc") = ba7816bf ... b410ff61 f20015ad (FIPS 180-2, appendix B.1).
        let id = HashedId8::of(b"abc");
        assert_eq!(id.0, [0xb4, 0x10, 0xff, 0x61, 0xf2, 0x00, 0x15, 0xad]);
        assert_eq!(id.to_string(), "b410ff61f20015ad");
    }
}
