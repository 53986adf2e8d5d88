//! Mixed vehicles (`configs/truck-car.toml`): a truck at follower 2 among cars. It designs for
//! every member's lag, runs on the native plant with each member's length in the gaps and its
//! class's limits on the input the plant applies, and both transports agree bit for bit.
use crate::common;

use common::{json, repo, run_config};
use platoon_app::design::{check_gain, CheckOptions, Theorem};
use platoon_sim::StepRow;

fn truck_car(from_to: &[(&str, &str)]) -> (platoon_config::Config, platoon_sim::Scenario) {
    let mut text = std::fs::read_to_string(repo().join("configs/truck-car.toml")).unwrap();
    for (from, to) in from_to {
        assert!(
            text.contains(from),
            "truck-car.toml no longer holds {from:?}"
        );
        text = text.replacen(from, to, 1);
    }
    platoon_config::parse(&text, std::path::Path::new("truck-car.toml")).unwrap()
}

fn run(scenario: platoon_sim::Scenario) -> (Vec<StepRow>, platoon_sim::Summary) {
    let mut rows = Vec::new();
    let summary = platoon_sim::run(scenario, |r| rows.extend_from_slice(r)).unwrap();
    (rows, summary)
}

#[test]
fn the_truck_car_platoon_designs_for_every_members_lag() {
    let (config, scenario) = truck_car(&[]);
    // The hull of the members' ranges and the nominal lag.
    assert_eq!(scenario.tau_range(), (0.3, 1.0));
    assert_eq!(
        scenario.member_tau_ranges(),
        vec![(0.3, 0.6), (0.6, 1.0), (0.3, 0.6), (0.3, 0.6)]
    );
    let report = check_gain(
        &config,
        &scenario,
        &CheckOptions {
            theorem: Theorem::Robust,
            ..CheckOptions::default()
        },
    )
    .unwrap();
    // (13) at both ends of the hull with one P: the config's ratio is certified there.
    assert_eq!(report.lmi_taus, vec![0.3, 1.0]);
    assert!(report.config_ratio_certified);
    let mixed = report.heterogeneous.expect("a check of the mixed platoon");
    assert_eq!(mixed.vertices, 16);
    assert!(mixed.worst_max_real < 0.0, "{}", mixed.worst_max_real);
    // That P does not carry over to followers of different lags (the Kronecker form is what
    // Theorem 2's vertices cover)...
    assert!(!mixed.certified, "{mixed:?}");
    assert!(mixed.max_eigenvalue.unwrap() > 0.0);
    // ...but the direct SDP over the 16 vertices, one P per follower, certifies the config's
    // ratio for every combination of lags in the members' ranges.
    let r = mixed.direct_min_ratio.expect("the direct SDP is feasible");
    assert!(mixed.direct_max_eigenvalue.unwrap() < 0.0);
    assert!(report.config_ratio >= r, "{} < {r}", report.config_ratio);
    // Without classes there is no such check.
    let (config, scenario) = platoon_config::load(&repo().join("configs/paper.toml")).unwrap();
    let plain = check_gain(&config, &scenario, &CheckOptions::default()).unwrap();
    assert!(plain.heterogeneous.is_none());
}

#[test]
fn the_truck_car_platoon_runs_with_each_members_length_and_limits() {
    let (_, scenario) = truck_car(&[]);
    assert_eq!(scenario.lengths(), vec![4.5, 4.5, 12.0, 4.5, 4.5]);
    let (rows, summary) = run(scenario.clone());
    assert!(!summary.safety.collided, "{:?}", summary.safety);
    // Gaps from each member's rear: the smallest one is behind the truck, and the summary's
    // is the smallest over the rows with the truck's 12 m counted.
    let n1 = 5;
    let mut smallest = (f64::INFINITY, 0);
    for step in rows.chunks(n1) {
        for i in 1..n1 {
            let gap = step[i - 1].p - step[i].p - scenario.length(i - 1);
            if gap < smallest.0 {
                smallest = (gap, i);
            }
        }
    }
    assert_eq!(smallest.1, 3, "the smallest gap is behind the truck");
    assert_eq!(summary.safety.min_gap_m, smallest.0);
    assert_eq!(summary.safety.min_gap_vehicle, 3);
    assert!(smallest.0 > 5.0 && smallest.0 < 13.0, "{}", smallest.0);
    // Every member's recorded input and acceleration keep within its class's limits.
    for r in rows.iter().filter(|r| r.vehicle > 0) {
        let (up, down) = if r.vehicle == 2 {
            (1.5, 4.0)
        } else {
            (3.0, 8.0)
        };
        assert!(r.u <= up && r.u >= -down, "{r:?}");
        assert!(r.a <= up && r.a >= -down, "{r:?}");
    }
    // The truck's limit binds: it uses all of it, and without the limit it would want more.
    let truck_max = |rows: &[StepRow]| {
        rows.iter()
            .filter(|r| r.vehicle == 2)
            .map(|r| r.a)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert!(truck_max(&rows) > 1.45, "{}", truck_max(&rows));
    assert!(rows.iter().any(|r| r.vehicle == 2 && r.u == 1.5));
    let (_, unlimited) = truck_car(&[("accel_max_mps2 = 1.5\n", "")]);
    let (free, _) = run(unlimited);
    assert!(truck_max(&free) > 1.6, "{}", truck_max(&free));
    // The truck's longer lag: its own schedule, the cars' theirs.
    assert_eq!(scenario.taus[1].at(10.0), 0.8);
    assert_eq!(scenario.taus[0].at(10.0), 0.4);
}

/// The mixed platoon over iceoryx2 and in process: the same trajectories, byte for byte.
#[test]
fn the_truck_car_platoon_agrees_over_both_transports() {
    let tmp = tempfile::tempdir().unwrap();
    let c = repo().join("configs/truck-car.toml");
    run_config(&c, "ipc", &[], tmp.path());
    run_config(&c, "inproc", &["--transport", "inproc"], tmp.path());
    for file in ["trajectories.csv", "events.csv"] {
        let a = std::fs::read(tmp.path().join("ipc").join(file)).unwrap();
        let b = std::fs::read(tmp.path().join("inproc").join(file)).unwrap();
        assert!(a == b, "{file} differs between the transports");
    }
    let s = json(&tmp.path().join("ipc/summary.json"));
    assert_eq!(s["safety"]["collided"], false);
}
