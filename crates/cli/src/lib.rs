//! `platoon`: resilient event-triggered platoon control under DoS attacks (Han et al., 2024).
//! The command as a library: [`main_with`] is the whole `platoon` program, called by the binary
//! and by the Python package's `platoon` script (`bridge/platoon`), which share its arguments,
//! messages and exit codes.
// The doc comments of the argument types are the `--help` text clap prints as written: `<DIR>`,
// `runs/<name>` and `[fallback]` there are for a terminal, not rustdoc markup.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]
mod bench;
mod campaign;
mod design;
mod experiment;
mod fcd;
mod names;
mod node;
mod outdir;
mod progress;
mod run;
mod search;
mod signals;

use clap::{Parser, Subcommand};

/// Co-simulation of resilient, event-triggered control of vehicle platoons under DoS attacks.
///
/// Implements Han et al., "Resilient Event-Triggered Control of Vehicle Platoon Under DoS Attacks
/// and Parameter Uncertainty", IEEE T-IV 2024, with the readings of docs/paper-readings.md.
#[derive(Debug, Parser)]
#[command(name = "platoon", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The bridge directory (SUMO plant, Python injector SDK and examples; the networks are in
    /// its ../sumo). Default: the checkout this binary was built from while it is inside it,
    /// else a bridge/ in the current directory or beside or above the binary, else the copy
    /// this binary carries, unpacked once into $XDG_DATA_HOME/platoon (~/.local/share).
    #[arg(long, global = true, value_name = "DIR", env = "PLATOON_BRIDGE_DIR")]
    bridge_dir: Option<std::path::PathBuf>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run one scenario and write trajectories, events, a summary and plots into a run directory.
    ///
    /// Without a config the embedded paper scenario (configs/paper.toml) runs. By default the run
    /// is an iceoryx2 co-simulation: plant, controller service and attack injector run as
    /// separate processes over shared memory, lock-step and event-driven (--transport inproc runs
    /// the same core in one process; both give identical files). The run directory receives:
    /// config.toml (the resolved config, every default written out), trajectories.csv (one row
    /// per vehicle and step: t, vehicle, p, v, a, u, theta, spacing and velocity errors,
    /// triggered, under_attack, affected, mode, guard), events.csv (one row per broadcast and
    /// per mode switch), channel.csv (every packet the channel did not deliver as sent),
    /// summary.json (triggers, inter-event times, tracking errors, time per mode and guard
    /// activations, attack and Assumption-2 verdict, safety with the smallest time to
    /// collision, rejected packets), fig6.png (positions, relative positions, velocities,
    /// internal variables), fig7.png (release instants), gaps.png (each follower's largest gap
    /// error to its predecessor: do errors grow along the platoon?), modes.png (each follower's mode over
    /// time, when one left the cooperative law: [fallback], [radar], [guard]), wire.csv (what happened on the V2V channel, per vehicle and step, whatever
    /// injector ran), and for iceoryx2 runs timing.json (where the time of a step went),
    /// run.json (the run id, for observers) and logs/. [output] in the config switches the
    /// per-step files to Parquet, decimates the trajectories or skips files.
    /// Files are staged in <DIR>.partial, which is renamed to <DIR> only when complete; a run
    /// stopped by a failed process or by Ctrl-C/SIGTERM keeps what it recorded, marked
    /// "complete": false (exit 130/143 for a signal). A bad config exits with code 2 before
    /// anything is written.
    Run(run::Args),
    /// Run a study: many cells of one scenario over axes of config values, a DoS-window map
    /// (attack onset x duration) and Monte Carlo draws, locally or on a Dask cluster.
    ///
    /// The campaign file (TOML; campaigns/ has commented examples) names a base scenario
    /// (`base`, relative to the file; default: the embedded paper scenario), `set` (keys set in
    /// every cell), `[[axes]]` (a config key by dotted path, e.g. `trigger.rule` or
    /// `channel.attacks[0].loss`, with `values` or a `range`; axes cross, or advance together
    /// when they share a `zip` group), `[dos_window]` (onset_s and duration_s of one attack
    /// interval), `[monte_carlo]` (samples, random admissible DoS schedules, loss, tau,
    /// initial-state jitter; each sample's seed comes from the campaign `seed` and the sample
    /// index, and every combination of the axes uses the same draws), `transport` (inproc, or
    /// iceoryx2 for full co-simulations, required by SUMO cells) and `metrics`.
    ///
    /// Metrics (cells.csv columns): max_spacing_error_m, rms_spacing_error_m,
    /// mean_spacing_error_m, final_spacing_error_m, max_velocity_error_mps, min_gap_m,
    /// max_deceleration_mps2, safety_class, collided, first_collision_s, triggers_total,
    /// triggers_per_follower, triggers_by_follower (triggers_1, ...), min_inter_event_s,
    /// assumption2,
    /// attack_intervals, attacked_time_s, max_affected_time_s, rejected_packets, min_ttc_s,
    /// fallback_time_s, guard_activations. Default: the
    /// spacing errors (max, RMS), min_gap_m, max_deceleration_mps2, safety_class, the
    /// triggers (total, per follower), min_inter_event_s, assumption2, attacked_time_s.
    ///
    /// Writes DIR (default runs/<name>), staged in DIR.partial and renamed when complete:
    /// campaign.toml (the resolved campaign), base.toml, cells.csv (one row per cell: cell,
    /// axis values, sample, seed, drawn values, status, metrics, error), campaign.json
    /// (counts, failures with their errors, wall and CPU time, per-group statistics),
    /// cells/<cNNNN>/ (config.toml, summary.json, cell.json), runs/<cNNNN>/ with --keep-runs,
    /// and plots/ (heatmaps for two axes, the safety class as a map, lines with min-max bands,
    /// ECDFs for Monte Carlo). A failed cell is recorded with its error and the campaign goes
    /// on; the exit code is 1 if any failed. Ctrl-C stops cleanly (exit 130; the cells in
    /// flight are lost) and running the same command again resumes: finished cells whose
    /// resolved config is unchanged are kept. A bad campaign file exits with code 2 and writes
    /// nothing.
    Campaign(campaign::Args),
    /// Search for the most harmful DoS schedule an attacker's budget allows, beside random
    /// admissible sampling and the DoS-timing grid at the same number of runs.
    ///
    /// The search file (TOML; campaigns/worst-dos.toml is a commented example; none: the paper
    /// scenario) names the scenario (`base`), the harm (a numeric campaign metric, e.g.
    /// max_spacing_error_m, min_gap_m, max_deceleration_mps2, first_collision_s), the budget
    /// (`[budget]`: Assumption 2's T1, T2, D1, D2 [the base's], max_jammed_s, max_intervals,
    /// min/max_interval_s, jam = "channel" or "links"), `evaluations` per strategy, `seed`, and
    /// `[study]` (laws x topologies) for one search per law and topology. Every schedule run
    /// is certified by the exact Assumption-2 checker first. Writes DIR (default
    /// runs/<name>), staged in DIR.partial: search.json (per strategy the most harmful schedule,
    /// its harm, class and Assumption-2 margins), evaluations.csv, convergence.csv and .png,
    /// worst.toml (re-run it with `platoon run`) and worst/ (its run directory); with [study],
    /// one such directory per law and topology, study.csv and study.md. See docs/search.md.
    Search(search::Args),
    /// One campaign cell: a job as JSON on stdin, the reply on stdout (what Dask workers run).
    #[command(hide = true)]
    CampaignCell,
    /// Reproduce an experiment of the paper's Section IV.
    #[command(subcommand)]
    Experiment(experiment::Experiment),
    /// LMI design: check or synthesise a gain for Theorem 1 or 2, re-check certificates, and
    /// the DoS bounds (16).
    #[command(subcommand)]
    Design(design::Design),
    /// Write SUMO's FCD output (fcd.xml, for sumo-gui) from a SUMO run directory's trajectories.
    ///
    /// What a SUMO run does after its last step by default (`[sumo] fcd = "recorded"`), for a
    /// run directory at hand: the platoons' vehicles under SUMO's ids, placed on the lane
    /// shapes of the run's network (plant.json names it), every --period seconds. Background
    /// traffic is not in the trajectories (`[sumo] fcd = "sumo"` has SUMO write it, at a cost
    /// per step). Replay with SUMO's tools/fcdReplay.py on the run's network.
    Fcd(fcd::Args),
    /// Measure what the co-simulation costs on this machine (`bench all` writes BENCHMARKS.md).
    #[command(subcommand)]
    Bench(bench::Bench),
    /// One process of an iceoryx2 run (started by `platoon run`, not by hand).
    #[command(hide = true)]
    Node(node::Args),
    /// Print the wire payloads' layout (the JSON of bridge/wire_layout.json).
    #[command(hide = true)]
    WireLayout,
}

/// Exit code for unusable input (a bad config or argument): 2, like clap's usage errors.
const EXIT_BAD_INPUT: u8 = 2;

/// Runs `platoon` with `args` (the program name first, as `std::env::args_os` gives them):
/// parses them (printing the help or the usage error and exiting, as clap does), runs the
/// command, prints its error, and returns the exit status (0, 1, or 2 for bad input; a
/// signal's stop exits the process with 128 + the signal, as the shell reports it).
pub fn main_with<I, T>(args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    // A closed pipe (`platoon run | head`) ends the program quietly, as for any Unix tool.
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
    let cli = Cli::parse_from(args);
    if let Some(dir) = &cli.bridge_dir {
        // For the processes this one starts (campaign cells, Dask workers) as well.
        std::env::set_var(
            "PLATOON_BRIDGE_DIR",
            std::path::absolute(dir).unwrap_or(dir.clone()),
        );
    }
    let result = match cli.command {
        Command::Run(args) => run::run(args),
        Command::Campaign(args) => campaign::run(args),
        Command::CampaignCell => campaign::cell_command(),
        Command::Search(args) => search::run(args),
        Command::Experiment(e) => experiment::run(e),
        Command::Node(args) => node::run(args),
        Command::Bench(b) => bench::run(b),
        Command::Design(d) => design::run(d),
        Command::Fcd(args) => fcd::run(args),
        Command::WireLayout => {
            print!("{}", platoon_wire::layouts_json());
            Ok(())
        }
    };
    match result {
        Ok(()) => 0,
        Err(Failure::BadInput(config)) => {
            eprintln!("error: {config}");
            EXIT_BAD_INPUT
        }
        Err(Failure::Failed(e)) => {
            eprintln!("error: {e:#}");
            1
        }
    }
}

/// Why a command failed, by what its exit status says: every error of the library that is a
/// config error (a run's, a campaign's, ...: each operation's error says so by its kind) is
/// unusable input, anything else a failure.
#[derive(Debug)]
enum Failure {
    /// A config, campaign or search file (or what the arguments make of it) is refused: the
    /// command exits [`EXIT_BAD_INPUT`], printing it alone.
    BadInput(platoon_config::ConfigError),
    /// Anything else: the command exits 1, printing the error with its causes.
    Failed(anyhow::Error),
}

/// The result of a command.
type Result<T = (), E = Failure> = std::result::Result<T, E>;

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Self::Failed(e)
    }
}

impl From<platoon_config::ConfigError> for Failure {
    fn from(e: platoon_config::ConfigError) -> Self {
        Self::BadInput(e)
    }
}

/// `From` an operation's error: its config error is bad input, the rest a failure.
macro_rules! by_kind {
    ($($error:ty),+) => {$(
        impl From<$error> for Failure {
            fn from(e: $error) -> Self {
                match e.config() {
                    Some(c) => Self::BadInput(c.clone()),
                    None => Self::Failed(e.into()),
                }
            }
        }
    )+};
}

by_kind!(
    platoon_app::RunError,
    platoon_app::CampaignError,
    platoon_app::SearchError,
    platoon_app::DesignError,
    platoon_app::ExperimentError,
    platoon_app::sumo::SumoError
);

/// `From` errors that are never a config's: a failure.
macro_rules! failed {
    ($($error:ty),+) => {$(
        impl From<$error> for Failure {
            fn from(e: $error) -> Self {
                Self::Failed(e.into())
            }
        }
    )+};
}

failed!(
    std::io::Error,
    std::fmt::Error,
    serde_json::Error,
    platoon_output::error::OutputError,
    platoon_synthesis::LmiError,
    platoon_app::OtherError
);

/// Returns an error (a [`Failure::Failed`]) with the message `format!` makes.
macro_rules! bail {
    ($($message:tt)+) => {
        return Err(anyhow::anyhow!($($message)+).into())
    };
}
use bail;
