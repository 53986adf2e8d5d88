//! The typed tables: each selector (`rule`, `kind`, `spacing_policy`, `preset`) is an enum whose
//! variants hold their own keys; errors still name the file, the line and the key; every
//! default reaches the resolved config; older spellings still load.
use platoon_config::{
    parse, to_toml, Config, ConfigError, DosConfig, LinkKindConfig, OutputFile, OutputFormat,
    PlantKind, RuleConfig, SpacingConfig, TopologyConfig, PAPER_TOML,
};
use std::path::Path;

fn paper_with(from: &str, to: &str) -> Result<(Config, platoon_sim::Scenario), ConfigError> {
    assert!(PAPER_TOML.contains(from), "the paper config lacks {from:?}");
    parse(&PAPER_TOML.replacen(from, to, 1), Path::new("bad.toml"))
}

fn paper_plus(extra: &str) -> Result<(Config, platoon_sim::Scenario), ConfigError> {
    parse(&format!("{PAPER_TOML}\n{extra}"), Path::new("bad.toml"))
}

/// The 1-based line of the first line of `text` that starts with `start`.
fn line_of(text: &str, start: &str) -> usize {
    text.lines().position(|l| l.starts_with(start)).unwrap() + 1
}

#[track_caller]
fn assert_error(
    result: Result<(Config, platoon_sim::Scenario), ConfigError>,
    key: &str,
    line: usize,
    words: &str,
) {
    let e = result.expect_err("the config should be rejected");
    let shown = e.to_string();
    assert_eq!(e.key, key, "{shown}");
    assert_eq!(e.line, Some(line), "{shown}");
    assert!(
        shown.starts_with(&format!("bad.toml:{line}: key `{key}`: ")),
        "{shown}"
    );
    assert!(shown.contains(words), "{shown} should say {words:?}");
}

#[test]
fn errors_in_a_tagged_table_name_the_key_at_fault_and_its_line() {
    let trigger = line_of(PAPER_TOML, "[trigger]");
    let rule = line_of(PAPER_TOML, "rule =");
    let phi = line_of(PAPER_TOML, "phi =");
    assert_error(
        paper_with("rule = \"dynamic\"", "rule = \"dymanic\""),
        "trigger.rule",
        rule,
        "unknown rule \"dymanic\"; use dynamic, static, mixed, periodic or cam",
    );
    assert_error(
        paper_with("phi = 0.33", "phi = 0.33\nmu = 1.0"),
        "trigger.mu",
        phi + 1,
        "is not used with rule = \"dynamic\"; it is only used with rule = \"mixed\"",
    );
    assert_error(
        paper_with("phi = 0.33", "phi = \"x\""),
        "trigger.phi",
        phi,
        "invalid type: string \"x\", expected f64",
    );
    assert_error(
        paper_with("phi = 0.33\n", ""),
        "trigger.phi",
        trigger,
        "missing: required with rule = \"dynamic\"",
    );
    assert_error(
        paper_with("h_s = 0.02\n", ""),
        "trigger.h_s",
        trigger,
        "missing field `h_s`",
    );
    assert_error(
        paper_with("rule = \"dynamic\"", "rule = \"static\""),
        "trigger.eta",
        line_of(PAPER_TOML, "eta ="),
        "only used with rule = \"dynamic\"",
    );
    let preset = line_of(PAPER_TOML, "preset =");
    assert_error(
        paper_with("preset = \"tpsf\"", "preset = \"star\""),
        "topology.preset",
        preset,
        "unknown preset \"star\"; use pf, plf, bpf, tpsf or explicit",
    );
    assert_error(
        paper_with("preset = \"tpsf\"", "preset = \"tpsf\"\npinning = [1.0]"),
        "topology.pinning",
        preset + 1,
        "only used with preset = \"explicit\"",
    );
    let kind = line_of(PAPER_TOML, "kind = \"intervals\"");
    assert_error(
        paper_with("kind = \"intervals\"", "kind = \"intervals\"\nseed = 3"),
        "attack.seed",
        kind + 1,
        "only used with kind = \"random\"",
    );
    assert_error(
        paper_with(
            "tau = { kind = \"paper\" }",
            "tau = { kind = \"paper\", value_s = 1.0 }",
        ),
        "plant.tau.value_s",
        line_of(PAPER_TOML, "tau = {"),
        "only used with kind = \"constant\"",
    );
    let spacing = line_of(PAPER_TOML, "spacing_m =");
    assert_error(
        paper_with("spacing_m = 10.0", "spacing_m = 10.0\nzzz = 1"),
        "platoon.zzz",
        spacing + 1,
        "unknown field `zzz`",
    );
    assert_error(
        paper_with(
            "spacing_m = 10.0",
            "spacing_m = 10.0\nspacing_policy = \"time_headway\"\ntime_headway_s = \"long\"",
        ),
        "platoon.time_headway_s",
        spacing + 2,
        "invalid type",
    );
}

#[test]
fn link_attack_errors_name_the_attack_and_the_line() {
    let at = PAPER_TOML.lines().count() + 2;
    assert_error(
        paper_plus("[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.1\n[[channel.attacks]]\nkind = \"delay\"\nloss = 0.1\n"),
        "channel.attacks[1].loss",
        at + 5,
        "is not used with kind = \"delay\"; it is only used with kind = \"bernoulli\"",
    );
    assert_error(
        paper_plus("[[channel.attacks]]\nkind = \"bernoulli\"\nloss = \"a\"\n"),
        "channel.attacks[0].loss",
        at + 2,
        "invalid type",
    );
    assert_error(
        paper_plus("[[channel.attacks]]\nkind = \"gilbert_elliott\"\np_good_bad = 0.1\n"),
        "channel.attacks[0].p_bad_good",
        at,
        "missing: required with kind = \"gilbert_elliott\"",
    );
    assert_error(
        paper_plus("[channel]\nattacks = [{ kind = \"replay\", lag_s = 0.1, loss = 0.2 }]\n"),
        "channel.attacks[0].loss",
        at + 1,
        "only used with kind = \"bernoulli\"",
    );
}

#[test]
fn enum_values_are_checked_at_their_key() {
    let at = PAPER_TOML.lines().count() + 2;
    assert_error(
        paper_plus("[output]\nformat = \"xml\"\n"),
        "output.format",
        at + 1,
        "unknown variant `xml`, expected one of `csv`, `parquet`, `auto`",
    );
    assert_error(
        paper_plus("[output]\nfiles = [\"events\", \"plots\"]\n"),
        "output.files[1]",
        at + 1,
        "unknown variant `plots`",
    );
    assert_error(
        paper_plus("[sumo]\ncollision_action = \"explode\"\n"),
        "sumo.collision_action",
        at + 1,
        "unknown variant `explode`",
    );
    assert_error(
        paper_with("dt_s = 0.01", "dt_s = 0.01\nplant = \"unity\""),
        "simulation.plant",
        line_of(PAPER_TOML, "dt_s") + 1,
        "expected `native` or `sumo`",
    );
}

#[test]
fn the_config_holds_enums_not_strings() {
    let (c, _) = paper_with("dt_s = 0.01", "dt_s = 0.01\nplant = \"sumo\"").unwrap();
    assert_eq!(c.simulation.plant, PlantKind::Sumo);
    assert_eq!(c.output.format, OutputFormat::Auto);
    assert_eq!(c.output.files, OutputFile::ALL);
    assert_eq!(c.topology, TopologyConfig::Tpsf {});
    assert_eq!(c.topology.preset(), Some(platoon_topology::Preset::Tpsf));
    assert_eq!(
        c.trigger.rule,
        RuleConfig::Dynamic {
            phi: 0.33,
            rho: 0.5,
            eta: 0.5,
            theta0: 200.0
        }
    );
    assert_eq!(c.platoon.spacing, SpacingConfig::Constant {});
    assert!(matches!(c.attack.kind, DosConfig::Intervals { .. }));
}

/// Every default is in the schema (not applied in validation only with `unwrap_or`), so the
/// resolved config says them.
#[test]
fn the_resolved_config_writes_out_every_default() {
    let (c, _) = paper_plus(
        "[[channel.attacks]]\nkind = \"gilbert_elliott\"\np_good_bad = 0.1\np_bad_good = 0.2\n\
         [[channel.attacks]]\nkind = \"range_jamming\"\nposition_m = 0.0\nradius_m = 5.0\n",
    )
    .unwrap();
    let text = to_toml(&c);
    assert!(text.contains("spacing_policy = \"constant\""), "{text}");
    for default in [
        "start_s = 0.0\nend_s = inf\n",
        "loss_good = 0.0\nloss_bad = 1.0\n",
        "speed_mps = 0.0\n",
    ] {
        assert!(text.contains(default), "{default:?} in {text}");
    }
    assert_eq!(parse(&text, Path::new("r.toml")).unwrap().0, c);
    assert_eq!(
        c.channel.attacks[0].kind,
        LinkKindConfig::GilbertElliott {
            p_good_bad: 0.1,
            p_bad_good: 0.2,
            loss_good: 0.0,
            loss_bad: 1.0
        }
    );

    // Table I's mixed row without mu and alpha.
    let mut mixed = PAPER_TOML.replacen("rule = \"dynamic\"", "rule = \"mixed\"", 1);
    for key in [
        "phi = 0.33\n",
        "rho = 0.5\n",
        "eta = 0.5\n",
        "theta0 = 200.0\n",
    ] {
        assert!(mixed.contains(key), "{key}");
        mixed = mixed.replacen(key, "", 1);
    }
    let (c, _) = parse(&mixed, Path::new("m.toml")).unwrap();
    assert_eq!(
        c.trigger.rule,
        RuleConfig::Mixed {
            mu: 0.0,
            alpha: 0.0
        }
    );
    assert!(to_toml(&c).contains("h_s = 0.02\nmu = 0.0\nalpha = 0.0\n"));

    // A periodic DoS without offset_s.
    let start = PAPER_TOML.find("kind = \"intervals\"").unwrap();
    let end = PAPER_TOML.find("assumption2 =").unwrap();
    let periodic = format!(
        "{}kind = \"periodic\"\nperiod_s = 10.0\nduration_s = 1.0\n{}",
        &PAPER_TOML[..start],
        &PAPER_TOML[end..]
    );
    let (c, _) = parse(&periodic, Path::new("p.toml")).unwrap();
    assert!(to_toml(&c)
        .contains("kind = \"periodic\"\nperiod_s = 10.0\nduration_s = 1.0\noffset_s = 0.0\n"));
}

/// A tagged table is written as before: its selector first, then the keys every variant has,
/// then the variant's own.
#[test]
fn tagged_tables_keep_their_order_when_written() {
    let (c, _) = paper_plus(
        "[[channel.attacks]]\nsenders = [1]\nlag_s = 0.5\nkind = \"replay\"\nend_s = 20.0\n",
    )
    .unwrap();
    let text = to_toml(&c);
    assert!(
        text.contains(
            "[trigger]\nrule = \"dynamic\"\ncheck_period_s = 0.01\nresilient = true\nh_s = 0.02\n\
             phi = 0.33\nrho = 0.5\neta = 0.5\ntheta0 = 200.0\n"
        ),
        "{text}"
    );
    assert!(
        text.contains(
            "[[channel.attacks]]\nkind = \"replay\"\nstart_s = 0.0\nend_s = 20.0\nsenders = [1]\nlag_s = 0.5\n"
        ),
        "{text}"
    );
    assert!(text.contains("[platoon]\nfollowers = 4\nspacing_m = 10.0\nspacing_policy = \"constant\"\nvehicle_length_m = 0.0\n"), "{text}");
}

/// Files written before the selectors were typed: `control.attack_input` (the older name of
/// `fallback.mode`) and resolved configs without the defaults written out load as they did.
#[test]
fn older_spellings_still_load() {
    let gain = "beta2 = 5.62";
    let older = PAPER_TOML
        .replacen(gain, "beta2 = 5.62\nattack_input = \"hold\"", 1)
        .replacen("mode = \"zero\"", "", 1);
    let (c, s) = parse(&older, Path::new("older.toml")).unwrap();
    assert_eq!(c.fallback.mode, Some(platoon_control::FallbackMode::Hold));
    assert_eq!(
        c.control.attack_input, None,
        "resolved under its current name"
    );
    assert_eq!(s.control.fallback.mode, platoon_control::FallbackMode::Hold);
    let text = to_toml(&c);
    assert!(text.contains("mode = \"hold\"") && !text.contains("attack_input"));
    // Both names, disagreeing: the older one is the error.
    let e = paper_with(gain, "beta2 = 5.62\nattack_input = \"hold\"").unwrap_err();
    assert_eq!(e.key, "control.attack_input", "{e}");
    assert!(e.message.contains("set only fallback.mode"), "{e}");

    // A resolved config of the previous version: no spacing_policy, no start_s/end_s.
    let (now, _) = paper_plus("[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.05\n").unwrap();
    let old = to_toml(&now)
        .replace("spacing_policy = \"constant\"\n", "")
        .replace("start_s = 0.0\nend_s = inf\n", "");
    assert!(
        !old.contains("spacing_policy") && !old.contains("\nend_s"),
        "{old}"
    );
    assert_eq!(parse(&old, Path::new("old.toml")).unwrap().0, now);
}

#[test]
fn a_spacing_policy_converts_to_and_from_the_controls_type() {
    use platoon_control::SpacingPolicy;
    for p in [SpacingPolicy::Constant, SpacingPolicy::TimeHeadway(1.5)] {
        assert_eq!(SpacingConfig::from(p).policy(), p);
    }
    for preset in [
        platoon_topology::Preset::Pf,
        platoon_topology::Preset::Plf,
        platoon_topology::Preset::Bpf,
        platoon_topology::Preset::Tpsf,
    ] {
        assert_eq!(TopologyConfig::from(preset).preset(), Some(preset));
    }
}

/// The paper's scenario turned to one of the field's laws: periodic beacons on plf, the
/// platoon's spacing the law's (`spacing`), plus `extra` keys in `[control]` after `law`.
fn law_config(law: &str, spacing: &str, extra: &str) -> String {
    PAPER_TOML
        .replacen(
            "gain = [4.81, 9.12, 2.97]      # u_i = -K q_i (reading R1)\nbeta1 = 319.38\nbeta2 = 5.62",
            &format!("law = \"{law}\"\n{extra}"),
            1,
        )
        .replacen("preset = \"tpsf\"", "preset = \"plf\"", 1)
        .replacen("spacing_m = 10.0", spacing, 1)
        .replacen(
            "rule = \"dynamic\"",
            "rule = \"periodic\"\nperiod_s = 0.1",
            1,
        )
        .lines()
        .filter(|l| {
            !["phi", "rho", "eta", "theta0", "check_period_s"]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_field_law_takes_its_own_keys_and_is_checked_against_the_platoon() {
    // Accepted, the law's keys written out with their defaults.
    let text = law_config("path_cacc", "spacing_m = 5.0", "");
    let (config, scenario) = parse(&text, Path::new("law.toml")).unwrap();
    assert_eq!(scenario.control.law.name(), "path_cacc");
    let written = to_toml(&config);
    assert!(
        written.contains("[control]\nlaw = \"path_cacc\"\n"),
        "{written}"
    );
    assert!(!written.contains("beta1"), "the paper's keys go: {written}");
    assert!(written.contains("omega_n_radps = 0.2"), "{written}");
    let (again, _) = parse(&written, Path::new("resolved.toml")).unwrap();
    assert_eq!(again, config);

    let bad = |t: String| parse(&t, Path::new("bad.toml")).expect_err("refused");
    // An unknown key of the law, by key.
    let e = bad(law_config(
        "path_cacc",
        "spacing_m = 5.0",
        "xi = 1.0\nomega = 3.0\n",
    ));
    assert_eq!(e.key, "control.omega", "{e}");
    // Another law's key.
    let e = bad(law_config(
        "path_cacc",
        "spacing_m = 5.0",
        "headway_s = 0.6\n",
    ));
    assert_eq!(e.key, "control.headway_s", "{e}");
    assert!(e.to_string().contains("law = \"path_cacc\""), "{e}");
    // The paper's keys with another law.
    let e = bad(law_config("path_cacc", "spacing_m = 5.0", "beta1 = 1.0\n"));
    assert_eq!(e.key, "control.beta1", "{e}");
    assert!(e.to_string().contains("law = \"paper\""), "{e}");
    // A value out of range, by key.
    let e = bad(law_config("path_cacc", "spacing_m = 5.0", "xi = 0.5\n"));
    assert_eq!(e.key, "control.xi", "{e}");
    // The paper's event triggers need the paper's law.
    let e = bad(law_config("path_cacc", "spacing_m = 5.0", "").replacen(
        "rule = \"periodic\"\nperiod_s = 0.1",
        "rule = \"static\"",
        1,
    ));
    assert_eq!(e.key, "trigger.rule", "{e}");
    // The leader out of earshot.
    let e = bad(law_config("path_cacc", "spacing_m = 5.0", "").replacen(
        "preset = \"plf\"",
        "preset = \"pf\"",
        1,
    ));
    assert_eq!(e.key, "topology.preset", "{e}");
    assert!(e.to_string().contains("the leader"), "{e}");
    // The platoon's spacing is not the law's: the message says what to set.
    let e = bad(law_config("path_cacc", "spacing_m = 10.0", ""));
    assert_eq!(e.key, "platoon.spacing_m", "{e}");
    assert!(e.to_string().contains("set spacing_m = 5"), "{e}");
    let e = bad(law_config("ploeg", "spacing_m = 2.0", ""));
    assert_eq!(e.key, "platoon.spacing_policy", "{e}");
    assert!(e.to_string().contains("time_headway_s = 0.5"), "{e}");
    // Ploeg with its time headway is accepted.
    let ok = law_config(
        "ploeg",
        "spacing_m = 2.0\nspacing_policy = \"time_headway\"\ntime_headway_s = 0.5",
        "",
    );
    parse(&ok, Path::new("ploeg.toml")).unwrap();
}

#[test]
fn the_plexe_discretisation_is_for_the_native_plant() {
    let (_, s) = paper_plus("").unwrap();
    assert_eq!(s.discretisation, platoon_model::Discretisation::Exact);
    let (_, s) = paper_with(
        "tau = { kind = \"paper\" }",
        "tau = { kind = \"paper\" }\ndiscretisation = \"plexe\"",
    )
    .unwrap();
    assert_eq!(s.discretisation, platoon_model::Discretisation::Plexe);
    let e = parse(
        &PAPER_TOML
            .replacen(
                "tau = { kind = \"paper\" }",
                "tau = { kind = \"paper\" }\ndiscretisation = \"plexe\"",
                1,
            )
            .replacen("[simulation]", "[simulation]\nplant = \"sumo\"", 1),
        Path::new("bad.toml"),
    )
    .expect_err("refused");
    assert_eq!(e.key, "plant.discretisation", "{e}");
}

#[test]
fn the_cam_rule_serves_every_law_with_etsis_defaults() {
    use platoon_control::{CamRule, TriggerRule};
    let etsi = TriggerRule::Cam(CamRule {
        min_steps: 10,
        max_steps: 100,
        position_m: 4.0,
        speed_mps: 0.5,
    });
    for (law, spacing) in [
        ("path_cacc", "spacing_m = 5.0"),
        (
            "ploeg",
            "spacing_m = 2.0\nspacing_policy = \"time_headway\"\ntime_headway_s = 0.5",
        ),
    ] {
        let text = law_config(law, spacing, "").replacen(
            "rule = \"periodic\"\nperiod_s = 0.1",
            "rule = \"cam\"",
            1,
        );
        let (config, scenario) = parse(&text, Path::new("cam.toml")).unwrap();
        assert_eq!(scenario.control.rule, etsi, "{law}");
        assert!(to_toml(&config).contains("min_interval_s = 0.1"));
        // Every follower sends between once a second and ten times a second.
        let s = platoon_sim::run(scenario, |_| {}).unwrap();
        for v in &s.vehicles[1..] {
            assert!(
                (56..=551).contains(&v.triggers),
                "{law}: {} CAMs",
                v.triggers
            );
        }
    }
    // The paper's law too, and the interval must be whole steps.
    let paper_cam = |extra: &str| {
        let text: Vec<&str> = PAPER_TOML
            .lines()
            .filter(|l| {
                !["phi", "rho", "eta", "theta0"]
                    .iter()
                    .any(|k| l.starts_with(k))
            })
            .collect();
        text.join("\n")
            .replacen("rule = \"dynamic\"", &format!("rule = \"cam\"\n{extra}"), 1)
    };
    let (_, scenario) = parse(&paper_cam(""), Path::new("cam.toml")).unwrap();
    assert_eq!(scenario.control.rule, etsi);
    let e =
        parse(&paper_cam("min_interval_s = 0.015"), Path::new("bad.toml")).expect_err("refused");
    assert_eq!(e.key, "trigger.min_interval_s", "{e}");
}

#[test]
fn consensus_rows_and_cam_keys_are_refused_by_key() {
    let consensus = |extra: &str, preset: &str| {
        law_config(
            "consensus",
            "spacing_m = 15.0\nspacing_policy = \"time_headway\"\ntime_headway_s = 0.8",
            extra,
        )
        .replacen("preset = \"plf\"", preset, 1)
    };
    parse(&consensus("", "preset = \"plf\""), Path::new("ok.toml")).unwrap();
    let bad = |t: String| parse(&t, Path::new("bad.toml")).expect_err("refused");
    // Follower 3 listens to follower 1, whom it does not hear on plf.
    let mut adjacency = vec![vec![0.0; 8]; 8];
    for (i, row) in adjacency.iter_mut().enumerate().skip(1) {
        row[0] = 1.0;
        row[i - 1] = 1.0;
    }
    adjacency[3][1] = 1.0;
    let rows: Vec<String> = adjacency.iter().map(|r| format!("{r:?}")).collect();
    let e = bad(consensus(
        &format!("adjacency = [{}]\n", rows.join(", ")),
        "preset = \"plf\"",
    ));
    assert_eq!(e.key, "control.adjacency", "{e}");
    assert!(e.to_string().contains("row 3 listens to vehicle 1"), "{e}");
    // SUMO's defaults serve 7 followers at most: 9 vehicles need more entries.
    let mut eight = String::new();
    let mut skipping = false;
    for line in consensus("", "preset = \"plf\"").lines() {
        if line.starts_with("initial_states = [") {
            skipping = true;
            eight.push_str("formation = { leader_position_m = 0.0 }\n");
        } else if skipping {
            skipping = line.trim() != "]";
        } else {
            eight.push_str(&line.replacen("followers = 4", "followers = 8", 1));
            eight.push('\n');
        }
    }
    let e = bad(eight);
    assert_eq!(e.key, "control.gains", "{e}");
    // A CAM key out of range, under [trigger].
    let cam = law_config("path_cacc", "spacing_m = 5.0", "").replacen(
        "rule = \"periodic\"\nperiod_s = 0.1",
        "rule = \"cam\"\nposition_m = 0.0",
        1,
    );
    assert_eq!(bad(cam).key, "trigger.position_m");
}

#[test]
fn the_80211p_radio_is_a_channel_model_with_its_own_table() {
    let (config, scenario) = paper_plus("[channel]\nmodel = \"80211p\"\n").unwrap();
    let radio = scenario.radio.as_ref().expect("a radio");
    assert_eq!(
        *radio.family.params(),
        platoon_radio::Params80211p::default()
    );
    assert_eq!(radio.load, platoon_attacks::channel::LoadSource::Scenario);
    assert_eq!((radio.window_steps, radio.dcc.as_ref()), (100, None));
    // The resolved config says the defaults it took.
    let resolved = to_toml(&config);
    for key in [
        "[channel.radio]",
        "load = \"scenario\"",
        "background_beacons = \"fixed\"",
    ] {
        assert!(resolved.contains(key), "{key} in {resolved}");
    }
    // The same parameters share one family of tabulated models.
    let (_, again) = paper_plus("[channel]\nmodel = \"80211p\"\n").unwrap();
    assert!(std::sync::Arc::ptr_eq(
        &radio.family,
        &again.radio.as_ref().unwrap().family
    ));
    // Without the radio none of its keys is written (other configs resolve as before).
    assert!(!to_toml(&paper_plus("").unwrap().0).contains("load"));
    assert!(paper_plus("").unwrap().1.radio.is_none());
    let e = paper_plus("[channel]\nradio = { beacon_hz = 10.0 }\n").expect_err("refused");
    assert_eq!(e.key, "channel.radio", "{e}");
    let e = paper_plus("[channel]\nmodel = \"80211p\"\nradio = { data_rate_mbps = 7.0 }\n")
        .expect_err("refused");
    assert_eq!(e.key, "channel.radio.data_rate_mbps", "{e}");
    let e =
        paper_plus("[channel]\nmodel = \"80211p\"\nradio = { rate = 6.0 }\n").expect_err("refused");
    assert!(e.key.starts_with("channel.radio"), "{e}");
}

#[test]
fn the_radios_load_and_dcc_are_checked_key_by_key() {
    let radio = |extra: &str| paper_plus(&format!("[channel]\nmodel = \"80211p\"\n{extra}"));
    let (_, s) = radio("load_window_s = 0.5\n[channel.dcc]\n").unwrap();
    let r = s.radio.unwrap();
    assert_eq!(r.load, platoon_attacks::channel::LoadSource::Scenario);
    assert_eq!(r.window_steps, 50);
    let (config, s) = radio("load = \"fixed\"\n").unwrap();
    assert_eq!(
        s.radio.unwrap().load,
        platoon_attacks::channel::LoadSource::Fixed
    );
    // The resolved config of a fixed load reads back (the counted load's keys stay out).
    let resolved = to_toml(&config);
    assert!(!resolved.contains("load_window_s"), "{resolved}");
    let dcc = r.dcc.expect("an empty [channel.dcc] turns it on");
    assert_eq!(dcc.t_off_s, vec![0.06, 0.10, 0.18, 0.26, 1.0]);
    let (_, s) = radio("background_beacons = \"platoon\"\n").unwrap();
    assert_eq!(
        s.radio.unwrap().background_beacons,
        platoon_attacks::channel::BackgroundBeacons::Platoon
    );
    for (extra, key) in [
        ("load_window_s = 0.0\n", "channel.load_window_s"),
        (
            "load = \"fixed\"\nload_window_s = 2.0\n",
            "channel.load_window_s",
        ),
        (
            "load = \"fixed\"\nbackground_beacons = \"platoon\"\n",
            "channel.background_beacons",
        ),
        ("load = \"sometimes\"\n", "channel.load"),
        (
            "[channel.dcc]\ncbr_thresholds = [0.5, 0.4]\nt_off_s = [0.1, 0.2, 0.3]\n",
            "channel.dcc.cbr_thresholds[1]",
        ),
        (
            "[channel.dcc]\ncbr_thresholds = [0.5]\nt_off_s = [0.1]\n",
            "channel.dcc.t_off_s",
        ),
        (
            "[channel.dcc]\ncbr_thresholds = [0.5]\nt_off_s = [0.2, 0.1]\n",
            "channel.dcc.t_off_s[1]",
        ),
        (
            "[channel.dcc]\ncbr_thresholds = [1.5]\nt_off_s = [0.1, 0.2]\n",
            "channel.dcc.cbr_thresholds[0]",
        ),
    ] {
        let e = radio(extra).expect_err(extra);
        assert!(e.key.starts_with(key), "{extra}: {e}");
    }
    // The radio's keys without the radio.
    for (extra, key) in [
        ("[channel]\nload = \"fixed\"\n", "channel.load"),
        ("[channel.dcc]\n", "channel.dcc"),
    ] {
        assert_eq!(paper_plus(extra).expect_err(extra).key, key);
    }
}

#[test]
fn jammers_are_transmitters_heard_out_to_their_sensing_radius() {
    use platoon_attacks::jammer::{Behaviour, Placement};
    let (_, s) = paper_plus(
        "[[channel.jammers]]\nposition_m = 300.0\npower_dbm = 10.0\non_s = 1.0\noff_s = 4.0\nstart_s = 2.0\nend_s = 20.0\n",
    )
    .unwrap();
    let p = platoon_radio::Params80211p::default();
    let j = &s.jammers[0];
    assert!(s.link_attacks.is_empty());
    assert_eq!(j.heard_m, p.sensing_radius_m(10.0));
    assert_eq!(j.senses_m, p.sensing_radius_m(p.tx_power_dbm));
    assert_eq!(
        j.behaviour,
        Behaviour::Periodic {
            on_s: 1.0,
            off_s: 4.0
        }
    );
    assert_eq!((j.start_s, j.end_s), (2.0, 20.0));
    // Each behaviour and placement by its keys.
    let one = |extra: &str| paper_plus(extra).unwrap().1.jammers[0];
    let j = one("[[channel.jammers]]\nmember = 2\noffset_m = -5.0\nbehaviour = \"reactive\"\n");
    assert_eq!(j.behaviour, Behaviour::Reactive);
    assert!(matches!(j.placement, Placement::Member { offset_m, .. } if offset_m == -5.0));
    let j = one("[[channel.jammers]]\nposition_m = 0.0\nbehaviour = \"random\"\nmean_on_s = 0.5\nmean_off_s = 2.0\n");
    assert_eq!(
        j.behaviour,
        Behaviour::Random {
            mean_on_s: 0.5,
            mean_off_s: 2.0
        }
    );
    assert_eq!(
        one("[[channel.jammers]]\nposition_m = 0.0\n").behaviour,
        Behaviour::Constant
    );
    let bad = |extra: &str| paper_plus(extra).expect_err("refused");
    let e = bad("[[channel.jammers]]\nposition_m = 0.0\npower_dbm = -200.0\n");
    assert_eq!(e.key, "channel.jammers[0].power_dbm", "{e}");
    let e = bad("[[channel.jammers]]\nposition_m = 0.0\non_s = 1.0\n");
    assert_eq!(e.key, "channel.jammers[0].off_s", "{e}");
    for (extra, key) in [
        ("member = 9", "member"),
        ("background = 0", "background"),
        ("position_m = 0.0\nmember = 1", "position_m"),
        ("speed_mps = 1.0", "position_m"),
        ("member = 1\nspeed_mps = 1.0", "speed_mps"),
        ("position_m = 0.0\noffset_m = 1.0", "offset_m"),
        (
            "position_m = 0.0\nbehaviour = \"random\"\nmean_on_s = 1.0",
            "mean_off_s",
        ),
        (
            "position_m = 0.0\nbehaviour = \"random\"\nmean_on_s = 0.0\nmean_off_s = 1.0",
            "mean_on_s",
        ),
        (
            "position_m = 0.0\nmean_on_s = 1.0\nmean_off_s = 1.0",
            "mean_on_s",
        ),
        (
            "position_m = 0.0\nbehaviour = \"reactive\"\non_s = 1.0\noff_s = 1.0",
            "on_s",
        ),
        ("position_m = 0.0\nbehaviour = \"periodic\"", "on_s"),
    ] {
        let e = bad(&format!("[[channel.jammers]]\n{extra}\n"));
        assert_eq!(e.key, format!("channel.jammers[0].{key}"), "{extra}: {e}");
    }
    let e = bad("[[channel.jammers]]\nposition_m = 0.0\nrange_m = 3.0\n");
    assert!(e.key.starts_with("channel.jammers"), "{e}");
}

#[test]
fn a_jammers_times_and_power_are_bounded_so_a_run_cannot_stall_on_them() {
    for (jammer, key) in [
        (
            "position_m = 0.0\non_s = 1e-17\noff_s = 1.0",
            "channel.jammers[0].on_s",
        ),
        (
            "position_m = 0.0\nbehaviour = \"random\"\nmean_on_s = 1.0\nmean_off_s = 1e-300",
            "channel.jammers[0].mean_off_s",
        ),
        (
            "position_m = 0.0\nstart_s = -1e9",
            "channel.jammers[0].start_s",
        ),
        (
            "position_m = 0.0\npower_dbm = 5000.0",
            "channel.jammers[0].power_dbm",
        ),
    ] {
        let e = paper_plus(&format!("[[channel.jammers]]\n{jammer}\n")).expect_err(jammer);
        assert_eq!(e.key, key, "{jammer}: {e}");
    }
    // One step is enough.
    paper_plus("[[channel.jammers]]\nposition_m = 0.0\non_s = 0.01\noff_s = 0.01\n").unwrap();
}

/// `[sumo]`'s background-traffic keys: absent, a config writes back without them (so the
/// runs of older configs write what they did); present, their ranges are checked.
#[test]
fn sumo_background_lane_changes_and_trucks() {
    let (c, _) = paper_plus("").unwrap();
    assert_eq!(c.sumo.background_lane_changes, None);
    let text = to_toml(&c);
    assert!(!text.contains("background_lane_changes"), "{text}");
    assert!(!text.contains("background_on_platoon_lanes"), "{text}");
    assert!(!text.contains("background_truck_share"), "{text}");
    let (c, _) = paper_plus(
        "[sumo]\nbackground_on_platoon_lanes = true\nbackground_truck_share = 0.25\n\
         background_lane_changes = { assertive = 3.0 }\n",
    )
    .unwrap();
    let lc = c.sumo.background_lane_changes.as_ref().unwrap();
    assert_eq!(
        (lc.assertive, lc.cooperative, lc.speed_gain),
        (3.0, 1.0, 1.0)
    );
    assert!(c.sumo.background_on_platoon_lanes);
    assert_eq!(c.sumo.background_truck_share, 0.25);
    for (extra, key, words) in [
        (
            "background_truck_share = 1.5",
            "sumo.background_truck_share",
            "must be in [0, 1]",
        ),
        (
            "background_lane_changes = { cooperative = 2.0 }",
            "sumo.background_lane_changes.cooperative",
            "must be in [0, 1]",
        ),
        (
            "background_lane_changes = { assertive = 0.0 }",
            "sumo.background_lane_changes.assertive",
            "must be > 0",
        ),
        (
            "background_lane_changes = { speed_gain = -1.0 }",
            "sumo.background_lane_changes.speed_gain",
            "must be >= 0",
        ),
    ] {
        let e = paper_plus(&format!("[sumo]\n{extra}\n")).expect_err(extra);
        assert_eq!(e.key, key, "{e}");
        assert!(e.to_string().contains(words), "{e}");
    }
}
