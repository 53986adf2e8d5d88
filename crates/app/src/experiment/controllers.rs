//! Controllers side by side under the same attacks ([`controllers`]).
use super::{
    bars_by_law, in_formation, refuse, walk, write_config, write_table, Base, Experiment,
    ExperimentError, Result,
};
use crate::progress::Progress;
use platoon_config::{
    Attack, DosConfig, Embedded, LawName, LawParams, LinkAttackConfig, LinkKindConfig, RuleConfig,
    SpacingConfig, TopologyConfig,
};
use platoon_output::plots;
use platoon_output::rundir::RunDir;
use platoon_sim::SafetyClass;
use platoon_topology::Preset;
use std::fmt::Write as _;

/// The attacks of [`controllers`], by name: none, then DoS (periodic, random admissible) and
/// link attacks (burst loss, delay, a false-data bias, replay).
pub const ATTACKS: [&str; 7] = [
    "none",
    "periodic-dos",
    "random-dos",
    "burst-loss",
    "delay",
    "fdi-bias",
    "replay",
];

/// How [`controllers`] runs; [`ControllersOptions::default`] is `platoon experiment
/// controllers`' default.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllersOptions {
    /// The laws (`--laws`).
    pub laws: Vec<LawName>,
    /// The topologies (`--topologies`): predecessor following and one multi-neighbour one.
    pub topologies: Vec<Preset>,
    /// The beacon period of the field's laws (s; `--beacon-period`): 0.1, CAM-like.
    pub beacon_period_s: f64,
}

impl Default for ControllersOptions {
    fn default() -> Self {
        Self {
            laws: LawName::ALL.to_vec(),
            topologies: vec![Preset::Pf, Preset::Plf],
            beacon_period_s: 0.1,
        }
    }
}

impl ControllersOptions {
    /// Fails on empty lists or a beacon period that is no period.
    pub fn validate(&self) -> Result<()> {
        if self.laws.is_empty() {
            refuse!(Options, "--laws needs at least one law, e.g. paper,ploeg");
        }
        if self.topologies.is_empty() {
            refuse!(
                Options,
                "--topologies needs at least one topology, e.g. pf,plf"
            );
        }
        if !(self.beacon_period_s.is_finite() && self.beacon_period_s > 0.0) {
            refuse!(
                Options,
                "--beacon-period must be > 0 s (got {})",
                self.beacon_period_s
            );
        }
        Ok(())
    }
}

/// One cell of [`controllers`] (a row of controllers.csv).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ControllersRow {
    /// The law's config name.
    pub law: &'static str,
    /// The attack ([`ATTACKS`]).
    pub attack: &'static str,
    /// The topology's preset name.
    pub topology: &'static str,
    /// Why the law cannot run on this topology (the other fields are then empty); empty if it
    /// ran.
    pub not_run: String,
    /// The safety class.
    pub class: Option<SafetyClass>,
    /// The smallest gap (m; below 0: a collision).
    pub min_gap_m: Option<f64>,
    /// The largest |gap error| to the predecessor (m), against the law's own spacing.
    pub max_gap_error_m: Option<f64>,
    /// The largest |spacing error| to the leader (m).
    pub max_spacing_error_m: Option<f64>,
    /// Broadcasts of all vehicles.
    pub messages: Option<u64>,
    /// Time followers spent outside their law (fallback or blending back; s, summed).
    pub fallback_time_s: Option<f64>,
}

/// Controllers side by side ([`controllers`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Controllers {
    /// Law by law, attack by attack, topology by topology.
    pub rows: Vec<ControllersRow>,
    /// controllers.md: the table.
    pub markdown: String,
}

/// Every law of `opts` under every attack of [`ATTACKS`] on every topology of `opts`, in
/// process, on the base scenario (its profile, plant, fallback, radar and guard): each law with
/// its own beaconing (the paper's law its event trigger from the base, the field's laws
/// periodic beacons every `beacon_period_s`), its own distances (SUMO's Plexe defaults; the
/// platoon's spacing policy set to the one the law keeps) and the platoon starting in
/// formation at the leader's speed. A law that needs a neighbour the topology does not give
/// (e.g. the leader under `pf`) is reported as not run. With `out`: config.toml,
/// controllers.csv, controllers.md and one smallest-gap plot per topology.
pub fn controllers(
    base: &Base,
    opts: &ControllersOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Controllers> {
    super::run::<Controllers>(base, opts, out, progress)
}

/// [`controllers`]'s cells (and their runs' directories in `out`), without its tables and figures.
fn measure(
    base: &Base,
    opts: &ControllersOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Controllers> {
    write_config(out, &base.config)?;
    let mut cells = Vec::new();
    for &law in &opts.laws {
        for &preset in &opts.topologies {
            cells.extend(ATTACKS.map(|attack| (law, preset, attack)));
        }
    }
    let rows = walk(
        progress,
        "simulating",
        cells,
        |(law, preset, attack)| format!("{}, {attack}, {}", law.name(), preset.name()),
        |(law, preset, attack)| cell(base, opts, law, preset, attack),
    )?;
    let markdown = markdown(&rows);
    Ok(Controllers { rows, markdown })
}

/// The base config set up for one cell.
fn cell(
    base: &Base,
    opts: &ControllersOptions,
    law: LawName,
    preset: Preset,
    attack: &'static str,
) -> Result<ControllersRow> {
    let mut c = configure(&base.config, law, preset, opts.beacon_period_s);
    apply_attack(&mut c, attack);
    let row = |not_run: String| ControllersRow {
        law: law.name(),
        attack,
        topology: preset.name(),
        not_run,
        class: None,
        min_gap_m: None,
        max_gap_error_m: None,
        max_spacing_error_m: None,
        messages: None,
        fallback_time_s: None,
    };
    let scenario = match platoon_config::to_scenario(&mut c) {
        Ok(s) => s,
        // The topology does not give the law whom it reads: a finding, not a failure.
        Err(e) if matches!(e.reason, platoon_config::Reason::Unheard(_)) => {
            return Ok(row(e.reason.to_string()))
        }
        Err(platoon_config::KeyError { key, reason: e }) => {
            refuse!(
                Variant,
                "{}: key `{key}` with law {} on {} under {attack}: {e}",
                base.label,
                law.name(),
                preset.name()
            )
        }
    };
    let s = platoon_sim::run(scenario, |_| {})?;
    Ok(ControllersRow {
        class: Some(s.safety.class),
        min_gap_m: Some(s.safety.min_gap_m),
        max_gap_error_m: Some(s.max_gap_error_m()),
        max_spacing_error_m: Some(s.max_spacing_error_m()),
        messages: Some(s.triggers_total),
        fallback_time_s: Some(
            s.vehicles
                .iter()
                .flat_map(|v| v.mode_time_s.iter())
                .filter(|(m, _)| m.as_str() != "coop")
                .fold(0.0, |sum, (_, t)| sum + t),
        ),
        ..row(String::new())
    })
}

/// The base config switched to `law` on `preset`, as [`controllers`] runs each law: its own
/// beaconing (the field's laws periodic beacons every `beacon_period_s`), its own distances
/// (SUMO's Plexe defaults; the platoon's spacing policy set to the one the law keeps), the
/// platoon starting in formation at the leader's speed. The attacks are the base's.
pub(crate) fn configure(
    base: &platoon_config::Config,
    law: LawName,
    preset: Preset,
    beacon_period_s: f64,
) -> platoon_config::Config {
    let mut c = base.clone();
    c.control.law = law_config(base, law);
    c.topology = TopologyConfig::from(preset);
    if keep_law_spacing(&mut c) {
        c.trigger.rule = RuleConfig::Periodic {
            period_s: beacon_period_s,
        };
        c.trigger.check_period_s = None;
    }
    in_formation(&mut c);
    c
}

/// `law` with its defaults as the experiments run it: the paper's with `base`'s gains, Plexe's
/// ACC with its cruise control set above the profile's 25 m/s (SUMO's 14 m/s would hold the
/// followers below the leader's speed).
pub(crate) fn law_config(base: &platoon_config::Config, law: LawName) -> LawParams {
    match law {
        LawName::Paper => LawParams::Paper(base.control.paper_law()),
        LawName::Acc => LawParams::Acc(platoon_control::laws::PlexeAccParams {
            desired_speed_mps: 30.0,
            ..Default::default()
        }),
        _ => law.defaults(),
    }
}

/// Sets the standstill gap (m, bumper to bumper) of a field's law to `standstill`.
pub(crate) fn on_standstill(law: &mut LawParams, standstill: f64) {
    match law {
        LawParams::Paper(_) => {}
        LawParams::Acc(p) => p.standstill_m = standstill,
        LawParams::PathCacc(p) => p.spacing_m = standstill,
        LawParams::Ploeg(p) => p.standstill_m = standstill,
        LawParams::Consensus(p) => p.standstill_m = standstill,
        LawParams::Flatbed(p) => p.spacing_m = standstill,
    }
}

/// Sets the platoon's spacing policy to the one `c`'s law keeps (its distances plus the
/// vehicle length); false, leaving it, for the paper's law, whose spacing is the platoon's.
pub(crate) fn keep_law_spacing(c: &mut platoon_config::Config) -> bool {
    let Some((l, h)) = c.control.law.spacing_policy(c.platoon.vehicle_length_m) else {
        return false;
    };
    c.platoon.spacing_m = l;
    c.platoon.spacing = if h == 0.0 {
        SpacingConfig::Constant {}
    } else {
        SpacingConfig::TimeHeadway { time_headway_s: h }
    };
    true
}

/// The attack `name` of [`ATTACKS`] into the config (replacing its own).
fn apply_attack(c: &mut platoon_config::Config, name: &str) {
    c.attack = Attack::default();
    c.channel.attacks.clear();
    let link = |kind, senders: Option<Vec<u16>>| LinkAttackConfig {
        kind,
        start_s: 0.0,
        end_s: f64::INFINITY,
        senders,
        receivers: None,
        acts_as: None,
        key_of: None,
    };
    match name {
        // 1 s of jamming every 5 s.
        "periodic-dos" => {
            c.attack.kind = DosConfig::Periodic {
                period_s: 5.0,
                duration_s: 1.0,
                offset_s: 2.0,
            }
        }
        // The Monte Carlo campaign's admissible random DoS (campaigns/monte-carlo.toml).
        "random-dos" => {
            c.attack.kind = DosConfig::Random {
                seed: 7,
                min_gap_s: 1.0,
                max_gap_s: 12.0,
                min_duration_s: 0.5,
                max_duration_s: 3.0,
            };
            c.attack.assumption2 = Some(platoon_attacks::Assumption2 {
                T1: 2.0,
                T2: 9.46,
                D1: 6.0,
                D2: 11.33,
            });
        }
        // Bursts: 5 % of packets start a bad spell that loses 90 % and lasts ~3 packets.
        "burst-loss" => c.channel.attacks.push(link(
            LinkKindConfig::GilbertElliott {
                p_good_bad: 0.05,
                p_bad_good: 0.3,
                loss_good: 0.0,
                loss_bad: 0.9,
            },
            None,
        )),
        "delay" => c
            .channel
            .attacks
            .push(link(LinkKindConfig::Delay { delay_s: 0.2 }, None)),
        // Follower 1 claims to be 0.2 m further ahead and 1 m/s faster than it is: small
        // enough to pass the packet checks' plausibility bound at 10 Hz (a 2 m jump does not).
        "fdi-bias" => c.channel.attacks.push(LinkAttackConfig {
            start_s: 20.0,
            ..link(
                LinkKindConfig::FalseData {
                    offset: [0.2, 1.0, 0.0],
                    insider: false,
                },
                Some(vec![1]),
            )
        }),
        // The leader's packets replaced by those it sent 1 s earlier, through its braking.
        "replay" => c.channel.attacks.push(LinkAttackConfig {
            start_s: 30.0,
            ..link(LinkKindConfig::Replay { lag_s: 1.0 }, Some(vec![0]))
        }),
        _ => {}
    }
}

fn markdown(rows: &[ControllersRow]) -> String {
    let mut md = String::from(
        "| law | topology | attack | class | min gap (m) | max gap error (m) | max spacing error (m) | messages | time in fallback (s) |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        if !r.not_run.is_empty() {
            let _ = writeln!(
                md,
                "| {} | {} | {} | not run: the topology lacks a neighbour the law reads | | | | | |",
                r.law, r.topology, r.attack
            );
            continue;
        }
        let f = |x: Option<f64>| x.map_or("-".into(), |x| format!("{x:.2}"));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.law,
            r.topology,
            r.attack,
            r.class.map_or("-".into(), |c| c.to_string()),
            f(r.min_gap_m),
            f(r.max_gap_error_m),
            f(r.max_spacing_error_m),
            r.messages.map_or("-".into(), |m| m.to_string()),
            f(r.fallback_time_s),
        );
    }
    md
}

impl Controllers {
    fn write_files(&self, opts: &ControllersOptions, dir: &RunDir) -> Result<()> {
        write_table(dir, "controllers", &self.rows, &self.markdown)?;
        let categories: Vec<String> = ATTACKS.iter().map(|a| a.to_string()).collect();
        for &preset in &opts.topologies {
            let groups = bars_by_law(&opts.laws, &ATTACKS, |law, a| {
                self.rows
                    .iter()
                    .find(|r| r.law == law && r.attack == a && r.topology == preset.name())
                    .and_then(|r| r.min_gap_m)
                    .map_or(0.0, |g| g.max(0.0))
            });
            plots::grouped_bars(
                &dir.path(&format!("controllers-{}.png", preset.name())),
                &format!(
                    "Smallest gap by attack and law ({}; 0 = collision or not run)",
                    preset.name()
                ),
                "smallest gap (m)",
                &categories,
                &groups,
            )?;
        }
        Ok(())
    }
}

impl Experiment for Controllers {
    type Options = ControllersOptions;
    const NAME: &'static str = "controllers";
    const DIR: &'static str = "runs/controllers";
    const BASE: Embedded = Embedded::Paper;
    fn validate(opts: &ControllersOptions) -> Result<()> {
        opts.validate()
    }
    fn measure(
        base: &Base,
        opts: &ControllersOptions,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(base, opts, out, progress)
    }
    fn write(&self, _base: &Base, opts: &ControllersOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts, dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
