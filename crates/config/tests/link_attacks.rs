//! The link attacks in config files: the state-altering kinds, outsider, insider or thief,
//! their keys checked by name, and the resolved config saying whom an attack acts as only
//! where the config said it.
use platoon_attacks::channel::{ActsAs, LinkAttackKind};
use platoon_config::{parse, to_toml, PAPER_TOML};
use platoon_model::VehicleId;
use std::path::Path;

const KINDS: &str = r#"
[[channel.attacks]]
kind = "random_offset"
std = [0.5, 0.1, 0.0]

[[channel.attacks]]
kind = "drift"
senders = [2]
start_s = 10.0
rate = [0.05, 0.0, 0.0]
insider = true

[[channel.attacks]]
kind = "feigned_braking"
accel_mps2 = -6.0
acts_as = "insider"

[[channel.attacks]]
kind = "accel_scale"
factor = 2.5
insider = false

[[channel.attacks]]
kind = "forged_head"
senders = [1]

[[channel.attacks]]
kind = "forge_maneuver"
message = "leave_notice"
senders = [2]
acts_as = "thief"
key_of = 4
"#;

fn paper_plus(extra: &str) -> Result<(platoon_config::Config, platoon_sim::Scenario), String> {
    parse(&format!("{PAPER_TOML}\n{extra}"), Path::new("bad.toml"))
        .map_err(|e| format!("{}: {}", e.key, e.message))
}

#[test]
fn the_state_altering_kinds_load_as_outsiders_or_insiders() {
    let (config, scenario) = paper_plus(KINDS).unwrap();
    let got: Vec<(LinkAttackKind, ActsAs)> = scenario
        .link_attacks
        .iter()
        .map(|a| (a.kind.clone(), a.acts_as))
        .collect();
    use ActsAs::{Insider, Outsider};
    assert_eq!(
        got,
        [
            (
                LinkAttackKind::RandomOffset {
                    std: [0.5, 0.1, 0.0]
                },
                Outsider
            ),
            (
                LinkAttackKind::Drift {
                    rate: [0.05, 0.0, 0.0]
                },
                Insider
            ),
            (LinkAttackKind::FeignedBraking { accel: -6.0 }, Insider),
            (LinkAttackKind::AccelScale { factor: 2.5 }, Outsider),
            (LinkAttackKind::ForgedHead, Outsider),
            (
                LinkAttackKind::ForgeManeuver {
                    message: platoon_maneuver::MessageKind::LeaveNotice
                },
                ActsAs::Thief {
                    key_of: VehicleId(4)
                }
            ),
        ]
    );
    assert!(got.iter().all(|(k, _)| k.alters_state()));
    // The resolved config says whom an attack acts as where the config did, and reads back
    // the same.
    let text = to_toml(&config);
    assert_eq!(text.matches("insider = true").count(), 1, "{text}");
    assert_eq!(text.matches("acts_as = \"insider\"").count(), 1, "{text}");
    assert_eq!(text.matches("acts_as = \"thief\"").count(), 1, "{text}");
    assert_eq!(text.matches("key_of = 4").count(), 1, "{text}");
    let (again, _) = parse(&text, Path::new("resolved.toml")).unwrap();
    assert_eq!(again, config);
}

#[test]
fn bad_keys_of_the_new_kinds_are_named() {
    let cases = [
        (
            "kind = \"random_offset\"\nstd = [0.5, -0.1, 0.0]",
            "channel.attacks[0].std: must be >= 0",
        ),
        (
            "kind = \"drift\"\nrate = [0.0, nan, 0.0]",
            "channel.attacks[0].rate: must be finite",
        ),
        (
            "kind = \"feigned_braking\"\naccel_mps2 = inf",
            "channel.attacks[0].accel_mps2: must be a finite number",
        ),
        (
            "kind = \"accel_scale\"\nfactor = nan",
            "channel.attacks[0].factor: must be a finite number",
        ),
        (
            "kind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\ninsider = true\nreceivers = [2]",
            "channel.attacks[0].insider: an insider's broadcast reaches every receiver alike",
        ),
        (
            "kind = \"bernoulli\"\nloss = 0.1\ninsider = true",
            "channel.attacks[0].insider: ",
        ),
        (
            "kind = \"feigned_braking\"",
            "channel.attacks[0].accel_mps2: ",
        ),
        (
            "kind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\nacts_as = \"insider\"\nreceivers = [2]",
            "channel.attacks[0].acts_as: an insider's broadcast reaches every receiver alike",
        ),
        (
            "kind = \"replay\"\nlag_s = 0.5\nacts_as = \"thief\"\nkey_of = 1",
            "channel.attacks[0].acts_as: a `replay` attack alters nothing a key could sign",
        ),
        (
            "kind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\nacts_as = \"thief\"",
            "channel.attacks[0].key_of: a thief signs with a member's stolen key",
        ),
        (
            "kind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\nacts_as = \"thief\"\nkey_of = 9",
            "channel.attacks[0].key_of: vehicle 9 does not exist",
        ),
        (
            "kind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\nkey_of = 1",
            "channel.attacks[0].key_of: only a thief",
        ),
        (
            "kind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\ninsider = true\nacts_as = \"thief\"\nkey_of = 1",
            "channel.attacks[0].acts_as: \"thief\" contradicts `insider = true`",
        ),
        (
            "kind = \"false_data\"\noffset = [1.0, 0.0, 0.0]\nacts_as = \"ghost\"",
            "channel.attacks[0].acts_as: ",
        ),
    ];
    for (attack, want) in cases {
        let e = paper_plus(&format!("[[channel.attacks]]\n{attack}\n")).unwrap_err();
        assert!(e.starts_with(want), "{attack}: {e}");
    }
}
