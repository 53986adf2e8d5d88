//! Every shipped config (`configs/*.toml`) resolves to the scenario and the resolved config it
//! resolved to when this test was written: a change to resolution that changes a shipped run
//! fails here. `shipped/<name>.txt` holds the scenario's `Debug` rendering and the resolved
//! config's TOML; `PLATOON_BLESS=1 cargo test -p platoon-config --lib shipped` rewrites them,
//! for a change meant to change a shipped scenario (the diff then shows how).
use std::path::{Path, PathBuf};

fn configs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}

fn snapshots_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src/shipped")
}

/// What a shipped config resolves to, as text: the scenario, then the resolved config.
fn rendering(path: &Path) -> String {
    let (config, scenario) = crate::load(path).unwrap_or_else(|e| panic!("{e}"));
    format!(
        "# scenario\n{scenario:#?}\n# resolved config\n{}",
        crate::to_toml(&config)
    )
}

#[test]
fn every_shipped_config_resolves_as_recorded() {
    let bless = std::env::var_os("PLATOON_BLESS").is_some();
    let mut names = Vec::new();
    for entry in std::fs::read_dir(configs_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            names.push(path);
        }
    }
    names.sort();
    assert!(!names.is_empty());
    let mut changed = Vec::new();
    for path in names {
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let snapshot = snapshots_dir().join(format!("{stem}.txt"));
        let now = rendering(&path);
        if bless {
            std::fs::write(&snapshot, &now).unwrap();
            continue;
        }
        let recorded = std::fs::read_to_string(&snapshot).unwrap_or_default();
        if recorded != now {
            let line = recorded
                .lines()
                .zip(now.lines())
                .position(|(a, b)| a != b)
                .map_or(0, |l| l + 1);
            changed.push(format!("{stem} (first difference at line {line})"));
        }
    }
    assert!(
        changed.is_empty(),
        "shipped configs resolve differently from src/shipped/*.txt: {}",
        changed.join(", ")
    );
}
