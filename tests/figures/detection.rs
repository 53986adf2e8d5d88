//! `platoon experiment detection` (docs/detection.md, README): its default grid run in process
//! by the library call the command makes, every figure of the F1 table and of the findings
//! compared with the text at the digits it prints, and the runs the text traces.
use crate::common::published;
use platoon_app::experiment::{self, attack_kind, Base, DetectionOptions, DetectionRow, Intensity};
use platoon_config::{Config, DetectionConfig, Embedded, LinkAttackConfig};
use platoon_control::{FallbackMode, Reaction};
use platoon_sim::Summary;

const DOC: &str = "docs/detection.md";
const README: &str = "README.md";

/// The rows of one cell of the grid over its repeats.
fn group<'a>(
    rows: &'a [DetectionRow],
    attack: &str,
    intensity: &str,
    reaction: &str,
    detector: &str,
) -> Vec<&'a DetectionRow> {
    let g: Vec<&DetectionRow> = rows
        .iter()
        .filter(|r| {
            r.attack == attack
                && r.intensity == intensity
                && r.reaction == reaction
                && r.detector == detector
        })
        .collect();
    assert!(
        !g.is_empty(),
        "no row for {attack} {intensity} {reaction} {detector}"
    );
    g
}

/// The mean over the repeats of what `field` gives, as detection.md averages it (the repeats
/// where it is defined).
fn mean(rows: &[&DetectionRow], field: impl Fn(&DetectionRow) -> Option<f64>) -> f64 {
    let values: Vec<f64> = rows.iter().filter_map(|r| field(r)).collect();
    assert!(!values.is_empty(), "undefined in every repeat");
    values.iter().sum::<f64>() / values.len() as f64
}

/// Two decimals, as the F1 table prints them, and a bare 0 for exactly nothing.
fn f2(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x:.2}")
    }
}

/// A whole number with a space between thousands, as the docs print counts (12 260).
fn count(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// Every packet a row's detector inspected, and the misbehaving ones among them.
fn packets(r: &DetectionRow) -> (u64, u64) {
    (r.tp + r.fp + r.tn + r.fn_, r.tp + r.fn_)
}

/// The whole default grid (7 attacks x 2 intensities and a clean run, without a reaction and
/// falling back on each detector, 3 repeats: 180 runs of 45 s), the F1 table of
/// docs/detection.md row by row, the findings under it and the README's summary; then the
/// strong offset's first repeat falling back on radar_cross, traced as the text traces it.
#[test]
fn detection_experiment_table_and_findings() {
    let base = Base::load(None, Embedded::Paper).unwrap();
    let opts = DetectionOptions::default();
    let rows = experiment::detection(&base, &opts, None, &()).unwrap().rows;
    let log = |a: &str, i: &str, d: &str| group(&rows, a, i, "log", d);
    let fallback = |a: &str, i: &str, d: &str| group(&rows, a, i, "fallback", d);
    let f1 = |a: &str, i: &str, d: &str| mean(&log(a, i, d), |r| r.f1);
    let recall = |a: &str, i: &str, d: &str| mean(&log(a, i, d), |r| r.recall);
    let precision = |a: &str, i: &str, d: &str| mean(&log(a, i, d), |r| r.precision);
    let detect = |a: &str, i: &str, d: &str| mean(&log(a, i, d), |r| r.time_to_detect_s);

    // The F1 table, every row.
    for a in experiment::DETECTION_ATTACKS {
        for i in ["stealthy", "strong"] {
            let cells: Vec<String> = ["plausibility", "radar_cross", "residual", "any"]
                .iter()
                .map(|d| f2(f1(a, i, d)))
                .collect();
            published(
                DOC,
                &format!("| {a} | {i} | {{}} | {{}} | {{}} | {{}} |"),
                &cells,
            );
        }
    }

    // What the runs inspected: packets per run, the misbehaving ones, those under strong noise
    // (whose other packets the packet checks refuse before any detector sees them).
    let per_run = |keep: &dyn Fn(&DetectionRow) -> bool| {
        let counts: Vec<(u64, u64)> = rows
            .iter()
            .filter(|r| r.reaction == "log" && r.detector == "any" && keep(r))
            .map(packets)
            .collect();
        assert!(!counts.is_empty());
        let total = |f: fn(&(u64, u64)) -> u64| {
            (
                counts.iter().map(f).min().unwrap(),
                counts.iter().map(f).max().unwrap(),
            )
        };
        (total(|c| c.0), total(|c| c.1))
    };
    let noise = |r: &DetectionRow| r.attack == "random_offset" && r.intensity == "strong";
    let ((inspected_lo, inspected_hi), _) = per_run(&|r| r.attack != "none");
    let (_, (bad_lo, bad_hi)) = per_run(&|r| r.attack != "none" && !noise(r));
    let (_, (noise_lo, noise_hi)) = per_run(&noise);
    published(
        DOC,
        "F1 without a reaction, mean of 3 repeats ({} to {} packets inspected per run, {} to {} of \
         them misbehaving; {} to {} under the strong noise,",
        &[
            count(inspected_lo),
            count(inspected_hi),
            count(bad_lo),
            count(bad_hi),
            count(noise_lo),
            count(noise_hi),
        ],
    );

    // Clean traffic.
    let clean = log("none", "none", "plausibility");
    let clean_packets: Vec<u64> = clean.iter().map(|r| packets(r).0).collect();
    assert!(clean_packets.iter().all(|&n| n == clean_packets[0]));
    for d in ["plausibility", "residual"] {
        assert!(log("none", "none", d).iter().all(|r| r.fp == 0), "{d}");
    }
    let radar_clean = log("none", "none", "radar_cross");
    let worst_clean = radar_clean.iter().max_by_key(|r| r.fp).unwrap();
    assert!(radar_clean.iter().filter(|r| r.fp > 0).count() == 1);
    let fa = mean(&radar_clean, |r| r.false_alarm_rate);
    published(
        DOC,
        "On clean traffic** plausibility and residual raise no false alarm in {} packets per run; \
         radar_cross {} on average ({} packets, {}, in one repeat",
        &[
            count(clean_packets[0]),
            format!("{fa:.1e}"),
            worst_clean.fp.to_string(),
            format!("{:.1e}", worst_clean.false_alarm_rate.unwrap()),
        ],
    );
    published(
        README,
        "False alarms on clean traffic: none for plausibility and residual, {} for the radar.",
        &[format!("{fa:.1e}")],
    );

    // A consistent lie about the position.
    let (offset, drift) = (("false_data", "strong"), ("drift", "strong"));
    assert_eq!(
        format!("{:.2}", recall(offset.0, offset.1, "radar_cross")),
        format!("{:.2}", recall(drift.0, drift.1, "radar_cross"))
    );
    assert_eq!(
        format!("{:.3}", precision(offset.0, offset.1, "radar_cross")),
        format!("{:.3}", precision(drift.0, drift.1, "radar_cross"))
    );
    for d in ["plausibility", "residual"] {
        assert_eq!(recall(drift.0, drift.1, d), 0.0, "{d}");
        assert_eq!(
            format!("{:.3}", recall(offset.0, offset.1, d)),
            format!("{:.3}", recall(offset.0, offset.1, "plausibility"))
        );
    }
    assert_eq!(detect(offset.0, offset.1, "radar_cross"), 0.0);
    published(
        DOC,
        "radar_cross flags the packets to follower 3 (recall {}, precision {}, at once for the \
         offset, after {} s for the drift)",
        &[
            format!("{:.2}", recall(offset.0, offset.1, "radar_cross")),
            format!("{:.3}", precision(offset.0, offset.1, "radar_cross")),
            format!("{:.2}", detect(drift.0, drift.1, "radar_cross")),
        ],
    );
    published(
        DOC,
        "Plausibility and residual flag the onset only (recall {}) or nothing",
        &[format!("{:.3}", recall(offset.0, offset.1, "residual"))],
    );
    published(
        README,
        "is flagged on the packets to the follower whose radar sees the liar (precision {}). The \
         next follower gets the same lie and has no radar on the liar, so recall stops at {}.",
        &[
            format!("{:.3}", precision(offset.0, offset.1, "radar_cross")),
            format!("{:.2}", recall(offset.0, offset.1, "radar_cross")),
        ],
    );

    // What jumps: strong noise and the onsets of a feigned braking.
    let noisy = ("random_offset", "strong");
    let braking = ("feigned_braking", "strong");
    assert_eq!(detect(braking.0, braking.1, "residual"), 0.0);
    let residual_noise = [
        format!("{:.2}", recall(noisy.0, noisy.1, "residual")),
        format!("{:.2}", precision(noisy.0, noisy.1, "residual")),
        format!("{:.2}", f1(noisy.0, noisy.1, "any")),
    ];
    published(
        DOC,
        "Strong random noise (recall {}, precision {}; with the radar, `any` reaches F1 {}) and \
         the onsets of a feigned braking (recall {}, flagged at the first forged packet).",
        &[
            residual_noise[0].clone(),
            residual_noise[1].clone(),
            residual_noise[2].clone(),
            format!("{:.2}", recall(braking.0, braking.1, "residual")),
        ],
    );
    published(
        README,
        "Strong random noise (recall {}, precision {}; F1 {} with the radar)",
        &residual_noise,
    );
    let plausible = recall(noisy.0, noisy.1, "plausibility");
    published(
        DOC,
        "Plausibility sees nothing inside its physical bounds**: only strong noise (recall {}).",
        &[format!("{plausible:.3}")],
    );
    published(
        README,
        "and {} % of strong noise.",
        &[format!("{:.1}", plausible * 100.0)],
    );
    // Nothing else is flagged by plausibility: F1 0 for every other attack.
    for a in experiment::DETECTION_ATTACKS {
        for i in ["stealthy", "strong"] {
            if (a, i) != noisy && (a, i) != offset {
                assert_eq!(recall(a, i, "plausibility"), 0.0, "{a} {i}");
            }
        }
    }

    // The stealthy attacks: the radar alone, late and partly, or nothing.
    let stealthy_offset = ("false_data", "stealthy");
    let stealthy_drift = ("drift", "stealthy");
    let stealthy_noise = ("random_offset", "stealthy");
    published(
        DOC,
        "a 0.15 m offset in {} % of packets (first after {} s), a 0.01 m/s drift in {} % (after {} \
         s, once it exceeds 4 sigma), noise of 0.05 m in {} % (F1 {}).",
        &[
            format!(
                "{:.0}",
                recall(stealthy_offset.0, stealthy_offset.1, "any") * 100.0
            ),
            format!(
                "{:.1}",
                detect(stealthy_offset.0, stealthy_offset.1, "any")
            ),
            format!(
                "{:.0}",
                recall(stealthy_drift.0, stealthy_drift.1, "any") * 100.0
            ),
            format!("{:.0}", detect(stealthy_drift.0, stealthy_drift.1, "any")),
            format!(
                "{:.1}",
                recall(stealthy_noise.0, stealthy_noise.1, "any") * 100.0
            ),
            f2(f1(stealthy_noise.0, stealthy_noise.1, "any")),
        ],
    );
    published(
        README,
        "A 0.05 m noise scores F1 {}.",
        &[f2(f1(stealthy_noise.0, stealthy_noise.1, "any"))],
    );
    // A -1 m/s² feigned braking, a 20 % scaled acceleration, a 0.1 s replay and a 0.05 s
    // delay: no detector flags one of their packets.
    for a in ["feigned_braking", "accel_scale", "replay", "delay"] {
        for d in ["plausibility", "radar_cross", "residual", "any"] {
            assert_eq!(f1(a, "stealthy", d), 0.0, "{a} {d}");
        }
    }
    let timing: Vec<(f64, f64)> = ["accel_scale", "replay", "delay"]
        .iter()
        .map(|a| (f1(a, "strong", "any"), detect(a, "strong", "radar_cross")))
        .collect();
    for a in ["accel_scale", "replay", "delay"] {
        assert_eq!(
            f1(a, "strong", "any"),
            f1(a, "strong", "radar_cross"),
            "{a}"
        );
    }
    let first = timing.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
    let last = timing.iter().map(|t| t.1).fold(f64::NEG_INFINITY, f64::max);
    published(
        DOC,
        "are nearly invisible even when strong** (F1 {}, {}, {}): only the radar sees the stale \
         or scaled claim, {} to {} s after the onset,",
        &[
            f2(timing[0].0),
            f2(timing[1].0),
            f2(timing[2].0),
            format!("{first:.1}"),
            format!("{last:.1}"),
        ],
    );
    let (lo, hi) = timing.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), t| {
        (lo.min(t.0), hi.max(t.0))
    });
    published(
        README,
        "A 3x scaled acceleration, a 1 s replay and a 0.5 s delay score {} to {}, and only when the \
         leader brakes, {} to {} s after the onset.",
        &[f2(lo), f2(hi), format!("{first:.1}"), format!("{last:.1}")],
    );

    // Reacting made the platoon less safe.
    let scenarios: Vec<(&str, &str)> = experiment::DETECTION_ATTACKS
        .iter()
        .flat_map(|a| [(*a, "stealthy"), (*a, "strong")])
        .collect();
    let worst = |rows: Vec<&DetectionRow>| {
        rows.iter()
            .map(|r| r.min_gap_m)
            .fold(f64::INFINITY, f64::min)
    };
    assert!(rows.iter().all(|r| r.collided == (r.min_gap_m < 0.0)));
    let no_reaction: Vec<(f64, (&str, &str))> = scenarios
        .iter()
        .map(|&(a, i)| (worst(log(a, i, "any")), (a, i)))
        .collect();
    let (closest, which) =
        no_reaction.iter().copied().fold(
            (f64::INFINITY, ("", "")),
            |b, x| if x.0 < b.0 { x } else { b },
        );
    assert!(closest > 0.0, "no attack collides without a reaction");
    assert_eq!(which, drift);
    published(
        DOC,
        "Without a reaction no attack here causes a collision (smallest gap {} m, the strong \
         drift).",
        &[format!("{closest:.2}")],
    );
    published(
        README,
        "Without a reaction no attack here collides (smallest gap {} m).",
        &[format!("{closest:.1}")],
    );
    let collides = |d: &str| -> Vec<((&str, &str), f64)> {
        scenarios
            .iter()
            .map(|&(a, i)| ((a, i), worst(fallback(a, i, d))))
            .filter(|x| x.1 < 0.0)
            .collect()
    };
    let radar = collides("radar_cross");
    assert_eq!(
        radar.iter().map(|x| x.0).collect::<Vec<_>>(),
        [
            ("false_data", "strong"),
            ("random_offset", "strong"),
            ("drift", "stealthy"),
            ("drift", "strong"),
        ]
    );
    let deepest = radar.iter().map(|x| x.1).fold(f64::INFINITY, f64::min);
    assert_eq!(deepest, radar[3].1, "the strong drift is the deepest");
    let residual = collides("residual");
    assert_eq!(residual.iter().map(|x| x.0).collect::<Vec<_>>(), [braking]);
    assert!(collides("plausibility").is_empty());
    let plausibility_closest = scenarios
        .iter()
        .map(|&(a, i)| worst(fallback(a, i, "plausibility")))
        .fold(f64::INFINITY, f64::min);
    published(
        DOC,
        "Falling back on radar_cross's flags collides under the strong offset, noise and drift \
         (down to {} m, the strong drift) and the stealthy drift ({} m); on the residual's, under \
         the strong feigned braking ({} m); on plausibility's, never (smallest gap {} m).",
        &[
            format!("{deepest:.2}"),
            format!("{:.2}", radar[2].1),
            format!("{:.2}", residual[0].1),
            format!("{plausibility_closest:.2}"),
        ],
    );

    // The trace: the strong offset's first repeat, falling back on radar_cross. The config is
    // the experiment's cell; its smallest gap is that of the row.
    let traced = worst(
        fallback("false_data", "strong", "radar_cross")
            .into_iter()
            .filter(|r| r.repeat == 0)
            .collect(),
    );
    let returning = trace(&base, &opts, |_| {});
    assert_eq!(returning.summary.safety.min_gap_m, traced);
    let never = trace(&base, &opts, |c| {
        c.detection.as_mut().unwrap().quiet_s = 2.0 * opts.duration_s
    });
    let guarded = trace(&base, &opts, |c| c.guard.enabled = true);
    // Kept on ACC: only follower 3 falls back, once, and follower 4 runs into it.
    let fell_back = |t: &Trace| -> Vec<u16> {
        t.summary
            .vehicles
            .iter()
            .filter(|v| v.mode_time_s.get("acc").is_some_and(|&s| s > 0.0))
            .map(|v| v.vehicle)
            .collect()
    };
    assert_eq!(fell_back(&never), [3]);
    let spacing = base.config.platoon.spacing_m;
    assert!(
        never.max_gap[3] > spacing + 5.0,
        "ACC opens follower 3's gap"
    );
    let s = &never.summary.safety;
    assert!(s.collided);
    assert_eq!(s.min_gap_vehicle, 4);
    // Returning: follower 3 switches back and forth and runs into vehicle 2.
    let r = &returning.summary;
    let switches = r
        .vehicles
        .iter()
        .find(|v| v.vehicle == 3)
        .unwrap()
        .mode_switches;
    assert_eq!(r.safety.min_gap_vehicle, 3);
    assert!(guarded.summary.safety.collided);
    published(
        DOC,
        "With follower 3 kept on ACC once it distrusts (`quiet_s` longer than the run), only \
         follower 3 falls back, and ACC opens its gap; follower 4, still cooperative with \
         vehicles 2 and 3 on TPSF, balances a gap too large to vehicle 2 against one too small \
         to vehicle 3 and drives into follower 3 at {} s, {} s after the lie began (smallest gap \
         {} m). With `quiet_s = 1` follower 3 returns to the paper's law with the lie still \
         coming ({} changes of mode), the law commands jumps the paper's plant (no actuator \
         limits) follows at up to {} m/s², and follower 3 runs into vehicle 2 ({} m). `[guard] \
         enabled = true` does not prevent it ({} m).",
        &[
            format!("{:.2}", s.first_collision_t_s.unwrap()),
            format!("{:.2}", s.first_collision_t_s.unwrap() - opts.start_s),
            format!("{:.2}", s.min_gap_m),
            switches.to_string(),
            format!("{:.1}", returning.max_accel[3]),
            format!("{:.2}", r.safety.min_gap_m),
            format!("{:.2}", guarded.summary.safety.min_gap_m),
        ],
    );
}

/// A traced run: its summary, each vehicle's largest acceleration (m/s²) and its largest gap
/// to the vehicle ahead (m).
struct Trace {
    summary: Summary,
    max_accel: Vec<f64>,
    max_gap: Vec<f64>,
}

/// The experiment's cell of the strong +5 m offset from vehicle 2, falling back on
/// radar_cross's flags, repeat 0, changed by `change`, run in process.
fn trace(base: &Base, opts: &DetectionOptions, change: impl Fn(&mut Config)) -> Trace {
    let mut c = base.config.clone();
    c.attack = Default::default();
    c.channel.attacks.clear();
    c.simulation.duration_s = opts.duration_s;
    c.fallback.mode = Some(FallbackMode::Acc);
    c.fallback.per_vehicle = None;
    c.channel.attacks.push(LinkAttackConfig {
        kind: attack_kind("false_data", Intensity::Strong).unwrap(),
        start_s: opts.start_s,
        end_s: f64::INFINITY,
        senders: Some(vec![opts.attacker]),
        receivers: None,
        acts_as: None,
        key_of: None,
    });
    c.detection = Some(DetectionConfig {
        plausibility: None,
        radar_cross: Some(Default::default()),
        residual: None,
        reaction: Reaction::Fallback,
        quiet_s: 1.0,
        plugin: Vec::new(),
    });
    change(&mut c);
    let scenario = platoon_config::to_scenario(&mut c).unwrap();
    let mut max_accel = vec![f64::NEG_INFINITY; scenario_vehicles(&c)];
    let mut max_gap = vec![f64::NEG_INFINITY; max_accel.len()];
    let length = c.platoon.vehicle_length_m;
    let summary = platoon_sim::run(scenario, |rows| {
        let mine: Vec<_> = rows.iter().filter(|r| r.platoon == 0).collect();
        for (i, r) in mine.iter().enumerate() {
            let v = usize::from(r.vehicle);
            max_accel[v] = max_accel[v].max(r.a);
            if i > 0 {
                max_gap[v] = max_gap[v].max(mine[i - 1].p - r.p - length);
            }
        }
    })
    .unwrap();
    Trace {
        summary,
        max_accel,
        max_gap,
    }
}

/// The platoon's vehicles, the leader included.
fn scenario_vehicles(c: &Config) -> usize {
    c.platoon.followers + 1
}
