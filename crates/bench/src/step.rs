//! `platoon bench step`: the co-simulation's step cost against the number of followers, by
//! transport and stage, with SUMO-driven peers.
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What `platoon bench step` measures.
#[derive(Debug, Clone)]
pub struct Step {
    /// Numbers of followers (multiples of 4: platoons of 4 followers).
    pub followers: Vec<usize>,
    /// Transports and plants: inproc, native, sumo, native-1cpu, sumo-1cpu, sumo-traffic.
    pub modes: Vec<String>,
    /// Simulated seconds per case.
    pub seconds: f64,
    /// Skip the SUMO-driven peers.
    pub no_peers: bool,
    /// Rounds, the cases interleaved (at least 1).
    pub rounds: u32,
    /// Output directory; None: runs/bench-step.
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    pub force: bool,
}

impl Default for Step {
    fn default() -> Self {
        Self {
            followers: vec![4, 100, 1000],
            modes: [
                "inproc",
                "native",
                "sumo",
                "native-1cpu",
                "sumo-1cpu",
                "sumo-traffic",
            ]
            .map(String::from)
            .to_vec(),
            seconds: 5.0,
            no_peers: false,
            rounds: 3,
            out: None,
            force: false,
        }
    }
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct StepRow {
    /// The round (1, 2, ...), or 0 for the median over the rounds.
    pub round: u32,
    pub mode: String,
    pub followers: usize,
    pub vehicles: usize,
    pub steps: u64,
    pub step_p50_us: f64,
    pub step_p99_us: f64,
    pub real_time_factor: f64,
    pub plant_p50_us: Option<f64>,
    pub controller_p50_us: Option<f64>,
    pub injector_p50_us: Option<f64>,
    pub sumo_step_p50_us: Option<f64>,
    pub bridge_p50_us: Option<f64>,
    /// Peak resident memory of every process of the run (`platoon run` and its nodes), MiB.
    pub peak_rss_mib: Option<f64>,
    /// SUMO's step and the bridge's work for the same SUMO and model in a loop with no
    /// co-simulation around it (`python -m platoon.sumo --tight-loop`).
    pub sumo_step_tight_p50_us: Option<f64>,
    pub bridge_tight_p50_us: Option<f64>,
}

/// One peer of a SUMO case: the same fleet for the same steps, driven by SUMO itself
/// (`bridge/tools/bench_peers.py`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct PeerRow {
    /// The round (1, 2, ...), or 0 for the median over the rounds.
    pub round: u32,
    pub followers: usize,
    pub vehicles: usize,
    /// krauss, plexe_acc, plexe_cacc or floor.
    pub peer: String,
    pub step_p50_us: f64,
    pub step_p90_us: f64,
    pub step_mean_us: f64,
    /// SUMO's `simulationStep` alone (the floor's calls around it left out).
    pub sumo_step_p50_us: f64,
}

/// What `platoon bench step` measured: our cases and their peers (medians over the rounds),
/// and our `sumo` step over each peer's, per round.
pub struct StepReport {
    pub rows: Vec<StepRow>,
    pub peers: Vec<PeerRow>,
    pub ratios: Vec<PeerRatio>,
}

/// Our `sumo` step over a peer's, in each round (the same round's runs, one after the other).
#[derive(Debug, Clone, serde::Serialize)]
pub struct PeerRatio {
    pub followers: usize,
    pub peer: String,
    /// One per round, in order.
    pub rounds: Vec<f64>,
    /// Their median.
    pub median: f64,
}

/// The median of `xs` (NaN when there are none).
pub(crate) fn median(mut xs: Vec<f64>) -> f64 {
    xs.retain(|x| !x.is_nan());
    xs.sort_by(f64::total_cmp);
    match xs.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => xs[n / 2],
        n => 0.5 * (xs[n / 2 - 1] + xs[n / 2]),
    }
}

/// The median over `rows` of a figure some rows may not have.
fn median_of<T>(rows: &[&T], f: impl Fn(&T) -> Option<f64>) -> Option<f64> {
    let xs: Vec<f64> = rows.iter().filter_map(|r| f(r)).collect();
    (!xs.is_empty()).then(|| median(xs))
}

/// `rows` grouped by `key`, the groups in the order their first rows come (a case's or a
/// peer's rows of every round).
fn groups<T, K: PartialEq>(rows: &[T], key: impl Fn(&T) -> K) -> Vec<Vec<&T>> {
    let mut out: Vec<(K, Vec<&T>)> = Vec::new();
    for r in rows {
        let k = key(r);
        match out.iter_mut().find(|(g, _)| *g == k) {
            Some((_, group)) => group.push(r),
            None => out.push((k, vec![r])),
        }
    }
    out.into_iter().map(|(_, group)| group).collect()
}

/// One row per case of the rounds' rows (in the order of the first round): each figure the
/// median over the rounds.
fn median_rows(rounds: &[StepRow]) -> Vec<StepRow> {
    groups(rounds, |r| (r.mode.clone(), r.followers))
        .into_iter()
        .map(|same| {
            let r = same[0];
            let step = median(same.iter().map(|x| x.step_p50_us).collect());
            StepRow {
                round: 0,
                mode: r.mode.clone(),
                followers: r.followers,
                vehicles: r.vehicles,
                steps: r.steps,
                step_p50_us: step,
                step_p99_us: median(same.iter().map(|x| x.step_p99_us).collect()),
                real_time_factor: 0.01 * 1e6 / step,
                plant_p50_us: median_of(&same, |x| x.plant_p50_us),
                controller_p50_us: median_of(&same, |x| x.controller_p50_us),
                injector_p50_us: median_of(&same, |x| x.injector_p50_us),
                sumo_step_p50_us: median_of(&same, |x| x.sumo_step_p50_us),
                bridge_p50_us: median_of(&same, |x| x.bridge_p50_us),
                peak_rss_mib: median_of(&same, |x| x.peak_rss_mib),
                sumo_step_tight_p50_us: median_of(&same, |x| x.sumo_step_tight_p50_us),
                bridge_tight_p50_us: median_of(&same, |x| x.bridge_tight_p50_us),
            }
        })
        .collect()
}

/// The peers' rows of every round as one row per size and peer, each figure the median.
fn median_peers(rounds: &[PeerRow]) -> Vec<PeerRow> {
    groups(rounds, |r| (r.peer.clone(), r.followers))
        .into_iter()
        .map(|same| {
            let r = same[0];
            let m = |f: fn(&PeerRow) -> f64| median(same.iter().map(|x| f(x)).collect());
            PeerRow {
                round: 0,
                followers: r.followers,
                vehicles: r.vehicles,
                peer: r.peer.clone(),
                step_p50_us: m(|x| x.step_p50_us),
                step_p90_us: m(|x| x.step_p90_us),
                step_mean_us: m(|x| x.step_mean_us),
                sumo_step_p50_us: m(|x| x.sumo_step_p50_us),
            }
        })
        .collect()
}

/// Our `sumo` step over each peer's, round by round.
fn peer_ratios(steps: &[StepRow], peers: &[PeerRow]) -> Vec<PeerRatio> {
    groups(peers, |p| (p.peer.clone(), p.followers))
        .into_iter()
        .map(|same| {
            let rounds: Vec<f64> = same
                .iter()
                .map(|q| {
                    steps
                        .iter()
                        .find(|r| {
                            r.mode == "sumo" && r.followers == q.followers && r.round == q.round
                        })
                        .map_or(f64::NAN, |r| r.step_p50_us / q.step_p50_us)
                })
                .collect();
            PeerRatio {
                followers: same[0].followers,
                peer: same[0].peer.clone(),
                median: median(rounds.clone()),
                rounds,
            }
        })
        .collect()
}

/// `bridge/tools/bench_peers.py` on a SUMO case's plant.json: each peer's step, µs.
fn peers(plant_json: &std::path::Path, followers: usize, round: u32) -> Result<Vec<PeerRow>> {
    let python = platoon_app::sumo::ensure_venv()?;
    let o = Command::new(python)
        .arg(platoon_app::sumo::bridge_dir()?.join("tools/bench_peers.py"))
        .arg("--plant-json")
        .arg(plant_json)
        .output()
        .context("starting bridge/tools/bench_peers.py")?;
    if !o.status.success() {
        bail!(
            "bridge/tools/bench_peers.py on {} ended with {}: {}",
            plant_json.display(),
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        );
    }
    let v: serde_json::Value = serde_json::from_slice(&o.stdout)
        .context("bench_peers.py printed something other than its JSON report")?;
    let peers = v
        .as_object()
        .context("bench_peers.py's report is not a JSON object")?;
    peers
        .iter()
        .map(|(peer, r)| {
            let num = |k: &str| {
                r[k].as_f64()
                    .with_context(|| format!("bench_peers.py's report: {peer}.{k} is missing"))
            };
            Ok(PeerRow {
                round,
                followers,
                vehicles: num("vehicles")? as usize,
                peer: peer.clone(),
                step_p50_us: num("p50_us")?,
                step_p90_us: num("p90_us")?,
                step_mean_us: num("mean_us")?,
                sumo_step_p50_us: num("sumo_step_p50_us")?,
            })
        })
        .collect()
}

/// A platoon-of-4 fleet config with `followers` followers in all, `seconds` long: Table I's
/// scenario, resolved, with its keys set by dotted path as a campaign sets them. With
/// `traffic` (on SUMO) the traffic touches every platoon: the platoons are
/// `configs/cut-in.toml`'s (the paper's law on PF, 20 m front to front, `[fallback.cut_in]`)
/// with the guard on, their car cutting in mid-gap ahead of each platoon's follower 3 at 30 %
/// of the run and leaving at 70 %, and one SUMO background vehicle per 5 followers drives on the
/// platoons' lanes, changing lanes by LC2013, a fifth of them trucks.
pub(crate) fn fleet_config(
    followers: usize,
    seconds: f64,
    sumo: bool,
    traffic: bool,
) -> Result<String> {
    let net = platoon_app::sumo::bridge_dir()?.join("../sumo/highway-long/highway-long.net.xml");
    let base = if traffic {
        platoon_config::Embedded::CutIn
    } else {
        platoon_config::Embedded::Table1
    };
    let (config, _) = base.parse()?;
    let mut root = toml::Value::try_from(&config).context("the resolved base config")?;
    let lanes: Vec<toml::Value> = (0..4).map(toml::Value::Integer).collect();
    let mut keys: Vec<(&str, toml::Value)> = vec![
        ("simulation.duration_s", seconds.into()),
        ("topology.preset", "pf".into()),
        ("fleet.platoons", (followers as i64 / 4).into()),
        ("fleet.lanes", lanes.into()),
        // Leader to leader: Table I's platoons are 44 m long, the cut-in config's 84.5 m.
        ("fleet.gap_m", if traffic { 200.0 } else { 60.0 }.into()),
        ("sumo.net", net.display().to_string().into()),
        ("sumo.fcd_period_s", 0.0.into()),
    ];
    if sumo {
        keys.push(("simulation.plant", "sumo".into()));
    }
    if traffic {
        keys.extend([
            ("cut_ins[0].at_s", (0.3 * seconds).into()),
            ("cut_ins[0].leave_s", (0.7 * seconds).into()),
            ("guard.enabled", true.into()),
            (
                "sumo.background_vehicles",
                (followers.div_ceil(5) as i64).into(),
            ),
            ("sumo.background_seed", 11.into()),
            ("sumo.background_on_platoon_lanes", true.into()),
            ("sumo.background_truck_share", 0.2.into()),
            (
                "sumo.background_lane_changes",
                toml::Value::Table(
                    [("assertive", 10.0), ("speed_gain", 5.0)]
                        .into_iter()
                        .map(|(k, v)| (k.to_string(), v.into()))
                        .collect(),
                ),
            ),
        ]);
    } else {
        keys.push(("platoon.vehicle_length_m", 4.0.into()));
    }
    for (key, value) in keys {
        platoon_campaign::overrides::set(&mut root, key, value)
            .map_err(|e| anyhow::anyhow!("the benchmark's fleet config: {e}"))?;
    }
    Ok(toml::to_string(&root)?)
}

/// `python -m platoon.sumo --tight-loop`: the same SUMO and model as a run's plant.json, timed
/// in a loop with no co-simulation around it.
fn tight_loop(plant_json: &std::path::Path, steps: u32) -> Result<serde_json::Value> {
    let o = platoon_app::sumo::bridge_module("platoon.sumo")?
        .args(["--tight-loop", &steps.to_string()])
        .env("PLATOON_PLANT_SPEC", plant_json)
        .output()?;
    if !o.status.success() {
        bail!("{}", String::from_utf8_lossy(&o.stderr).trim());
    }
    Ok(serde_json::from_slice(&o.stdout)?)
}

/// Runs `platoon bench step`.
pub fn step(a: Step) -> Result<StepReport> {
    if a.followers.is_empty() || a.followers.iter().any(|&n| n == 0 || n % 4 != 0) {
        bail!(
            "--followers needs positive multiples of 4 (platoons of 4 followers), e.g. 4,100,1000"
        );
    }
    for m in &a.modes {
        if !matches!(
            m.as_str(),
            "inproc" | "native" | "sumo" | "native-1cpu" | "sumo-1cpu" | "sumo-traffic"
        ) {
            bail!(
                "unknown mode {m:?} in --modes: use inproc, native, sumo, native-1cpu, sumo-1cpu \
                 or sumo-traffic"
            );
        }
    }
    if !(a.seconds.is_finite() && a.seconds >= 0.1) {
        bail!("--seconds must be at least 0.1");
    }
    let dir = crate::create_out(a.out, "bench-step", a.force)?;
    let exe = platoon_app::platoon_program()?;
    let one_cpu = platoon_runtime::available_cpus()
        .first()
        .map_or_else(|| "0".to_string(), |c| c.to_string());
    let bar =
        indicatif::ProgressBar::new((a.rounds as usize * a.followers.len() * a.modes.len()) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {msg} [{elapsed}] {wide_bar} {pos}/{len}",
        )
        .expect("static template"),
    );
    let mut rows = Vec::new();
    let mut peer_rows = Vec::new();
    for round in 1..=a.rounds {
        for &n in &a.followers {
            for mode in &a.modes {
                bar.set_message(format!("round {round}/{}: {mode}, {n} followers", a.rounds));
                let config = dir.path(&format!("{mode}-{n}.toml"));
                let sumo = mode.starts_with("sumo");
                let traffic = mode == "sumo-traffic";
                std::fs::write(&config, fleet_config(n, a.seconds, sumo, traffic)?)?;
                let case = dir.path(&format!("{mode}-{n}"));
                run_case(&exe, &config, &case, mode, n, &one_cpu)?;
                let read = |f: &str| -> Option<serde_json::Value> {
                    serde_json::from_str(&std::fs::read_to_string(case.join(f)).ok()?).ok()
                };
                let timing = read("timing.json").context("timing.json missing")?;
                let sumo = read("sumo.json");
                let tight =
                    if sumo.is_some() {
                        Some(tight_loop(&case.join("plant.json"), 500).with_context(|| {
                            format!("timing SUMO's tight loop for {n} followers")
                        })?)
                    } else {
                        None
                    };
                if mode == "sumo" && !a.no_peers {
                    bar.set_message(format!(
                        "round {round}/{}: SUMO's own peers, {n} followers",
                        a.rounds
                    ));
                    peer_rows.extend(
                        peers(&case.join("plant.json"), n, round)
                            .with_context(|| format!("running the peers for {n} followers"))?,
                    );
                }
                rows.push(step_row(
                    round,
                    mode,
                    n,
                    a.seconds,
                    &timing,
                    sumo.as_ref(),
                    tight.as_ref(),
                ));
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    let mut csv = csv::Writer::from_writer(dir.writer("step.csv")?);
    for r in &rows {
        csv.serialize(r)?;
    }
    csv.flush()?;
    if !peer_rows.is_empty() {
        let mut csv = csv::Writer::from_writer(dir.writer("peers.csv")?);
        for r in &peer_rows {
            csv.serialize(r)?;
        }
        csv.flush()?;
    }
    // From here on, one row per case and per peer: the median over the rounds.
    let ratios = peer_ratios(&rows, &peer_rows);
    let (round_rows, round_peers) = (rows, peer_rows);
    let (rows, peer_rows) = (median_rows(&round_rows), median_peers(&round_peers));
    // Least-squares line per mode: cost per step = a + b N.
    let mut series = Vec::new();
    let mut fits = Vec::new();
    for (i, mode) in a.modes.iter().enumerate() {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| &r.mode == mode)
            .map(|r| (r.followers as f64, r.step_p50_us))
            .collect();
        let (a0, b) = fit(&pts);
        fits.push(
            serde_json::json!({"mode": mode, "intercept_us": a0, "slope_us_per_follower": b}),
        );
        series.push(platoon_output::plots::Series {
            label: format!("{mode}: {a0:.1} + {b:.3} N µs"),
            color: i,
            points: pts,
        });
    }
    platoon_output::plots::scatter_with_lines(
        &dir.path("step.png"),
        "Co-simulation cost per step (p50) against followers",
        "followers N",
        "µs per step",
        &series,
    )?;
    dir.write(
        "step.json",
        (serde_json::to_string_pretty(&serde_json::json!({
            "rounds": a.rounds,
            "rows": rows,
            "fits": fits,
            "peers": peer_rows,
            "ratios": ratios,
            "round_rows": round_rows,
            "round_peers": round_peers,
        }))? + "\n")
            .as_bytes(),
    )?;
    let path = dir.commit()?;
    print_table(&rows, &fits, &peer_rows, &ratios);
    println!("outputs: {}", path.display());
    Ok(StepReport {
        rows,
        peers: peer_rows,
        ratios,
    })
}

/// The step costs, the fits of cost against size and the peers' ratios, on stdout.
fn print_table(
    rows: &[StepRow],
    fits: &[serde_json::Value],
    peer_rows: &[PeerRow],
    ratios: &[PeerRatio],
) {
    println!(
        "{:<7} {:>6} {:>9} {:>11} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "mode", "N", "vehicles", "step p50", "x realtime", "plant", "control", "injector", "SUMO"
    );
    // A stage a mode does not have (in process: no plant or injector process) prints "-".
    let stage = |x: Option<f64>| x.map_or(String::from("-"), |x| format!("{x:.1}"));
    for r in rows {
        println!(
            "{:<7} {:>6} {:>9} {:>9.1}µs {:>10.1} {:>10} {:>10} {:>10} {:>10}",
            r.mode,
            r.followers,
            r.vehicles,
            r.step_p50_us,
            r.real_time_factor,
            stage(r.plant_p50_us),
            stage(r.controller_p50_us),
            stage(r.injector_p50_us),
            stage(r.sumo_step_p50_us)
        );
    }
    for f in fits {
        let mode = f["mode"].as_str().unwrap_or_default();
        match (
            f["intercept_us"].as_f64(),
            f["slope_us_per_follower"].as_f64(),
        ) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() => {
                println!("{mode}: {a:.1} µs + {b:.3} µs per follower")
            }
            _ => println!("{mode}: one size only, no fit of cost against N"),
        }
    }
    if !peer_rows.is_empty() {
        println!(
            "\nthe same fleet driven by SUMO itself (step p50, and our sumo step as a ratio, the \
             median of the rounds' ratios, then each round's):"
        );
        for p in peer_rows {
            let r = ratios
                .iter()
                .find(|r| r.peer == p.peer && r.followers == p.followers);
            let each = r.map_or(String::new(), |r| {
                r.rounds
                    .iter()
                    .map(|x| format!("{x:.2}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            });
            println!(
                "{:<11} {:>6} {:>9.1}µs  ours {:.2}x  ({each})",
                p.peer,
                p.followers,
                p.step_p50_us,
                r.map_or(f64::NAN, |r| r.median)
            );
        }
    }
}

/// `platoon run` (the binary `exe`) of the case `mode` with `n` followers: `config` into
/// `case`, on the CPU `one_cpu` for a `-1cpu` mode.
fn run_case(
    exe: &Path,
    config: &Path,
    case: &Path,
    mode: &str,
    n: usize,
    one_cpu: &str,
) -> Result<()> {
    let transport = if mode == "inproc" {
        "inproc"
    } else {
        "iceoryx2"
    };
    let mut cmd = Command::new(exe);
    cmd.args([
        "run",
        config.to_str().unwrap_or_default(),
        "--no-plots",
        "--force",
        "--transport",
        transport,
        "--out",
    ])
    .arg(case);
    if mode.ends_with("-1cpu") {
        cmd.arg("--cpus").arg(one_cpu);
    }
    let o = cmd
        .env("PLATOON_STEP_TIMEOUT", "30")
        .output()
        .with_context(|| format!("running the {mode} case with {n} followers"))?;
    if !o.status.success() {
        bail!(
            "the {mode} case with {n} followers failed: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        );
    }
    Ok(())
}

/// The row of one case: its timing.json, and with SUMO its sumo.json and the tight loop's
/// timing.
fn step_row(
    round: u32,
    mode: &str,
    n: usize,
    seconds: f64,
    timing: &serde_json::Value,
    sumo: Option<&serde_json::Value>,
    tight: Option<&serde_json::Value>,
) -> StepRow {
    let p = |v: &serde_json::Value, k: &str| v[k]["p50_us"].as_f64();
    let step_p50 = p(timing, "step").unwrap_or(f64::NAN);
    let dt = 0.01;
    StepRow {
        round,
        mode: mode.to_string(),
        followers: n,
        vehicles: n / 4 * 5,
        steps: (seconds / dt).round() as u64 + 1,
        step_p50_us: step_p50,
        step_p99_us: timing["step"]["p99_us"].as_f64().unwrap_or(f64::NAN),
        real_time_factor: dt * 1e6 / step_p50,
        plant_p50_us: p(timing, "plant"),
        controller_p50_us: p(timing, "controller_tx")
            .zip(p(timing, "controller_rx"))
            .map(|(x, y)| x + y),
        injector_p50_us: p(timing, "injector"),
        sumo_step_p50_us: sumo.and_then(|s| s["sumo_step"]["p50_us"].as_f64()),
        bridge_p50_us: sumo.and_then(|s| s["bridge_step"]["p50_us"].as_f64()),
        sumo_step_tight_p50_us: tight.and_then(|t| t["sumo_step_p50_us"].as_f64()),
        bridge_tight_p50_us: tight.and_then(|t| t["bridge_step_p50_us"].as_f64()),
        peak_rss_mib: timing["peak_rss_mib"]
            .as_object()
            .map(|m| m.values().filter_map(|v| v.as_f64()).sum()),
    }
}

/// BENCHMARKS.md's table of the peers: the same fleets driven by SUMO itself, our `sumo` step
/// as a ratio to each (the median of the rounds' ratios), and the target against Plexe's
/// auto-fed CACC.
pub(crate) fn peers_section(md: &mut String, peers: &[PeerRow], ratios: &[PeerRatio]) {
    if peers.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "### The same fleets driven by SUMO itself (`bridge/tools/bench_peers.py`, in the same run)\n\n\
         After each `sumo` case, its plant.json (network, vehicles, lanes, initial states, steps) \
         runs again in one process through libsumo: `krauss`, SUMO's own model drives every \
         vehicle; `plexe_acc` and `plexe_cacc`, Plexe's ACC and PATH CACC in SUMO's CC model (the \
         CACC fed by SUMO itself every step, `ccaf`), leaders on cruise control; `floor`, any \
         external driver's least work (per vehicle one `setAcceleration` and two getters from \
         Python, no control). µs per step, medians over the rounds; \"ours / peer\" is the `sumo` \
         row's step (nodes on any CPU) over the peer's (p50), the median of the rounds' ratios, \
         each taken between runs made one right after the other:\n"
    );
    let _ = writeln!(
        md,
        "| followers | vehicles | peer | p50 | p90 | mean | SUMO's step alone (p50) | ours / peer (p50) | each round |\n|---|---|---|---|---|---|---|---|---|"
    );
    let ratio = |p: &PeerRow| {
        ratios
            .iter()
            .find(|r| r.peer == p.peer && r.followers == p.followers)
    };
    let each = |r: &PeerRatio| {
        r.rounds
            .iter()
            .map(|x| format!("{x:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    for p in peers {
        let r = ratio(p);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {} |",
            p.followers,
            p.vehicles,
            p.peer,
            p.step_p50_us,
            p.step_p90_us,
            p.step_mean_us,
            p.sumo_step_p50_us,
            r.map_or("-".into(), |r| format!("{:.2}", r.median)),
            r.map_or("-".into(), each)
        );
    }
    let _ = writeln!(md);
    let big = peers.iter().map(|p| p.followers).max().unwrap_or(0);
    if let Some((cacc, r)) = peers
        .iter()
        .find(|p| p.followers == big && p.peer == "plexe_cacc")
        .and_then(|p| Some((p, ratio(p)?)))
    {
        let x = r.median;
        let _ = writeln!(
            md,
            "{big} followers ({} vehicles) with SUMO: our step is **{x:.2}x** Plexe's auto-fed CACC inside SUMO, the median of {} rounds ({}; target <= 0.8: {}).\n",
            cacc.vehicles,
            r.rounds.len(),
            each(r),
            if x <= 0.8 { "met" } else { "missed" }
        );
    }
}

/// Least squares y = a + b x.
pub(crate) fn fit(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    if pts.len() < 2 {
        return (pts.first().map_or(f64::NAN, |p| p.1), f64::NAN);
    }
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    (my - b * mx, b)
}
