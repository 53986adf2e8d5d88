//! The whole paper scenario, in process: the claims of Section IV that our reading reproduces.
use platoon_config::{parse, PAPER_TOML, TABLE1_TOML};
use platoon_control::{FallbackMode, TriggerRule};
use platoon_sim::{run, Scenario, StepRow, Summary};
use std::path::Path;

fn paper() -> Scenario {
    parse(PAPER_TOML, Path::new("paper.toml")).unwrap().1
}

fn table1() -> Scenario {
    parse(TABLE1_TOML, Path::new("table1.toml")).unwrap().1
}

fn run_rows(s: Scenario) -> (Vec<StepRow>, Summary) {
    let mut rows = Vec::new();
    let summary = run(s, |r| rows.extend_from_slice(r)).unwrap();
    (rows, summary)
}

fn with_rule(mut s: Scenario, rule: TriggerRule) -> Scenario {
    s.control.rule = rule;
    s
}

#[test]
fn paper_schedule_matches_fig5b_totals_and_assumption_2() {
    let (_, s) = run_rows(paper());
    assert_eq!(s.attack.intervals, 7, "N(0,55) = 7");
    assert!(
        (s.attack.attacked_time_s - 10.0).abs() < 1e-12,
        "|A(0,55)| = 10"
    );
    assert!(s.attack.assumption2.as_ref().unwrap().holds);
    assert!(s.complete);
    assert_eq!(s.steps, 5501);
}

#[test]
fn dynamic_triggers_less_than_static_on_every_vehicle_under_dos() {
    let (_, d) = run_rows(paper());
    let (_, st) = run_rows(with_rule(paper(), TriggerRule::Static));
    // Section IV's broadcasts per follower as the README quotes them, measured by this code;
    // runs are bit-deterministic, so any change is a behaviour change: update README.md with it.
    let counts = |s: &Summary| s.vehicles.iter().map(|v| v.triggers).collect::<Vec<_>>();
    assert_eq!(counts(&d), [613, 646, 689, 690]);
    assert_eq!(d.triggers_total, 2638);
    assert!((d.safety.min_gap_m - 8.45).abs() < 0.005, "{:?}", d.safety);
    for (a, b) in d.vehicles.iter().zip(&st.vehicles) {
        assert!(
            a.triggers < b.triggers,
            "follower {}: dynamic {} vs static {}",
            a.vehicle,
            a.triggers,
            b.triggers
        );
    }
}

#[test]
fn every_follower_converges_after_the_last_attack() {
    let (rows, s) = run_rows(paper());
    let last_end = paper().dos.intervals().last().unwrap().end;
    assert!(!s.safety.collided, "{:?}", s.safety);
    for v in &s.vehicles {
        let after: Vec<f64> = rows
            .iter()
            .filter(|r| r.vehicle == v.vehicle && r.t >= last_end)
            .map(|r| r.spacing_error.abs())
            .collect();
        let (first, last) = (after[0], *after.last().unwrap());
        // The README's final spacing errors (mm, two decimals), measured by this code; runs are
        // bit-deterministic, so any change is a behaviour change: update README.md with it.
        let printed_mm = [1.01, 0.52, 0.10, 0.13][usize::from(v.vehicle) - 1];
        assert!(
            (last * 1e3 - printed_mm).abs() < 0.005,
            "follower {}: final spacing error {} mm, the README says {printed_mm}",
            v.vehicle,
            last * 1e3
        );
        assert_eq!(last, v.spacing_error_m.final_abs);
        assert!(
            last <= first,
            "follower {}: {first} m -> {last} m after the last attack",
            v.vehicle
        );
        assert!(v.velocity_error_mps.final_abs < 0.01);
    }
}

#[test]
fn table1_dynamic_saves_broadcasts_with_comparable_tracking() {
    let (_, d) = run_rows(table1());
    let (_, st) = run_rows(with_rule(table1(), TriggerRule::Static));
    assert_eq!(d.attack.intervals, 0);
    // The README's "the same tracking error": the mean |spacing error| of every follower is at
    // most the static rule's and at least 97 % of it (measured: 97.5-99.5 %), so neither a rule
    // that tracks worse nor one that tracks markedly better passes. The means themselves are
    // pinned to 4 decimals (table1.md prints the platoon's mean to 4: 0.1363 and 0.1384),
    // measured by this code; runs are bit-deterministic, so any change is a behaviour change.
    let dynamic_m = [0.1300, 0.1105, 0.1311, 0.1736];
    let static_m = [0.1306, 0.1133, 0.1340, 0.1755];
    for (i, (a, b)) in d.vehicles.iter().zip(&st.vehicles).enumerate() {
        assert!(a.triggers < b.triggers, "follower {}", a.vehicle);
        let (ea, eb) = (a.spacing_error_m.mean_abs, b.spacing_error_m.mean_abs);
        assert!(
            ea <= eb && ea >= 0.97 * eb,
            "follower {}: tracking error {ea} vs static {eb}",
            a.vehicle
        );
        assert!(
            (ea - dynamic_m[i]).abs() < 5e-5,
            "follower {}: {ea}",
            a.vehicle
        );
        assert!(
            (eb - static_m[i]).abs() < 5e-5,
            "follower {}: {eb}",
            b.vehicle
        );
    }
}

#[test]
fn in_process_runs_are_bit_for_bit_deterministic() {
    let (r1, s1) = run_rows(paper());
    let (r2, s2) = run_rows(paper());
    assert_eq!(s1, s2);
    assert_eq!(r1.len(), r2.len());
    for (a, b) in r1.iter().zip(&r2) {
        assert_eq!(
            (a.p.to_bits(), a.v.to_bits(), a.a.to_bits(), a.u.to_bits()),
            (b.p.to_bits(), b.v.to_bits(), b.a.to_bits(), b.u.to_bits())
        );
        assert_eq!(
            (a.triggered, a.theta.to_bits()),
            (b.triggered, b.theta.to_bits())
        );
    }
}

#[test]
fn affected_followers_apply_zero_or_hold_and_freeze_theta() {
    let (rows, _) = run_rows(paper());
    let followers = || rows.iter().filter(|r| r.vehicle > 0);
    assert!(followers().any(|r| r.affected));
    assert!(followers().filter(|r| r.affected).all(|r| r.u == 0.0));
    // theta does not change across an affected step.
    for w in rows.chunks(5).collect::<Vec<_>>().windows(2) {
        for (now, next) in w[0].iter().zip(w[1]).skip(1) {
            if now.affected {
                assert_eq!(now.theta, next.theta, "t = {}", now.t);
            }
        }
    }
    let mut hold = paper();
    hold.control.fallback.mode = FallbackMode::Hold;
    let (rows_hold, _) = run_rows(hold);
    let during = |rs: &[StepRow]| {
        rs.iter()
            .filter(|r| r.vehicle > 0 && r.affected)
            .map(|r| r.u.abs())
            .sum::<f64>()
    };
    assert!(
        during(&rows_hold) > 0.0,
        "hold keeps a non-zero input during attacks"
    );
    assert_ne!(rows_hold.last().unwrap().p, rows.last().unwrap().p);
}

#[test]
fn resilient_sampling_every_h_during_attacks() {
    // With u = 0 while jammed the plant follows the open-loop estimator, so the event rule rarely
    // fires inside an attack; holding the last input makes it fire, and then (11) takes over.
    let mut s = paper();
    s.control.fallback.mode = FallbackMode::Hold;
    let (rows, _) = run_rows(s.clone());
    let h = f64::from(s.control.h_steps) * s.dt();
    // Within an attack, consecutive broadcasts of a follower are h apart once it has detected it.
    for v in 1..=4u16 {
        let times: Vec<(u64, bool)> = rows
            .iter()
            .filter(|r| r.vehicle == v && r.triggered)
            .map(|r| (r.step, r.under_attack))
            .collect();
        let gaps_in_attack: Vec<u64> = times
            .windows(2)
            .filter(|w| w[0].1 && w[1].1)
            .map(|w| w[1].0 - w[0].0)
            .collect();
        assert!(
            !gaps_in_attack.is_empty(),
            "follower {v} never sampled during an attack"
        );
        assert!(
            gaps_in_attack
                .iter()
                .all(|&g| g == s.control.h_steps as u64),
            "follower {v}: {gaps_in_attack:?} (h = {h} s)"
        );
    }
}

#[test]
fn attacks_on_the_leaders_ramp_hurt_more_than_during_cruise() {
    // Reading R23: the same 3 s of jamming during cruise vs on the acceleration ramp.
    let attack = |start: f64| {
        let mut s = table1();
        s.dos = platoon_attacks::DosSchedule::from_intervals(&[(start, 3.0)]).unwrap();
        run_rows(s)
            .1
            .vehicles
            .iter()
            .map(|v| v.spacing_error_m.max_abs)
            .fold(0.0, f64::max)
    };
    let (cruise, ramp) = (attack(25.0), attack(11.0));
    assert!(ramp > 3.0 * cruise, "ramp {ramp} m vs cruise {cruise} m");
}

#[test]
fn non_resilient_and_periodic_variants_run() {
    // With the paper's fallback (u = 0 while jammed) the plant follows the open-loop
    // estimators, so no event rule fires inside an attack: the resilient mechanism (11), which
    // acts only on a broadcast that falls in one, never engages, and turning it off changes
    // nothing at all.
    let (rows, resilient) = run_rows(paper());
    let in_attack = |rows: &[StepRow]| {
        rows.iter()
            .filter(|r| r.vehicle > 0 && r.triggered && r.under_attack)
            .count()
    };
    assert_eq!(in_attack(&rows), 0);
    let mut s = paper();
    s.control.resilient = false;
    let (_, summary) = run_rows(s);
    assert!(summary.complete);
    assert_eq!(summary, resilient);
    // Holding the last input, the event rule does fire inside attacks. Resilient, a follower
    // whose broadcast is jammed samples every h until one gets through (so it stays affected a
    // little longer than the 10 s attacked); without it, it broadcasts only when its event rule
    // fires and is affected exactly while jammed. The counts are measured by this code (runs
    // are bit-deterministic, so any change is a behaviour change).
    let hold = |resilient: bool| {
        let mut s = paper();
        s.control.fallback.mode = FallbackMode::Hold;
        s.control.resilient = resilient;
        run_rows(s)
    };
    let counts = |s: &Summary| s.vehicles.iter().map(|v| v.triggers).collect::<Vec<_>>();
    let ((rows_r, r), (rows_n, n)) = (hold(true), hold(false));
    assert_eq!(counts(&r), [903, 964, 988, 987]);
    assert_eq!(counts(&n), [619, 686, 639, 688]);
    assert_eq!((in_attack(&rows_r), in_attack(&rows_n)), (1172, 80));
    for (a, b) in r.vehicles.iter().zip(&n.vehicles) {
        assert!(a.affected_time_s > 10.0 + 1e-9, "follower {}", a.vehicle);
        assert!(
            (b.affected_time_s - 10.0).abs() < 1e-9,
            "follower {}",
            b.vehicle
        );
    }
    let (_, periodic) = run_rows(with_rule(
        table1(),
        TriggerRule::Periodic { period_steps: 10 },
    ));
    // Every 0.1 s over [0, 55]: 551 samples per follower.
    assert!(
        periodic.vehicles.iter().all(|v| v.triggers == 551),
        "{:?}",
        periodic.triggers
    );
    assert_eq!(periodic.triggers_total, 4 * 551);
}

/// With constant spacing a long predecessor-following platoon is string unstable (gap
/// errors grow from the first follower to the last, up to a collision under the paper's DoS);
/// with a time headway the same platoon, gain and attacks damp them, as the string-stability
/// analysis of `platoon design check-gain` predicts. Measured in the plant.
#[test]
fn a_time_headway_damps_gap_errors_along_a_long_platoon_that_constant_spacing_amplifies() {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/time-headway.toml"),
    )
    .unwrap();
    let (_, th) = parse(&text, Path::new("time-headway.toml")).unwrap();
    assert_eq!(th.headway(), 1.0);
    let constant = text
        .replace(
            "spacing_policy = \"time_headway\"",
            "spacing_policy = \"constant\"",
        )
        .replace("time_headway_s = 1.0", "");
    let (_, cs) = parse(&constant, Path::new("constant.toml")).unwrap();
    assert_eq!(cs.headway(), 0.0);
    let (rows, th) = run_rows(th);
    let (_, cs) = run_rows(cs);
    assert_eq!(
        (th.spacing_policy.as_str(), cs.spacing_policy.as_str()),
        ("time_headway", "constant")
    );
    // In formation at t = 0: every gap is l + h_t v0 = 10 + 15 m, no error.
    let first: Vec<&StepRow> = rows.iter().filter(|r| r.step == 0).collect();
    for w in first.windows(2) {
        assert!((w[0].p - w[1].p - 25.0).abs() < 1e-9);
        assert!(w[1].spacing_error.abs() < 1e-9);
    }
    let growth_th = th.gap_error_growth().unwrap();
    let growth_cs = cs.gap_error_growth().unwrap();
    assert!(growth_th < 0.5, "time headway: {growth_th}");
    assert!(growth_cs > 10.0, "constant spacing: {growth_cs}");
    assert!(!th.safety.collided && th.safety.min_gap_m > 15.0);
    assert!(cs.safety.collided, "{:?}", cs.safety);
}
