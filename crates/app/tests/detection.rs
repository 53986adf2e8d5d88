//! The detectors measured against ground truth in closed loop, the per-message
//! dataset, and `platoon experiment detection` on a reduced grid.
use platoon_app::experiment::{self, attack_kind, Base, DetectionOptions, Intensity};
use platoon_config::{Config, DetectionConfig, Embedded, LinkAttackConfig, LinkKindConfig};
use platoon_control::{FallbackMode, Reaction};
use platoon_sim::detection::{DetectionSummary, DetectorScore};
use std::path::Path;

/// The paper's scenario without its DoS, 30 s, ACC on the radar as the fallback, with
/// `detectors` (their defaults) logging, and `attack` on the insider vehicle 2 from 20 s.
fn config(detectors: &[&str], attack: Option<LinkKindConfig>) -> Config {
    let (mut c, _) = Embedded::Paper.parse().unwrap();
    c.attack = Default::default();
    c.simulation.duration_s = 30.0;
    c.fallback.mode = Some(FallbackMode::Acc);
    if let Some(kind) = attack {
        c.channel.attacks.push(LinkAttackConfig {
            kind,
            start_s: 20.0,
            end_s: f64::INFINITY,
            senders: Some(vec![2]),
            receivers: None,
            acts_as: None,
            key_of: None,
        });
    }
    let on = |name: &str| detectors.contains(&name);
    c.detection = Some(DetectionConfig {
        plausibility: on("plausibility").then(Default::default),
        radar_cross: on("radar_cross").then(Default::default),
        residual: on("residual").then(Default::default),
        reaction: Reaction::Log,
        quiet_s: 1.0,
        plugin: Vec::new(),
    });
    c
}

/// `c` run in process into a temporary run directory (kept as long as the guard lives).
fn run_inproc(c: Config) -> (tempfile::TempDir, platoon_app::run::RunOutcome) {
    let mut c2 = c.clone();
    let scenario = platoon_config::to_scenario(&mut c2).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let opts = platoon_app::RunOptions {
        transport: platoon_config::Transport::Inproc,
        plots: false,
        ..Default::default()
    };
    let out = platoon_app::run::run(
        c,
        &scenario,
        &opts,
        &tmp.path().join("run"),
        false,
        &platoon_app::Stop::default(),
        &(),
    )
    .unwrap();
    (tmp, out)
}

fn detect(mut c: Config) -> DetectionSummary {
    let scenario = platoon_config::to_scenario(&mut c).unwrap();
    platoon_sim::run(scenario, |_| {})
        .unwrap()
        .detection
        .expect("a run with [detection] measures it")
}

fn score<'a>(d: &'a DetectionSummary, name: &str) -> &'a DetectorScore {
    d.detectors.iter().find(|s| s.name == name).unwrap()
}

#[test]
fn radar_cross_catches_a_position_offset_from_the_predecessor() {
    let d = detect(config(
        &["radar_cross"],
        attack_kind("false_data", Intensity::Strong),
    ));
    let s = score(&d, "radar_cross");
    // Vehicle 2's packets reach follower 3 (whose radar sees vehicle 2) and follower 4 (whose
    // radar sees vehicle 3): every packet to follower 3 is flagged, none to follower 4.
    assert!(s.totals.tp > 0, "{s:?}");
    assert!(s.recall.unwrap() > 0.45, "{s:?}");
    assert!(s.precision.unwrap() > 0.99, "{s:?}");
    assert!(s.time_to_detect_s.unwrap() <= 0.05, "{s:?}");
}

#[test]
fn residual_catches_the_onsets_of_a_feigned_braking() {
    let d = detect(config(
        &["residual"],
        attack_kind("feigned_braking", Intensity::Strong),
    ));
    let s = score(&d, "residual");
    assert!(s.totals.tp > 0 && s.recall.unwrap() > 0.0, "{s:?}");
    assert!(s.precision.unwrap() > 0.99, "{s:?}");
    // The first forged packet each receiver gets, against a genuine last one, is flagged.
    assert_eq!(s.time_to_detect_s, Some(0.0), "{s:?}");
}

#[test]
fn plausibility_catches_a_braking_beyond_the_friction_limit() {
    let d = detect(config(
        &["plausibility"],
        Some(LinkKindConfig::FeignedBraking {
            accel_mps2: -12.0,
            insider: true,
        }),
    ));
    let s = score(&d, "plausibility");
    assert_eq!(s.totals.fn_, 0, "every packet claims -12 m/s²: {s:?}");
    assert!(s.totals.tp > 0, "{s:?}");
}

#[test]
fn on_clean_traffic_every_detector_stays_under_its_false_alarm_rate() {
    let d = detect(config(&["plausibility", "radar_cross", "residual"], None));
    assert_eq!(d.labels.keys().collect::<Vec<_>>(), ["genuine"]);
    assert!(d.inspected > 5_000, "{}", d.inspected);
    let far = |name: &str| score(&d, name).false_alarm_rate.unwrap();
    assert_eq!(far("plausibility"), 0.0);
    // The radar's noise is Gaussian with the detector's sigmas: 4 sigma on two components.
    assert!(far("radar_cross") <= 1e-3, "{}", far("radar_cross"));
    // Its alpha is 1e-3.
    assert!(far("residual") <= 2e-3, "{}", far("residual"));
}

#[test]
fn the_dataset_has_one_row_per_delivery_with_its_label_and_what_refused_it() {
    let c = config(
        &["plausibility", "radar_cross", "residual"],
        attack_kind("random_offset", Intensity::Strong),
    );
    let (_tmp, out) = run_inproc(c);
    let d = out.summary.detection.unwrap();
    let mut reader = csv::Reader::from_path(out.dir.join("detections.csv")).unwrap();
    let header = reader.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (label, refused, flagged) = (col("label"), col("refused"), col("flagged"));
    let (true_p, residual) = (col("true_p"), col("residual_flagged"));
    let (inspected, refused_by, fields) = (col("inspected"), col("refused_by"), col("fields"));
    let (mut rows, mut inspected_rows) = (0u64, 0u64);
    let mut labels = std::collections::BTreeMap::<String, u64>::new();
    let mut refusals = std::collections::BTreeMap::<String, u64>::new();
    let (mut flags, mut residual_flags) = (0u64, 0u64);
    for r in reader.records() {
        let r = r.unwrap();
        rows += 1;
        assert!(!r[true_p].is_empty(), "every sender is a platoon member");
        assert_eq!(&r[refused], "false", "log refuses nothing");
        assert_eq!(r[label] == *"altered", !r[fields].is_empty(), "{r:?}");
        if &r[inspected] == "true" {
            // What a detector saw passed the packet checks.
            assert_eq!(&r[refused_by], "", "{r:?}");
            inspected_rows += 1;
            *labels.entry(r[label].to_string()).or_default() += 1;
            flags += u64::from(&r[flagged] == "true");
            residual_flags += u64::from(&r[residual] == "true");
        } else {
            // What none saw, the packet checks refused, and say why.
            assert!(!r[refused_by].is_empty(), "{r:?}");
            assert_eq!(&r[residual], "", "{r:?}");
            *refusals.entry(r[refused_by].to_string()).or_default() += 1;
        }
    }
    assert_eq!(inspected_rows, d.inspected);
    assert_eq!(labels, d.labels);
    assert!(labels["altered"] > 0);
    assert_eq!(flags, d.flagged);
    let s = score(&d, "residual");
    assert_eq!(residual_flags, s.totals.tp + s.totals.fp);
    // Every delivery has its row: those refused by the checks are the summary's refusals.
    let w = out.summary.wire.as_ref().unwrap().totals;
    assert_eq!(rows, w.delivered_as_sent + w.altered + w.injected);
    let rejected = out.summary.rejected_packets;
    assert!(rows > d.inspected && refusals.get("implausible_state").is_some_and(|&n| n > 0));
    assert_eq!(
        refusals.values().sum::<u64>(),
        rejected.total(),
        "{refusals:?}"
    );
    // Reason by reason (the checks' reasons in the order of `as_array`).
    for (why, n) in platoon_control::RefusedBy::ALL
        .iter()
        .zip(rejected.as_array())
    {
        assert_eq!(refusals.get(why.name()).copied().unwrap_or(0), n, "{why:?}");
    }
}

#[test]
fn without_detection_there_is_no_dataset() {
    let mut c = config(&[], None);
    c.detection = None;
    let (_tmp, out) = run_inproc(c);
    assert!(!out.dir.join("detections.csv").exists());
    assert!(out.summary.detection.is_none());
}

#[test]
fn the_experiment_writes_its_files_with_sane_numbers() {
    let base = Base::load(None, Embedded::Paper).unwrap();
    let opts = DetectionOptions {
        attacks: vec!["feigned_braking".into()],
        detectors: vec!["residual".into()],
        intensities: vec![Intensity::Strong],
        reactions: vec![Reaction::Log],
        clean: true,
        repeats: 1,
        duration_s: 30.0,
        ..Default::default()
    };
    let tmp = tempfile::tempdir().unwrap();
    let dir = platoon_output::rundir::RunDir::create(&tmp.path().join("exp"), false).unwrap();
    let result = experiment::detection(&base, &opts, Some(&dir), &()).unwrap();
    let path = dir.commit().unwrap();
    for f in [
        "config.toml",
        "detection.csv",
        "detection.md",
        "f1.png",
        "safety.png",
    ] {
        assert!(Path::new(&path.join(f)).exists(), "{f}");
    }
    // The clean run and the attack, one detector each.
    assert_eq!(result.rows.len(), 2);
    let clean = &result.rows[0];
    assert_eq!((clean.attack.as_str(), clean.intensity), ("none", "none"));
    assert_eq!(clean.tp + clean.fn_, 0);
    assert_eq!(clean.recall, None);
    let r = &result.rows[1];
    assert_eq!(
        (r.attack.as_str(), r.intensity, r.detector.as_str()),
        ("feigned_braking", "strong", "residual")
    );
    assert!(r.tp > 0 && r.tn > 0, "{r:?}");
    // The ratios are the counts' (not merely numbers in [0, 1]).
    let ratio = |a: u64, b: u64| (b > 0).then(|| a as f64 / b as f64);
    assert_eq!(r.precision, ratio(r.tp, r.tp + r.fp), "{r:?}");
    assert_eq!(r.recall, ratio(r.tp, r.tp + r.fn_), "{r:?}");
    assert_eq!(r.f1, ratio(2 * r.tp, 2 * r.tp + r.fp + r.fn_), "{r:?}");
    assert_eq!(r.false_alarm_rate, ratio(r.fp, r.fp + r.tn), "{r:?}");
    assert!(!r.collided && r.min_gap_m > 0.0, "{r:?}");
    let csv = std::fs::read_to_string(path.join("detection.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.starts_with(
        "attack,intensity,reaction,repeat,detector,tp,fp,tn,fn,precision,recall,f1,\
         false_alarm_rate,time_to_detect_s,min_gap_m,collided,safety_class"
    ));
    assert!(result
        .markdown
        .contains("| feigned_braking | strong | residual |"));
}
