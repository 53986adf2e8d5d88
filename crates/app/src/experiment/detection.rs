//! Every misbehaviour detector against every attack of an insider, measured against ground
//! truth, with and without a reaction ([`detection`]).
use super::{refuse, write_config, write_table, Base, Experiment, ExperimentError, Result};
use crate::progress::Progress;
use platoon_config::{Attack, DetectionConfig, Embedded, LinkAttackConfig, LinkKindConfig};
use platoon_control::{FallbackMode, Reaction};
use platoon_output::plots;
use platoon_output::rundir::RunDir;
use platoon_sim::detection::DetectorScore;
use platoon_sim::{SafetyClass, Summary};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;

/// The built-in detectors, by config name.
pub const DETECTORS: [&str; 3] = platoon_control::screening::DetectorSpec::NAMES;

/// The reactions [`detection`] compares (`drop` is `fallback` without the fallback law).
pub const REACTIONS: [Reaction; 2] = [Reaction::Log, Reaction::Fallback];

/// The attacks of [`detection`], by `[[channel.attacks]] kind`.
pub const ATTACKS: [&str; 7] = [
    "false_data",
    "random_offset",
    "drift",
    "feigned_braking",
    "accel_scale",
    "replay",
    "delay",
];

/// How hard an attack pushes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Intensity {
    /// Meant to stay inside sensor noise or genuine dynamics.
    Stealthy,
    /// Meant to matter.
    Strong,
}

impl Intensity {
    /// Every intensity.
    pub const ALL: [Intensity; 2] = [Self::Stealthy, Self::Strong];

    /// Its name in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Stealthy => "stealthy",
            Self::Strong => "strong",
        }
    }

    /// By name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }
}

/// The attack `name` of [`ATTACKS`] at `intensity`, as the channel's attack kind (an insider
/// where the kind has one), or None for an unknown name.
///
/// | attack | stealthy | strong |
/// |---|---|---|
/// | false_data | +0.15 m on the position (inside the radar's 4 sigma) | +5 m |
/// | random_offset | noise of 0.05 m, 0.05 m/s, 0.1 m/s² | 1 m, 0.5 m/s, 0.5 m/s² |
/// | drift | 0.01 m/s on the position (0.25 m after 25 s) | 0.5 m/s |
/// | feigned_braking | a claimed -1 m/s² | -6 m/s² |
/// | accel_scale | the claimed acceleration x 1.2 | x 3 |
/// | replay | packets of 0.1 s earlier | 1 s earlier |
/// | delay | 0.05 s | 0.5 s |
pub fn attack_kind(name: &str, intensity: Intensity) -> Option<LinkKindConfig> {
    let strong = intensity == Intensity::Strong;
    let pick = |stealthy: f64, s: f64| if strong { s } else { stealthy };
    Some(match name {
        "false_data" => LinkKindConfig::FalseData {
            offset: [pick(0.15, 5.0), 0.0, 0.0],
            insider: true,
        },
        "random_offset" => LinkKindConfig::RandomOffset {
            std: if strong {
                [1.0, 0.5, 0.5]
            } else {
                [0.05, 0.05, 0.1]
            },
            insider: true,
        },
        "drift" => LinkKindConfig::Drift {
            rate: [pick(0.01, 0.5), 0.0, 0.0],
            insider: true,
        },
        "feigned_braking" => LinkKindConfig::FeignedBraking {
            accel_mps2: pick(-1.0, -6.0),
            insider: true,
        },
        "accel_scale" => LinkKindConfig::AccelScale {
            factor: pick(1.2, 3.0),
            insider: true,
        },
        "replay" => LinkKindConfig::Replay {
            lag_s: pick(0.1, 1.0),
        },
        "delay" => LinkKindConfig::Delay {
            delay_s: pick(0.05, 0.5),
        },
        _ => return None,
    })
}

/// How [`detection`] runs; [`DetectionOptions::default`] is `platoon experiment detection`'s
/// default.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectionOptions {
    /// The attacks (`--attacks`), names of [`ATTACKS`].
    pub attacks: Vec<String>,
    /// The detectors (`--detectors`), names of [`DETECTORS`].
    pub detectors: Vec<String>,
    /// The intensities (`--intensities`).
    pub intensities: Vec<Intensity>,
    /// The reactions (`--reactions`): `log` (off) and `fallback` (on, to ACC on the radar).
    pub reactions: Vec<Reaction>,
    /// Also run without an attack (the false-alarm baseline; `--no-clean` leaves it out).
    pub clean: bool,
    /// Seeded repeats of every cell (`--repeats`): the radar's and the channel's seeds.
    pub repeats: u32,
    /// The runs' duration (s; `--duration`): 45 covers the leader's braking at 35-40 s.
    pub duration_s: f64,
    /// The insider: the vehicle whose packets are attacked (`--attacker`).
    pub attacker: u16,
    /// When the attack starts (s; `--start`).
    pub start_s: f64,
    /// Runs at once (`--jobs`; None: as many as the machine has cores).
    pub jobs: Option<usize>,
}

impl Default for DetectionOptions {
    fn default() -> Self {
        Self {
            attacks: ATTACKS.iter().map(|a| a.to_string()).collect(),
            detectors: DETECTORS.iter().map(|d| d.to_string()).collect(),
            intensities: vec![Intensity::Stealthy, Intensity::Strong],
            reactions: REACTIONS.to_vec(),
            clean: true,
            repeats: 3,
            duration_s: 45.0,
            attacker: 2,
            start_s: 20.0,
            jobs: None,
        }
    }
}

impl DetectionOptions {
    /// Fails on unknown names, empty lists, no repeat or a duration that is none.
    pub fn validate(&self) -> Result<()> {
        for a in &self.attacks {
            if !ATTACKS.contains(&a.as_str()) {
                refuse!(
                    Options,
                    "--attacks: unknown attack {a:?}; use {}",
                    ATTACKS.join(", ")
                );
            }
        }
        for d in &self.detectors {
            if !DETECTORS.contains(&d.as_str()) {
                refuse!(
                    Options,
                    "--detectors: unknown detector {d:?}; use {}",
                    DETECTORS.join(", ")
                );
            }
        }
        if self.detectors.is_empty() {
            refuse!(
                Options,
                "--detectors needs at least one detector, e.g. residual"
            );
        }
        if self.attacks.is_empty() && !self.clean {
            refuse!(Options, "nothing to run: no attack and no clean run");
        }
        if !self.attacks.is_empty() && self.intensities.is_empty() {
            refuse!(
                Options,
                "--intensities needs at least one of stealthy, strong"
            );
        }
        if self.reactions.is_empty() {
            refuse!(Options, "--reactions needs at least one of log, fallback");
        }
        if self.repeats == 0 {
            refuse!(Options, "--repeats must be at least 1");
        }
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            refuse!(
                Options,
                "--duration must be > 0 s (got {})",
                self.duration_s
            );
        }
        if !(self.start_s.is_finite() && self.start_s >= 0.0) {
            refuse!(Options, "--start must be >= 0 s (got {})", self.start_s);
        }
        Ok(())
    }
}

/// One row of detection.csv: one detector in one run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DetectionRow {
    /// The attack ([`ATTACKS`], or `none`).
    pub attack: String,
    /// `stealthy`, `strong`, or `none` without an attack.
    pub intensity: &'static str,
    /// `log` (no reaction) or `fallback`.
    pub reaction: &'static str,
    /// The repeat (0-based; its seeds).
    pub repeat: u32,
    /// The detector, or `any` (every detector of a `log` run together).
    pub detector: String,
    /// Misbehaving packets flagged.
    pub tp: u64,
    /// Genuine packets flagged.
    pub fp: u64,
    /// Genuine packets not flagged.
    pub tn: u64,
    /// Misbehaving packets not flagged.
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// `tp / (tp + fp)`; empty without a flag.
    pub precision: Option<f64>,
    /// `tp / (tp + fn)`; empty without a misbehaving packet.
    pub recall: Option<f64>,
    /// `2 tp / (2 tp + fp + fn)` (0 when nothing misbehaving was flagged); empty without a
    /// misbehaving packet.
    pub f1: Option<f64>,
    /// `fp / (fp + tn)`.
    pub false_alarm_rate: Option<f64>,
    /// From the first misbehaving packet inspected to the first flag on one (s).
    pub time_to_detect_s: Option<f64>,
    /// The run's smallest gap (m; below 0: a collision).
    pub min_gap_m: f64,
    /// Whether two vehicles collided.
    pub collided: bool,
    /// The run's safety class.
    pub safety_class: SafetyClass,
}

/// The detectors against the attacks ([`detection`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// Run by run, detector by detector.
    pub rows: Vec<DetectionRow>,
    /// detection.md: the table, averaged over the repeats.
    pub markdown: String,
}

/// One run of the grid.
#[derive(Debug, Clone)]
struct Cell {
    attack: Option<String>,
    intensity: Option<Intensity>,
    reaction: Reaction,
    repeat: u32,
    /// The detectors it runs: all of them with `log` (they do not interact: nothing is
    /// refused), one with `fallback` (what a flag makes the follower do depends on who flags).
    detectors: Vec<String>,
}

/// Every detector of `opts` against every attack of `opts` at every intensity, with every
/// reaction, `repeats` times, in process on worker threads, on the base scenario with its DoS
/// removed, `[fallback] mode = "acc"`, and the attack on the packets of the insider
/// `opts.attacker` from `opts.start_s` on. With `log`, one run holds every detector (they see
/// the same packets, nothing is refused) and also gives `any`; with `fallback`, each detector
/// runs alone. The clean run (no attack) measures the false alarms. With `out`: config.toml,
/// detection.csv, detection.md, f1.png and safety.png.
pub fn detection(
    base: &Base,
    opts: &DetectionOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Detection> {
    super::run::<Detection>(base, opts, out, progress)
}

/// [`detection`]'s cells (and their runs' directories in `out`), without its tables and figures.
fn measure(
    base: &Base,
    opts: &DetectionOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Detection> {
    let prepared = prepare(&base.config, opts);
    write_config(out, &prepared)?;
    let cells = cells(opts);
    let jobs = opts
        .jobs
        .or_else(|| std::thread::available_parallelism().ok().map(|n| n.get()))
        .unwrap_or(1)
        .clamp(1, cells.len());
    progress.start("simulating", cells.len() as u64);
    let next = AtomicUsize::new(0);
    let done = AtomicU64::new(0);
    let results: Mutex<Vec<Option<Result<Vec<DetectionRow>>>>> =
        Mutex::new((0..cells.len()).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some(cell) = cells.get(i) else { break };
                let rows = run_cell(base, &prepared, opts, cell);
                let failed = rows.is_err();
                results.lock().expect("a worker panicked")[i] = Some(rows);
                progress.at(done.fetch_add(1, Ordering::SeqCst) + 1);
                if failed {
                    // The others see it at their next cell.
                    next.store(cells.len(), Ordering::SeqCst);
                    break;
                }
            });
        }
    });
    progress.finish();
    let mut rows = Vec::new();
    for r in results.into_inner().expect("a worker panicked").into_iter() {
        match r {
            Some(r) => rows.extend(r?),
            None => continue,
        }
    }
    let markdown = markdown(&rows, opts);
    Ok(Detection { rows, markdown })
}

/// The base config as every run of [`detection`] shares it: no DoS, the attacks and detection
/// of the base removed, `opts.duration_s`, ACC on the radar as the fallback.
fn prepare(base: &platoon_config::Config, opts: &DetectionOptions) -> platoon_config::Config {
    let mut c = base.clone();
    c.attack = Attack::default();
    c.channel.attacks.clear();
    c.detection = None;
    c.simulation.duration_s = opts.duration_s;
    c.fallback.mode = Some(FallbackMode::Acc);
    c.fallback.per_vehicle = None;
    c
}

fn cells(opts: &DetectionOptions) -> Vec<Cell> {
    let mut attacks: Vec<(Option<String>, Option<Intensity>)> = Vec::new();
    if opts.clean {
        attacks.push((None, None));
    }
    for a in &opts.attacks {
        for &i in &opts.intensities {
            attacks.push((Some(a.clone()), Some(i)));
        }
    }
    let mut cells = Vec::new();
    for (attack, intensity) in attacks {
        for &reaction in &opts.reactions {
            for repeat in 0..opts.repeats {
                let cell = |detectors| Cell {
                    attack: attack.clone(),
                    intensity,
                    reaction,
                    repeat,
                    detectors,
                };
                if reaction == Reaction::Log {
                    cells.push(cell(opts.detectors.clone()));
                } else {
                    for d in &opts.detectors {
                        cells.push(cell(vec![d.clone()]));
                    }
                }
            }
        }
    }
    cells
}

/// The config of one cell.
fn configure(
    prepared: &platoon_config::Config,
    opts: &DetectionOptions,
    cell: &Cell,
) -> platoon_config::Config {
    let mut c = prepared.clone();
    // The repeat's seeds: the radar's noise and the channel's draws (random_offset).
    c.radar.seed = prepared.radar.seed.wrapping_add(u64::from(cell.repeat));
    c.channel.seed = prepared.channel.seed.wrapping_add(u64::from(cell.repeat));
    if let (Some(a), Some(i)) = (&cell.attack, cell.intensity) {
        c.channel.attacks.push(LinkAttackConfig {
            kind: attack_kind(a, i).expect("validated"),
            start_s: opts.start_s,
            end_s: f64::INFINITY,
            senders: Some(vec![opts.attacker]),
            receivers: None,
            acts_as: None,
            key_of: None,
        });
    }
    let on = |name: &str| cell.detectors.iter().any(|d| d == name);
    c.detection = Some(DetectionConfig {
        plausibility: on("plausibility").then(Default::default),
        radar_cross: on("radar_cross").then(Default::default),
        residual: on("residual").then(Default::default),
        reaction: cell.reaction,
        // `[detection] quiet_s`'s default.
        quiet_s: 1.0,
        plugin: Vec::new(),
    });
    c
}

fn run_cell(
    base: &Base,
    prepared: &platoon_config::Config,
    opts: &DetectionOptions,
    cell: &Cell,
) -> Result<Vec<DetectionRow>> {
    let mut c = configure(prepared, opts, cell);
    let name = || {
        format!(
            "{}: {} {} with {} ({})",
            base.label,
            cell.intensity.map_or("no", Intensity::name),
            cell.attack.as_deref().unwrap_or("attack"),
            cell.detectors.join("+"),
            cell.reaction.name()
        )
    };
    let scenario = platoon_config::to_scenario(&mut c)
        .map_err(|e| ExperimentError::Variant(format!("{}: {e}", name())))?;
    let summary = platoon_sim::run(scenario, |_| {})?;
    let Some(d) = &summary.detection else {
        return Err(failure!("{}: the run measured no detection", name()).into());
    };
    let mut scores: Vec<&DetectorScore> = d.detectors.iter().collect();
    if cell.detectors.len() > 1 {
        scores.push(&d.any);
    }
    Ok(scores.into_iter().map(|s| row(cell, s, &summary)).collect())
}

fn row(cell: &Cell, s: &DetectorScore, summary: &Summary) -> DetectionRow {
    let c = s.totals;
    DetectionRow {
        attack: cell.attack.clone().unwrap_or_else(|| "none".into()),
        intensity: cell.intensity.map_or("none", Intensity::name),
        reaction: cell.reaction.name(),
        repeat: cell.repeat,
        detector: s.name.clone(),
        tp: c.tp,
        fp: c.fp,
        tn: c.tn,
        fn_: c.fn_,
        precision: s.precision,
        recall: s.recall,
        f1: s.f1,
        false_alarm_rate: s.false_alarm_rate,
        time_to_detect_s: s.time_to_detect_s,
        min_gap_m: summary.safety.min_gap_m,
        collided: summary.safety.collided,
        safety_class: summary.safety.class,
    }
}

/// The mean of the values present, if any.
fn mean(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let (sum, n) = values
        .flatten()
        .fold((0.0, 0u32), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / f64::from(n))
}

/// The rows of one (attack, intensity, reaction, detector) over the repeats.
fn group<'a>(
    rows: &'a [DetectionRow],
    attack: &'a str,
    intensity: &'a str,
    reaction: &'a str,
    detector: &'a str,
) -> impl Iterator<Item = &'a DetectionRow> + Clone + 'a {
    rows.iter().filter(move |r| {
        r.attack == attack
            && r.intensity == intensity
            && r.reaction == reaction
            && r.detector == detector
    })
}

/// The (attack, intensity) pairs of `opts` in order, the clean run first.
fn scenarios(opts: &DetectionOptions) -> Vec<(String, &'static str)> {
    let mut v = Vec::new();
    if opts.clean {
        v.push(("none".to_string(), "none"));
    }
    for a in &opts.attacks {
        for i in &opts.intensities {
            v.push((a.clone(), i.name()));
        }
    }
    v
}

/// The detectors of the `log` runs' rows: `opts`' and `any` when there are several.
fn log_detectors(opts: &DetectionOptions) -> Vec<String> {
    let mut v = opts.detectors.clone();
    if v.len() > 1 {
        v.push("any".into());
    }
    v
}

fn markdown(rows: &[DetectionRow], opts: &DetectionOptions) -> String {
    let f = |x: Option<f64>, digits: usize| x.map_or("-".into(), |x| format!("{x:.digits$}"));
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Means over {} repeat(s); `-`: undefined (no flag for precision, no misbehaving packet for recall and F1, never detected for the time). Smallest gap: the worst repeat.\n",
        opts.repeats
    );
    if opts.reactions.contains(&Reaction::Log) {
        md.push_str("Without a reaction (`log`):\n\n| attack | intensity | detector | precision | recall | F1 | false-alarm rate | time to detect (s) |\n|---|---|---|---|---|---|---|---|\n");
        for (a, i) in scenarios(opts) {
            for d in log_detectors(opts) {
                let g = group(rows, &a, i, "log", &d);
                if g.clone().next().is_none() {
                    continue;
                }
                let _ = writeln!(
                    md,
                    "| {a} | {i} | {d} | {} | {} | {} | {} | {} |",
                    f(mean(g.clone().map(|r| r.precision)), 3),
                    f(mean(g.clone().map(|r| r.recall)), 3),
                    f(mean(g.clone().map(|r| r.f1)), 3),
                    f(mean(g.clone().map(|r| r.false_alarm_rate)), 5),
                    f(mean(g.map(|r| r.time_to_detect_s)), 2),
                );
            }
        }
        md.push('\n');
    }
    let worst =
        |g: &mut dyn Iterator<Item = &DetectionRow>| g.map(|r| r.min_gap_m).reduce(f64::min);
    md.push_str("Smallest gap (m) without and with the reaction (`fallback` to ACC on the radar, one detector at a time):\n\n| attack | intensity | no reaction |");
    for d in &opts.detectors {
        let _ = write!(md, " fallback on {d} |");
    }
    md.push_str("\n|---|---|---|");
    md.push_str(&"---|".repeat(opts.detectors.len()));
    md.push('\n');
    for (a, i) in scenarios(opts) {
        let first = opts.detectors.first().map_or("any", |d| d.as_str());
        let log_det = if opts.detectors.len() > 1 {
            "any"
        } else {
            first
        };
        let _ = write!(
            md,
            "| {a} | {i} | {} |",
            f(worst(&mut group(rows, &a, i, "log", log_det)), 2)
        );
        for d in &opts.detectors {
            let _ = write!(
                md,
                " {} |",
                f(worst(&mut group(rows, &a, i, "fallback", d)), 2)
            );
        }
        md.push('\n');
    }
    md
}

impl Detection {
    fn write_files(&self, opts: &DetectionOptions, dir: &RunDir) -> Result<()> {
        write_table(dir, "detection", &self.rows, &self.markdown)?;
        if opts.reactions.contains(&Reaction::Log) && !opts.attacks.is_empty() {
            f1_heatmap(&dir.path("f1.png"), &self.rows, opts)
                .map_err(|e| failure!("drawing f1.png: {e}"))?;
        }
        // The smallest gap per attack (strong, or the only intensity), with and without the
        // reaction.
        let intensity = if opts.intensities.contains(&Intensity::Strong) {
            "strong"
        } else {
            opts.intensities.first().map_or("none", |i| i.name())
        };
        let mut categories: Vec<(String, &str)> = Vec::new();
        if opts.clean {
            categories.push(("none".into(), "none"));
        }
        categories.extend(opts.attacks.iter().map(|a| (a.clone(), intensity)));
        let log_det = if opts.detectors.len() > 1 {
            "any".to_string()
        } else {
            opts.detectors[0].clone()
        };
        let mut groups: Vec<(String, &str, String)> = Vec::new();
        if opts.reactions.contains(&Reaction::Log) {
            groups.push(("no reaction".into(), "log", log_det));
        }
        if opts.reactions.contains(&Reaction::Fallback) {
            groups.extend(
                opts.detectors
                    .iter()
                    .map(|d| (format!("fallback on {d}"), "fallback", d.clone())),
            );
        }
        let groups: Vec<(String, Vec<f64>)> = groups
            .into_iter()
            .map(|(label, reaction, det)| {
                let values = categories
                    .iter()
                    .map(|(a, i)| {
                        group(&self.rows, a, i, reaction, &det)
                            .map(|r| r.min_gap_m)
                            .reduce(f64::min)
                            .map_or(0.0, |g| g.max(0.0))
                    })
                    .collect();
                (label, values)
            })
            .collect();
        let names: Vec<String> = categories.iter().map(|(a, _)| a.clone()).collect();
        plots::grouped_bars(
            &dir.path("safety.png"),
            &format!(
                "Smallest gap per attack ({intensity}), worst of {} repeat(s); 0 = collision",
                opts.repeats
            ),
            "smallest gap (m)",
            &names,
            &groups,
        )?;
        Ok(())
    }
}

/// f1.png: the mean F1 of each detector (rows) against each attack (columns) without a
/// reaction, one panel per intensity; grey where undefined.
fn f1_heatmap(
    path: &std::path::Path,
    rows: &[DetectionRow],
    opts: &DetectionOptions,
) -> Result<()> {
    plots::ensure_font();
    let detectors = log_detectors(opts);
    let panels = opts.intensities.len().max(1);
    let root = BitMapBackend::new(
        path,
        (900 * panels as u32, 120 + 60 * detectors.len() as u32),
    )
    .into_drawing_area();
    root.fill(&WHITE).map_err(plots::err)?;
    let root = root
        .titled(
            "F1 per detector and attack, no reaction (mean over repeats)",
            ("sans-serif", 22),
        )
        .map_err(plots::err)?;
    let na = attacks_len(opts);
    for (panel, &intensity) in root.split_evenly((1, panels)).iter().zip(&opts.intensities) {
        let attacks = opts.attacks.clone();
        let dets = detectors.clone();
        let mut chart = ChartBuilder::on(panel)
            .caption(intensity.name(), ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(100)
            .build_cartesian_2d(0.0..na as f64, 0.0..detectors.len() as f64)
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(na * 2 + 1)
            .y_labels(detectors.len() * 2 + 1)
            .x_label_formatter(&move |x| centred(*x, &attacks))
            .y_label_formatter(&move |y| centred(*y, &dets))
            .x_label_style(("sans-serif", 12))
            .draw()
            .map_err(plots::err)?;
        for (ai, a) in opts.attacks.iter().enumerate() {
            for (di, d) in detectors.iter().enumerate() {
                let f1 = mean(group(rows, a, intensity.name(), "log", d).map(|r| r.f1));
                let color = match f1 {
                    // White (0) to dark green (1).
                    Some(v) => RGBColor(
                        (255.0 * (1.0 - 0.8 * v)) as u8,
                        (255.0 * (1.0 - 0.45 * v)) as u8,
                        (255.0 * (1.0 - 0.8 * v)) as u8,
                    ),
                    None => RGBColor(200, 200, 200),
                };
                let (x, y) = (ai as f64, di as f64);
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x, y), (x + 1.0, y + 1.0)],
                        ShapeStyle::from(&color).filled(),
                    )))
                    .map_err(plots::err)?;
                let text = f1.map_or("n/a".into(), |v| format!("{v:.2}"));
                chart
                    .draw_series(std::iter::once(Text::new(
                        text,
                        (x + 0.35, y + 0.6),
                        ("sans-serif", 14),
                    )))
                    .map_err(plots::err)?;
            }
        }
    }
    root.present().map_err(plots::err)?;
    Ok(())
}

fn attacks_len(opts: &DetectionOptions) -> usize {
    opts.attacks.len().max(1)
}

/// The name of the cell whose centre is at `x` (labels fall on halves), else nothing.
fn centred(x: f64, names: &[String]) -> String {
    let i = x.floor() as usize;
    if (x - x.floor() - 0.5).abs() < 1e-6 && i < names.len() {
        names[i].clone()
    } else {
        String::new()
    }
}

impl Experiment for Detection {
    type Options = DetectionOptions;
    const NAME: &'static str = "detection";
    const DIR: &'static str = "runs/detection";
    const BASE: Embedded = Embedded::Paper;
    fn validate(opts: &DetectionOptions) -> Result<()> {
        opts.validate()
    }
    fn measure(
        base: &Base,
        opts: &DetectionOptions,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(base, opts, out, progress)
    }
    fn write(&self, _base: &Base, opts: &DetectionOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts, dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
