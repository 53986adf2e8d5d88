//! Vehicles from outside the platoon that act on it: scripted cut-ins on the native plant (the
//! SUMO bridge moves its cut-in vehicles with the same formulas, `platoon.sumo.model.CutIns`).
//!
//! A cut-in is a vehicle that enters the platoon's lane at time `at_s` in the gap ahead of
//! follower `ahead_of`, `gap_m` ahead of the follower (bumper to bumper; without it in the
//! middle of the gap, equal gaps to the member ahead and to the follower), at the follower's speed plus `speed_diff_mps`, then brakes at `decel_mps2` for
//! `brake_s` and keeps its speed after; at `leave_s` it leaves the lane. Its motion is exact
//! for piecewise-constant acceleration (it stops rather than reverses). The radar of the
//! vehicle behind it measures it ([`radar_truth`]), and [`RadarTruth::intruder`] says it is not
//! the platoon's predecessor.
use platoon_control::fallback::RadarTruth;
use platoon_model::State;

/// One scripted cut-in (`[[cut_ins]]` in a config; in the SUMO bridge's plant spec, whose
/// `platoon.sumo.model` moves it with the same formulas).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CutIn {
    /// When it enters the lane (s).
    pub at_s: f64,
    /// The follower (1..=N) it cuts in front of.
    pub ahead_of: usize,
    /// The gap it leaves to that follower as it enters (m); `None`: the middle of the gap.
    pub gap_m: Option<f64>,
    /// Its speed at entry minus the follower's (m/s).
    pub speed_diff_mps: f64,
    /// How hard it brakes after entering (m/s^2, >= 0)...
    pub decel_mps2: f64,
    /// ...and for how long (s).
    pub brake_s: f64,
    /// When it leaves the lane (s), if it does.
    pub leave_s: Option<f64>,
    /// Its length (m).
    pub length_m: f64,
}

/// Where a cut-in vehicle is: front bumper `p` (m) and speed `v` (m/s), while on the lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intruder {
    /// Front bumper position (m).
    pub p: f64,
    /// Speed (m/s).
    pub v: f64,
    /// Length (m).
    pub length_m: f64,
}

/// The scripted cut-ins of one platoon, moving with its plant.
#[derive(Debug, Clone, Default)]
pub struct Traffic {
    cut_ins: Vec<CutIn>,
    /// Each cut-in's vehicle while it is on the lane.
    on_lane: Vec<Option<Intruder>>,
    /// Whether it has entered (it never enters twice).
    entered: Vec<bool>,
}

impl Traffic {
    /// The cut-ins `cut_ins`, none on the lane yet.
    pub fn new(cut_ins: &[CutIn]) -> Self {
        Self {
            cut_ins: cut_ins.to_vec(),
            on_lane: vec![None; cut_ins.len()],
            entered: vec![false; cut_ins.len()],
        }
    }

    /// Whether there is any cut-in at all.
    pub fn is_empty(&self) -> bool {
        self.cut_ins.is_empty()
    }

    /// The vehicles on the lane now.
    pub fn on_lane(&self) -> impl Iterator<Item = &Intruder> {
        self.on_lane.iter().flatten()
    }

    /// The intruders at step `k` (time `t = k dt`), given the platoon's `states` at that step:
    /// those due enter, those due leave. Called once per step, after the platoon moved there.
    /// `lengths` holds every vehicle's length, leader first.
    pub fn arrive(&mut self, t: f64, states: &[State], lengths: &[f64]) {
        for ((c, slot), entered) in self
            .cut_ins
            .iter()
            .zip(&mut self.on_lane)
            .zip(&mut self.entered)
        {
            if c.leave_s.is_some_and(|l| t >= l) {
                *slot = None;
            } else if !*entered && t >= c.at_s {
                *entered = true;
                let (ahead, behind) = (states[c.ahead_of - 1], states[c.ahead_of]);
                let p = match c.gap_m {
                    Some(g) => behind[0] + g + c.length_m,
                    // Equal gaps: ahead[0] - L - p = p - length - behind[0].
                    None => 0.5 * (ahead[0] - lengths[c.ahead_of - 1] + behind[0] + c.length_m),
                };
                *slot = Some(Intruder {
                    p,
                    v: (behind[1] + c.speed_diff_mps).max(0.0),
                    length_m: c.length_m,
                });
            }
        }
    }

    /// Moves every intruder from time `t` to `t + dt`.
    pub fn advance(&mut self, t: f64, dt: f64) {
        for (c, slot) in self.cut_ins.iter().zip(&mut self.on_lane) {
            if let Some(x) = slot {
                let braking = t < c.at_s + c.brake_s;
                let a = if braking { -c.decel_mps2 } else { 0.0 };
                // It stops rather than reverses.
                let a = if x.v + a * dt < 0.0 { -x.v / dt } else { a };
                x.p += x.v * dt + 0.5 * a * dt * dt;
                x.v += a * dt;
            }
        }
    }
}

/// What every vehicle's radar sees (leader first, `None` for the leader): the nearest vehicle
/// ahead on the lane, the platoon's predecessor or an intruder whose front is ahead of the
/// follower's. Without intruders this is [`platoon_control::fallback::radar_truth`], value for
/// value. `off_lane[i]`: vehicle i is in the lane beside (`[maneuvers]`; empty: nobody changes
/// lanes in this run).
pub fn radar_truth(
    states: &[State],
    lengths: &[f64],
    traffic: &Traffic,
    off_lane: &[bool],
    out: &mut Vec<Option<RadarTruth>>,
) {
    radar_view(states, lengths, traffic, off_lane, out, &mut Vec::new());
}

/// [`radar_truth`], and who each radar sees (`targets`, leader first): the member ahead on the
/// lane ([`RadarTarget::Member`]: the predecessor, unless vehicles change lanes, then the
/// nearest on its own lane by position) or the cut-in ([`RadarTarget::CutIn`], on the
/// platoon's lane). A vehicle in the lane beside sees the nearest member ahead of it there.
pub fn radar_view(
    states: &[State],
    lengths: &[f64],
    traffic: &Traffic,
    off_lane: &[bool],
    out: &mut Vec<Option<RadarTruth>>,
    targets: &mut Vec<RadarTarget>,
) {
    platoon_control::fallback::radar_truth(states, |j| lengths[j], out);
    targets.clear();
    targets.push(RadarTarget::Nothing);
    targets.extend((1..states.len()).map(|i| RadarTarget::Member(i as u16 - 1)));
    let off = |i: usize| off_lane.get(i).copied().unwrap_or(false);
    if !off_lane.is_empty() {
        // Vehicles change lanes: the nearest member ahead on its lane, by position (a joiner
        // that moved in stands between members; a leaver follows those that left before it).
        for i in 1..states.len() {
            let ahead = (0..states.len())
                .filter(|&j| j != i && off(j) == off(i) && states[j][0] > states[i][0])
                .min_by(|&a, &b| states[a][0].total_cmp(&states[b][0]));
            (out[i], targets[i]) = match ahead {
                Some(j) => (
                    Some(RadarTruth {
                        gap: states[j][0] - states[i][0] - lengths[j],
                        closing: states[i][1] - states[j][1],
                        intruder: false,
                    }),
                    RadarTarget::Member(j as u16),
                ),
                _ => (None, RadarTarget::Nothing),
            };
        }
    }
    for (i, ((x, t), who)) in states
        .iter()
        .zip(out.iter_mut())
        .zip(targets.iter_mut())
        .enumerate()
        .skip(1)
    {
        if off(i) {
            continue;
        }
        for (n, c) in traffic.on_lane.iter().enumerate() {
            let Some(c) = c else { continue };
            let gap = c.p - c.length_m - x[0];
            let nearer = t.is_none_or(|t| gap < t.gap);
            if c.p > x[0] && nearer {
                *t = Some(RadarTruth {
                    gap,
                    closing: x[1] - c.v,
                    intruder: true,
                });
                *who = RadarTarget::CutIn(n as u16);
            }
        }
    }
}

/// Who a vehicle's radar has in front of it: in `trajectories` and the per-message dataset of
/// runs with traffic that can touch the platoon, as `radar_target`, written as a string: the
/// member's vehicle number (`"2"`), `cut_in:<c>` for the platoon's scripted cut-in c (`[[cut_ins]]`
/// entry c), SUMO's id of a background vehicle (`bg<b>`), `unknown` for a vehicle from outside
/// the platoon the plant did not name, and nothing (an empty field) for nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RadarTarget {
    /// Nothing (the leader, or nothing within the radar's range).
    #[default]
    Nothing,
    /// A member of the platoon, by its number (the predecessor).
    Member(u16),
    /// The platoon's scripted cut-in c.
    CutIn(u16),
    /// SUMO's background vehicle `bg<b>`.
    Background(u32),
    /// A vehicle from outside the platoon that the plant did not name.
    Unknown,
}

impl std::fmt::Display for RadarTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RadarTarget::Nothing => Ok(()),
            RadarTarget::Member(i) => write!(f, "{i}"),
            RadarTarget::CutIn(c) => write!(f, "cut_in:{c}"),
            RadarTarget::Background(b) => write!(f, "bg{b}"),
            RadarTarget::Unknown => f.write_str("unknown"),
        }
    }
}

impl std::str::FromStr for RadarTarget {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("not a radar target: {s:?}");
        Ok(match s {
            "" => RadarTarget::Nothing,
            "unknown" => RadarTarget::Unknown,
            _ => match (s.strip_prefix("cut_in:"), s.strip_prefix("bg")) {
                (Some(c), _) => RadarTarget::CutIn(c.parse().map_err(|_| bad())?),
                (_, Some(b)) => RadarTarget::Background(b.parse().map_err(|_| bad())?),
                _ => RadarTarget::Member(s.parse().map_err(|_| bad())?),
            },
        })
    }
}

/// As its string; nothing as no value at all (an empty CSV field, a Parquet null).
impl serde::Serialize for RadarTarget {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            RadarTarget::Nothing => s.serialize_none(),
            _ => s.collect_str(self),
        }
    }
}

impl<'de> serde::Deserialize<'de> for RadarTarget {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn platoon() -> Vec<State> {
        // Leader at 100 m, followers 10 m apart, all at 20 m/s; vehicles 4 m long.
        (0..4)
            .map(|i| State::new(100.0 - 10.0 * i as f64, 20.0, 0.0))
            .collect()
    }

    fn cut_in() -> CutIn {
        CutIn {
            at_s: 1.0,
            ahead_of: 2,
            gap_m: None,
            speed_diff_mps: -2.0,
            decel_mps2: 1.0,
            brake_s: 0.5,
            leave_s: Some(3.0),
            length_m: 4.0,
        }
    }

    #[test]
    fn a_cut_in_enters_mid_gap_is_seen_by_the_follower_behind_brakes_and_leaves() {
        let states = platoon();
        let mut t = Traffic::new(&[cut_in()]);
        let mut truth = Vec::new();
        let l4 = [4.0; 4];
        t.arrive(0.99, &states, &l4);
        radar_truth(&states, &l4, &t, &[], &mut truth);
        let mut plain = Vec::new();
        platoon_control::fallback::radar_truth(&states, |_| 4.0, &mut plain);
        assert_eq!(truth, plain);
        t.arrive(1.0, &states, &l4);
        let c = *t.on_lane().next().unwrap();
        // Gap 6 m between followers 1 (at 90) and 2 (at 80): 1 m either side of a 4 m car.
        assert_eq!((c.p, c.v), (85.0, 18.0));
        radar_truth(&states, &l4, &t, &[], &mut truth);
        assert_eq!(
            truth[2],
            Some(RadarTruth {
                gap: 1.0,
                closing: 2.0,
                intruder: true
            })
        );
        assert_eq!((truth[1], truth[3]), (plain[1], plain[3]));
        // 0.5 s at -1 m/s^2, then constant speed.
        for k in 0..100 {
            t.advance(1.0 + k as f64 * 0.01, 0.01);
        }
        let c = *t.on_lane().next().unwrap();
        assert!((c.v - 17.5).abs() < 1e-9, "{}", c.v);
        assert!((c.p - (85.0 + 18.0 * 0.5 - 0.125 + 17.5 * 0.5)).abs() < 1e-9);
        t.arrive(3.0, &states, &l4);
        assert_eq!(t.on_lane().count(), 0);
        // It never comes back.
        t.arrive(1.5, &states, &l4);
        assert_eq!(t.on_lane().count(), 0);
    }

    #[test]
    fn the_radar_view_names_the_predecessor_or_the_cut_in() {
        let states = platoon();
        let mut t = Traffic::new(&[cut_in()]);
        let (mut truth, mut who) = (Vec::new(), Vec::new());
        let l4 = [4.0; 4];
        radar_view(&states, &l4, &t, &[], &mut truth, &mut who);
        use RadarTarget::*;
        assert_eq!(who, [Nothing, Member(0), Member(1), Member(2)]);
        t.arrive(1.0, &states, &l4);
        radar_view(&states, &l4, &t, &[], &mut truth, &mut who);
        assert_eq!(who, [Nothing, Member(0), CutIn(0), Member(2)]);
        let mut plain = Vec::new();
        radar_truth(&states, &l4, &t, &[], &mut plain);
        assert_eq!(truth, plain);
        // As the outputs write them, and back.
        for w in [Nothing, Member(2), CutIn(0), Background(17), Unknown] {
            let text = w.to_string();
            assert_eq!(text.parse::<RadarTarget>(), Ok(w), "{text}");
        }
        assert_eq!(CutIn(1).to_string(), "cut_in:1");
        assert_eq!(Background(17).to_string(), "bg17");
        assert!("cut_in:x".parse::<RadarTarget>().is_err());
    }

    #[test]
    fn an_intruder_stops_rather_than_reverses() {
        let mut t = Traffic::new(&[CutIn {
            decel_mps2: 50.0,
            brake_s: 10.0,
            ..cut_in()
        }]);
        t.arrive(1.0, &platoon(), &[4.0; 4]);
        for k in 0..200 {
            t.advance(1.0 + k as f64 * 0.01, 0.01);
        }
        let c = *t.on_lane().next().unwrap();
        assert_eq!(c.v, 0.0);
        assert!(c.p > 85.0);
    }
}
