//! The two lanes of a platoon that changes lanes (`[maneuvers]` with leaves or joins from
//! beside): the platoon's own and the one beside it, and when a vehicle may change between them.
//!
//! A vehicle changes lanes only into a safe gap ([`LaneChangeRule`], MOBIL's safety criterion
//! with a kinematic stand-in for the car-following model): on the lane it wants, the gap to the
//! vehicle that would be ahead of it and the gap of the vehicle that would be behind it are each
//! at least the safe gap for their closing speed. Otherwise it stays where it is and asks again
//! at the next step; the run records the wait ([`crate::LaneChangeRecord::waited_s`]). The change
//! itself is instantaneous, as SUMO's without the sublane model. The SUMO bridge decides with
//! the same rule (`platoon.sumo.model.LaneChangeRule`, from plant.json's `lane_change`, tested
//! against this one), so both
//! plants change lanes at the same steps.

/// When a lane change is safe: the gap `g` (bumper to bumper) between a vehicle and the one
/// ahead of it on the lane it moves into, closing at `c = v_behind - v_ahead`, must satisfy
/// `g >= min_gap_m + max(c, 0) * reaction_s + max(c, 0)^2 / (2 safe_decel_mps2)`: the vehicle
/// behind can match the speed ahead braking at `safe_decel_mps2` after `reaction_s`, and keep
/// `min_gap_m`. Checked for the changer behind its new leader and for its new follower behind it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LaneChangeRule {
    /// The smallest gap left either side (m): SUMO's default `minGap` for a passenger car.
    pub min_gap_m: f64,
    /// The reaction time before braking (s): the platoon's actuator lag order.
    pub reaction_s: f64,
    /// The braking asked at most of either vehicle (m/s^2): MOBIL's `b_safe`.
    pub safe_decel_mps2: f64,
}

/// [`LaneChangeRule::DEFAULT`].
impl Default for LaneChangeRule {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl LaneChangeRule {
    /// The rule both plants use: 2.5 m, 0.5 s, 4 m/s^2.
    pub const DEFAULT: Self = Self {
        min_gap_m: 2.5,
        reaction_s: 0.5,
        safe_decel_mps2: 4.0,
    };

    /// Whether a gap `gap` (m) closing at `closing` (m/s) is safe.
    pub fn gap_is_safe(&self, gap: f64, closing: f64) -> bool {
        let c = closing.max(0.0);
        gap >= self.min_gap_m + c * self.reaction_s + c * c / (2.0 * self.safe_decel_mps2)
    }

    /// Whether a vehicle `me` may move between `ahead` and `behind` on the other lane (each
    /// `[front bumper, speed, length]`; `None`: nobody there).
    pub fn safe(&self, me: [f64; 3], ahead: Option<[f64; 3]>, behind: Option<[f64; 3]>) -> bool {
        let front = ahead.is_none_or(|a| self.gap_is_safe(a[0] - a[2] - me[0], me[1] - a[1]));
        let back = behind.is_none_or(|b| self.gap_is_safe(me[0] - me[2] - b[0], b[1] - me[1]));
        front && back
    }

    /// Whether `me` may move onto a lane where `others` drive (`[front bumper, speed, length]`
    /// each, in any order; `me` itself not among them): between the nearest ahead (front
    /// bumper further on than its own, or level with it) and the nearest behind.
    pub fn safe_among(&self, me: [f64; 3], others: impl Iterator<Item = [f64; 3]>) -> bool {
        let (mut ahead, mut behind): (Option<[f64; 3]>, Option<[f64; 3]>) = (None, None);
        for o in others {
            if o[0] >= me[0] {
                if ahead.is_none_or(|a| o[0] < a[0]) {
                    ahead = Some(o);
                }
            } else if behind.is_none_or(|b| o[0] > b[0]) {
                behind = Some(o);
            }
        }
        self.safe(me, ahead, behind)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: LaneChangeRule = LaneChangeRule::DEFAULT;

    #[test]
    fn a_gap_is_safe_from_the_minimum_gap_up_growing_with_the_closing_speed() {
        assert!(R.gap_is_safe(2.5, 0.0));
        assert!(!R.gap_is_safe(2.49, 0.0));
        // Opening gaps ask for the minimum only.
        assert!(R.gap_is_safe(2.5, -5.0));
        // 4 m/s closing: 2.5 + 2 + 16 / 8 = 6.5 m.
        assert!(R.gap_is_safe(6.5, 4.0));
        assert!(!R.gap_is_safe(6.49, 4.0));
    }

    #[test]
    fn a_vehicle_moves_only_between_neighbours_it_leaves_room_to() {
        // A 4.5 m car at 100 m, 20 m/s.
        let me = [100.0, 20.0, 4.5];
        assert!(R.safe_among(me, std::iter::empty()));
        // 1.2 m behind a car at the same speed: too close (the two leaves of issue 51).
        assert!(!R.safe_among(me, [[105.7, 20.0, 4.5]].into_iter()));
        assert!(R.safe_among(me, [[107.0, 20.0, 4.5]].into_iter()));
        // A car level with it is ahead, and overlaps.
        assert!(!R.safe_among(me, [[100.0, 20.0, 4.5]].into_iter()));
        // The one behind closes at 6 m/s: it needs 2.5 + 3 + 4.5 = 10 m.
        assert!(!R.safe_among(me, [[86.0, 26.0, 4.5]].into_iter()));
        assert!(R.safe_among(me, [[85.5, 26.0, 4.5]].into_iter()));
        // Only the nearest either side counts.
        let far = [
            [300.0, 0.0, 4.5],
            [120.0, 20.0, 4.5],
            [-50.0, 40.0, 4.5],
            [80.0, 20.0, 4.5],
        ];
        assert!(R.safe_among(me, far.into_iter()));
    }
}
