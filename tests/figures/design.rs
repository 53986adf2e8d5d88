//! docs/design.md's figures: Theorem 1's check of the paper's K, the designed gains (nominal
//! and robust) with their decay rates and DoS bounds, the run with the designed gain, Fig. 9
//! and Fig. 10 on sizes 2 and 4, computed by the library calls `platoon design` and `platoon
//! experiment` make.
use crate::common::{json, papers_gain_checked, published};
use platoon_app::design::{self, BoundsOptions, CheckOptions, SynthesisOptions, Theorem};
use platoon_app::experiment::{self, Base, RobustOptions, TopologiesOptions};
use platoon_config::Embedded;
use std::path::Path;

const DOC: &str = "docs/design.md";

fn gain(k: [f64; 3]) -> String {
    format!("[{:.2}, {:.2}, {:.2}]", k[0], k[1], k[2])
}

/// `design check-gain` of the paper's K: the smallest ratios with a common and with a
/// block-diagonal certificate, and string stability on 4 and 100 followers. Read from the
/// check.json of the suite's one `platoon design check-gain` run of it
/// (`common::papers_gain_checked`, which `cli::` checks too): the same `design::check_gain`.
#[test]
fn the_papers_gain_checked() {
    let (config, scenario) = Embedded::Paper.parse().unwrap();
    let (o, checked) = papers_gain_checked();
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r = json(&checked.join("d/check.json"));
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    let ratio = num(&r["min_ratio_at_c"][1]);
    let config_ratio = num(&r["config_ratio"]);
    assert!(r["stable_over_tau_range"] == true && r["config_ratio_certified"] == false);
    let paper = config.control.paper_law();
    let (beta1, beta2) = (paper.beta1, paper.beta2);
    published(
        DOC,
        "Tested: the paper's K = [{}, {}, {}] is stable for every tau in [{}, {}] s, but on the TPSF \
         graph (13) needs beta1/beta2 >= {}, {}x the paper's {}/{} = {}, which does not satisfy it",
        &[
            format!("{}", paper.gain[0]),
            format!("{}", paper.gain[1]),
            format!("{}", paper.gain[2]),
            format!("{}", scenario.tau_range().0),
            format!("{}", scenario.tau_range().1),
            format!("{ratio:.2}"),
            format!("{:.1}", ratio / config_ratio),
            format!("{beta1:.2}"),
            format!("{beta2:.2}"),
            format!("{config_ratio:.2}"),
        ],
    );
    let block_ratio = num(&r["block_diagonal"]["min_ratio"]);
    published(
        DOC,
        "with a smaller ratio where both hold (TPSF 4: {} against {})",
        &[format!("{block_ratio:.0}"), format!("{ratio:.0}")],
    );
    // String stability: the worst tau of each platoon size.
    let worst = |followers: usize| {
        let s = r["string_stability"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["followers"] == followers)
            .unwrap();
        let t = s["per_tau"]
            .as_array()
            .unwrap()
            .iter()
            .max_by(|a, b| num(&a["amplification"]).total_cmp(&num(&b["amplification"])))
            .unwrap()
            .clone();
        (s["string_stable"] == true, t)
    };
    let (stable4, four) = worst(4);
    let (stable100, hundred) = worst(100);
    assert!(stable4 && !stable100);
    published(
        DOC,
        "The paper's K: string stable on its 4-follower TPSF platoon ({}x), string unstable on TPSF \
         with 100 followers ({}x, {}x per follower at {} rad/s)",
        &[
            format!("{:.2}", num(&four["amplification"])),
            format!("{:.0}", num(&hundred["amplification"])),
            format!("{:.2}", num(&hundred["per_follower"])),
            format!("{:.1}", num(&hundred["at_rad_s"])),
        ],
    );

    // Theorem 2 (robust over the tau range) for the same K.
    let robust = CheckOptions {
        theorem: Theorem::Robust,
        ..CheckOptions::default()
    };
    let r2 = design::check_gain(&config, &scenario, &robust).unwrap();
    let (_, ratio2) = r2.min_ratio_at_c.unwrap();
    published(
        DOC,
        "The paper's K needs beta1/beta2 >= {} for it (barely robust)",
        &[format!("{ratio2:.1e}")],
    );

    // The DoS bounds (16) from the paper's own inputs.
    let (t2, d2) = design::bounds(&BoundsOptions::default()).unwrap();
    published(
        DOC,
        "the paper's inputs give T2 > {} and D2 > {} (tested)",
        &[format!("{t2:.2}"), format!("{d2:.2}")],
    );
}

/// `design synthesize` (nominal and robust) on the paper's platoon, and the paper scenario run
/// with the nominal design (`platoon run --design`).
#[test]
fn the_designed_gains() {
    let (config, scenario) = Embedded::Paper.parse().unwrap();
    let nominal = design::synthesize(&config, &scenario, &SynthesisOptions::default()).unwrap();
    let d = &nominal.report;
    let norm = d.k.iter().map(|x| x * x).sum::<f64>().sqrt();
    published(
        DOC,
        "Our synthesis on the same graph gives K = {} with beta1/beta2 = {} (|K| = {});",
        &[
            gain(d.k),
            format!("{:.2}", d.beta1_over_beta2),
            format!("{norm:.2}"),
        ],
    );
    let verdict = |r: &design::DesignReport| r.schedule_verdict.clone().unwrap().to_lowercase();
    assert!(verdict(d).contains("satisfies"), "{}", verdict(d));
    let robust_opts = SynthesisOptions {
        theorem: Theorem::Robust,
        ..SynthesisOptions::default()
    };
    let robust = design::synthesize(&config, &scenario, &robust_opts).unwrap();
    let r = &robust.report;
    assert!(verdict(r).contains("violates"), "{}", verdict(r));
    published(
        DOC,
        "For the paper's TPSF platoon: varsigma1 = {}, varsigma2 = {}, T2 > {} s, D2 > {}, and the \
         paper's DoS schedule satisfies Assumption 2 with those bounds; the robust design needs D2 \
         > {}, which that schedule",
        &[
            format!("{:.3}", d.varsigma1),
            format!("{:.3}", d.varsigma2),
            format!("{:.2}", d.t2_bound.unwrap()),
            format!("{:.2}", d.d2_bound.unwrap()),
            format!("{:.2}", r.d2_bound.unwrap()),
        ],
    );
    published(
        DOC,
        "while the robust synthesis gives K = {}, beta1/beta2 = {}.",
        &[gain(r.k), format!("{:.0}", r.beta1_over_beta2)],
    );
    published(
        DOC,
        "{} SDPs for the nominal design on the paper's platoon",
        &[d.sdps.to_string()],
    );

    // The paper scenario with the designed K and beta1 = ratio x beta2 as published (to the
    // digits printed: the solver's last digits follow the machine's BLAS, and the broadcasts
    // follow them).
    let printed = |x: f64| (x * 100.0).round() / 100.0;
    let mut designed = config.clone();
    let paper = designed.control.paper_law_mut();
    paper.gain = d.k.map(printed);
    paper.beta1 = printed(d.beta1_over_beta2) * paper.beta2;
    let (_, sc) = platoon_config::parse(
        &platoon_config::to_toml(&designed),
        Path::new("designed.toml"),
    )
    .unwrap();
    let s = platoon_sim::run(sc, |_| {}).unwrap();
    assert!(!s.safety.collided);
    let means: Vec<f64> = s
        .vehicles
        .iter()
        .map(|v| v.spacing_error_m.mean_abs)
        .collect();
    assert_eq!(means.len(), 4);
    let counts: Vec<String> = s.vehicles.iter().map(|v| v.triggers.to_string()).collect();
    let paper = platoon_sim::run(scenario.clone(), |_| {}).unwrap();
    assert!(s.triggers_total > paper.triggers_total);
    published(
        DOC,
        "Run with it, the paper scenario stays safe, with larger tracking errors (mean {}-{} m) and \
         more broadcasts ({}) than the paper's gain",
        &[
            format!("{:.2}", means.iter().cloned().fold(f64::INFINITY, f64::min)),
            format!("{:.2}", means.iter().cloned().fold(0.0, f64::max)),
            counts.join("/"),
        ],
    );
}

/// Fig. 9 (`platoon experiment robust`): the ordering of the three designs while tau is high.
#[test]
fn fig9_nominal_against_robust() {
    let base = Base::load(None, Embedded::Paper).unwrap();
    let f = experiment::robust(&base, &RobustOptions::default(), None, &()).unwrap();
    let names: Vec<&str> = f.designs.iter().map(|d| d.name).collect();
    assert_eq!(
        names,
        ["theorem1-nominal", "theorem2-robust", "lower-bound"]
    );
    let high: Vec<f64> = f.designs.iter().map(|d| d.phase_errors[2]).collect();
    assert!(high[1] < high[0] && high[0] < high[2], "{high:?}");
    published(
        DOC,
        "Mean tracking error while tau = 0.82 s (35-55 s): robust {} m < nominal {} m < lower bound \
         {} m (tested)",
        &[
            format!("{:.2}", high[1]),
            format!("{:.2}", high[0]),
            format!("{:.2}", high[2]),
        ],
    );
}

/// Fig. 10 (`platoon experiment topologies --sizes 2,4`).
#[test]
fn fig10_decay_rates_by_topology() {
    let base = Base::load(None, Embedded::Paper).unwrap();
    let opts = TopologiesOptions {
        sizes: vec![2, 4],
        ..TopologiesOptions::default()
    };
    let t = experiment::topologies(&base, &opts, None, &()).unwrap();
    let rate = |topology: &str, n: usize, condition: &str| {
        t.rows
            .iter()
            .find(|r| r.topology == topology && r.followers == n && r.condition == condition)
            .unwrap_or_else(|| panic!("no {topology} {n} {condition}"))
            .varsigma1
    };
    let topologies = ["PF", "TPSF", "BPF"];
    for topology in topologies {
        // varsigma1 falls with the platoon's size, nominal and under uncertainty.
        assert!(rate(topology, 4, "nominal") < rate(topology, 2, "nominal"));
        assert!(rate(topology, 4, "uncertainty") < rate(topology, 2, "uncertainty"));
        for n in [2, 4] {
            // Uncertainty lowers it in every case but BPF with 2 followers.
            let lower = rate(topology, n, "uncertainty") < rate(topology, n, "nominal");
            assert_eq!(lower, !(topology == "BPF" && n == 2), "{topology} {n}");
        }
    }
    for n in [2, 4] {
        for condition in ["nominal", "uncertainty"] {
            let best = topologies
                .iter()
                .max_by(|a, b| rate(a, n, condition).total_cmp(&rate(b, n, condition)))
                .unwrap();
            assert_eq!(*best, "TPSF", "{n} {condition}");
        }
    }
    let conservative: Vec<f64> = t
        .rows
        .iter()
        .filter(|r| r.condition == "conservative")
        .map(|r| r.varsigma1)
        .collect();
    let cap = conservative[0];
    assert!(conservative.iter().all(|&c| (c - cap).abs() < 1e-12));
    let dos: Vec<f64> = t
        .rows
        .iter()
        .filter(|r| r.condition == "dos")
        .map(|r| r.varsigma1)
        .collect();
    assert_eq!(dos.len(), 6);
    published(
        DOC,
        "TPSF gives the largest rates ({} and {} nominal), the conservative trigger caps every rate \
         at {}, and DoS leaves {}-{}.",
        &[
            format!("{:.2}", rate("TPSF", 2, "nominal")),
            format!("{:.2}", rate("TPSF", 4, "nominal")),
            format!("{cap:.3}"),
            format!("{:.2}", dos.iter().cloned().fold(f64::INFINITY, f64::min)),
            format!("{:.2}", dos.iter().cloned().fold(0.0, f64::max)),
        ],
    );
}
