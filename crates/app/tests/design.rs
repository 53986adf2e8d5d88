//! `platoon_app::design` as library calls: the figures `platoon design` prints, in memory, and
//! the files only where the caller says.
use platoon_app::design::{
    self, BoundsOptions, CheckOptions, DesignError, SynthesisOptions, Theorem,
};
use platoon_config::Embedded;
use platoon_output::rundir::RunDir;

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The figures tests/cli.rs pins for `platoon design check-gain` (reading R15: the paper's
/// ratio 56.83 is an order of magnitude too small for its K), from the call itself.
#[test]
fn check_gain_on_the_paper_scenario_gives_the_pinned_ratios_in_memory() {
    let (config, scenario) = Embedded::Paper.parse().unwrap();
    let report = design::check_gain(&config, &scenario, &CheckOptions::default()).unwrap();
    assert_eq!(report.k, config.control.paper_law().gain);
    assert_eq!(report.topology_followers, 4);
    assert_eq!(report.time_headway_s, 0.0);
    assert!(report.stable_over_tau_range);
    let (c, min) = report.min_ratio_at_c.unwrap();
    assert_eq!(c, 0.0);
    assert_eq!(format!("{min:.2}"), "707.37");
    assert_eq!(format!("{:.2}", report.config_ratio), "56.83");
    assert!(!report.config_ratio_certified);
    let block = report.block_diagonal.as_ref().unwrap();
    assert_eq!(format!("{:.2}", block.min_ratio), "141.31");
    assert_eq!(format!("{:.2}", block.transient_growth), "13.18");
    assert!(!block.config_ratio_certified);
    assert_eq!(report.theorem, Theorem::Nominal);
    assert_eq!(report.lmi_taus, vec![scenario.control.tau_nominal]);
    assert_eq!(report.spectrum.len(), 51);
    let strings: Vec<(usize, bool)> = report
        .string_stability
        .iter()
        .map(|s| (s.followers, s.string_stable))
        .collect();
    assert_eq!(strings, vec![(4, true), (100, false)]);
    // The certificates come back too, and re-check independently of the solver.
    let cert = report.certificate.clone().unwrap();
    assert_eq!(cert.ratio, min);
    assert!(design::verify(&cert).unwrap().holds);
    let mut low = cert.clone();
    low.ratio = 56.83;
    assert!(!design::verify(&low).unwrap().holds);
    let decay = report.max_decay.as_ref().unwrap();
    assert_eq!(report.max_decay_c, Some(decay.c));
    assert!(design::verify(decay).unwrap().holds);

    // Written on request: check.json is the report itself; the certificates read back equal.
    let tmp = tempfile::tempdir().unwrap();
    let dir = RunDir::create(&tmp.path().join("check"), false).unwrap();
    report.write(&dir).unwrap();
    let out = dir.commit().unwrap();
    assert_eq!(
        std::fs::read_to_string(out.join("check.json")).unwrap(),
        serde_json::to_string_pretty(&report).unwrap() + "\n"
    );
    assert_eq!(
        json(&out.join("check.json"))["min_ratio_at_c"][1].as_f64(),
        Some(min)
    );
    assert_eq!(
        design::read_certificate(&out.join("certificate.json")).unwrap(),
        cert
    );
    assert_eq!(
        design::read_certificate(&out.join("certificate-block-diagonal.json")).unwrap(),
        report.block_diagonal_certificate.clone().unwrap()
    );
    assert!(out.join("certificate-max-decay.json").is_file());
    let spectrum = std::fs::read_to_string(out.join("spectrum.csv")).unwrap();
    assert_eq!(spectrum.lines().count(), 52);
}

#[test]
fn options_a_design_cannot_use_are_refused_before_anything_is_computed() {
    let (config, scenario) = Embedded::Paper.parse().unwrap();
    let bad = CheckOptions {
        time_headway: Some(-1.0),
        ..CheckOptions::default()
    };
    let e = design::check_gain(&config, &scenario, &bad).unwrap_err();
    assert!(matches!(e, DesignError::Options(_)), "{e:?}");
    assert!(e.to_string().contains("-1"), "{e}");
    let nan = CheckOptions {
        gain: Some([1.0, f64::NAN, 2.0]),
        ..CheckOptions::default()
    };
    assert!(nan.validate().is_err());
    for star_fraction in [0.0, 1.0, f64::NAN] {
        let opts = SynthesisOptions {
            star_fraction,
            ..SynthesisOptions::default()
        };
        let e = design::synthesize(&config, &scenario, &opts).unwrap_err();
        assert!(matches!(e, DesignError::Options(_)), "{e:?}");
        assert!(e.to_string().contains("(0, 1)"), "{e}");
    }
    assert_eq!(Theorem::from_number(2), Some(Theorem::Robust));
    assert_eq!(Theorem::from_number(3), None);
    assert_eq!(
        Theorem::Robust.taus(&scenario),
        vec![scenario.tau_range().0, scenario.tau_range().1]
    );
}

#[test]
fn the_dos_bounds_of_section_iv() {
    let (t2, d2) = design::bounds(&BoundsOptions::default()).unwrap();
    assert_eq!(format!("{t2:.2} {d2:.2}"), "9.46 11.33");
}

/// A synthesised gain comes back certified with its bounds; an infeasible request is an error
/// and, with nothing written before it, leaves no file.
#[test]
fn synthesis_returns_a_certified_design_and_its_bounds() {
    let (config, scenario) = Embedded::Paper.parse().unwrap();
    let s = design::synthesize(&config, &scenario, &SynthesisOptions::default()).unwrap();
    let d = &s.design;
    assert!(d.k.iter().map(|x| x * x).sum::<f64>().sqrt() <= 20.0);
    assert!(design::verify(&d.certificate).unwrap().holds);
    let r = &s.report;
    assert_eq!(r.theorem, 1);
    assert_eq!(r.k, d.k);
    assert_eq!(r.beta1_over_beta2, d.certificate.ratio);
    assert_eq!(r.beta2, config.control.paper_law().beta2);
    assert!(r.varsigma1 > 0.0 && r.varsigma1 <= s.trigger_cap + 1e-12);
    assert!(r.t2_bound.unwrap() > 0.0 && r.d2_bound.unwrap() > 1.0);
    assert!(r
        .schedule_verdict
        .as_deref()
        .unwrap()
        .contains("Assumption 2"));
    assert_eq!(r.certificate_max_decay.is_some(), s.max_decay.is_some());

    let tmp = tempfile::tempdir().unwrap();
    let dir = RunDir::create(&tmp.path().join("d"), false).unwrap();
    s.write(&dir).unwrap();
    let out = dir.commit().unwrap();
    assert_eq!(
        design::read_certificate(&out.join("certificate.json")).unwrap(),
        d.certificate
    );
    assert_eq!(json(&out.join("design.json"))["k"], serde_json::json!(d.k));

    let none = SynthesisOptions {
        k_max: 0.01,
        ..SynthesisOptions::default()
    };
    let e = design::synthesize(&config, &scenario, &none).unwrap_err();
    assert!(e.to_string().starts_with("infeasible"), "{e}");
    let DesignError::Infeasible {
        theorem,
        followers,
        k_max,
        ..
    } = e
    else {
        panic!("{e:?}");
    };
    assert_eq!((theorem, followers, k_max), (1, 4, 0.01));

    // A certificate that is not there, or not one.
    let missing = tmp.path().join("missing.json");
    let e = design::read_certificate(&missing).unwrap_err();
    assert!(
        matches!(&e, DesignError::ReadCertificate { path, .. } if *path == missing),
        "{e:?}"
    );
    assert_eq!(format!("{e}"), format!("reading {}", missing.display()));
    let e = design::read_certificate(&out.join("design.json")).unwrap_err();
    assert!(matches!(e, DesignError::NotACertificate { .. }), "{e:?}");
    assert!(
        e.to_string().ends_with("design.json is not a certificate"),
        "{e}"
    );
}
