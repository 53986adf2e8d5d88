//! `platoon run`: the arguments, the signals and what is printed; the run itself is
//! [`platoon_app::run::run`].
use crate::{bail, Result};
use anyhow::Context;
use platoon_app::run::{Injector, RunOptions, Stop};
use platoon_config::Transport;
use platoon_sim::Summary;
use std::path::PathBuf;

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
    /// iceoryx2: plant, controller and injector run as separate processes over shared memory
    /// (lock-step, event-driven). inproc: the same core in one process, with no IPC (the oracle
    /// the iceoryx2 run must match bit for bit).
    #[arg(long, value_enum, default_value_t = Transport::Iceoryx2)]
    pub transport: Transport,
    /// Run this program as the attack injector instead of the built-in one (iceoryx2 only),
    /// e.g. "bridge/.venv/bin/python bridge/examples/drop_sender.py 2". It gets PLATOON_RUN_ID
    /// and PLATOON_CONFIG in its environment; docs/injector-contract.md says what it must do.
    #[arg(long, value_name = "COMMAND")]
    pub injector: Option<String>,
    /// With --injector: `replace` runs it instead of the built-in channel (the config's
    /// `[attack]` and `[[channel.attacks]]` are then applied by no one); `after` runs the
    /// built-in channel first and gives the injector what survived it, jammed notices included
    /// (it reads the `gated` service instead of `tx`; the SDKs do this by themselves).
    /// summary.json records the mode under "injector".
    #[arg(long, value_enum, default_value_t = InjectorMode::Replace, requires = "injector")]
    pub injector_mode: InjectorMode,
    /// Run this program as the controller service instead of the built-in controllers
    /// (iceoryx2 only), e.g. "bridge/.venv/bin/python bridge/examples/paper_law.py". It gets
    /// PLATOON_RUN_ID and PLATOON_CONFIG in its environment; docs/controller-contract.md says
    /// what it must do. summary.json records it under "controller".
    #[arg(long, value_name = "COMMAND")]
    pub controller: Option<String>,
    /// Seconds the run waits for a process's sample of one step before it stops and names the
    /// process (iceoryx2 only).
    #[arg(
        long,
        default_value_t = 1.0,
        value_name = "SECONDS",
        env = "PLATOON_STEP_TIMEOUT"
    )]
    pub step_timeout: f64,
    /// Seconds the run waits for its processes to start (report READY) before it stops and
    /// names the one that did not (iceoryx2 only). SUMO and a Python plug-in take a few
    /// seconds on a busy machine.
    #[arg(
        long,
        default_value_t = 60.0,
        value_name = "SECONDS",
        env = "PLATOON_READY_TIMEOUT"
    )]
    pub ready_timeout: f64,
    /// What integrates the vehicles, overriding the config's `simulation.plant`: native (the
    /// model in Rust) or sumo (SUMO through the libsumo bridge in bridge/, whose Python
    /// environment is created on first use; writes fcd.xml and sumo.json too).
    #[arg(long, value_enum)]
    pub plant: Option<platoon_config::PlantKind>,
    /// Read-only observers that may attach to the run's `observe/*` services (iceoryx2 only;
    /// see docs/observer-contract.md). More than this are refused at attach time; the run is
    /// never affected either way.
    #[arg(long, default_value_t = 4, value_name = "N", env = "PLATOON_OBSERVERS")]
    pub observers: usize,
    /// Pin the run's processes (plant, controller, injector) to these CPUs, as `taskset -c`
    /// takes them (e.g. 0 or 0-1; iceoryx2 only). A step is a chain of wake-ups with one
    /// process running at a time, so where waking a process on another core is slow (VMs
    /// that halt idle cores) one core is faster; BENCHMARKS.md measures it. Default: any.
    #[arg(long, value_name = "LIST", env = "PLATOON_CPUS", value_parser = CpuList::parse)]
    pub cpus: Option<CpuList>,
    /// Take K and beta1/beta2 from a certificate (`platoon design synthesize` or `check-gain`):
    /// control.gain = its K, control.beta1 = its ratio x the config's beta2.
    #[arg(long, value_name = "CERTIFICATE")]
    pub design: Option<PathBuf>,
}

/// `--cpus`: a CPU list as `taskset -c` takes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CpuList(pub Vec<usize>);

impl CpuList {
    fn parse(list: &str) -> Result<Self, String> {
        platoon_runtime::parse_cpus(list).map(Self)
    }
}

/// How a third-party injector composes with the built-in channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InjectorMode {
    /// Instead of the built-in channel.
    Replace,
    /// After the built-in channel, on what survived it.
    After,
}

pub fn run(args: Args) -> Result<()> {
    let platoon_config::Loaded {
        mut config,
        mut scenario,
        stem,
    } = platoon_config::load_or(args.config.as_deref(), platoon_config::Embedded::Paper)?;
    if let Some(file) = &args.design {
        if let Some(warning) =
            platoon_app::run::apply_design(&mut config, &mut scenario, &stem, file)?
        {
            eprintln!("warning: {warning}");
        }
    }
    if !(args.step_timeout.is_finite() && args.step_timeout > 0.0) {
        bail!("--step-timeout must be a positive number of seconds");
    }
    if !(args.ready_timeout.is_finite() && args.ready_timeout > 0.0) {
        bail!("--ready-timeout must be a positive number of seconds");
    }
    let opts = RunOptions {
        transport: args.transport,
        plant: args.plant,
        injector: args.injector.clone().map(|command| Injector {
            command,
            mode: match args.injector_mode {
                InjectorMode::Replace => platoon_app::run::InjectorMode::Replace,
                InjectorMode::After => platoon_app::run::InjectorMode::After,
            },
        }),
        controller: args.controller.clone(),
        step_timeout: std::time::Duration::try_from_secs_f64(args.step_timeout)
            .context("--step-timeout is too long")?,
        ready_timeout: std::time::Duration::try_from_secs_f64(args.ready_timeout)
            .context("--ready-timeout is too long")?,
        observers: args.observers,
        cpus: args.cpus.clone().map(|c| c.0).unwrap_or_default(),
        plots: !args.no_plots,
        node_program: None,
        config_file: args
            .config
            .clone()
            .unwrap_or_else(|| PathBuf::from(platoon_config::Embedded::Paper.label())),
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(&stem));
    let interrupt = std::sync::Arc::new(crate::signals::Interrupt::install(
        "stopping the run; what is recorded is kept (complete: false)",
    )?);
    let signalled = interrupt.clone();
    let stop = Stop::new(interrupt.stop.clone(), move || {
        signalled
            .signal()
            .map(|sig| format!("interrupted by {}", crate::signals::name(sig)))
    });
    let outcome = platoon_app::run::run(
        config,
        &scenario,
        &opts,
        &out,
        args.force,
        &stop,
        &crate::progress::Bar::default(),
    )?;
    let summary = &outcome.summary;
    if let Some(sig) = interrupt.signal() {
        eprintln!(
            "interrupted: {} of {} steps are recorded in {} (summary.json says complete: false)",
            summary.steps,
            scenario.steps + 1,
            outcome.dir.display()
        );
        std::process::exit(crate::signals::exit_code(sig));
    }
    if let Some(e) = outcome.failure {
        eprintln!(
            "the run stopped after {} of {} steps; what it recorded is in {} (summary.json says complete: false)",
            summary.steps,
            scenario.steps + 1,
            outcome.dir.display()
        );
        return Err(e.into());
    }
    print_summary(summary, outcome.compute.as_secs_f64());
    println!("outputs: {}", outcome.dir.display());
    Ok(())
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
    let attacks = |n: usize| {
        if n == 1 {
            "1 attack".to_string()
        } else {
            format!("{n} attacks")
        }
    };
    match (a.applied, a.intervals) {
        (true, 0) => println!("  DoS: none"),
        (true, n) => println!(
            "  DoS: {}, {:.2} s jammed, {verdict}",
            attacks(n),
            a.attacked_time_s
        ),
        (false, 0) => println!(
            "  DoS: none in the config; what the injector did is in wire.csv"
        ),
        (false, n) => println!(
            "  DoS: the config's {} {} not applied (--injector-mode replace); what the injector did is in wire.csv",
            attacks(n),
            if n == 1 { "was" } else { "were" }
        ),
    }
    if let Some(o) = &a.observed {
        let verdict = match &o.assumption2 {
            Some(r) if r.holds => "satisfies Assumption 2",
            Some(_) => "VIOLATES Assumption 2",
            None => "no Assumption-2 bounds given",
        };
        println!(
            "  jamming observed by the vehicles: {}, {:.2} s, {verdict}",
            attacks(o.intervals).replace("attack", "interval"),
            o.jammed_time_s
        );
    }
    if let Some(f) = &s.fleet {
        println!(
            "  fleet: {} platoons, {} vehicles, {} broadcasts, smallest gap {:.2} m, largest deceleration {:.2} m/s^2, class {}{}",
            f.platoons,
            f.vehicles,
            f.triggers_total,
            f.min_gap_m,
            f.max_deceleration_mps2,
            f.class,
            if f.collided { ", COLLISION" } else { "" }
        );
        println!(
            "  (the lines above are platoon 0's; summary.json has every platoon under \"fleet\")"
        );
    }
    println!("  safety: {}", safety_line(&s.safety));
    // Degradation, when anything but the cooperative law ran.
    let mut modes = std::collections::BTreeMap::<&str, f64>::new();
    for v in &s.vehicles {
        for (m, t) in &v.mode_time_s {
            *modes.entry(m.as_str()).or_default() += t;
        }
    }
    let guard: u64 = s.vehicles.iter().map(|v| v.guard_activations).sum();
    if modes.keys().any(|m| *m != "coop") || guard > 0 {
        let total: f64 = modes.values().sum();
        let shares: Vec<String> = modes
            .iter()
            .map(|(m, t)| format!("{m} {:.1} %", 100.0 * t / total.max(f64::MIN_POSITIVE)))
            .collect();
        println!(
            "  modes (all followers): {}; {} mode switches; guard braked {} times; smallest TTC {}",
            shares.join(", "),
            s.vehicles.iter().map(|v| v.mode_switches).sum::<u64>(),
            guard,
            s.safety
                .min_ttc_s
                .map_or("-".to_string(), |t| format!("{t:.2} s"))
        );
    }
    if let Some(m) = &s.maneuvers {
        println!("  maneuvers: {} messages broadcast", m.messages_sent);
        for r in &m.maneuvers {
            let how = match (r.requested_t_s, r.completion_s) {
                (None, _) => "never asked (the run ended first)".to_string(),
                (Some(at), Some(took)) => format!("asked at {at:.2} s, completed in {took:.2} s"),
                (Some(at), None) => format!("asked at {at:.2} s, FAILED"),
            };
            let seen = match (r.max_spacing_error_m, r.min_gap_m) {
                (Some(e), Some(g)) => {
                    format!("; from then on spacing error <= {e:.2} m, smallest gap {g:.2} m")
                }
                _ => String::new(),
            };
            println!(
                "    {} of vehicle {}: {how}, {} messages{seen}",
                r.maneuver, r.vehicle, r.messages
            );
        }
        for f in &m.formations {
            let platoons: Vec<String> = f
                .platoons
                .iter()
                .map(|p| {
                    let ids: Vec<String> = p.iter().map(u16::to_string).collect();
                    format!("[{}]", ids.join(" "))
                })
                .collect();
            let verdict = match &f.stability {
                None => "not checked".to_string(),
                Some(c) => match (&c.unchecked, c.decay_per_s) {
                    (Some(why), _) => format!("not checked: {why}"),
                    (None, Some(d)) => format!("stable, certified decay {d:.3}/s"),
                    (None, None) => format!(
                        "NOT certified (largest spectral radius {:.6})",
                        c.spectral_radius.unwrap_or(f64::NAN)
                    ),
                },
            };
            println!(
                "    formation {} from {:.2} s: {verdict}",
                platoons.join(" "),
                f.t_s
            );
        }
    }
}

/// The run's safety line: no collision and the smallest gap, or who hit whom first, on which
/// lane and when, and the smallest gap in words that agree with it (a collision the plant
/// recorded between vehicles whose gap the platoon does not measure, such as SUMO's between a
/// background car and a member, leaves the platoon's own gaps above zero: the line says so).
pub(crate) fn safety_line(s: &platoon_sim::Safety) -> String {
    let smallest = format!(
        "smallest gap {:.2} m, follower {} at {:.2} s",
        s.min_gap_m, s.min_gap_vehicle, s.min_gap_t_s
    );
    match (s.collided, &s.first_collision) {
        (false, _) => format!("no collision ({smallest})"),
        (true, None) => format!("COLLISION ({smallest})"),
        (true, Some(c)) if s.min_gap_m <= 0.0 => format!("COLLISION: {c}; {smallest}"),
        (true, Some(c)) => format!(
            "COLLISION: {c}; the gaps the platoon measures to the vehicle ahead stayed above \
             zero ({smallest})"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A collision the platoon's gaps did not see (SUMO's, between vehicles whose gap no
    /// follower measures) is not printed beside a positive "smallest gap" as if it were one.
    #[test]
    fn the_safety_line_never_contradicts_its_smallest_gap() {
        let mut s: platoon_sim::Safety = serde_json::from_value(serde_json::json!({
            "collided": true, "min_gap_m": 15.76, "min_gap_vehicle": 3, "min_gap_t_s": 20.5,
            "min_ttc_s": null, "max_deceleration_mps2": 2.0, "class": "severe",
            "thresholds": {"none": 1.0, "negligible": 2.0,
                           "benign": 5.0}
        }))
        .unwrap();
        s.first_collision = Some(platoon_sim::Collision {
            t_s: 20.0,
            collider: "SUMO's p1".into(),
            victim: "cutin0".into(),
            lane: "lane highway_1".into(),
            gap_m: None,
        });
        let line = safety_line(&s);
        assert_eq!(
            line,
            "COLLISION: SUMO's p1 hit cutin0 on lane highway_1 at 20.00 s; the gaps the platoon \
             measures to the vehicle ahead stayed above zero (smallest gap 15.76 m, follower 3 at \
             20.50 s)"
        );
        s.collided = false;
        s.first_collision = None;
        assert_eq!(
            safety_line(&s),
            "no collision (smallest gap 15.76 m, follower 3 at 20.50 s)"
        );
    }
}
