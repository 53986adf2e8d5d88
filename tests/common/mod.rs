//! What the end-to-end test files share: the repository, the `platoon` binary, and readers.
#![allow(dead_code)] // each test file uses its own subset
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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
    let mut c = Command::new(env!("CARGO_BIN_EXE_platoon"));
    c.current_dir(cwd).env("PLATOON_STEP_TIMEOUT", "20");
    c
}

/// Runs `platoon args` in `cwd` to completion.
pub fn platoon(args: &[&str], cwd: &Path) -> Output {
    platoon_command(cwd).args(args).output().unwrap()
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
