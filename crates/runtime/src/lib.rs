//! The iceoryx2 co-simulation: one process per role, lock-step, event-driven.
//!
//! ```text
//!  plant --states[k]--> controller --tx[k]--> injector --rx[k]--> controller --commands[k]--> plant
//!                 (the orchestrator reads every service and records the run)
//! ```
//!
//! Every node composes the same pure core as the in-process runner (`platoon-sim`): the plant
//! runs [`platoon_sim::Plant`], the controller [`platoon_control::ComposedController`], the
//! injector [`platoon_attacks::channel::Channel`], and the orchestrator assembles its rows with
//! [`platoon_sim::step_rows`], so both transports give the same trajectories bit for bit.
//!
//! Nothing busy-polls: each node blocks on its own wake-up event service with a timeout and is
//! notified by every publisher it reads from.
#![warn(missing_docs)]

pub mod bench;
pub mod controller;
mod detection;
mod handoff;
pub mod injector;
pub mod ipc;
pub mod nodes;
pub mod orchestrator;
pub mod plugin;
pub mod session;
pub mod timing;

pub use orchestrator::{orchestrate, DuplicateSamples, Options, Outcome, Program};

/// Why a co-simulation (the orchestrator's run, or one of its processes) stopped early.
#[derive(Debug, thiserror::Error)]
pub enum CosimError {
    /// iceoryx2 refused an operation.
    #[error("iceoryx2: {what}")]
    Ipc {
        /// What this process was doing (`creating service platoon/<run>/states`, ...).
        what: String,
        /// iceoryx2's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
    /// A node's process could not be started.
    #[error("could not start the {node} process ({command})")]
    Spawn {
        /// Which.
        node: &'static str,
        /// The command line.
        command: String,
        /// Why.
        source: std::io::Error,
    },
    /// A node's process exited before the end of the run.
    #[error("the {node} process (pid {pid}) exited at step {step}: {status}{detail}")]
    Died {
        /// Which.
        node: &'static str,
        /// Its pid.
        pid: u32,
        /// The step the run was at.
        step: u64,
        /// How it ended.
        status: String,
        /// What else helps: the last lines of its log, the run's contract version (empty, or
        /// starting with a line break).
        detail: String,
    },
    /// This process was built for another contract version than the run that started it
    /// speaks (`platoon_wire::check_contract_version`).
    #[error("{0}")]
    ContractVersion(String),
    /// A node did not publish what the run waited for.
    #[error(
        "the {node} process published nothing for step {step} within {waited_s} s ({what}){}{detail}",
        if *duplicates > 0 { format!("; meanwhile {duplicates} duplicate samples of steps already published arrived") } else { String::new() }
    )]
    Stalled {
        /// Which.
        node: &'static str,
        /// The step the run was at.
        step: u64,
        /// The timeout (s).
        waited_s: f64,
        /// What was missing.
        what: &'static str,
        /// Samples that repeated a step (they do not count as progress).
        duplicates: u64,
        /// Where its log is and its last lines, and how to wait longer (empty, or starting
        /// with a line break).
        detail: String,
    },
    /// The run was asked to stop (SIGINT or SIGTERM to `platoon run`).
    #[error("interrupted at step {step}")]
    Interrupted {
        /// The step the run was at.
        step: u64,
    },
    /// A node reported that it cannot go on.
    #[error("the {node} process failed at step {step}: {reason}{detail}")]
    Failed {
        /// Which.
        node: &'static str,
        /// At which step.
        step: u64,
        /// Its reason, made printable.
        reason: String,
        /// Where its log is, with the whole report (empty, or starting with a line break).
        detail: String,
    },
    /// A sample broke the contract (wrong length, unknown vehicle, NaN command).
    #[error("{node}: {message}")]
    Contract {
        /// Who sent it.
        node: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The orchestrator went away: this node exits.
    #[error("the orchestrator is gone")]
    Orphaned,
    /// The orchestrator aborted the run.
    #[error("aborted by the orchestrator: {0}")]
    Aborted(String),
}

impl CosimError {
    /// The node this error is about, if one.
    pub fn node(&self) -> Option<&'static str> {
        match self {
            CosimError::Spawn { node, .. }
            | CosimError::Died { node, .. }
            | CosimError::Stalled { node, .. }
            | CosimError::Failed { node, .. }
            | CosimError::Contract { node, .. } => Some(node),
            _ => None,
        }
    }
}

/// An error and its causes, `: `-separated (as `anyhow` prints `{:#}`): for a message that
/// goes where no one walks the chain (a node's report, a plug-in's stderr).
pub struct Causes<'a>(pub &'a (dyn std::error::Error + 'static));

impl std::fmt::Display for Causes<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)?;
        let mut cause = self.0.source();
        while let Some(c) = cause {
            write!(f, ": {c}")?;
            cause = c.source();
        }
        Ok(())
    }
}

/// A fresh run id: process id and time, so concurrent runs never share a service.
pub fn new_run_id() -> String {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    format!("{:x}-{:x}", std::process::id(), nanos & 0xffff_ffff_ffff)
}

/// `CLOCK_MONOTONIC` in ns (shared by every process on the machine), for packet time stamps.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime only writes the timespec it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Parses a CPU list as `taskset -c` takes it ("0", "0,2", "0-3") and checks that this process
/// may run on each of them. The error says which CPU is not available and which are.
pub fn parse_cpus(list: &str) -> Result<Vec<usize>, String> {
    let mut cpus = Vec::new();
    for part in list.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let num = |s: &str| {
            s.trim()
                .parse::<usize>()
                .map_err(|_| format!("{part:?} is not a CPU number or range (e.g. 0, 0,2 or 0-3)"))
        };
        let (lo, hi) = match part.split_once('-') {
            Some((a, b)) => (num(a)?, num(b)?),
            None => (num(part)?, num(part)?),
        };
        if lo > hi {
            return Err(format!("{part:?}: the range is empty"));
        }
        cpus.extend(lo..=hi);
    }
    if cpus.is_empty() {
        return Err("the CPU list is empty".into());
    }
    let available = available_cpus();
    if let Some(c) = cpus.iter().find(|c| !available.contains(c)) {
        return Err(format!(
            "CPU {c} is not available to this process (available: {})",
            available
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(",")
        ));
    }
    cpus.sort_unstable();
    cpus.dedup();
    Ok(cpus)
}

/// The CPUs this process may run on (its affinity mask).
pub fn available_cpus() -> Vec<usize> {
    // SAFETY: cpu_set_t is plain data, filled in by sched_getaffinity.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    let size = std::mem::size_of::<libc::cpu_set_t>();
    if unsafe { libc::sched_getaffinity(0, size, &mut set) } != 0 {
        return Vec::new();
    }
    (0..libc::CPU_SETSIZE as usize)
        .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
        .collect()
}

/// The peak resident memory (`VmHWM`) of process `pid`, or of this process with `None`, in
/// KiB; `None` where `/proc` does not say (not Linux, or the process is gone).
pub fn peak_rss_kib(pid: Option<u32>) -> Option<u64> {
    let path = match pid {
        Some(pid) => format!("/proc/{pid}/status"),
        None => "/proc/self/status".to_string(),
    };
    std::fs::read_to_string(path)
        .ok()?
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_lists_parse_like_taskset_and_name_what_is_wrong() {
        let first = available_cpus()[0];
        assert_eq!(parse_cpus(&first.to_string()).unwrap(), vec![first]);
        assert_eq!(
            parse_cpus(&format!("{first},{first}-{first}")).unwrap(),
            vec![first]
        );
        assert!(parse_cpus("").unwrap_err().contains("empty"));
        assert!(parse_cpus("x").unwrap_err().contains("\"x\""));
        assert!(parse_cpus("3-1").unwrap_err().contains("empty"));
        let own = peak_rss_kib(None).unwrap();
        assert!(own > 100, "{own} KiB");
        // The same process by pid. Not `>= own`: the kernel folds the current RSS into VmHWM
        // lazily, so a second read can be lower when the tests running beside this one have
        // freed memory in between (seen once in CI).
        let by_pid = peak_rss_kib(Some(std::process::id())).unwrap();
        assert!(
            by_pid > 100 && by_pid <= 2 * own && own <= 2 * by_pid,
            "{by_pid} vs {own} KiB"
        );
        let err = parse_cpus("100000").unwrap_err();
        assert!(err.contains("CPU 100000 is not available"), "{err}");
    }
}
