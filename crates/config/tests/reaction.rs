//! Reacting to misbehaviour detection keeps the platoon safe where ignoring it does not: the
//! paper's platoon (no DoS, ACC on the radar as the fallback) whose leader, from 35 s, claims a
//! speed drifting up by 1 m/s every second while it really brakes. Without a reaction the
//! followers run into it; with `reaction = "fallback"` they switch to ACC on the flagged sender
//! and keep their gaps. Measured in process, against the ground truth of every packet.
use platoon_config::{parse, PAPER_TOML};
use std::path::Path;

fn run(detection: &str) -> platoon_sim::Summary {
    let attack_from = PAPER_TOML
        .find("[attack]")
        .expect("the paper config has [attack]");
    let text = format!(
        "{}\n[attack]\nkind = \"none\"\n\n[[channel.attacks]]\nkind = \"drift\"\nrate = [0.0, 1.0, 0.0]\n\
         senders = [0]\nstart_s = 35.0\ninsider = true\n{detection}",
        PAPER_TOML[..attack_from].replacen(
            "mode = \"zero\"",
            "mode = \"acc\"",
            1
        )
    );
    let (_, scenario) = parse(&text, Path::new("reaction.toml")).unwrap();
    platoon_sim::run(scenario, |_| {}).unwrap()
}

#[test]
fn falling_back_on_a_flagged_leader_turns_a_collision_into_a_safe_run() {
    let ignored = run("");
    assert!(ignored.safety.collided, "{:?}", ignored.safety);
    assert!(ignored.detection.is_none());

    let detectors = "[detection.residual]\n[detection.radar_cross]\n";
    let logged = run(&format!("[detection]\nreaction = \"log\"\n{detectors}"));
    // Logging changes nothing but the record.
    assert_eq!(logged.safety.min_gap_m, ignored.safety.min_gap_m);
    let d = logged.detection.as_ref().expect("measured");
    assert!(d.labels["altered"] > 0 && d.labels["genuine"] > 0, "{d:?}");
    for s in &d.detectors {
        // Both catch the lie, raising few false alarms on the genuine packets.
        assert!(s.totals.tp > 0, "{s:?}");
        assert!(s.false_alarm_rate.unwrap() < 0.01, "{s:?}");
    }

    let reacting = run(&format!(
        "[detection]\nreaction = \"fallback\"\nquiet_s = 10.0\n{detectors}"
    ));
    assert!(!reacting.safety.collided, "{:?}", reacting.safety);
    assert!(reacting.safety.min_gap_m > 1.0);
    let d = reacting.detection.as_ref().unwrap();
    assert!(d.refused > 0 && d.flagged > 0, "{d:?}");
}

/// `[detection] plugin` names the detectors a controller plug-in runs: the run measures them
/// after the built-in ones, and a bad list is refused naming the key.
#[test]
fn a_plugins_detectors_are_named_after_the_builtin_ones_and_bad_names_are_refused() {
    let with = |detection: &str| parse(&format!("{PAPER_TOML}\n{detection}"), Path::new("p.toml"));
    let (_, s) = with("[detection]\nplugin = [\"pos_speed\"]\n[detection.residual]\n").unwrap();
    let d = &s.control.detection;
    assert_eq!(d.names(), ["residual", "pos_speed"]);
    assert!(d.is_on() && d.is_measured());
    // A plug-in's detectors alone: the built-in controllers run nothing, the run measures.
    let (_, s) = with("[detection]\nplugin = [\"mine\"]\n").unwrap();
    assert!(!s.control.detection.is_on() && s.control.detection.is_measured());
    for (bad, key) in [
        ("plugin = [\"a b\"]", "detection.plugin[0]"),
        ("plugin = [\"x\", \"x\"]", "detection.plugin[1]"),
        ("plugin = [\"residual\"]", "detection.plugin[0]"),
        (
            "plugin = [\"a\", \"b\", \"c\", \"d\", \"e\", \"f\", \"g\", \"h\", \"i\"]",
            "detection.plugin",
        ),
        ("plugin = []", "detection"),
    ] {
        let e = with(&format!("[detection]\n{bad}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{bad}: {e}");
    }
}
