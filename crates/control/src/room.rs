//! A follower's room offset: the extra gap it keeps while a vehicle leaves or joins in front of
//! it, and how the offset moves so that the vehicle its law follows has no step in speed or
//! acceleration; and what a vehicle reads of one in the lane beside (out of its radar's sight)
//! from that one's packets.

use crate::checks::PacketChecks;
use crate::fallback::Reading;
use platoon_model::{State, VehicleId};

/// The largest acceleration of the virtual vehicle a law follows while a room offset moves
/// (m/s^2): a comfortable one, so that a small offset is not taken up in a jerk.
const OFFSET_ACCEL_MPS2: f64 = 0.5;

/// How a follower's room offset moves from one value to another: smoothly (a quintic
/// smootherstep, so the vehicle its law follows starts and ends moving with no step in its
/// speed or its acceleration), at most at `fallback.closing_mps` and [`OFFSET_ACCEL_MPS2`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ramp {
    from: f64,
    pub(crate) to: f64,
    start: u64,
    steps: u64,
}

impl Ramp {
    /// From `from` to `to` (m), beginning at step `start`.
    pub(crate) fn new(from: f64, to: f64, start: u64, closing_mps: f64, dt: f64) -> Self {
        // The smootherstep's fastest rate is 15/8 of its mean, its largest acceleration
        // 10/sqrt(3) times the distance over the duration squared.
        let d = (to - from).abs();
        let peak_accel = 10.0 / 3f64.sqrt();
        let span = (1.875 * d / closing_mps).max((peak_accel * d / OFFSET_ACCEL_MPS2).sqrt());
        let steps = (span / dt).ceil().max(1.0) as u64;
        Self {
            from,
            to,
            start,
            steps,
        }
    }

    /// The offset at step `k`.
    pub(crate) fn at(&self, k: u64) -> f64 {
        let t = ((k - self.start) as f64 / self.steps as f64).min(1.0);
        self.from + (self.to - self.from) * t * t * t * (10.0 - 15.0 * t + 6.0 * t * t)
    }

    /// How fast the offset grows at step `k` (m/s) and how fast that changes (m/s^2): the
    /// virtual vehicle the law follows moves that much slower, and brakes that much harder,
    /// than the one ahead.
    pub(crate) fn motion(&self, k: u64, dt: f64) -> (f64, f64) {
        let t = (k - self.start) as f64 / self.steps as f64;
        if t >= 1.0 {
            return (0.0, 0.0);
        }
        let span = self.steps as f64 * dt;
        let d = self.to - self.from;
        let (u, w) = (t * (1.0 - t), 1.0 - 2.0 * t);
        (d * 30.0 * u * u / span, d * 60.0 * u * w / (span * span))
    }

    /// Whether it has arrived at step `k`.
    pub(crate) fn done(&self, k: u64) -> bool {
        k >= self.start + self.steps
    }
}

/// What follower `i`'s radar would read of vehicle `j` (in the lane beside, or beyond the
/// radar), from the last packet it accepted from `j` brought forward to step `k`: the gap
/// (m, `j`'s length `length`) and the closing speed.
pub(crate) fn v2v_reading(
    checks: &PacketChecks,
    i: VehicleId,
    j: VehicleId,
    k: u64,
    dt: f64,
    own: &State,
    length: f64,
) -> Option<Reading> {
    checks.heard_from(i, j).map(|h| {
        let age = (k - h.step.unwrap_or(0)) as f64 * dt;
        Reading {
            gap: h.state[0] + h.state[1] * age - own[0] - length,
            closing: own[1] - h.state[1],
            intruder: false,
        }
    })
}
