//! Each detector against clean traffic of the paper's manoeuvres (its false alarms) and against
//! the attacks it must catch; the specs' serde; no input panics.

use crate::testkit::{self, DT};
use crate::*;
use platoon_model::{State, VehicleId};
use proptest::prelude::*;
use rand::Rng;

/// One sender and its receiver just behind it, over the paper's run.
struct Pair {
    sender: u16,
    receiver: u16,
    sender_states: Vec<State>,
    receiver_states: Vec<State>,
}

/// The leader heard by follower 1, and follower 1 by follower 2.
fn pairs() -> Vec<Pair> {
    let leader = testkit::leader();
    let f1 = testkit::follower(&leader);
    let f2 = testkit::follower(&f1);
    vec![
        Pair {
            sender: 0,
            receiver: 1,
            sender_states: leader,
            receiver_states: f1.clone(),
        },
        Pair {
            sender: 1,
            receiver: 2,
            sender_states: f1,
            receiver_states: f2,
        },
    ]
}

/// How a run of clean traffic is made and what is forged in it.
#[derive(Clone, Copy)]
struct Traffic {
    /// Gaussian noise on the claims' `[p, v, a]`.
    gaussian: [f64; 3],
    /// Uniform noise within ± this on the claims' `[p, v, a]`.
    uniform: [f64; 3],
    /// A radar (period 5 steps, uniform noise within ±0.05 m and m/s) on the sender.
    radar: bool,
    /// Packets arrive 0 to this many steps late.
    max_delay: u64,
}

const CLEAN: Traffic = Traffic {
    gaussian: [0.0; 3],
    uniform: [0.0; 3],
    radar: false,
    max_delay: 0,
};

/// Counts of one detector over runs: observations tested and flagged, clean and forged.
#[derive(Debug, Default)]
struct Counts {
    clean: u64,
    clean_flagged: u64,
    forged: u64,
    forged_flagged: u64,
    max_clean_score: f64,
}

/// Runs `sut` over `seeds` runs of both pairs of the paper's platoon. Every packet is shown
/// clean (then remembered as the last accepted); with `forge`, before it, a forged copy of it
/// (its claim changed by `forge`, compared with the same genuine last), which is not
/// remembered: each forged packet is an attack's onset.
fn run(
    sut: &mut dyn Detector,
    seeds: std::ops::Range<u64>,
    traffic: Traffic,
    forge: Option<&dyn Fn(State) -> State>,
) -> Counts {
    let mut n = Counts::default();
    for seed in seeds {
        for pair in pairs() {
            let mut rng = testkit::rng(seed * 2 + u64::from(pair.sender));
            let mut last: Option<Last> = None;
            for (i, &s) in testkit::send_steps(&mut rng).iter().enumerate() {
                let mut claim = testkit::noisy(&pair.sender_states[s], traffic.gaussian, &mut rng);
                for (j, u) in traffic.uniform.iter().enumerate() {
                    if *u > 0.0 {
                        claim[j] += rng.gen_range(-u..=*u);
                    }
                }
                let k = (s + rng.gen_range(0..=traffic.max_delay) as usize).min(testkit::STEPS);
                let radar = traffic.radar.then(|| {
                    testkit::radar(
                        &pair.receiver_states,
                        &pair.sender_states,
                        k,
                        5,
                        [0.05, 0.05],
                        &mut rng,
                    )
                });
                let mut inspect = |packet: &platoon_v2v::Packet| {
                    sut.inspect(&Observation {
                        k: k as u64,
                        dt: DT,
                        receiver: VehicleId(pair.receiver),
                        own: pair.receiver_states[k],
                        packet,
                        last,
                        radar,
                    })
                };
                if let Some(forge) = forge {
                    let pk = testkit::packet(pair.sender, i as u32 + 1, s, forge(claim));
                    let v = inspect(&pk);
                    if v.tested() {
                        n.forged += 1;
                        n.forged_flagged += u64::from(v.flagged);
                    }
                }
                let pk = testkit::packet(pair.sender, i as u32 + 1, s, claim);
                let v = inspect(&pk);
                if v.tested() {
                    n.clean += 1;
                    n.clean_flagged += u64::from(v.flagged);
                    n.max_clean_score = n.max_clean_score.max(v.score);
                }
                last = Some(Last::from(&pk));
            }
        }
    }
    n
}

fn residual() -> Residual {
    Residual::new(ResidualParams::default()).unwrap()
}

/// The residual's own noise model, as Gaussian noise on every claim.
fn residual_noise() -> Traffic {
    let p = ResidualParams::default();
    Traffic {
        gaussian: [p.sigma_p_m, p.sigma_v_mps, p.sigma_a_mps2],
        ..CLEAN
    }
}

// ---------------------------------------------------------------------------------------------
// Residual

#[test]
fn the_residual_threshold_is_the_chi_square_3_quantile() {
    // Tables: chi2(3) at 0.999 is 16.266, at 0.95 7.815.
    assert!((residual().threshold() - 16.266).abs() < 1e-3);
    let p = ResidualParams {
        alpha: 0.05,
        ..ResidualParams::default()
    };
    assert!((p.threshold() - 7.815).abs() < 1e-3);
}

#[test]
fn the_residual_is_silent_on_the_papers_manoeuvres_without_noise() {
    let n = run(&mut residual(), 0..10, CLEAN, None);
    assert!(n.clean > 5000, "{n:?}");
    assert_eq!(n.clean_flagged, 0, "{n:?}");
    // The leader's jumps of 2 m/s^2 in acceleration are the largest term: (2 / 0.6)^2 = 11.1.
    assert!(n.max_clean_score < 11.2, "{n:?}");
}

#[test]
fn the_residuals_false_alarm_rate_on_noisy_clean_traffic_is_within_twice_alpha() {
    let mut sut = residual();
    let n = run(&mut sut, 0..40, residual_noise(), None);
    assert!(n.clean >= 20_000, "{n:?}");
    let rate = n.clean_flagged as f64 / n.clean as f64;
    assert!(rate <= 2.0 * sut.params().alpha, "rate {rate}: {n:?}");
}

#[test]
fn the_residual_catches_the_onset_of_a_3_mps_speed_offset() {
    let n = run(
        &mut residual(),
        0..10,
        residual_noise(),
        Some(&|x| x + State::new(0.0, 3.0, 0.0)),
    );
    let rate = n.forged_flagged as f64 / n.forged as f64;
    assert!(rate >= 0.99, "detection rate {rate}: {n:?}");
}

#[test]
fn the_residual_catches_a_feigned_emergency_braking() {
    let n = run(
        &mut residual(),
        0..10,
        residual_noise(),
        Some(&|x| State::new(x[0], x[1], -8.0)),
    );
    let rate = n.forged_flagged as f64 / n.forged as f64;
    assert!(rate >= 0.99, "detection rate {rate}: {n:?}");
}

#[test]
fn the_residual_catches_a_5_m_position_offset() {
    let n = run(
        &mut residual(),
        0..10,
        residual_noise(),
        Some(&|x| x + State::new(5.0, 0.0, 0.0)),
    );
    assert!(n.forged > 5000, "{n:?}");
    assert_eq!(n.forged_flagged, n.forged, "{n:?}");
}

#[test]
fn the_residual_tests_nothing_without_an_earlier_packet() {
    let pk = testkit::packet(0, 1, 10, State::new(0.0, 20.0, 0.0));
    let v = residual().inspect(&testkit::observe(1, State::zeros(), &pk, None, None));
    assert!(!v.flagged && !v.tested());
}

// ---------------------------------------------------------------------------------------------
// Radar cross-check

fn radar_cross() -> RadarCross {
    RadarCross::new(RadarCrossParams::default()).unwrap()
}

/// Radar readings held between measurements every 5 steps, packets up to 3 steps late.
const WITH_RADAR: Traffic = Traffic {
    radar: true,
    max_delay: 3,
    ..CLEAN
};

#[test]
fn the_radar_cross_check_is_silent_on_clean_traffic() {
    let n = run(&mut radar_cross(), 0..10, WITH_RADAR, None);
    assert!(n.clean > 5000, "{n:?}");
    assert_eq!(n.clean_flagged, 0, "{n:?}");
}

#[test]
fn the_radar_cross_check_catches_a_5_m_position_offset_on_every_packet() {
    let n = run(
        &mut radar_cross(),
        0..10,
        WITH_RADAR,
        Some(&|x| x + State::new(5.0, 0.0, 0.0)),
    );
    assert!(n.forged > 5000, "{n:?}");
    assert_eq!(n.forged_flagged, n.forged, "{n:?}");
}

#[test]
fn the_radar_cross_check_catches_a_1_mps_speed_offset_on_every_packet() {
    let n = run(
        &mut radar_cross(),
        0..10,
        WITH_RADAR,
        Some(&|x| x + State::new(0.0, 1.0, 0.0)),
    );
    assert!(n.forged > 5000, "{n:?}");
    assert_eq!(n.forged_flagged, n.forged, "{n:?}");
}

#[test]
fn without_a_radar_reading_the_cross_check_tests_nothing() {
    let n = run(
        &mut radar_cross(),
        0..2,
        CLEAN,
        Some(&|x| x + State::new(50.0, 0.0, 0.0)),
    );
    assert_eq!((n.clean, n.forged), (0, 0));
}

// ---------------------------------------------------------------------------------------------
// Plausibility

fn plausibility() -> Plausibility {
    Plausibility::new(PlausibilityParams::default()).unwrap()
}

#[test]
fn the_plausibility_checks_are_silent_on_clean_traffic() {
    let n = run(&mut plausibility(), 0..10, CLEAN, None);
    assert!(n.clean > 5000, "{n:?}");
    assert_eq!(n.clean_flagged, 0, "{n:?}");
    // With bounded noise of the residual's size on every claim, and late packets.
    let noisy = Traffic {
        uniform: [0.1, 0.1, 0.6],
        max_delay: 3,
        ..CLEAN
    };
    let n = run(&mut plausibility(), 0..10, noisy, None);
    assert!(n.clean > 5000, "{n:?}");
    assert_eq!(n.clean_flagged, 0, "{n:?}");
}

#[test]
fn the_plausibility_checks_catch_a_claimed_120_mps() {
    let n = run(
        &mut plausibility(),
        0..3,
        CLEAN,
        Some(&|x| State::new(x[0], 120.0, x[2])),
    );
    assert!(n.forged > 1500, "{n:?}");
    assert_eq!(n.forged_flagged, n.forged, "{n:?}");
}

#[test]
fn each_plausibility_check_fails_on_its_own_lie() {
    let last = Last {
        step: 100,
        state: State::new(200.0, 20.0, 0.0),
    };
    let own = State::new(176.0, 20.0, 0.0);
    // 10 steps later, genuinely 2 m further.
    let genuine = State::new(202.0, 20.0, 0.0);
    let failures = |claim: State, params: PlausibilityParams| {
        let mut sut = Plausibility::new(params).unwrap();
        let pk = testkit::packet(0, 2, 110, claim);
        sut.failures(&testkit::observe(1, own, &pk, Some(last), None))
    };
    let d = PlausibilityParams::default();
    assert_eq!(failures(genuine, d), PlausibilityFailures::default());
    let f = failures(State::new(202.0, 20.0, -12.0), d);
    assert!(f.acceleration && f.count() == 1, "{f:?}");
    let f = failures(State::new(202.0, -1.0, 0.0), d);
    assert!(f.speed && f.speed_change, "{f:?}");
    let f = failures(State::new(207.0, 20.0, 0.0), d);
    assert!(f.position_speed && f.count() == 1, "{f:?}");
    let f = failures(State::new(202.0, 22.0, 0.0), d);
    assert!(f.speed_change && !f.speed, "{f:?}");
    let f = failures(State::new(900.0, 20.0, 0.0), d);
    assert!(f.range, "{f:?}");
    // Switched off, a check passes.
    let off = PlausibilityParams {
        check_acceleration: false,
        ..d
    };
    assert_eq!(failures(State::new(202.0, 20.0, -12.0), off).count(), 0);
    // The sudden appearance of a ghost 10 m ahead, with the check on.
    let appear = PlausibilityParams {
        appear_m: 15.0,
        ..d
    };
    let f = failures(State::new(186.0, 20.0, 0.0), appear);
    assert!(f.appearance, "{f:?}");
    assert!(!failures(genuine, appear).appearance);
}

#[test]
fn the_beacon_frequency_check_counts_from_the_senders_previous_packet() {
    let mut sut = Plausibility::new(PlausibilityParams {
        min_interval_s: 0.1,
        ..PlausibilityParams::default()
    })
    .unwrap();
    let own = State::new(0.0, 20.0, 0.0);
    let mut at = |k: u64, sender: u16| {
        let pk = testkit::packet(
            sender,
            1,
            k as usize,
            State::new(24.0 + 0.2 * k as f64, 20.0, 0.0),
        );
        sut.failures(&testkit::observe(1, own, &pk, None, None))
            .frequency
    };
    assert!(!at(0, 0));
    assert!(!at(10, 0), "exactly 0.1 s later");
    assert!(at(15, 0), "0.05 s later");
    assert!(!at(16, 2), "another sender");
}

// ---------------------------------------------------------------------------------------------
// Specs, building, running several

#[test]
fn detection_tables_parse_with_defaults_and_refuse_unknown_keys() {
    let d: Detection = toml::from_str("[plausibility]\nv_max_mps = 50.0\n[residual]\n").unwrap();
    assert_eq!(d.plausibility.unwrap().v_max_mps, 50.0);
    assert_eq!(d.plausibility.unwrap().range_m, 500.0);
    assert_eq!(d.residual, Some(ResidualParams::default()));
    assert_eq!(d.radar_cross, None);
    assert_eq!(
        d.specs().iter().map(DetectorSpec::name).collect::<Vec<_>>(),
        ["plausibility", "residual"]
    );
    assert!(toml::from_str::<Detection>("[residual]\nalpah = 0.01\n").is_err());
    assert!(toml::from_str::<Detection>("[radar]\n").is_err());

    let spec: DetectorSpec = toml::from_str("kind = \"radar_cross\"\nk_sigma = 3.0\n").unwrap();
    assert_eq!(
        spec,
        DetectorSpec::RadarCross(RadarCrossParams {
            k_sigma: 3.0,
            ..RadarCrossParams::default()
        })
    );
    assert!(toml::from_str::<DetectorSpec>("kind = \"residual\"\nbogus = 1\n").is_err());
    assert!(toml::from_str::<DetectorSpec>("kind = \"vibes\"\n").is_err());
    // Round trip.
    let all = Detection {
        plausibility: Some(PlausibilityParams::default()),
        radar_cross: Some(RadarCrossParams::default()),
        residual: Some(ResidualParams::default()),
    };
    for spec in all.specs() {
        let text = toml::to_string(&spec).unwrap();
        assert_eq!(
            toml::from_str::<DetectorSpec>(&text).unwrap(),
            spec,
            "{text}"
        );
    }
}

#[test]
fn validation_names_the_field_at_fault() {
    let bad = DetectorSpec::Residual(ResidualParams {
        alpha: 0.0,
        ..ResidualParams::default()
    });
    let e = build(&bad).unwrap_err();
    assert_eq!((e.detector, e.field), ("residual", "alpha"));
    assert_eq!(
        e.to_string(),
        "detection.residual.alpha = 0: must be in (0, 0.5]"
    );
    let bad = Detection {
        plausibility: Some(PlausibilityParams {
            v_min_mps: 80.0,
            ..PlausibilityParams::default()
        }),
        ..Detection::default()
    };
    assert_eq!(bad.validate().unwrap_err().field, "v_min_mps");
    let bad = RadarCrossParams {
        sigma_v_mps: f64::NAN,
        ..RadarCrossParams::default()
    };
    assert_eq!(bad.validate().unwrap_err().field, "sigma_v_mps");
}

#[test]
fn detectors_run_in_order_and_clone_with_their_state() {
    let all = Detection {
        plausibility: Some(PlausibilityParams::default()),
        radar_cross: Some(RadarCrossParams::default()),
        residual: Some(ResidualParams::default()),
    };
    let mut sut = Detectors::try_from(&all).unwrap();
    assert_eq!(
        sut.names().collect::<Vec<_>>(),
        ["plausibility", "radar_cross", "residual"]
    );
    let last = Last {
        step: 100,
        state: State::new(200.0, 20.0, 0.0),
    };
    let pk = testkit::packet(0, 2, 110, State::new(202.0, 20.0, 0.0));
    let mut out = Vec::new();
    let own = State::new(176.0, 20.0, 0.0);
    assert!(!sut.inspect_all(&testkit::observe(1, own, &pk, Some(last), None), &mut out));
    assert_eq!(out.len(), 3);
    assert!(out[1].score.is_nan());
    let ghost = testkit::packet(0, 2, 110, State::new(202.0, 130.0, 0.0));
    let mut copy = sut.clone();
    assert!(copy.inspect_all(
        &testkit::observe(1, own, &ghost, Some(last), None),
        &mut out
    ));
    assert!(out[0].flagged && out[2].flagged && !out[1].flagged);
}

// ---------------------------------------------------------------------------------------------
// No input panics

fn any_state() -> impl Strategy<Value = State> {
    let x = prop_oneof![
        any::<f64>(),
        -1e3..1e3f64,
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(-f64::INFINITY),
        Just(f64::MAX),
        Just(0.0),
    ];
    [x.clone(), x.clone(), x].prop_map(|[p, v, a]| State::new(p, v, a))
}

fn any_radar() -> impl Strategy<Value = Option<RadarReading>> {
    proptest::option::of(
        (any::<f64>(), -100.0..100.0f64, any::<f64>(), any::<f64>()).prop_map(
            |(gap_m, closing_mps, vehicle_length_m, age_s)| RadarReading {
                gap_m,
                closing_mps,
                vehicle_length_m,
                age_s,
            },
        ),
    )
}

proptest! {
    #[test]
    fn no_input_panics(
        (k, step, last_step) in (any::<u64>(), any::<u64>(), any::<u64>()),
        dt in prop_oneof![Just(0.01), any::<f64>()],
        (sender, receiver) in (any::<u16>(), any::<u16>()),
        (claim, own, last_state) in (any_state(), any_state(), any_state()),
        has_last in any::<bool>(),
        radar in any_radar(),
    ) {
        let all = Detection {
            plausibility: Some(PlausibilityParams {
                min_interval_s: 0.1,
                appear_m: 5.0,
                ..PlausibilityParams::default()
            }),
            radar_cross: Some(RadarCrossParams::default()),
            residual: Some(ResidualParams::default()),
        };
        let mut sut = Detectors::try_from(&all).unwrap();
        let packet = platoon_v2v::Packet::beacon(VehicleId(sender), 1, step, claim);
        let obs = Observation {
            k,
            dt,
            receiver: VehicleId(receiver),
            own,
            packet: &packet,
            last: has_last.then_some(Last { step: last_step, state: last_state }),
            radar,
        };
        let mut out = Vec::new();
        // Twice: the second sees the per-sender memory of the first.
        sut.inspect_all(&obs, &mut out);
        sut.inspect_all(&obs, &mut out);
        prop_assert_eq!(out.len(), 3);
        for v in &out {
            prop_assert!(!(v.flagged && v.score.is_nan()));
        }
        // A non-finite claim never passes the plausibility checks.
        if claim.iter().any(|x| !x.is_finite()) {
            prop_assert!(out[0].flagged);
        }
    }
}

#[cfg(feature = "schemars")]
#[test]
fn the_tables_have_a_json_schema_with_their_defaults() {
    let schema = serde_json::to_value(schemars::schema_for!(Detection)).unwrap();
    let defs = &schema["$defs"];
    assert_eq!(
        defs["ResidualParams"]["properties"]["alpha"]["default"],
        1e-3
    );
    assert_eq!(
        defs["PlausibilityParams"]["properties"]["v_max_mps"]["default"],
        70.0
    );
    assert_eq!(defs["RadarCrossParams"]["additionalProperties"], false);
    let spec = serde_json::to_string(&schemars::schema_for!(DetectorSpec)).unwrap();
    assert!(spec.contains("\"radar_cross\""), "{spec}");
}
