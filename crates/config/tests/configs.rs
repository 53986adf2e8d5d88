//! Every shipped config parses; bad values are rejected with the file and key named.
use platoon_config::{parse, ConfigError};
use std::path::Path;

fn configs_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}

/// The shipped configs, each run by a line of the README's quick start. A config added to or
/// removed from `configs/` must be named here too: the test checks that the directory holds
/// exactly these, so one that stops being found (or a stray file) fails it.
const SHIPPED: [&str; 19] = [
    "cut-in-split.toml",
    "cut-in.toml",
    "degradation.toml",
    "density.toml",
    "highway-large.toml",
    "jammer.toml",
    "join-middle.toml",
    "join-plexe.toml",
    "join.toml",
    "leave.toml",
    "link-attacks.toml",
    "merge.toml",
    "onramp.toml",
    "paper.toml",
    "split.toml",
    "sumo-paper.toml",
    "table1.toml",
    "time-headway.toml",
    "truck-car.toml",
];

#[test]
fn every_file_in_configs_parses_and_validates() {
    let mut seen: Vec<String> = Vec::new();
    for entry in std::fs::read_dir(configs_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let (config, scenario) = platoon_config::load(&path).unwrap_or_else(|e| panic!("{e}"));
            // The resolved config round-trips to the same scenario inputs.
            let text = platoon_config::to_toml(&config);
            let (again, _) =
                parse(&text, &path).unwrap_or_else(|e| panic!("resolved {}: {e}", path.display()));
            assert_eq!(config, again, "{}", path.display());
            assert!(scenario.steps > 0, "{}", path.display());
            seen.push(path.file_name().unwrap().to_string_lossy().into_owned());
        }
    }
    // Every shipped config, by name, was found and checked, and nothing else is there.
    seen.sort();
    assert_eq!(seen, SHIPPED, "the .toml files of configs/");
}

/// Every shipped traffic and maneuver config (one with `[[cut_ins]]`, `[maneuvers]` or
/// `[[sumo.flows]]`) runs on vehicles with limits: `platoon.members` names a class for every
/// vehicle, and each such class bounds acceleration, braking and the guard's emergency braking
/// (docs/traffic.md#vehicles-with-limits). A run of one of them (configs/cut-in.toml, in
/// process) reports each follower's `saturated_time_s`, and follower 3's way back after the
/// car left is held at the limits.
#[test]
fn every_traffic_and_maneuver_config_runs_on_vehicles_with_limits() {
    let mut checked = Vec::new();
    for name in SHIPPED {
        let (config, _) =
            platoon_config::load(&configs_dir().join(name)).unwrap_or_else(|e| panic!("{e}"));
        if config.cut_ins.is_empty() && config.maneuvers.is_none() && config.sumo.flows.is_empty() {
            continue;
        }
        let vehicles = config.platoon.followers + 1;
        let names: Vec<String> = match &config.platoon.members {
            Some(platoon_config::Members::Every(class)) => vec![class.clone(); vehicles],
            Some(platoon_config::Members::Each(classes)) => classes.clone(),
            None => panic!("{name}: no platoon.members"),
        };
        assert_eq!(names.len(), vehicles, "{name}");
        for class in &names {
            let c = config
                .vehicle_classes
                .get(class)
                .unwrap_or_else(|| panic!("{name}: no [vehicle_classes.{class}]"));
            for (key, limit) in [
                ("accel_max_mps2", c.accel_max_mps2),
                ("decel_max_mps2", c.decel_max_mps2),
                ("emergency_decel_mps2", c.emergency_decel_mps2),
            ] {
                assert!(
                    limit.is_some_and(|x| x > 0.0),
                    "{name}: [vehicle_classes.{class}] {key}"
                );
            }
        }
        checked.push(name);
    }
    assert_eq!(
        checked,
        [
            "cut-in-split.toml",
            "cut-in.toml",
            "join-middle.toml",
            "join-plexe.toml",
            "join.toml",
            "leave.toml",
            "merge.toml",
            "onramp.toml",
            "split.toml",
        ]
    );
    let (_, scenario) = platoon_config::load(&configs_dir().join("cut-in.toml")).unwrap();
    let summary = platoon_sim::run(scenario, |_| {}).unwrap();
    assert_eq!(summary.vehicles.len(), 4);
    let saturated: Vec<f64> = summary
        .vehicles
        .iter()
        .map(|v| v.saturated_time_s.expect("saturated_time_s per vehicle"))
        .collect();
    assert!(saturated[2] > 10.0, "{saturated:?}");
}

/// A split behind a cut-in re-points the followers' leader: the paper's law (on its part of the
/// platoon, the head in the leader's place) and the flatbed controller of the shipped config
/// split, and their followers hear every member ahead; a law with no leader to re-point (the
/// ACC reads its radar alone) says so.
#[test]
fn a_split_needs_a_law_that_follows_a_head() {
    let split = platoon_config::CUT_IN_TOML.replacen(
        "cut_in = { dwell_s = 1.0, blend_s = 3.0 }",
        "cut_in = { dwell_s = 1.0, blend_s = 3.0, split = true }",
        1,
    );
    let (_, paper) = parse(&split, Path::new("paper.toml")).unwrap();
    assert!(paper.splits());
    let gains = "gain = [4.81, 9.12, 2.97]      # the paper's law u_i = -K q_i\nbeta1 = 319.38\nbeta2 = 5.62";
    assert!(split.contains(gains), "the cut-in config's gains");
    let acc = split.replacen(gains, "law = \"acc\"", 1);
    assert_error(
        parse(&acc, Path::new("bad.toml")).map(|_| ()),
        "fallback.cut_in.split",
        "path_cacc",
    );
    let (_, scenario) = platoon_config::load(&configs_dir().join("cut-in-split.toml")).unwrap();
    assert!(scenario.splits());
    assert_eq!(scenario.topology.links().count(), 4 + 3);
    assert_eq!(scenario.hearing().links().count(), 4 + 6);
}

fn paper_with(from: &str, to: &str) -> Result<(), ConfigError> {
    let text = platoon_config::PAPER_TOML;
    assert!(
        text.contains(from),
        "the paper config no longer contains {from:?}"
    );
    parse(&text.replacen(from, to, 1), Path::new("bad.toml")).map(|_| ())
}

fn assert_error(result: Result<(), ConfigError>, key: &str, words: &str) {
    let e = result.expect_err("the config should be rejected");
    let line = e.to_string();
    assert!(!line.contains('\n'), "the error must be one line: {line}");
    assert!(
        line.starts_with("bad.toml"),
        "the error must name the file: {line}"
    );
    assert_eq!(e.key, key, "{line}");
    assert!(line.contains(words), "{line} should mention {words:?}");
}

#[test]
fn non_positive_tau_is_rejected() {
    assert_error(
        paper_with(
            "tau = { kind = \"paper\" }",
            "tau = { kind = \"constant\", value_s = 0.0 }",
        ),
        "plant.tau",
        "positive",
    );
    assert_error(
        paper_with("tau_nominal_s = 0.5", "tau_nominal_s = -0.5"),
        "plant.tau_nominal_s",
        "> 0",
    );
}

#[test]
fn step_longer_than_h_is_rejected() {
    assert_error(
        paper_with("h_s = 0.02", "h_s = 0.005"),
        "trigger.h_s",
        "shorter than the step",
    );
    assert_error(
        paper_with("h_s = 0.02", "h_s = 0.025"),
        "trigger.h_s",
        "whole number of steps",
    );
}

#[test]
fn nan_is_rejected() {
    assert_error(
        paper_with("beta1 = 319.38", "beta1 = nan"),
        "control.beta1",
        "finite",
    );
    assert_error(
        paper_with("[8.0, 16.0, 0.0]", "[8.0, nan, 0.0]"),
        "platoon.initial_states[1]",
        "finite",
    );
}

#[test]
fn follower_count_must_match_initial_states() {
    assert_error(
        paper_with("followers = 4", "followers = 5"),
        "platoon.initial_states",
        "needs 6",
    );
}

#[test]
fn topology_without_spanning_tree_is_rejected() {
    let explicit = "preset = \"explicit\"\nadjacency = [[0,0,0,0],[1,0,0,0],[0,0,0,1],[0,0,1,0]]\npinning = [1,0,0,0]";
    assert_error(
        paper_with("preset = \"tpsf\"", explicit),
        "topology",
        "follower(s) 3, 4",
    );
}

#[test]
fn unknown_keys_and_bad_types_are_rejected_with_their_key() {
    assert_error(
        paper_with("h_s = 0.02", "h_s = 0.02\nhh = 1"),
        "trigger.hh",
        "unknown field `hh`",
    );
    assert_error(
        paper_with("followers = 4", "followers = \"four\""),
        "platoon.followers",
        "invalid type",
    );
    assert_error(
        paper_with("rule = \"dynamic\"", "rule = \"dymanic\""),
        "trigger.rule",
        "unknown rule",
    );
    assert_error(
        paper_with("phi = 0.33", "phi = 0.33\nmu = 1.0"),
        "trigger.mu",
        "only used with rule = \"mixed\"",
    );
}

#[test]
fn trigger_parameters_outside_the_papers_conditions_are_rejected() {
    // 1 > rho > phi (1 - eta) fails for rho = 0.1 < 0.33 * 0.5.
    assert_error(
        paper_with("rho = 0.5", "rho = 0.1"),
        "trigger.rho",
        "1 > rho > phi (1 - eta)",
    );
}

#[test]
fn leader_profile_must_start_at_the_leaders_speed() {
    assert_error(
        paper_with("[20.0, 15.0, 0.0]", "[20.0, 14.0, 0.0]"),
        "leader.profile",
        "14 m/s",
    );
}

#[test]
fn random_attack_needs_bounds_and_satisfies_them() {
    let random = "kind = \"random\"\nseed = 3\nmin_gap_s = 1.0\nmax_gap_s = 6.0\nmin_duration_s = 0.5\nmax_duration_s = 2.0\n";
    let text = platoon_config::PAPER_TOML;
    let start = text.find("kind = \"intervals\"").unwrap();
    let end = text.find("assumption2 =").unwrap();
    let with_bounds = format!("{}{random}{}", &text[..start], &text[end..]);
    let (_, scenario) = parse(&with_bounds, Path::new("random.toml")).unwrap();
    assert!(!scenario.dos.intervals().is_empty());
    let bounds = scenario.assumption2.unwrap();
    assert!(bounds.check(&scenario.dos, scenario.duration()).holds);
    let without = format!("{}{random}", &text[..start]);
    let e = parse(&without, Path::new("bad.toml")).unwrap_err();
    assert_eq!(e.key, "attack.assumption2");
}

fn paper_plus(extra: &str) -> Result<(), ConfigError> {
    let text = format!("{}\n{extra}", platoon_config::PAPER_TOML);
    parse(&text, Path::new("bad.toml")).map(|_| ())
}

#[test]
fn link_attacks_are_checked_with_their_index_and_key() {
    assert_error(
        paper_plus("[[channel.attacks]]\nkind = \"teleport\"\n"),
        "channel.attacks[0].kind",
        "unknown kind",
    );
    assert_error(
        paper_plus("[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 1.5\n"),
        "channel.attacks[0].loss",
        "probability",
    );
    assert_error(
        paper_plus("[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.1\nlag_s = 1.0\n"),
        "channel.attacks[0].lag_s",
        "not used with kind",
    );
    assert_error(
        paper_plus(
            "[[channel.attacks]]\nkind = \"delay\"\ndelay_s = 0.1\n\
             [[channel.attacks]]\nkind = \"replay\"\nlag_s = 0.015\n",
        ),
        "channel.attacks[1].lag_s",
        "whole number of steps",
    );
    assert_error(
        paper_plus(
            "[[channel.attacks]]\nkind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\nsenders = [9]\n",
        ),
        "channel.attacks[0].senders",
        "does not exist",
    );
    assert_error(
        paper_plus("[[channel.attacks]]\nkind = \"range_jamming\"\nposition_m = 0.0\n"),
        "channel.attacks[0].radius_m",
        "required",
    );
    assert_error(
        paper_plus(
            "[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.1\nstart_s = 5.0\nend_s = 2.0\n",
        ),
        "channel.attacks[0].end_s",
        "after start_s",
    );
}

#[test]
fn fleet_platoons_on_one_lane_must_not_overlap() {
    assert_error(
        paper_plus("[fleet]\nplatoons = 4\nlanes = [0, 1]\ngap_m = 20.0\n"),
        "fleet.gap_m",
        "would overlap",
    );
    assert!(paper_plus("[fleet]\nplatoons = 2\nlanes = [0, 1]\ngap_m = 20.0\n").is_ok());
    assert_error(
        paper_plus("[fleet]\nplatoons = 0\n"),
        "fleet.platoons",
        "at least one",
    );
}

#[test]
fn a_formation_generates_initial_states_for_any_size() {
    let text = platoon_config::PAPER_TOML;
    let start = text.find("initial_states = [").unwrap();
    let end = start + text[start..].find("\n]\n").unwrap() + 3;
    let formation = "formation = { leader_position_m = 100.0, position_jitter_m = 0.4, speed_jitter_mps = 0.3, seed = 9 }";
    let with = |n: usize, f: &str| {
        let t = format!("{}{f}{}", &text[..start], &text[end..]);
        t.replace("followers = 4", &format!("followers = {n}"))
    };
    let (config, s) = parse(&with(50, formation), Path::new("f.toml")).unwrap();
    assert_eq!(s.initial.len(), 51);
    assert_eq!(s.initial[0], platoon_model::State::new(100.0, 15.0, 0.0));
    for (i, x) in s.initial.iter().enumerate().skip(1) {
        let dp = x[0] - (100.0 - 10.0 * i as f64);
        assert!(
            dp.abs() <= 0.4 && (x[1] - 15.0).abs() <= 0.3 && x[2] == 0.0,
            "{i}: {x:?}"
        );
    }
    // The resolved config keeps the formation (and its seed), not the drawn states.
    assert!(config.platoon.initial_states.is_none());
    let (_, again) = parse(&platoon_config::to_toml(&config), Path::new("f.toml")).unwrap();
    assert_eq!(
        again.initial, s.initial,
        "the same seed draws the same states"
    );
    let e = parse(
        &with(4, "formation = { position_jitter_m = 5.0 }"),
        Path::new("f.toml"),
    )
    .unwrap_err();
    assert_eq!(e.key, "platoon.formation.position_jitter_m");
    let e = parse(&with(4, ""), Path::new("f.toml")).unwrap_err();
    assert!(e.message.contains("[platoon.formation]"), "{e}");
}

#[test]
fn the_spacing_policy_and_its_headway_are_checked_by_key() {
    let spacing = "spacing_m = 10.0";
    assert_error(
        paper_with(
            spacing,
            "spacing_m = 10.0\nspacing_policy = \"time_headway\"",
        ),
        "platoon.time_headway_s",
        "missing",
    );
    assert_error(
        paper_with(spacing, "spacing_m = 10.0\ntime_headway_s = 0.5"),
        "platoon.time_headway_s",
        "only used with",
    );
    assert_error(
        paper_with(spacing, "spacing_m = 10.0\nspacing_policy = \"tight\""),
        "platoon.spacing_policy",
        "constant or time_headway",
    );
    assert_error(
        paper_with(
            spacing,
            "spacing_m = 10.0\nspacing_policy = \"time_headway\"\ntime_headway_s = -0.5",
        ),
        "platoon.time_headway_s",
        "must be > 0",
    );
    assert_error(
        paper_with(
            spacing,
            "spacing_m = 10.0\nspacing_policy = \"time_headway\"\ntime_headway_s = 1e300",
        ),
        "platoon.time_headway_s",
        "at most 60",
    );
    // Accepted, and the resolved config says so again.
    let text = platoon_config::PAPER_TOML.replacen(
        spacing,
        "spacing_m = 10.0\nspacing_policy = \"time_headway\"\ntime_headway_s = 0.5",
        1,
    );
    let (config, scenario) = parse(&text, Path::new("th.toml")).unwrap();
    assert_eq!(scenario.headway(), 0.5);
    assert!(platoon_config::to_toml(&config).contains("time_headway_s = 0.5"));
}

/// The leader in SUMO's traffic, the vehicles ahead of it, the flows and a route of several
/// edges: bad values name their key.
#[test]
fn bad_traffic_around_the_leader_names_its_key() {
    let drive = "profile = { kind = \"paper\" }";
    let sumo_leader =
        "profile = { kind = \"paper\" }\ndrive = { kind = \"sumo\", speed_mps = 25.0 }";
    assert_error(
        paper_with(drive, sumo_leader),
        "leader.drive",
        "simulation.plant",
    );
    let on_sumo = |extra: &str| {
        let text = platoon_config::PAPER_TOML
            .replacen("[simulation]", "[simulation]\nplant = \"sumo\"", 1)
            .replacen(drive, sumo_leader, 1)
            + extra;
        parse(&text, Path::new("bad.toml")).map(|_| ())
    };
    assert!(on_sumo("").is_ok());
    assert_error(
        on_sumo("\n[sumo]\nstates = \"model\"\n"),
        "leader.drive",
        "sumo.states",
    );
    assert_error(
        on_sumo("\n[[sumo.ahead]]\ngap_m = -1.0\nspeed_mps = 18.0\n"),
        "sumo.ahead[0].gap_m",
        "> 0",
    );
    assert_error(
        on_sumo("\n[[sumo.flows]]\nfrom = \"ramp\"\nto = \"out\"\nvehicles_per_hour = 0.0\n"),
        "sumo.flows[0].vehicles_per_hour",
        "> 0",
    );
    assert_error(
        on_sumo("\n[sumo]\nedge = \"in\"\nroute = [\"merge\", \"out\"]\nfcd = \"sumo\"\n"),
        "sumo.route",
        "sumo.edge",
    );
    assert_error(
        on_sumo("\n[sumo]\nedge = \"in\"\nroute = [\"in\", \"out\"]\n"),
        "sumo.fcd",
        "fcd = \"sumo\"",
    );
}

/// configs/truck-car.toml with `from` replaced by `to`, parsed as bad.toml.
fn truck_car_with(from: &str, to: &str) -> Result<(), ConfigError> {
    let text = std::fs::read_to_string(configs_dir().join("truck-car.toml")).unwrap();
    assert!(
        text.contains(from),
        "truck-car.toml no longer contains {from:?}"
    );
    parse(&text.replacen(from, to, 1), Path::new("bad.toml")).map(|_| ())
}

#[test]
fn vehicle_classes_are_checked_with_the_key_and_line_named() {
    let members = r#"members = ["car", "car", "truck", "car", "car"]"#;
    assert_error(
        truck_car_with(members, r#"members = ["car", "car", "bus", "car", "car"]"#),
        "platoon.members[2]",
        "unknown vehicle class \"bus\"",
    );
    assert_error(
        truck_car_with(members, r#"members = ["car", "truck", "car", "car"]"#),
        "platoon.members",
        "lists 4 vehicles but platoon.followers = 4 needs 5",
    );
    assert_error(
        truck_car_with("tau_range_s = [0.6, 1.0]", "tau_range_s = [0.9, 1.0]"),
        "vehicle_classes.truck.tau_range_s",
        "does not contain the lag of follower 2",
    );
    assert_error(
        truck_car_with("accel_max_mps2 = 3.0", "accel_max_mps2 = 1.0"),
        "leader.profile",
        "more than its class \"car\" allows",
    );
    assert_error(
        truck_car_with("length_m = 12.0", "length_m = -12.0"),
        "vehicle_classes.truck.length_m",
        ">= 0",
    );
    assert_error(
        truck_car_with(members, "# no members"),
        "vehicle_classes.car",
        "platoon.members assigns none",
    );
    assert_error(
        truck_car_with("tau_s = 0.8", "tau_s = 0.8\ntau = { kind = \"paper\" }"),
        "vehicle_classes.truck.tau",
        "not both",
    );
    assert_error(
        truck_car_with(
            "tau = { kind = \"paper\" }       # unused",
            "tau_per_vehicle = [{ kind = \"paper\" }, { kind = \"paper\" }, { kind = \"paper\" }, { kind = \"paper\" }]\ntau = { kind = \"paper\" } #",
        ),
        "plant.tau_per_vehicle",
        "give it in one place",
    );
    // The error names the line of the key.
    let e = truck_car_with("tau_range_s = [0.6, 1.0]", "tau_range_s = [0.9, 1.0]").unwrap_err();
    let text = std::fs::read_to_string(configs_dir().join("truck-car.toml")).unwrap();
    let line = text
        .lines()
        .position(|l| l.starts_with("tau_range_s = [0.6, 1.0]"))
        .unwrap()
        + 1;
    assert!(
        e.to_string().starts_with(&format!("bad.toml:{line}:")),
        "{e}"
    );
    // A field law keeps one vehicle length.
    assert_error(
        truck_car_with(
            "gain = [1.5751, 5.4977, 4.2091]\nbeta1 = 5790.26\nbeta2 = 5.62",
            "law = \"ploeg\"",
        ),
        "platoon.members",
        "keeps one vehicle length",
    );
}

/// `[security]`: absent, no security; present, the controllers sign and verify with its
/// settings; bad values name their key.
#[test]
fn security_resolves_and_bad_values_name_their_key() {
    let with = |keys: &str| {
        let text = format!("{}\n[security]\n{keys}", platoon_config::PAPER_TOML);
        parse(&text, Path::new("bad.toml")).map(|(_, s)| s)
    };
    let (_, plain) = parse(platoon_config::PAPER_TOML, Path::new("paper.toml")).unwrap();
    assert_eq!(plain.control.security, None);
    let s = with("").unwrap().control.security.unwrap();
    assert_eq!(s, platoon_control::SecurityParams::default());
    assert_eq!(
        (
            s.certificate_period_ms,
            s.freshness_ms,
            s.pseudonym_change_ms
        ),
        (1000, 1000, 0)
    );
    let s = with("policy = \"on_demand\"\npseudonym_change_s = 60.0\nseed = 7\n")
        .unwrap()
        .control
        .security
        .unwrap();
    assert_eq!(s.policy, platoon_control::SecurityPolicy::OnDemand);
    assert_eq!((s.pseudonym_change_ms, s.seed), (60_000, 7));
    assert_error(
        with("certificate_period_s = 0.0\n").map(|_| ()),
        "security.certificate_period_s",
        "",
    );
    assert_error(
        with("pseudonym_change_s = -1.0\n").map(|_| ()),
        "security.pseudonym_change_s",
        ">= 0",
    );
    assert_error(
        with("freshness_s = 0.0005\n").map(|_| ()),
        "security.freshness_s",
        "milliseconds",
    );
    assert!(with("policy = \"sometimes\"\n").is_err());
    assert!(with("bogus = 1\n").is_err());
}

/// `[security.reports]`: its defaults (the authority's documented rule), a false report
/// campaign, and bad values named by key; reports need a detector.
#[test]
fn security_reports_resolve_and_bad_values_name_their_key() {
    let with = |keys: &str| {
        let text = format!(
            "{}\n[maneuvers]\n\n[detection.residual]\n\n[security]\n[security.reports]\n{keys}",
            platoon_config::PAPER_TOML
        );
        parse(&text, Path::new("bad.toml")).map(|(_, s)| s)
    };
    let r = with("").unwrap().control.security.unwrap().reports.unwrap();
    assert_eq!(r, platoon_control::security::ReportParams::default());
    assert_eq!(
        (r.latency_ms, r.quorum, r.window_ms, r.every_ms, r.loss),
        (100, 2, 5000, 1000, 0.0)
    );
    let r = with(
        "quorum = 3\n[security.reports.false_reports]\nreporter = 3\naccused = 1\nstart_s = 5.0\n",
    )
    .unwrap()
    .control
    .security
    .unwrap()
    .reports
    .unwrap();
    let f = r.false_reports.unwrap();
    assert_eq!((r.quorum, f.reporter.0, f.accused.0), (3, 3, 1));
    assert_eq!((f.start_ms, f.end_ms), (5000, u64::MAX));
    let cases = [
        ("loss = 1.0\n", "security.reports.loss", "[0, 1)"),
        ("quorum = 0\n", "security.reports.quorum", ">= 1"),
        ("window_s = 0.0\n", "security.reports.window_s", ""),
        ("latency_s = 0.0001\n", "security.reports.latency_s", "milliseconds"),
        (
            "[security.reports.false_reports]\nreporter = 9\naccused = 1\n",
            "security.reports.false_reports.reporter",
            "does not exist",
        ),
        (
            "[security.reports.false_reports]\nreporter = 2\naccused = 2\n",
            "security.reports.false_reports.accused",
            "itself",
        ),
        (
            "[security.reports.false_reports]\nreporter = 2\naccused = 1\nstart_s = 5.0\nend_s = 4.0\n",
            "security.reports.false_reports.end_s",
            "after start_s",
        ),
    ];
    for (keys, key, says) in cases {
        assert_error(with(keys).map(|_| ()), key, says);
    }
    // Without a detector nothing flags, without maneuvers nobody can be ejected: reports are
    // config errors.
    for (extra, says) in [
        ("[maneuvers]\n", "detector"),
        ("[detection.residual]\n", "[maneuvers]"),
    ] {
        let text = format!(
            "{}\n{extra}\n[security]\n[security.reports]\n",
            platoon_config::PAPER_TOML
        );
        assert_error(
            parse(&text, Path::new("bad.toml")).map(|_| ()),
            "security.reports",
            says,
        );
    }
}

/// `[security.group]`: `maneuvers` by default, `all` on request; `maneuvers` without
/// `[maneuvers]` (nothing to tag) and a group key with a merge or a split (not modelled) are
/// config errors naming their key; an unknown `mac` is refused.
#[test]
fn a_group_key_resolves_and_bad_uses_name_their_key() {
    use platoon_control::group_key::{GroupMac, GroupParams};
    let with = |extra: &str, keys: &str| {
        let text = format!(
            "{}
{extra}
[security]
[security.group]
{keys}",
            platoon_config::PAPER_TOML
        );
        parse(&text, Path::new("bad.toml")).map(|(_, s)| s.control.security.unwrap().group)
    };
    assert_eq!(
        with("[maneuvers]\n", "").unwrap(),
        Some(GroupParams {
            mac: GroupMac::Maneuvers
        })
    );
    assert_eq!(
        with("", "mac = \"all\"\n").unwrap(),
        Some(GroupParams { mac: GroupMac::All })
    );
    assert_error(
        with("", "").map(|_| ()),
        "security.group.mac",
        "[maneuvers]",
    );
    let merge = "[maneuvers]\n[maneuvers.merge]\nhead = 3\nat_s = 5.0\n";
    assert_error(
        with(merge, "").map(|_| ()),
        "security.group",
        "not modelled",
    );
    assert!(with("[maneuvers]\n", "mac = \"some\"\n").is_err());
}

/// `[security]` on the 802.11p channel: the model's packets carry what signing adds on the
/// air (the standards' overhead, the certificate on its share of packets); without it, as
/// configured. A packet that signing would push past 802.11's largest names its key.
#[test]
fn security_enlarges_the_radio_models_packets() {
    let text = std::fs::read_to_string(configs_dir().join("density.toml")).unwrap();
    let size = |text: &str| {
        let (_, s) = parse(text, Path::new("bad.toml")).unwrap();
        let radio = s.radio.unwrap();
        (radio.family.params().packet_bytes, s.control.security)
    };
    let (plain, none) = size(&text);
    assert_eq!((plain, none), (190, None));
    let (signed, security) = size(&format!("{text}\n[security]\n"));
    let beacon_hz = {
        let (_, s) = parse(&text, Path::new("bad.toml")).unwrap();
        s.radio.unwrap().family.params().beacon_hz
    };
    let overhead = security.unwrap().mean_overhead_bytes(beacon_hz);
    assert_eq!(signed, 190 + overhead);
    assert!((94..=219).contains(&overhead), "{overhead}");
    // The config ends in [channel.radio].
    assert!(text.trim_end().ends_with("beacon_hz = 10.0"));
    let big = format!("{text}packet_bytes = 2300\n");
    assert_eq!(size(&big).0, 2300);
    assert_error(
        parse(&format!("{big}\n[security]\n"), Path::new("bad.toml")).map(|_| ()),
        "channel.radio.packet_bytes",
        "2304",
    );
}
