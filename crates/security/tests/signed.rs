//! Signed V2V end to end in the pure core: a PKI, senders, receivers, and every refusal.
use platoon_security::{
    AttachRule, CertKind, Credential, HashedId8, Pki, Policy, Refusal, SecurityHeader,
    SignatureCheck, SignatureMemo, Signer, SignerId, Validity, Verifier, VerifierConfig,
    CERTIFICATE_HEADER_LEN, DIGEST_HEADER_LEN,
};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

/// An hour of run time.
const RUN: Validity = Validity {
    from_ms: 0,
    until_ms: 3_600_000,
};

/// An 80-byte payload, the size of `platoon_wire::V2vPacket`.
const PAYLOAD: [u8; 80] = [7; 80];

struct World {
    rng: ChaCha20Rng,
    pki: Pki,
}

fn world(seed: u64) -> World {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    let pki = Pki::generate(&mut rng, RUN);
    World { rng, pki }
}

impl World {
    fn pseudonym(&mut self) -> Credential {
        self.pki.pseudonym(&mut self.rng, RUN)
    }

    fn signer(&mut self) -> Signer {
        Signer::new(self.pseudonym(), AttachRule::STANDARD)
    }

    fn verifier(&self) -> Verifier {
        self.pki.verifier(VerifierConfig::default())
    }
}

fn attached(h: &SecurityHeader) -> bool {
    matches!(h.signer, SignerId::Certificate(_))
}

#[test]
fn the_same_seed_makes_the_same_pki_and_signatures_bit_for_bit() {
    let run = |seed| {
        let mut w = world(seed);
        let mut s = w.signer();
        let headers: Vec<Vec<u8>> = (0..3)
            .map(|k| s.sign(&PAYLOAD, k * 100).to_bytes())
            .collect();
        (
            w.pki.root().certificate().encode(),
            w.pki.authority().certificate().encode(),
            headers,
        )
    };
    assert_eq!(run(7), run(7));
    let (a, b) = (run(7), run(8));
    assert_ne!(a.0, b.0);
    assert_ne!(a.2, b.2);
}

#[test]
fn signing_is_deterministic_and_headers_round_trip() {
    let mut w = world(1);
    let s = w.signer();
    for attach in [false, true] {
        let h = s.sign_with(&PAYLOAD, 40, attach);
        assert_eq!(
            h,
            s.sign_with(&PAYLOAD, 40, attach),
            "RFC 6979: no randomness"
        );
        let bytes = h.to_bytes();
        let len = if attach {
            CERTIFICATE_HEADER_LEN
        } else {
            DIGEST_HEADER_LEN
        };
        assert_eq!((bytes.len(), h.encoded_len()), (len, len));
        assert_eq!(SecurityHeader::decode(&bytes), Ok(h));
    }
}

#[test]
fn a_certificate_teaches_the_receiver_and_digests_follow() {
    let mut w = world(2);
    let mut s = w.signer();
    let mut v = w.verifier();
    let first = s.sign(&PAYLOAD, 0);
    assert!(attached(&first));
    let got = v.check(&PAYLOAD, &first, 5, Policy::Every).unwrap();
    assert_eq!(
        (got.signer, got.learned, got.signature),
        (s.digest(), true, SignatureCheck::Verified)
    );
    assert!(v.knows(s.digest()));
    for k in 1..10 {
        let h = s.sign(&PAYLOAD, k * 100);
        assert!(!attached(&h), "digest only within the second");
        let got = v
            .check_bytes(&PAYLOAD, &h.to_bytes(), k * 100 + 5, Policy::Every)
            .unwrap();
        assert!(!got.learned);
    }
}

#[test]
fn a_digest_never_seen_in_full_is_an_unknown_certificate() {
    let mut w = world(3);
    let s = w.signer();
    let mut v = w.verifier();
    let h = s.sign_with(&PAYLOAD, 0, false);
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::Every),
        Err(Refusal::UnknownCertificate)
    );
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::OnDemand),
        Err(Refusal::UnknownCertificate)
    );
    assert_eq!(
        v.verify_signature(&PAYLOAD, &h),
        Err(Refusal::UnknownCertificate)
    );
    assert!(!v.knows(s.digest()));
}

#[test]
fn another_pki_is_a_foreign_root() {
    let w = world(4);
    let mut other = world(5);
    let mut v = w.verifier();
    let stranger = other.signer();
    let h = stranger.sign_with(&PAYLOAD, 0, true);
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::Every),
        Err(Refusal::ForeignRoot)
    );
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::OnDemand),
        Err(Refusal::ForeignRoot)
    );
    assert!(!v.knows(stranger.digest()));
    assert_eq!(
        v.add_authority(other.pki.authority().certificate()),
        Err(Refusal::ForeignRoot)
    );
    // A verifier built from the other root alone, given our AA: foreign too; given its own AA:
    // held, and then the stranger's certificate is accepted.
    let mut theirs =
        Verifier::new(other.pki.root().certificate(), VerifierConfig::default()).unwrap();
    assert_eq!(
        theirs.add_authority(w.pki.authority().certificate()),
        Err(Refusal::ForeignRoot)
    );
    assert_eq!(
        theirs.add_authority(other.pki.authority().certificate()),
        Ok(other.pki.authority().digest())
    );
    assert!(theirs.check(&PAYLOAD, &h, 0, Policy::Every).is_ok());
}

#[test]
fn certificates_of_the_wrong_kind_are_refused() {
    let mut w = world(6);
    let mut v = w.verifier();
    let cases = [
        // An authority signing a packet, the root signing a packet.
        w.pki.authority().clone(),
        w.pki.root().clone(),
        // A pseudonym the root issued itself, bypassing the AA.
        w.pki.root().issue(CertKind::Pseudonym, &mut w.rng, RUN),
    ];
    for cred in cases {
        let h = Signer::new(cred, AttachRule::STANDARD).sign_with(&PAYLOAD, 0, true);
        assert_eq!(
            v.check(&PAYLOAD, &h, 0, Policy::Every),
            Err(Refusal::WrongKind)
        );
    }
    // A pseudonym issued by a pseudonym: its issuer is no authority under the root.
    let p = w.pseudonym();
    let h = Signer::new(
        p.issue(CertKind::Pseudonym, &mut w.rng, RUN),
        AttachRule::STANDARD,
    )
    .sign_with(&PAYLOAD, 0, true);
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::Every),
        Err(Refusal::ForeignRoot)
    );
    // An authority's certificate that is no authority's, and a root that is not a root.
    let fake_aa = w.pki.root().issue(CertKind::Pseudonym, &mut w.rng, RUN);
    assert_eq!(
        v.add_authority(fake_aa.certificate()),
        Err(Refusal::WrongKind)
    );
    assert_eq!(
        Verifier::new(w.pki.authority().certificate(), VerifierConfig::default()).err(),
        Some(Refusal::WrongKind)
    );
}

#[test]
fn an_altered_certificate_does_not_verify() {
    let mut w = world(7);
    let mut v = w.verifier();
    let s = w.signer();
    let mut h = s.sign_with(&PAYLOAD, 0, true);
    let SignerId::Certificate(mut cert) = h.signer else {
        panic!("attached")
    };
    cert.validity.until_ms += 1; // a longer life than the AA gave
    h.signer = SignerId::Certificate(cert);
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::Every),
        Err(Refusal::BadCertificateSignature)
    );
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::OnDemand),
        Err(Refusal::BadCertificateSignature)
    );
    assert!(!v.knows(cert.digest()));
    // A root whose self-signature does not hold.
    let mut root = *w.pki.root().certificate();
    root.signature[10] ^= 1;
    assert_eq!(
        Verifier::new(&root, VerifierConfig::default()).err(),
        Some(Refusal::BadCertificateSignature)
    );
}

#[test]
fn validity_is_checked_for_the_pseudonym_and_its_authority() {
    let mut w = world(8);
    let short = w.pki.pseudonym(&mut w.rng, Validity::new(1000, 2000));
    let s = Signer::new(short, AttachRule::STANDARD);
    let mut v = w.verifier();
    let at = |ms| s.sign_with(&PAYLOAD, ms, true);
    assert_eq!(
        v.check(&PAYLOAD, &at(500), 500, Policy::Every),
        Err(Refusal::NotYetValid)
    );
    assert!(!v.knows(s.digest()), "not learned before it is valid");
    assert!(
        v.check(&PAYLOAD, &at(1500), 1500, Policy::Every)
            .unwrap()
            .learned
    );
    let digest_only = s.sign_with(&PAYLOAD, 2000, false);
    assert_eq!(
        v.check(&PAYLOAD, &digest_only, 2000, Policy::Every),
        Err(Refusal::Expired)
    );
    v.prune(1999);
    assert!(v.knows(s.digest()));
    v.prune(2000);
    assert!(!v.knows(s.digest()));
    // An AA that expires takes its pseudonyms with it.
    let mut rng = ChaCha20Rng::seed_from_u64(80);
    let pki = Pki::generate(&mut rng, Validity::new(0, 3000));
    let s = Signer::new(pki.pseudonym(&mut rng, RUN), AttachRule::STANDARD);
    let mut v = pki.verifier(VerifierConfig::default());
    assert!(v
        .check(
            &PAYLOAD,
            &s.sign_with(&PAYLOAD, 2900, true),
            2900,
            Policy::Every
        )
        .is_ok());
    let late = s.sign_with(&PAYLOAD, 3000, false);
    assert_eq!(
        v.check(&PAYLOAD, &late, 3000, Policy::Every),
        Err(Refusal::Expired)
    );
}

#[test]
fn a_revoked_pseudonym_or_authority_is_refused_even_once_learned() {
    let mut w = world(9);
    let mut v = w.verifier();
    let (a, b) = (w.signer(), w.signer());
    for s in [&a, &b] {
        assert!(v
            .check(&PAYLOAD, &s.sign_with(&PAYLOAD, 0, true), 0, Policy::Every)
            .is_ok());
    }
    v.revoke(a.digest());
    assert!(v.is_revoked(a.digest()));
    for attach in [false, true] {
        let h = a.sign_with(&PAYLOAD, 10, attach);
        assert_eq!(
            v.check(&PAYLOAD, &h, 10, Policy::Every),
            Err(Refusal::Revoked)
        );
        assert!(v
            .check(
                &PAYLOAD,
                &b.sign_with(&PAYLOAD, 10, attach),
                10,
                Policy::Every
            )
            .is_ok());
    }
    // Revoking the AA refuses every pseudonym it issued, known or new.
    v.revoke(w.pki.authority().digest());
    let c = w.signer();
    for (s, attach) in [(&b, false), (&c, true)] {
        let h = s.sign_with(&PAYLOAD, 20, attach);
        assert_eq!(
            v.check(&PAYLOAD, &h, 20, Policy::Every),
            Err(Refusal::Revoked)
        );
    }
}

#[test]
fn a_packet_outside_the_freshness_window_is_stale() {
    let mut w = world(10);
    let mut v = w.verifier();
    let s = w.signer();
    assert!(v
        .check(
            &PAYLOAD,
            &s.sign_with(&PAYLOAD, 0, true),
            1000,
            Policy::Every
        )
        .is_ok());
    let old = s.sign_with(&PAYLOAD, 0, false);
    assert_eq!(
        v.check(&PAYLOAD, &old, 1001, Policy::Every),
        Err(Refusal::Stale)
    );
    let ahead = s.sign_with(&PAYLOAD, 5000, false);
    assert_eq!(
        v.check(&PAYLOAD, &ahead, 3999, Policy::Every),
        Err(Refusal::Stale)
    );
    assert!(v.check(&PAYLOAD, &ahead, 4000, Policy::Every).is_ok());
}

#[test]
fn the_certificate_rides_once_a_second_after_a_change_and_on_request() {
    let mut w = world(11);
    let mut s = w.signer();
    let mut carried = vec![];
    for k in 0..31 {
        let now = k * 100;
        if now == 2200 {
            s.request_certificate();
        }
        if attached(&s.sign(&PAYLOAD, now)) {
            carried.push(now);
        }
    }
    assert_eq!(carried, [0, 1000, 2000, 2200]);
    let old = s.change_pseudonym(w.pseudonym());
    assert_ne!(old.digest(), s.digest());
    assert!(
        attached(&s.sign(&PAYLOAD, 3100)),
        "a new pseudonym shows its certificate"
    );
    assert!(!attached(&s.sign(&PAYLOAD, 3200)));
    assert!(attached(&s.sign(&PAYLOAD, 4100)));
}

#[test]
fn receivers_follow_a_pseudonym_change() {
    let mut w = world(12);
    let mut s = w.signer();
    let (mut heard, mut missed) = (w.verifier(), w.verifier());
    for k in 0..5 {
        let h = s.sign(&PAYLOAD, k * 100);
        assert!(heard.check(&PAYLOAD, &h, k * 100, Policy::Every).is_ok());
        assert!(missed.check(&PAYLOAD, &h, k * 100, Policy::Every).is_ok());
    }
    let before = s.digest();
    s.change_pseudonym(w.pseudonym());
    let change = s.sign(&PAYLOAD, 500);
    let got = heard.check(&PAYLOAD, &change, 500, Policy::Every).unwrap();
    assert_eq!((got.signer, got.learned), (s.digest(), true));
    // The other receiver lost the packet with the certificate: the digests that follow are
    // unknown to it until the sender attaches the certificate again (on its request here).
    let next = s.sign(&PAYLOAD, 600);
    assert!(heard.check(&PAYLOAD, &next, 600, Policy::Every).is_ok());
    assert_eq!(
        missed.check(&PAYLOAD, &next, 600, Policy::Every),
        Err(Refusal::UnknownCertificate)
    );
    s.request_certificate();
    let again = s.sign(&PAYLOAD, 700);
    assert!(
        missed
            .check(&PAYLOAD, &again, 700, Policy::Every)
            .unwrap()
            .learned
    );
    assert!(heard.knows(before) && heard.knows(s.digest()));
}

#[test]
fn on_demand_defers_the_signature_and_nothing_else() {
    let mut w = world(13);
    let mut v = w.verifier();
    let s = w.signer();
    let h = s.sign_with(&PAYLOAD, 0, true);
    let mut forged = PAYLOAD;
    forged[0] ^= 0x80;
    let got = v.check(&forged, &h, 0, Policy::OnDemand).unwrap();
    assert_eq!(got.signature, SignatureCheck::Deferred);
    assert_eq!(v.verify_signature(&forged, &h), Err(Refusal::BadSignature));
    assert_eq!(v.verify_signature(&PAYLOAD, &h), Ok(()));
    assert_eq!(
        v.check(&forged, &h, 0, Policy::Every),
        Err(Refusal::BadSignature)
    );
    let stale = s.sign_with(&PAYLOAD, 0, false);
    assert_eq!(
        v.check(&PAYLOAD, &stale, 5000, Policy::OnDemand),
        Err(Refusal::Stale)
    );
}

#[test]
fn every_truncation_is_truncated_and_every_extension_malformed() {
    let mut w = world(14);
    let mut v = w.verifier();
    let s = w.signer();
    for attach in [true, false] {
        let bytes = s.sign_with(&PAYLOAD, 0, attach).to_bytes();
        for n in 0..bytes.len() {
            assert_eq!(
                v.check_bytes(&PAYLOAD, &bytes[..n], 0, Policy::Every),
                Err(Refusal::Truncated),
                "cut at {n}"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(
            v.check_bytes(&PAYLOAD, &longer, 0, Policy::Every),
            Err(Refusal::Malformed)
        );
        assert!(v.check_bytes(&PAYLOAD, &bytes, 0, Policy::Every).is_ok());
    }
}

#[test]
fn a_signature_that_is_no_valid_pair_is_a_bad_signature() {
    let mut w = world(15);
    let mut v = w.verifier();
    let s = w.signer();
    let mut h = s.sign_with(&PAYLOAD, 0, true);
    h.signature = [0; 64]; // r = s = 0
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::Every),
        Err(Refusal::BadSignature)
    );
    h.signature = [0xff; 64]; // both above the group order
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::Every),
        Err(Refusal::BadSignature)
    );
    assert!(v.knows(s.digest()), "the certificate itself was genuine");
}

#[test]
fn a_key_that_is_no_curve_point_is_malformed() {
    let mut w = world(16);
    let mut v = w.verifier();
    let mut cert = *w.pseudonym().certificate();
    cert.subject_key = [0xff; 33]; // no SEC1 point starts with 0xff
                                   // Altered after the AA signed: refused for the signature, before the key is read.
    let forged = SecurityHeader {
        generated_ms: 0,
        signer: SignerId::Certificate(cert),
        signature: [1; 64],
    };
    assert_eq!(
        v.check(&PAYLOAD, &forged, 0, Policy::Every),
        Err(Refusal::BadCertificateSignature)
    );
    // Signed so by a faulty AA: the chain holds, the key does not.
    let faulty = w.pki.authority().certify(&cert);
    assert_eq!(faulty.issuer, w.pki.authority().digest());
    let h = SecurityHeader {
        signer: SignerId::Certificate(faulty),
        ..forged
    };
    assert_eq!(
        v.check(&PAYLOAD, &h, 0, Policy::Every),
        Err(Refusal::Malformed)
    );
    assert_eq!(faulty.public_key().err(), Some(Refusal::Malformed));
    assert!(!v.knows(faulty.digest()));
    assert_eq!(HashedId8::of(&faulty.encode()), faulty.digest());
}

#[test]
fn receivers_sharing_a_memo_decide_as_receivers_alone_and_verify_each_signature_once() {
    let mut w = world(17);
    let mut stranger_world = world(18);
    let stranger = stranger_world.signer();
    let mut s = w.signer();
    let mut memo = SignatureMemo::new();
    let mut shared: Vec<Verifier> = (0..4).map(|_| w.verifier()).collect();
    let mut alone: Vec<Verifier> = (0..4).map(|_| w.verifier()).collect();
    let mut tampered_payload = PAYLOAD;
    tampered_payload[3] ^= 1;
    let mut bad_signature = s.sign_with(&PAYLOAD, 0, false);
    bad_signature.signature[5] ^= 1;
    let packets = [
        (PAYLOAD, s.sign(&PAYLOAD, 0)),   // certificate: chain + packet
        (PAYLOAD, s.sign(&PAYLOAD, 100)), // digest
        (tampered_payload, s.sign_with(&PAYLOAD, 100, false)),
        (PAYLOAD, bad_signature),
        (PAYLOAD, stranger.sign_with(&PAYLOAD, 0, true)), // refused before any signature
    ];
    let mut outcomes = vec![];
    for (payload, header) in &packets {
        for (a, b) in shared.iter_mut().zip(alone.iter_mut()) {
            let with = a.check_shared(&mut memo, payload, header, 100, Policy::Every);
            let without = b.check(payload, header, 100, Policy::Every);
            assert_eq!(with, without, "{header:?}");
            outcomes.push(with.map(|a| a.learned));
        }
    }
    assert_eq!(
        outcomes.iter().filter(|o| o.is_ok()).count(),
        8,
        "the first two packets, at each of four receivers: {outcomes:?}"
    );
    // One check per distinct signature: the certificate's chain, then four packets.
    assert_eq!(memo.len(), 5);
    memo.clear();
    assert!(memo.is_empty());
}

proptest! {
    // Each case signs and verifies a few times (a few ms each at opt-level 0); failures are
    // not persisted to files (as the workspace's other property tests), proptest prints them.
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn any_payload_verifies_and_any_bit_flipped_in_it_does_not(
        payload in proptest::collection::vec(any::<u8>(), 0..300),
        bit in any::<usize>(),
        attach in any::<bool>(),
    ) {
        let mut w = world(20);
        let mut v = w.verifier();
        let s = w.signer();
        let learn = s.sign_with(b"hello", 0, true);
        prop_assert!(v.check(b"hello", &learn, 0, Policy::Every).is_ok());
        let h = s.sign_with(&payload, 10, attach);
        prop_assert!(v.check(&payload, &h, 10, Policy::Every).is_ok());
        let mut flipped = payload.clone();
        flipped.push(0);
        let i = bit % (flipped.len() * 8);
        flipped[i / 8] ^= 1 << (i % 8);
        prop_assert_eq!(v.check(&flipped, &h, 10, Policy::Every), Err(Refusal::BadSignature));
    }

    #[test]
    fn any_byte_changed_in_a_header_is_refused_without_panic(
        at in any::<usize>(),
        xor in 1u8..=255,
        attach in any::<bool>(),
        learned in any::<bool>(),
    ) {
        let mut w = world(21);
        let mut v = w.verifier();
        let s = w.signer();
        if learned {
            prop_assert!(v.check(&PAYLOAD, &s.sign_with(&PAYLOAD, 0, true), 0, Policy::Every).is_ok());
        }
        let mut bytes = s.sign_with(&PAYLOAD, 0, attach).to_bytes();
        let i = at % bytes.len();
        bytes[i] ^= xor;
        let got = v.check_bytes(&PAYLOAD, &bytes, 0, Policy::Every);
        prop_assert!(got.is_err(), "byte {} ^ {:#x} accepted: {:?}", i, xor, got);
        // Verify on demand does not read the signature (nor which bytes a generation time
        // within the window holds): what it accepts, the deferred verification refuses.
        if v.check_bytes(&PAYLOAD, &bytes, 0, Policy::OnDemand).is_ok() {
            let h = SecurityHeader::decode(&bytes).unwrap();
            prop_assert_eq!(v.verify_signature(&PAYLOAD, &h), Err(Refusal::BadSignature));
        }
    }
}
