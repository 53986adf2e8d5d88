use super::*;
use platoon_config::{DosConfig, LinkKindConfig, RuleConfig};

fn parse(text: &str) -> Result<Campaign, ConfigError> {
    Campaign::parse(text, Path::new("test.toml"), None)
}

fn config(c: &Cell) -> platoon_config::Config {
    toml::from_str(c.config.as_ref().unwrap()).unwrap()
}

#[test]
fn axes_cross_with_the_first_slowest_and_zipped_axes_advance_together() {
    let c = parse(
        r#"
        [[axes]]
        key = "trigger.rule"
        values = ["dynamic", "static"]
        [[axes]]
        key = "control.beta2"
        values = [1.0, 2.0, 3.0]
        zip = "w"
        [[axes]]
        key = "control.beta1"
        range = { from = 100, to = 300, step = 100 }
        zip = "w"
        "#,
    )
    .unwrap();
    assert_eq!(c.dims, vec![2, 3]);
    assert_eq!(c.cells.len(), 6);
    let got: Vec<(String, f64, f64)> = c
        .cells
        .iter()
        .map(|cell| {
            let k = config(cell);
            (
                k.trigger.rule.name().to_string(),
                k.control.paper_law().beta1,
                k.control.paper_law().beta2,
            )
        })
        .collect();
    assert_eq!(got[0], ("dynamic".into(), 100.0, 1.0));
    assert_eq!(got[2], ("dynamic".into(), 300.0, 3.0));
    assert_eq!(got[3], ("static".into(), 100.0, 1.0));
    // The static rule's cells lost the dynamic rule's parameters instead of failing.
    assert!(c.cells.iter().all(|cell| cell.config.is_ok()));
    assert_eq!(config(&c.cells[3]).trigger.rule, RuleConfig::Static {});
    assert!(matches!(
        config(&c.cells[0]).trigger.rule,
        RuleConfig::Dynamic { phi: 0.33, .. }
    ));
}

#[test]
fn ranges_give_tidy_floats_and_integers() {
    let r = |from: &str, to: &str, step: &str| {
        let spec: Range =
            toml::from_str(&format!("from = {from}\nto = {to}\nstep = {step}\n")).unwrap();
        expand_range(&spec).unwrap()
    };
    let f = r("0.0", "0.5", "0.1");
    assert_eq!(f.len(), 6);
    assert_eq!(f[3].as_float(), Some(0.3));
    assert_eq!(f[5].as_float(), Some(0.5));
    let i = r("4", "16", "4");
    assert_eq!(
        i.iter()
            .map(|v| v.as_integer().unwrap())
            .collect::<Vec<_>>(),
        vec![4, 8, 12, 16]
    );
    let spec: Range = toml::from_str("from = 1.0\nto = 2.0\ncount = 3\n").unwrap();
    let c = expand_range(&spec).unwrap();
    assert_eq!(c[1].as_float(), Some(1.5));
    let spec: Range = toml::from_str("from = 1.0\nto = 2.0\n").unwrap();
    assert!(expand_range(&spec).unwrap_err().contains("step"));
}

#[test]
fn the_dos_window_puts_one_interval_in_each_cell_and_keeps_the_bounds() {
    let c = parse(
        r#"
        [dos_window]
        onset_s = { from = 0.0, to = 10.0, step = 5.0 }
        duration_s = [0.5, 2.0]
        "#,
    )
    .unwrap();
    assert_eq!(c.cells.len(), 6);
    let k = config(&c.cells[5]);
    assert_eq!(
        k.attack.kind,
        DosConfig::Intervals {
            intervals: vec![[10.0, 2.0]]
        }
    );
    assert!(k.attack.assumption2.is_some(), "the base's bounds are kept");
    assert_eq!(c.columns[0].name, "dos.onset_s");
}

#[test]
fn monte_carlo_seeds_depend_on_the_campaign_seed_and_sample_only() {
    let text = |seed: u64| {
        format!(
            r#"
            seed = {seed}
            [[axes]]
            key = "trigger.rule"
            values = ["dynamic", "static"]
            [monte_carlo]
            samples = 3
            dos = {{ T1 = 2.0, T2 = 9.46, D1 = 6.0, D2 = 11.33, min_gap_s = 2.0, max_gap_s = 10.0, min_duration_s = 0.5, max_duration_s = 2.0 }}
            loss = [0.0, 0.2]
            tau_s = [0.34, 0.82]
            position_jitter_m = 0.5
            speed_jitter_mps = 0.2
            "#
        )
    };
    let a = parse(&text(7)).unwrap();
    let b = parse(&text(7)).unwrap();
    let other = parse(&text(8)).unwrap();
    assert_eq!(a.cells.len(), 6);
    assert_eq!(a.drawn_columns, vec!["mc.loss", "mc.tau_s"]);
    for (x, y) in a.cells.iter().zip(&b.cells) {
        assert_eq!(x.config, y.config, "the same file gives the same cells");
        assert_eq!(x.hash, y.hash);
    }
    // Sample s draws the same in both rules (common random numbers), differently across s.
    assert_eq!(a.cells[1].seed, a.cells[4].seed);
    assert_eq!(a.cells[1].drawn, a.cells[4].drawn);
    assert_ne!(a.cells[0].seed, a.cells[1].seed);
    assert_ne!(a.cells[0].seed, other.cells[0].seed);
    let k = config(&a.cells[1]);
    assert_eq!(k.attack.kind.name(), "random");
    assert_eq!(
        k.channel.attacks.last().unwrap().kind,
        LinkKindConfig::Bernoulli {
            loss: a.cells[1].drawn[0]
        }
    );
    let states = k.platoon.initial_states.unwrap();
    let paper = [8.0, -1.0, -9.5, -19.0];
    for (i, p) in paper.iter().enumerate() {
        let moved = (states[i + 1][0] - p).abs();
        assert!(
            moved <= 0.5 && moved > 0.0,
            "follower {} moved {moved}",
            i + 1
        );
    }
    assert_eq!(states[0], [20.0, 15.0, 0.0], "the leader is not jittered");
    // --samples overrides the count.
    let quick = Campaign::parse(&text(7), Path::new("t.toml"), Some(1)).unwrap();
    assert_eq!(quick.cells.len(), 2);
    assert_eq!(quick.cells[0].config, a.cells[0].config);
}

#[test]
fn followers_is_an_axis_with_a_generated_formation() {
    let c = parse(
        r#"
        set = { "platoon.formation" = { position_jitter_m = 0.0 }, "topology.preset" = "pf" }
        [[axes]]
        key = "platoon.followers"
        values = [4, 100]
        "#,
    )
    .unwrap();
    assert!(
        c.cells.iter().all(|cell| cell.config.is_ok()),
        "{:?}",
        c.cells[1].config
    );
    assert_eq!(c.cells[1].followers, 100);
    assert_eq!(c.max_followers(), 100);
    // Without a formation, 100 followers cannot use the paper's five listed states.
    let c = parse("[[axes]]\nkey = \"platoon.followers\"\nvalues = [4, 8]\n").unwrap();
    assert!(c.cells[0].config.is_ok());
    let e = c.cells[1].config.as_ref().unwrap_err();
    assert!(
        e.contains("platoon.initial_states") && e.contains("formation"),
        "{e}"
    );
}

#[test]
fn bad_campaign_files_name_the_line_and_key() {
    let e = parse("[[axes]]\nkey = \"trigger.rulez\"\nvalues = [\"static\"]\n").unwrap_err();
    assert_eq!(e.line, Some(2), "{e}");
    assert!(e.to_string().contains("rulez"), "{e}");
    let e = parse("[[axes]]\nkey = \"platoon.followers\"\nvalues = [4.5]\n").unwrap_err();
    assert!(e.to_string().contains("platoon.followers"), "{e}");
    let e = parse("samplez = 3\n").unwrap_err();
    assert_eq!(e.line, Some(1));
    assert!(e.message.contains("unknown field"), "{e}");
    let e = parse("metrics = [\"max_spacing_error_m\", \"fun\"]\n").unwrap_err();
    assert!(e.message.contains("`fun`"), "{e}");
    let e = parse(
        "[[axes]]\nkey = \"control.beta1\"\nvalues = [1.0, 2.0]\nzip = \"a\"\n[[axes]]\nkey = \"control.beta2\"\nvalues = [1.0]\nzip = \"a\"\n",
    )
    .unwrap_err();
    assert!(e.message.contains("equal lengths"), "{e}");
    let e = parse("base = \"nowhere.toml\"\n").unwrap_err();
    assert_eq!(e.key, "base");
    let e = parse("[[axes]]\nkey = \"simulation.plant\"\nvalues = [\"sumo\"]\n").unwrap_err();
    assert_eq!(e.key, "transport", "{e}");
    let e = parse("[[axes]]\nkey = \"channel.attacks[0].loss\"\nvalues = [0.1]\n").unwrap_err();
    assert!(e.message.contains("0 entries"), "{e}");
}

#[test]
fn invalid_values_fail_their_cells_only() {
    let c = parse("[[axes]]\nkey = \"simulation.dt_s\"\nvalues = [0.01, 0.0]\n").unwrap();
    assert!(c.cells[0].config.is_ok());
    let e = c.cells[1].config.as_ref().unwrap_err();
    assert!(e.starts_with("key `simulation.dt_s`"), "{e}");
    assert_ne!(c.cells[0].hash, c.cells[1].hash);
}

#[test]
fn the_hash_changes_with_the_config_and_the_transport() {
    let a = parse("[[axes]]\nkey = \"control.beta2\"\nvalues = [1.0, 2.0]\n").unwrap();
    assert_ne!(a.cells[0].hash, a.cells[1].hash);
    let b =
        parse("transport = \"iceoryx2\"\n[[axes]]\nkey = \"control.beta2\"\nvalues = [1.0, 2.0]\n")
            .unwrap();
    assert_eq!(a.cells[0].config, b.cells[0].config);
    assert_ne!(a.cells[0].hash, b.cells[0].hash);
    assert_eq!(a.cells[0].dir_name(2), "c0000");
}

#[test]
fn sumo_traffic_fails_a_cell_on_the_native_plant() {
    // The native plant would run the cell without it: the cell fails, naming the key.
    let c = parse("[[axes]]\nkey = \"sumo.background_vehicles\"\nvalues = [0, 5]\n").unwrap();
    assert!(c.cells[0].config.is_ok());
    let e = c.cells[1].config.as_ref().unwrap_err();
    assert!(e.starts_with("key `sumo.background_vehicles`"), "{e}");
}
