//! The wake-up hand-off: a node that wakes another one on a multi-CPU machine first narrows the
//! sleeping reader's CPU set to the CPU it runs on itself, unless the reader already has just
//! that CPU; the reader keeps the narrowed set for a few wake-ups and then returns to its own.
//!
//! Why: a step is a chain of hops, each a wake-up of a process that sleeps in iceoryx2's
//! listener (a blocking Unix-datagram receive). Linux wakes a sleeper on an idle CPU when there
//! is one, and on a VM an idle vCPU is halted: waking it costs 20-30 µs, most of a hop. Woken
//! on the waker's CPU (which is about to block on its own listener), the hop costs what it
//! costs on one core. Nothing spins. A chain that stays on one CPU pays one `sched_getaffinity`
//! (about 0.3 µs) per wake-up: the set is changed (about 1 µs a call) only when the chain moved
//! or the reader went home. Every [`RETURN_EVERY`] wake-ups a node returns to its own set, so
//! the load balancer can still move the chain; the orchestrator, which records off the chain,
//! is never narrowed and stays free to run on the other CPU. Two runs at once may be held on
//! one CPU for a while this way (their chains each follow their waker); `--cpus` with a
//! different CPU per run is the fastest for runs side by side.
//! `PLATOON_WAKE_HANDOFF=0` turns it off; it is off by itself where a process may run on one
//! CPU only (`platoon run --cpus 0`), and failures (another user's process, a CPU outside the
//! reader's cgroup) are ignored: the hop is then an ordinary one.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Mutex;

/// A node returns to its own CPU set every this many wake-ups (a narrowed set is kept between
/// them, so a chain that stays on one CPU changes no set).
pub(crate) const RETURN_EVERY: u32 = 64;

/// Wake-ups since this process last returned to its own set.
static WOKEN: AtomicU32 = AtomicU32::new(0);

/// `sched_setaffinity` calls on other processes so far (what the tests count).
#[cfg(test)]
static NARROWED: AtomicU32 = AtomicU32::new(0);

/// Whether this process hands its wake-ups off (its own set has more than one CPU).
static ON: AtomicBool = AtomicBool::new(false);

/// This process's own CPU set, read when its endpoint was made, if the hand-off is on.
static HOME: Mutex<Option<libc::cpu_set_t>> = Mutex::new(None);

/// Reads this process's CPU set as it is now (each endpoint made reads it again): the set
/// [`restore`] returns to. The hand-off is on when that set has more than one CPU and
/// `PLATOON_WAKE_HANDOFF` is not `0`; a process pinned to one CPU (`platoon run --cpus`, the
/// one-core rows of `bench latency`) neither narrows others nor leaves its CPU.
pub(crate) fn init() {
    let home = (|| {
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
    })();
    let mut slot = HOME.lock().unwrap_or_else(|e| e.into_inner());
    ON.store(home.is_some(), Ordering::Relaxed);
    WOKEN.store(0, Ordering::Relaxed);
    *slot = home;
}

/// Whether this process hands its wake-ups off.
pub(crate) fn enabled() -> bool {
    ON.load(Ordering::Relaxed)
}

/// Narrows the sleeping processes `pids` to the CPU this one runs on, each unless it already
/// has just that CPU: call it right before waking them.
pub(crate) fn hand_to(pids: &[libc::pid_t]) {
    if pids.is_empty() || !enabled() {
        return;
    }
    // SAFETY: sched_getcpu has no arguments; cpu_set_t is plain data.
    let cpu = unsafe { libc::sched_getcpu() };
    if cpu < 0 {
        return;
    }
    let size = std::mem::size_of::<libc::cpu_set_t>();
    let mut one: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    unsafe { libc::CPU_SET(cpu as usize, &mut one) };
    for &pid in pids {
        let mut now: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        // SAFETY: reads the CPU set of `pid` into `now`; an error leaves it empty.
        let read = unsafe { libc::sched_getaffinity(pid, size, &mut now) } == 0;
        if read && unsafe { libc::CPU_EQUAL(&now, &one) } {
            continue;
        }
        #[cfg(test)]
        NARROWED.fetch_add(1, Ordering::Relaxed);
        // SAFETY: only the CPU set of `pid` changes; an error leaves it as it was.
        unsafe { libc::sched_setaffinity(pid, size, &one) };
    }
}

/// After a wake-up: every [`RETURN_EVERY`]-th one, returns this process to its own CPU set
/// (another node may have narrowed it); the others keep the set as it is.
pub(crate) fn woken() {
    if !enabled() {
        return;
    }
    if WOKEN.fetch_add(1, Ordering::Relaxed) + 1 >= RETURN_EVERY {
        WOKEN.store(0, Ordering::Relaxed);
        restore();
    }
}

/// Returns this process to its own CPU set (another node may have narrowed it).
pub(crate) fn restore() {
    let home = *HOME.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(home) = home {
        // SAFETY: sets this process's own CPU set to the one it started with.
        unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &home) };
    }
}

/// Returns this process to its own CPU set for good, when it stops being a node (the bench
/// process after a raw hop): what it starts next must not inherit a narrowed set.
pub(crate) fn go_home() {
    if enabled() {
        WOKEN.store(0, Ordering::Relaxed);
        restore();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-off's state is the process's: its tests run one at a time.
    static SERIAL: Mutex<()> = Mutex::new(());

    fn cpus_of(pid: libc::pid_t) -> usize {
        // SAFETY: cpu_set_t is plain data, filled in by sched_getaffinity.
        let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        let size = std::mem::size_of::<libc::cpu_set_t>();
        assert_eq!(unsafe { libc::sched_getaffinity(pid, size, &mut set) }, 0);
        unsafe { libc::CPU_COUNT(&set) as usize }
    }

    #[test]
    fn a_sleeping_reader_is_handed_one_cpu_and_gets_its_set_back_every_return_every_wake_ups() {
        let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
        init();
        let cpus = cpus_of(0);
        // On by itself wherever there is more than one CPU (unless turned off).
        let off = std::env::var_os("PLATOON_WAKE_HANDOFF").is_some_and(|v| v == "0");
        assert_eq!(enabled(), cpus > 1 && !off);
        // This thread, narrowed as a reader is (so the CPU it hands on stays the same).
        hand_to(&[0]);
        // A reader that sleeps until this test kills it (also when an assertion fails), however
        // slowly the machine gets to the checks.
        struct Reader(std::process::Child);
        impl Drop for Reader {
            fn drop(&mut self) {
                let _ = self.0.kill();
                let _ = self.0.wait();
            }
        }
        let child = Reader(
            std::process::Command::new("sleep")
                .arg("100000")
                .spawn()
                .expect("sleep"),
        );
        let pid = child.0.id() as libc::pid_t;
        // The child inherited the narrowed set; give it the whole one back first.
        let home = HOME
            .lock()
            .unwrap()
            .unwrap_or(unsafe { std::mem::zeroed() });
        unsafe { libc::sched_setaffinity(pid, std::mem::size_of::<libc::cpu_set_t>(), &home) };
        assert_eq!(cpus_of(pid), cpus);
        hand_to(&[pid]);
        assert_eq!(cpus_of(pid), if enabled() { 1 } else { cpus });
        // Handed the CPU it already has, it keeps it, and its set is not written again.
        let narrowed = NARROWED.load(Ordering::Relaxed);
        hand_to(&[pid]);
        assert_eq!(cpus_of(pid), if enabled() { 1 } else { cpus });
        assert_eq!(NARROWED.load(Ordering::Relaxed), narrowed);
        // A narrowed node keeps its set for RETURN_EVERY - 1 wake-ups and returns to its own
        // at the next one.
        WOKEN.store(0, Ordering::Relaxed);
        for _ in 1..RETURN_EVERY {
            woken();
        }
        assert_eq!(cpus_of(0), if enabled() { 1 } else { cpus });
        woken();
        assert_eq!(cpus_of(0), cpus);
        // A process that stops being a node goes home for good.
        hand_to(&[0]);
        go_home();
        assert_eq!(cpus_of(0), cpus);
        drop(child);
    }

    #[test]
    fn a_process_pinned_to_one_cpu_hands_nothing_off_and_stays() {
        let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
        init();
        let Some(home) = *HOME.lock().unwrap() else {
            return; // one CPU, or turned off: nothing to pin away from
        };
        hand_to(&[0]);
        // An endpoint made now (as in `bench latency`'s one-core rows) reads the pinned set.
        init();
        assert!(!enabled());
        for _ in 0..RETURN_EVERY {
            woken();
        }
        assert_eq!(cpus_of(0), 1);
        // Back on its own CPUs, the next endpoint hands off again.
        unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &home) };
        init();
        assert!(enabled());
    }

    #[test]
    fn python_nodes_return_home_as_often_as_rust_ones() {
        let wire = concat!(env!("CARGO_MANIFEST_DIR"), "/../../bridge/platoon/wire.py");
        let text = std::fs::read_to_string(wire).expect("bridge/platoon/wire.py");
        let value = text
            .lines()
            .find_map(|l| l.strip_prefix("HANDOFF_RETURN_EVERY = "))
            .expect("HANDOFF_RETURN_EVERY in bridge/platoon/wire.py");
        assert_eq!(value.trim().parse::<u32>(), Ok(RETURN_EVERY));
    }
}
