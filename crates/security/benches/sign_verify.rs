//! Cost of signed V2V per packet: signing, and verifying under each policy and signer form.
//!
//! Method: one PKI, one sender and one receiver from a fixed seed; the payload is 80 bytes, the
//! size of `platoon_wire::V2vPacket`. Each iteration signs (or checks) one packet; the receiver
//! already knows the sender's certificate except in `verify_new_certificate`, where every
//! iteration checks a packet carrying a certificate it has not seen (a fresh verifier each
//! time, built outside the timing: the chain's signature and the packet's, two verifications).
//! `verify_digest_memo_hit` is `verify_digest` through a `SignatureMemo` that already holds the
//! outcome (what every receiver but the first pays when the receivers of a broadcast share
//! one). `p256_verify_only` and `ring_verify_only` are the signature check alone, with RustCrypto's
//! `p256` and with `ring`: the comparison behind verifying with `ring`. Criterion reports the median of its samples.
//! Run: `cargo bench -p platoon-security`.
use criterion::{black_box, criterion_group, criterion_main, BatchSize, Criterion};
use p256::ecdsa::signature::Verifier as _;
use p256::ecdsa::{Signature, VerifyingKey};
use platoon_security::{AttachRule, Pki, Policy, SecurityHeader, Signer, Validity, VerifierConfig};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

fn bench(c: &mut Criterion) {
    let mut rng = ChaCha20Rng::seed_from_u64(52);
    let pki = Pki::generate(&mut rng, Validity::ALWAYS);
    let signer = Signer::new(
        pki.pseudonym(&mut rng, Validity::ALWAYS),
        AttachRule::STANDARD,
    );
    let payload = [0x5a_u8; 80];
    let with_cert = signer.sign_with(&payload, 0, true);
    let with_digest = signer.sign_with(&payload, 0, false);
    let mut receiver = pki.verifier(VerifierConfig::default());
    receiver
        .check(&payload, &with_cert, 0, Policy::Every)
        .expect("the receiver learns the certificate");
    let digest_bytes = with_digest.to_bytes();

    let mut g = c.benchmark_group("signed_v2v");
    g.bench_function("sign", |b| {
        b.iter(|| signer.sign_with(black_box(&payload), 0, false))
    });
    g.bench_function("verify_digest", |b| {
        b.iter(|| {
            receiver.check(
                black_box(&payload),
                black_box(&with_digest),
                0,
                Policy::Every,
            )
        })
    });
    g.bench_function("verify_digest_bytes", |b| {
        b.iter(|| {
            receiver.check_bytes(
                black_box(&payload),
                black_box(&digest_bytes),
                0,
                Policy::Every,
            )
        })
    });
    let mut memo = platoon_security::SignatureMemo::new();
    g.bench_function("verify_digest_memo_hit", |b| {
        b.iter(|| {
            receiver.check_shared(
                &mut memo,
                black_box(&payload),
                black_box(&with_digest),
                0,
                Policy::Every,
            )
        })
    });
    g.bench_function("check_on_demand", |b| {
        b.iter(|| {
            receiver.check(
                black_box(&payload),
                black_box(&with_digest),
                0,
                Policy::OnDemand,
            )
        })
    });
    g.bench_function("verify_new_certificate", |b| {
        b.iter_batched(
            || pki.verifier(VerifierConfig::default()),
            |mut fresh| fresh.check(black_box(&payload), black_box(&with_cert), 0, Policy::Every),
            BatchSize::SmallInput,
        )
    });
    let key = VerifyingKey::from_sec1_bytes(&signer.certificate().subject_key).unwrap();
    let message = SecurityHeader::signed_message(&payload, 0, &with_digest.signer);
    let signature = Signature::from_slice(&with_digest.signature).unwrap();
    g.bench_function("p256_verify_only", |b| {
        b.iter(|| key.verify(black_box(&message), black_box(&signature)))
    });
    let public = signer.certificate().public_key().unwrap();
    g.bench_function("ring_verify_only", |b| {
        b.iter(|| public.verifies(black_box(&message), black_box(&with_digest.signature)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
