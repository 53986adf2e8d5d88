//! Security in the loop: attacker by defence by law ([`security`], issue 52 item 5).
use super::maneuvers::configure;
use super::{
    bars_by_law, check_names, refuse, repeats, walk, write_table, Base, Experiment,
    ExperimentError, Result,
};
use crate::progress::Progress;
use platoon_config::{
    ActsAsConfig, Config, CutInConfig, CutInHandling, DetectionConfig, Embedded,
    FalseReportsConfig, GroupConfig, LawName, LinkAttackConfig, LinkKindConfig, ReportsConfig,
    SecurityConfig,
};
use platoon_control::Role;
use platoon_output::plots;
use platoon_output::rundir::RunDir;
use std::fmt::Write as _;

/// The attackers of [`security`], by name, on `configs/leave.toml` without its own leaves:
/// none; an outsider forging a leave notice in follower 1's name at 10 s; an insider
/// (follower 2) claiming from 20 s to be 3 m further ahead and 1 m/s faster than it is; an
/// insider (follower 2) feigning a -6 m/s^2 braking from 20 s; a Sybil with follower 4's
/// stolen key forging a leave notice in follower 3's name at 10 s; an insider (follower 3)
/// reporting honest follower 1 from 5 s on; no attacker but a benign car that cuts in ahead of
/// follower 3 at 25 s, brakes, and leaves the lane at 32 s (whom do honest flags get revoked?).
pub const ATTACKERS: [&str; 7] = [
    "none",
    "outsider-forgery",
    "insider-false-data",
    "insider-feigned-braking",
    "stolen-key-sybil",
    "false-reports",
    "benign-cut-in",
];

/// The defences of [`security`], each adding to the one before: none (unsigned, no
/// detectors), signatures (`[security]`), a group key (`[security.group]`, a MAC on the
/// maneuver messages), local detection (the three detectors, reaction `log`), reports and
/// revocation (`[security.reports]`, its defaults).
pub const DEFENCES: [&str; 5] = ["none", "signatures", "group", "detection", "reports"];

/// How [`security`] runs; [`SecurityOptions::default`] is `platoon experiment security`'s
/// default.
#[derive(Debug, Clone, PartialEq)]
pub struct SecurityOptions {
    /// The attackers (`--attackers`), names of [`ATTACKERS`].
    pub attackers: Vec<String>,
    /// The defences (`--defences`), names of [`DEFENCES`].
    pub defences: Vec<String>,
    /// The laws (`--laws`).
    pub laws: Vec<LawName>,
    /// Each run's length (s, `--duration`), over 20 s (the insiders start lying at 20 s).
    pub duration_s: f64,
    /// Seeded repeats of each cell (`--repeats`): the radars' noise, the channel's and the
    /// uplink's draws and the keys.
    pub repeats: u32,
    /// On the 802.11p channel with this density of other traffic (vehicles/m,
    /// `--radio-density`; the model's other parameters its defaults, the load the scenario's):
    /// the packets are as large on the air as signing and the group key make them. `None`:
    /// the ideal radio.
    pub radio_density: Option<f64>,
}

impl Default for SecurityOptions {
    fn default() -> Self {
        Self {
            attackers: ATTACKERS.iter().map(|a| a.to_string()).collect(),
            defences: DEFENCES.iter().map(|d| d.to_string()).collect(),
            laws: vec![LawName::Paper, LawName::PathCacc],
            duration_s: 40.0,
            repeats: 1,
            radio_density: None,
        }
    }
}

impl SecurityOptions {
    /// Fails on empty lists, unknown names, a law that refuses leaves and a run too short.
    pub fn validate(&self) -> Result<()> {
        check_names("--attackers", &self.attackers, &ATTACKERS)?;
        check_names("--defences", &self.defences, &DEFENCES)?;
        if self.laws.is_empty() {
            refuse!(
                Options,
                "--laws needs at least one law, e.g. paper,path_cacc"
            );
        }
        if self.laws.contains(&LawName::Consensus) {
            refuse!(
                Options,
                "--laws: the consensus law refuses leaves, and a revoked member is ejected by \
                 one; use paper, acc, ploeg, path_cacc or flatbed"
            );
        }
        if self.repeats == 0 {
            refuse!(Options, "--repeats must be at least 1");
        }
        if let Some(d) = self.radio_density {
            if !(d.is_finite() && d >= 0.0) {
                refuse!(
                    Options,
                    "--radio-density must be a density >= 0 (vehicles/m), got {d}"
                );
            }
        }
        if !(self.duration_s.is_finite() && self.duration_s > 21.0) {
            refuse!(
                Options,
                "--duration must be over 21 s (the insiders lie from 20 s), got {}",
                self.duration_s
            );
        }
        Ok(())
    }
}

/// One run of [`security`] (a row of security.csv).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SecurityRow {
    /// The law's config name.
    pub law: &'static str,
    /// The attacker ([`ATTACKERS`]).
    pub attacker: String,
    /// The defence ([`DEFENCES`]).
    pub defence: String,
    /// The repeat (its seeds).
    pub repeat: u32,
    /// Any vehicle collided (the plant's measure).
    pub collided: bool,
    /// The smallest gap to the vehicle ahead on the lane (m).
    pub min_gap_m: f64,
    /// The largest |spacing error| of a follower still in the platoon (m).
    pub max_spacing_error_m: f64,
    /// Followers that left the lane by the end (ejected by a forged notice or a revocation).
    pub left_lane: usize,
    /// Deliveries the seals refused (0 unsigned).
    pub refused: u64,
    /// Signatures verified per step (0 unsigned): the verification load.
    pub verified_per_step: f64,
    /// Reports filed (0 without reports).
    pub reports: u64,
    /// The vehicles revoked, `+`-separated (empty: none).
    pub revoked: String,
    /// From the attacker's first lie to its revocation (s), for the lying attackers.
    pub time_to_revocation_s: Option<f64>,
    /// Revocations of vehicles whose key signed no lie (the ground truth).
    pub false_revocations: usize,
    /// A packet's size on the air, as the 802.11p model takes it (bytes: the configured size
    /// and what security adds; 0 on the ideal radio).
    pub packet_bytes: u32,
    /// The share of the deliveries the channel owed that arrived as sent (the wire's count:
    /// losses on the air, refused or altered packets excluded).
    pub delivered_share: f64,
}

/// [`security`]'s result.
#[derive(Debug, Clone, PartialEq)]
pub struct Security {
    /// Law by law, attacker by attacker, defence by defence.
    pub rows: Vec<SecurityRow>,
    /// security.md.
    pub markdown: String,
}

/// Every attacker of `opts` against every defence under every law, in process, on
/// `configs/leave.toml` without its own leaves (each law on its own distances, the guard on:
/// [`super::maneuvers`]'s configuration). With `out`: security.csv, security.md and a plot of
/// the smallest gap per law.
pub fn security(
    opts: &SecurityOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Security> {
    super::run::<Security>(&Base::load(None, Security::BASE)?, opts, out, progress)
}

fn measure(base: &Config, opts: &SecurityOptions, progress: &dyn Progress) -> Result<Security> {
    let mut base = base.clone();
    if let Some(m) = &mut base.maneuvers {
        m.leaves.clear();
    }
    base.simulation.duration_s = opts.duration_s;
    let mut cells = Vec::new();
    for &law in &opts.laws {
        for attacker in &opts.attackers {
            for defence in &opts.defences {
                cells.extend((0..opts.repeats).map(|r| (law, attacker, defence, r)));
            }
        }
    }
    let rows = walk(
        progress,
        "simulating",
        cells,
        |(law, attacker, defence, r)| format!("{}, {attacker}, {defence}, repeat {r}", law.name()),
        |(law, attacker, defence, r)| cell(&base, law, (attacker, defence), r, opts.radio_density),
    )?;
    let markdown = markdown(&rows);
    Ok(Security { rows, markdown })
}

/// When the lying attackers lie first (s).
fn lies_from(attacker: &str) -> Option<f64> {
    match attacker {
        "insider-false-data" | "insider-feigned-braking" => Some(20.0),
        "stolen-key-sybil" => Some(10.0),
        _ => None,
    }
}

/// `base` under `law` with `attacker` and `defence`, its seeds moved by `repeat`, on the
/// 802.11p channel with `radio_density` of other traffic.
fn configured(
    base: &Config,
    law: LawName,
    (attacker, defence): (&str, &str),
    repeat: u32,
    radio_density: Option<f64>,
) -> Config {
    let mut c = configure(base, law);
    if let Some(density_veh_per_m) = radio_density {
        c.channel.model = platoon_config::RadioModel::Ieee80211p;
        c.channel.radio = Some(platoon_radio::Params80211p {
            density_veh_per_m,
            ..Default::default()
        });
    }
    c.radar.seed = c.radar.seed.wrapping_add(u64::from(repeat));
    c.channel.seed = c.channel.seed.wrapping_add(u64::from(repeat));
    let link = |kind, senders: u16, start_s: f64, end_s: f64| LinkAttackConfig {
        kind,
        start_s,
        end_s,
        senders: Some(vec![senders]),
        receivers: None,
        acts_as: None,
        key_of: None,
    };
    let forged_leave = || LinkKindConfig::ForgeManeuver {
        message: "leave_notice".into(),
        insider: false,
    };
    let insider = |kind| LinkAttackConfig {
        acts_as: Some(ActsAsConfig::Insider),
        ..link(kind, 2, 20.0, f64::INFINITY)
    };
    match attacker {
        "outsider-forgery" => c.channel.attacks.push(LinkAttackConfig {
            receivers: Some(vec![0]),
            ..link(forged_leave(), 1, 10.0, 10.2)
        }),
        "insider-false-data" => c.channel.attacks.push(insider(LinkKindConfig::FalseData {
            offset: [3.0, 1.0, 0.0],
            insider: false,
        })),
        "insider-feigned-braking" => {
            c.channel
                .attacks
                .push(insider(LinkKindConfig::FeignedBraking {
                    accel_mps2: -6.0,
                    insider: false,
                }))
        }
        "stolen-key-sybil" => c.channel.attacks.push(LinkAttackConfig {
            receivers: Some(vec![0]),
            acts_as: Some(ActsAsConfig::Thief),
            key_of: Some(4),
            ..link(forged_leave(), 3, 10.0, 10.2)
        }),
        "benign-cut-in" => {
            c.cut_ins.push(CutInConfig {
                at_s: 25.0,
                ahead_of: 3,
                gap_m: None,
                speed_diff_mps: -2.0,
                decel_mps2: 2.0,
                brake_s: 1.0,
                leave_s: Some(32.0),
                length_m: None,
                aggressive: false,
            });
            c.fallback.cut_in = Some(CutInHandling::default());
        }
        _ => {}
    }
    let level = DEFENCES.iter().position(|d| *d == defence).unwrap_or(0);
    if level >= 1 {
        c.security = Some(SecurityConfig {
            seed: u64::from(repeat),
            ..SecurityConfig::default()
        });
    }
    if level >= 2 {
        if let Some(s) = &mut c.security {
            s.group = Some(GroupConfig::default());
        }
    }
    if level >= 3 {
        c.detection = Some(DetectionConfig {
            plausibility: Some(Default::default()),
            radar_cross: Some(Default::default()),
            residual: Some(Default::default()),
            reaction: Default::default(),
            quiet_s: 1.0,
            plugin: Vec::new(),
        });
    }
    if level >= 4 {
        if let Some(s) = &mut c.security {
            s.reports = Some(ReportsConfig {
                false_reports: (attacker == "false-reports").then_some(FalseReportsConfig {
                    reporter: 3,
                    accused: 1,
                    start_s: 5.0,
                    end_s: f64::INFINITY,
                }),
                ..ReportsConfig::default()
            });
        }
    }
    c
}

fn cell(
    base: &Config,
    law: LawName,
    (attacker, defence): (&str, &str),
    repeat: u32,
    radio_density: Option<f64>,
) -> Result<SecurityRow> {
    let mut c = configured(base, law, (attacker, defence), repeat, radio_density);
    let scenario = match platoon_config::to_scenario(&mut c) {
        Ok(s) => s,
        Err(platoon_config::KeyError { key, reason: e }) => refuse!(
            Variant,
            "key `{key}` with law {} under {attacker} against {defence}: {e}",
            law.name()
        ),
    };
    let dt = scenario.dt();
    let mut left_lane = 0;
    let mut max_spacing_error_m: f64 = 0.0;
    let summary = platoon_sim::run_until(&scenario, |sim| {
        let rows = sim.rows();
        left_lane = rows.iter().filter(|r| r.mode == Role::Left).count();
        for r in rows
            .iter()
            .filter(|r| r.vehicle > 0 && r.mode != Role::Left)
        {
            max_spacing_error_m = max_spacing_error_m.max(r.spacing_error.abs());
        }
        std::ops::ControlFlow::Continue(())
    })?;
    let security = summary.security.as_ref();
    let reports = security.and_then(|s| s.reports.as_ref());
    let revoked = reports.map_or(&[][..], |r| r.revoked.as_slice());
    // The lying attackers: follower 2 (insiders) or the owner of the stolen key (4).
    let liar = match attacker {
        "stolen-key-sybil" => Some(4),
        a if a.starts_with("insider") => Some(2),
        _ => None,
    };
    let time_to_revocation_s = lies_from(attacker).and_then(|from| {
        let r = revoked.iter().find(|r| Some(r.vehicle) == liar)?;
        Some(r.step as f64 * dt - from)
    });
    let steps = scenario.steps.max(1) as f64;
    Ok(SecurityRow {
        law: law.name(),
        attacker: attacker.to_string(),
        defence: defence.to_string(),
        repeat,
        collided: summary.safety.collided,
        min_gap_m: summary.safety.min_gap_m,
        max_spacing_error_m,
        left_lane,
        refused: security.map_or(0, |s| s.refused_total),
        verified_per_step: security.map_or(0.0, |s| s.verified as f64 / steps),
        reports: reports.map_or(0, |r| r.filed),
        revoked: revoked
            .iter()
            .map(|r| r.vehicle.to_string())
            .collect::<Vec<_>>()
            .join("+"),
        time_to_revocation_s,
        false_revocations: revoked
            .iter()
            .filter(|r| r.signed_a_lie == Some(false))
            .count(),
        packet_bytes: scenario
            .radio
            .as_ref()
            .map_or(0, |r| r.family.params().packet_bytes),
        delivered_share: summary.wire.as_ref().map_or(f64::NAN, |w| {
            w.totals.delivered_as_sent as f64 / w.totals.sent.max(1) as f64
        }),
    })
}

/// security.md: a row per cell, the worst case over its repeats (collided in any, the
/// smallest gap, the largest error, refusals and reports, every vehicle revoked in any, the
/// longest time to revocation, the mean verification load) and the false revocations summed.
fn markdown(rows: &[SecurityRow]) -> String {
    let mut md = String::from(
        "| law | attacker | defence | collided | min gap (m) | max spacing error (m) | left the lane | refused | verified per step | reports | revoked | time to revocation (s) | false revocations |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for ((law, attacker, defence), same) in
        repeats(rows, |r| (r.law, r.attacker.as_str(), r.defence.as_str()))
    {
        let max = |f: fn(&SecurityRow) -> u64| same.iter().map(|r| f(r)).max().unwrap_or(0);
        let mut revoked: Vec<&str> = Vec::new();
        for v in same.iter().flat_map(|r| r.revoked.split('+')) {
            if !v.is_empty() && !revoked.contains(&v) {
                revoked.push(v);
            }
        }
        let revoked = if revoked.is_empty() {
            "-".to_string()
        } else {
            revoked.join("+")
        };
        let time = (same.iter().filter_map(|r| r.time_to_revocation_s))
            .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.max(t))));
        let n = same.len().max(1) as f64;
        let _ = writeln!(
            md,
            "| {law} | {attacker} | {defence} | {} | {:.2} | {:.2} | {} | {} | {:.2} | {} | {revoked} | {} | {} |",
            if same.iter().any(|r| r.collided) { "yes" } else { "no" },
            same.iter().map(|r| r.min_gap_m).fold(f64::INFINITY, f64::min),
            same.iter().map(|r| r.max_spacing_error_m).fold(0.0, f64::max),
            max(|r| r.left_lane as u64),
            max(|r| r.refused),
            same.iter().map(|r| r.verified_per_step).sum::<f64>() / n,
            max(|r| r.reports),
            time.map_or("-".to_string(), |t| format!("{t:.2}")),
            same.iter().map(|r| r.false_revocations).sum::<usize>(),
        );
    }
    if rows.iter().any(|r| r.packet_bytes > 0) {
        md.push_str(
            "\nOn the 802.11p channel (the worst delivery over the repeats):\n\n| law | attacker | defence | packet on the air (bytes) | delivered as sent |\n|---|---|---|---|---|\n",
        );
        for ((law, attacker, defence), same) in
            repeats(rows, |r| (r.law, r.attacker.as_str(), r.defence.as_str()))
        {
            let _ = writeln!(
                md,
                "| {law} | {attacker} | {defence} | {} | {:.4} |",
                same[0].packet_bytes,
                same.iter().map(|r| r.delivered_share).fold(1.0, f64::min),
            );
        }
    }
    md
}

impl Security {
    fn write_files(&self, opts: &SecurityOptions, dir: &RunDir) -> Result<()> {
        write_table(dir, "security", &self.rows, &self.markdown)?;
        for attacker in &opts.attackers {
            let groups = bars_by_law(&opts.laws, &opts.defences, |law, d| {
                (self.rows.iter())
                    .filter(|r| r.attacker == *attacker && r.law == law && r.defence == d)
                    .map(|r| r.min_gap_m.max(0.0))
                    .reduce(f64::min)
                    .unwrap_or(0.0)
            });
            plots::grouped_bars(
                &dir.path(&format!("security-{attacker}.png")),
                &format!("{attacker}: smallest gap on the lane by defence (0 = collided)"),
                "smallest gap (m)",
                &opts.defences,
                &groups,
            )?;
        }
        Ok(())
    }
}

/// The runs are on `configs/leave.toml`: the base is the embedded one.
impl Experiment for Security {
    type Options = SecurityOptions;
    const NAME: &'static str = "security";
    const DIR: &'static str = "runs/security";
    const BASE: Embedded = Embedded::Leave;
    fn validate(opts: &SecurityOptions) -> Result<()> {
        opts.validate()
    }
    fn measure(
        base: &Base,
        opts: &SecurityOptions,
        _out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(&base.config, opts, progress)
    }
    fn write(&self, _base: &Base, opts: &SecurityOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts, dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
