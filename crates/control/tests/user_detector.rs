//! A detector of the user's own on the built-in controller (`examples/user_detector.rs`, run
//! here): measured in the run's summary like a built-in one, and the config's reaction acts on
//! its flags.
#[allow(dead_code)]
#[path = "../examples/user_detector.rs"]
mod example;

use platoon_control::Reaction;
use platoon_sim::Summary;

fn affected_s(summary: &Summary, vehicle: u16) -> f64 {
    let v = summary.vehicles.iter().find(|v| v.vehicle == vehicle);
    v.map_or(0.0, |v| v.affected_time_s)
}

#[test]
fn a_users_detector_flags_the_lies_and_the_fallback_reaction_shows_in_the_run() {
    // Logging only: the accepted lies steer follower 2 towards the claimed speed, so the
    // detector sees the onset only; nobody is affected.
    let logged = example::run(Reaction::Log);
    let d = logged
        .detection
        .as_ref()
        .expect("the user's detector is measured");
    assert_eq!(d.reaction, "log");
    assert_eq!(d.detectors.len(), 1);
    assert_eq!(d.detectors[0].name, "speed_gap");
    assert!(d.flagged >= 1, "{d:?}");
    assert_eq!((d.detectors[0].totals.fp, d.refused), (0, 0), "{d:?}");
    assert!((0..=4).all(|v| affected_s(&logged, v) == 0.0));

    // Falling back: every lie that passes the packet checks is flagged and refused, nothing
    // genuine is flagged, and follower 2 (who hears follower 1 on PF) runs its fallback from
    // the first lie (12 s) to the quiet half second after the last (just before 14 s).
    let reacting = example::run(Reaction::Fallback);
    let d = reacting.detection.as_ref().unwrap();
    assert_eq!(d.reaction, "fallback");
    assert_eq!(d.flagged, d.labels["altered"], "{d:?}");
    assert_eq!(d.detectors[0].recall, Some(1.0), "{d:?}");
    assert_eq!(d.detectors[0].totals.fp, 0, "{d:?}");
    assert!(d.refused >= d.flagged, "{d:?}");
    let follower2 = affected_s(&reacting, 2);
    assert!((2.0..=2.6).contains(&follower2), "{follower2} s");
    assert!([0, 1, 3, 4]
        .iter()
        .all(|&v| affected_s(&reacting, v) == 0.0));
}
