//! `platoon-fuzz`: fuzzing of what reads untrusted input, on stable Rust.
//!
//! Coverage-guided fuzzers do not build here: cargo-fuzz (libFuzzer) needs a nightly compiler
//! for `-Zsanitizer`, and cargo-afl needs AFL++'s LLVM plugins built against rustc's own LLVM,
//! neither of which this toolchain or the package registries provide. So this is a
//! property-based, mutation-based fuzzer on proptest: each execution takes an input of the seed
//! corpus and applies up to eight random mutations (bit flips, byte writes, inserts, deletes,
//! splices from other inputs, numbers replaced by extreme values, lines dropped or repeated),
//! runs the target, and checks its property; a failure is shrunk to a minimal input by proptest
//! and saved under `fuzz/crashes/`. The same seed gives the same executions.
//!
//! Targets:
//! - `config`: TOML text in (seeds: `configs/*.toml`, `fuzz/corpus/config/`). Never a panic: a
//!   clean error, or a valid scenario whose resolved config parses again and whose first steps
//!   run.
//! - `packets`: bytes read as two rx batches of `LinkPacket`s (steps k and k + 1) for a fleet of
//!   two paper platoons, and as a plant `VehicleState` batch (seeds: `fuzz/corpus/packets/`,
//!   real batches written by `platoon-fuzz seed-corpus`). Never a panic, every command finite
//!   (no NaN or absurd state ever reaches an estimator), and no more refusals than deliveries.
//! - `seals`: the same for a fleet with `[security]` (every packet verified, docs/security.md),
//!   whose seeds are real signed batches of steps k and k + 1 (`fuzz/corpus/seals/`), and whose
//!   mutations besides the bytes' aim at the security header on the wire (`V2vPacket`'s
//!   `seal_len` and `seal`): a length out of range, a truncated signature or certificate,
//!   random bytes, a flipped bit, and a seal made elsewhere put in its place (a certificate from
//!   another root, a digest of a certificate no receiver saw, a certificate altered after its
//!   issuer signed it). Never a panic, every command finite, and every delivery either
//!   verified or refused with a reason (`platoon_security::Refusal`), none uncounted.
use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use platoon_control::{Controller, Delivery, Packet};
use platoon_model::State;
use platoon_runtime::session::{deliveries_from_wire, packet_to_wire, states_from_wire, Numbering};
use platoon_wire::{LinkPacket, V2vPacket, VehicleState};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestError, TestRng, TestRunner};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Fuzz the config loader and the packet paths (see the crate docs for the method).
#[derive(Debug, Parser)]
#[command(name = "platoon-fuzz", about, long_about)]
struct Cli {
    #[command(subcommand)]
    target: Target,
    /// Executions per target.
    #[arg(long, default_value_t = 100_000, global = true)]
    iterations: u32,
    /// Seed of the mutations (the same seed repeats the same executions).
    #[arg(long, default_value_t = 1, global = true)]
    seed: u64,
}

#[derive(Debug, Subcommand)]
enum Target {
    /// TOML text into the config loader.
    Config,
    /// Bytes into the rx-batch decoding and the controllers' packet checks.
    Packets,
    /// Signed rx batches, their security headers mutated, into the seals' checks.
    Seals,
    /// Every target (`seals` with a tenth of the executions: each verifies signatures).
    All,
    /// Writes real rx batches of the paper scenario into fuzz/corpus/packets/ and, signed,
    /// into fuzz/corpus/seals/.
    SeedCorpus {
        /// Which corpus.
        #[arg(long, value_enum, default_value_t = CorpusOf::Both)]
        of: CorpusOf,
    },
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

fn read_dir(dir: &Path, ext: Option<&str>) -> Result<Vec<Vec<u8>>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| ext.is_none_or(|x| p.extension().is_some_and(|e| e == x)))
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| std::fs::read(p).with_context(|| format!("reading {}", p.display())))
        .collect()
}

/// One change to an input.
#[derive(Debug, Clone)]
enum Mutation {
    Flip {
        at: usize,
        bit: u8,
    },
    Set {
        at: usize,
        byte: u8,
    },
    Insert {
        at: usize,
        bytes: Vec<u8>,
    },
    Delete {
        at: usize,
        len: usize,
    },
    Splice {
        at: usize,
        from: usize,
        from_at: usize,
        len: usize,
    },
    Number {
        nth: usize,
        value: usize,
    },
    DropLine {
        nth: usize,
    },
    RepeatLine {
        nth: usize,
    },
}

/// Values that break naive parsers and validators.
const INTERESTING: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "-0.0",
    "1e-300",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "0.5",
    "3",
    "1e9",
    "\"\"",
    "[]",
    "{}",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    let at = any::<usize>();
    prop_oneof![
        (at, 0u8..8).prop_map(|(at, bit)| Mutation::Flip { at, bit }),
        (at, any::<u8>()).prop_map(|(at, byte)| Mutation::Set { at, byte }),
        (at, prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(at, bytes)| Mutation::Insert { at, bytes }),
        (at, 1usize..64).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (at, any::<usize>(), any::<usize>(), 1usize..128).prop_map(|(at, from, from_at, len)| {
            Mutation::Splice {
                at,
                from,
                from_at,
                len,
            }
        }),
        (any::<usize>(), 0..INTERESTING.len())
            .prop_map(|(nth, value)| Mutation::Number { nth, value }),
        any::<usize>().prop_map(|nth| Mutation::DropLine { nth }),
        any::<usize>().prop_map(|nth| Mutation::RepeatLine { nth }),
    ]
}

/// Start and end of every number-like token (digits, sign, dot, exponent).
fn numbers(s: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < s.len() {
        if s[i].is_ascii_digit() {
            let start = i;
            while i < s.len()
                && (s[i].is_ascii_alphanumeric() || matches!(s[i], b'.' | b'_' | b'-' | b'+'))
            {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

fn lines(s: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, b) in s.iter().enumerate() {
        if *b == b'\n' {
            out.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < s.len() {
        out.push((start, s.len()));
    }
    out
}

fn mutate(base: &[u8], muts: &[Mutation], corpus: &[Vec<u8>]) -> Vec<u8> {
    let mut s = base.to_vec();
    for m in muts {
        let n = s.len();
        match m {
            Mutation::Flip { at, bit } if n > 0 => s[at % n] ^= 1 << bit,
            Mutation::Set { at, byte } if n > 0 => s[at % n] = *byte,
            Mutation::Insert { at, bytes } => {
                let at = at % (n + 1);
                s.splice(at..at, bytes.iter().copied());
            }
            Mutation::Delete { at, len } if n > 0 => {
                let at = at % n;
                s.drain(at..(at + len).min(n));
            }
            Mutation::Splice {
                at,
                from,
                from_at,
                len,
            } => {
                let src = &corpus[from % corpus.len()];
                if !src.is_empty() {
                    let a = from_at % src.len();
                    let piece = &src[a..(a + len).min(src.len())];
                    let at = at % (n + 1);
                    s.splice(at..at, piece.iter().copied());
                }
            }
            Mutation::Number { nth, value } => {
                let nums = numbers(&s);
                if !nums.is_empty() {
                    let (a, b) = nums[nth % nums.len()];
                    s.splice(a..b, INTERESTING[*value].bytes());
                }
            }
            Mutation::DropLine { nth } => {
                let ls = lines(&s);
                if !ls.is_empty() {
                    let (a, b) = ls[nth % ls.len()];
                    s.drain(a..b);
                }
            }
            Mutation::RepeatLine { nth } => {
                let ls = lines(&s);
                if !ls.is_empty() {
                    let (a, b) = ls[nth % ls.len()];
                    let line = s[a..b].to_vec();
                    s.splice(b..b, line);
                }
            }
            _ => {}
        }
    }
    s
}

/// The config loader: an error or a scenario that runs. True for a valid scenario.
fn config_target(input: &[u8]) -> bool {
    let text = String::from_utf8_lossy(input);
    let Ok((config, scenario)) = platoon_config::parse(&text, Path::new("fuzz.toml")) else {
        return false;
    };
    let resolved = platoon_config::to_toml(&config);
    if let Err(e) = platoon_config::parse(&resolved, Path::new("resolved.toml")) {
        panic!("a resolved config does not parse again: {e}\n{resolved}");
    }
    if scenario.vehicles() <= 256 {
        let mut sim = platoon_sim::FleetSimulation::new(&scenario)
            .unwrap_or_else(|e| panic!("a valid scenario does not build: {e}"));
        for _ in 0..20 {
            if sim.is_done() {
                break;
            }
            sim.step();
        }
    }
    true
}

/// A fleet of two paper platoons, and its states at step 0; signed (`[security]`, every
/// packet verified) or not.
struct PacketBench {
    scenario: platoon_sim::Scenario,
    num: Numbering,
    states: Vec<State>,
    signed: bool,
}

impl PacketBench {
    fn new(signed: bool) -> Self {
        let mut text = platoon_config::PAPER_TOML.replace(
            "[attack]",
            "[fleet]\nplatoons = 2\ngap_m = 200.0\n\n[attack]",
        );
        if signed {
            text.push_str("\n[security]\npolicy = \"every\"\n");
        }
        let (_, scenario) =
            platoon_config::parse(&text, Path::new("fleet.toml")).expect("the fuzz fleet parses");
        let num = Numbering::of(&scenario);
        let states = scenario
            .replicas()
            .iter()
            .flat_map(|r| r.initial.clone())
            .collect();
        Self {
            scenario,
            num,
            states,
            signed,
        }
    }

    /// What every controller's seals counted so far: signatures verified, refusals.
    fn sealed(controllers: &[Box<dyn Controller>]) -> (u64, u64) {
        controllers
            .iter()
            .filter_map(|c| c.seals())
            .fold((0, 0), |(v, r), s| (v + s.verified, r + s.refused_total()))
    }

    /// Items of an rx batch from raw bytes (every bit pattern is a valid `LinkPacket`).
    fn items(bytes: &[u8]) -> Vec<LinkPacket> {
        let size = std::mem::size_of::<LinkPacket>();
        bytes
            .chunks_exact(size)
            .map(|c| {
                // SAFETY: LinkPacket is repr(C) of integers and floats only, so any bytes of its
                // size are a valid value; read_unaligned copies from the unaligned slice.
                unsafe { std::ptr::read_unaligned(c.as_ptr() as *const LinkPacket) }
            })
            .collect()
    }

    /// True when some packet reached an estimator.
    fn run(&self, input: &[u8]) -> bool {
        let states_size = std::mem::size_of::<VehicleState>();
        let plant: Vec<VehicleState> = input
            .chunks_exact(states_size)
            .map(|c| {
                // SAFETY: as above, VehicleState is repr(C) of integers and floats.
                unsafe { std::ptr::read_unaligned(c.as_ptr() as *const VehicleState) }
            })
            .collect();
        let _ = states_from_wire(&plant, self.num.vehicles());

        let k0 = u64::from(input.first().copied().unwrap_or(0));
        let rest = input.get(1..).unwrap_or(&[]);
        let half = rest.len() / 2;
        let n1 = self.num.per_platoon;
        let mut controllers: Vec<Box<dyn Controller>> = self
            .scenario
            .replicas()
            .iter()
            .map(|r| {
                platoon_control::build(&r.control, &r.topology, &r.initial)
                    .expect("the paper's controllers build")
            })
            .collect();
        let mut deliveries: Vec<Vec<Delivery>> = vec![Vec::new(); self.num.platoons];
        let mut jammed = vec![false; self.num.vehicles()];
        let mut accepted = false;
        for (k, batch) in [(k0, &rest[..half]), (k0 + 1, &rest[half..])] {
            let items = Self::items(batch);
            deliveries_from_wire(&items, self.num, &mut deliveries, &mut jammed);
            let delivered: usize = deliveries.iter().map(Vec::len).sum();
            let before: u64 = controllers.iter().map(|c| c.rejected().total()).sum();
            let (verified, refused) = Self::sealed(&controllers);
            for (j, c) in controllers.iter_mut().enumerate() {
                let range = j * n1..(j + 1) * n1;
                let mut tx: Vec<Packet> = Vec::new();
                c.transmit(k, &self.states[range.clone()], &mut tx);
                let u = c.receive(
                    k,
                    &self.states[range.clone()],
                    &deliveries[j],
                    &jammed[range],
                );
                assert!(
                    u.iter().all(|x| x.is_finite()),
                    "platoon {j} step {k}: a command is not finite: {u:?}"
                );
            }
            let after: u64 = controllers.iter().map(|c| c.rejected().total()).sum();
            let (verified_after, refused_after) = Self::sealed(&controllers);
            let by_seal = refused_after - refused;
            assert!(
                after - before + by_seal <= delivered as u64,
                "more refusals than deliveries"
            );
            if self.signed {
                // Every delivery's seal is checked first: verified, or refused with a reason.
                assert_eq!(
                    verified_after - verified + by_seal,
                    delivered as u64,
                    "step {k}: a delivery neither verified nor refused by its seal"
                );
            }
            accepted |= after - before + by_seal < delivered as u64;
        }
        accepted
    }
}

/// The bytes of a repr(C) plain-data wire item.
fn raw<T>(it: &T) -> &[u8] {
    // SAFETY: reading the bytes of a repr(C) plain-data struct (integers, floats, bytes).
    unsafe { std::slice::from_raw_parts((it as *const T).cast::<u8>(), std::mem::size_of::<T>()) }
}

/// A change aimed at the security header of one item of an rx batch (item `item` modulo the
/// items the target reads).
#[derive(Debug, Clone)]
enum SealMutation {
    /// `seal_len` set to `len`: 0 (no seal), within the buffer, or beyond it.
    Len { item: usize, len: u32 },
    /// The seal cut to at most `keep` bytes: a truncated signature or certificate.
    Truncate { item: usize, keep: u8 },
    /// The seal replaced by random bytes (at most the buffer's).
    Random { item: usize, bytes: Vec<u8> },
    /// One bit of the seal flipped.
    Flip { item: usize, at: u8, bit: u8 },
    /// The seal replaced by one made elsewhere ([`SealBench::forged`]).
    Forged { item: usize, which: usize },
}

fn seal_mutation() -> impl Strategy<Value = SealMutation> {
    let item = any::<usize>();
    let len = prop_oneof![
        0u32..=200,
        Just(V2vPacket::SEAL_CAPACITY as u32 + 1),
        Just(u32::MAX),
        any::<u32>(),
    ];
    prop_oneof![
        (item, len).prop_map(|(item, len)| SealMutation::Len { item, len }),
        (item, any::<u8>()).prop_map(|(item, keep)| SealMutation::Truncate { item, keep }),
        (
            item,
            prop::collection::vec(any::<u8>(), 0..=V2vPacket::SEAL_CAPACITY)
        )
            .prop_map(|(item, bytes)| SealMutation::Random { item, bytes }),
        (item, any::<u8>(), 0u8..8).prop_map(|(item, at, bit)| SealMutation::Flip {
            item,
            at,
            bit
        }),
        (item, any::<usize>()).prop_map(|(item, which)| SealMutation::Forged { item, which }),
    ]
}

/// Where `seal_len` and `seal` of an rx item are, from the item's start.
const SEAL_LEN_AT: usize =
    std::mem::offset_of!(LinkPacket, packet) + std::mem::offset_of!(V2vPacket, seal_len);
const SEAL_AT: usize =
    std::mem::offset_of!(LinkPacket, packet) + std::mem::offset_of!(V2vPacket, seal);

/// The signed fleet of [`PacketBench`] and seals made elsewhere, for the `seals` target.
struct SealBench {
    bench: PacketBench,
    /// Each with the refusal it stands for on a genuine packet of the fleet.
    forged: Vec<(Vec<u8>, platoon_security::Refusal)>,
}

impl SealBench {
    fn new() -> Self {
        use platoon_control::security::{Sealing, SecurityParams};
        use platoon_security::Refusal;
        // Two packets of vehicle 1 sealed by `params`' keys: the first carries the signer's
        // certificate, the second its digest.
        let two = |params: SecurityParams| {
            let mut sealing = Sealing::new(params, 5, 0.01);
            let mut out = [0, 1].map(|k| {
                Packet::beacon(
                    platoon_model::VehicleId(1),
                    k as u32 + 1,
                    k,
                    State::new(0.0, 20.0, 0.0),
                )
            });
            for (k, p) in out.iter_mut().enumerate() {
                sealing.seal(k as u64, std::slice::from_mut(p));
            }
            out.map(|p| p.seal.expect("sealed").as_bytes().to_vec())
        };
        let other_root = two(SecurityParams {
            seed: 99,
            ..SecurityParams::default()
        });
        // The fleet's PKI, a pseudonym none of its vehicles holds.
        let stranger = two(SecurityParams {
            platoon: 7,
            ..SecurityParams::default()
        });
        let own = two(SecurityParams::default());
        let mut altered = own[0].clone();
        // The last byte of the certificate (its issuer's signature).
        altered[2 + 8 + 121] ^= 0x01;
        let cut = own[1][..own[1].len() - 5].to_vec();
        Self {
            bench: PacketBench::new(true),
            forged: vec![
                (other_root[0].clone(), Refusal::ForeignRoot),
                (other_root[1].clone(), Refusal::UnknownCertificate),
                (stranger[1].clone(), Refusal::UnknownCertificate),
                (stranger[0].clone(), Refusal::BadSignature),
                (altered, Refusal::BadCertificateSignature),
                (cut, Refusal::Truncated),
            ],
        }
    }

    /// Applies `muts` to the rx items of `input` as [`PacketBench::run`] reads them.
    fn aim(&self, input: &mut [u8], muts: &[SealMutation]) {
        let size = std::mem::size_of::<LinkPacket>();
        let half = input.len().saturating_sub(1) / 2;
        let starts: Vec<usize> = [1, 1 + half]
            .into_iter()
            .flat_map(|from| (0..half / size).map(move |i| from + i * size))
            .collect();
        if starts.is_empty() {
            return;
        }
        let len_of = |input: &[u8], at: usize| {
            let mut w = [0; 4];
            w.copy_from_slice(&input[at + SEAL_LEN_AT..at + SEAL_LEN_AT + 4]);
            u32::from_ne_bytes(w)
        };
        let put = |input: &mut [u8], at: usize, seal: &[u8]| {
            let buffer = &mut input[at + SEAL_AT..at + SEAL_AT + V2vPacket::SEAL_CAPACITY];
            buffer.fill(0);
            buffer[..seal.len()].copy_from_slice(seal);
            input[at + SEAL_LEN_AT..at + SEAL_LEN_AT + 4]
                .copy_from_slice(&(seal.len() as u32).to_ne_bytes());
        };
        for m in muts {
            match m {
                SealMutation::Len { item, len } => {
                    let at = starts[item % starts.len()] + SEAL_LEN_AT;
                    input[at..at + 4].copy_from_slice(&len.to_ne_bytes());
                }
                SealMutation::Truncate { item, keep } => {
                    let at = starts[item % starts.len()];
                    let len = len_of(input, at).min(u32::from(*keep));
                    input[at + SEAL_LEN_AT..at + SEAL_LEN_AT + 4]
                        .copy_from_slice(&len.to_ne_bytes());
                }
                SealMutation::Random { item, bytes } => {
                    put(input, starts[item % starts.len()], bytes);
                }
                SealMutation::Flip { item, at, bit } => {
                    let i = starts[item % starts.len()]
                        + SEAL_AT
                        + usize::from(*at) % V2vPacket::SEAL_CAPACITY;
                    input[i] ^= 1 << bit;
                }
                SealMutation::Forged { item, which } => {
                    let seal = &self.forged[which % self.forged.len()].0;
                    put(input, starts[item % starts.len()], seal);
                }
            }
        }
    }

    fn run(&self, input: &[u8]) -> bool {
        self.bench.run(input)
    }
}

fn seed_corpus(which: CorpusOf) -> Result<()> {
    if which != CorpusOf::Seals {
        seed_packets(&PacketBench::new(false), "packets")?;
    }
    if which != CorpusOf::Packets {
        seed_packets(&PacketBench::new(true), "seals")?;
    }
    Ok(())
}

/// Which corpus `seed-corpus` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum CorpusOf {
    /// fuzz/corpus/packets/.
    Packets,
    /// fuzz/corpus/seals/.
    Seals,
    /// Both.
    Both,
}

/// Real rx batches of `bench`'s fleet into fuzz/corpus/`name`/: unsigned, a step's batch twice
/// (steps 0, 150, ..., then busy ones); signed, the batches of steps k and k + 1 after each
/// step k at which a sender attached its certificate (the receivers learn it at k and verify
/// digests at k + 1), within the first 250 steps (the first byte is then k itself: the
/// packets are fresh).
fn seed_packets(bench: &PacketBench, name: &str) -> Result<()> {
    let dir = root().join("corpus").join(name);
    std::fs::create_dir_all(&dir)?;
    let mut sim = platoon_sim::FleetSimulation::new(&bench.scenario)?;
    let mut written = 0;
    // Real broadcasts of the paper's fleet, as the controller node puts them on the wire.
    let mut controllers: Vec<Box<dyn Controller>> = bench
        .scenario
        .replicas()
        .iter()
        .map(|r| platoon_control::build(&r.control, &r.topology, &r.initial))
        .collect::<Result<_, _>>()?;
    let mut last: Vec<LinkPacket> = Vec::new();
    for k in 0..1200u64 {
        let rows = sim.step().to_vec();
        let states: Vec<State> = rows.iter().map(|r| State::new(r.p, r.v, r.a)).collect();
        let mut batch: Vec<LinkPacket> = Vec::new();
        for (j, (c, r)) in controllers
            .iter_mut()
            .zip(bench.scenario.replicas())
            .enumerate()
        {
            let n1 = bench.num.per_platoon;
            let mut tx = Vec::new();
            c.transmit(k, &states[j * n1..(j + 1) * n1], &mut tx);
            for p in &tx {
                let packet = packet_to_wire(p, 0, j, bench.num);
                for &rcv in r.topology.out_neighbours(p.sender) {
                    batch.push(LinkPacket {
                        receiver: bench.num.global(j, rcv),
                        kind: LinkPacket::DELIVERY,
                        packet,
                    });
                }
            }
        }
        let certificate = |b: &[LinkPacket]| {
            b.iter()
                .any(|it| it.packet.seal_len as usize == V2vPacket::SEAL_CAPACITY)
        };
        let pair = if !bench.signed {
            (k % 150 == 0 || (k > 1000 && batch.len() > 10)).then(|| (k, batch.clone()))
        } else {
            (k > 0 && k < 250 && certificate(&last) && !batch.is_empty())
                .then(|| (k - 1, std::mem::take(&mut last)))
        };
        if let Some((k0, first)) = pair.filter(|_| written < 12) {
            let mut bytes = vec![(k0 % 251) as u8];
            for it in first.iter().chain(batch.iter()) {
                bytes.extend_from_slice(raw(it));
            }
            std::fs::write(dir.join(format!("step{k0:04}.bin")), bytes)?;
            written += 1;
        }
        last = batch;
    }
    println!("wrote {written} rx batches to {}", dir.display());
    Ok(())
}

/// Runs `target` on `iterations` mutated inputs; `target` says whether the input got past the
/// checks (a valid scenario, an accepted packet), which the report counts.
fn fuzz(
    name: &str,
    corpus: Vec<Vec<u8>>,
    iterations: u32,
    seed: u64,
    target: &dyn Fn(&[u8]) -> bool,
) -> Result<()> {
    fuzz_aimed(name, corpus, iterations, seed, Just(()), &|_, _| {}, target)
}

/// [`fuzz`] with mutations drawn from `aimed` and applied by `aim` after the byte mutations
/// (mutations that know the input's structure).
fn fuzz_aimed<A: Strategy>(
    name: &str,
    corpus: Vec<Vec<u8>>,
    iterations: u32,
    seed: u64,
    aimed: A,
    aim: &dyn Fn(&mut Vec<u8>, &A::Value),
    target: &dyn Fn(&[u8]) -> bool,
) -> Result<()> {
    if corpus.is_empty() {
        bail!("the {name} corpus is empty");
    }
    let config = Config {
        cases: iterations,
        failure_persistence: None,
        max_shrink_iters: 5_000,
        ..Config::default()
    };
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &key));
    let strategy = (
        0..corpus.len(),
        prop::collection::vec(mutation(), 0..8),
        aimed,
    );
    let input = |i: usize, muts: &[Mutation], aimed: &A::Value| {
        let mut input = mutate(&corpus[i], muts, &corpus);
        aim(&mut input, aimed);
        input
    };
    let started = Instant::now();
    let deep = std::cell::Cell::new(0u64);
    let result = runner.run(&strategy, |(i, muts, aimed)| {
        let input = input(i, &muts, &aimed);
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| target(&input)))
            .map(|passed| deep.set(deep.get() + u64::from(passed)))
            .map_err(|p| {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "a panic".into());
                TestCaseError::fail(msg)
            })
    });
    let secs = started.elapsed().as_secs_f64();
    match result {
        Ok(()) => {
            println!(
                "{name}: {iterations} executions, 0 crashes, {} got past the checks, {secs:.1} s ({:.0} executions/s), seed {seed}",
                deep.get(),
                f64::from(iterations) / secs
            );
            Ok(())
        }
        Err(TestError::Fail(why, (i, muts, aimed))) => {
            let input = input(i, &muts, &aimed);
            let dir = root().join("crashes");
            std::fs::create_dir_all(&dir)?;
            let file = dir.join(format!("{name}-seed{seed}.bin"));
            std::fs::write(&file, &input)?;
            bail!(
                "{name}: crash after shrinking: {why}; the input is in {}",
                file.display()
            )
        }
        Err(TestError::Abort(why)) => bail!("{name}: aborted: {why}"),
    }
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    // Panics are the findings: keep their messages out of the way until the end.
    std::panic::set_hook(Box::new(|_| {}));
    let repo = root().join("..");
    let config_corpus = || -> Result<Vec<Vec<u8>>> {
        let mut c = read_dir(&repo.join("configs"), Some("toml"))?;
        c.extend(read_dir(&root().join("corpus/config"), None)?);
        Ok(c)
    };
    let packets = PacketBench::new(false);
    let packet_corpus = || read_dir(&root().join("corpus/packets"), None);
    let seals = SealBench::new();
    let seal_corpus = || read_dir(&root().join("corpus/seals"), None);
    let seal_target = |b: &[u8]| seals.run(b);
    let seal_fuzz = |iterations: u32| -> Result<()> {
        fuzz_aimed(
            "seals",
            seal_corpus()?,
            iterations,
            cli.seed,
            prop::collection::vec(seal_mutation(), 0..4),
            &|input, muts| seals.aim(input, muts),
            &seal_target,
        )
    };
    match cli.target {
        Target::Config => fuzz(
            "config",
            config_corpus()?,
            cli.iterations,
            cli.seed,
            &config_target,
        ),
        Target::Packets => fuzz(
            "packets",
            packet_corpus()?,
            cli.iterations,
            cli.seed,
            &|b| packets.run(b),
        ),
        Target::Seals => seal_fuzz(cli.iterations),
        Target::All => {
            fuzz(
                "config",
                config_corpus()?,
                cli.iterations,
                cli.seed,
                &config_target,
            )?;
            fuzz(
                "packets",
                packet_corpus()?,
                cli.iterations,
                cli.seed,
                &|b| packets.run(b),
            )?;
            // An execution signs and verifies (about 0.1 ms a signature): a tenth as many.
            seal_fuzz((cli.iterations / 10).max(1))
        }
        Target::SeedCorpus { of } => seed_corpus(of),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_control::security::{Sealing, SecurityParams};

    /// Each seal the `seals` target puts in a packet's place is refused for the reason it
    /// stands for, on a packet of the fleet's first platoon (another packet than the one the
    /// seals were made for: a pseudonym of the fleet's PKI may sign any packet).
    #[test]
    fn the_forged_seals_are_refused_for_their_reasons() {
        let bench = SealBench::new();
        let mut receiver = Sealing::new(SecurityParams::default(), 5, 0.01);
        for (seal, why) in &bench.forged {
            let mut packet = Packet::beacon(
                platoon_model::VehicleId(1),
                1,
                0,
                State::new(3.0, 21.0, 0.0),
            );
            packet.seal = platoon_v2v::Seal::new(seal);
            let d = Delivery {
                receiver: platoon_model::VehicleId(2),
                packet,
            };
            receiver.begin_step();
            assert_eq!(receiver.screen(0, &d), Err(*why), "{}", why.name());
        }
    }

    /// The aimed mutations write where the target reads a seal: an item's `seal_len`.
    #[test]
    fn aimed_mutations_write_the_seal_fields() {
        let bench = SealBench::new();
        let size = std::mem::size_of::<LinkPacket>();
        let mut input = vec![0u8; 1 + 2 * size];
        bench.aim(&mut input, &[SealMutation::Forged { item: 1, which: 0 }]);
        let items = PacketBench::items(&input[1 + size..]);
        assert_eq!(items[0].packet.seal_len as usize, bench.forged[0].0.len());
        assert_eq!(
            &items[0].packet.seal[..bench.forged[0].0.len()],
            &bench.forged[0].0[..]
        );
        bench.aim(&mut input, &[SealMutation::Len { item: 0, len: 500 }]);
        assert_eq!(
            PacketBench::items(&input[1..1 + size])[0].packet.seal_len,
            500
        );
    }
}
