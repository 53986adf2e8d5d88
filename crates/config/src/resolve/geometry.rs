//! Who fits where when they appear: the vehicles of `platoon.initial_states` on their lane at
//! t = 0 (a joiner included), each `[[cut_ins]]` car in its gap at its `at_s`, the vehicles of
//! `[[sumo.ahead]]` ahead of the leader. A vehicle that would appear inside another is a
//! config error naming the key that puts it there (docs/traffic.md#checked-before-the-run).
use super::checks::bad;
use crate::error::{KeyError, Num};
use crate::schema::Config;
use platoon_model::{LeaderProfile, State};

/// The fastest a scripted cut-in may enter at (m/s): SUMO's vehicle type for it (`maxSpeed`).
pub(crate) const CUT_IN_MAX_SPEED_MPS: f64 = 100.0;

/// The platoon as the checks see it: where it starts and the formation it keeps.
pub(crate) struct Layout<'a> {
    /// The initial states, leader first.
    pub initial: &'a [State],
    /// Every vehicle's length, leader first.
    pub lengths: Vec<f64>,
    /// Spacing in formation, front to front at standstill (m).
    pub spacing: f64,
    /// Time headway (s).
    pub headway: f64,
    /// The leader's profile.
    pub leader: &'a LeaderProfile,
}

impl Layout<'_> {
    /// The gap (bumper to bumper, m) ahead of follower `k` at time `t`: at t = 0 the initial
    /// states'; later the larger of that and the gap in formation at the leader's speed then
    /// (the platoon closes up to its formation or stays wider, as it started).
    pub(crate) fn gap_ahead_of(&self, k: usize, t: f64) -> f64 {
        let initial = self.initial[k - 1][0] - self.lengths[k - 1] - self.initial[k][0];
        if t <= 0.0 {
            return initial;
        }
        let formation =
            self.spacing + self.headway * self.leader.velocity_at(t) - self.lengths[k - 1];
        initial.max(formation)
    }

    /// Follower `k`'s speed at time `t` (m/s): its initial speed at t = 0, the leader's
    /// profile's later (in formation).
    pub(crate) fn speed_of(&self, k: usize, t: f64) -> f64 {
        if t <= 0.0 {
            self.initial[k][1]
        } else {
            self.leader.velocity_at(t)
        }
    }
}

/// `platoon.initial_states`: no vehicle starts inside another on its lane (the joiners from
/// the lane beside, `beside[i]`, on theirs).
pub(crate) fn initial_states(c: &Config, layout: &Layout<'_>) -> Result<(), KeyError> {
    if c.platoon.initial_states.is_none() {
        // [platoon.formation] keeps every gap open (its jitter is checked).
        return Ok(());
    }
    let beside: Vec<usize> = c
        .maneuvers
        .iter()
        .flat_map(|m| &m.joins)
        .filter(|j| j.behind.is_some())
        .map(|j| j.vehicle)
        .collect();
    for lane in [false, true] {
        let mut on: Vec<usize> = (0..layout.initial.len())
            .filter(|i| beside.contains(i) == lane)
            .collect();
        on.sort_by(|&a, &b| layout.initial[b][0].total_cmp(&layout.initial[a][0]));
        for w in on.windows(2) {
            let (ahead, behind) = (w[0], w[1]);
            let rear = layout.initial[ahead][0] - layout.lengths[ahead];
            let front = layout.initial[behind][0];
            if front >= rear {
                let who = |i: usize| {
                    if i == 0 {
                        "the leader".to_string()
                    } else {
                        format!("vehicle {i}")
                    }
                };
                return bad(
                    &format!("platoon.initial_states[{behind}]"),
                    format!(
                        "{} starts inside {}{}: its front at {} m is not behind {}'s rear at {} \
                         m ({} m long); start it behind {} m",
                        who(behind),
                        who(ahead),
                        if lane { " in the lane beside" } else { "" },
                        Num(front),
                        who(ahead),
                        Num(rear),
                        Num(layout.lengths[ahead]),
                        Num(rear)
                    ),
                );
            }
        }
    }
    Ok(())
}

/// `[[cut_ins]]` car `i` (already checked key by key): it fits its gap when it enters, enters
/// at a speed a car can drive, and no other car is in that gap then.
pub(crate) fn cut_in(
    c: &Config,
    layout: &Layout<'_>,
    i: usize,
    x: &platoon_sim::traffic::CutIn,
    earlier: &[platoon_sim::traffic::CutIn],
) -> Result<(), KeyError> {
    let key = |k: &str| format!("cut_ins[{i}].{k}");
    let k = x.ahead_of;
    let gap = layout.gap_ahead_of(k, x.at_s);
    let when = format!("at {} s", Num(x.at_s));
    let length_key = if c.cut_ins[i].length_m.is_some() {
        key("length_m")
    } else {
        "platoon.vehicle_length_m".to_string()
    };
    if x.length_m >= gap {
        return bad(
            &length_key,
            format!(
                "the car of cut_ins[{i}], {} m long, does not fit the {} m gap ahead of follower \
                 {k} {when} (it would start inside a vehicle): make it shorter than the gap",
                Num(x.length_m),
                Num(gap)
            ),
        );
    }
    if let Some(g) = x.gap_m {
        if g <= 0.0 || g + x.length_m >= gap {
            return bad(
                &key("gap_m"),
                format!(
                    "{} m puts the car ({} m long) {} the {} m gap ahead of follower {k} {when}: \
                     it must leave 0 < gap_m < {} m (the gap less the car)",
                    Num(g),
                    Num(x.length_m),
                    if g <= 0.0 {
                        format!("against follower {k}, not in")
                    } else {
                        "inside or ahead of the vehicle in front, beyond".to_string()
                    },
                    Num(gap),
                    Num(gap - x.length_m)
                ),
            );
        }
    }
    let v = layout.speed_of(k, x.at_s);
    let entry = v + x.speed_diff_mps;
    if !(0.0..=CUT_IN_MAX_SPEED_MPS).contains(&entry) {
        return bad(
            &key("speed_diff_mps"),
            format!(
                "{} m/s makes the car enter at {} m/s (follower {k} drives at {} m/s {when}): a \
                 car enters at 0 to {CUT_IN_MAX_SPEED_MPS} m/s, so speed_diff_mps must be in \
                 [{}, {}]",
                Num(x.speed_diff_mps),
                Num(entry),
                Num(v),
                Num(-v),
                Num(CUT_IN_MAX_SPEED_MPS - v)
            ),
        );
    }
    let until = |y: &platoon_sim::traffic::CutIn| y.leave_s.unwrap_or(f64::INFINITY);
    if let Some((j, y)) = earlier
        .iter()
        .enumerate()
        .find(|(_, y)| y.ahead_of == k && x.at_s < until(y) && y.at_s < until(x))
    {
        return bad(
            &key("at_s"),
            format!(
                "the car of cut_ins[{i}] would be in the gap ahead of follower {k} together with \
                 cut_ins[{j}]'s (on the lane from {} s{}), each placed as if alone: one car in a \
                 gap at a time (enter after the other's leave_s, or ahead of another follower)",
                Num(y.at_s),
                y.leave_s
                    .map_or(" to the end".to_string(), |l| format!(" to {} s", Num(l)))
            ),
        );
    }
    Ok(())
}

/// `[[sumo.ahead]]`: the vehicles ahead of each leader do not overlap one another, nor, in a
/// fleet of platoons sharing a lane, the platoon ahead; and a leader that drives its profile
/// (it has no radar, and SUMO's car-following model does not drive it) never reaches one
/// within the run (`duration` s).
pub(crate) fn ahead(c: &Config, layout: &Layout<'_>, duration: f64) -> Result<(), KeyError> {
    let a = &c.sumo.ahead;
    // (from, to) of each, measured ahead of the leader's front.
    let span = |x: &crate::schema::AheadVehicle| (x.gap_m, x.gap_m + x.length_m);
    for (i, x) in a.iter().enumerate() {
        let (lo, hi) = span(x);
        if let Some(j) = (0..i).find(|&j| {
            let (l, h) = span(&a[j]);
            lo < h && l < hi
        }) {
            return bad(
                &format!("sumo.ahead[{i}].gap_m"),
                format!(
                    "{} m puts it ({} m long) inside sumo.ahead[{j}] ({} to {} m ahead of the \
                     leader): vehicles ahead must not overlap",
                    Num(x.gap_m),
                    Num(x.length_m),
                    Num(span(&a[j]).0),
                    Num(span(&a[j]).1)
                ),
            );
        }
        let lanes = c.fleet.lanes.as_ref().map_or(1, Vec::len);
        if c.fleet.platoons > lanes {
            let back = layout
                .initial
                .iter()
                .zip(&layout.lengths)
                .map(|(s, l)| s[0] - l)
                .fold(f64::INFINITY, f64::min);
            let room = c.fleet.gap_m - (layout.initial[0][0] - back);
            if hi >= room {
                return bad(
                    &format!("sumo.ahead[{i}].gap_m"),
                    format!(
                        "{} m puts it ({} m long) inside the platoon ahead on the same lane, \
                         whose tail is {} m ahead of the leader (fleet.gap_m = {})",
                        Num(x.gap_m),
                        Num(x.length_m),
                        Num(room),
                        Num(c.fleet.gap_m)
                    ),
                );
            }
        }
    }
    if c.leader.drive.is_profile() {
        for (i, x) in a.iter().enumerate() {
            if let Some(t) = caught_up(layout.leader, x.speed_mps, x.gap_m, duration) {
                return bad(
                    &format!("sumo.ahead[{i}].speed_mps"),
                    format!(
                        "{} m/s: the leader drives its profile (leader.drive is not SUMO's, so \
                         nothing slows it for a vehicle ahead) and would reach this one, {} m \
                         ahead, at t = {t:.2} s, driving through it; let SUMO drive the leader \
                         (leader.drive = {{ kind = \"sumo\", ... }}) or put it farther or faster",
                        Num(x.speed_mps),
                        Num(x.gap_m)
                    ),
                );
            }
        }
    }
    Ok(())
}

/// When a leader driving `leader` first closes a gap of `gap` m to a vehicle ahead at a
/// constant `speed` (m/s), if within `duration` s: the closing distance integrated exactly
/// over the profile's pieces (linear in speed, so the distance is quadratic in each piece),
/// sampled at 1000 points a piece.
fn caught_up(leader: &LeaderProfile, speed: f64, gap: f64, duration: f64) -> Option<f64> {
    let mut times: Vec<f64> = leader
        .waypoints()
        .iter()
        .map(|w| w.0)
        .filter(|&t| t > 0.0 && t < duration)
        .collect();
    times.push(duration);
    let (mut t0, mut closed) = (0.0, 0.0);
    for t1 in times {
        let n = 1000;
        let h = (t1 - t0) / f64::from(n);
        for k in 0..n {
            let (a, b) = (t0 + h * f64::from(k), t0 + h * f64::from(k + 1));
            // The speed is linear on [a, b]: the trapezoid is exact.
            closed += 0.5 * (leader.velocity_at(a) + leader.velocity_at(b)) * h - speed * h;
            if closed >= gap {
                return Some(b);
            }
        }
        t0 = t1;
    }
    None
}
