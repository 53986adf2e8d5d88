//! Vehicles from outside the platoon that act on it: scripted cut-ins on the native plant (the
//! SUMO bridge moves its cut-in vehicles with the same formulas, `platoon.sumo.model.CutIns`).
//!
//! A cut-in is a car that appears at time `at_s` on the lane beside the platoon's, level with
//! the gap ahead of follower `ahead_of`: its front bumper `gap_m` ahead of the follower's
//! (bumper to bumper; without it in the middle of the gap, equal gaps to the member ahead and
//! to the follower), at the follower's speed plus `speed_diff_mps`. From then on it asks at
//! every step to change into the platoon's lane and does so only into a safe gap
//! ([`LaneChangeRule`], the rule of the members' lane changes, against the vehicles on the
//! platoon's lane), unless it is `aggressive` (it cuts in at once whatever the gap: the
//! aggressive driver a cut-in study asks for). Once in, it brakes at `decel_mps2` for
//! `brake_s` and keeps its speed after; from `leave_s` it asks to change back to the lane
//! beside, again into a safe gap there unless aggressive, and drives on there at the speed
//! it has until the run ends. Beside the platoon it holds its speed (a car waiting for a gap
//! it wants, then one that drove out). Its motion is exact for piecewise-constant
//! acceleration (it stops rather than reverses). The radar of the vehicle behind it on its
//! lane measures it ([`radar_truth`]), and [`RadarTruth::intruder`] says it is not the
//! platoon's predecessor.
use crate::lanes::LaneChangeRule;
use platoon_control::fallback::RadarTruth;
use platoon_model::State;

/// One scripted cut-in (`[[cut_ins]]` in a config; in the SUMO bridge's plant spec, whose
/// `platoon.sumo.model` moves it with the same formulas).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CutIn {
    /// When it appears beside the gap and starts asking to cut in (s).
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
    /// When it asks to leave the lane (s), if it does.
    pub leave_s: Option<f64>,
    /// Its length (m).
    pub length_m: f64,
    /// It changes lanes at once whatever the gap (`true`), or only into a safe gap.
    pub aggressive: bool,
}

/// Where a cut-in vehicle is: front bumper `p` (m), speed `v` (m/s) and lane, from the step it
/// appears.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intruder {
    /// Front bumper position (m).
    pub p: f64,
    /// Speed (m/s).
    pub v: f64,
    /// Length (m).
    pub length_m: f64,
    /// On the lane beside the platoon's (before it cut in, and after it left).
    pub beside: bool,
}

/// When a cut-in changed lanes: the plant's record of it (`traffic.cut_ins` of a run's summary
/// measures the same on the wire, from the radars).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Changes {
    /// When it appeared beside the platoon (s).
    appeared: Option<f64>,
    /// When it changed into the platoon's lane (s).
    entered: Option<f64>,
    /// When it changed back to the lane beside (s).
    left: Option<f64>,
}

/// The scripted cut-ins of one platoon, moving with its plant.
#[derive(Debug, Clone, Default)]
pub struct Traffic {
    cut_ins: Vec<CutIn>,
    /// Each cut-in's vehicle from the step it appears.
    cars: Vec<Option<Intruder>>,
    /// When each appeared, entered and left.
    changes: Vec<Changes>,
    /// When a car may change lanes.
    rule: LaneChangeRule,
}

impl Traffic {
    /// The cut-ins `cut_ins`, none on the road yet, changing lanes by `rule`.
    pub fn new(cut_ins: &[CutIn], rule: LaneChangeRule) -> Self {
        Self {
            cut_ins: cut_ins.to_vec(),
            cars: vec![None; cut_ins.len()],
            changes: vec![Changes::default(); cut_ins.len()],
            rule,
        }
    }

    /// Whether there is any cut-in at all.
    pub fn is_empty(&self) -> bool {
        self.cut_ins.is_empty()
    }

    /// The vehicles on the platoon's lane now.
    pub fn on_lane(&self) -> impl Iterator<Item = &Intruder> {
        self.cars_on(false)
    }

    /// The vehicles on the lane beside the platoon's now (waiting to cut in, or gone out).
    pub fn beside(&self) -> impl Iterator<Item = &Intruder> {
        self.cars_on(true)
    }

    /// Cut-in c's vehicle, once it appeared.
    pub fn car(&self, c: usize) -> Option<&Intruder> {
        self.cars.get(c).and_then(Option::as_ref)
    }

    /// When cut-in c changed into the platoon's lane (s), if it did.
    pub fn entered_s(&self, c: usize) -> Option<f64> {
        self.changes.get(c).and_then(|x| x.entered)
    }

    /// When cut-in c changed back to the lane beside (s), if it did.
    pub fn left_s(&self, c: usize) -> Option<f64> {
        self.changes.get(c).and_then(|x| x.left)
    }

    /// The cars at step `k` (time `t = k dt`), given the platoon's `states` at that step:
    /// those due appear beside the platoon, those that want the other lane change into it
    /// where the gap is safe. Called once per step, after the platoon moved there.
    /// `lengths` holds every vehicle's length, leader first; `off_lane[i]`: member i is in the
    /// lane beside (empty: every member is on the platoon's lane).
    pub fn arrive(&mut self, t: f64, states: &[State], lengths: &[f64], off_lane: &[bool]) {
        for c in 0..self.cut_ins.len() {
            let cut = self.cut_ins[c];
            if self.cars[c].is_none() && t >= cut.at_s {
                let (ahead, behind) = (states[cut.ahead_of - 1], states[cut.ahead_of]);
                let p = match cut.gap_m {
                    Some(g) => behind[0] + g + cut.length_m,
                    // Equal gaps: ahead[0] - L - p = p - length - behind[0].
                    None => 0.5 * (ahead[0] - lengths[cut.ahead_of - 1] + behind[0] + cut.length_m),
                };
                self.cars[c] = Some(Intruder {
                    p,
                    v: (behind[1] + cut.speed_diff_mps).max(0.0),
                    length_m: cut.length_m,
                    beside: true,
                });
                self.changes[c].appeared = Some(t);
            }
            let Some(car) = self.cars[c] else { continue };
            // It asks for the platoon's lane until its time there is up, then for the lane
            // beside (a car that never got in stays there; one that left never comes back).
            let wants_beside =
                cut.leave_s.is_some_and(|l| t >= l) || self.changes[c].left.is_some();
            if wants_beside == car.beside {
                continue;
            }
            if !cut.aggressive && !self.safe(c, car, wants_beside, states, lengths, off_lane) {
                continue;
            }
            self.cars[c] = Some(Intruder {
                beside: wants_beside,
                ..car
            });
            match wants_beside {
                false => self.changes[c].entered = Some(t),
                true => self.changes[c].left = Some(t),
            }
        }
    }

    /// Whether cut-in c's `car` may move onto the lane beside (`beside`) or the platoon's: the
    /// members on that lane and the other cars there.
    fn safe(
        &self,
        c: usize,
        car: Intruder,
        beside: bool,
        states: &[State],
        lengths: &[f64],
        off_lane: &[bool],
    ) -> bool {
        let others = self.lane(c, beside, states, lengths, off_lane);
        self.rule.safe_among([car.p, car.v, car.length_m], others)
    }

    /// The vehicles on the lane beside (`beside`) or the platoon's, as `[front bumper, speed,
    /// length]`, cut-in c's own car left out: the members there, then the other cars there.
    fn lane<'a>(
        &'a self,
        c: usize,
        beside: bool,
        states: &'a [State],
        lengths: &'a [f64],
        off_lane: &'a [bool],
    ) -> impl Iterator<Item = [f64; 3]> + 'a {
        let off = move |i: usize| off_lane.get(i).copied().unwrap_or(false);
        let members = (0..states.len())
            .filter(move |&i| off(i) == beside)
            .map(|i| [states[i][0], states[i][1], lengths[i]]);
        members.chain(
            self.indexed_on(beside)
                .filter(move |(d, _)| *d != c)
                .map(|(_, x)| [x.p, x.v, x.length_m]),
        )
    }

    /// The cars on the lane beside (`beside`) or the platoon's.
    pub fn cars_on(&self, beside: bool) -> impl Iterator<Item = &Intruder> {
        self.indexed_on(beside).map(|(_, x)| x)
    }

    /// [`Traffic::cars_on`], with their cut-in's index.
    fn indexed_on(&self, beside: bool) -> impl Iterator<Item = (usize, &Intruder)> {
        (self.cars.iter().enumerate())
            .filter_map(move |(d, x)| x.as_ref().filter(|x| x.beside == beside).map(|x| (d, x)))
    }

    /// Moves every car from time `t` to `t + dt`, given the platoon at `t` (`states`,
    /// `lengths`, `off_lane` as for [`Traffic::arrive`]): once it cut in it brakes for
    /// `brake_s` from the moment it entered, and otherwise holds its speed; whatever its script,
    /// while it closes in on the vehicle ahead on its lane (a member or another car) nearer than
    /// the lane-change rule's safe gap it brakes at the rule's `safe_decel_mps2` (so it does
    /// not drive into it unless that one brakes harder).
    pub fn advance(
        &mut self,
        t: f64,
        dt: f64,
        states: &[State],
        lengths: &[f64],
        off_lane: &[bool],
    ) {
        let held: Vec<Option<f64>> = (0..self.cars.len())
            .map(|c| self.acceleration(c, t, dt, states, lengths, off_lane))
            .collect();
        for (slot, a) in self.cars.iter_mut().zip(held) {
            if let (Some(x), Some(a)) = (slot, a) {
                x.p += x.v * dt + 0.5 * a * dt * dt;
                x.v += a * dt;
            }
        }
    }

    /// The acceleration cut-in c's car holds from `t` over `dt` (`None` before it appears).
    fn acceleration(
        &self,
        c: usize,
        t: f64,
        dt: f64,
        states: &[State],
        lengths: &[f64],
        off_lane: &[bool],
    ) -> Option<f64> {
        let (cut, x, done) = (&self.cut_ins[c], self.cars[c]?, &self.changes[c]);
        let a = match (done.entered, done.appeared) {
            // The braking lasts brake_s from the entry: from at_s when it cut in as it
            // appeared (the sum written so, the same float either way).
            (Some(e), Some(s)) if t < cut.at_s + cut.brake_s + (e - s) => -cut.decel_mps2,
            _ => 0.0,
        };
        // The nearest vehicle ahead on its lane: members first, then the other cars.
        let mut ahead: Option<[f64; 3]> = None;
        for o in self.lane(c, x.beside, states, lengths, off_lane) {
            if o[0] > x.p && ahead.is_none_or(|a| o[0] < a[0]) {
                ahead = Some(o);
            }
        }
        let a = match ahead {
            Some(o) if x.v > o[1] && !self.rule.gap_is_safe(o[0] - o[2] - x.p, x.v - o[1]) => {
                a.min(-self.rule.safe_decel_mps2)
            }
            _ => a,
        };
        // It stops rather than reverses.
        Some(if x.v + a * dt < 0.0 { -x.v / dt } else { a })
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
        // The cars on its own lane: before they cut in and after they left, on the lane beside.
        for (n, c) in traffic.cars.iter().enumerate() {
            let Some(c) = c.filter(|c| c.beside == off(i)) else {
                continue;
            };
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
            // 1 m either side of the car: too close for the rule.
            aggressive: true,
        }
    }

    const RULE: LaneChangeRule = LaneChangeRule::DEFAULT;

    #[test]
    fn a_cut_in_enters_mid_gap_is_seen_by_the_follower_behind_brakes_and_leaves() {
        let states = platoon();
        let mut t = Traffic::new(&[cut_in()], RULE);
        let mut truth = Vec::new();
        let l4 = [4.0; 4];
        t.arrive(0.99, &states, &l4, &[]);
        radar_truth(&states, &l4, &t, &[], &mut truth);
        let mut plain = Vec::new();
        platoon_control::fallback::radar_truth(&states, |_| 4.0, &mut plain);
        assert_eq!(truth, plain);
        t.arrive(1.0, &states, &l4, &[]);
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
            t.advance(1.0 + k as f64 * 0.01, 0.01, &[], &[], &[]);
        }
        let c = *t.on_lane().next().unwrap();
        assert!((c.v - 17.5).abs() < 1e-9, "{}", c.v);
        assert!((c.p - (85.0 + 18.0 * 0.5 - 0.125 + 17.5 * 0.5)).abs() < 1e-9);
        t.arrive(3.0, &states, &l4, &[]);
        assert_eq!(t.on_lane().count(), 0);
        // It drives on beside the platoon, and never comes back.
        assert_eq!(t.beside().count(), 1);
        assert_eq!((t.entered_s(0), t.left_s(0)), (Some(1.0), Some(3.0)));
        t.arrive(1.5, &states, &l4, &[]);
        assert_eq!(t.on_lane().count(), 0);
    }

    #[test]
    fn a_car_waits_beside_for_a_safe_gap_then_cuts_in_and_brakes_from_then() {
        // Followers 20 m apart: the car mid-gap of 16 m has 6 m either side, closing at 2 m/s
        // on follower 2 (it needs 2.5 + 1 + 0.5 = 4 m); but 10 m apart, 1 m: it waits.
        let l4 = [4.0; 4];
        let tight = platoon();
        let car = CutIn {
            aggressive: false,
            leave_s: None,
            ..cut_in()
        };
        let mut t = Traffic::new(&[car], RULE);
        t.arrive(1.0, &tight, &l4, &[]);
        assert_eq!((t.on_lane().count(), t.beside().count()), (0, 1));
        assert_eq!(t.entered_s(0), None);
        // The radar of a member on the platoon's lane does not see it; one beside would.
        let mut truth = Vec::new();
        radar_truth(&tight, &l4, &t, &[], &mut truth);
        let mut plain = Vec::new();
        platoon_control::fallback::radar_truth(&tight, |_| 4.0, &mut plain);
        assert_eq!(truth, plain);
        let beside = [false, false, false, true];
        radar_truth(&tight, &l4, &t, &beside, &mut truth);
        assert!(truth[3].is_some_and(|r| r.intruder), "{truth:?}");
        // Holding its speed beside, it falls back 2 m/s on the platoon: a second later it is
        // level with follower 2 (its tail 1 m behind follower 2's front): still waiting.
        for k in 0..100 {
            t.advance(1.0 + k as f64 * 0.01, 0.01, &[], &[], &[]);
        }
        let moved: Vec<State> = tight
            .iter()
            .map(|x| State::new(x[0] + 20.0, 20.0, 0.0))
            .collect();
        t.arrive(2.0, &moved, &l4, &[]);
        assert!((t.car(0).unwrap().p - 103.0).abs() < 1e-9);
        assert_eq!(t.entered_s(0), None);
        // The platoon opens its gaps: it cuts in, and brakes for 0.5 s from then (nobody near
        // ahead of it: the members do not move in this test).
        let open: Vec<State> = [120.0, 100.0, 70.0, 50.0]
            .into_iter()
            .map(|p| State::new(p, 20.0, 0.0))
            .collect();
        let mut t2 = Traffic::new(&[car], RULE);
        t2.arrive(1.0, &tight, &l4, &[]);
        t2.arrive(1.5, &open, &l4, &[]);
        assert_eq!(t2.entered_s(0), Some(1.5));
        let v0 = t2.car(0).unwrap().v;
        for k in 0..100 {
            t2.advance(1.5 + k as f64 * 0.01, 0.01, &[], &[], &[]);
        }
        assert!((t2.car(0).unwrap().v - (v0 - 0.5)).abs() < 1e-9);
    }

    #[test]
    fn the_radar_view_names_the_predecessor_or_the_cut_in() {
        let states = platoon();
        let mut t = Traffic::new(&[cut_in()], RULE);
        let (mut truth, mut who) = (Vec::new(), Vec::new());
        let l4 = [4.0; 4];
        radar_view(&states, &l4, &t, &[], &mut truth, &mut who);
        use RadarTarget::*;
        assert_eq!(who, [Nothing, Member(0), Member(1), Member(2)]);
        t.arrive(1.0, &states, &l4, &[]);
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
        let mut t = Traffic::new(
            &[CutIn {
                decel_mps2: 50.0,
                brake_s: 10.0,
                ..cut_in()
            }],
            RULE,
        );
        t.arrive(1.0, &platoon(), &[4.0; 4], &[]);
        for k in 0..200 {
            t.advance(1.0 + k as f64 * 0.01, 0.01, &[], &[], &[]);
        }
        let c = *t.on_lane().next().unwrap();
        assert_eq!(c.v, 0.0);
        assert!(c.p > 85.0);
    }

    #[test]
    fn a_faster_car_brakes_behind_the_vehicle_ahead_rather_than_drive_into_it() {
        // Followers 20 m apart at 20 m/s; the car cuts in 2 m ahead of follower 2, 5 m/s
        // faster, 10 m behind follower 1's tail: closing at 5 m/s it would hit it in 2 s.
        let at = |k: u64| -> Vec<State> {
            (0..4)
                .map(|i| State::new(100.0 - 20.0 * i as f64 + 0.2 * k as f64, 20.0, 0.0))
                .collect()
        };
        let l4 = [4.0; 4];
        let car = CutIn {
            at_s: 0.0,
            gap_m: Some(2.0),
            speed_diff_mps: 5.0,
            decel_mps2: 0.0,
            brake_s: 0.0,
            leave_s: None,
            ..cut_in()
        };
        let mut t = Traffic::new(&[car], RULE);
        t.arrive(0.0, &at(0), &l4, &[]);
        assert_eq!(t.entered_s(0), Some(0.0));
        let mut smallest = f64::INFINITY;
        for k in 0..1000u64 {
            t.advance(k as f64 * 0.01, 0.01, &at(k), &l4, &[]);
            let x = *t.car(0).unwrap();
            let follower_1 = at(k + 1)[1];
            smallest = smallest.min(follower_1[0] - 4.0 - x.p);
        }
        // It braked to the follower's speed and kept at least the rule's smallest gap.
        assert!(smallest > 2.5, "{smallest}");
        assert!(t.car(0).unwrap().v <= 20.0 + 1e-9);
    }
}
