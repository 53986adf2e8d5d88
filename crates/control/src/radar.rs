//! The on-board radar: what it sees of the vehicle ahead ([`RadarTruth`], from the plant or
//! the platoon's states), and its measurements ([`Radar`]: noise, dropouts, a period).
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The on-board radar: the gap to the vehicle ahead and the closing speed, measured locally.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadarParams {
    /// Beyond this range (m) there is no target. > 0.
    pub range_m: f64,
    /// A new measurement every this many steps (held in between). >= 1.
    pub period_steps: u32,
    /// Standard deviation of the gap's noise (m), >= 0.
    pub noise_m: f64,
    /// Standard deviation of the closing speed's noise (m/s), >= 0.
    pub noise_mps: f64,
    /// Probability that a measurement is lost (the previous one is kept), in [0, 1).
    pub dropout: f64,
    /// Seed of the noise and dropouts (each vehicle of each platoon draws its own stream).
    pub seed: u64,
}

impl Default for RadarParams {
    /// A long-range automotive radar: 150 m, 20 Hz at dt = 0.01 s, 0.05 m and 0.05 m/s noise.
    fn default() -> Self {
        Self {
            range_m: 150.0,
            period_steps: 5,
            noise_m: 0.05,
            noise_mps: 0.05,
            dropout: 0.0,
            seed: 1,
        }
    }
}

/// What the radar of every vehicle sees in a step (leader first): given by the plant, or else
/// taken from the platoon's states (the vehicle ahead is the predecessor).
#[derive(Debug, Clone, Default)]
pub(crate) struct Truths {
    truth: Vec<Option<RadarTruth>>,
    given: bool,
}

impl Truths {
    /// The plant's view for the coming step, padded or cut to `vehicles`.
    pub(crate) fn give(&mut self, truth: &[Option<RadarTruth>], vehicles: usize) {
        self.truth.clear();
        self.truth.extend_from_slice(truth);
        self.truth.resize(vehicles, None);
        self.given = true;
    }

    /// The view the last [`Truths::take`] gave.
    pub(crate) fn current(&self) -> &[Option<RadarTruth>] {
        &self.truth
    }

    /// This step's view: the plant's if it gave one, else (when `needed`) the states'. The next
    /// step starts without one again.
    pub(crate) fn take(
        &mut self,
        states: &[platoon_model::State],
        length: impl Fn(usize) -> f64,
        needed: bool,
    ) -> &[Option<RadarTruth>] {
        if needed && !self.given {
            radar_truth(states, length, &mut self.truth);
        }
        self.given = false;
        &self.truth
    }
}

/// What a radar sees of the vehicle ahead: the true gap and closing speed.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RadarTruth {
    /// Bumper-to-bumper gap (m).
    pub gap: f64,
    /// `v_i - v_ahead` (m/s): positive while closing in.
    pub closing: f64,
    /// The vehicle ahead is not the platoon's predecessor (the plant's association of the
    /// radar's object with the V2V sender ahead, taken as perfect).
    pub intruder: bool,
}

/// One radar measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Measured gap (m).
    pub gap: f64,
    /// Measured closing speed (m/s).
    pub closing: f64,
    /// Of a vehicle that is not the platoon's predecessor ([`RadarTruth::intruder`]).
    pub intruder: bool,
}

impl Reading {
    /// Time to collision (s): gap over closing speed while closing in, else infinite.
    pub fn ttc(&self) -> f64 {
        if self.closing > 0.0 {
            self.gap.max(0.0) / self.closing
        } else {
            f64::INFINITY
        }
    }
}

/// One vehicle's radar: measurement noise and dropouts from its own seeded stream, a new
/// reading every `period_steps`, held in between.
#[derive(Debug, Clone)]
pub struct Radar {
    rng: ChaCha8Rng,
    last: Option<Reading>,
    /// The step `last` was measured at.
    taken: u64,
}

impl Radar {
    /// The radar of vehicle `vehicle` of a platoon whose radar seed is `seed`.
    pub fn new(seed: u64, vehicle: u16) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(u64::from(vehicle));
        Self {
            rng,
            last: None,
            taken: 0,
        }
    }

    /// The step the reading in use was measured at (a radar holds it between measurements).
    pub fn taken(&self) -> u64 {
        self.taken
    }

    /// The reading in use at step k, given the truth (`None`: no vehicle ahead).
    pub fn read(&mut self, k: u64, p: &RadarParams, truth: Option<RadarTruth>) -> Option<Reading> {
        if !k.is_multiple_of(u64::from(p.period_steps)) {
            return self.last;
        }
        // The draws do not depend on the truth, so the stream stays aligned whatever happens.
        let lost = self.rng.gen::<f64>() < p.dropout;
        let n_gap = gaussian(&mut self.rng, p.noise_m);
        let n_rate = gaussian(&mut self.rng, p.noise_mps);
        if lost {
            return self.last;
        }
        self.last = truth.filter(|t| t.gap <= p.range_m).map(|t| Reading {
            gap: t.gap + n_gap,
            closing: t.closing + n_rate,
            intruder: t.intruder,
        });
        self.taken = k;
        self.last
    }
}

fn gaussian(rng: &mut ChaCha8Rng, std: f64) -> f64 {
    let z: f64 = StandardNormal.sample(rng);
    std * z
}

/// The true gap and closing speed to the vehicle ahead in the platoon, for every follower
/// (`states[0]` is the leader; `None` for the leader); `length(j)` is vehicle j's length.
pub fn radar_truth(
    states: &[platoon_model::State],
    length: impl Fn(usize) -> f64,
    out: &mut Vec<Option<RadarTruth>>,
) {
    out.clear();
    out.push(None);
    for (j, w) in states.windows(2).enumerate() {
        out.push(Some(RadarTruth {
            gap: w[0][0] - w[1][0] - length(j),
            closing: w[1][1] - w[0][1],
            intruder: false,
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_radar_holds_between_periods_drops_out_and_sees_nothing_beyond_range() {
        let p = RadarParams {
            period_steps: 5,
            noise_m: 0.0,
            noise_mps: 0.0,
            ..RadarParams::default()
        };
        let mut r = Radar::new(3, 1);
        let t = |gap| {
            Some(RadarTruth {
                gap,
                closing: 1.0,
                intruder: false,
            })
        };
        assert_eq!(r.read(0, &p, t(20.0)).unwrap().gap, 20.0);
        assert_eq!(r.read(3, &p, t(10.0)).unwrap().gap, 20.0); // held
        assert_eq!(r.read(5, &p, t(10.0)).unwrap().gap, 10.0);
        assert_eq!(r.read(10, &p, t(200.0)), None); // out of range
        let lossy = RadarParams { dropout: 0.5, ..p };
        let mut r = Radar::new(3, 1);
        // Each period the truth changes; a lost measurement keeps the previous one.
        let fresh = (1..=1000u64)
            .filter(|&j| {
                let gap = (j % 100) as f64 + 1.0;
                r.read(5 * j, &lossy, t(gap)).is_some_and(|m| m.gap == gap)
            })
            .count();
        assert!((400..600).contains(&fresh), "{fresh} of 1000 measured");
    }

    #[test]
    fn radar_noise_is_seeded_per_vehicle() {
        let p = RadarParams::default();
        let truth = Some(RadarTruth {
            gap: 30.0,
            closing: 0.0,
            intruder: false,
        });
        let draw = |seed, v| {
            let mut r = Radar::new(seed, v);
            (0..50)
                .map(|k| r.read(k * 5, &p, truth).unwrap().gap)
                .collect::<Vec<_>>()
        };
        assert_eq!(draw(1, 2), draw(1, 2));
        assert_ne!(draw(1, 2), draw(1, 3));
        assert_ne!(draw(1, 2), draw(2, 2));
        let g = draw(1, 2);
        let mean = g.iter().sum::<f64>() / g.len() as f64;
        assert!((mean - 30.0).abs() < 0.05, "{mean}");
    }
}
