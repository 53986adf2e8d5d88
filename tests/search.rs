//! `platoon search` end to end, at small budgets: what it reports is admissible by the exact
//! checker, its worst schedule re-run with `platoon run` gives the reported harm exactly, the
//! same seed gives the same result (on the local pool and on a Dask cluster on 127.0.0.1), a
//! study per law and topology, and bad files.
use crate::common;

use common::{json, ok, platoon, repo};
use platoon_attacks::{Assumption2, DosSchedule};
use std::path::{Path, PathBuf};

const PAPER: Assumption2 = Assumption2 {
    T1: 2.0,
    T2: 9.46,
    D1: 6.0,
    D2: 11.33,
};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The jams of a schedule in search.json, as `(start, duration, target)`.
fn jams(schedule: &serde_json::Value) -> Vec<(f64, f64, String)> {
    schedule["jams"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| {
            let t = &j["target"];
            let target = match t["jam"].as_str().unwrap() {
                "channel" => "channel".to_string(),
                _ => format!("{}->{}", t["sender"], t["receiver"]),
            };
            (
                j["start_s"].as_f64().unwrap(),
                j["duration_s"].as_f64().unwrap(),
                target,
            )
        })
        .collect()
}

/// Whether the jams' activity satisfies the paper's Assumption 2 by the exact checker.
fn admissible(jams: &[(f64, f64, String)]) -> bool {
    let pairs: Vec<(f64, f64)> = jams.iter().map(|j| (j.0, j.1)).collect();
    PAPER
        .check(&DosSchedule::from_intervals(&pairs).unwrap(), 55.0)
        .holds
}

/// search.json without what differs between two runs of the same search (wall times, the
/// executor).
fn deterministic(mut v: serde_json::Value) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.remove("wall_s");
                m.remove("executor");
                m.values_mut().for_each(strip);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    strip(&mut v);
    v
}

/// Runs `platoon run worst.toml --transport inproc` and returns its summary.json.
fn rerun(worst: &Path, cwd: &Path) -> serde_json::Value {
    let out = cwd.join(format!(
        "rerun-{}",
        worst
            .parent()
            .unwrap()
            .file_name()
            .unwrap()
            .to_string_lossy()
    ));
    ok(&platoon(
        &[
            "run",
            worst.to_str().unwrap(),
            "--transport",
            "inproc",
            "--no-plots",
            "--force",
            "--out",
            out.to_str().unwrap(),
        ],
        cwd,
    ));
    json(&out.join("summary.json"))
}

/// The search's first generation: its seeds on the leader's manoeuvres and random members.
const POPULATION: usize = 24;

#[test]
fn the_search_beats_the_hand_made_jam_and_its_worst_schedule_reruns_exactly() {
    let tmp = tempfile::tempdir().unwrap();
    // Two generations of 24, then the pattern search around the best (refine = 0.5 starts it
    // after the second generation).
    let file = write(
        tmp.path(),
        "small.toml",
        "seed = 7\nevaluations = 64\ncompare = [\"random\"]\nreference = [[34.9, 6.5]]\n\
         [search]\npopulation = 24\nrefine = 0.5\n[random]\nseed = 2024\n",
    );
    let out = tmp.path().join("out");
    let o = platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-plots",
        ],
        tmp.path(),
    );
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("search") && stdout.contains("reference"),
        "{stdout}"
    );
    let s = json(&out.join("search.json"));
    assert_eq!(s["complete"], true);
    let p = &s["problems"][0];
    assert_eq!(p["reproduced"], true);
    let methods = p["methods"].as_array().unwrap();
    let names: Vec<&str> = methods
        .iter()
        .map(|m| m["method"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["search", "random"]);
    // Every schedule it reports is admissible by the exact checker, and says so.
    for m in methods {
        assert_eq!(m["evaluations"], 64, "{m}");
        let best = &m["best"];
        assert!(admissible(&jams(&best["schedule"])), "{best}");
        assert_eq!(best["certificate"]["holds"], true);
    }
    // The hand-made 6.5 s jam from 34.9 s over the braking ramp: 42.3 m and a collision. The
    // search does better, the random admissible schedules (the Monte Carlo campaign's) worse.
    let harm = |m: &serde_json::Value| m["best"]["harm"].as_f64().unwrap();
    let reference = p["reference"]["harm"].as_f64().unwrap();
    assert!((reference - 42.3).abs() < 0.05, "{reference}");
    assert_eq!(p["reference"]["class"], "severe");
    assert!(harm(&methods[0]) > reference, "{}", methods[0]);
    assert!(harm(&methods[1]) < 15.0, "{}", methods[1]);
    assert_eq!(p["worst_by"], "search");
    // It beats its own seeds too: one of them (the longest jam over the acceleration ramp)
    // already beats the hand-made jam, so the best must come after the first generation, and
    // be better than all of it.
    let mut rows = csv::Reader::from_path(out.join("evaluations.csv")).unwrap();
    let header = rows.headers().unwrap().clone();
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (method, harm_at) = (column("method"), column("harm"));
    let searched: Vec<(usize, f64)> = rows
        .records()
        .map(|r| r.unwrap())
        .filter(|r| &r[method] == "search")
        .map(|r| {
            (
                r[column("evaluation")].parse().unwrap(),
                r[harm_at].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(searched.len(), 64);
    let seeds = searched[..POPULATION]
        .iter()
        .map(|e| e.1)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(seeds > reference, "a seed beats the hand-made jam: {seeds}");
    assert!(harm(&methods[0]) > seeds, "{} <= {seeds}", methods[0]);
    assert!(methods[0]["best"]["evaluation"].as_u64().unwrap() > POPULATION as u64);
    // worst.toml, re-run with platoon run, gives the reported harm exactly.
    let summary = rerun(&out.join("worst.toml"), tmp.path());
    let rerun_harm = summary["vehicles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["spacing_error_m"]["max_abs"].as_f64().unwrap())
        .fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(rerun_harm, harm(&methods[0]));
    assert_eq!(summary["attack"]["assumption2"]["holds"], true);
    // A collision is in the summary exactly when it says so.
    assert_eq!(
        summary["safety"]["collided"].as_bool().unwrap(),
        summary["safety"]["first_collision_t_s"].is_f64()
    );
    assert!(out.join("worst/summary.json").is_file());
    // The convergence curve never goes down and ends at the best.
    let conv = std::fs::read_to_string(out.join("convergence.csv")).unwrap();
    let search: Vec<f64> = conv
        .lines()
        .filter(|l| l.starts_with("search,"))
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(search.len(), 64);
    assert!(search.windows(2).all(|w| w[1] >= w[0]));
    assert_eq!(*search.last().unwrap(), harm(&methods[0]));
    // The same seed gives the same result.
    let again = tmp.path().join("again");
    ok(&platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            again.to_str().unwrap(),
            "--no-plots",
            "--jobs",
            "1",
        ],
        tmp.path(),
    ));
    assert_eq!(
        deterministic(json(&again.join("search.json"))),
        deterministic(s.clone())
    );
    assert_eq!(
        std::fs::read_to_string(again.join("evaluations.csv")).unwrap(),
        std::fs::read_to_string(out.join("evaluations.csv")).unwrap()
    );
    // A finished directory is not overwritten without --force.
    let o = platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    );
    assert!(!o.status.success());
}

#[test]
fn collision_time_on_links_and_a_study_of_two_laws() {
    let tmp = tempfile::tempdir().unwrap();
    // The first collision as early as possible: a collision, during the worst jam.
    let file = write(
        tmp.path(),
        "collision.toml",
        "seed = 3\nevaluations = 24\nharm = \"first_collision_s\"\ncompare = []\n\
         [search]\npopulation = 12\n",
    );
    let out = tmp.path().join("collision");
    ok(&platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-plots",
        ],
        tmp.path(),
    ));
    let s = json(&out.join("search.json"));
    let p = &s["problems"][0];
    assert_eq!(s["minimised"], true);
    assert_eq!(p["reproduced"], true);
    let best = &p["methods"][0]["best"];
    let collision = best["harm"].as_f64().expect("a collision");
    let j = jams(&best["schedule"]);
    assert!(admissible(&j), "{best}");
    assert!(j.iter().any(|(a, _, _)| *a < collision), "{best}");
    let summary = rerun(&out.join("worst.toml"), tmp.path());
    assert_eq!(summary["safety"]["collided"], true);
    assert_eq!(
        summary["safety"]["first_collision_t_s"].as_f64(),
        Some(collision)
    );

    // One link at a time (the receivers not told), at most two jams.
    let file = write(
        tmp.path(),
        "links.toml",
        "seed = 3\nevaluations = 24\nharm = \"min_gap_m\"\ncompare = []\n\
         [budget]\njam = \"links\"\nmax_intervals = 2\n[search]\npopulation = 12\n",
    );
    let out = tmp.path().join("links");
    ok(&platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-plots",
        ],
        tmp.path(),
    ));
    let s = json(&out.join("search.json"));
    let p = &s["problems"][0];
    assert_eq!(p["methods"].as_array().unwrap().len(), 1);
    let best = &p["methods"][0]["best"];
    let j = jams(&best["schedule"]);
    assert!(!j.is_empty() && j.len() <= 2, "{best}");
    assert!(j.iter().all(|(_, _, t)| t != "channel"), "{best}");
    assert!(admissible(&j), "{best}");
    assert_eq!(p["reproduced"], true);
    let summary = rerun(&out.join("worst.toml"), tmp.path());
    assert_eq!(
        summary["safety"]["min_gap_m"].as_f64(),
        best["harm"].as_f64()
    );
    let config = std::fs::read_to_string(out.join("worst.toml")).unwrap();
    assert!(config.contains("kind = \"bernoulli\"") && config.contains("senders"));

    // A study: the paper's law and Ploeg's on PF, one directory each, and the tables.
    let file = write(
        tmp.path(),
        "study.toml",
        "evaluations = 12\ncompare = [\"grid\"]\n[search]\npopulation = 6\n\
         [study]\nlaws = [\"paper\", \"ploeg\"]\ntopologies = [\"pf\"]\n",
    );
    let out = tmp.path().join("study");
    ok(&platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-plots",
        ],
        tmp.path(),
    ));
    for label in ["paper-pf", "ploeg-pf"] {
        assert!(out.join(label).join("worst.toml").is_file(), "{label}");
        assert!(out.join(label).join("evaluations.csv").is_file(), "{label}");
    }
    let md = std::fs::read_to_string(out.join("study.md")).unwrap();
    assert!(
        md.contains("| paper-pf |") && md.contains("| ploeg-pf |"),
        "{md}"
    );
    let s = json(&out.join("search.json"));
    assert!(s["problems"]
        .as_array()
        .unwrap()
        .iter()
        .all(|p| p["reproduced"] == true));
}

#[test]
fn bad_search_files_are_refused_by_key_with_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    for (text, key) in [
        ("harm = \"speed\"\n", "harm"),
        ("[budget]\nmax_intervals = 0\n", "budget.max_intervals"),
        ("reference = [[30.0, 9.0]]\n", "reference"),
        ("typo = 1\n", "typo"),
    ] {
        let file = write(tmp.path(), "bad.toml", text);
        let out = tmp.path().join("bad");
        let o = platoon(
            &[
                "search",
                file.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            tmp.path(),
        );
        assert_eq!(o.status.code(), Some(2), "{text}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(key), "{text}: {err}");
        assert!(!out.exists() && !tmp.path().join("bad.partial").exists());
    }
}

#[test]
fn a_dask_cluster_on_localhost_gives_the_local_search() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(
        tmp.path(),
        "small.toml",
        "seed = 5\nevaluations = 24\ncompare = [\"random\"]\n[search]\npopulation = 12\n",
    );
    let local = tmp.path().join("local");
    ok(&platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            local.to_str().unwrap(),
            "--no-plots",
        ],
        tmp.path(),
    ));
    assert!(repo().join("bridge/setup-venv.sh").is_file());
    let cluster = platoon_app::campaign::LocalCluster::start(2, tmp.path()).unwrap();
    let remote = tmp.path().join("remote");
    ok(&platoon(
        &[
            "search",
            file.to_str().unwrap(),
            "--out",
            remote.to_str().unwrap(),
            "--no-plots",
            "--dask",
            &cluster.address,
        ],
        tmp.path(),
    ));
    drop(cluster);
    let r = json(&remote.join("search.json"));
    assert!(r["executor"]
        .as_str()
        .unwrap()
        .starts_with("dask tcp://127.0.0.1"));
    assert_eq!(
        deterministic(r),
        deterministic(json(&local.join("search.json")))
    );
    assert_eq!(
        std::fs::read_to_string(remote.join("evaluations.csv")).unwrap(),
        std::fs::read_to_string(local.join("evaluations.csv")).unwrap()
    );
}

#[test]
fn every_shipped_search_parses() {
    let mut seen = Vec::new();
    for entry in std::fs::read_dir(repo().join("campaigns")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if name.starts_with("worst-dos") {
            let s = platoon_app::search::load(&path, None).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(s.name, name);
            if let Some(total) = name.strip_prefix("worst-dos-budget-") {
                // A total jammed time on top of Assumption 2: the hand-made 6.5 s jam is over
                // it, so there is no reference.
                let total: f64 = total.parse().unwrap();
                assert_eq!(s.problems[0].budget.limits.max_jammed_s, Some(total));
                assert!(s.problems[0].budget.limits.assumption2.is_some());
                assert_eq!(s.spec.evaluations, 48, "{}", path.display());
            } else {
                assert_eq!(s.spec.evaluations, 1000, "{}", path.display());
                assert!(s.reference.is_some());
            }
            seen.push(name);
        }
    }
    seen.sort();
    assert_eq!(
        seen,
        [
            "worst-dos",
            "worst-dos-budget-2.7",
            "worst-dos-budget-2.9",
            "worst-dos-study"
        ]
    );
    let study =
        platoon_app::search::load(&repo().join("campaigns/worst-dos-study.toml"), None).unwrap();
    assert_eq!(study.problems.len(), 12);
}
