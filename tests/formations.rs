//! The formations a run visits and their stability certificates (`summary.json`'s
//! `maneuvers.formations`, `platoon_app::formations`): the formations are those the plant
//! drove; each one's linearised loop is the loop the controller and the plant run (checked
//! against a run step by step); every formation of the maneuver configs and of every law's
//! tail join is certified, and a destabilising gain is not.
use crate::common;

use common::maneuvers::run;
use common::{cut_in_config, repo};
use platoon_control::formation_loop::{step_matrix, LoopSpec, STATES};
use platoon_model::VehicleId;
use platoon_sim::Scenario;

fn scenario(text: &str) -> Scenario {
    platoon_config::parse(text, std::path::Path::new("formations.toml"))
        .unwrap()
        .1
}

fn config(name: &str) -> String {
    std::fs::read_to_string(repo().join("configs").join(name)).unwrap()
}

/// The formations of a run in process, certified as `platoon run` certifies them.
fn formations(text: &str) -> Vec<platoon_sim::FormationRecord> {
    let s = scenario(text);
    let mut summary = platoon_sim::run(s.clone(), |_| {}).unwrap();
    platoon_app::formations::certify(&s, &mut summary);
    summary.maneuvers.unwrap().formations
}

/// A formation from a time on: its platoons, each head first.
type Visit<'a> = (f64, &'a [&'a [u16]]);

/// Every formation of the shipped maneuver configs, as the plant drove them (the joiner in the
/// slot it was given, a leaver gone, the merged platoon one, the split one two), each
/// certified: stable at both ends of the lag range, with a common quadratic Lyapunov function
/// decaying at a positive rate.
#[test]
fn every_formation_of_the_maneuver_configs_is_certified() {
    let expected: [(&str, &[Visit]); 5] = [
        (
            "join.toml",
            &[(0.0, &[&[0, 1, 2, 3]]), (26.92, &[&[0, 1, 2, 3, 4]])],
        ),
        (
            "join-middle.toml",
            &[(0.0, &[&[0, 1, 2, 3]]), (27.6, &[&[0, 1, 4, 2, 3]])],
        ),
        (
            "leave.toml",
            &[
                (0.0, &[&[0, 1, 2, 3, 4, 5]]),
                (20.02, &[&[0, 1, 3, 4, 5]]),
                (45.02, &[&[0, 1, 3, 4]]),
            ],
        ),
        (
            "merge.toml",
            &[
                (0.0, &[&[0, 1, 2], &[3, 4, 5]]),
                (27.17, &[&[0, 1, 2, 3, 4, 5]]),
            ],
        ),
        (
            "split.toml",
            &[
                (0.0, &[&[0, 1, 2, 3, 4, 5]]),
                (20.02, &[&[0, 1, 2], &[3, 4, 5]]),
            ],
        ),
    ];
    for (name, want) in expected {
        let got = formations(&config(name));
        let seen: Vec<(f64, Vec<Vec<u16>>)> =
            got.iter().map(|f| (f.t_s, f.platoons.clone())).collect();
        let want: Vec<(f64, Vec<Vec<u16>>)> = want
            .iter()
            .map(|(t, p)| (*t, p.iter().map(|x| x.to_vec()).collect()))
            .collect();
        assert_eq!(seen, want, "{name}");
        for f in &got {
            let c = f.stability.as_ref().unwrap();
            assert_eq!(c.unchecked, None, "{name}: {f:?}");
            assert!(c.spectral_radius.unwrap() < 1.0, "{name}: {f:?}");
            // Every config's members run the PATH CACC: a cascade whose rate is its members'
            // (docs/maneuvers.md), whatever the formation.
            let d = c.decay_per_s.unwrap();
            assert!((d - 0.145).abs() < 0.002, "{name}: {f:?}");
        }
    }
}

/// Every law of the controller seam, before and after its tail join: certified (the
/// consensus law reads vehicles behind it too, so it goes through the one SDP over the whole
/// loop rather than a cascade's blocks). The ACC holds its gap only below its cruise
/// control's set speed (Plexe's ACC takes the smaller of the two commands): at 15 m/s with
/// SUMO's default set speed of 14 m/s it cruises, the gaps drift (an eigenvalue 1) and
/// nothing is certified; with a set speed above the leader's it is.
#[test]
fn every_laws_formations_are_certified() {
    let acc = cut_in_config("acc");
    let acc = &acc[..acc.find("[[cut_ins]]").unwrap()];
    let cruising = platoon_app::formations::check(&scenario(acc), &[vec![0, 1, 2, 3]], 15.0);
    assert!(
        (cruising.spectral_radius.unwrap() - 1.0).abs() < 1e-6,
        "{cruising:?}"
    );
    assert_eq!(cruising.decay_per_s, None, "{cruising:?}");
    // The rates docs/maneuvers.md publishes (1/s).
    let published = [
        ("acc", 0.097),
        ("ploeg", 0.347),
        ("path_cacc", 0.145),
        ("consensus", 0.284),
        ("flatbed", 0.246),
    ];
    for (law, rate) in published {
        let text =
            cut_in_config(law).replace("law = \"acc\"", "law = \"acc\"\ndesired_speed_mps = 40.0");
        let text = &text[..text.find("[[cut_ins]]").unwrap()];
        let s = scenario(text);
        for platoon in [vec![0, 1, 2, 3], vec![0, 1, 2, 3, 4]] {
            let c = platoon_app::formations::check(&s, std::slice::from_ref(&platoon), 15.0);
            assert_eq!(c.unchecked, None, "{law} {platoon:?}: {c:?}");
            assert!(c.spectral_radius.unwrap() < 1.0, "{law} {platoon:?}: {c:?}");
            let d = c.decay_per_s.unwrap();
            assert!((d - rate).abs() < 0.002, "{law} {platoon:?}: {c:?}");
        }
    }
}

/// A gain that makes the loop unstable (Ploeg's CACC pushed away from its gap) is not
/// certified: its spectral radius is above 1 and no decay is claimed.
#[test]
fn an_unstable_gain_is_not_certified() {
    let text = cut_in_config("ploeg");
    let text = &text[..text.find("[[cut_ins]]").unwrap()];
    let bad = text.replace("law = \"ploeg\"", "law = \"ploeg\"\nkp_per_s2 = -0.2");
    assert_ne!(bad, text, "the law's key");
    let c = platoon_app::formations::check(&scenario(&bad), &[vec![0, 1, 2, 3]], 15.0);
    assert_eq!(c.unchecked, None);
    assert!(c.spectral_radius.unwrap() > 1.0, "{c:?}");
    assert_eq!(c.decay_per_s, None);
}

/// The paper's law runs on the one pipeline, so the formations it visits are certified as the
/// field's laws' are, its graph (the cut-in config's `pf`, and `plf`) the preset's pattern on
/// each platoon: before and after a tail join, and both parts of a split; a gain that makes
/// the loop unstable (the position gain's sign flipped) is not certified.
#[test]
fn the_papers_law_formations_are_certified_and_an_unstable_gain_is_not() {
    let text = cut_in_config("paper");
    let text = &text[..text.find("[[cut_ins]]").unwrap()];
    for preset in ["pf", "plf"] {
        let text = text.replace("preset = \"pf\"", &format!("preset = \"{preset}\" #"));
        let s = scenario(&text);
        for platoons in [
            vec![vec![0, 1, 2, 3]],
            vec![vec![0, 1, 2, 3, 4]],
            vec![vec![0, 1], vec![2, 3, 4]],
        ] {
            let c = platoon_app::formations::check(&s, &platoons, 15.0);
            assert_eq!(c.unchecked, None, "{preset} {platoons:?}: {c:?}");
            assert!(
                c.spectral_radius.unwrap() < 1.0,
                "{preset} {platoons:?}: {c:?}"
            );
            assert!(c.decay_per_s.unwrap() > 0.0, "{preset} {platoons:?}: {c:?}");
        }
    }
    let bad = text.replace("gain = [4.81,", "gain = [-4.81,");
    assert_ne!(bad, text, "the paper's gain");
    let c = platoon_app::formations::check(&scenario(&bad), &[vec![0, 1, 2, 3]], 15.0);
    assert_eq!(c.unchecked, None);
    assert!(c.spectral_radius.unwrap() > 1.0, "{c:?}");
    assert_eq!(c.decay_per_s, None);
}

/// The linearised loop is the loop a run closes: a PATH CACC platoon beaconing every step
/// at a constant speed, started off its equilibrium, follows `z[k+1] = Phi z[k]` of its
/// formation step by step (the deviations from the equilibrium trajectory: position, speed,
/// acceleration, the command of the step before), to rounding, for 30 s.
#[test]
fn the_linearised_loop_is_the_loop_a_run_closes() {
    let text = config("join.toml");
    let text = &text[..text.find("[maneuvers]").unwrap()];
    let text = text
        .replace("followers = 4", "followers = 3")
        .replace("    [-124.5, 15.0, 0.0],\n", "")
        .replace("[-20.0, 15.0, 0.0]", "[-19.2, 15.3, 0.1]")
        .replace("[-40.0, 15.0, 0.0]", "[-40.5, 14.9, 0.0]")
        .replace(
            "profile = { kind = \"paper\" }",
            "profile = { kind = \"constant\", speed_mps = 15.0 }",
        )
        .replace(
            "tau = { kind = \"paper\" }",
            "tau = { kind = \"constant\", value_s = 0.5 }",
        )
        .replace("period_s = 0.1", "period_s = 0.01")
        .replace("duration_s = 70.0", "duration_s = 30.0");
    let s = scenario(&text);
    assert_eq!(s.initial.len(), 4, "{text}");
    let (rows, _) = run(s.clone(), |_, _| false);
    let spec = LoopSpec {
        params: &s.control,
        topology: &s.topology,
        discretisation: s.discretisation,
    };
    let platoon: Vec<VehicleId> = (0..4).map(VehicleId).collect();
    let phi = step_matrix(&spec, &[platoon], 15.0, &[0.5; 4]).unwrap();
    let spacing = s.control.spacing;
    let deviation = |k: usize| -> Vec<f64> {
        let step = &rows[4 * k..4 * k + 4];
        (1..4)
            .flat_map(|i| {
                let r = &step[i];
                let last_u = if k == 0 { 0.0 } else { rows[4 * (k - 1) + i].u };
                [
                    r.p - (step[0].p - i as f64 * spacing),
                    r.v - 15.0,
                    r.a,
                    last_u,
                ]
            })
            .collect()
    };
    let mut z = nalgebra::DVector::from_vec(deviation(0));
    let z0 = z.norm();
    assert!(z0 > 0.5, "started off the equilibrium");
    for k in 1..3000 {
        z = &phi * z;
        let seen = deviation(k);
        for (j, (a, b)) in z.iter().zip(&seen).enumerate() {
            assert!(
                (a - b).abs() < 1e-6,
                "step {k}, state {j} (follower {}, {}): linearised {a}, run {b}",
                j / STATES + 1,
                ["p", "v", "a", "u"][j % STATES]
            );
        }
    }
    assert!(z.norm() < 0.1 * z0, "it settles: {z}");
}

/// A cascade's certificate (one SDP per member, then the whole re-checked at once) and the
/// one SDP over the whole loop agree on a formation (PATH CACC, three followers, both ends of
/// a lag range): both certify it, at rates within 10 % of each other; and the maps are block
/// lower triangular (a member reads no vehicle behind it), which is what lets the cascade's
/// way apply.
#[test]
fn a_cascades_certificate_agrees_with_the_whole_sdp() {
    let s = scenario(&config("join.toml"));
    let spec = LoopSpec {
        params: &s.control,
        topology: &s.topology,
        discretisation: s.discretisation,
    };
    let platoon: Vec<VehicleId> = (0..4).map(VehicleId).collect();
    let maps: Vec<_> = [0.3, 0.7]
        .iter()
        .map(|&tau| step_matrix(&spec, std::slice::from_ref(&platoon), 15.0, &[tau; 4]).unwrap())
        .collect();
    let above = (0..maps[0].nrows())
        .flat_map(|r| ((r / STATES + 1) * STATES..maps[0].ncols()).map(move |c| (r, c)))
        .any(|(r, c)| maps.iter().any(|m| m[(r, c)] != 0.0));
    assert!(!above, "no member reads a vehicle behind it");
    let dt = s.dt();
    let cascade = platoon_synthesis::cascade_decay(&maps, dt, STATES).unwrap();
    let whole = platoon_synthesis::common_decay(&maps, dt).unwrap();
    assert!((cascade.spectral_radius - whole.spectral_radius).abs() < 1e-6);
    let (c, w) = (cascade.decay_per_s.unwrap(), whole.decay_per_s.unwrap());
    assert!(c > 0.0 && w > 0.0);
    assert!((c - w).abs() <= 0.1 * c.max(w), "cascade {c}, whole {w}");
}

/// A formation that could not be checked (here: no follower) reads back from its JSON (no
/// NaN written as null where a number is due), and a summary written before formations were
/// recorded still reads.
#[test]
fn an_unchecked_formation_and_an_older_summary_read_back() {
    let s = scenario(&config("join.toml"));
    let c = platoon_app::formations::check(&s, &[vec![0]], 15.0);
    assert_eq!((c.spectral_radius, c.decay_per_s), (None, None));
    assert!(c.unchecked.is_some());
    let mut summary = platoon_sim::run(s.clone(), |_| {}).unwrap();
    let maneuvers = summary.maneuvers.as_mut().unwrap();
    maneuvers.formations[0].stability = Some(c);
    let text = serde_json::to_string(&summary).unwrap();
    let back: platoon_sim::Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(back.maneuvers, summary.maneuvers);
    let mut older: serde_json::Value = serde_json::from_str(&text).unwrap();
    older["maneuvers"]
        .as_object_mut()
        .unwrap()
        .remove("formations");
    let older: platoon_sim::Summary = serde_json::from_value(older).unwrap();
    assert!(older.maneuvers.unwrap().formations.is_empty());
}
