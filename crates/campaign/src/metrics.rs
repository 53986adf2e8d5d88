//! The metrics a campaign collects per cell, read from the cell's `summary.json` (the same file
//! `platoon run` writes), so a cell run anywhere (a local worker, a Dask worker, a co-simulation)
//! reports the same numbers.
use platoon_sim::{Summary, VehicleSummary};
use serde::Deserialize;
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
        "first_collision_s",
        "when a gap first reached zero (any platoon), s; empty without a collision",
    ),
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
        "observed_jammed_s",
        "time some vehicle sensed jamming, measured (runs with jammers), s",
    ),
    (
        "observed_assumption2",
        "Assumption 2 on the observed jamming: holds or violated (runs with jammers and bounds)",
    ),
    (
        "max_affected_time_s",
        "longest time a follower was affected by attacks (A*), s",
    ),
    ("rejected_packets", "packets the controllers refused"),
    (
        "delivery_ratio",
        "link packets delivered as sent over link packets sent, measured on the wire (all platoons)",
    ),
    (
        "mean_cbr",
        "mean channel busy ratio the vehicles' radios measured (802.11p runs)",
    ),
    (
        "max_cbr",
        "largest channel busy ratio a vehicle's radio measured (802.11p runs)",
    ),
    (
        "channel_load",
        "mean load a vehicle's radio saw, packets per second per metre (802.11p runs)",
    ),
    (
        "transmissions",
        "packets the vehicles put on the air (802.11p runs, after DCC)",
    ),
    (
        "dcc_deferred",
        "packets DCC held back for a later step (802.11p runs with [channel.dcc])",
    ),
    (
        "detection_precision",
        "share of flagged packets that misbehaved, any detector (runs with [detection])",
    ),
    (
        "detection_recall",
        "share of misbehaving packets flagged, any detector (runs with [detection])",
    ),
    (
        "detection_f1",
        "F1 of any detector's flags against the ground truth (runs with [detection])",
    ),
    (
        "false_alarm_rate",
        "share of genuine packets flagged, any detector (runs with [detection])",
    ),
    (
        "time_to_detect_s",
        "first misbehaving packet to the first flag on one, s (runs with [detection])",
    ),
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
    (
        "maneuvers_completed",
        "maneuvers of the config completed by the end of the run (runs with [maneuvers])",
    ),
    (
        "maneuver_time_s",
        "the slowest completed maneuver, from its request to its completion (runs with [maneuvers]), s",
    ),
    (
        "maneuver_messages",
        "maneuver messages the vehicles broadcast (runs with [maneuvers])",
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

/// A figure `summary.json` holds as a number (a non-finite one is written as `null`, and read
/// back as NaN): not defined for this cell otherwise.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

fn num(x: Option<f64>) -> Metric {
    x.and_then(finite).map_or(Metric::Empty, Metric::Num)
}

/// `fold` of `figure` over the followers; not defined if any follower lacks it (or there are
/// none).
fn over_vehicles(
    summary: &Summary,
    figure: impl Fn(&VehicleSummary) -> f64,
    fold: fn(f64, f64) -> f64,
) -> Metric {
    summary
        .vehicles
        .iter()
        .map(|v| finite(figure(v)))
        .try_fold(None, |acc: Option<f64>, x| {
            x.map(|x| Some(acc.map_or(x, |a| fold(a, x))))
        })
        .flatten()
        .map_or(Metric::Empty, Metric::Num)
}

/// Reads a cell's `summary.json` (what `platoon run` wrote, extra keys such as `sumo`
/// ignored).
pub fn read(summary: &Value) -> Result<Summary, String> {
    Summary::deserialize(summary).map_err(|e| format!("summary.json is not a run summary: {e}"))
}

/// The values of the columns of `names` for one cell's summary.
pub fn extract(names: &[String], max_followers: usize, summary: &Summary) -> Vec<Metric> {
    let mut out = Vec::new();
    for name in names {
        if name == "triggers_by_follower" {
            for i in 1..=max_followers {
                out.push(
                    summary
                        .triggers
                        .get(&i.to_string())
                        .map_or(Metric::Empty, |n| Metric::Int(*n)),
                );
            }
            continue;
        }
        let m = platoon_metric(name, summary).or_else(|| run_metric(name, summary));
        out.push(m.unwrap_or(Metric::Empty));
    }
    out
}

/// A metric of the platoon's motion, safety and broadcasts; `None` for another name.
fn platoon_metric(name: &str, summary: &Summary) -> Option<Metric> {
    let fleet = summary.fleet.as_ref();
    let safety = &summary.safety;
    let followers = summary.vehicles.len();
    Some(match name {
        "max_spacing_error_m" => match fleet {
            Some(f) => f
                .per_platoon
                .iter()
                .map(|p| finite(p.max_spacing_error_m))
                .try_fold(0.0f64, |a, x| x.map(|x| a.max(x)))
                .map_or(Metric::Empty, Metric::Num),
            None => over_vehicles(summary, |v| v.spacing_error_m.max_abs, f64::max),
        },
        "rms_spacing_error_m" => {
            let rms: Option<Vec<f64>> = summary
                .vehicles
                .iter()
                .map(|v| finite(v.spacing_error_m.rms))
                .collect();
            match rms {
                Some(r) if !r.is_empty() => {
                    Metric::Num((r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt())
                }
                _ => Metric::Empty,
            }
        }
        "mean_spacing_error_m" => {
            match over_vehicles(summary, |v| v.spacing_error_m.mean_abs, |a, b| a + b) {
                Metric::Num(s) if followers > 0 => Metric::Num(s / followers as f64),
                _ => Metric::Empty,
            }
        }
        "final_spacing_error_m" => {
            over_vehicles(summary, |v| v.spacing_error_m.final_abs, f64::max)
        }
        "max_gap_error_m" => over_vehicles(summary, |v| v.gap_error_m.max_abs, f64::max),
        "gap_error_growth" => {
            let v = &summary.vehicles;
            let max = |x: Option<&VehicleSummary>| x.and_then(|x| finite(x.gap_error_m.max_abs));
            match (max(v.first()), max(v.last())) {
                (Some(a), Some(b)) if v.len() > 1 && (b / a).is_finite() => Metric::Num(b / a),
                _ => Metric::Empty,
            }
        }
        "max_velocity_error_mps" => {
            over_vehicles(summary, |v| v.velocity_error_mps.max_abs, f64::max)
        }
        "min_gap_m" => num(Some(fleet.map_or(safety.min_gap_m, |f| f.min_gap_m))),
        "max_deceleration_mps2" => {
            num(Some(fleet.map_or(safety.max_deceleration_mps2, |f| {
                f.max_deceleration_mps2
            })))
        }
        "safety_class" => Metric::Text(fleet.map_or(safety.class, |f| f.class).name().into()),
        "collided" => Metric::Int(u64::from(fleet.map_or(safety.collided, |f| f.collided))),
        "first_collision_s" => {
            num(fleet.map_or(safety.first_collision_t_s, |f| f.first_collision_t_s))
        }
        "triggers_total" => Metric::Int(fleet.map_or(summary.triggers_total, |f| f.triggers_total)),
        "triggers_per_follower" if followers > 0 => {
            Metric::Num(summary.triggers_total as f64 / followers as f64)
        }
        "min_ttc_s" => num(safety.min_ttc_s),
        "max_affected_time_s" => over_vehicles(summary, |v| v.affected_time_s, f64::max),
        _ => return None,
    })
}

/// A metric of the attack, the channel, detection, maneuvers and fallbacks; `None` for another
/// name.
fn run_metric(name: &str, summary: &Summary) -> Option<Metric> {
    Some(match name {
        "min_inter_event_s" => num(summary.min_inter_event_s),
        "assumption2" => match &summary.attack.assumption2 {
            Some(r) if r.holds => Metric::Text("holds".into()),
            Some(_) => Metric::Text("violated".into()),
            None => Metric::Empty,
        },
        "attack_intervals" => Metric::Int(summary.attack.intervals as u64),
        "attacked_time_s" => num(Some(summary.attack.attacked_time_s)),
        "observed_jammed_s" => num(summary.attack.observed.as_ref().map(|o| o.jammed_time_s)),
        "delivery_ratio" => num(summary.wire.as_ref().and_then(|w| {
            (w.totals.sent > 0).then(|| w.totals.delivered_as_sent as f64 / w.totals.sent as f64)
        })),
        "mean_cbr" => num(summary.channel.map(|c| c.mean_cbr)),
        "detection_precision" => num(summary.detection.as_ref().and_then(|d| d.any.precision)),
        "detection_recall" => num(summary.detection.as_ref().and_then(|d| d.any.recall)),
        "detection_f1" => num(summary.detection.as_ref().and_then(|d| d.any.f1)),
        "false_alarm_rate" => num(summary
            .detection
            .as_ref()
            .and_then(|d| d.any.false_alarm_rate)),
        "time_to_detect_s" => num(summary
            .detection
            .as_ref()
            .and_then(|d| d.any.time_to_detect_s)),
        "max_cbr" => num(summary.channel.map(|c| c.max_cbr)),
        "channel_load" => num(summary.channel.map(|c| c.mean_load)),
        "transmissions" => summary
            .channel
            .map_or(Metric::Empty, |c| Metric::Int(c.transmissions)),
        "dcc_deferred" => summary
            .channel
            .map_or(Metric::Empty, |c| Metric::Int(c.dcc_deferred)),
        "observed_assumption2" => {
            match summary
                .attack
                .observed
                .as_ref()
                .and_then(|o| o.assumption2.as_ref())
            {
                Some(r) if r.holds => Metric::Text("holds".into()),
                Some(_) => Metric::Text("violated".into()),
                None => Metric::Empty,
            }
        }
        "rejected_packets" => Metric::Int(summary.rejected_packets.total()),
        "fallback_time_s" => Metric::Num(
            summary
                .vehicles
                .iter()
                .flat_map(|v| v.mode_time_s.iter())
                .filter(|(mode, _)| mode.as_str() != "coop")
                .filter_map(|(_, t)| finite(*t))
                .sum(),
        ),
        "guard_activations" => {
            Metric::Int(summary.vehicles.iter().map(|v| v.guard_activations).sum())
        }
        "maneuvers_completed" => summary.maneuvers.as_ref().map_or(Metric::Empty, |m| {
            let done = m.maneuvers.iter().filter(|r| r.completion_s.is_some());
            Metric::Int(done.count() as u64)
        }),
        "maneuver_time_s" => num(summary.maneuvers.as_ref().and_then(|m| {
            m.maneuvers
                .iter()
                .filter_map(|r| r.completion_s)
                .reduce(f64::max)
        })),
        "maneuver_messages" => summary
            .maneuvers
            .as_ref()
            .map_or(Metric::Empty, |m| Metric::Int(m.messages_sent)),
        _ => return None,
    })
}

/// Why a cell whose run finished must still count as failed: it diverged (non-finite errors,
/// which `summary.json` writes as null) or stopped early.
pub fn failure(summary: &Summary) -> Option<String> {
    if !summary.complete {
        let why = summary.error.as_deref().unwrap_or("no reason given");
        return Some(format!("the run stopped early: {why}"));
    }
    let diverged = summary
        .vehicles
        .iter()
        .any(|v| !v.spacing_error_m.max_abs.is_finite());
    diverged.then(|| "the run diverged: a spacing error is not finite".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A real run's summary (the paper scenario, 10 steps) with the figures the tests expect.
    fn summary() -> Summary {
        let (_, mut scenario) = platoon_config::Embedded::Paper.parse().unwrap();
        scenario.steps = 10;
        let mut s = platoon_sim::run(scenario, |_| {}).unwrap();
        s.vehicles.truncate(2);
        s.triggers = [("1".to_string(), 10), ("2".to_string(), 20)].into();
        s.triggers_total = 30;
        s.min_inter_event_s = Some(0.02);
        let figures = [
            (
                1.5,
                0.3,
                0.2,
                0.01,
                2.0,
                1.0,
                2.0,
                2,
                [("coop", 50.0), ("acc", 4.0), ("blend", 1.0)].as_slice(),
            ),
            (
                0.5,
                0.4,
                0.4,
                0.02,
                0.5,
                2.0,
                3.0,
                1,
                [("coop", 52.5), ("zero", 2.5)].as_slice(),
            ),
        ];
        for (v, (max, rms, mean, fin, gap, vel, affected, guard, modes)) in
            s.vehicles.iter_mut().zip(figures)
        {
            v.spacing_error_m.max_abs = max;
            v.spacing_error_m.rms = rms;
            v.spacing_error_m.mean_abs = mean;
            v.spacing_error_m.final_abs = fin;
            v.gap_error_m.max_abs = gap;
            v.velocity_error_mps.max_abs = vel;
            v.affected_time_s = affected;
            v.guard_activations = guard;
            v.mode_time_s = modes.iter().map(|(m, t)| (m.to_string(), *t)).collect();
        }
        s.attack.intervals = 1;
        s.attack.attacked_time_s = 2.5;
        s.attack.assumption2 = Some(platoon_attacks::Assumption2Report {
            holds: false,
            worst_duration: None,
            worst_frequency: None,
        });
        s.safety.collided = false;
        s.safety.min_gap_m = 7.0;
        s.safety.max_deceleration_mps2 = 2.5;
        s.safety.class = platoon_sim::SafetyClass::Negligible;
        s.safety.min_ttc_s = Some(3.5);
        s.rejected_packets.non_finite = 1;
        s.rejected_packets.stale_seq = 2;
        let record = |completion_s: Option<f64>| platoon_sim::ManeuverRecord {
            maneuver: "leave".into(),
            vehicle: 2,
            outcome: if completion_s.is_some() {
                "completed"
            } else {
                "failed"
            }
            .into(),
            requested_t_s: Some(5.0),
            completion_s,
            max_spacing_error_m: Some(1.0),
            min_gap_m: Some(10.0),
            messages: 2,
        };
        s.maneuvers = Some(platoon_sim::ManeuversSummary {
            messages_sent: 9,
            maneuvers: vec![record(Some(0.5)), record(None), record(Some(21.5))],
            formations: Vec::new(),
            lane_changes: Vec::new(),
        });
        s
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
        assert_eq!(get("first_collision_s"), "", "no collision");
        assert_eq!(get("triggers_per_follower"), "15");
        assert_eq!(get("triggers_2"), "20");
        assert_eq!(get("triggers_3"), "", "a follower this cell does not have");
        assert_eq!(get("assumption2"), "violated");
        assert_eq!(get("max_affected_time_s"), "3");
        assert_eq!(get("rejected_packets"), "3");
        assert_eq!(get("min_ttc_s"), "3.5");
        assert_eq!(get("fallback_time_s"), "7.5");
        assert_eq!(get("guard_activations"), "3");
        assert_eq!(get("maneuvers_completed"), "2");
        assert_eq!(get("maneuver_time_s"), "21.5");
        assert_eq!(get("maneuver_messages"), "9");
        assert!(failure(&summary()).is_none());
    }

    #[test]
    fn diverged_and_incomplete_runs_fail() {
        let mut s = summary();
        s.vehicles[1].spacing_error_m.max_abs = f64::NAN;
        // Through summary.json (NaN is written as null), as a campaign reads it.
        let s = read(&serde_json::to_value(&s).unwrap()).unwrap();
        assert!(failure(&s).unwrap().contains("diverged"));
        assert_eq!(
            extract(&["max_spacing_error_m".into()], 2, &s),
            [Metric::Empty],
            "a diverged follower leaves the largest error undefined"
        );
        let mut s = s;
        s.complete = false;
        s.error = Some("plant died".into());
        assert!(failure(&s).unwrap().contains("plant died"));
    }

    #[test]
    fn unknown_metrics_are_named() {
        let e = validate(&["max_spacing_error_m".into(), "speed".into()]).unwrap_err();
        assert!(e.contains("`speed`"), "{e}");
    }
}
