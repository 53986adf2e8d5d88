//! The wake-up hand-off: a node that wakes another one on a multi-CPU machine first narrows the
//! sleeping reader's CPU set to the CPU it runs on itself, and the reader restores its own set
//! as soon as it wakes.
//!
//! Why: a step is a chain of hops, each a wake-up of a process that sleeps in iceoryx2's
//! listener (a blocking Unix-datagram receive). Linux wakes a sleeper on an idle CPU when there
//! is one, and on a VM an idle vCPU is halted: waking it costs 20-30 µs, most of a hop. Woken
//! on the waker's CPU (which is about to block on its own listener), the hop costs what it
//! costs on one core. No process is held to a CPU while it runs, nothing spins, and the load
//! balancer still moves the chain; only a sleeping reader's set is narrowed, until it wakes.
//! `PLATOON_WAKE_HANDOFF=0` turns it off; it is off by itself where a process may run on one
//! CPU only (`platoon run --cpus 0`), and failures (another user's process, a CPU outside the
//! reader's cgroup) are ignored: the hop is then an ordinary one.

use std::sync::OnceLock;

/// This process's CPU set when its endpoint was made, if the hand-off is on.
static HOME: OnceLock<Option<libc::cpu_set_t>> = OnceLock::new();

/// Reads this process's CPU set, once: the set [`restore`] returns to. The hand-off is on when
/// that set has more than one CPU and `PLATOON_WAKE_HANDOFF` is not `0`.
pub(crate) fn init() {
    HOME.get_or_init(|| {
        if std::env::var_os("PLATOON_WAKE_HANDOFF").is_some_and(|v| v == "0") {
            return None;
        }
        // SAFETY: cpu_set_t is plain data, filled in by sched_getaffinity.
        let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        let size = std::mem::size_of::<libc::cpu_set_t>();
        if unsafe { libc::sched_getaffinity(0, size, &mut set) } != 0 {
            return None;
        }
        (unsafe { libc::CPU_COUNT(&set) } > 1).then_some(set)
    });
}

/// Whether this process hands its wake-ups off.
pub(crate) fn enabled() -> bool {
    HOME.get().is_some_and(Option::is_some)
}

/// Narrows the sleeping processes `pids` to the CPU this one runs on: call it right before
/// waking them.
pub(crate) fn hand_to(pids: &[libc::pid_t]) {
    if pids.is_empty() || !enabled() {
        return;
    }
    // SAFETY: sched_getcpu has no arguments; cpu_set_t is plain data.
    let cpu = unsafe { libc::sched_getcpu() };
    if cpu < 0 {
        return;
    }
    let mut one: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    unsafe { libc::CPU_SET(cpu as usize, &mut one) };
    for &pid in pids {
        // SAFETY: only the CPU set of `pid` changes; an error leaves it as it was.
        unsafe { libc::sched_setaffinity(pid, std::mem::size_of::<libc::cpu_set_t>(), &one) };
    }
}

/// Returns this process to its own CPU set after a wake-up (another node may have narrowed it).
pub(crate) fn restore() {
    if let Some(Some(home)) = HOME.get() {
        // SAFETY: sets this process's own CPU set to the one it started with.
        unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), home) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cpus_of(pid: libc::pid_t) -> usize {
        // SAFETY: cpu_set_t is plain data, filled in by sched_getaffinity.
        let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        let size = std::mem::size_of::<libc::cpu_set_t>();
        assert_eq!(unsafe { libc::sched_getaffinity(pid, size, &mut set) }, 0);
        unsafe { libc::CPU_COUNT(&set) as usize }
    }

    #[test]
    fn a_sleeping_reader_is_handed_one_cpu_and_a_woken_one_gets_its_set_back() {
        init();
        let cpus = cpus_of(0);
        // On by itself wherever there is more than one CPU (unless turned off).
        let off = std::env::var_os("PLATOON_WAKE_HANDOFF").is_some_and(|v| v == "0");
        assert_eq!(enabled(), cpus > 1 && !off);
        let mut child = std::process::Command::new("sleep")
            .arg("10")
            .spawn()
            .expect("sleep");
        let pid = child.id() as libc::pid_t;
        assert_eq!(cpus_of(pid), cpus);
        hand_to(&[pid]);
        assert_eq!(cpus_of(pid), if enabled() { 1 } else { cpus });
        // This process, narrowed as a reader is, returns to its own set.
        hand_to(&[0]);
        restore();
        assert_eq!(cpus_of(0), cpus);
        let _ = child.kill();
        let _ = child.wait();
    }
}
