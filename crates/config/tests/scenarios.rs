//! Scenarios that cannot happen are refused before anything runs, naming the key that makes
//! them impossible (issue 53): a vehicle that would appear inside another, a setting that can
//! never take effect, a value SUMO would refuse, a number too large for the step arithmetic.
use platoon_config::{parse, ConfigError};
use std::path::Path;

fn shipped(name: &str) -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../configs")
            .join(name),
    )
    .unwrap()
}

/// configs/`name` with each `(from, to)` replaced once (`from` must be there), parsed as
/// bad.toml.
fn edited(name: &str, edits: &[(&str, &str)]) -> Result<(), ConfigError> {
    let mut text = shipped(name);
    for (from, to) in edits {
        assert!(text.contains(from), "{name} no longer contains {from:?}");
        text = text.replacen(from, to, 1);
    }
    parse(&text, Path::new("bad.toml")).map(|_| ())
}

/// configs/`name` with `extra` appended.
fn plus(name: &str, extra: &str) -> Result<(), ConfigError> {
    parse(&(shipped(name) + extra), Path::new("bad.toml")).map(|_| ())
}

/// The error is one line naming bad.toml, the key and `words`, and prints no number of more
/// than 20 digits.
#[track_caller]
fn refused(result: Result<(), ConfigError>, key: &str, words: &str) {
    let e = result.expect_err("the config should be refused");
    let line = e.to_string();
    assert!(!line.contains('\n'), "one line: {line}");
    assert!(line.starts_with("bad.toml:"), "file and line: {line}");
    assert_eq!(e.key, key, "{line}");
    assert!(line.contains(words), "{line} should say {words:?}");
    let digits = line
        .split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0);
    assert!(
        digits <= 20,
        "a number printed with {digits} digits: {line}"
    );
}

/// The cut-in of configs/cut-in.toml (mid-gap ahead of follower 3 at 20 s; the gap is 15.5 m).
const CUT_IN_LEAVE: &str = "leave_s = 30.0         # and leaves the lane";

#[test]
fn a_cut_in_that_would_start_inside_a_vehicle_is_refused() {
    // Longer than its gap.
    refused(
        edited(
            "cut-in.toml",
            &[(CUT_IN_LEAVE, "leave_s = 30.0\nlength_m = 20.0")],
        ),
        "cut_ins[0].length_m",
        "does not fit the 15.5 m gap ahead of follower 3 at 20 s",
    );
    // A gap_m beyond the gap puts it inside follower 2, or ahead of it.
    for g in ["12.0", "30.0", "0.0"] {
        refused(
            edited(
                "cut-in.toml",
                &[(CUT_IN_LEAVE, &format!("leave_s = 30.0\ngap_m = {g}"))],
            ),
            "cut_ins[0].gap_m",
            "0 < gap_m < 11 m",
        );
    }
    // Twice the same car.
    let car = &shipped("cut-in.toml")[shipped("cut-in.toml").find("[[cut_ins]]").unwrap()..];
    refused(
        plus("cut-in.toml", &format!("\n{car}")),
        "cut_ins[1].at_s",
        "together with cut_ins[0]'s",
    );
    // A second car in the same gap after the first left, or in another gap, is fine.
    let later = car.replacen("at_s = 20.0", "at_s = 40.0", 1).replacen(
        "leave_s = 30.0",
        "leave_s = 50.0",
        1,
    );
    plus("cut-in.toml", &format!("\n{later}")).unwrap();
    let elsewhere = car.replacen("ahead_of = 3", "ahead_of = 1", 1);
    plus("cut-in.toml", &format!("\n{elsewhere}")).unwrap();
    // Entering backwards, or faster than any vehicle.
    for (dv, words) in [
        ("-40.0", "enter at -15 m/s"),
        ("1e308", "enter at 1e308 m/s"),
    ] {
        refused(
            edited(
                "cut-in.toml",
                &[("speed_diff_mps = -2.0", &format!("speed_diff_mps = {dv}"))],
            ),
            "cut_ins[0].speed_diff_mps",
            words,
        );
    }
    // At t = 0 the initial states' gap counts.
    refused(
        edited(
            "cut-in.toml",
            &[
                ("at_s = 20.0", "at_s = 0.0"),
                (CUT_IN_LEAVE, "leave_s = 30.0\ngap_m = 11.5"),
            ],
        ),
        "cut_ins[0].gap_m",
        "ahead of follower 3 at 0 s",
    );
}

#[test]
fn a_joiner_or_a_vehicle_ahead_that_would_start_inside_another_is_refused() {
    // The joiner of configs/join.toml 2 m behind follower 3's front, inside it.
    refused(
        edited(
            "join.toml",
            &[("[-124.5, 15.0, 0.0]", "[-62.0, 15.0, 0.0]")],
        ),
        "platoon.initial_states[4]",
        "vehicle 4 starts inside vehicle 3",
    );
    // From the lane beside (configs/join-middle.toml) it may start alongside a member, not
    // inside another vehicle of that lane.
    edited("join-middle.toml", &[]).unwrap();
    // Two vehicles ahead of the leader in one place.
    let ahead = "\n[[sumo.ahead]]\ngap_m = 60.0\nspeed_mps = 18.0\n";
    refused(
        plus(
            "paper.toml",
            &format!("{ahead}{}", ahead.replace("60.0", "65.0")),
        ),
        "sumo.ahead[1].gap_m",
        "inside sumo.ahead[0]",
    );
    plus(
        "paper.toml",
        &format!("{ahead}{}", ahead.replace("60.0", "80.0")),
    )
    .unwrap();
}
