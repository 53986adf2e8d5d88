//! Supervision of the run's processes: starting them (CPU sets, Python path, logs), watching
//! them, naming the one that failed from its report or its log, and stopping them all.
use super::*;

/// One process of the run.
pub(super) struct Proc {
    pub(super) node: Node,
    pub(super) child: Child,
    /// Where its stdout and stderr go.
    pub(super) log: Option<PathBuf>,
    /// Not built in: a program of the user's (`--injector`) or the SUMO bridge.
    pub(super) plugin: bool,
}

pub(super) struct Children {
    pub(super) procs: Vec<Proc>,
}

impl Children {
    /// A child that has exited (its index), with its status.
    pub(super) fn exited(&mut self) -> Option<(usize, String)> {
        self.procs
            .iter_mut()
            .enumerate()
            .find_map(|(i, p)| Some((i, p.child.try_wait().ok()??.to_string())))
    }

    /// The process that plays `node`.
    pub(super) fn of(&self, node: &str) -> Option<&Proc> {
        self.procs.iter().find(|p| p.node.name() == node)
    }

    /// Each child's peak resident memory so far, in KiB.
    pub(super) fn peak_rss_kib(&self) -> Vec<(&'static str, u64)> {
        self.procs
            .iter()
            .filter_map(|p| Some((p.node.name(), crate::peak_rss_kib(Some(p.child.id()))?)))
            .collect()
    }

    /// Waits up to `grace` for every child to exit, then kills what is left.
    pub(super) fn shut_down(&mut self, grace: Duration) {
        let until = Instant::now() + grace;
        for Proc { child: c, .. } in &mut self.procs {
            while Instant::now() < until {
                if let Ok(Some(_)) = c.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
        self.procs.clear();
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        self.shut_down(Duration::ZERO);
    }
}

/// A node's FAILED report as the run's error, naming the log that holds the whole of it.
pub(super) fn check_failed(m: &ControlMsg, children: &Children) -> Result<(), CosimError> {
    if m.kind == ControlMsg::FAILED {
        let node = Node::from_u32(m.node).map_or("unknown", |n| n.name());
        return Err(CosimError::Failed {
            node,
            step: m.step,
            reason: printable(&m.reason()),
            detail: children
                .of(node)
                .map_or_else(String::new, |p| log_detail(p, false)),
        });
    }
    Ok(())
}

/// The error of a process that exited, or the report it sent first: a node that reported
/// FAILED and waits for ABORT (both SDKs, the built-in nodes and the SUMO plant do) keeps its
/// report readable until it is read, so its report, never its exit, is the run's error on any
/// machine load. A process that exits right after reporting may take its report with it.
pub(super) fn watch(
    children: &mut Children,
    step: u64,
    status: &ControlInlet,
) -> Result<(), CosimError> {
    let Some((i, exit)) = children.exited() else {
        return Ok(());
    };
    while let Some(m) = status.next()? {
        check_failed(&m, children)?;
    }
    let p = &children.procs[i];
    Err(CosimError::Died {
        node: p.node.name(),
        pid: p.child.id(),
        step,
        status: exit,
        detail: died_detail(p, step),
    })
}

/// How many of a dead process's last log lines its error quotes.
pub(super) const TAIL_LINES: usize = 10;

/// What the error of a process that died adds, one line each: the last lines of its log (its
/// stderr and stdout) and where that log is, and for a plug-in that died before the run got
/// past step 0 (starting, or at its first step: where a plug-in of another contract version
/// fails) the contract version the run speaks.
pub(super) fn died_detail(p: &Proc, step: u64) -> String {
    let mut s = log_detail(p, true);
    if p.plugin && step == 0 {
        use platoon_wire::{CONTRACT_DOC, CONTRACT_VERSION, CONTRACT_VERSION_ENV};
        s += &format!(
            "\n  this run speaks platoon contract v{CONTRACT_VERSION} (type names \
             platoon::v{CONTRACT_VERSION}::*, {CONTRACT_VERSION_ENV}={CONTRACT_VERSION} in the \
             {}'s environment); a plug-in written for another version fails as it starts: \
             see \"Contract versions\" in {CONTRACT_DOC}",
            p.node.name()
        );
    }
    s
}

/// A line naming `p`'s log (`logs/<node>.log`, in the run directory) and, with `tail`, quoting
/// its last lines; empty when its output is not logged.
pub(super) fn log_detail(p: &Proc, tail: bool) -> String {
    let Some(log) = &p.log else {
        return String::new();
    };
    // The log directory is `logs/` in the run directory, which is renamed when the run ends:
    // name it from there.
    let shown = match log.parent().and_then(|d| d.file_name()) {
        Some(dir) => format!("{}/{}.log", dir.to_string_lossy(), p.node.name()),
        None => format!("{}.log", p.node.name()),
    };
    if !tail {
        return format!("\n  its whole report is in {shown} (in the run directory)");
    }
    let lines = last_lines(log, TAIL_LINES);
    if lines.is_empty() {
        return format!("\n  it wrote nothing to {shown} (in the run directory)");
    }
    let mut s = format!("\n  the last lines of {shown} (in the run directory):");
    for line in lines {
        s += &format!("\n  | {line}");
    }
    s
}

/// `text` safe for a terminal and a JSON file: control characters (an escape sequence, a
/// carriage return, a NUL) are written as escapes (`\u{1b}`); invalid UTF-8 was already
/// replaced when the bytes were read.
pub(super) fn printable(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// The last `n` non-empty lines of a log file (of its last 64 KiB), each cut to 300
/// characters and made [`printable`]; none if it cannot be read.
pub(super) fn last_lines(path: &std::path::Path, n: usize) -> Vec<String> {
    use std::io::{Read, Seek, SeekFrom};
    const WINDOW: u64 = 64 * 1024;
    let Ok(mut file) = std::fs::File::open(path) else {
        return Vec::new();
    };
    let len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut bytes = Vec::new();
    if file
        .seek(SeekFrom::Start(len.saturating_sub(WINDOW)))
        .is_err()
        || file.read_to_end(&mut bytes).is_err()
    {
        return Vec::new();
    }
    let text = String::from_utf8_lossy(&bytes);
    let mut lines: Vec<String> = text
        .lines()
        .map(str::trim_end)
        .filter(|l| !l.is_empty())
        .rev()
        .take(n)
        .map(|l| match l.char_indices().nth(300) {
            Some((i, _)) => format!("{}...", printable(&l[..i])),
            None => printable(l),
        })
        .collect();
    lines.reverse();
    lines
}

pub(super) fn spawn_all(opts: &Options, children: &mut Children) -> Result<(), CosimError> {
    let channel = opts.channel_first.then_some(Node::Channel);
    for node in [Node::Plant, Node::Controller, Node::Injector]
        .into_iter()
        .chain(channel)
    {
        let program = match node {
            Node::Plant => &opts.plant,
            Node::Controller => &opts.controller,
            Node::Injector => &opts.injector,
            _ => &Program::Builtin,
        };
        let (mut cmd, shown) = match program {
            Program::Shell(line) => {
                let mut cmd = Process::new("sh");
                cmd.arg("-c").arg(format!("exec {line}"));
                (cmd, line.clone())
            }
            Program::Exec { program, args } => {
                let mut cmd = Process::new(program);
                cmd.args(args);
                (cmd, format!("{} {}", program.display(), args.join(" ")))
            }
            Program::Builtin => {
                let mut cmd = node_command(opts, node);
                // The channel log belongs to whichever node runs the built-in channel.
                if matches!(node, Node::Injector | Node::Channel) {
                    if let Some(log) = &opts.channel_log {
                        cmd.arg("--log").arg(log);
                    }
                }
                (cmd, format!("{} node {}", opts.exe.display(), node.name()))
            }
        };
        // Their own process group: a Ctrl-C at the terminal reaches the orchestrator only,
        // which stops them with ABORT after recording what is complete.
        std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
        pin(&mut cmd, &opts.cpus);
        if node == Node::Injector && opts.channel_first {
            cmd.env("PLATOON_INJECTOR_INPUT", "gated");
        }
        cmd.env("PLATOON_RUN_ID", &opts.run_id)
            .env("PLATOON_CONFIG", &opts.config)
            .env(
                platoon_wire::CONTRACT_VERSION_ENV,
                platoon_wire::CONTRACT_VERSION.to_string(),
            )
            .envs(opts.env.iter().map(|(k, v)| (k, v)))
            .stdin(Stdio::null());
        if let Some(facts) = &opts.facts {
            cmd.env(crate::plugin::RUN_FACTS_ENV, facts);
        }
        // Our nodes compute one step at a time between wake-ups: a BLAS thread pool (this
        // binary's OpenBLAS, numpy's in the SUMO bridge) buys them nothing, and its threads
        // spin at start (some 50 ms of CPU each, beside SUMO starting). A user's command
        // (`--injector`, `--controller`) gets the environment as it is; so does any node when
        // the user set the variable.
        let blas = "OPENBLAS_NUM_THREADS";
        let ours = !matches!(program, Program::Shell(_));
        if ours && std::env::var_os(blas).is_none() && !opts.env.iter().any(|(k, _)| k == blas) {
            cmd.env(blas, "1");
        }
        let plugin = *program != Program::Builtin;
        if let (true, Some(dir)) = (plugin, &opts.python_path) {
            cmd.env("PYTHONPATH", python_path(dir, &opts.env));
        }
        let spawn_err = |source| CosimError::Spawn {
            node: node.name(),
            command: shown.clone(),
            source,
        };
        let log = opts
            .log_dir
            .as_ref()
            .map(|dir| dir.join(format!("{}.log", node.name())));
        if let Some(log) = &log {
            let file = std::fs::File::create(log).map_err(spawn_err)?;
            let out = file.try_clone().map_err(spawn_err)?;
            cmd.stdout(out).stderr(file);
        }
        let child = cmd.spawn().map_err(spawn_err)?;
        children.procs.push(Proc {
            node,
            child,
            log,
            plugin,
        });
    }
    Ok(())
}

/// `dir` before the `PYTHONPATH` a plug-in would otherwise get (from `env`, the run's
/// [`Options::env`], else this process's), which it keeps.
pub(super) fn python_path(dir: &std::path::Path, env: &[(String, String)]) -> std::ffi::OsString {
    let theirs = match env.iter().rev().find(|(k, _)| k == "PYTHONPATH") {
        Some((_, v)) => Some(std::ffi::OsString::from(v)),
        None => std::env::var_os("PYTHONPATH"),
    };
    let mut path = dir.as_os_str().to_owned();
    if let Some(theirs) = theirs.filter(|t| !t.is_empty()) {
        path.push(":");
        path.push(theirs);
    }
    path
}

/// Restricts the child to `cpus` (before it runs anything, so its threads inherit it).
pub(super) fn pin(cmd: &mut Process, cpus: &[usize]) {
    if cpus.is_empty() {
        return;
    }
    // SAFETY: cpu_set_t is plain data; CPU_ZERO/CPU_SET only write into it.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &cpu in cpus {
        unsafe { libc::CPU_SET(cpu, &mut set) };
    }
    // SAFETY: sched_setaffinity is async-signal-safe and touches only this (forked) process.
    unsafe {
        std::os::unix::process::CommandExt::pre_exec(cmd, move || {
            if libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

pub(super) fn node_command(opts: &Options, node: Node) -> Process {
    let mut cmd = Process::new(&opts.exe);
    cmd.arg("node")
        .arg(node.name())
        .arg("--run-id")
        .arg(&opts.run_id)
        .arg("--config")
        .arg(&opts.config);
    cmd
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dead(node: Node, log: Option<PathBuf>, plugin: bool) -> Proc {
        let mut child = Process::new("true").spawn().unwrap();
        child.wait().unwrap();
        Proc {
            node,
            child,
            log,
            plugin,
        }
    }

    #[test]
    fn a_dead_plugin_is_quoted_from_its_log_and_told_the_contract() {
        let dir = std::env::temp_dir().join(format!("platoon-died-{}", std::process::id()));
        let logs = dir.join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        let log = logs.join("injector.log");
        let mut text: String = (1..=15).map(|i| format!("line {i}\n\n")).collect();
        text += &"x".repeat(1000);
        std::fs::write(&log, text).unwrap();
        let d = died_detail(&dead(Node::Injector, Some(log.clone()), true), 0);
        assert!(d.contains("logs/injector.log"), "{d}");
        assert!(d.contains("| line 15\n") && d.contains("| line 7\n"), "{d}");
        assert!(!d.contains("line 6\n"), "10 lines only: {d}");
        assert!(d.contains(&format!("| {}...", "x".repeat(300))), "{d}");
        assert!(!d.contains(&"x".repeat(301)), "{d}");
        assert!(
            d.contains(&format!("contract v{}", platoon_wire::CONTRACT_VERSION)),
            "{d}"
        );
        // A built-in node, or a plug-in past step 0: no contract note.
        let later = died_detail(&dead(Node::Injector, Some(log.clone()), true), 5);
        assert!(!later.contains("contract") && later.contains("| line 15"));
        let builtin = died_detail(&dead(Node::Plant, Some(logs.join("plant.log")), false), 0);
        assert!(
            builtin.contains("it wrote nothing to logs/plant.log"),
            "{builtin}"
        );
        assert!(!builtin.contains("contract"), "{builtin}");
        assert_eq!(died_detail(&dead(Node::Plant, None, false), 3), "");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn plugins_get_the_bridge_first_on_their_python_path() {
        let bridge = std::path::Path::new("/b/bridge");
        let mut env = vec![("PYTHONPATH".to_string(), "/mine:/also".to_string())];
        assert_eq!(python_path(bridge, &env), "/b/bridge:/mine:/also");
        env[0].1 = String::new();
        assert_eq!(python_path(bridge, &env), "/b/bridge");
    }
}
