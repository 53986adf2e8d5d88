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
use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use platoon_control::{Controller, Delivery, Packet};
use platoon_model::State;
use platoon_runtime::session::{deliveries_from_wire, packet_to_wire, states_from_wire, Numbering};
use platoon_wire::{LinkPacket, VehicleState};
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
    /// Both targets.
    All,
    /// Writes real rx batches of the paper scenario into fuzz/corpus/packets/.
    SeedCorpus,
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

/// A fleet of two paper platoons, and its states at step 0.
struct PacketBench {
    scenario: platoon_sim::Scenario,
    num: Numbering,
    states: Vec<State>,
}

impl PacketBench {
    fn new() -> Self {
        let text = platoon_config::PAPER_TOML.replace(
            "[attack]",
            "[fleet]\nplatoons = 2\ngap_m = 200.0\n\n[attack]",
        );
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
        }
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
            assert!(
                after - before <= delivered as u64,
                "more refusals than deliveries"
            );
            accepted |= after - before < delivered as u64;
        }
        accepted
    }
}

fn seed_corpus() -> Result<()> {
    let bench = PacketBench::new();
    let dir = root().join("corpus/packets");
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
        if written < 12 && (k % 150 == 0 || (k > 1000 && batch.len() > 10)) {
            let mut bytes = vec![(k % 251) as u8];
            for it in batch.iter().chain(batch.iter()) {
                // SAFETY: reading the bytes of a repr(C) plain-data struct.
                let raw = unsafe {
                    std::slice::from_raw_parts(
                        (it as *const LinkPacket).cast::<u8>(),
                        std::mem::size_of::<LinkPacket>(),
                    )
                };
                bytes.extend_from_slice(raw);
            }
            std::fs::write(dir.join(format!("step{k:04}.bin")), bytes)?;
            written += 1;
        }
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
    let strategy = (0..corpus.len(), prop::collection::vec(mutation(), 0..8));
    let started = Instant::now();
    let deep = std::cell::Cell::new(0u64);
    let result = runner.run(&strategy, |(i, muts)| {
        let input = mutate(&corpus[i], &muts, &corpus);
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
        Err(TestError::Fail(why, (i, muts))) => {
            let input = mutate(&corpus[i], &muts, &corpus);
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
    let packets = PacketBench::new();
    let packet_corpus = || read_dir(&root().join("corpus/packets"), None);
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
            )
        }
        Target::SeedCorpus => seed_corpus(),
    }
}
