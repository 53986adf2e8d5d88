//! The two lanes of a platoon whose members change lanes (issue 51, "one road on both plants"):
//! a vehicle changes lanes only into a safe gap (`platoon_sim::lanes::LaneChangeRule`, the same
//! rule in the SUMO bridge), a member that left drives on its ACC on whatever is ahead on its
//! lane, and collisions and gaps count on both lanes. Two leaves in one run (followers 1 and 3,
//! the second changing beside the first) never collide, on either plant, and both plants report
//! the same lane changes at the precision docs/maneuvers.md publishes; a leave beside SUMO's
//! background traffic waits for a gap.
use crate::common;

use common::{json, published, repo, run_config};
use platoon_sim::{MetricsAccumulator, StepRow};
use std::path::Path;

/// configs/leave.toml with followers 1 (at 12 s) and 3 (at `second_s`) leaving. Follower 1
/// keeps the speed it left at (about 19 m/s) while the platoon speeds up to 25 m/s, so the
/// platoon passes it: follower 3 asking at 20 s finds it alongside.
fn two_leaves(second_s: f64) -> String {
    let text = std::fs::read_to_string(repo().join("configs/leave.toml")).unwrap();
    let base = &text[..text.find("[[maneuvers.leaves]]").unwrap()];
    base.replace("name = \"leave\"", "name = \"two-leaves\"")
        + &format!(
            "[[maneuvers.leaves]]\nvehicle = 1\nat_s = 12.0\n\n\
             [[maneuvers.leaves]]\nvehicle = 3\nat_s = {second_s:?}\n"
        )
}

/// A run's trajectories as (step, vehicle, p, beside) per row.
fn lanes_and_positions(run: &Path) -> Vec<(u64, u16, f64, bool)> {
    let mut csv = csv::Reader::from_path(run.join("trajectories.csv")).unwrap();
    csv.deserialize::<StepRow>()
        .map(|r| {
            let r = r.unwrap();
            (r.step, r.vehicle, r.p, r.beside.unwrap())
        })
        .collect()
}

/// `config` in process, on SUMO and (with `ipc`) over iceoryx2: neither plant sees a
/// collision on any lane, both make the same lane changes at the same steps, every position
/// agrees within what docs/maneuvers.md publishes (2e-10 m) and both transports give the same
/// bytes. The lane changes.
fn both_plants_change_lanes_alike(config: &str, ipc: bool) -> Vec<serde_json::Value> {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("two-leaves.toml");
    std::fs::write(&path, config).unwrap();
    let inproc = run_config(&path, "inproc", &["--transport", "inproc"], tmp.path());
    let sumo = run_config(&path, "sumo", &["--plant", "sumo"], tmp.path());
    if ipc {
        let ipc = run_config(&path, "ipc", &[], tmp.path());
        let traj = |run: &Path| std::fs::read(run.join("trajectories.csv")).unwrap();
        assert!(traj(&inproc) == traj(&ipc), "the transports differ");
    }
    let summaries: Vec<serde_json::Value> = [&inproc, &sumo]
        .iter()
        .map(|r| json(&r.join("summary.json")))
        .collect();
    for s in &summaries {
        assert_eq!(s["safety"]["collided"], false, "{}", s["safety"]);
        // The smallest gap on either lane is at least the rule's 2.5 m.
        assert!(
            s["safety"]["min_gap_m"].as_f64().unwrap() >= 2.5,
            "{}",
            s["safety"]
        );
    }
    let changes = &summaries[0]["maneuvers"]["lane_changes"];
    assert_eq!(changes, &summaries[1]["maneuvers"]["lane_changes"]);
    let changes = changes.as_array().unwrap().clone();
    assert!(changes
        .iter()
        .all(|c| c["to"] == "beside" && c["t_s"].is_number()));
    // SUMO saw no collision on any lane, moved the vehicles at the native steps, and every
    // position agrees with the native plant's.
    let report = json(&sumo.join("sumo.json"));
    assert_eq!(report["collisions"], serde_json::json!([]));
    let waited = |l: &[serde_json::Value]| -> Vec<f64> {
        l.iter().map(|c| c["waited_s"].as_f64().unwrap()).collect()
    };
    assert_eq!(
        waited(report["lane_changes"].as_array().unwrap()),
        waited(&changes)
    );
    let (a, b) = (lanes_and_positions(&inproc), lanes_and_positions(&sumo));
    assert_eq!(a.len(), b.len());
    let mut worst = 0.0f64;
    for (x, y) in a.iter().zip(&b) {
        assert_eq!((x.0, x.1, x.3), (y.0, y.1, y.3), "lanes differ");
        worst = worst.max((x.2 - y.2).abs());
    }
    assert!(worst < 2e-10, "positions differ by up to {worst} m");
    changes
}

/// Issue 51's two leaves (followers 1 at 12 s and 3 at 25 s): no collision on either plant,
/// which agree.
#[test]
fn two_leaves_never_collide_and_both_plants_agree() {
    let changes = both_plants_change_lanes_alike(&two_leaves(25.0), false);
    let who: Vec<u64> = changes
        .iter()
        .map(|c| c["vehicle"].as_u64().unwrap())
        .collect();
    assert_eq!(who, [1, 3]);
}

/// Follower 3 asks to leave with follower 1 alongside: it waits for a safe gap, on both plants
/// the same steps, and nobody collides.
#[test]
fn a_leaver_with_a_vehicle_alongside_waits_on_both_plants() {
    let changes = both_plants_change_lanes_alike(&two_leaves(20.0), true);
    assert_eq!(changes.len(), 2, "{changes:?}");
    assert_eq!(
        (
            changes[0]["vehicle"].as_u64(),
            changes[0]["waited_s"].as_f64()
        ),
        (Some(1), Some(0.0))
    );
    assert_eq!(changes[1]["vehicle"], 3);
    let waited = changes[1]["waited_s"].as_f64().unwrap();
    assert!(waited > 0.5, "{changes:?}");
    published(
        "docs/maneuvers.md",
        "follower 1 is alongside and follower 3 waits {} s for a safe gap",
        &[centiseconds(waited)],
    );
}

/// A time as docs/maneuvers.md prints it: to the hundredth, without trailing zeros.
fn centiseconds(s: f64) -> String {
    format!("{}", (s * 100.0).round() / 100.0)
}

/// Members leaving beside SUMO's background traffic (300 vehicles of SUMO's Krauss model,
/// seed 2, on the lanes the platoon does not use): each leaver finds a vehicle beside it and
/// waits for a safe gap before it changes, and nobody collides on any lane (SUMO's own
/// collision check, and the platoon's gaps).
#[test]
fn a_leave_beside_background_traffic_waits_for_a_gap() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/leave.toml")).unwrap();
    let config = tmp.path().join("busy.toml");
    std::fs::write(
        &config,
        text + "\n[sumo]\nbackground_vehicles = 300\nbackground_seed = 2\n",
    )
    .unwrap();
    let run = run_config(&config, "r", &["--plant", "sumo"], tmp.path());
    let report = json(&run.join("sumo.json"));
    assert_eq!(report["collisions"], serde_json::json!([]));
    let s = json(&run.join("summary.json"));
    assert_eq!(s["safety"]["collided"], false, "{}", s["safety"]);
    let changes = s["maneuvers"]["lane_changes"].as_array().unwrap().clone();
    let who: Vec<u64> = changes
        .iter()
        .map(|c| c["vehicle"].as_u64().unwrap())
        .collect();
    assert_eq!(who, [2, 5], "{changes:?}");
    for c in &changes {
        assert!(c["waited_s"].as_f64().unwrap() > 1.0, "{changes:?}");
        assert!(c["t_s"].is_number());
    }
    let waited: Vec<String> = changes
        .iter()
        .map(|c| centiseconds(c["waited_s"].as_f64().unwrap()))
        .collect();
    published(
        "docs/maneuvers.md",
        "follower 2 waits {} s for a gap and the tail {} s",
        &waited,
    );
    for m in s["maneuvers"]["maneuvers"].as_array().unwrap() {
        assert_eq!(m["outcome"], "completed", "{m}");
    }
}

/// The Python rule the SUMO bridge decides with (`platoon.sumo.model.LaneChangeRule`) says
/// what the Rust one says, on neighbours either side at every distance and closing speed
/// around the boundary.
#[test]
fn the_bridges_lane_change_rule_is_the_native_plants() {
    let rule = platoon_sim::lanes::LaneChangeRule::DEFAULT;
    let mut cases = Vec::new();
    for i in 0..400 {
        let x = f64::from(i);
        let me = [100.0, 20.0 + (x * 0.37) % 7.0, 4.5];
        let ahead = [
            100.0 + 2.0 + (x * 0.731) % 14.0 + 4.5,
            14.0 + (x * 1.3) % 12.0,
            4.5,
        ];
        let behind = [
            100.0 - 4.5 - (x * 0.53) % 15.0,
            16.0 + (x * 0.9) % 12.0,
            12.0,
        ];
        cases.push((me, vec![ahead, behind]));
    }
    let expected: Vec<f64> = cases
        .iter()
        .map(|(me, others)| f64::from(u8::from(rule.safe_among(*me, others.iter().copied()))))
        .collect();
    assert!(expected.contains(&0.0) && expected.contains(&1.0));
    let script = format!(
        r#"
import sys; sys.path.insert(0, {bridge:?})
import platoon.sumo.model as m
rule = m.LaneChangeRule({{"min_gap_m": {g:?}, "reaction_s": {r:?}, "safe_decel_mps2": {b:?}}})
for me, others in {cases:?}:
    print(1.0 if rule.safe_among(me, others) else 0.0)
"#,
        bridge = repo().join("bridge").display().to_string(),
        g = rule.min_gap_m,
        r = rule.reaction_s,
        b = rule.safe_decel_mps2,
        cases = cases
            .iter()
            .map(|(me, o)| (
                me.to_vec(),
                o.iter().map(|x| x.to_vec()).collect::<Vec<_>>()
            ))
            .collect::<Vec<_>>(),
    );
    assert_eq!(crate::sumo::python_floats(&script), expected);
}

/// The safety summary covers the lane beside: two members that left, one driving into the
/// other there, is a collision on that lane (and none on the platoon's), named as such.
#[test]
fn a_collision_on_the_lane_beside_is_counted_and_named() {
    let scenario = platoon_config::parse(&two_leaves(25.0), Path::new("two-leaves.toml"))
        .unwrap()
        .1;
    let mut m = MetricsAccumulator::new(&scenario);
    let row = |vehicle: u16, p: f64, beside: bool| StepRow {
        step: 100,
        t: 1.0,
        platoon: 0,
        vehicle,
        p,
        v: 20.0,
        a: 0.0,
        u: 0.0,
        theta: f64::NAN,
        spacing_error: 0.0,
        velocity_error: 0.0,
        triggered: false,
        under_attack: false,
        affected: false,
        mode: match beside {
            true => platoon_control::Status::new(
                platoon_control::Role::Left,
                platoon_control::Mode::Coop,
            ),
            false => platoon_control::Status::default(),
        },
        guard: false,
        saturated: false,
        revoked: false,
        intruder: None,
        radar_target: None,
        radar_gap_m: None,
        radar_closing_mps: None,
        head: None,
        beside: Some(beside),
    };
    // On the platoon's lane 15.5 m gaps; beside, follower 3 1 m into follower 1's rear.
    m.push(&[
        row(0, 0.0, false),
        row(1, -20.0, true),
        row(2, -20.0, false),
        row(3, -23.5, true),
        row(4, -40.0, false),
        row(5, -60.0, false),
    ]);
    let s = m.finish(Default::default());
    assert!(s.safety.collided);
    let c = s.safety.first_collision.unwrap();
    assert_eq!(
        (c.collider.as_str(), c.victim.as_str(), c.lane.as_str()),
        ("follower 3", "follower 1", "the lane beside the platoon's")
    );
    assert!((c.gap_m.unwrap() + 1.0).abs() < 1e-12);
}

/// A car that would cut in 1 m ahead of follower 3, 2 m/s slower (configs/cut-in.toml with
/// `gap_m = 1.0`), is too close for the lane-change rule (4 m needed at that closing speed): it
/// waits beside the platoon, falls back along it and cuts in ahead of follower 4 once that gap
/// is safe, on both plants at the same step; nobody collides, the summary's `cut_ins` says
/// where and after how long, SUMO's log the same, and the positions agree within what
/// docs/traffic.md publishes for cut-in.toml. Aggressive (`aggressive = true`), it cuts in at
/// once, 1 m ahead of follower 3, as before lanes.
#[test]
fn a_car_that_would_cut_in_too_close_waits_beside_for_a_safe_gap() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/cut-in.toml")).unwrap();
    let close = text
        .replace("duration_s = 70.0", "duration_s = 35.0")
        .replace("at_s = 20.0 ", "gap_m = 1.0\nat_s = 20.0 ");
    assert!(close.contains("gap_m = 1.0") && close.contains("duration_s = 35.0"));
    let path = tmp.path().join("close.toml");
    std::fs::write(&path, &close).unwrap();
    let inproc = run_config(&path, "inproc", &["--transport", "inproc"], tmp.path());
    let sumo = run_config(&path, "sumo", &["--plant", "sumo"], tmp.path());
    let cut_ins: Vec<serde_json::Value> = [&inproc, &sumo]
        .iter()
        .map(|r| {
            let s = json(&r.join("summary.json"));
            assert_eq!(s["safety"]["collided"], false, "{}", s["safety"]);
            s["cut_ins"].clone()
        })
        .collect();
    assert_eq!(cut_ins[0], cut_ins[1], "the plants differ");
    let car = &cut_ins[0][0];
    assert_eq!(car["ahead_of"], 4, "{car}");
    let waited = car["waited_s"].as_f64().unwrap();
    assert!(waited > 1.0, "{car}");
    let report = json(&sumo.join("sumo.json"));
    assert_eq!(report["collisions"], serde_json::json!([]));
    let log = &report["cut_ins"]["vehicles"]["cutin0"];
    assert_eq!(log["appeared_step"], 2000, "{log}");
    let entered = log["entered_step"].as_u64().unwrap();
    assert!(
        (entered as f64 * 0.01 - car["entered_t_s"].as_f64().unwrap()).abs() < 1e-9,
        "{log} {car}"
    );
    let positions = |run: &Path| -> Vec<f64> {
        let mut csv = csv::Reader::from_path(run.join("trajectories.csv")).unwrap();
        csv.deserialize::<StepRow>().map(|r| r.unwrap().p).collect()
    };
    let (a, b) = (positions(&inproc), positions(&sumo));
    assert_eq!(a.len(), b.len());
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(worst < 3.2e-3, "positions differ by up to {worst} m");
    published(
        "docs/traffic.md",
        "waits {} s beside the platoon and cuts in ahead of follower 4",
        &[centiseconds(waited)],
    );
    // The same car, aggressive: in at once, 1 m ahead of follower 3.
    let path = tmp.path().join("aggressive.toml");
    std::fs::write(
        &path,
        close.replace("gap_m = 1.0", "gap_m = 1.0\naggressive = true"),
    )
    .unwrap();
    let run = run_config(&path, "aggressive", &["--transport", "inproc"], tmp.path());
    let car = json(&run.join("summary.json"))["cut_ins"][0].clone();
    assert_eq!(
        (car["ahead_of"].as_u64(), car["waited_s"].as_f64()),
        (Some(3), Some(0.0)),
        "{car}"
    );
}

/// A joiner moves in only into a safe gap: configs/join-middle.toml's joiner starts beside the
/// platoon alongside follower 2. Asked at every step to move in while it speeds up past
/// follower 2 (2 m/s^2, the others holding their speed), the plant keeps it beside until the
/// rule finds the gap between followers 1 and 2 safe, and moves it at that very step.
#[test]
fn a_joiner_alongside_a_member_waits_to_move_in() {
    let text = std::fs::read_to_string(repo().join("configs/join-middle.toml")).unwrap();
    let scenario = platoon_config::parse(&text, Path::new("join-middle.toml"))
        .unwrap()
        .1;
    let rule = platoon_sim::lanes::LaneChangeRule::DEFAULT;
    let mut plant = platoon_sim::Plant::new(&scenario);
    let (joiner, length) = (4, 4.5);
    assert!(plant.beside(joiner));
    let mut u = vec![0.0; scenario.topology.followers()];
    u[joiner - 1] = 2.0;
    let mut moved = None;
    for k in 0..500u64 {
        let x = plant.states().to_vec();
        let me = [x[joiner][0], x[joiner][1], length];
        let safe = rule.safe_among(me, (0..4).map(|j| [x[j][0], x[j][1], length]));
        plant.change_lanes(|_| false);
        assert_eq!(!plant.beside(joiner), safe, "step {k}: {x:?}");
        if safe {
            moved = Some(k);
            break;
        }
        plant.advance(k, &u, |_| false);
    }
    // Not at once (it was alongside), but within the 5 s.
    let moved = moved.expect("the joiner never found a safe gap");
    assert!(moved > 100, "{moved}");
}
