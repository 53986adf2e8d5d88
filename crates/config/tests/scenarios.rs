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

/// configs/`name` with `extra` appended, run on the native plant (as `platoon run` checks it
/// once the plant is chosen).
fn natively(name: &str, extra: &str) -> Result<(), ConfigError> {
    let text = shipped(name) + extra;
    let (config, _) = parse(&text, Path::new("bad.toml"))?;
    platoon_config::native_plant_check(&config)
        .map_err(|e| e.in_file("bad.toml", &platoon_config::KeyLines::new(&text)))
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
    let driven = |extra: &str| {
        let profile = "profile = { kind = \"paper\" }";
        let text = shipped("sumo-paper.toml");
        assert!(text.contains(profile));
        let text = text.replacen(
            profile,
            &format!("{profile}\ndrive = {{ kind = \"sumo\", speed_mps = 25.0 }}"),
            1,
        ) + extra;
        parse(&text, Path::new("bad.toml")).map(|_| ())
    };
    refused(
        driven(&format!("{ahead}{}", ahead.replace("60.0", "65.0"))),
        "sumo.ahead[1].gap_m",
        "inside sumo.ahead[0]",
    );
    driven(&format!("{ahead}{}", ahead.replace("60.0", "80.0"))).unwrap();
    // A leader that drives its profile has no radar: it would drive through a slower truck.
    refused(
        plus("sumo-paper.toml", ahead),
        "sumo.ahead[0].speed_mps",
        "would reach this one, 60 m ahead, at t = ",
    );
    plus("sumo-paper.toml", &ahead.replace("18.0", "30.0")).unwrap();
}

/// configs/onramp.toml's flow (`vehicles_per_hour = 1200.0`, `speed_mps = 22.0`, cars).
const FLOW_SPEED: &str = "speed_mps = 22.0";

#[test]
fn a_setting_that_can_never_take_effect_is_refused() {
    // Maneuvers after the run's end.
    refused(
        edited("join.toml", &[("at_s = 5.0", "at_s = 80.0")]),
        "maneuvers.joins[0].at_s",
        "not before the run's end (simulation.duration_s = 70 s)",
    );
    refused(
        edited("leave.toml", &[("at_s = ", "at_s = 1e308 #")]),
        "maneuvers.leaves[0].at_s",
        "1e308 s is not before the run's end",
    );
    // A flow that begins after the end, even with its own end_s.
    refused(
        edited(
            "onramp.toml",
            &[(
                FLOW_SPEED,
                "speed_mps = 22.0\nbegin_s = 100.0\nend_s = 200.0",
            )],
        ),
        "sumo.flows[0].begin_s",
        "no vehicle would enter",
    );
    // A join that would time out as it is accepted; a tries of 0.
    refused(
        edited("join.toml", &[("timeout_s = 40.0", "timeout_s = 0.0")]),
        "maneuvers.timeout_s",
        "shorter than a step",
    );
    refused(
        edited("join.toml", &[("tries = 3", "tries = 0")]),
        "maneuvers.tries",
        "at least 1",
    );
    // A platoon larger than it may be from the start.
    refused(
        edited(
            "join.toml",
            &[("timeout_s = 40.0", "timeout_s = 40.0\nmax_members = 3")],
        ),
        "maneuvers.max_members",
        "fewer than the 4 members the platoon starts with",
    );
    edited(
        "join.toml",
        &[("timeout_s = 40.0", "timeout_s = 40.0\nmax_members = 4")],
    )
    .unwrap();
    // SUMO's traffic on the native plant, which would drop it.
    refused(
        natively(
            "paper.toml",
            "\n[[sumo.flows]]\nfrom = \"ramp\"\nto = \"out\"\nvehicles_per_hour = 600.0\n",
        ),
        "sumo.flows[0]",
        "native plant",
    );
    refused(
        natively(
            "paper.toml",
            "\n[[sumo.ahead]]\ngap_m = 60.0\nspeed_mps = 30.0\n",
        ),
        "sumo.ahead[0]",
        "native plant",
    );
    refused(
        natively("paper.toml", "\n[sumo]\nbackground_vehicles = 10\n"),
        "sumo.background_vehicles",
        "native plant",
    );
    refused(
        natively(
            "paper.toml",
            "\n[sumo]\nedge = \"in\"\nroute = [\"in\", \"out\"]\nfcd = \"sumo\"\n",
        ),
        "sumo.route",
        "native plant",
    );
    // The rest of [sumo] is where the platoon drives on SUMO's road: ignored natively; and a
    // config whose plant is native may carry SUMO's traffic for `--plant sumo`.
    natively("sumo-paper.toml", "").unwrap();
    plus("paper.toml", "\n[sumo]\nbackground_vehicles = 10\n").unwrap();
}

#[test]
fn what_sumo_would_refuse_is_a_config_error_naming_the_key() {
    // Faster than the flow's trucks may go, or than its cars.
    refused(
        edited(
            "onramp.toml",
            &[(FLOW_SPEED, "speed_mps = 30.0\ntruck_share = 0.2")],
        ),
        "sumo.flows[0].speed_mps",
        "top speed of 25 m/s",
    );
    edited("onramp.toml", &[(FLOW_SPEED, "speed_mps = 30.0")]).unwrap();
    refused(
        edited("onramp.toml", &[(FLOW_SPEED, "speed_mps = 40.0")]),
        "sumo.flows[0].speed_mps",
        "top speed of 36 m/s",
    );
    // More than one vehicle a step, printed as a number.
    refused(
        edited(
            "onramp.toml",
            &[("vehicles_per_hour = 1200.0", "vehicles_per_hour = 1e308")],
        ),
        "sumo.flows[0].vehicles_per_hour",
        "1e308 is more than one vehicle per step",
    );
}

#[test]
fn errors_name_the_key_the_user_wrote() {
    // A truck longer than the formation's spacing: its length, not the jitter the file does
    // not set.
    refused(
        edited("truck-car.toml", &[("length_m = 12.0", "length_m = 30.0")]),
        "vehicle_classes.truck.length_m",
        "does not fit the formation's 25 m front to front",
    );
    refused(
        edited(
            "cut-in.toml",
            &[("vehicle_length_m = 4.5", "vehicle_length_m = 20.0")],
        ),
        "platoon.vehicle_length_m",
        "does not fit",
    );
    // A jitter that could make two vehicles touch is still the jitter's.
    refused(
        edited(
            "cut-in.toml",
            &[(
                "formation = { leader_position_m = 0.0 }",
                "formation = { leader_position_m = 0.0, position_jitter_m = 9.0 }",
            )],
        ),
        "platoon.formation.position_jitter_m",
        "could make two vehicles touch",
    );
}

#[test]
fn huge_values_name_their_own_key_and_print_as_numbers() {
    // A timeout beyond any run is a join that never times out (no deadline overflows).
    edited("join.toml", &[("timeout_s = 40.0", "timeout_s = 2e17")]).unwrap();
    refused(
        edited(
            "cut-in.toml",
            &[("leave_s = 30.0 ", "leave_s = 30.0\nlength_m = 1e308 #")],
        ),
        "cut_ins[0].length_m",
        "1e308 m long",
    );
    refused(
        edited("paper.toml", &[("h_s = 0.02", "h_s = -1e308")]),
        "trigger.h_s",
        "got -1e308",
    );
    // A period of more steps than a step counter holds is too long, not "no whole number".
    refused(
        edited("join.toml", &[("reply_s = 0.5", "reply_s = 1e308")]),
        "maneuvers.reply_s",
        "1e308 s is more steps of 0.01 s than a period may count",
    );
}

/// Every number of every shipped config, set in turn to values far out of range: the config
/// is refused or accepted without a panic, and a refusal prints no number of more than 20
/// digits (a bad-config corpus of its own, beside the fuzzer's).
#[test]
fn far_out_values_never_panic_and_print_as_numbers() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    let (mut tried, mut long) = (0, Vec::new());
    for name in names {
        let text = shipped(&name);
        for (i, line) in text.lines().enumerate() {
            let Some((key, value)) = line.split_once(" = ") else {
                continue;
            };
            let value = value.split('#').next().unwrap().trim();
            if key.contains('[') || value.parse::<f64>().is_err() {
                continue;
            }
            for far in ["1e308", "-1e308", "2e17", "1e-300"] {
                let edited: Vec<String> = text
                    .lines()
                    .enumerate()
                    .map(|(j, l)| {
                        if j == i {
                            format!("{key} = {far}")
                        } else {
                            l.to_string()
                        }
                    })
                    .collect();
                let edited = edited.join("\n");
                tried += 1;
                let result = std::panic::catch_unwind(|| parse(&edited, Path::new("bad.toml")));
                let result = result.unwrap_or_else(|_| panic!("{name}: {key} = {far} panics"));
                if let Err(e) = result {
                    let line = e.to_string();
                    let digits = line
                        .split(|c: char| !c.is_ascii_digit())
                        .map(str::len)
                        .max()
                        .unwrap_or(0);
                    if digits > 20 || line.contains('\n') {
                        long.push(format!("{name}: {key} = {far}: {line}"));
                    }
                }
            }
        }
    }
    assert!(long.is_empty(), "{}", long.join("\n"));
    assert!(tried > 500, "{tried} edits");
}
