//! `platoon node <role>`: one process of an iceoryx2 run, started by the orchestrator (or by
//! `platoon bench latency`, for the echo).
use crate::Result;
use anyhow::Context;
use std::path::PathBuf;

/// Which process `platoon node` runs: the nodes of a run ([`platoon_wire::Node`], by the same
/// names) and the latency benchmark's echoes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Role {
    /// Integrates the vehicles.
    Plant,
    /// Every vehicle's triggering rule, estimators and control law.
    Controller,
    /// Gates every link: the built-in attack injector.
    Injector,
    /// The built-in channel in front of a third-party injector.
    Channel,
    /// The latency baseline over iceoryx2.
    Echo,
    /// The latency baseline over a UDP socket.
    EchoUdp,
    /// The latency baseline over a Unix socket.
    EchoUds,
}

/// Arguments of `platoon node`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which process: plant, controller, injector, channel (the built-in channel in front of a
    /// third-party injector), or echo (the latency baseline).
    #[arg(value_enum)]
    pub role: Role,
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
    use platoon_runtime::bench::{echo, socket_echo, Socket};
    use platoon_wire::Node;
    let node = match args.role {
        Role::Echo => return Ok(echo(&args.run_id, args.busy).context("echo node")?),
        Role::EchoUdp => {
            return Ok(socket_echo(Socket::Udp, &args.config).context("UDP echo node")?)
        }
        Role::EchoUds => {
            return Ok(socket_echo(Socket::Uds, &args.config).context("Unix-socket echo node")?)
        }
        Role::Plant => Node::Plant,
        Role::Controller => Node::Controller,
        Role::Injector => Node::Injector,
        Role::Channel => Node::Channel,
    };
    let (_, scenario) = platoon_config::load(&args.config)?;
    let (run_id, log) = (&args.run_id, args.log.as_deref());
    let r = match node {
        Node::Plant => platoon_runtime::nodes::plant(run_id, &scenario),
        Node::Controller => platoon_runtime::nodes::controller(run_id, &scenario),
        Node::Channel => platoon_runtime::nodes::channel(run_id, &scenario, log),
        _ => platoon_runtime::nodes::injector(run_id, &scenario, log),
    };
    Ok(r.with_context(|| format!("{} node of run {}", node.name(), args.run_id))?)
}
