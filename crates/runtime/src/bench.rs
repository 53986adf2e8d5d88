//! A raw iceoryx2 hop, as the baseline of the injector hop: the same services, payload and
//! event-driven waits as a co-simulation, but a second process that only echoes.
//!
//! Method (as iceoryx2's own benchmarks): ping-pong, warm-up first, then many iterations. The
//! one-way hop is measured like the co-simulation's injector stage, from publish to publish:
//! the echo's publish stamp minus the ping's publish stamp (`CLOCK_MONOTONIC`, shared by both
//! processes), so the two figures mean the same thing.
use crate::ipc::{wait, Endpoint, Inlet, Outlet};
use crate::RunError;
use platoon_wire::{LinkPacket, Node, Service};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The step number that tells the echo to exit.
const QUIT: u64 = u64::MAX;

/// Runs `warmup + iterations` ping-pongs of `items` link packets with a `platoon node echo`
/// process started from `exe`; returns the one-way hop of each measured iteration (ns).
pub fn raw_hop(
    run_id: &str,
    exe: &Path,
    iterations: usize,
    warmup: usize,
    items: usize,
) -> Result<Vec<u64>, RunError> {
    let e = Endpoint::new(run_id, Node::Controller)?;
    let _wake = [Node::Controller, Node::Injector]
        .iter()
        .map(|&n| e.wake_service(n, true))
        .collect::<Result<Vec<_>, _>>()?;
    let tx_service = e.create_step_service::<LinkPacket>(Service::Tx)?;
    let rx_service = e.create_step_service::<LinkPacket>(Service::Rx)?;
    let listener = e.listener()?;
    let tx: Outlet<LinkPacket> = e.outlet(&tx_service, Service::Tx, items)?;
    let mut rx: Inlet<LinkPacket> = Inlet::new(&rx_service, Node::Injector)?;
    let mut child = Command::new(exe)
        .args(["node", "echo", "--run-id", run_id, "--config", "-"])
        .stdin(Stdio::null())
        .spawn()
        .map_err(|source| RunError::Spawn {
            node: "echo",
            command: format!("{} node echo", exe.display()),
            source,
        })?;
    let batch = vec![LinkPacket::default(); items];
    let mut hops = Vec::with_capacity(iterations);
    let result = (|| {
        // Until the echo is up, a ping may go unanswered: resend every 100 ms.
        let started = Instant::now();
        loop {
            tx.send(0, 0.0, &batch)?;
            wait(&listener, Duration::from_millis(100))?;
            if rx.take(0)?.0.is_some() {
                break;
            }
            if let Ok(Some(status)) = child.try_wait() {
                return Err(RunError::Died {
                    node: "echo",
                    pid: child.id(),
                    step: 0,
                    status: status.to_string(),
                });
            }
            if started.elapsed() > Duration::from_secs(30) {
                return Err(RunError::Stalled {
                    node: "echo",
                    step: 0,
                    waited_s: 30.0,
                    what: "it never answered",
                });
            }
        }
        for i in 1..=(warmup + iterations) as u64 {
            let sent = tx.send(i, 0.0, &batch)?;
            let echoed = loop {
                if let (Some((h, _)), _) = rx.take_sample(i)? {
                    break h.stamp_ns;
                }
                wait(&listener, Duration::from_secs(1))?;
                if let Ok(Some(status)) = child.try_wait() {
                    return Err(RunError::Died {
                        node: "echo",
                        pid: child.id(),
                        step: i,
                        status: status.to_string(),
                    });
                }
            };
            if i as usize > warmup {
                hops.push(echoed.saturating_sub(sent));
            }
        }
        Ok(())
    })();
    let _ = tx.send(QUIT, 0.0, &[]);
    let until = Instant::now() + Duration::from_secs(2);
    while Instant::now() < until && !matches!(child.try_wait(), Ok(Some(_))) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let _ = child.kill();
    let _ = child.wait();
    result?;
    Ok(hops)
}

/// The echo process: republishes every tx sample on rx, until told to quit or orphaned.
pub fn echo(run_id: &str) -> Result<(), RunError> {
    let e = Endpoint::new(run_id, Node::Injector)?;
    let listener = e.listener()?;
    let mut tx: Inlet<LinkPacket> =
        Inlet::new(&e.open_step_service(Service::Tx)?, Node::Controller)?;
    let rx: Outlet<LinkPacket> = e.outlet(&e.open_step_service(Service::Rx)?, Service::Rx, 64)?;
    let parent = std::os::unix::process::parent_id();
    loop {
        tx.drain()?;
        while let Some((h, items)) = tx.pop() {
            if h.step == QUIT {
                return Ok(());
            }
            rx.send(h.step, 0.0, &items)?;
        }
        wait(&listener, Duration::from_millis(200))?;
        if std::os::unix::process::parent_id() != parent {
            return Err(RunError::Orphaned);
        }
    }
}
