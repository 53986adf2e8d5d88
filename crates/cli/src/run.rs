//! `platoon run`: one scenario, in process, into a run directory.
use crate::output::RunDir;
use crate::plots;
use anyhow::{Context, Result};
use platoon_config::{Config, ConfigError};
use platoon_sim::{Scenario, StepRow, Summary};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `platoon run` (its help text is on the `Run` command in main.rs).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenario config (TOML). Without it, the embedded configs/paper.toml runs.
    pub config: Option<PathBuf>,
    /// Run directory to create [default: runs/<config name>].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the run directory if it exists.
    #[arg(long)]
    pub force: bool,
    /// Skip the PNG plots (faster on long runs).
    #[arg(long)]
    pub no_plots: bool,
}

/// Loads the config named on the command line or, without one, an embedded config (`name` is
/// its stem, e.g. `paper` for configs/paper.toml). Also returns the stem for default run names.
pub fn load(
    config: Option<&Path>,
    embedded: &str,
    name: &str,
) -> Result<(Config, Scenario, String), ConfigError> {
    match config {
        Some(path) => {
            let (c, s) = platoon_config::load(path)?;
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into());
            Ok((c, s, stem))
        }
        None => {
            let label = format!("<embedded configs/{name}.toml>");
            let (c, s) = platoon_config::parse(embedded, Path::new(&label))?;
            Ok((c, s, name.into()))
        }
    }
}

pub fn run(args: Args) -> Result<()> {
    let (config, scenario, stem) =
        load(args.config.as_deref(), platoon_config::PAPER_TOML, "paper")?;
    let out = args
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join(&stem));
    let dir = RunDir::create(&out, args.force)?;
    let started = Instant::now();
    let (rows, summary) = simulate(&scenario, &dir)?;
    let compute = started.elapsed();
    write_outputs(&dir, &config, &scenario, &rows, &summary, !args.no_plots)?;
    let path = dir.commit()?;
    print_summary(&summary, compute.as_secs_f64());
    println!("outputs: {}", path.display());
    Ok(())
}

/// Runs the scenario with a progress bar and streams trajectories.csv; returns the rows and summary.
pub fn simulate(scenario: &Scenario, dir: &RunDir) -> Result<(Vec<StepRow>, Summary)> {
    let steps = scenario.steps + 1;
    let bar = indicatif::ProgressBar::new(steps);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} simulating {pos}/{len} steps [{elapsed}] {wide_bar}",
        )
        .expect("static template"),
    );
    let mut csv = csv::Writer::from_writer(dir.writer("trajectories.csv")?);
    let mut rows = Vec::with_capacity(steps as usize * (scenario.topology.followers() + 1));
    let mut failure = None;
    let summary = platoon_sim::run(scenario.clone(), |step| {
        for r in step {
            if failure.is_none() {
                if let Err(e) = csv.serialize(r) {
                    failure = Some(e);
                }
            }
        }
        rows.extend_from_slice(step);
        if step[0].step % 1000 == 0 {
            bar.set_position(step[0].step);
        }
    })?;
    bar.finish_and_clear();
    if let Some(e) = failure {
        return Err(e).context("writing trajectories.csv");
    }
    csv.flush().context("writing trajectories.csv")?;
    Ok((rows, summary))
}

/// One row per broadcast of a follower.
#[derive(serde::Serialize)]
struct EventRow {
    vehicle: u16,
    step: u64,
    t: f64,
    inter_event_s: Option<f64>,
    under_attack: bool,
}

/// Writes config.toml, events.csv, plots, and summary.json last.
pub fn write_outputs(
    dir: &RunDir,
    config: &Config,
    scenario: &Scenario,
    rows: &[StepRow],
    summary: &Summary,
    plots: bool,
) -> Result<()> {
    dir.write("config.toml", platoon_config::to_toml(config).as_bytes())?;
    let mut events = csv::Writer::from_writer(dir.writer("events.csv")?);
    let mut last: Vec<Option<u64>> = vec![None; scenario.topology.followers() + 1];
    let mut followers: Vec<&StepRow> = rows
        .iter()
        .filter(|r| r.vehicle > 0 && r.triggered)
        .collect();
    followers.sort_by_key(|r| (r.vehicle, r.step));
    for r in followers {
        let prev = &mut last[r.vehicle as usize];
        events.serialize(EventRow {
            vehicle: r.vehicle,
            step: r.step,
            t: r.t,
            inter_event_s: prev.map(|p| (r.step - p) as f64 * scenario.dt()),
            under_attack: r.under_attack,
        })?;
        *prev = Some(r.step);
    }
    events.flush().context("writing events.csv")?;
    if plots {
        plots::fig6(&dir.path("fig6.png"), scenario, rows).context("drawing fig6.png")?;
        plots::fig7(&dir.path("fig7.png"), scenario, rows).context("drawing fig7.png")?;
    }
    let json = serde_json::to_string_pretty(summary)? + "\n";
    dir.write("summary.json", json.as_bytes())
}

fn print_summary(s: &Summary, compute_s: f64) {
    println!(
        "{} steps of {} s (t = 0 to {} s, rule {}) in {:.1} ms",
        s.steps,
        s.dt_s,
        s.duration_s,
        s.rule,
        compute_s * 1e3
    );
    for v in &s.vehicles {
        println!(
            "  follower {}: {:>5} broadcasts, spacing error mean {:.3} m, max {:.3} m, final {:.4} m",
            v.vehicle, v.triggers, v.spacing_error_m.mean_abs, v.spacing_error_m.max_abs, v.spacing_error_m.final_abs
        );
    }
    let a = &s.attack;
    let verdict = match &a.assumption2 {
        Some(r) if r.holds => "satisfies Assumption 2",
        Some(_) => "VIOLATES Assumption 2",
        None => "no Assumption-2 bounds given",
    };
    println!(
        "  DoS: {} attacks, {:.2} s jammed, {verdict}",
        a.intervals, a.attacked_time_s
    );
    println!(
        "  safety: {} (smallest gap {:.2} m, follower {} at {:.2} s)",
        if s.safety.safe { "safe" } else { "COLLISION" },
        s.safety.min_gap_m,
        s.safety.min_gap_vehicle,
        s.safety.min_gap_t_s
    );
}
