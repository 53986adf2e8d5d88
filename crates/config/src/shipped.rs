//! Every shipped config (`configs/*.toml`) resolves to the scenario and the resolved config it
//! resolved to when this test was written: a change to resolution that changes a shipped run
//! fails here. `shipped/<name>.txt` holds the scenario's `Debug` rendering and the resolved
//! config's TOML; `PLATOON_BLESS=1 cargo test -p platoon-config --lib shipped` rewrites them,
//! for a change meant to change a shipped scenario (the diff then shows how). The published JSON
//! Schema accepts every shipped config and refuses what the loader refuses.
use crate::reference::json_schema;
use crate::tagged::fits;
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

/// The shipped configs and the fuzz corpus's (whose `bad-*.toml` the loader refuses):
/// `(file, text)`.
fn shipped() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut out = Vec::new();
    for dir in ["configs", "fuzz/corpus/config"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                out.push((
                    p.display().to_string(),
                    std::fs::read_to_string(&p).unwrap(),
                ));
            }
        }
    }
    assert!(out.len() >= 10, "{out:?}");
    out
}

/// Editors must not flag a file the loader accepts, nor its resolved config.
#[test]
fn the_published_schema_accepts_every_shipped_config_and_its_resolved_form() {
    let schema = json_schema();
    for (name, text) in shipped() {
        if Path::new(&name)
            .file_name()
            .is_some_and(|f| f.to_string_lossy().starts_with("bad-"))
        {
            // The fuzz corpus's scenarios that cannot happen: the loader refuses them.
            assert!(crate::parse(&text, Path::new(&name)).is_err(), "{name}");
            continue;
        }
        let value: toml::Value = toml::from_str(&text).unwrap();
        assert!(fits(&schema, &schema, &value, 0), "{name}");
        let (config, _) = crate::parse(&text, Path::new(&name)).unwrap();
        let resolved: toml::Value = toml::from_str(&crate::to_toml(&config)).unwrap();
        assert!(fits(&schema, &schema, &resolved, 0), "{name}, resolved");
    }
}

/// ...and flags the keys of another rule or kind, unknown keys and unknown values.
#[test]
fn the_published_schema_refuses_what_the_loader_refuses() {
    let schema = json_schema();
    let paper = crate::PAPER_TOML;
    for (from, to) in [
        ("phi = 0.33", "phi = 0.33\nmu = 1.0"),
        ("phi = 0.33\n", ""),
        ("h_s = 0.02", "h_s = 0.02\nhh = 1"),
        ("rule = \"dynamic\"", "rule = \"dymanic\""),
        ("preset = \"tpsf\"", "preset = \"tpsf\"\npinning = [1.0]"),
        ("spacing_m = 10.0", "spacing_m = 10.0\ntime_headway_s = 0.5"),
        ("kind = \"intervals\"", "kind = \"intervals\"\nseed = 3"),
        ("dt_s = 0.01", "dt_s = 0.01\nplant = \"unity\""),
    ] {
        assert!(paper.contains(from), "{from}");
        let text = paper.replacen(from, to, 1);
        assert!(crate::parse(&text, Path::new("bad.toml")).is_err(), "{to}");
        let value: toml::Value = toml::from_str(&text).unwrap();
        assert!(
            !fits(&schema, &schema, &value, 0),
            "{to:?} passes the schema"
        );
    }
    let link = format!("{paper}\n[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.1\n");
    let value: toml::Value = toml::from_str(&link).unwrap();
    assert!(fits(&schema, &schema, &value, 0));
    let value: toml::Value = toml::from_str(&format!("{link}lag_s = 0.1\n")).unwrap();
    assert!(!fits(&schema, &schema, &value, 0));
}
