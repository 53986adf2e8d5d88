//! `platoon bench security`: what signed V2V (`[security]`, docs/security.md) costs a run, as a
//! ratio to the same run unsigned, measured side by side.
//!
//! Method: every case runs as a pair, unsigned and signed (the same config with a `[security]`
//! table), one right after the other, the pair's order alternating from round to round (this
//! VM's speed drifts over minutes: a ratio of neighbours cancels most of it). A round's ratio is
//! signed over unsigned of the same round; the tables give the median over the rounds of each
//! figure and of the ratios. Figures: the wall time of `platoon run` (start-up included), the
//! step's p50 from timing.json (in process: a step's compute; over iceoryx2: publish to publish),
//! and in the signed run timing.json's `sign` and `verify` stages (their percentiles per step)
//! and summary.json's counts. The real-time factor is the step's: `dt` over its p50, as in
//! `platoon bench step`.
//!
//! Cases: (a) the paper's scenario (the embedded configs/paper.toml, 5 vehicles, 55 s) with
//! `policy = "every"`, on each transport asked for; (b) a fleet on SUMO (platoons of 4
//! followers, `platoon bench step`'s fleet: Table I's platoons on PF on the long highway) with
//! `policy = "on_demand"`, over iceoryx2.
use crate::step::median;
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// What `platoon bench security` measures.
#[derive(Debug, Clone)]
pub struct Security {
    /// Rounds of the paper's scenario (each an unsigned and a signed run per transport).
    pub rounds: u32,
    /// Transports of the paper's scenario: inproc, iceoryx2.
    pub transports: Vec<String>,
    /// Vehicles of the SUMO fleet, a multiple of 5 (0: no fleet case).
    pub fleet_vehicles: usize,
    /// Simulated seconds of the fleet's runs.
    pub fleet_seconds: f64,
    /// Rounds of the fleet (each an unsigned and a signed run).
    pub fleet_rounds: u32,
    /// Output directory; None: runs/bench-security.
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    pub force: bool,
}

impl Default for Security {
    fn default() -> Self {
        Self {
            rounds: 5,
            transports: vec!["inproc".into(), "iceoryx2".into()],
            fleet_vehicles: 1000,
            fleet_seconds: 5.0,
            fleet_rounds: 3,
            out: None,
            force: false,
        }
    }
}

/// One run of a case.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SecurityRow {
    /// The round (1, 2, ...), or 0 for the median over the rounds.
    pub round: u32,
    /// `paper` or `fleet`.
    pub case: String,
    pub transport: String,
    pub vehicles: usize,
    /// `none` (unsigned), `every` or `on_demand`.
    pub policy: String,
    pub steps: u64,
    /// `platoon run`'s wall time, start-up and outputs included (s).
    pub wall_s: f64,
    pub step_p50_us: f64,
    pub step_p99_us: f64,
    /// `dt` over the step's p50.
    pub real_time_factor: f64,
    /// Simulated time over the wall time.
    pub wall_real_time_factor: f64,
    /// timing.json's `sign` and `verify` per step (signed runs only).
    pub sign_p50_us: Option<f64>,
    pub sign_p99_us: Option<f64>,
    pub verify_p50_us: Option<f64>,
    pub verify_p99_us: Option<f64>,
    /// summary.json's `security`: packets signed, signatures verified.
    pub signed: Option<u64>,
    pub verified: Option<u64>,
}

/// A signed run over its unsigned pair: each round's ratio and their median.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SecurityRatio {
    pub case: String,
    pub transport: String,
    pub policy: String,
    /// Signed over unsigned wall time, per round.
    pub wall_rounds: Vec<f64>,
    pub wall_median: f64,
    /// Signed over unsigned step p50, per round.
    pub step_rounds: Vec<f64>,
    pub step_median: f64,
}

/// What `platoon bench security` measured: the medians of every case and the ratios.
pub struct SecurityReport {
    pub rows: Vec<SecurityRow>,
    pub ratios: Vec<SecurityRatio>,
}

/// A case: its name, transport, vehicles, simulated seconds and its two configs.
struct Case {
    name: &'static str,
    transport: String,
    vehicles: usize,
    seconds: f64,
    policy: &'static str,
    plain: PathBuf,
    signed: PathBuf,
}

/// `text` with a `[security]` table of `policy` at its end.
fn signed(text: &str, policy: &str) -> String {
    format!("{text}\n[security]\npolicy = \"{policy}\"\n")
}

/// Runs `platoon bench security`.
pub fn security(a: Security) -> Result<SecurityReport> {
    for t in &a.transports {
        if !matches!(t.as_str(), "inproc" | "iceoryx2") {
            bail!("unknown transport {t:?} in --transports: use inproc or iceoryx2");
        }
    }
    if a.rounds == 0 || a.fleet_rounds == 0 {
        bail!("--rounds and --fleet-rounds must be at least 1");
    }
    if !a.fleet_vehicles.is_multiple_of(5) {
        bail!("--fleet-vehicles must be a multiple of 5 (platoons of 4 followers), e.g. 1000");
    }
    if !(a.fleet_seconds.is_finite() && a.fleet_seconds >= 0.1) {
        bail!("--fleet-seconds must be at least 0.1");
    }
    let dir = crate::create_out(a.out, "bench-security", a.force)?;
    let exe = platoon_app::platoon_program()?;
    let write = |name: &str, text: &str| -> Result<PathBuf> {
        let p = dir.path(name);
        std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))?;
        Ok(p)
    };
    let paper = platoon_config::PAPER_TOML;
    let (paper_plain, paper_signed) = (
        write("paper.toml", paper)?,
        write("paper-signed.toml", &signed(paper, "every"))?,
    );
    let paper_seconds = platoon_config::parse(paper, Path::new("paper.toml"))?
        .1
        .duration();
    let mut cases: Vec<(Case, u32)> = a
        .transports
        .iter()
        .map(|t| {
            let case = Case {
                name: "paper",
                transport: t.clone(),
                vehicles: 5,
                seconds: paper_seconds,
                policy: "every",
                plain: paper_plain.clone(),
                signed: paper_signed.clone(),
            };
            (case, a.rounds)
        })
        .collect();
    if a.fleet_vehicles > 0 {
        let followers = a.fleet_vehicles / 5 * 4;
        let text = crate::step::fleet_config(followers, a.fleet_seconds, true, false)?;
        let case = Case {
            name: "fleet",
            transport: "iceoryx2".into(),
            vehicles: a.fleet_vehicles,
            seconds: a.fleet_seconds,
            policy: "on_demand",
            plain: write("fleet.toml", &text)?,
            signed: write("fleet-signed.toml", &signed(&text, "on_demand"))?,
        };
        cases.push((case, a.fleet_rounds));
    }
    let mut rows = Vec::new();
    let most = cases.iter().map(|c| c.1).max().unwrap_or(0);
    for round in 1..=most {
        for (case, rounds) in &cases {
            if round > *rounds {
                continue;
            }
            // Unsigned first in odd rounds, signed first in even ones.
            let order = if round % 2 == 1 {
                [false, true]
            } else {
                [true, false]
            };
            for is_signed in order {
                let name = format!(
                    "{}-{}-{}",
                    case.name,
                    case.transport,
                    if is_signed { "signed" } else { "plain" }
                );
                println!("round {round}: {name}");
                let out = dir.path(&name);
                let config = if is_signed { &case.signed } else { &case.plain };
                let wall = run_case(&exe, config, &out, &case.transport)
                    .with_context(|| format!("the {name} case, round {round}"))?;
                rows.push(row(round, case, is_signed, wall, &out)?);
            }
        }
    }
    let ratios = ratios(&rows);
    let medians = median_rows(&rows);
    let mut w = csv::Writer::from_writer(dir.writer("security.csv")?);
    for r in &rows {
        w.serialize(r)?;
    }
    w.flush()?;
    dir.write(
        "security.json",
        (serde_json::to_string_pretty(&serde_json::json!({
            "rounds": a.rounds,
            "fleet_rounds": a.fleet_rounds,
            "machine_cores": crate::machine::cores(),
            "commit": crate::machine::commit(),
            "rows": medians,
            "ratios": ratios,
            "round_rows": rows,
        }))? + "\n")
            .as_bytes(),
    )?;
    let path = dir.commit()?;
    print!("{}", table(&medians, &ratios));
    println!("outputs: {}", path.display());
    Ok(SecurityReport {
        rows: medians,
        ratios,
    })
}

/// `platoon run` of `config` into `out` over `transport`; its wall time (s).
fn run_case(exe: &Path, config: &Path, out: &Path, transport: &str) -> Result<f64> {
    let started = Instant::now();
    let o = Command::new(exe)
        .args(["run", config.to_str().unwrap_or_default()])
        .args(["--no-plots", "--force", "--transport", transport, "--out"])
        .arg(out)
        .env("PLATOON_STEP_TIMEOUT", "60")
        .output()
        .context("starting platoon run")?;
    let wall = started.elapsed().as_secs_f64();
    if !o.status.success() {
        bail!("{}", String::from_utf8_lossy(&o.stderr).trim());
    }
    Ok(wall)
}

/// The row of one run from its timing.json and summary.json.
fn row(round: u32, case: &Case, is_signed: bool, wall_s: f64, out: &Path) -> Result<SecurityRow> {
    let read = |f: &str| -> Result<serde_json::Value> {
        let p = out.join(f);
        let text =
            std::fs::read_to_string(&p).with_context(|| format!("{} missing", p.display()))?;
        Ok(serde_json::from_str(&text)?)
    };
    let (timing, summary) = (read("timing.json")?, read("summary.json")?);
    let us = |stage: &str, q: &str| timing[stage][q].as_f64();
    let step_p50 = us("step", "p50_us").unwrap_or(f64::NAN);
    let dt = 0.01;
    Ok(SecurityRow {
        round,
        case: case.name.into(),
        transport: case.transport.clone(),
        vehicles: case.vehicles,
        policy: if is_signed { case.policy } else { "none" }.into(),
        steps: (case.seconds / dt).round() as u64 + 1,
        wall_s,
        step_p50_us: step_p50,
        step_p99_us: us("step", "p99_us").unwrap_or(f64::NAN),
        real_time_factor: dt * 1e6 / step_p50,
        wall_real_time_factor: case.seconds / wall_s,
        sign_p50_us: us("sign", "p50_us"),
        sign_p99_us: us("sign", "p99_us"),
        verify_p50_us: us("verify", "p50_us"),
        verify_p99_us: us("verify", "p99_us"),
        signed: summary["security"]["signed"].as_u64(),
        verified: summary["security"]["verified"].as_u64(),
    })
}

/// Each signed run over its unsigned pair of the same round, per case and transport.
fn ratios(rows: &[SecurityRow]) -> Vec<SecurityRatio> {
    let mut out: Vec<SecurityRatio> = Vec::new();
    for s in rows.iter().filter(|r| r.policy != "none") {
        let Some(p) = rows.iter().find(|r| {
            r.policy == "none"
                && r.round == s.round
                && r.case == s.case
                && r.transport == s.transport
        }) else {
            continue;
        };
        let i = match out
            .iter()
            .position(|r| r.case == s.case && r.transport == s.transport)
        {
            Some(i) => i,
            None => {
                out.push(SecurityRatio {
                    case: s.case.clone(),
                    transport: s.transport.clone(),
                    policy: s.policy.clone(),
                    wall_rounds: Vec::new(),
                    wall_median: f64::NAN,
                    step_rounds: Vec::new(),
                    step_median: f64::NAN,
                });
                out.len() - 1
            }
        };
        out[i].wall_rounds.push(s.wall_s / p.wall_s);
        out[i].step_rounds.push(s.step_p50_us / p.step_p50_us);
    }
    for r in &mut out {
        r.wall_median = median(r.wall_rounds.clone());
        r.step_median = median(r.step_rounds.clone());
    }
    out
}

/// One row per case, transport and policy: the median over the rounds of every figure.
fn median_rows(rows: &[SecurityRow]) -> Vec<SecurityRow> {
    let mut out: Vec<SecurityRow> = Vec::new();
    for r in rows {
        let same = |o: &SecurityRow| {
            o.case == r.case && o.transport == r.transport && o.policy == r.policy
        };
        if out.iter().any(same) {
            continue;
        }
        let all: Vec<&SecurityRow> = rows.iter().filter(|o| same(o)).collect();
        let m = |f: &dyn Fn(&SecurityRow) -> f64| median(all.iter().map(|o| f(o)).collect());
        let mo = |f: &dyn Fn(&SecurityRow) -> Option<f64>| {
            let xs: Vec<f64> = all.iter().filter_map(|o| f(o)).collect();
            (!xs.is_empty()).then(|| median(xs))
        };
        out.push(SecurityRow {
            round: 0,
            wall_s: m(&|o| o.wall_s),
            step_p50_us: m(&|o| o.step_p50_us),
            step_p99_us: m(&|o| o.step_p99_us),
            real_time_factor: m(&|o| o.real_time_factor),
            wall_real_time_factor: m(&|o| o.wall_real_time_factor),
            sign_p50_us: mo(&|o| o.sign_p50_us),
            sign_p99_us: mo(&|o| o.sign_p99_us),
            verify_p50_us: mo(&|o| o.verify_p50_us),
            verify_p99_us: mo(&|o| o.verify_p99_us),
            ..r.clone()
        });
    }
    out
}

/// The report's tables (markdown): the medians, then the ratios.
pub(crate) fn table(rows: &[SecurityRow], ratios: &[SecurityRatio]) -> String {
    let mut md = String::new();
    let f = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |v| format!("{v:.1}"));
    let n = |x: Option<u64>| x.map_or_else(|| "-".to_string(), |v| v.to_string());
    let _ = writeln!(
        md,
        "| case | transport | vehicles | policy | wall (s) | step p50 (µs) | step p99 (µs) | real-time factor (step) | real-time factor (wall) | sign p50 / p99 (µs per step) | verify p50 / p99 (µs per step) | packets signed | signatures verified |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {:.2} | {:.1} | {:.1} | {:.2} | {:.2} | {} / {} | {} / {} | {} | {} |",
            r.case,
            r.transport,
            r.vehicles,
            r.policy,
            r.wall_s,
            r.step_p50_us,
            r.step_p99_us,
            r.real_time_factor,
            r.wall_real_time_factor,
            f(r.sign_p50_us),
            f(r.sign_p99_us),
            f(r.verify_p50_us),
            f(r.verify_p99_us),
            n(r.signed),
            n(r.verified),
        );
    }
    let _ = writeln!(
        md,
        "\n| case | transport | policy | signed / unsigned, wall (median; rounds) | signed / unsigned, step p50 (median; rounds) |\n|---|---|---|---|---|"
    );
    let list = |xs: &[f64]| {
        xs.iter()
            .map(|x| format!("{x:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    for r in ratios {
        let _ = writeln!(
            md,
            "| {} | {} | {} | **{:.2}** ({}) | **{:.2}** ({}) |",
            r.case,
            r.transport,
            r.policy,
            r.wall_median,
            list(&r.wall_rounds),
            r.step_median,
            list(&r.step_rounds),
        );
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(round: u32, policy: &str, wall_s: f64, step: f64) -> SecurityRow {
        SecurityRow {
            round,
            case: "paper".into(),
            transport: "inproc".into(),
            vehicles: 5,
            policy: policy.into(),
            steps: 5501,
            wall_s,
            step_p50_us: step,
            step_p99_us: step,
            real_time_factor: 1e4 / step,
            wall_real_time_factor: 55.0 / wall_s,
            sign_p50_us: None,
            sign_p99_us: None,
            verify_p50_us: None,
            verify_p99_us: None,
            signed: None,
            verified: None,
        }
    }

    /// A ratio is a signed run over the unsigned run of its own round; the medians are over
    /// the rounds.
    #[test]
    fn ratios_pair_runs_of_the_same_round() {
        let rows = [
            run(1, "none", 1.0, 2.0),
            run(1, "every", 4.0, 20.0),
            run(2, "every", 9.0, 60.0),
            run(2, "none", 3.0, 3.0),
            run(3, "none", 2.0, 1.0),
            run(3, "every", 10.0, 50.0),
        ];
        let r = ratios(&rows);
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].wall_rounds, vec![4.0, 3.0, 5.0]);
        assert_eq!(r[0].wall_median, 4.0);
        assert_eq!(r[0].step_rounds, vec![10.0, 20.0, 50.0]);
        assert_eq!(r[0].step_median, 20.0);
        let m = median_rows(&rows);
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].policy.as_str(), m[0].wall_s), ("none", 2.0));
        assert_eq!((m[1].policy.as_str(), m[1].step_p50_us), ("every", 50.0));
        assert!(table(&m, &r).contains("**4.00** (4.00, 3.00, 5.00)"));
    }

    #[test]
    fn a_signed_config_has_the_table_at_its_end() {
        let text = signed(platoon_config::PAPER_TOML, "on_demand");
        let (_, scenario) = platoon_config::parse(&text, Path::new("s.toml")).unwrap();
        let s = scenario.control.security.expect("[security]");
        assert_eq!(s.policy.name(), "on_demand");
    }
}
