//! Whether a run's physics stayed inside the vehicle model: a follower that drives backwards
//! (the model's lag integrates a braking command below zero speed; no vehicle on a highway has
//! a reverse gear engaged by its longitudinal controller) has left it, and the run stops there
//! with an error naming the vehicle, the step and the cause. Both transports push the same rows
//! into a [`ModelCheck`], so they stop at the same step. A follower that drives backwards after
//! its platoon collided is not checked: the collision was the first departure from what the
//! scenario means, and the run already says so (`COLLISION`, class `severe`).
use crate::StepRow;

/// How fast backwards a follower may drive before the run stops (m/s): the model's numbers at
/// a standstill are not exactly zero.
pub const REVERSE_TOLERANCE_MPS: f64 = 0.01;

/// Where and why a run left the vehicle model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelExit {
    /// The platoon.
    pub platoon: u16,
    /// The follower.
    pub vehicle: u16,
    /// The step at which it did (the run's last).
    pub step: u64,
    /// Its time (s).
    pub t_s: f64,
    /// Its speed then (m/s, below zero).
    pub v_mps: f64,
}

impl std::fmt::Display for ModelExit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "follower {} of platoon {} drives backwards at step {} (t = {:.2} s, v = {:.3} m/s, \
             no collision before): the vehicle model has no reverse, so the run left it and \
             stopped there",
            self.vehicle, self.platoon, self.step, self.t_s, self.v_mps
        )
    }
}

/// The check, step by step, of every platoon of a run.
#[derive(Debug, Clone)]
pub struct ModelCheck {
    /// Every vehicle's length, leader first (each platoon's the same).
    lengths: Vec<f64>,
    /// Each platoon: whether it collided already.
    collided: Vec<bool>,
    /// Vehicles change lanes: the vehicle ahead is the nearest on the lane, not the
    /// predecessor (as the metrics count gaps).
    lanes: bool,
}

impl ModelCheck {
    /// The check of `scenario`'s platoons.
    pub fn new(scenario: &crate::Scenario) -> Self {
        Self {
            lengths: scenario.lengths(),
            collided: vec![false; scenario.fleet.platoons],
            lanes: scenario.changes_lanes(),
        }
    }

    /// One step's rows (platoon by platoon, leader first): the first follower that drives
    /// backwards in a platoon that has not collided, if any.
    pub fn push(&mut self, rows: &[StepRow]) -> Option<ModelExit> {
        let n1 = self.lengths.len();
        for (j, platoon) in rows.chunks(n1).enumerate() {
            let collided = &mut self.collided[j];
            if !*collided {
                *collided = Self::collides(platoon, &self.lengths, self.lanes);
            }
            if *collided {
                continue;
            }
            if let Some(r) = platoon
                .iter()
                .skip(1)
                .find(|r| r.v < -REVERSE_TOLERANCE_MPS)
            {
                return Some(ModelExit {
                    platoon: r.platoon,
                    vehicle: r.vehicle,
                    step: r.step,
                    t_s: r.t,
                    v_mps: r.v,
                });
            }
        }
        None
    }

    /// Whether a follower's gap to the vehicle ahead reached zero, as the run's metrics count
    /// it: to its predecessor (with `lanes`, to the nearest vehicle ahead on its lane), or to a
    /// car that cut in ahead of it.
    fn collides(rows: &[StepRow], lengths: &[f64], lanes: bool) -> bool {
        let touch = |a: &StepRow, b: &StepRow| a.p - lengths[usize::from(a.vehicle)] - b.p <= 0.0;
        let touches = if lanes {
            // Each lane as the plant has it, in the road's order: each vehicle against the
            // last one seen ahead of it on its lane.
            let mut by_road: Vec<&StepRow> = rows.iter().collect();
            by_road.sort_by(|a, b| b.p.total_cmp(&a.p));
            let mut ahead: [Option<&StepRow>; 2] = [None, None];
            by_road.into_iter().any(|r| {
                let lane = &mut ahead[usize::from(r.beside == Some(true))];
                let hit = lane.is_some_and(|a| touch(a, r));
                *lane = Some(r);
                hit
            })
        } else {
            rows.windows(2).any(|w| touch(&w[0], &w[1]))
        };
        touches
            || rows
                .iter()
                .any(|r| r.intruder.is_some_and(|t| t.gap <= 0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(vehicle: u16, p: f64, v: f64) -> StepRow {
        StepRow {
            step: 7,
            t: 0.07,
            platoon: 0,
            vehicle,
            p,
            v,
            a: 0.0,
            u: 0.0,
            theta: 0.0,
            spacing_error: 0.0,
            velocity_error: 0.0,
            triggered: false,
            under_attack: false,
            affected: false,
            mode: platoon_control::Status::default(),
            guard: false,
            saturated: false,
            revoked: false,
            intruder: None,
            radar_target: None,
            radar_gap_m: None,
            radar_closing_mps: None,
            head: None,
            beside: None,
        }
    }

    #[test]
    fn a_follower_backwards_stops_the_run_unless_its_platoon_collided() {
        let mut check = ModelCheck {
            lengths: vec![4.5; 3],
            collided: vec![false],
            lanes: false,
        };
        // At a standstill within the tolerance: inside the model.
        assert_eq!(
            check.push(&[row(0, 0.0, 0.0), row(1, -20.0, -0.005), row(2, -40.0, 1.0)]),
            None
        );
        let exit = check
            .push(&[row(0, 0.0, 0.0), row(1, -20.0, 0.0), row(2, -40.0, -0.5)])
            .unwrap();
        assert_eq!((exit.vehicle, exit.step, exit.v_mps), (2, 7, -0.5));
        assert!(exit
            .to_string()
            .contains("follower 2 of platoon 0 drives backwards at step 7"));
        // Once follower 1 touched the leader, the collision is what the run reports.
        assert_eq!(
            check.push(&[row(0, 0.0, 0.0), row(1, -4.5, -3.0), row(2, -40.0, 1.0)]),
            None
        );
        assert_eq!(
            check.push(&[row(0, 0.0, 0.0), row(1, -20.0, -3.0), row(2, -40.0, -1.0)]),
            None
        );
    }
}
