//! Jammers as transmitters (`[[channel.jammers]]`): where a jammer is, when it transmits, and
//! what that does to the channel. Pure and seeded, like the channel that runs it.
//!
//! A jammer that transmits (constant, periodic or random on/off) is heard above the sensing
//! threshold out to [`Jammer::heard_m`]: a vehicle within it senses its channel jammed and
//! neither sends nor receives (carrier sense, the paper's DoS as the vehicle sees it). A
//! reactive jammer transmits only while it senses a transmission: a packet whose sender it hears
//! gets its interference at every receiver, and nobody senses the channel jammed beforehand.
//! With the 802.11p radio a transmitting jammer's mean received power also enters the SINR of
//! every link ([`Jammers::interference_dbm`], `platoon_radio::Model::pdr_with_interference`);
//! with the ideal radio only its radius counts ([`Jammers::blocks`]).
use platoon_model::{State, VehicleId};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Where a jammer is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Placement {
    /// On or beside the road at `position_m + speed_mps t` (the platoon's road coordinates).
    Roadside {
        /// Its road coordinate at t = 0 (m).
        position_m: f64,
        /// Its speed along the road (m/s; 0: a fixed roadside unit).
        speed_mps: f64,
        /// Its distance from the road (m).
        lateral_m: f64,
    },
    /// Riding along with a platoon member: at that vehicle's position plus `offset_m`.
    Member {
        /// The vehicle it follows (0 = the leader).
        vehicle: VehicleId,
        /// Its offset along the road from the vehicle (m; negative: behind it).
        offset_m: f64,
        /// Its distance from the road (m).
        lateral_m: f64,
    },
    /// On SUMO background vehicle `bg<index>` (its position from
    /// `Channel::set_background`; absent, and silent, while that vehicle is not on the road).
    Background {
        /// The background vehicle's index.
        index: usize,
        /// Its distance from the road (m).
        lateral_m: f64,
    },
}

impl Placement {
    fn lateral_m(&self) -> f64 {
        match *self {
            Self::Roadside { lateral_m, .. }
            | Self::Member { lateral_m, .. }
            | Self::Background { lateral_m, .. } => lateral_m,
        }
    }

    /// Its road coordinate at `t`, if it is on the road.
    fn position_m(&self, t: f64, states: &[State], background: &[f64]) -> Option<f64> {
        let x = match *self {
            Self::Roadside {
                position_m,
                speed_mps,
                ..
            } => position_m + speed_mps * t,
            Self::Member {
                vehicle, offset_m, ..
            } => states.get(vehicle.index())?[0] + offset_m,
            Self::Background { index, .. } => *background.get(index)?,
        };
        x.is_finite().then_some(x)
    }
}

/// When a jammer transmits, within `[start_s, end_s)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Behaviour {
    /// All the time.
    Constant,
    /// On for `on_s`, then off for `off_s`, from `start_s`.
    Periodic {
        /// Burst length (s).
        on_s: f64,
        /// Pause between bursts (s).
        off_s: f64,
    },
    /// On and off for exponentially distributed durations of these means, drawn from the
    /// jammer's own seeded stream; on from `start_s`.
    Random {
        /// Mean burst length (s).
        mean_on_s: f64,
        /// Mean pause (s).
        mean_off_s: f64,
    },
    /// Only while it senses a transmission (a sender within [`Jammer::senses_m`]).
    Reactive,
}

impl Behaviour {
    /// The config name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Constant => "constant",
            Self::Periodic { .. } => "periodic",
            Self::Random { .. } => "random",
            Self::Reactive => "reactive",
        }
    }
}

/// One jammer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jammer {
    /// Where it is.
    pub placement: Placement,
    /// Its transmit power (dBm).
    pub power_dbm: f64,
    /// When it starts (s).
    pub start_s: f64,
    /// When it stops (s, exclusive; infinity: never).
    pub end_s: f64,
    /// When it transmits in between.
    pub behaviour: Behaviour,
    /// How far it is heard above the sensing threshold (m, straight line, mean path loss).
    pub heard_m: f64,
    /// How far it senses the vehicles' transmissions (m, straight line; reactive jammers).
    pub senses_m: f64,
}

impl Jammer {
    /// The stretch of road on either side of it within `radius_m` of it (m).
    fn along_road(&self, radius_m: f64) -> f64 {
        let lateral = self.placement.lateral_m();
        (radius_m * radius_m - lateral * lateral).max(0.0).sqrt()
    }
}

/// Every jammer's state across steps.
#[derive(Debug, Clone)]
struct JamState {
    /// Its road coordinate this step, if on the road.
    at: Option<f64>,
    /// Transmitting this step (reactive: within its window, per packet).
    on: bool,
    /// Periodic: the current burst's start; random: the next switch (NaN before the start).
    next_s: f64,
    /// Random: on (else off) since the last switch.
    random_on: bool,
    rng: ChaCha8Rng,
    /// `heard_m` and `senses_m` along the road.
    heard_along: f64,
    senses_along: f64,
}

/// The jammers of one channel and their state.
#[derive(Debug, Clone, Default)]
pub struct Jammers {
    specs: Vec<Jammer>,
    state: Vec<JamState>,
}

/// The stream of jammer `i`'s random on/off times: after the link attacks' (0) and the radio's
/// (1), so adding a jammer shifts neither.
fn stream(i: usize) -> u64 {
    2 + i as u64
}

impl Jammers {
    /// The jammers `specs`, their random streams seeded from the channel's `seed`.
    pub fn new(specs: &[Jammer], seed: u64) -> Jammers {
        let state = specs
            .iter()
            .enumerate()
            .map(|(i, j)| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(stream(i));
                JamState {
                    at: None,
                    on: false,
                    next_s: match j.behaviour {
                        Behaviour::Periodic { .. } => j.start_s,
                        _ => f64::NAN,
                    },
                    random_on: false,
                    rng,
                    heard_along: j.along_road(j.heard_m),
                    senses_along: j.along_road(j.senses_m),
                }
            })
            .collect();
        Jammers {
            specs: specs.to_vec(),
            state,
        }
    }

    /// No jammers.
    pub fn is_empty(&self) -> bool {
        self.specs.is_empty()
    }

    /// The jammers.
    pub fn specs(&self) -> &[Jammer] {
        &self.specs
    }

    /// Whether jammer `i` transmits at the current step (reactive: whether it is within its
    /// window, listening), and where it is.
    pub fn transmitting(&self, i: usize) -> Option<f64> {
        let s = &self.state[i];
        s.at.filter(|_| s.on)
    }

    /// Advances to time `t` (steps in increasing time): where each jammer is and whether it
    /// transmits; sets `jammed[v]` for every vehicle that hears a transmitting (non-reactive)
    /// jammer above the sensing threshold.
    pub fn step(&mut self, t: f64, states: &[State], background: &[f64], jammed: &mut [bool]) {
        for (j, s) in self.specs.iter().zip(&mut self.state) {
            s.at = j.placement.position_m(t, states, background);
            let within = t >= j.start_s && t < j.end_s;
            s.on = match j.behaviour {
                Behaviour::Constant | Behaviour::Reactive => within,
                Behaviour::Periodic { on_s, off_s } => {
                    // Burst starts accumulate as start, start + (on + off), ... exactly.
                    while t >= s.next_s + (on_s + off_s) {
                        s.next_s += on_s + off_s;
                    }
                    within && t >= s.next_s && t < (s.next_s + on_s).min(j.end_s)
                }
                Behaviour::Random {
                    mean_on_s,
                    mean_off_s,
                } => {
                    if within {
                        let draw =
                            |mean: f64, rng: &mut ChaCha8Rng| -mean * (1.0 - rng.gen::<f64>()).ln();
                        if s.next_s.is_nan() {
                            s.random_on = true;
                            s.next_s = j.start_s + draw(mean_on_s, &mut s.rng);
                        }
                        while t >= s.next_s {
                            s.random_on = !s.random_on;
                            let mean = if s.random_on { mean_on_s } else { mean_off_s };
                            s.next_s += draw(mean, &mut s.rng);
                        }
                    }
                    within && s.random_on
                }
            };
            if j.behaviour == Behaviour::Reactive || !s.on {
                continue;
            }
            if let Some(centre) = s.at {
                for (v, x) in jammed.iter_mut().zip(states) {
                    *v |= (x[0] - centre).abs() <= s.heard_along;
                }
            }
        }
    }

    /// Whether jammer `i` transmits during a packet sent from `sender_m`: a transmitting jammer
    /// always, a reactive one when it senses the sender.
    fn during(&self, i: usize, sender_m: f64) -> Option<f64> {
        let centre = self.transmitting(i)?;
        let s = &self.state[i];
        match self.specs[i].behaviour {
            Behaviour::Reactive => ((sender_m - centre).abs() <= s.senses_along).then_some(centre),
            _ => Some(centre),
        }
    }

    /// The jammers' summed mean received power at a receiver at `receiver_m` during a packet
    /// sent from `sender_m` (dBm; `-inf` when none transmits), over `params`' path loss.
    pub fn interference_dbm(
        &self,
        params: &platoon_radio::Params80211p,
        sender_m: f64,
        receiver_m: f64,
    ) -> f64 {
        let mut mw = 0.0;
        for (i, j) in self.specs.iter().enumerate() {
            if let Some(centre) = self.during(i, sender_m) {
                let dx = receiver_m - centre;
                let lateral = j.placement.lateral_m();
                let d = (dx * dx + lateral * lateral).sqrt();
                mw += 10f64.powf((j.power_dbm - params.path_loss_db(d)) / 10.0);
            }
        }
        if mw > 0.0 {
            10.0 * mw.log10()
        } else {
            f64::NEG_INFINITY
        }
    }

    /// With the ideal radio: whether a reactive jammer destroys a packet sent from `sender_m`
    /// at a receiver at `receiver_m` (it senses the sender, and the receiver hears it above the
    /// sensing threshold).
    pub fn blocks(&self, sender_m: f64, receiver_m: f64) -> bool {
        (0..self.specs.len()).any(|i| {
            self.specs[i].behaviour == Behaviour::Reactive
                && self
                    .during(i, sender_m)
                    .is_some_and(|c| (receiver_m - c).abs() <= self.state[i].heard_along)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jammer(placement: Placement, behaviour: Behaviour) -> Jammer {
        Jammer {
            placement,
            power_dbm: 20.0,
            start_s: 1.0,
            end_s: 9.0,
            behaviour,
            heard_m: 50.0,
            senses_m: 100.0,
        }
    }

    fn roadside(x: f64) -> Placement {
        Placement::Roadside {
            position_m: x,
            speed_mps: 0.0,
            lateral_m: 0.0,
        }
    }

    fn at(xs: &[f64]) -> Vec<State> {
        xs.iter().map(|&x| State::new(x, 10.0, 0.0)).collect()
    }

    /// Which vehicles sense their channel jammed at each of `ts`.
    fn sensed(js: &mut Jammers, ts: &[f64], states: &[State], bg: &[f64]) -> Vec<Vec<bool>> {
        ts.iter()
            .map(|&t| {
                let mut j = vec![false; states.len()];
                js.step(t, states, bg, &mut j);
                j
            })
            .collect()
    }

    #[test]
    fn a_constant_roadside_jammer_jams_within_its_radius_during_its_window() {
        let mut js = Jammers::new(&[jammer(roadside(0.0), Behaviour::Constant)], 1);
        let states = at(&[60.0, 40.0, -50.0, -51.0]);
        let got = sensed(&mut js, &[0.5, 1.0, 8.99, 9.0], &states, &[]);
        assert_eq!(got[0], vec![false; 4], "before its start");
        assert_eq!(got[1], vec![false, true, true, false]);
        assert_eq!(got[2], got[1]);
        assert_eq!(got[3], vec![false; 4], "from its end");
    }

    #[test]
    fn lateral_distance_shrinks_its_reach_along_the_road() {
        let mut j = jammer(
            Placement::Roadside {
                position_m: 0.0,
                speed_mps: 2.0,
                lateral_m: 30.0,
            },
            Behaviour::Constant,
        );
        j.start_s = 0.0;
        let mut js = Jammers::new(&[j], 1);
        // At t = 5 it is at 10 m; 40 m along the road (sqrt(50^2 - 30^2)).
        let got = sensed(&mut js, &[5.0], &at(&[50.0, 50.5, -30.0, -30.5]), &[]);
        assert_eq!(got[0], vec![true, false, true, false]);
    }

    #[test]
    fn a_periodic_jammer_is_on_in_bursts() {
        let mut js = Jammers::new(
            &[jammer(
                roadside(0.0),
                Behaviour::Periodic {
                    on_s: 1.0,
                    off_s: 2.0,
                },
            )],
            1,
        );
        let states = at(&[0.0]);
        let ts: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
        let on: Vec<bool> = sensed(&mut js, &ts, &states, &[])
            .iter()
            .map(|j| j[0])
            .collect();
        for (t, on) in ts.iter().zip(on) {
            // Bursts [1, 2), [4, 5), [7, 8) (to rounding of 0.1 k at the edges).
            let want = [1.0, 4.0, 7.0]
                .iter()
                .any(|s| *t >= s - 1e-9 && *t < s + 1.0 - 1e-9);
            if ((t - 1.0) % 3.0).abs() > 1e-6 && ((t - 2.0) % 3.0).abs() > 1e-6 {
                assert_eq!(on, want, "t = {t}");
            }
        }
    }

    #[test]
    fn a_random_jammer_is_seeded_and_has_its_duty_cycle() {
        let j = Jammer {
            start_s: 0.0,
            end_s: f64::INFINITY,
            ..jammer(
                roadside(0.0),
                Behaviour::Random {
                    mean_on_s: 0.5,
                    mean_off_s: 1.5,
                },
            )
        };
        let run = |seed| {
            let mut js = Jammers::new(&[j], seed);
            let ts: Vec<f64> = (0..200_000).map(|k| k as f64 * 0.01).collect();
            sensed(&mut js, &ts, &at(&[0.0]), &[])
                .iter()
                .map(|v| v[0])
                .collect::<Vec<_>>()
        };
        let a = run(7);
        assert_eq!(a, run(7), "the same seed, the same bursts");
        assert_ne!(a, run(8));
        assert!(a[0], "on from its start");
        let duty = a.iter().filter(|o| **o).count() as f64 / a.len() as f64;
        assert!((duty - 0.25).abs() < 0.03, "duty {duty}");
        let bursts = a.windows(2).filter(|w| !w[0] && w[1]).count() as f64;
        // 2000 s / 2 s per cycle.
        assert!((bursts - 1000.0).abs() < 120.0, "{bursts} bursts");
    }

    #[test]
    fn a_member_jammer_follows_its_vehicle_and_a_background_one_its_car() {
        let member = jammer(
            Placement::Member {
                vehicle: VehicleId(2),
                offset_m: -60.0,
                lateral_m: 0.0,
            },
            Behaviour::Constant,
        );
        let bg = jammer(
            Placement::Background {
                index: 1,
                lateral_m: 0.0,
            },
            Behaviour::Constant,
        );
        let mut js = Jammers::new(&[member], 1);
        // 60 m behind vehicle 2: 60 m from it, out of its 50 m radius.
        let states = at(&[300.0, 200.0, 100.0]);
        assert_eq!(sensed(&mut js, &[2.0], &states, &[])[0], [false; 3]);
        assert_eq!(js.transmitting(0), Some(40.0));
        // Vehicle 2 drops back towards the jammer's former place: the jammer keeps its distance.
        let states = at(&[300.0, 200.0, 80.0]);
        assert_eq!(sensed(&mut js, &[2.0], &states, &[])[0], [false; 3]);
        assert_eq!(js.transmitting(0), Some(20.0));
        let states = at(&[300.0, 200.0, 80.0, 40.0]);
        assert_eq!(
            sensed(&mut js, &[2.0], &states, &[])[0],
            [false, false, false, true]
        );
        let states = at(&[300.0, 200.0, 80.0]);
        let mut js = Jammers::new(&[bg], 1);
        assert_eq!(
            sensed(&mut js, &[2.0], &states, &[f64::NAN, 190.0])[0],
            [false, true, false]
        );
        assert_eq!(js.transmitting(0), Some(190.0));
        // Off the road (NaN) or not given: silent.
        for bg in [&[0.0, f64::NAN][..], &[0.0][..]] {
            assert_eq!(sensed(&mut js, &[2.0], &states, bg)[0], [false; 3]);
            assert_eq!(js.transmitting(0), None);
        }
    }

    #[test]
    fn a_reactive_jammer_jams_no_one_and_hits_only_what_it_senses() {
        let mut js = Jammers::new(&[jammer(roadside(0.0), Behaviour::Reactive)], 1);
        let states = at(&[0.0, 99.0, 150.0]);
        assert_eq!(sensed(&mut js, &[2.0], &states, &[])[0], [false; 3]);
        // Senses senders within 100 m; destroys at receivers within 50 m.
        assert!(js.blocks(99.0, 10.0));
        assert!(!js.blocks(101.0, 10.0), "it does not sense the sender");
        assert!(!js.blocks(99.0, 51.0), "the receiver does not hear it");
        let p = platoon_radio::Params80211p::default();
        assert_eq!(js.interference_dbm(&p, 150.0, 0.0), f64::NEG_INFINITY);
        let near = js.interference_dbm(&p, 99.0, 10.0);
        let far = js.interference_dbm(&p, 99.0, 200.0);
        assert!((near - (20.0 - p.path_loss_db(10.0))).abs() < 1e-9);
        assert!(far < near);
        // Outside its window it does not listen.
        sensed(&mut js, &[9.5], &states, &[]);
        assert!(!js.blocks(0.0, 0.0));
        assert_eq!(js.interference_dbm(&p, 0.0, 0.0), f64::NEG_INFINITY);
    }

    #[test]
    fn two_jammers_add_their_powers() {
        let one = Jammers::new(&[jammer(roadside(0.0), Behaviour::Constant)], 1);
        let mut two = Jammers::new(
            &[
                jammer(roadside(0.0), Behaviour::Constant),
                jammer(roadside(0.0), Behaviour::Constant),
            ],
            1,
        );
        let mut one = one;
        let mut jammed = [false];
        one.step(2.0, &at(&[0.0]), &[], &mut jammed);
        two.step(2.0, &at(&[0.0]), &[], &mut jammed);
        let p = platoon_radio::Params80211p::default();
        let (a, b) = (
            one.interference_dbm(&p, 500.0, 300.0),
            two.interference_dbm(&p, 500.0, 300.0),
        );
        assert!((b - a - 10.0 * 2f64.log10()).abs() < 1e-9, "{a} {b}");
    }
}
