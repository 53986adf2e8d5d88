//! `platoon`'s join in the middle beside Plexe's own, both in SUMO: Plexe's rules (its Python
//! API's join example) replayed on SUMO's CC model by bridge/tools/plexe_join.py, and
//! `configs/join-plexe.toml` (the example's platoon and start) run with SUMO as the plant.
//! Both end in the same formation; the figures docs/maneuvers.md publishes side by side are
//! the ones measured here.
use crate::common;

use common::{json, ok, platoon, published, repo};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

/// The platoon's gap (m, bumper to bumper) and the cars' length (m).
const GAP: f64 = 5.0;
const LENGTH: f64 = 4.0;
/// The joiner, numbered after the 7 followers, and the follower it joins behind.
const JOINER: u16 = 8;
const FRONT: u16 = 2;

/// One step of a run: each vehicle's (number, position) on the platoon's lane, and whether
/// everyone is on it.
struct Step {
    t: f64,
    on_lane: Vec<(u16, f64)>,
    everyone: bool,
}

/// What the side-by-side compares.
#[derive(Debug)]
struct Figures {
    /// From the request to the joiner's lane change into the platoon's lane (s).
    lane_change_s: f64,
    /// From the request until every gap on the lane stays within 0.5 m of the platoon's (s).
    settled_s: f64,
    /// The smallest gap on the platoon's lane from the request on (m).
    min_gap_m: f64,
    /// The order on the lane at the end, the front first.
    order: Vec<u16>,
}

fn figures(steps: &[Step], asked: f64, lane_change: f64) -> Figures {
    let gaps = |s: &Step| -> Vec<f64> {
        s.on_lane
            .windows(2)
            .map(|w| w[0].1 - w[1].1 - LENGTH)
            .collect()
    };
    let min_gap_m = steps
        .iter()
        .filter(|s| s.t >= asked)
        .flat_map(gaps)
        .fold(f64::INFINITY, f64::min);
    let unsettled = steps
        .iter()
        .rposition(|s| !s.everyone || gaps(s).iter().any(|g| (g - GAP).abs() > 0.5))
        .expect("unsettled at the start");
    assert!(unsettled + 1 < steps.len(), "never settled");
    let last = steps.last().unwrap();
    Figures {
        lane_change_s: lane_change - asked,
        settled_s: steps[unsettled + 1].t - asked,
        min_gap_m,
        order: last.on_lane.iter().map(|&(v, _)| v).collect(),
    }
}

/// Steps from `rows` of (t, vehicle, on the platoon's lane, position).
fn steps(rows: impl Iterator<Item = (f64, u16, bool, f64)>) -> Vec<Step> {
    let mut by: BTreeMap<u64, Step> = BTreeMap::new();
    for (t, v, on, p) in rows {
        let s = by.entry((t * 1000.0).round() as u64).or_insert(Step {
            t,
            on_lane: Vec::new(),
            everyone: true,
        });
        if on {
            s.on_lane.push((v, p));
        } else {
            s.everyone = false;
        }
    }
    let mut steps: Vec<Step> = by.into_values().collect();
    for s in &mut steps {
        s.on_lane.sort_by(|a, b| b.1.total_cmp(&a.1));
    }
    steps
}

fn csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn column(header: &[String], name: &str) -> usize {
    header.iter().position(|h| h == name).unwrap()
}

#[test]
fn a_middle_join_beside_plexes_in_sumo() {
    let tmp = tempfile::tempdir().unwrap();
    // Plexe's rules, on the long highway (its joiner takes 150 s to settle at 120 km/h).
    let reference = tmp.path().join("plexe.csv");
    let o = Command::new(repo().join("bridge/.venv/bin/python"))
        .arg(repo().join("bridge/tools/plexe_join.py"))
        .arg("--out")
        .arg(&reference)
        .args(["--duration", "150"])
        .arg("--net")
        .arg(repo().join("sumo/highway-long/highway-long.net.xml"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "plexe_join.py: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let (header, rows) = csv(&reference);
    let (t, v, lane, p, phase) = (
        column(&header, "t"),
        column(&header, "vehicle"),
        column(&header, "lane"),
        column(&header, "p"),
        column(&header, "phase"),
    );
    let first = |f: &dyn Fn(&Vec<String>) -> bool| -> f64 {
        rows.iter()
            .find(|r| f(r))
            .map(|r| r[t].parse().unwrap())
            .unwrap()
    };
    // The example starts the approach at 1 s (the step's row after it says so).
    let asked = first(&|r| r[phase] != "waiting") - 0.01;
    let moved = first(&|r| r[v] == JOINER.to_string() && r[lane] == "0");
    let completed = first(&|r| r[phase] == "completed");
    assert!(completed <= moved, "{completed} {moved}");
    let plexe = figures(
        &steps(rows.iter().map(|r| {
            (
                r[t].parse().unwrap(),
                r[v].parse().unwrap(),
                r[lane] == "0",
                r[p].parse().unwrap(),
            )
        })),
        asked,
        moved,
    );

    // `platoon` on the same start, SUMO the plant.
    let config = repo().join("configs/join-plexe.toml");
    let args = [
        "run",
        config.to_str().unwrap(),
        "--plant",
        "sumo",
        "--no-plots",
        "--out",
        "ours",
    ];
    ok(&platoon(&args, tmp.path()));
    let ours_dir = tmp.path().join("ours");
    let summary = json(&ours_dir.join("summary.json"));
    assert_eq!(summary["safety"]["collided"], false);
    let join = &summary["maneuvers"]["maneuvers"][0];
    assert_eq!(join["outcome"], "completed", "{join}");
    let asked_ours = join["requested_t_s"].as_f64().unwrap();
    let changes = json(&ours_dir.join("sumo.json"))["lane_changes"].clone();
    let [change] = changes.as_array().unwrap().as_slice() else {
        panic!("one lane change: {changes}")
    };
    assert_eq!(change["vehicle"], format!("follower{JOINER}"));
    let (header, rows) = csv(&ours_dir.join("trajectories.csv"));
    let (t, v, p, mode) = (
        column(&header, "t"),
        column(&header, "vehicle"),
        column(&header, "p"),
        column(&header, "mode"),
    );
    let ours = figures(
        &steps(rows.iter().map(|r| {
            (
                r[t].parse().unwrap(),
                r[v].parse().unwrap(),
                r[mode] != "beside",
                r[p].parse().unwrap(),
            )
        })),
        asked_ours,
        change["t"].as_f64().unwrap(),
    );

    // The same formation: the joiner behind follower 2, everyone in order on the lane.
    let want: Vec<u16> = (0..=FRONT)
        .chain([JOINER])
        .chain(FRONT + 1..JOINER)
        .collect();
    assert_eq!(plexe.order, want, "Plexe's: {plexe:?}");
    assert_eq!(ours.order, want, "ours: {ours:?}");
    let row = |name: &str, a: f64, b: f64| {
        published(
            "docs/maneuvers.md",
            &format!("| {name} | {{}} | {{}} |"),
            &[format!("{a:.2}"), format!("{b:.2}")],
        )
    };
    row(
        "from the request to the lane change (s)",
        plexe.lane_change_s,
        ours.lane_change_s,
    );
    row(
        "from the request until every gap stays within 0.5 m of 5 m (s)",
        plexe.settled_s,
        ours.settled_s,
    );
    row(
        "smallest gap on the platoon's lane from the request on (m)",
        plexe.min_gap_m,
        ours.min_gap_m,
    );
}
