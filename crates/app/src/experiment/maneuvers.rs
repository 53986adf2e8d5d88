//! Maneuvers by law and attack ([`maneuvers`]).
use super::{
    bars_by_law, check_names, keep_law_spacing, law_config, on_standstill, refuse, repeats, walk,
    write_table, Base, Experiment, ExperimentError, Result,
};
use crate::progress::Progress;
use platoon_config::{Config, DosConfig, Embedded, LawName, LinkAttackConfig, LinkKindConfig};
use platoon_control::Role;
use platoon_output::plots;
use platoon_output::rundir::RunDir;
use std::fmt::Write as _;

/// The maneuvers of [`maneuvers`], by name: a join at the tail (`configs/join.toml`), one in
/// the middle (`configs/join-middle.toml`), a leave from the middle (`configs/leave.toml`'s
/// first), a merge of two platoons (`configs/merge.toml`) and a split of one
/// (`configs/split.toml`).
pub const MANEUVERS: [&str; 5] = ["join-tail", "join-middle", "leave", "merge", "split"];

/// The attacks of [`maneuvers`], by name, each from the maneuver's request on: none, the
/// channel jammed for 2 s (DoS), 30 % of the packets lost on every link, a reactive jammer on
/// one of its messages (the tail join's, the leave's, the merge's and the split's updates, the
/// middle join's move-in) and a forged message (an in-position report in the joiner's or the
/// rear head's name; for the leave a leave notice, for the split a split notice, in
/// follower 1's name).
pub const ATTACKS: [&str; 5] = ["none", "dos", "loss", "jam", "forge"];

/// The V2V security of [`maneuvers`]'s runs, by name: none (unsigned); signatures
/// (`[security]`); signatures and a group key on the maneuver messages (`[security.group]`).
/// With either, the forged messages are a thief's, signed with follower 2's stolen key (an
/// outsider's are refused at verification: docs/security.md).
pub const SECURITY: [&str; 3] = ["none", "signatures", "group"];

/// How [`maneuvers`] runs; [`ManeuversOptions::default`] is `platoon experiment maneuvers`'s
/// default.
#[derive(Debug, Clone, PartialEq)]
pub struct ManeuversOptions {
    /// The maneuvers (`--maneuvers`), names of [`MANEUVERS`].
    pub maneuvers: Vec<String>,
    /// The laws (`--laws`), the field's (the paper's runs on one graph and refuses maneuvers).
    pub laws: Vec<LawName>,
    /// The attacks (`--attacks`), names of [`ATTACKS`].
    pub attacks: Vec<String>,
    /// Seeded repeats of each cell (`--repeats`): the radars' noise and the channel's losses.
    pub repeats: u32,
    /// The runs' V2V security (`--security`), a name of [`SECURITY`].
    pub security: String,
}

impl Default for ManeuversOptions {
    fn default() -> Self {
        Self {
            maneuvers: MANEUVERS.iter().map(|m| m.to_string()).collect(),
            laws: LawName::ALL
                .into_iter()
                .filter(|l| *l != LawName::Paper)
                .collect(),
            attacks: ATTACKS.iter().map(|a| a.to_string()).collect(),
            repeats: 3,
            security: "none".into(),
        }
    }
}

impl ManeuversOptions {
    /// Fails on empty lists, unknown names, the paper's law and no repeats.
    pub fn validate(&self) -> Result<()> {
        check_names("--maneuvers", &self.maneuvers, &MANEUVERS)?;
        check_names("--attacks", &self.attacks, &ATTACKS)?;
        if self.laws.is_empty() {
            refuse!(
                Options,
                "--laws needs at least one law, e.g. path_cacc,ploeg"
            );
        }
        if self.laws.contains(&LawName::Paper) {
            refuse!(
                Options,
                "--laws: the paper's law runs on one graph for the whole run and refuses \
                 maneuvers; use the field's laws (acc, ploeg, path_cacc, consensus, flatbed)"
            );
        }
        if self.repeats == 0 {
            refuse!(Options, "--repeats must be at least 1");
        }
        check_names(
            "--security",
            std::slice::from_ref(&self.security),
            &SECURITY,
        )?;
        let regroups = self.maneuvers.iter().any(|m| m == "merge" || m == "split");
        if self.security == "group" && regroups {
            refuse!(
                Options,
                "--security group: a merge or a split with a group key is not modelled yet \
                 (docs/security.md#a-group-key-at-join); pass --maneuvers without merge and \
                 split, e.g. join-tail,join-middle,leave"
            );
        }
        Ok(())
    }
}

/// One run of [`maneuvers`] (a row of maneuvers.csv).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ManeuversRow {
    /// The maneuver ([`MANEUVERS`]).
    pub maneuver: String,
    /// The law's config name.
    pub law: &'static str,
    /// The attack ([`ATTACKS`]).
    pub attack: String,
    /// The repeat (its seeds).
    pub repeat: u32,
    /// `completed` (the joiner or the rear platoon's head admitted, the leaver out of the
    /// lane), `failed` (it was not, and
    /// nobody collided: the protocol ended it safely), `collided` or `refused` (the law refuses
    /// the maneuver: the consensus law and a leave).
    pub outcome: &'static str,
    /// From the request to the joiner's (the head's) admission or the leaver's leaving the
    /// lane (s).
    pub completion_s: Option<f64>,
    /// The largest |spacing error| of any member from the request on (m; a leave starts it at
    /// one slot for the members behind the leaver, counted in the formation from then on).
    pub max_spacing_error_m: f64,
    /// The smallest gap to the vehicle ahead on the lane over the run (m).
    pub min_gap_m: f64,
    /// Followers that left the lane by the end (the leaver, and any member a forged notice
    /// ejected).
    pub left_lane: usize,
    /// Maneuver messages the vehicles sent.
    pub messages: u64,
}

/// [`maneuvers`]'s result.
#[derive(Debug, Clone, PartialEq)]
pub struct Maneuvers {
    /// Maneuver by maneuver, law by law, attack by attack, repeat by repeat.
    pub rows: Vec<ManeuversRow>,
    /// maneuvers.md: the outcomes and the worst case over the repeats.
    pub markdown: String,
}

/// Every maneuver of `opts` under every law and attack, in process, each on its embedded
/// scenario (`configs/join.toml`, `configs/join-middle.toml`, `configs/merge.toml`,
/// `configs/leave.toml` with its
/// first leave only): each law on its own distances (the platoon's standstill gap, the
/// positions scaled to its spacing at the scenario's speed, so a joiner starts as far back or
/// beside as in the scenario), PATH CACC's leader-following topology, the guard on. With
/// `out`: maneuvers.csv, maneuvers.md and one completion-time plot per maneuver.
pub fn maneuvers(
    opts: &ManeuversOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Maneuvers> {
    super::run::<Maneuvers>(&Base::load(None, Maneuvers::BASE)?, opts, out, progress)
}

/// [`maneuvers`]'s cells, without its tables and figures (its runs keep no directory).
fn measure(opts: &ManeuversOptions, progress: &dyn Progress) -> Result<Maneuvers> {
    let bases = opts
        .maneuvers
        .iter()
        .map(|m| base(m))
        .collect::<Result<Vec<_>>>()?;
    let mut cells = Vec::new();
    for (maneuver, base) in opts.maneuvers.iter().zip(&bases) {
        for &law in &opts.laws {
            for attack in &opts.attacks {
                cells.extend((0..opts.repeats).map(|repeat| (base, maneuver, law, attack, repeat)));
            }
        }
    }
    let rows = walk(
        progress,
        "simulating",
        cells,
        |(_, maneuver, law, attack, repeat)| {
            format!("{maneuver}, {}, {attack}, repeat {repeat}", law.name())
        },
        |(base, maneuver, law, attack, repeat)| {
            cell(base, (maneuver, &opts.security), law, attack, repeat)
        },
    )?;
    let mut markdown = markdown(&rows);
    if opts.security != "none" {
        markdown.insert_str(
            0,
            &format!(
                "V2V security: {}; the forged messages are signed with follower 2's stolen key \
                 (a thief).\n\n",
                opts.security
            ),
        );
    }
    Ok(Maneuvers { rows, markdown })
}

/// The embedded scenario of `maneuver` (a leave: the first of `configs/leave.toml`'s).
fn base(maneuver: &str) -> Result<Config> {
    let embedded = match maneuver {
        "join-tail" => Embedded::Join,
        "join-middle" => Embedded::JoinMiddle,
        "merge" => Embedded::Merge,
        "split" => Embedded::Split,
        _ => Embedded::Leave,
    };
    let (mut config, _) = embedded.parse()?;
    if let Some(m) = &mut config.maneuvers {
        m.leaves.truncate(1);
    }
    Ok(config)
}

fn cell(
    base: &Config,
    (maneuver, security): (&str, &str),
    law: LawName,
    attack: &str,
    repeat: u32,
) -> Result<ManeuversRow> {
    let mut c = configure(base, law);
    let m = c.maneuvers.as_ref().expect("a maneuver scenario");
    let regroup = m.merge.as_ref().or(m.split.as_ref());
    let (vehicle, at_s) = match (m.joins.first(), regroup) {
        (Some(j), _) => (j.vehicle, j.at_s),
        (None, Some(g)) => (g.head, g.at_s),
        (None, None) => (m.leaves[0].vehicle, m.leaves[0].at_s),
    };
    apply_attack(&mut c, maneuver, attack, vehicle, at_s);
    secure(&mut c, security);
    c.radar.seed = c.radar.seed.wrapping_add(u64::from(repeat));
    c.channel.seed = c.channel.seed.wrapping_add(u64::from(repeat));
    let row = |outcome| ManeuversRow {
        maneuver: maneuver.to_string(),
        law: law.name(),
        attack: attack.to_string(),
        repeat,
        outcome,
        completion_s: None,
        max_spacing_error_m: f64::NAN,
        min_gap_m: f64::NAN,
        left_lane: 0,
        messages: 0,
    };
    let scenario = match platoon_config::to_scenario(&mut c) {
        Ok(s) => s,
        Err(e)
            if matches!(e.reason, platoon_config::Reason::LawWithoutManeuvers(_))
                && law == LawName::Consensus =>
        {
            return Ok(row("refused"))
        }
        Err(platoon_config::KeyError { key, reason: e }) => refuse!(
            Variant,
            "{maneuver}: key `{key}` with law {} under {attack}: {e}",
            law.name()
        ),
    };
    let mut left_lane = 0;
    let summary = platoon_sim::run_until(&scenario, |sim| {
        // Leaving is for good: the last step's count is everyone who left.
        left_lane = sim.rows().iter().filter(|r| r.mode == Role::Left).count();
        std::ops::ControlFlow::Continue(())
    })?;
    // The run's maneuver, as summary.json measures it.
    let measured = summary.maneuvers.as_ref().and_then(|m| {
        m.maneuvers
            .iter()
            .find(|r| r.vehicle == vehicle as u16)
            .map(|r| (r, m.messages_sent))
    });
    let Some((record, messages)) = measured else {
        refuse!(
            Variant,
            "{maneuver}: the summary of the run with law {} under {attack} measured no \
             maneuver of vehicle {vehicle}",
            law.name()
        );
    };
    let outcome = match (summary.safety.collided, record.completion_s) {
        (true, _) => "collided",
        (false, Some(_)) => "completed",
        (false, None) => "failed",
    };
    Ok(ManeuversRow {
        completion_s: record.completion_s,
        max_spacing_error_m: record.max_spacing_error_m.unwrap_or(f64::NAN),
        min_gap_m: summary.safety.min_gap_m,
        left_lane,
        messages,
        ..row(outcome)
    })
}

/// `base` with `law` as [`maneuvers`] runs it: the law's defaults on the platoon's standstill
/// gap (Plexe's ACC set above the profile's top speed), the platoon's spacing policy the law's,
/// every initial position scaled from the scenario's spacing to the law's at the scenario's
/// speed, the guard on.
pub(super) fn configure(base: &Config, law: LawName) -> Config {
    let mut c = base.clone();
    c.control.law = law_config(base, law);
    on_standstill(
        &mut c.control.law,
        base.platoon.spacing_m - base.platoon.vehicle_length_m,
    );
    let before = base.platoon.spacing_m;
    keep_law_spacing(&mut c);
    let speed = base
        .platoon
        .initial_states
        .as_ref()
        .and_then(|s| s.first())
        .map_or(0.0, |x| x[1]);
    let after = c.platoon.spacing_m
        + match c.platoon.spacing {
            platoon_config::SpacingConfig::TimeHeadway { time_headway_s } => time_headway_s * speed,
            _ => 0.0,
        };
    if let Some(states) = &mut c.platoon.initial_states {
        for x in states.iter_mut() {
            x[0] *= after / before;
        }
    }
    // Consensus weighs the leader: it hears it, as PATH CACC and flatbed do.
    c.guard.enabled = true;
    c
}

/// The V2V security `name` of [`SECURITY`] into the config: signed, the forgeries a thief's
/// (follower 2's stolen key); with a group key on the maneuver messages.
fn secure(c: &mut Config, name: &str) {
    if name == "none" {
        return;
    }
    c.security = Some(platoon_config::SecurityConfig {
        group: (name == "group").then(platoon_config::GroupConfig::default),
        ..platoon_config::SecurityConfig::default()
    });
    for a in &mut c.channel.attacks {
        if matches!(a.kind, LinkKindConfig::ForgeManeuver { .. }) {
            a.acts_as = Some(platoon_config::ActsAsConfig::Thief);
            a.key_of = Some(2);
        }
    }
}

/// The attack `name` of [`ATTACKS`] on `maneuver` into the config, from the request of
/// `vehicle` at `at_s` on.
fn apply_attack(c: &mut Config, maneuver: &str, name: &str, vehicle: usize, at_s: f64) {
    let link = |kind| LinkAttackConfig {
        kind,
        start_s: at_s,
        end_s: f64::INFINITY,
        senders: None,
        receivers: None,
        acts_as: None,
        key_of: None,
    };
    match name {
        "dos" => {
            c.attack.kind = DosConfig::Intervals {
                intervals: vec![[at_s, at_s + 2.0]],
            }
        }
        "loss" => c
            .channel
            .attacks
            .push(link(LinkKindConfig::Bernoulli { loss: 0.3 })),
        "jam" => {
            let message = match maneuver {
                "join-middle" => "move_in",
                _ => "update",
            };
            c.channel.attacks.push(link(LinkKindConfig::JamManeuvers {
                messages: vec![message.into()],
            }));
        }
        "forge" => {
            let (sender, message) = match maneuver {
                "leave" => (1, "leave_notice"),
                // A split nobody asked for, at follower 1.
                "split" => (1, "split_notice"),
                _ => (vehicle, "in_position"),
            };
            c.channel.attacks.push(LinkAttackConfig {
                senders: Some(vec![sender as u16]),
                start_s: at_s + 1.0,
                ..link(LinkKindConfig::ForgeManeuver {
                    message: message.into(),
                    insider: false,
                })
            });
        }
        _ => {}
    }
}

fn markdown(rows: &[ManeuversRow]) -> String {
    let mut md = String::from(
        "| maneuver | law | attack | completed | failed safely | collided | completion (s) | max spacing error (m) | min gap (m) | left the lane | messages |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let cells = repeats(rows, |r| (r.maneuver.as_str(), r.law, r.attack.as_str()));
    for ((maneuver, law, attack), same) in cells {
        if same.iter().all(|r| r.outcome == "refused") {
            let _ = writeln!(
                md,
                "| {maneuver} | {law} | {attack} | refused by the law | | | | | | | |"
            );
            continue;
        }
        let count = |o: &str| same.iter().filter(|r| r.outcome == o).count();
        let times: Vec<f64> = same.iter().filter_map(|r| r.completion_s).collect();
        let completion = match times.is_empty() {
            true => "-".to_string(),
            false => format!("{:.2}", times.iter().copied().fold(0.0, f64::max)),
        };
        let _ = writeln!(
            md,
            "| {maneuver} | {law} | {attack} | {}/{n} | {}/{n} | {}/{n} | {completion} | {:.2} | {:.2} | {} | {} |",
            count("completed"),
            count("failed"),
            count("collided"),
            same.iter().map(|r| r.max_spacing_error_m).fold(0.0, f64::max),
            same.iter().map(|r| r.min_gap_m).fold(f64::INFINITY, f64::min),
            same.iter().map(|r| r.left_lane).max().unwrap_or(0),
            same.iter().map(|r| r.messages).max().unwrap_or(0),
            n = same.len(),
        );
    }
    md
}

impl Maneuvers {
    fn write_files(&self, opts: &ManeuversOptions, dir: &RunDir) -> Result<()> {
        write_table(dir, "maneuvers", &self.rows, &self.markdown)?;
        for maneuver in &opts.maneuvers {
            let groups = bars_by_law(&opts.laws, &opts.attacks, |law, a| {
                // The slowest completion over the repeats; 0: none completed.
                self.rows
                    .iter()
                    .filter(|r| r.maneuver == *maneuver && r.law == law && r.attack == a)
                    .filter_map(|r| r.completion_s)
                    .fold(0.0, f64::max)
            });
            plots::grouped_bars(
                &dir.path(&format!("maneuvers-{maneuver}.png")),
                &format!("{maneuver}: time to complete (slowest repeat; 0 = never completed)"),
                "time from the request (s)",
                &opts.attacks,
                &groups,
            )?;
        }
        Ok(())
    }
}

/// Each maneuver runs on a scenario of its own (configs/join.toml, ...): the base is not used.
impl Experiment for Maneuvers {
    type Options = ManeuversOptions;
    const NAME: &'static str = "maneuvers";
    const DIR: &'static str = "runs/maneuvers";
    const BASE: Embedded = Embedded::Paper;
    fn validate(opts: &ManeuversOptions) -> Result<()> {
        opts.validate()
    }
    fn measure(
        _base: &Base,
        opts: &ManeuversOptions,
        _out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(opts, progress)
    }
    fn write(&self, _base: &Base, opts: &ManeuversOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts, dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
