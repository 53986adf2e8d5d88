//! What the end-to-end test files share: the repository, the `platoon` binary, and readers.
#![allow(dead_code)] // each test file uses its own subset
use std::path::{Path, PathBuf};

pub mod maneuvers;
pub mod signed;
use std::collections::HashMap;
use std::process::{Command, Output};
use std::sync::Mutex;
use std::thread::JoinHandle;

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// The `platoon` binary, run in `cwd`. The tests run many co-simulations at once on two cores:
/// a generous step timeout keeps a starved (not stalled) process from being reported; the stall
/// test passes its own `--step-timeout`, which wins.
pub fn platoon_command(cwd: &Path) -> Command {
    head_start();
    let mut c = Command::new(env!("CARGO_BIN_EXE_platoon"));
    c.current_dir(cwd).env("PLATOON_STEP_TIMEOUT", "20");
    c
}

/// How long a test waits for something that only a hang would keep from happening (a poll's
/// deadline, never a budget: what is awaited comes much sooner on any machine).
pub const PATIENCE: std::time::Duration = std::time::Duration::from_secs(120);

/// Polls `done` until it holds, failing after [`PATIENCE`] with what was awaited.
pub fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = std::time::Instant::now() + PATIENCE;
    while !done() {
        assert!(
            std::time::Instant::now() < deadline,
            "waited {PATIENCE:?} for {what}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// Runs `platoon args` in `cwd` to completion.
pub fn platoon(args: &[&str], cwd: &Path) -> Output {
    platoon_command(cwd).args(args).output().unwrap()
}

/// Runs `platoon run CONFIG --out OUT --no-plots EXTRA...` in `cwd` to completion, failing the
/// test with its stderr if it fails: the run directory.
pub fn run_config(config: &Path, out: &str, extra: &[&str], cwd: &Path) -> PathBuf {
    let c = config.to_str().unwrap();
    let mut args = vec!["run", c, "--out", out, "--no-plots"];
    args.extend_from_slice(extra);
    ok(&platoon(&args, cwd));
    cwd.join(out)
}

/// `platoon design check-gain --out d` of the paper's K (the embedded paper config), run once
/// for every test that reads it: `cli::` checks what the command prints, exits with and writes,
/// `figures::design` the figures docs/design.md quotes from its check.json. Its three
/// bisections of LMI (13) take tens of seconds; each test ran them again. The run's output and
/// its working directory (`d` in it holds what it wrote; tests write only elsewhere).
pub fn papers_gain_checked() -> &'static (Output, PathBuf) {
    static RUN: std::sync::OnceLock<(Output, PathBuf)> = std::sync::OnceLock::new();
    RUN.get_or_init(|| {
        let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR"))
            .unwrap()
            .keep();
        (platoon(&["design", "check-gain", "--out", "d"], &dir), dir)
    })
}

/// Tests that spend most of their time waiting out a timeout (idle: a test thread sat through
/// each) run their bodies side by side: the first test of the group to call [`Together::run`]
/// starts every body of the group, each in a thread of its own, and each test then waits for
/// its own body, whose failure is the test's (with its message). The timeouts stay what a
/// loaded machine needs; the suite waits them out once per group, not once per test.
pub struct Together {
    bodies: &'static [(&'static str, fn())],
    started: std::sync::OnceLock<Mutex<HashMap<&'static str, JoinHandle<()>>>>,
}

impl Together {
    pub const fn new(bodies: &'static [(&'static str, fn())]) -> Self {
        Self {
            bodies,
            started: std::sync::OnceLock::new(),
        }
    }

    /// Starts every body of the group, each in a thread of its own, unless they started.
    fn start(&self) -> &Mutex<HashMap<&'static str, JoinHandle<()>>> {
        self.started.get_or_init(|| {
            let threads = self.bodies.iter().map(|&(name, body)| {
                let thread = std::thread::Builder::new().name(name.to_string());
                (name, thread.spawn(body).unwrap())
            });
            Mutex::new(threads.collect())
        })
    }

    /// Runs the body `name` (started with the group's others if none has started yet) to its
    /// end, failing with its message if it failed.
    pub fn run(&self, name: &str) {
        let started = self.start();
        let body = started
            .lock()
            .unwrap()
            .remove(name)
            .unwrap_or_else(|| panic!("{name} is no body of this group, or it ran already"));
        if let Err(panic) = body.join() {
            let message = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)");
            panic!("{name} failed: {message}");
        }
    }
}

/// The suite's tests that wait out a 20 s step or ready timeout (tests/controller.rs's
/// faulty controllers, tests/cosim.rs's stalled injectors), run side by side: the first to run
/// starts them all (in a whole run, the first `platoon` process: [`head_start`]), so the suite
/// waits the 20 s out once instead of once per module. Each
/// body idles, its processes asleep or polling, so the group adds no load worth the name.
pub static TIMEOUTS: Together = Together::new(&[
    (
        "controller hangs",
        crate::controller::a_controller_that_hangs,
    ),
    (
        "controller repeats",
        crate::controller::a_controller_repeating_one_step,
    ),
    (
        "controller never ready",
        crate::controller::a_plugin_that_never_reports_ready,
    ),
    (
        "injector stops",
        crate::cosim::an_injector_that_stops_publishing,
    ),
    (
        "injector repeats",
        crate::cosim::an_injector_repeating_one_step,
    ),
]);

/// In a run of the whole binary (no test named on its command line, not nextest's process per
/// test), [`TIMEOUTS`] starts with the first `platoon` process a test starts. Left to its
/// tests, the group started when the first of them ran, and the next of them, adjacent in
/// libtest's order, held the second test thread: both waited out the same 20 s with the
/// machine idle. Started at the beginning, its bodies wait while the other tests run, and its
/// tests find them done.
fn head_start() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        if std::env::var_os("NEXTEST").is_none() && !names_tests(std::env::args().skip(1)) {
            TIMEOUTS.start();
        }
    });
}

/// Whether libtest's arguments name tests to run (a filter, `--exact` or not), rather than the
/// whole binary: any argument that is no option nor an option's value.
fn names_tests(mut args: impl Iterator<Item = String>) -> bool {
    const WITH_VALUE: [&str; 7] = [
        "--test-threads",
        "--skip",
        "--format",
        "--color",
        "--logfile",
        "--shuffle-seed",
        "-Z",
    ];
    while let Some(a) = args.next() {
        if WITH_VALUE.contains(&a.as_str()) {
            args.next();
        } else if !a.starts_with('-') {
            return true;
        }
    }
    false
}

#[test]
fn a_filter_names_tests_and_options_do_not() {
    let names = |args: &[&str]| names_tests(args.iter().map(|a| a.to_string()));
    assert!(!names(&[]));
    assert!(!names(&["--test-threads", "2", "-q", "--nocapture"]));
    assert!(!names(&[
        "--test-threads=2",
        "--skip",
        "sumo::",
        "--color",
        "never"
    ]));
    assert!(names(&["sumo::"]));
    assert!(names(&["--exact", "cli::run_writes_every_output"]));
    assert!(names(&["--test-threads", "1", "controller::"]));
}

/// Fails the test with platoon's stderr if it did not succeed.
pub fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "platoon failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A JSON file.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Pins a figure the docs publish to what a test computed: `doc` (a path from the repository
/// root) must hold `template` with each `{}` replaced by the next of `values`, formatted to the
/// digits the doc prints. A figure that drifts (the code computes another value, or someone
/// edits the doc) fails here, quoting the doc's lines that hold the template's longest fixed
/// part, so the doc or the code can be put right.
pub fn published(doc: &str, template: &str, values: &[String]) {
    let pieces: Vec<&str> = template.split("{}").collect();
    assert_eq!(
        pieces.len(),
        values.len() + 1,
        "{template:?} has {} placeholders for {} values",
        pieces.len() - 1,
        values.len()
    );
    let mut expected = pieces[0].to_string();
    for (value, piece) in values.iter().zip(&pieces[1..]) {
        expected += value;
        expected += piece;
    }
    let text = std::fs::read_to_string(repo().join(doc))
        .unwrap_or_else(|e| panic!("cannot read {doc}: {e}"));
    // A Markdown paragraph may wrap anywhere: compare with runs of whitespace as one space.
    let squash = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    let (text_s, expected_s) = (squash(&text), squash(&expected));
    // A match must not be part of a longer number or word: "5 % fewer" is not in "15 % fewer",
    // nor "0.86" in "0.864".
    let bounded = |at: usize| {
        let before = text_s[..at].chars().next_back();
        let mut after = text_s[at + expected_s.len()..].chars();
        let starts = expected_s
            .chars()
            .next()
            .is_some_and(|c| c.is_alphanumeric());
        let ends = expected_s
            .chars()
            .next_back()
            .is_some_and(|c| c.is_alphanumeric());
        let glued_before = before.is_some_and(|c| c.is_alphanumeric() || c == '.' || c == '-');
        let glued_after = match after.next() {
            Some(c) if c.is_alphanumeric() => true,
            Some('.') => after.next().is_some_and(|c| c.is_ascii_digit()),
            _ => false,
        };
        !((starts && glued_before) || (ends && glued_after))
    };
    if text_s.match_indices(&expected_s).any(|(at, _)| bounded(at)) {
        return;
    }
    let anchor = pieces
        .iter()
        .map(|p| p.trim())
        .max_by_key(|p| p.len())
        .unwrap_or("");
    let near: Vec<String> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !anchor.is_empty() && l.contains(anchor))
        .map(|(i, l)| format!("  {doc}:{}: {l}", i + 1))
        .collect();
    panic!(
        "{doc} does not publish what the test computed:\n  expected: {expected}\n{}",
        if near.is_empty() {
            format!("  and no line holds {anchor:?}")
        } else {
            format!("  it says:\n{}", near.join("\n"))
        }
    );
}

/// Splits `line` into its text with every number as `#`, and the numbers.
fn skeleton(line: &str) -> (String, Vec<f64>) {
    let (mut text, mut numbers, mut number) = (String::new(), Vec::new(), String::new());
    for c in line.trim().chars().chain(std::iter::once(' ')) {
        if c.is_ascii_digit() || (c == '.' && !number.is_empty()) {
            number.push(c);
            continue;
        }
        if !number.is_empty() {
            let trailing_dot = number.ends_with('.');
            numbers.push(number.trim_end_matches('.').parse().unwrap());
            text.push('#');
            if trailing_dot {
                text.push('.');
            }
            number.clear();
        }
        text.push(c);
    }
    (text.trim_end().to_string(), numbers)
}

/// [`published`] for lines of figures that are solver results, whose last digits move with
/// the machine (the SDP's with the BLAS build): each line of `expected` must stand in `doc`
/// with the same words and every number within `rel` of the computed one, or, from 100 up,
/// one unit of the last digit printed (a rounding boundary crossed).
pub fn published_close(doc: &str, expected: &str, rel: f64) {
    let text = std::fs::read_to_string(repo().join(doc))
        .unwrap_or_else(|e| panic!("cannot read {doc}: {e}"));
    let lines: Vec<(String, Vec<f64>)> = text.lines().map(skeleton).collect();
    for want in expected.lines().filter(|l| !l.trim().is_empty()) {
        let (shape, numbers) = skeleton(want);
        let close = |got: &[f64]| {
            got.len() == numbers.len()
                && got.iter().zip(&numbers).all(|(a, b)| {
                    let x = a.abs().max(b.abs());
                    // A unit of the last digit for the large figures only: labels (N = 4)
                    // and small counts stay exact.
                    (a - b).abs()
                        <= if x >= 100.0 {
                            (rel * x).max(1.0)
                        } else {
                            rel * x
                        }
                })
        };
        let same_shape: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].0 == shape).collect();
        if same_shape.iter().any(|&i| close(&lines[i].1)) {
            continue;
        }
        let near: Vec<String> = same_shape
            .iter()
            .map(|&i| format!("  {doc}:{}: {}", i + 1, text.lines().nth(i).unwrap()))
            .collect();
        panic!(
            "{doc} does not publish what the test computed (within {rel} or a unit of the last \
             digit):\n  expected: {want}\n{}",
            if near.is_empty() {
                "  and no line has its words".to_string()
            } else {
                format!("  it says:\n{}", near.join("\n"))
            }
        );
    }
}

/// `configs/cut-in.toml` with `law` (and the keys it needs) in place of the paper's law.
pub fn cut_in_config(law: &str) -> String {
    let text = std::fs::read_to_string(repo().join("configs/cut-in.toml")).unwrap();
    if law == "paper" {
        return text;
    }
    let body = without_paper_law_keys(&text);
    // Each law keeps the platoon's 20 m front to front (15.5 m between 4.5 m cars) at
    // standstill, plus its own time headway, on the config's cars and guard; laws that need the
    // leader get it (plf); those that read the leader's packets split the platoon behind the
    // car (docs/traffic.md).
    let (keys, headway, leader, split) = match law {
        "acc" => ("standstill_m = 15.5", Some(1.5), false, false),
        "ploeg" => ("standstill_m = 15.5", Some(0.5), false, false),
        "path_cacc" => ("spacing_m = 15.5", None, true, true),
        "consensus" => ("standstill_m = 15.5", Some(0.8), true, false),
        "flatbed" => ("spacing_m = 15.5", None, true, true),
        other => panic!("no cut-in config for {other}"),
    };
    let mut c = body
        .replacen(
            "[control]",
            &format!("[control]\nlaw = \"{law}\"\n{keys}"),
            1,
        )
        .replacen(
            "rule = \"dynamic\"",
            "rule = \"periodic\"\nperiod_s = 0.1",
            1,
        );
    if let Some(h) = headway {
        c = c.replacen(
            "vehicle_length_m = 4.5",
            &format!(
                "vehicle_length_m = 4.5\nspacing_policy = \"time_headway\"\ntime_headway_s = {h}"
            ),
            1,
        );
    }
    if leader {
        c = c.replacen("preset = \"pf\"", "preset = \"plf\"", 1);
    }
    if split {
        c = c.replacen(
            "cut_in = { dwell_s = 1.0, blend_s = 3.0 }",
            "cut_in = { dwell_s = 1.0, blend_s = 3.0, split = true }",
            1,
        );
    }
    c
}

/// A shipped config's text with its guard off (`[guard] enabled = true` made false).
pub fn without_guard(text: &str) -> String {
    let on = "[guard]\nenabled = true";
    assert!(text.contains(on), "no guard to switch off");
    text.replacen(on, "[guard]\nenabled = false", 1)
}

/// A shipped config's text on the paper's ideal vehicle: without its `members = "car"` and
/// its `[vehicle_classes.car]` table (docs/traffic.md#vehicles-with-limits).
pub fn without_cars(text: &str) -> String {
    let (start, members) = (text.find("[vehicle_classes.car]"), "members = \"car\"");
    let start = start.expect("no [vehicle_classes.car]");
    let end = start
        + text[start..]
            .find("\n\n")
            .expect("a blank line after the class");
    let text = format!("{}{}", &text[..start], &text[end + 2..]);
    assert!(text.contains(members), "no members = \"car\"");
    text.lines()
        .filter(|l| !l.starts_with(members))
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

/// A config's text without the paper's law keys and trigger weights, which another law refuses.
pub fn without_paper_law_keys(text: &str) -> String {
    text.lines()
        .filter(|l| {
            !["phi", "rho", "eta", "theta0", "gain", "beta1", "beta2"]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .collect::<Vec<_>>()
        .join("\n")
}
