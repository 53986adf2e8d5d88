//! `summary.json` reads back into the `Summary` that wrote it: campaigns and
//! library users read fields, not JSON paths.
use platoon_sim::{SafetyClass, Summary};

fn paper(steps: u64, platoons: usize) -> Summary {
    let (_, mut scenario) = platoon_config::Embedded::Paper.parse().unwrap();
    scenario.steps = steps;
    scenario.fleet.platoons = platoons;
    platoon_sim::run(scenario, |_| {}).unwrap()
}

fn round_trip(s: &Summary) -> (String, Summary) {
    let text = serde_json::to_string_pretty(s).unwrap();
    let back: Summary = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    (text, back)
}

#[test]
fn a_summary_round_trips_through_its_json() {
    for platoons in [1, 3] {
        let s = paper(2_000, platoons);
        assert_eq!(s.fleet.is_some(), platoons > 1);
        let (text, back) = round_trip(&s);
        assert_eq!(back, s, "{text}");
        assert_eq!(serde_json::to_string_pretty(&back).unwrap(), text);
    }
}

#[test]
fn numbers_json_cannot_hold_come_back_as_nan_and_write_the_same_bytes() {
    let mut s = paper(10, 1);
    s.vehicles[0].spacing_error_m.max_abs = f64::NAN;
    s.safety.min_gap_m = f64::INFINITY;
    let (text, back) = round_trip(&s);
    assert!(text.contains("\"max_abs\": null"), "{text}");
    assert!(back.vehicles[0].spacing_error_m.max_abs.is_nan());
    assert!(back.safety.min_gap_m.is_nan());
    assert_eq!(serde_json::to_string_pretty(&back).unwrap(), text);
}

#[test]
fn safety_classes_are_ordered_by_severity_and_named_as_in_files() {
    use SafetyClass::*;
    assert!(None < Negligible && Negligible < Benign && Benign < Severe);
    for c in [None, Negligible, Benign, Severe] {
        assert_eq!(serde_json::to_string(&c).unwrap(), format!("\"{c}\""));
    }
}
