//! Clean traffic for the tests: the paper's leader profile, a follower behind it, an
//! event-triggered sender, noise on the claims and on the radar, all seeded.

use crate::{Last, Observation, RadarReading};
use platoon_model::{leader_step, plant_step, LeaderProfile, State, VehicleId};
use platoon_v2v::Packet;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The step (s).
pub const DT: f64 = 0.01;
/// The run: the paper's 55 s.
pub const STEPS: usize = 5500;
/// Vehicle length (m).
pub const LENGTH: f64 = 4.0;
/// The follower's desired gap (m).
pub const GAP: f64 = 20.0;

/// The paper's leader (15 m/s, +2 m/s^2 on [10, 15) s, 25 m/s, -2 m/s^2 on [35, 40) s, 15 m/s),
/// stepped as the platoon's leader is: its acceleration jumps at the ramps' ends.
pub fn leader() -> Vec<State> {
    let profile = LeaderProfile::paper();
    let mut x = State::new(100.0, 15.0, profile.step_acceleration(0, DT));
    let mut xs = Vec::with_capacity(STEPS + 1);
    xs.push(x);
    for k in 0..STEPS {
        x = leader_step(&x, profile.step_acceleration(k + 1, DT), DT);
        xs.push(x);
    }
    xs
}

/// A follower behind `ahead` with the paper's power train (tau = 0.34 s) and a simple
/// constant-spacing law on the true gap: `u = a_ahead + 0.6 (gap error) + 1.5 (speed error)`.
pub fn follower(ahead: &[State]) -> Vec<State> {
    let mut x = State::new(ahead[0][0] - GAP - LENGTH, ahead[0][1], 0.0);
    let mut xs = Vec::with_capacity(ahead.len());
    xs.push(x);
    for y in &ahead[..ahead.len() - 1] {
        let gap = y[0] - x[0] - LENGTH;
        let u = y[2] + 0.6 * (gap - GAP) + 1.5 * (y[1] - x[1]);
        x = plant_step(&x, u, 0.34, DT);
        xs.push(x);
    }
    xs
}

/// The steps at which an event-triggered sender broadcasts: step 0, then every 1 to 30 steps.
pub fn send_steps(rng: &mut ChaCha8Rng) -> Vec<usize> {
    let mut steps = vec![0];
    loop {
        let next = steps[steps.len() - 1] + rng.gen_range(1..=30);
        if next > STEPS {
            return steps;
        }
        steps.push(next);
    }
}

/// Gaussian noise with standard deviations `sigma` on each of `[p, v, a]` (none where 0).
pub fn noisy(x: &State, sigma: [f64; 3], rng: &mut ChaCha8Rng) -> State {
    let mut y = *x;
    for i in 0..3 {
        if sigma[i] > 0.0 {
            y[i] += Normal::new(0.0, sigma[i]).unwrap().sample(rng);
        }
    }
    y
}

/// A radar on the vehicle ahead that measures every `period` steps with noise drawn uniformly
/// within `±sigma` (m, m/s), held in between: the reading at step `k`.
pub fn radar(
    own: &[State],
    ahead: &[State],
    k: usize,
    period: usize,
    sigma: [f64; 2],
    rng: &mut ChaCha8Rng,
) -> RadarReading {
    let m = k - k % period;
    RadarReading {
        gap_m: ahead[m][0] - own[m][0] - LENGTH + rng.gen_range(-sigma[0]..=sigma[0]),
        closing_mps: own[m][1] - ahead[m][1] + rng.gen_range(-sigma[1]..=sigma[1]),
        vehicle_length_m: LENGTH,
        age_s: (k - m) as f64 * DT,
    }
}

/// A seeded generator.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// The packet of `sender` sampled at `step` claiming `state`.
pub fn packet(sender: u16, seq: u32, step: usize, state: State) -> Packet {
    Packet {
        u: state[2],
        ..Packet::beacon(VehicleId(sender), seq, step as u64, state)
    }
}

/// An observation by `receiver` (own state `own`) of `packet` at its own step.
pub fn observe<'a>(
    receiver: u16,
    own: State,
    packet: &'a Packet,
    last: Option<Last>,
    radar: Option<RadarReading>,
) -> Observation<'a> {
    Observation {
        k: packet.step,
        dt: DT,
        receiver: VehicleId(receiver),
        own,
        packet,
        last,
        radar,
    }
}
