//! Cut-ins by law and attack ([`traffic`]).
use super::{
    configure_law, in_formation, keep_law_spacing, on_standstill, refuse, repeats, walk,
    write_config, write_table, Base, Experiment, ExperimentError, Result,
};
use crate::error::OtherError;
use crate::progress::Progress;
use platoon_config::{Embedded, LawName, LinkAttackConfig, LinkKindConfig, PlantKind};
use platoon_output::plots;
use platoon_output::rundir::RunDir;
use platoon_topology::Preset;
use std::fmt::Write as _;

/// The attacks of [`traffic`], by name: none, a periodic DoS, a false-data bias and a feigned
/// braking, the last two on the packets of the member ahead of the cut-in while the car is
/// between it and the follower (the follower's radar cannot check them then).
pub const ATTACKS: [&str; 4] = ["none", "periodic-dos", "fdi-bias", "feigned-braking"];

/// How [`traffic`] runs; [`TrafficOptions::default`] is `platoon experiment traffic`'s default.
#[derive(Debug, Clone, PartialEq)]
pub struct TrafficOptions {
    /// The laws (`--laws`).
    pub laws: Vec<LawName>,
    /// The gap the car leaves to the follower as it cuts in (m, `--gaps`).
    pub gaps_m: Vec<f64>,
    /// Its speed minus the follower's as it cuts in (m/s, `--speed-diffs`).
    pub speed_diffs_mps: Vec<f64>,
    /// The attacks (`--attacks`), names of [`ATTACKS`].
    pub attacks: Vec<String>,
    /// Seeded repeats of each cell (`--repeats`): the radars' noise and the channel's losses.
    pub repeats: u32,
    /// The plant (`--plant`): native, in process; or SUMO, each run a co-simulation with SUMO
    /// as the plant (`platoon run --plant sumo`), its run directory under `runs/`.
    pub plant: PlantKind,
}

impl Default for TrafficOptions {
    fn default() -> Self {
        Self {
            laws: LawName::ALL.to_vec(),
            gaps_m: vec![3.0, 6.0],
            speed_diffs_mps: vec![-4.0, 0.0],
            attacks: ATTACKS.iter().map(|a| a.to_string()).collect(),
            repeats: 1,
            plant: PlantKind::Native,
        }
    }
}

impl TrafficOptions {
    /// Fails on empty lists, unknown attacks and values that are no gaps or speeds.
    pub fn validate(&self) -> Result<()> {
        if self.laws.is_empty() {
            refuse!(Options, "--laws needs at least one law, e.g. paper,ploeg");
        }
        if self.gaps_m.is_empty() || self.gaps_m.iter().any(|g| !(g.is_finite() && *g >= 0.0)) {
            refuse!(
                Options,
                "--gaps needs gaps >= 0 m, e.g. 3,6 (got {:?})",
                self.gaps_m
            );
        }
        if self.speed_diffs_mps.is_empty() || self.speed_diffs_mps.iter().any(|v| !v.is_finite()) {
            refuse!(
                Options,
                "--speed-diffs needs finite speeds in m/s, e.g. -4,0"
            );
        }
        if self.attacks.is_empty() {
            refuse!(
                Options,
                "--attacks needs at least one of {}",
                ATTACKS.join(", ")
            );
        }
        if let Some(a) = self.attacks.iter().find(|a| !ATTACKS.contains(&a.as_str())) {
            refuse!(
                Options,
                "--attacks: unknown attack {a:?}; use {}",
                ATTACKS.join(", ")
            );
        }
        if self.repeats == 0 {
            refuse!(Options, "--repeats must be at least 1");
        }
        Ok(())
    }
}

/// One run of [`traffic`] (a row of traffic.csv).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TrafficRow {
    /// The law's config name.
    pub law: &'static str,
    /// The topology it ran on: `pf`, or `plf` for the laws that need the leader.
    pub topology: &'static str,
    /// The gap the car left to the follower as it cut in (m).
    pub gap_m: f64,
    /// Its speed minus the follower's (m/s).
    pub speed_diff_mps: f64,
    /// The attack ([`ATTACKS`]).
    pub attack: String,
    /// The repeat (its seeds).
    pub repeat: u32,
    /// A gap reached zero (to the car or within the platoon).
    pub collided: bool,
    /// The smallest gap of any follower to the vehicle ahead of it, the car included (m).
    pub min_gap_m: f64,
    /// The follower behind the car, on ACC on it (s).
    pub cut_in_s: f64,
    /// All followers outside their law: attack fallbacks, cut-ins and the way back (s, summed).
    pub fallback_s: f64,
    /// The longest time any follower's command was held within its vehicle class's limits (s,
    /// `saturated_time_s` of summary.json); `None` for a base without vehicle classes.
    pub saturated_s: Option<f64>,
    /// Packets the detectors flagged that were genuine.
    pub false_alarms: u64,
    /// Forged packets they flagged.
    pub detected: u64,
    /// Forged packets they let through.
    pub missed: u64,
}

/// [`traffic`]'s result.
#[derive(Debug, Clone, PartialEq)]
pub struct Traffic {
    /// Law by law, gap by gap, speed by speed, attack by attack, repeat by repeat.
    pub rows: Vec<TrafficRow>,
    /// traffic.md: the table, worst case over the repeats.
    pub markdown: String,
}

/// Every law of `opts` against a car cutting in ahead of the base's cut-in follower at each gap
/// and speed difference (an aggressive car: it cuts in at that gap whether the lane-change
/// rule finds it safe or not), under each attack, in process: the base scenario (`configs/cut-in.toml`
/// by default: its car, its vehicles (passenger cars with limits), profile, `[fallback.cut_in]`
/// and radar) with each law on its own beaconing and on the base's distances (each law's standstill gap set to the platoon's, so the
/// car fits the same gap), on `pf`, or `plf` for the laws that need the leader, and the paper's
/// law also on its own TPSF, the guard on, the split behind the car as the base's
/// `[fallback.cut_in]` has it (by default the laws that steer on vehicles ahead of the car
/// split), and the three built-in detectors logging. With `out`: config.toml, traffic.csv, traffic.md and
/// one smallest-gap plot per gap. On SUMO (`opts.plant`) every run is `platoon run --plant sumo`
/// of the same scenario (the cut-in a SUMO vehicle), its run directory (summary.json,
/// sumo.json, the logs; no per-step tables) in `runs/<law>[-tpsf]-gap<G>-dv<V>-<attack>-r<R>` of `out`
/// (without `out`, of a temporary directory); SUMO's collisions count as collisions.
pub fn traffic(
    base: &Base,
    opts: &TrafficOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Traffic> {
    super::run::<Traffic>(base, opts, out, progress)
}

/// [`traffic`]'s cells (and their runs' directories in `out`), without its tables and figures.
fn measure(
    base: &Base,
    opts: &TrafficOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Traffic> {
    if base.config.cut_ins.is_empty() {
        refuse!(
            Base,
            "{}: has no [[cut_ins]]; the experiment varies the first one",
            base.label
        );
    }
    write_config(out, &base.config)?;
    // Where the SUMO runs go.
    let tmp;
    let runs = match (opts.plant, out) {
        (PlantKind::Native, _) => None,
        (PlantKind::Sumo, Some(dir)) => Some(dir.path("runs")),
        (PlantKind::Sumo, None) => {
            tmp = tempfile::tempdir().map_err(|e| {
                ExperimentError::Other(OtherError::context("a directory for the runs", e))
            })?;
            Some(tmp.path().to_path_buf())
        }
    };
    let mut cells = Vec::new();
    for &law in &opts.laws {
        for &gap in &opts.gaps_m {
            for &dv in &opts.speed_diffs_mps {
                for attack in &opts.attacks {
                    for own in [None].into_iter().chain(own_topology(law).map(Some)) {
                        cells.extend((0..opts.repeats).map(|repeat| Cell {
                            law,
                            own,
                            gap,
                            dv,
                            attack,
                            repeat,
                        }));
                    }
                }
            }
        }
    }
    let on = Plant {
        runs: runs.as_deref(),
        label: &base.label,
    };
    let rows = walk(
        progress,
        "simulating",
        cells,
        |c| {
            format!(
                "{}{}, gap {} m, {:+} m/s, {}, repeat {}",
                c.law.name(),
                c.own.map_or(String::new(), |p| format!(" on {}", p.name())),
                c.gap,
                c.dv,
                c.attack,
                c.repeat
            )
        },
        |c| cell(base, &c, on),
    )?;
    let markdown = markdown(&rows);
    Ok(Traffic { rows, markdown })
}

/// Where a cell runs: in process, or on SUMO with its run directory in `runs`.
#[derive(Clone, Copy)]
struct Plant<'a> {
    runs: Option<&'a std::path::Path>,
    label: &'a str,
}

impl Plant<'_> {
    /// The summary of `config`'s run (its scenario `scenario`), named `name` on SUMO.
    fn run(
        self,
        mut config: platoon_config::Config,
        scenario: platoon_sim::Scenario,
        name: &str,
    ) -> Result<platoon_sim::Summary> {
        let Some(runs) = self.runs else {
            return Ok(platoon_sim::run(scenario, |_| {})?);
        };
        // The summary is what the row needs: no per-step tables, no replay file.
        config.output.files.clear();
        config.sumo.fcd_period_s = Some(0.0);
        let opts = crate::run::RunOptions {
            plant: Some(PlantKind::Sumo),
            plots: false,
            // A stall, not a deadline: the machine may be busy with other runs.
            step_timeout: std::time::Duration::from_secs(30),
            config_file: std::path::PathBuf::from(self.label),
            ..Default::default()
        };
        let failed = |e: crate::BoxError| {
            ExperimentError::Other(OtherError::context(format!("the run {name} on SUMO"), e))
        };
        let dir = runs.join(name);
        let outcome = crate::run::run(
            config,
            &scenario,
            &opts,
            &dir,
            true,
            &Default::default(),
            &(),
        )
        .map_err(|e| match e.config() {
            // Refused as a bad config is, whoever runs it (`platoon experiment` exits 2).
            Some(_) => ExperimentError::from(e),
            None => failed(e.into()),
        })?;
        match outcome.failure {
            Some(e) => Err(failed(
                OtherError::context(format!("see {}", outcome.dir.join("logs").display()), e)
                    .into(),
            )),
            None => Ok(outcome.summary),
        }
    }
}

/// One cell of the table: a law (on `pf`, or `plf` if it needs the leader; or on `own`, its
/// own topology), the cut-in's gap (m) and speed difference (m/s), an attack, and which
/// repeat.
struct Cell<'a> {
    law: LawName,
    own: Option<Preset>,
    gap: f64,
    dv: f64,
    attack: &'a str,
    repeat: u32,
}

/// The topology a law was designed on, where it is neither `pf` nor the `plf` it needs for
/// the leader: the paper's law's TPSF (Section IV of the paper).
fn own_topology(law: LawName) -> Option<Preset> {
    (law == LawName::Paper).then_some(Preset::Tpsf)
}

/// The row of `cell` (on its own topology, or on pf, or plf for a law that needs the leader),
/// run on `plant`.
fn cell(base: &Base, cell: &Cell<'_>, plant: Plant<'_>) -> Result<TrafficRow> {
    let &Cell {
        law,
        own,
        gap,
        dv,
        attack,
        repeat,
    } = cell;
    let mut last = None;
    let presets = match own {
        Some(p) => vec![p],
        None => vec![Preset::Pf, Preset::Plf],
    };
    for preset in presets {
        let mut c = configure(&base.config, law, preset);
        let first = &mut c.cut_ins[0];
        first.gap_m = Some(gap);
        first.speed_diff_mps = dv;
        // The grid's gaps are the study's: the car cuts in at them, safe or not.
        first.aggressive = true;
        let (at, ahead_of) = (first.at_s, first.ahead_of);
        let until = first.leave_s.unwrap_or(c.simulation.duration_s);
        apply_attack(&mut c, attack, ahead_of - 1, at, until);
        c.radar.seed = c.radar.seed.wrapping_add(u64::from(repeat));
        c.channel.seed = c.channel.seed.wrapping_add(u64::from(repeat));
        let scenario = match platoon_config::to_scenario(&mut c) {
            Ok(s) => s,
            // The law needs the leader: the next topology gives it.
            Err(e) if matches!(e.reason, platoon_config::Reason::Unheard(_)) => {
                last = Some(e.reason.to_string());
                continue;
            }
            Err(platoon_config::KeyError { key, reason: e }) => refuse!(
                Variant,
                "{}: key `{key}` with law {} under {attack}: {e}",
                base.label,
                law.name()
            ),
        };
        let on = own.map_or(String::new(), |p| format!("-{}", p.name()));
        let name = format!("{}{on}-gap{gap}-dv{dv}-{attack}-r{repeat}", law.name());
        let s = plant.run(c, scenario, &name)?;
        let time_in = |v: &platoon_sim::VehicleSummary, mode: Option<&str>| {
            v.mode_time_s
                .iter()
                .filter(|(m, _)| mode.map_or(m.as_str() != "coop", |x| m.as_str() == x))
                .fold(0.0, |sum, (_, t)| sum + t)
        };
        let d = s.detection.as_ref();
        let any =
            |f: fn(&platoon_sim::detection::Confusion) -> u64| d.map_or(0, |d| f(&d.any.totals));
        return Ok(TrafficRow {
            law: law.name(),
            topology: preset.name(),
            gap_m: gap,
            speed_diff_mps: dv,
            attack: attack.to_string(),
            repeat,
            collided: s.safety.collided,
            min_gap_m: s.safety.min_gap_m,
            cut_in_s: time_in(&s.vehicles[ahead_of - 1], Some("cut_in")),
            fallback_s: s.vehicles.iter().fold(0.0, |sum, v| sum + time_in(v, None)),
            saturated_s: s
                .vehicles
                .iter()
                .filter_map(|v| v.saturated_time_s)
                .reduce(f64::max),
            false_alarms: any(|c| c.fp),
            detected: any(|c| c.tp),
            missed: any(|c| c.fn_),
        });
    }
    Err(ExperimentError::Variant(format!(
        "law {} runs on none of its topologies: {}",
        law.name(),
        last.unwrap_or_default()
    )))
}

/// The base config with `law` on `preset` as [`traffic`] runs it: the law's own beaconing, its
/// standstill gap the platoon's, the guard on, the built-in detectors logging.
fn configure(
    base: &platoon_config::Config,
    law: LawName,
    preset: Preset,
) -> platoon_config::Config {
    let mut c = configure_law(base, law, preset, 0.1);
    on_standstill(
        &mut c.control.law,
        base.platoon.spacing_m - base.platoon.vehicle_length_m,
    );
    keep_law_spacing(&mut c);
    in_formation(&mut c);
    c.guard.enabled = true;
    // `[fallback.cut_in] split` as the base has it: absent, the laws that read the leader's
    // packets, and the paper's law on a graph beyond the predecessor, split the platoon behind
    // the car, so the followers behind it keep their distance to the member that drops back
    // (docs/traffic.md).
    let detection = c.detection.get_or_insert_with(Default::default);
    detection.plausibility.get_or_insert_with(Default::default);
    detection.radar_cross.get_or_insert_with(Default::default);
    detection.residual.get_or_insert_with(Default::default);
    c
}

/// The attack `name` of [`ATTACKS`] into the config (replacing its own): the link attacks on
/// `sender`'s packets from `from_s` to `until_s`.
fn apply_attack(
    c: &mut platoon_config::Config,
    name: &str,
    sender: usize,
    from_s: f64,
    until_s: f64,
) {
    c.attack = Default::default();
    c.channel.attacks.clear();
    let forged = |offset| LinkAttackConfig {
        kind: LinkKindConfig::FalseData {
            offset,
            insider: false,
        },
        start_s: from_s,
        end_s: until_s,
        senders: Some(vec![sender as u16]),
        receivers: None,
        acts_as: None,
        key_of: None,
    };
    match name {
        // 1 s of jamming every 5 s.
        "periodic-dos" => {
            c.attack.kind = platoon_config::DosConfig::Periodic {
                period_s: 5.0,
                duration_s: 1.0,
                offset_s: 2.0,
            }
        }
        // 2 m further ahead and 1 m/s faster than it is: the follower behind would close in.
        "fdi-bias" => c.channel.attacks.push(forged([2.0, 1.0, 0.0])),
        // Braking at 4 m/s^2 more than it does: the followers behind would brake for nothing.
        "feigned-braking" => c.channel.attacks.push(forged([0.0, 0.0, -4.0])),
        _ => {}
    }
}

fn markdown(rows: &[TrafficRow]) -> String {
    let mut md = String::from(
        "| law | topology | gap (m) | speed diff (m/s) | attack | collisions | min gap (m) | on the car (s) | outside the law (s) | saturated (s) | false alarms | forged detected | forged missed |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let cells = repeats(rows, |r| {
        (
            r.law,
            r.topology,
            r.gap_m,
            r.speed_diff_mps,
            r.attack.as_str(),
        )
    });
    for ((law, _, gap, dv, attack), same) in cells {
        let worst = |f: fn(&TrafficRow) -> f64| same.iter().map(|r| f(r)).fold(f64::NAN, f64::max);
        let _ = writeln!(
            md,
            "| {law} | {} | {gap} | {dv:+} | {attack} | {}/{} | {:.2} | {:.1} | {:.1} | {} | {} | {} | {} |",
            same[0].topology,
            same.iter().filter(|r| r.collided).count(),
            same.len(),
            same.iter().map(|r| r.min_gap_m).fold(f64::INFINITY, f64::min),
            worst(|r| r.cut_in_s),
            worst(|r| r.fallback_s),
            match same.iter().filter_map(|r| r.saturated_s).reduce(f64::max) {
                Some(s) => format!("{s:.1}"),
                None => "-".to_string(),
            },
            same.iter().map(|r| r.false_alarms).sum::<u64>(),
            same.iter().map(|r| r.detected).sum::<u64>(),
            same.iter().map(|r| r.missed).sum::<u64>(),
        );
    }
    md
}

impl Traffic {
    fn write_files(&self, opts: &TrafficOptions, dir: &RunDir) -> Result<()> {
        write_table(dir, "traffic", &self.rows, &self.markdown)?;
        let categories: Vec<String> = opts.attacks.clone();
        for &gap in &opts.gaps_m {
            // One group per law and topology it ran on, in the rows' order.
            let mut ran: Vec<(&str, &str)> = Vec::new();
            for r in &self.rows {
                if !ran.contains(&(r.law, r.topology)) {
                    ran.push((r.law, r.topology));
                }
            }
            let groups: Vec<(String, Vec<f64>)> = ran
                .iter()
                .map(|&(law, topology)| {
                    let values = opts
                        .attacks
                        .iter()
                        .map(|a| {
                            self.rows
                                .iter()
                                .filter(|r| {
                                    r.law == law
                                        && r.topology == topology
                                        && &r.attack == a
                                        && r.gap_m == gap
                                })
                                .map(|r| r.min_gap_m)
                                .fold(f64::INFINITY, f64::min)
                                .max(0.0)
                        })
                        .collect();
                    (format!("{law} ({topology})"), values)
                })
                .collect();
            plots::grouped_bars(
                &dir.path(&format!("traffic-gap{gap}.png")),
                &format!(
                    "Smallest gap, a car cutting in {gap} m ahead (worst case; 0 = collision)"
                ),
                "smallest gap (m)",
                &categories,
                &groups,
            )?;
        }
        Ok(())
    }
}

impl Experiment for Traffic {
    type Options = TrafficOptions;
    const NAME: &'static str = "traffic";
    const DIR: &'static str = "runs/traffic";
    const BASE: Embedded = Embedded::CutIn;
    fn validate(opts: &TrafficOptions) -> Result<()> {
        opts.validate()
    }
    fn plant(opts: &TrafficOptions) -> PlantKind {
        opts.plant
    }
    fn measure(
        base: &Base,
        opts: &TrafficOptions,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(base, opts, out, progress)
    }
    fn write(&self, _base: &Base, opts: &TrafficOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts, dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
