//! Traffic that touches the platoon, in process (the pure core): a scripted cut-in between
//! followers 2 and 3 (`configs/cut-in.toml`) seen by follower 3's radar, handled by each law
//! through the controller seam (ACC on the intruder, then back to the law), and the errors a
//! bad `[[cut_ins]]` gets.
mod common;

use common::repo;
use platoon_config::parse;
use platoon_control::Mode;
use platoon_sim::{Scenario, Simulation, StepRow};
use std::path::Path;

/// `configs/cut-in.toml` with `law` (and the keys it needs) in place of the paper's law.
fn cut_in_config(law: &str) -> String {
    let text = std::fs::read_to_string(repo().join("configs/cut-in.toml")).unwrap();
    if law == "paper" {
        return text;
    }
    // The paper's law keys and trigger weights: another law refuses them.
    let body: Vec<&str> = text
        .lines()
        .filter(|l| {
            !["phi", "rho", "eta", "theta0", "gain", "beta1", "beta2"]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .collect();
    // Each law keeps the platoon's 20 m front to front (15.5 m between 4.5 m cars) at
    // standstill, plus its own time headway; laws that need the leader get it (plf), and the
    // guard, since the followers behind the cut-in still track the leader.
    let (keys, headway, leader) = match law {
        "acc" => ("standstill_m = 15.5", Some(1.5), false),
        "ploeg" => ("standstill_m = 15.5", Some(0.5), false),
        "path_cacc" => ("spacing_m = 15.5", None, true),
        "consensus" => ("standstill_m = 15.5", Some(0.8), true),
        other => panic!("no cut-in config for {other}"),
    };
    let mut c = body
        .join("\n")
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
        c = c.replacen("preset = \"pf\"", "preset = \"plf\"", 1) + "\n[guard]\nenabled = true\n";
    }
    c
}

fn scenario(text: &str) -> Scenario {
    parse(text, Path::new("cut-in.toml")).unwrap().1
}

/// Runs `s` in process: every row, and the smallest gap follower 3's radar had to the
/// intruder while it was ahead of it (from the plant's own view of the lane).
fn run(s: Scenario) -> (Vec<StepRow>, platoon_sim::Summary, f64) {
    let (mut rows, mut truth, mut smallest) = (Vec::new(), Vec::new(), f64::INFINITY);
    let summary = platoon_sim::run_until(&s, |sim| {
        rows.extend_from_slice(sim.rows());
        // The plant has moved on to the next step: what follower 3's radar sees there.
        sim.platoons()[0].plant().radar_truth(&mut truth);
        if let Some(t) = truth[3].filter(|t| t.intruder) {
            smallest = smallest.min(t.gap);
        }
        std::ops::ControlFlow::Continue(())
    })
    .unwrap();
    (rows, summary, smallest)
}

#[test]
fn a_cut_in_between_followers_2_and_3_is_seen_handled_and_left_by_each_law() {
    for law in ["paper", "ploeg", "acc", "path_cacc", "consensus"] {
        let s = scenario(&cut_in_config(law));
        let dt = s.dt();
        let entry = (20.0 / dt).round() as u64;
        let (rows, summary, smallest) = run(s);
        assert!(!summary.safety.collided, "{law}: {:?}", summary.safety);
        // The intruder was ahead of follower 3 the whole time, never touched.
        assert!(smallest.is_finite() && smallest > 1.0, "{law}: {smallest}");
        let f3: Vec<&StepRow> = rows.iter().filter(|r| r.vehicle == 3).collect();
        let mode_at = |k: u64| f3[k as usize].mode;
        if law == "acc" {
            // A law on the radar alone follows whoever is ahead: nothing to switch.
            assert!(f3.iter().all(|r| r.mode == Mode::Coop), "{law}");
            continue;
        }
        // On ACC from the step it entered (the radar measures every 5 steps, from step 0),
        // until a second after it left at 30 s, then back through the blend to the law.
        assert_eq!(mode_at(entry - 1), Mode::Coop, "{law}");
        assert_eq!(mode_at(entry), Mode::CutIn, "{law}");
        let left = (30.0 / dt).round() as u64;
        assert_eq!(mode_at(left + 99), Mode::CutIn, "{law}");
        assert_eq!(mode_at(left + 100), Mode::Blend, "{law}");
        assert_eq!(f3.last().unwrap().mode, Mode::Coop, "{law}");
        // The gap it opened is closed again by the end.
        assert!(
            f3.last().unwrap().spacing_error.abs() < 2.0,
            "{law}: {}",
            f3.last().unwrap().spacing_error
        );
        // No follower but 3 ever saw an intruder.
        assert!(
            rows.iter()
                .filter(|r| r.vehicle != 3)
                .all(|r| r.mode != Mode::CutIn),
            "{law}"
        );
        // It brakes as the car cuts in (on ACC, or harder with the guard), and the hand-over
        // back is bumpless (the law starts from the ACC's command).
        let step = |k: u64| (f3[k as usize].u - f3[k as usize - 1].u).abs();
        assert!(
            f3[entry as usize].u < -1.0,
            "{law}: {}",
            f3[entry as usize].u
        );
        assert!(step(left + 100) < 0.1, "{law}: {}", step(left + 100));
    }
}

#[test]
fn without_cut_in_handling_the_papers_law_drives_into_the_intruder() {
    let text = cut_in_config("paper").replace("cut_in = { dwell_s = 1.0, blend_s = 3.0 }", "");
    let (rows, _, smallest) = run(scenario(&text));
    assert!(smallest < 0.0, "{smallest}");
    assert!(rows.iter().all(|r| r.mode != Mode::CutIn));
}

#[test]
fn runs_without_cut_ins_see_the_predecessor_as_before() {
    // The plant's view of the lane without traffic is the predecessor, value for value.
    let text = std::fs::read_to_string(repo().join("configs/degradation.toml")).unwrap();
    let s = scenario(&text);
    let mut sim = Simulation::new(s).unwrap();
    let (mut lane, mut platoon) = (Vec::new(), Vec::new());
    for _ in 0..500 {
        sim.plant().radar_truth(&mut lane);
        platoon_control::fallback::radar_truth(
            sim.plant().states(),
            sim.scenario().vehicle_length,
            &mut platoon,
        );
        assert_eq!(lane, platoon);
        sim.step();
    }
}

#[test]
fn bad_cut_ins_name_their_key() {
    let base = cut_in_config("paper");
    for (from, to, key) in [
        ("ahead_of = 3 ", "ahead_of = 5 ", "cut_ins[0].ahead_of"),
        ("ahead_of = 3 ", "ahead_of = 0 ", "cut_ins[0].ahead_of"),
        ("leave_s = 30.0", "leave_s = 10.0", "cut_ins[0].leave_s"),
        ("at_s = 20.0", "at_s = 90.0", "cut_ins[0].at_s"),
        (
            "decel_mps2 = 2.0",
            "decel_mps2 = -2.0",
            "cut_ins[0].decel_mps2",
        ),
        (
            "cut_in = { dwell_s = 1.0",
            "cut_in = { dwell_s = -1.0",
            "fallback.cut_in.dwell_s",
        ),
    ] {
        assert!(base.contains(from), "{from}");
        let text = base.replacen(from, to, 1);
        let e = parse(&text, Path::new("cut-in.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("key `{key}`")), "{key}: {e}");
    }
}
