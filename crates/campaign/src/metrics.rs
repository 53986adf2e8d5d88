//! The metrics a campaign collects per cell, read from the cell's `summary.json` (the same file
//! `platoon run` writes), so a cell run anywhere (a local worker, a Dask worker, a co-simulation)
//! reports the same numbers.
use serde_json::Value;
use std::fmt;

/// Every metric: its name (the `cells.csv` column) and what it is.
pub const ALL: &[(&str, &str)] = &[
    (
        "max_spacing_error_m",
        "largest |spacing error| of any follower (of any platoon of a fleet), m",
    ),
    (
        "rms_spacing_error_m",
        "RMS spacing error over the followers and the run (platoon 0), m",
    ),
    (
        "mean_spacing_error_m",
        "mean |spacing error| over the followers and the run (platoon 0), m",
    ),
    (
        "final_spacing_error_m",
        "largest |spacing error| at the last step (platoon 0), m",
    ),
    (
        "max_gap_error_m",
        "largest |gap error to the predecessor| of any follower (platoon 0), m",
    ),
    (
        "gap_error_growth",
        "the last follower's largest |gap error| over the first's (platoon 0): above 1, errors grew along the platoon",
    ),
    (
        "max_velocity_error_mps",
        "largest |velocity error| of any follower (platoon 0), m/s",
    ),
    (
        "min_gap_m",
        "smallest bumper-to-bumper gap (any platoon), m",
    ),
    (
        "max_deceleration_mps2",
        "largest deceleration any follower needed, m/s^2",
    ),
    (
        "safety_class",
        "none, negligible, benign or severe (any collision is severe)",
    ),
    ("collided", "a gap reached zero"),
    (
        "triggers_total",
        "broadcasts of all followers (all platoons)",
    ),
    (
        "triggers_per_follower",
        "mean broadcasts per follower (platoon 0)",
    ),
    (
        "triggers_by_follower",
        "one column per follower: triggers_1, triggers_2, ... (platoon 0)",
    ),
    (
        "min_inter_event_s",
        "shortest time between two broadcasts of a follower, s",
    ),
    (
        "assumption2",
        "holds or violated (empty without attack.assumption2 bounds)",
    ),
    ("attack_intervals", "DoS intervals in the run"),
    ("attacked_time_s", "time the channel was jammed, s"),
    (
        "max_affected_time_s",
        "longest time a follower was affected by attacks (A*), s",
    ),
    ("rejected_packets", "packets the controllers refused"),
    (
        "min_ttc_s",
        "smallest time to collision of a follower closing in (platoon 0), s",
    ),
    (
        "fallback_time_s",
        "time followers spent outside the cooperative law, summed (platoon 0), s",
    ),
    (
        "guard_activations",
        "times the emergency-braking guard took over, all followers (platoon 0)",
    ),
];

/// Collected when the campaign file names none.
pub const DEFAULT: &[&str] = &[
    "max_spacing_error_m",
    "rms_spacing_error_m",
    "min_gap_m",
    "max_deceleration_mps2",
    "safety_class",
    "triggers_total",
    "triggers_per_follower",
    "min_inter_event_s",
    "assumption2",
    "attacked_time_s",
];

/// One metric's value in one cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Metric {
    /// A number.
    Num(f64),
    /// A count.
    Int(u64),
    /// A label (safety class, verdict).
    Text(String),
    /// Not defined for this cell (e.g. no inter-event time with one broadcast).
    Empty,
}

impl Metric {
    /// The value as a number, if it is one (`collided` reads 0/1).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Metric::Num(x) => Some(*x),
            Metric::Int(n) => Some(*n as f64),
            _ => None,
        }
    }
}

impl fmt::Display for Metric {
    /// The `cells.csv` field: the shortest text that reads back to the same number.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Metric::Num(x) => write!(f, "{x}"),
            Metric::Int(n) => write!(f, "{n}"),
            Metric::Text(s) => f.write_str(s),
            Metric::Empty => Ok(()),
        }
    }
}

/// Checks metric names; the error names the first unknown one and lists the known ones.
pub fn validate(names: &[String]) -> Result<(), String> {
    for n in names {
        if !ALL.iter().any(|(m, _)| m == n) {
            let known: Vec<&str> = ALL.iter().map(|(m, _)| *m).collect();
            return Err(format!("unknown metric `{n}`; known: {}", known.join(", ")));
        }
    }
    Ok(())
}

/// The `cells.csv` columns of `names` (`triggers_by_follower` expands to one column per
/// follower of the largest platoon of the campaign).
pub fn columns(names: &[String], max_followers: usize) -> Vec<String> {
    names
        .iter()
        .flat_map(|n| {
            if n == "triggers_by_follower" {
                (1..=max_followers)
                    .map(|i| format!("triggers_{i}"))
                    .collect()
            } else {
                vec![n.clone()]
            }
        })
        .collect()
}

fn num(v: &Value) -> Metric {
    v.as_f64().map_or(Metric::Empty, Metric::Num)
}

fn int(v: &Value) -> Metric {
    v.as_u64().map_or(Metric::Empty, Metric::Int)
}

fn vehicles(summary: &Value) -> &[Value] {
    summary["vehicles"].as_array().map_or(&[], |v| v.as_slice())
}

fn over_vehicles(summary: &Value, path: &[&str], fold: fn(f64, f64) -> f64) -> Metric {
    let mut acc: Option<f64> = None;
    for v in vehicles(summary) {
        let mut x = v;
        for p in path {
            x = &x[*p];
        }
        let Some(x) = x.as_f64() else {
            return Metric::Empty;
        };
        acc = Some(acc.map_or(x, |a| fold(a, x)));
    }
    acc.map_or(Metric::Empty, Metric::Num)
}

/// The values of the columns of `names` for one cell's summary.
pub fn extract(names: &[String], max_followers: usize, summary: &Value) -> Vec<Metric> {
    let fleet = summary.get("fleet").filter(|f| f.is_object());
    let safety = &summary["safety"];
    let mut out = Vec::new();
    for name in names {
        let m = match name.as_str() {
            "max_spacing_error_m" => match fleet {
                Some(f) => f["per_platoon"]
                    .as_array()
                    .and_then(|ps| {
                        ps.iter()
                            .map(|p| p["max_spacing_error_m"].as_f64())
                            .try_fold(0.0f64, |a, x| x.map(|x| a.max(x)))
                    })
                    .map_or(Metric::Empty, Metric::Num),
                None => over_vehicles(summary, &["spacing_error_m", "max_abs"], f64::max),
            },
            "rms_spacing_error_m" => {
                let rms: Option<Vec<f64>> = vehicles(summary)
                    .iter()
                    .map(|v| v["spacing_error_m"]["rms"].as_f64())
                    .collect();
                match rms {
                    Some(r) if !r.is_empty() => {
                        Metric::Num((r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt())
                    }
                    _ => Metric::Empty,
                }
            }
            "mean_spacing_error_m" => {
                let n = vehicles(summary).len();
                match over_vehicles(summary, &["spacing_error_m", "mean_abs"], |a, b| a + b) {
                    Metric::Num(s) if n > 0 => Metric::Num(s / n as f64),
                    _ => Metric::Empty,
                }
            }
            "final_spacing_error_m" => {
                over_vehicles(summary, &["spacing_error_m", "final_abs"], f64::max)
            }
            "max_gap_error_m" => over_vehicles(summary, &["gap_error_m", "max_abs"], f64::max),
            "gap_error_growth" => {
                let v = vehicles(summary);
                let max = |x: Option<&Value>| x.and_then(|x| x["gap_error_m"]["max_abs"].as_f64());
                match (max(v.first()), max(v.last())) {
                    (Some(a), Some(b)) if v.len() > 1 && (b / a).is_finite() => Metric::Num(b / a),
                    _ => Metric::Empty,
                }
            }
            "max_velocity_error_mps" => {
                over_vehicles(summary, &["velocity_error_mps", "max_abs"], f64::max)
            }
            "min_gap_m" => num(&fleet.unwrap_or(safety)["min_gap_m"]),
            "max_deceleration_mps2" => num(&fleet.unwrap_or(safety)["max_deceleration_mps2"]),
            "safety_class" => fleet.unwrap_or(safety)["class"]
                .as_str()
                .map_or(Metric::Empty, |s| Metric::Text(s.into())),
            "collided" => fleet.unwrap_or(safety)["collided"]
                .as_bool()
                .map_or(Metric::Empty, |c| Metric::Int(u64::from(c))),
            "triggers_total" => int(&fleet.unwrap_or(summary)["triggers_total"]),
            "triggers_per_follower" => {
                let n = vehicles(summary).len();
                match summary["triggers_total"].as_u64() {
                    Some(t) if n > 0 => Metric::Num(t as f64 / n as f64),
                    _ => Metric::Empty,
                }
            }
            "triggers_by_follower" => {
                for i in 1..=max_followers {
                    out.push(int(&summary["triggers"][i.to_string()]));
                }
                continue;
            }
            "min_inter_event_s" => num(&summary["min_inter_event_s"]),
            "assumption2" => match summary["attack"]["assumption2"]["holds"].as_bool() {
                Some(true) => Metric::Text("holds".into()),
                Some(false) => Metric::Text("violated".into()),
                None => Metric::Empty,
            },
            "attack_intervals" => int(&summary["attack"]["intervals"]),
            "attacked_time_s" => num(&summary["attack"]["attacked_time_s"]),
            "max_affected_time_s" => over_vehicles(summary, &["affected_time_s"], f64::max),
            "rejected_packets" => summary["rejected_packets"]
                .as_object()
                .map(|o| o.values().filter_map(Value::as_u64).sum())
                .map_or(Metric::Empty, Metric::Int),
            "min_ttc_s" => num(&safety["min_ttc_s"]),
            "fallback_time_s" => Metric::Num(
                vehicles(summary)
                    .iter()
                    .filter_map(|v| v["mode_time_s"].as_object())
                    .flat_map(|m| m.iter())
                    .filter(|(mode, _)| mode.as_str() != "coop")
                    .filter_map(|(_, t)| t.as_f64())
                    .sum(),
            ),
            "guard_activations" => Metric::Int(
                vehicles(summary)
                    .iter()
                    .filter_map(|v| v["guard_activations"].as_u64())
                    .sum(),
            ),
            _ => Metric::Empty,
        };
        out.push(m);
    }
    out
}

/// Why a cell whose run finished must still count as failed: it diverged (non-finite errors,
/// which `summary.json` writes as null) or stopped early.
pub fn failure(summary: &Value) -> Option<String> {
    if summary["complete"].as_bool() != Some(true) {
        let why = summary["error"].as_str().unwrap_or("no reason given");
        return Some(format!("the run stopped early: {why}"));
    }
    let diverged = vehicles(summary).iter().any(|v| {
        v["spacing_error_m"]["max_abs"]
            .as_f64()
            .is_none_or(|x| !x.is_finite())
    });
    diverged.then(|| "the run diverged: a spacing error is not finite".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary() -> Value {
        serde_json::json!({
            "complete": true,
            "triggers": {"1": 10, "2": 20},
            "triggers_total": 30,
            "min_inter_event_s": 0.02,
            "vehicles": [
                {"spacing_error_m": {"max_abs": 1.5, "rms": 0.3, "mean_abs": 0.2, "final_abs": 0.01},
                 "gap_error_m": {"max_abs": 2.0},
                 "velocity_error_mps": {"max_abs": 1.0}, "affected_time_s": 2.0,
                 "mode_time_s": {"coop": 50.0, "acc": 4.0, "blend": 1.0}, "guard_activations": 2},
                {"spacing_error_m": {"max_abs": 0.5, "rms": 0.4, "mean_abs": 0.4, "final_abs": 0.02},
                 "gap_error_m": {"max_abs": 0.5},
                 "velocity_error_mps": {"max_abs": 2.0}, "affected_time_s": 3.0,
                 "mode_time_s": {"coop": 52.5, "zero": 2.5}, "guard_activations": 1}
            ],
            "attack": {"intervals": 1, "attacked_time_s": 2.5, "assumption2": {"holds": false}},
            "safety": {"collided": false, "min_gap_m": 7.0, "max_deceleration_mps2": 2.5, "class": "negligible", "min_ttc_s": 3.5},
            "rejected_packets": {"non_finite": 1, "stale_seq": 2}
        })
    }

    #[test]
    fn reads_every_metric_from_a_summary() {
        let names: Vec<String> = ALL.iter().map(|(n, _)| n.to_string()).collect();
        let cols = columns(&names, 3);
        let vals = extract(&names, 3, &summary());
        assert_eq!(cols.len(), vals.len());
        let get = |c: &str| vals[cols.iter().position(|x| x == c).unwrap()].to_string();
        assert_eq!(get("max_spacing_error_m"), "1.5");
        assert_eq!(get("rms_spacing_error_m"), (0.125f64).sqrt().to_string());
        assert_eq!(get("mean_spacing_error_m"), "0.30000000000000004");
        assert_eq!(get("max_gap_error_m"), "2");
        assert_eq!(get("gap_error_growth"), "0.25");
        assert_eq!(get("safety_class"), "negligible");
        assert_eq!(get("collided"), "0");
        assert_eq!(get("triggers_per_follower"), "15");
        assert_eq!(get("triggers_2"), "20");
        assert_eq!(get("triggers_3"), "", "a follower this cell does not have");
        assert_eq!(get("assumption2"), "violated");
        assert_eq!(get("max_affected_time_s"), "3");
        assert_eq!(get("rejected_packets"), "3");
        assert_eq!(get("min_ttc_s"), "3.5");
        assert_eq!(get("fallback_time_s"), "7.5");
        assert_eq!(get("guard_activations"), "3");
        assert!(failure(&summary()).is_none());
    }

    #[test]
    fn diverged_and_incomplete_runs_fail() {
        let mut s = summary();
        s["vehicles"][1]["spacing_error_m"]["max_abs"] = Value::Null;
        assert!(failure(&s).unwrap().contains("diverged"));
        s["complete"] = Value::Bool(false);
        s["error"] = Value::String("plant died".into());
        assert!(failure(&s).unwrap().contains("plant died"));
    }

    #[test]
    fn unknown_metrics_are_named() {
        let e = validate(&["max_spacing_error_m".into(), "speed".into()]).unwrap_err();
        assert!(e.contains("`speed`"), "{e}");
    }
}
