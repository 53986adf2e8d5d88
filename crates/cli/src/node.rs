//! `platoon node <role>`: one process of an iceoryx2 run, started by the orchestrator (or by
//! `platoon bench latency`, for the echo).
use anyhow::{Context, Result};
use std::path::PathBuf;

/// Arguments of `platoon node`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which process: plant, controller, injector, channel (the built-in channel in front of a
    /// third-party injector), or echo (the latency baseline).
    #[arg(value_parser = ["plant", "controller", "injector", "channel", "echo", "echo-udp", "echo-uds"])]
    pub role: String,
    /// The run's id (names its iceoryx2 services).
    #[arg(long)]
    pub run_id: String,
    /// The run's resolved scenario config (unused by echo).
    #[arg(long)]
    pub config: PathBuf,
    /// Injector: where to write the channel log (CSV).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// echo: poll instead of waiting (the busy-polling baseline).
    #[arg(long)]
    pub busy: bool,
}

pub fn run(args: Args) -> Result<()> {
    match args.role.as_str() {
        "echo" => {
            return platoon_runtime::bench::echo(&args.run_id, args.busy).context("echo node")
        }
        "echo-udp" => {
            return platoon_runtime::bench::socket_echo(
                platoon_runtime::bench::Socket::Udp,
                &args.config,
            )
            .context("UDP echo node")
        }
        "echo-uds" => {
            return platoon_runtime::bench::socket_echo(
                platoon_runtime::bench::Socket::Uds,
                &args.config,
            )
            .context("Unix-socket echo node")
        }
        _ => {}
    }
    let (_, scenario) = platoon_config::load(&args.config)?;
    let r = match args.role.as_str() {
        "plant" => platoon_runtime::nodes::plant(&args.run_id, &scenario),
        "controller" => platoon_runtime::nodes::controller(&args.run_id, &scenario),
        "channel" => platoon_runtime::nodes::channel(&args.run_id, &scenario, args.log.as_deref()),
        _ => platoon_runtime::nodes::injector(&args.run_id, &scenario, args.log.as_deref()),
    };
    r.with_context(|| format!("{} node of run {}", args.role, args.run_id))
}
