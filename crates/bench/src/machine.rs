//! What the reports say of the machine and the source tree: cores, halt polling, the commit.
use std::path::Path;
use std::process::Command;

/// Where the haltpoll cpuidle driver (KVM guests) exposes how long an idle vCPU polls before
/// halting.
pub(crate) const HALT_POLL: &str = "/sys/module/haltpoll/parameters/guest_halt_poll_ns";

/// `guest_halt_poll_ns`, read from this machine (None where it is not readable).
pub(crate) fn guest_halt_poll_ns() -> Option<String> {
    std::fs::read_to_string(HALT_POLL)
        .ok()
        .map(|v| v.trim().to_string())
        .filter(|v| !v.is_empty())
}

/// What was read of `guest_halt_poll_ns`, for the report.
pub(crate) fn describe_halt_poll(v: Option<&str>) -> String {
    match v {
        Some("0") => format!(
            "`guest_halt_poll_ns` = 0, read from {HALT_POLL}: idle vCPUs halt without polling"
        ),
        Some(v) => format!(
            "`guest_halt_poll_ns` = {v}, read from {HALT_POLL}: idle vCPUs poll up to {v} ns before halting"
        ),
        None => format!("`guest_halt_poll_ns` not readable here ({HALT_POLL})"),
    }
}

/// The commit of the source tree this binary was built from, as git reports it when the
/// benchmarks start: the short hash, with " + uncommitted changes" when a tracked file other
/// than BENCHMARKS.md (the report itself) differs from it, or "unknown" without git or the tree.
pub(crate) fn commit() -> String {
    let tree = Path::new(env!("CARGO_MANIFEST_DIR"));
    let git = |args: &[&str]| -> Option<String> {
        let o = Command::new("git")
            .arg("-C")
            .arg(tree)
            .args(args)
            .stderr(std::process::Stdio::null())
            .output()
            .ok()?;
        o.status
            .success()
            .then(|| String::from_utf8_lossy(&o.stdout).into_owned())
    };
    let Some(head) = git(&["rev-parse", "--short", "HEAD"]) else {
        return "unknown".into();
    };
    let head = head.trim().to_string();
    match git(&["status", "--porcelain", "--untracked-files=no"]) {
        Some(status) => {
            let changed = status
                .lines()
                .filter_map(|l| l.get(3..))
                .any(|path| path != "BENCHMARKS.md");
            if changed {
                format!("{head} + uncommitted changes")
            } else {
                head
            }
        }
        None => format!("{head} (uncommitted changes unknown)"),
    }
}

pub(crate) fn cores() -> usize {
    std::thread::available_parallelism().map_or(0, |n| n.get())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stamp of BENCHMARKS.md: a short hash (with a note when the tree differs from it), or
    /// "unknown" where git or the source tree is missing.
    #[test]
    fn the_commit_is_a_short_hash_or_unknown() {
        let c = commit();
        let hash = c.split(' ').next().unwrap_or_default();
        assert!(
            c == "unknown"
                || (hash.len() >= 7
                    && hash.chars().all(|x| x.is_ascii_hexdigit())
                    && [hash.to_string(), format!("{hash} + uncommitted changes")].contains(&c)),
            "{c}"
        );
    }

    /// `guest_halt_poll_ns` is reported as read, never assumed.
    #[test]
    fn halt_polling_is_reported_as_read() {
        assert!(describe_halt_poll(Some("0")).contains("= 0, read from"));
        assert!(describe_halt_poll(Some("200000")).contains("poll up to 200000 ns"));
        assert!(describe_halt_poll(None).contains("not readable here"));
        let read = describe_halt_poll(guest_halt_poll_ns().as_deref());
        match std::fs::read_to_string(HALT_POLL) {
            Ok(v) => assert!(read.contains(&format!("= {},", v.trim())), "{read}"),
            Err(_) => assert!(read.contains("not readable here"), "{read}"),
        }
    }
}
