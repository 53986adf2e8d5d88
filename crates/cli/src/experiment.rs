//! `platoon experiment`: the arguments and what is printed; the experiments are
//! [`platoon_app::experiment`]'s.
use crate::names::one_of;
use crate::outdir::OutDir;
use crate::progress::Bar;
use crate::Result;
use clap::builder::PossibleValuesParser;
use platoon_app::experiment::{
    Base, Controllers, ControllersOptions, Degradation, DegradationOptions, Detection,
    DetectionOptions, Intensity, Maneuvers, ManeuversOptions, Robust, RobustOptions, Scaling,
    ScalingOptions, Security, SecurityOptions, Table1, Topologies, TopologiesOptions, Traffic,
    TrafficOptions, DETECTION_ATTACKS, DETECTION_REACTIONS, DETECTORS, MANEUVERS, MANEUVER_ATTACKS,
    MANEUVER_SECURITY, SECURITY_ATTACKERS, SECURITY_DEFENCES, TRAFFIC_ATTACKS,
};
use platoon_config::LawName;
use platoon_control::Reaction;
use platoon_topology::Preset;
use std::path::{Path, PathBuf};

/// The experiments.
#[derive(Debug, clap::Subcommand)]
pub enum Experiment {
    /// Table I and Fig. 8: trigger counts and tracking errors of the dynamic ETM (4), the static
    /// ETM (21) and a third baseline (`mixed`: static ETM with an exponentially decaying offset),
    /// without DoS and without parameter uncertainty. Writes table1.csv, table1.md (the paper's
    /// numbers beside ours), table1.png, fig8.png, fig8.csv and one summary per rule.
    Table1(Table1Args),
    /// Fig. 9: controllers designed by Theorem 1 at the nominal tau, by Theorem 2 (robust over
    /// the config's tau range: docs/paper-readings.md#R18) and by Theorem 1 at the lower bound
    /// of tau (the "lower-bound method" the paper compares to), each run on the config's tau(t)
    /// schedule without DoS. Writes designs.csv, the three certificates, fig9.csv, fig9.png and
    /// fig9.md (mean tracking error per phase of tau).
    Robust(RobustArgs),
    /// Fig. 10: varsigma1 (the guaranteed decay rate) for PF, TPSF and BPF platoons of several
    /// sizes under four conditions: nominal (Theorem 1 design), with tau uncertainty (robust
    /// design), with conservative trigger parameters, and with DoS. Writes topologies.csv and
    /// fig10.png; shows a progress bar (each point is a synthesis and a bisection of SDPs).
    Topologies(TopologiesArgs),
    /// Graceful degradation: the same attacks (an 8 s jam on the leader's acceleration ramp,
    /// one on its braking ramp, a 10 s jam during cruise, the paper's schedule, and a 20 s
    /// jam) on the paper's platoon and a longer one, for every fallback (zero, hold, predict,
    /// acc), each with and without the emergency-braking guard, side by side. Writes
    /// degradation.csv (one row per run: largest spacing error, smallest gap and time to
    /// collision, largest deceleration, safety class, messages, guard activations, time in
    /// fallback), degradation.md (the table) and degradation.png (smallest gap per attack and
    /// fallback).
    Degradation(DegradationArgs),
    /// Long platoons: the largest gap error against the platoon's size for each topology, the
    /// paper's gain with constant spacing beside a gain designed for a time headway (Theorem 1
    /// on the time-headway error dynamics, designed on --design-followers), with and without
    /// the base config's DoS, in process, in formation at t = 0 (errors come from the leader's
    /// ramps and the attacks). Each row also holds what the analysis predicts: string stability
    /// (the amplification from the first follower to the last) and, up to --certify-up-to
    /// followers, the smallest beta1/beta2 Theorem 1 certifies. Writes scaling.csv, scaling.md,
    /// scaling.png (one panel per topology, log-log), designs.csv and the designs'
    /// certificates; shows a progress bar.
    Scaling(ScalingArgs),
    /// Controllers side by side under the same attacks: the paper's law and the field's (acc,
    /// path_cacc, ploeg, consensus, flatbed, as Plexe computes them) under no attack, a
    /// periodic DoS, a random admissible DoS, burst loss, a 0.2 s delay, a false-data bias and
    /// a replay, on predecessor following (pf) and predecessor-leader following (plf), in
    /// process, each law with its own beaconing (the paper's its event trigger, the others
    /// periodic beacons) and its own distances, starting in formation. A law that needs a
    /// neighbour the topology does not give is reported as not run. Writes controllers.csv
    /// (one row per law, topology and attack: safety class, smallest gap, largest gap and
    /// spacing errors, messages, time in fallback), controllers.md and one smallest-gap plot
    /// per topology (controllers-<topology>.png).
    Controllers(ControllersArgs),
    /// Misbehaviour detection against ground truth: every detector (plausibility, radar_cross,
    /// residual) against every attack of an insider (false_data, random_offset, drift,
    /// feigned_braking, accel_scale, replay, delay; each stealthy and strong) and without an
    /// attack, without a reaction (log) and with one (fallback to ACC on the radar, one
    /// detector at a time), repeated with other radar and channel seeds, in process on worker
    /// threads, on the paper's scenario without its DoS. A log run holds every detector (they
    /// do not interact when nothing is refused) and also scores `any`. Writes detection.csv
    /// (one row per run and detector: TP/FP/TN/FN, precision, recall, F1, false-alarm rate,
    /// time to detect, smallest gap, collision, safety class), detection.md (means over the
    /// repeats), f1.png (F1 per detector and attack, no reaction, a panel per intensity) and
    /// safety.png (smallest gap per attack with and without the reaction).
    Detection(DetectionArgs),
    /// Traffic that touches the platoon: a car cuts in ahead of a follower (the base's first
    /// [[cut_ins]], by default configs/cut-in.toml: between followers 2 and 3, braking, leaving
    /// after 10 s) at each gap and speed difference, for every law (the paper's and the field's,
    /// each on its own beaconing and on the platoon's standstill gap; pf, or plf for the laws
    /// that need the leader, and the paper's law also on its own TPSF; on the base's vehicles,
    /// by default passenger cars with acceleration and braking limits; the guard on; the
    /// platoon split behind the car where a law steers on vehicles ahead of it), under no
    /// attack, a periodic DoS, a false-data bias
    /// and a feigned braking on the packets of the member ahead of the car while it is there,
    /// with the three built-in detectors logging, in process or on SUMO (--plant sumo), with
    /// seeded repeats. Writes
    /// traffic.csv (one row per run: collision, smallest gap counting the car, time on the
    /// car's ACC, time outside the law, the longest time a follower was held at its limits,
    /// false alarms, forged packets detected and missed),
    /// traffic.md (worst case over the repeats) and one smallest-gap plot per gap
    /// (traffic-gap<G>.png).
    Traffic(TrafficArgs),
    /// Maneuvers negotiated over V2V under attack: a join at the tail (configs/join.toml), one
    /// in the middle (configs/join-middle.toml), a leave from the middle (configs/leave.toml),
    /// a merge of two platoons (configs/merge.toml) and a split of one (configs/split.toml),
    /// for every field law (each on the platoon's standstill gap, the positions scaled to its
    /// spacing, the guard on), under no attack, 2 s of DoS from the request, 30 % loss on every
    /// link, a reactive jammer on one of the maneuver's messages (the tail join's updates, the
    /// middle join's move-in, the leave's, merge's and split's update) and a forged message (an
    /// in-position report in the joiner's or the rear head's name, a leave or a split notice in
    /// follower 1's name), with seeded repeats, in process. Writes maneuvers.csv (one row per run: completed, failed safely or collided,
    /// the time to complete, the largest spacing error, the smallest gap, who left the lane,
    /// the messages sent), maneuvers.md (outcomes, worst case over the repeats) and one
    /// completion-time plot per maneuver (maneuvers-<maneuver>.png).
    Maneuvers(ManeuversArgs),
    /// Security in the loop (docs/security.md#the-study): attackers (none, an outsider forging
    /// a leave notice, an insider's false data, an insider feigning braking, a Sybil with a
    /// member's stolen key forging a leave notice, an insider's false reports, a benign car
    /// cutting in) against
    /// defences (none, signatures, + a group key, + local detection, + reports and revocation)
    /// by law, on
    /// configs/leave.toml without its own leaves, in process. Writes security.csv (one row per
    /// run: collided, the smallest gap, the largest spacing error, who left the lane, seal
    /// refusals, signatures verified per step, reports, whom the authority revoked and how
    /// soon, false revocations), security.md and one smallest-gap plot per attacker
    /// (security-<attacker>.png).
    Security(SecurityArgs),
}

/// Arguments of `experiment security`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/security]")))]
pub struct SecurityArgs {
    /// The attackers.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = PossibleValuesParser::new(SECURITY_ATTACKERS),
        default_values = SECURITY_ATTACKERS
    )]
    pub attackers: Vec<String>,
    /// The defences, each adding to the one before.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = PossibleValuesParser::new(SECURITY_DEFENCES),
        default_values = SECURITY_DEFENCES
    )]
    pub defences: Vec<String>,
    /// The laws (not consensus: it refuses leaves, and a revoked member is ejected by one).
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = one_of(&LawName::ALL, LawName::name),
        default_values = ["paper", "path_cacc"]
    )]
    pub laws: Vec<LawName>,
    /// Each run's length (s), over 21 (the insiders lie from 20 s).
    #[arg(long, default_value_t = 40.0)]
    pub duration: f64,
    /// Seeded repeats of each cell (the radars' noise, the channel's and the uplink's draws,
    /// the keys); security.md shows each cell's worst case and sums its false revocations.
    #[arg(long, default_value_t = 1)]
    pub repeats: u32,
    /// Run on the 802.11p channel with this density of other traffic (vehicles/m, e.g. 0.06;
    /// the model's other parameters its defaults): the packets are as large on the air as
    /// signing and the group key make them, and security.md says how many arrived. Default:
    /// the ideal radio.
    #[arg(long, value_name = "VEH_PER_M")]
    pub radio_density: Option<f64>,
    #[command(flatten)]
    pub output: OutDir,
}

/// `--laws`, of the experiments that compare laws.
#[derive(Debug, clap::Args)]
pub struct Laws {
    /// The laws.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = one_of(&LawName::ALL, LawName::name),
        default_values = LawName::ALL.map(LawName::name)
    )]
    pub laws: Vec<LawName>,
}

/// Arguments of `experiment traffic`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/traffic]")))]
pub struct TrafficArgs {
    /// Base scenario (TOML) with at least one [[cut_ins]] [default: the embedded
    /// configs/cut-in.toml]: its profile, vehicle length, spacing, cut-in, [fallback.cut_in]
    /// and radar are kept; law, topology, beaconing, the cut-in's gap and speed, the guard,
    /// the detectors and the attacks are varied.
    #[arg(long)]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub laws: Laws,
    /// The gaps the car leaves to the follower as it cuts in (m, bumper to bumper): it cuts in
    /// at them whether the lane-change rule finds them safe or not (an aggressive car).
    #[arg(long, value_delimiter = ',', default_value = "3,6")]
    pub gaps: Vec<f64>,
    /// The car's speed minus the follower's as it cuts in (m/s).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "-4,0",
        allow_hyphen_values = true
    )]
    pub speed_diffs: Vec<f64>,
    /// The attacks.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = PossibleValuesParser::new(TRAFFIC_ATTACKS),
        default_values = TRAFFIC_ATTACKS
    )]
    pub attacks: Vec<String>,
    /// Seeded repeats of each cell (the radars' noise and the channel's losses).
    #[arg(long, default_value_t = 1)]
    pub repeats: u32,
    /// What integrates the vehicles: native (in process) or sumo (each run `platoon run
    /// --plant sumo`, the car a SUMO vehicle; the runs' directories under runs/).
    #[arg(long, value_enum, default_value = "native")]
    pub plant: platoon_config::PlantKind,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment maneuvers`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/maneuvers]")))]
pub struct ManeuversArgs {
    /// The maneuvers.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = PossibleValuesParser::new(MANEUVERS),
        default_values = MANEUVERS
    )]
    pub maneuvers: Vec<String>,
    /// The laws (the field's: the paper's law runs on one graph and refuses maneuvers; the
    /// consensus law refuses leaves, merges and splits).
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = one_of(&LawName::ALL, LawName::name),
        default_values = ["acc", "ploeg", "path_cacc", "consensus", "flatbed"]
    )]
    pub laws: Vec<LawName>,
    /// The attacks.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = PossibleValuesParser::new(MANEUVER_ATTACKS),
        default_values = MANEUVER_ATTACKS
    )]
    pub attacks: Vec<String>,
    /// Seeded repeats of each cell (the radars' noise and the channel's losses).
    #[arg(long, default_value_t = 3)]
    pub repeats: u32,
    /// The runs' V2V security: none (unsigned), signatures ([security]), or group (signatures
    /// and a group key on the maneuver messages, [security.group]; not with merge or split).
    /// Signed, the forged messages are a thief's, signed with follower 2's stolen key.
    #[arg(
        long,
        value_parser = PossibleValuesParser::new(MANEUVER_SECURITY),
        default_value = "none"
    )]
    pub security: String,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment detection`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/detection]")))]
pub struct DetectionArgs {
    /// Base scenario (TOML) [default: the embedded configs/paper.toml]: its DoS, link attacks
    /// and [detection] are replaced, its fallback set to acc, its duration to --duration.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The attacks (kinds of [[channel.attacks]]).
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = PossibleValuesParser::new(DETECTION_ATTACKS),
        default_values = DETECTION_ATTACKS
    )]
    pub attacks: Vec<String>,
    /// The detectors.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = PossibleValuesParser::new(DETECTORS),
        default_values = DETECTORS
    )]
    pub detectors: Vec<String>,
    /// The intensities: stealthy (inside sensor noise or genuine dynamics), strong.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = one_of(&Intensity::ALL, Intensity::name),
        default_values = Intensity::ALL.map(Intensity::name)
    )]
    pub intensities: Vec<Intensity>,
    /// The reactions: log (record only), fallback (refuse the sender and run ACC on the radar
    /// until a quiet second).
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = one_of(&DETECTION_REACTIONS, |r| r.name()),
        default_values = DETECTION_REACTIONS.map(|r: Reaction| r.name())
    )]
    pub reactions: Vec<Reaction>,
    /// Leave out the run without an attack (the false-alarm baseline).
    #[arg(long)]
    pub no_clean: bool,
    /// Runs of every cell, with the radar's and the channel's seeds + 0, 1, ...
    #[arg(long, default_value_t = DetectionOptions::default().repeats)]
    pub repeats: u32,
    /// Each run's duration (s); 45 covers the leader's braking at 35-40 s.
    #[arg(long, default_value_t = DetectionOptions::default().duration_s)]
    pub duration: f64,
    /// The insider whose packets are attacked (vehicle id).
    #[arg(long, default_value_t = DetectionOptions::default().attacker)]
    pub attacker: u16,
    /// When the attack starts (s).
    #[arg(long, default_value_t = DetectionOptions::default().start_s)]
    pub start: f64,
    /// Runs at once [default: the machine's cores].
    #[arg(long)]
    pub jobs: Option<usize>,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment controllers`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/controllers]")))]
pub struct ControllersArgs {
    /// Base scenario (TOML) [default: the embedded configs/paper.toml]: its leader profile,
    /// tau, vehicle length, fallback, radar and guard are kept; law, topology, spacing,
    /// beaconing, initial states and attacks are varied.
    #[arg(long)]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub laws: Laws,
    /// The topologies.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = one_of(&Preset::ALL, Preset::name),
        default_value = "pf,plf"
    )]
    pub topologies: Vec<Preset>,
    /// The field's laws' beacon period (s), a whole number of steps (0.1: 10 Hz, CAM-like).
    #[arg(long, default_value_t = 0.1)]
    pub beacon_period: f64,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment scaling`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/scaling-experiment]")))]
pub struct ScalingArgs {
    /// Base scenario (TOML) [default: the embedded configs/paper.toml]: its leader profile, tau,
    /// trigger, DoS schedule and vehicle length are kept; size, topology, gain and spacing
    /// policy are varied.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Platoon sizes (followers).
    #[arg(long, value_delimiter = ',', default_value = "4,10,25,50,100")]
    pub sizes: Vec<usize>,
    /// Topologies.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = one_of(&Preset::ALL, Preset::name),
        default_value = "pf,plf,tpsf,bpf"
    )]
    pub presets: Vec<Preset>,
    /// The time headway h_t of the designed gains (s).
    #[arg(long, default_value_t = ScalingOptions::default().time_headway)]
    pub time_headway: f64,
    /// The platoon size the time-headway gains are designed and certified on.
    #[arg(long, default_value_t = ScalingOptions::default().design_followers)]
    pub design_followers: usize,
    /// Bound on |K| for the designs.
    #[arg(long, default_value_t = ScalingOptions::default().k_max)]
    pub k_max: f64,
    /// Certify (Theorem 1 at the nominal tau, with a common and with a block-diagonal
    /// Lyapunov matrix) each gain on each size up to this many followers (two SDPs of size 9N
    /// each, about a second at N = 100; larger sizes get empty certificate columns).
    #[arg(long, default_value_t = ScalingOptions::default().certify_up_to)]
    pub certify_up_to: usize,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment degradation`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/degradation]")))]
pub struct DegradationArgs {
    /// Base scenario (TOML) [default: the embedded configs/degradation.toml]: its [fallback],
    /// [radar] and [guard] settings are kept, its mode, guard switch, attacks and size varied.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Platoon sizes (followers); the base's initial states are replaced by a formation when
    /// the size differs.
    #[arg(long, value_delimiter = ',', default_value = "4,10")]
    pub followers: Vec<usize>,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment topologies`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/topologies]")))]
pub struct TopologiesArgs {
    /// Base scenario (TOML) [default: the embedded configs/paper.toml]: tau range, trigger
    /// parameters and Assumption-2 bounds come from it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Platoon sizes (followers).
    #[arg(long, value_delimiter = ',', default_value = "2,4,6,8")]
    pub sizes: Vec<usize>,
    /// The conservative trigger: varrho (the base's eta and phi are kept).
    #[arg(long, default_value_t = TopologiesOptions::default().conservative_rho)]
    pub conservative_rho: f64,
    /// Bound on |K| for the designs.
    #[arg(long, default_value_t = TopologiesOptions::default().k_max)]
    pub k_max: f64,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment robust`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/robust]")))]
pub struct RobustArgs {
    /// Base scenario (TOML) [default: the embedded configs/paper.toml]; its attacks are removed.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Bound on |K| for the designs.
    #[arg(long, default_value_t = RobustOptions::default().k_max)]
    pub k_max: f64,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `experiment table1`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/table1]")))]
pub struct Table1Args {
    /// Base scenario (TOML); its trigger rule is replaced by each rule in turn. Without it, the
    /// embedded configs/table1.toml is used.
    #[arg(long)]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub output: OutDir,
}

pub fn run(e: Experiment) -> Result<()> {
    match e {
        Experiment::Table1(args) => table1(args),
        Experiment::Robust(args) => robust(args),
        Experiment::Topologies(args) => topologies(args),
        Experiment::Degradation(args) => degradation(args),
        Experiment::Scaling(args) => scaling(args),
        Experiment::Controllers(args) => controllers(args),
        Experiment::Detection(args) => detection(args),
        Experiment::Traffic(args) => traffic(args),
        Experiment::Maneuvers(args) => maneuvers(args),
        Experiment::Security(args) => security(args),
    }
}

fn security(args: SecurityArgs) -> Result<()> {
    let opts = SecurityOptions {
        attackers: args.attackers,
        defences: args.defences,
        laws: args.laws,
        duration_s: args.duration,
        repeats: args.repeats,
        radio_density: args.radio_density,
    };
    experiment::<Security>(opts, None, &args.output, Bar::counting("runs"))
}

/// Runs the experiment `E` with `opts` on the config `config` (None: `E::BASE`) into the
/// output directory (by default `E::DIR`), printing its summary; options and base are refused
/// before anything is written.
fn experiment<E: platoon_app::experiment::Experiment>(
    opts: E::Options,
    config: Option<&Path>,
    output: &OutDir,
    bar: Bar,
) -> Result<()> {
    E::validate(&opts)?;
    let base = Base::load(config, E::BASE)?;
    E::check_base(&base)?;
    output.write(E::DIR, |dir| {
        Ok(platoon_app::experiment::run::<E>(&base, &opts, Some(dir), &bar)?.summary())
    })
}

fn table1(args: Table1Args) -> Result<()> {
    experiment::<Table1>((), args.config.as_deref(), &args.output, Bar::default())
}

fn traffic(args: TrafficArgs) -> Result<()> {
    let opts = TrafficOptions {
        laws: args.laws.laws,
        gaps_m: args.gaps,
        speed_diffs_mps: args.speed_diffs,
        attacks: args.attacks,
        repeats: args.repeats,
        plant: args.plant,
    };
    let bar = Bar::counting("runs");
    experiment::<Traffic>(opts, args.config.as_deref(), &args.output, bar)
}

fn maneuvers(args: ManeuversArgs) -> Result<()> {
    let opts = ManeuversOptions {
        maneuvers: args.maneuvers,
        laws: args.laws,
        attacks: args.attacks,
        repeats: args.repeats,
        security: args.security,
    };
    experiment::<Maneuvers>(opts, None, &args.output, Bar::counting("runs"))
}

fn robust(args: RobustArgs) -> Result<()> {
    let opts = RobustOptions { k_max: args.k_max };
    experiment::<Robust>(opts, args.config.as_deref(), &args.output, Bar::default())
}

fn topologies(args: TopologiesArgs) -> Result<()> {
    let opts = TopologiesOptions {
        sizes: args.sizes,
        conservative_rho: args.conservative_rho,
        k_max: args.k_max,
    };
    let bar = Bar::counting("platoons");
    experiment::<Topologies>(opts, args.config.as_deref(), &args.output, bar)
}

fn degradation(args: DegradationArgs) -> Result<()> {
    let opts = DegradationOptions {
        followers: args.followers,
    };
    let bar = Bar::counting("runs");
    experiment::<Degradation>(opts, args.config.as_deref(), &args.output, bar)
}

fn controllers(args: ControllersArgs) -> Result<()> {
    let opts = ControllersOptions {
        laws: args.laws.laws,
        topologies: args.topologies,
        beacon_period_s: args.beacon_period,
    };
    let bar = Bar::counting("runs");
    experiment::<Controllers>(opts, args.config.as_deref(), &args.output, bar)
}

fn detection(args: DetectionArgs) -> Result<()> {
    let opts = DetectionOptions {
        attacks: args.attacks,
        detectors: args.detectors,
        intensities: args.intensities,
        reactions: args.reactions,
        clean: !args.no_clean,
        repeats: args.repeats,
        duration_s: args.duration,
        attacker: args.attacker,
        start_s: args.start,
        jobs: args.jobs,
    };
    let bar = Bar::counting("runs");
    experiment::<Detection>(opts, args.config.as_deref(), &args.output, bar)
}

fn scaling(args: ScalingArgs) -> Result<()> {
    let opts = ScalingOptions {
        sizes: args.sizes,
        presets: args.presets,
        time_headway: args.time_headway,
        design_followers: args.design_followers,
        k_max: args.k_max,
        certify_up_to: args.certify_up_to,
    };
    let bar = Bar::counting("runs");
    experiment::<Scaling>(opts, args.config.as_deref(), &args.output, bar)
}
