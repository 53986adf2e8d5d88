//! The search for the most harmful DoS schedule an attacker's budget allows, as a pure library
//! (no I/O, clocks or threads): what a schedule is, what a budget admits, and how candidates are
//! proposed. Running the candidates is the caller's job (`platoon_app::search` runs them as
//! campaign cells, on a local pool or on Dask); this crate only decides what to run next from
//! the harm the caller measured.
//!
//! * [`Grid`]: the run's step grid; schedules are searched on it (a jam starts and ends on a
//!   step), so two candidates that the simulation cannot tell apart are one candidate.
//! * [`Schedule`]: jams `[start, start + duration)`, each on the whole channel or on one link
//!   ([`Target`]); what a candidate is in seconds, as a config writes it.
//! * [`Budget`]: what the attacker may do: the paper's Assumption 2 (certified by the exact
//!   checker, [`platoon_attacks::Assumption2::check`]), a total jammed time, a number of
//!   intervals, interval lengths, the targets. [`Budget::repair`] maps any proposal into the
//!   admissible set (a subset of what was proposed: fronts and ends trimmed, intervals dropped);
//!   [`Budget::certify`] is the gate every schedule passes before it is run.
//! * The strategies ([`Strategy`]), proposing batches and told the harm of each:
//!   [`Evolution`] (the search: differential evolution on interval onsets, lengths and targets
//!   with repair, seeded with jams on the leader's manoeuvres, then a pattern search around the
//!   best on the step grid), [`RandomSampler`] (random admissible schedules, as the Monte Carlo
//!   campaigns draw them) and [`GridSampler`] (one interval on an onset x duration grid, as the
//!   DoS-timing campaign).
#![warn(missing_docs)]

mod budget;
mod strategy;

pub use budget::{Budget, Certificate, Jam, JamKind, Limits, Plan};
pub use strategy::{
    monte_carlo_seed, Evolution, EvolutionSettings, GridSampler, RandomSampler, RandomSettings,
    Strategy,
};

use platoon_attacks::DosSchedule;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Why a search cannot start; `key` names the setting at fault as a search file spells it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct SearchError {
    /// The setting (`budget.max_jammed_s`, `evaluations`, ...).
    pub key: String,
    /// What is wrong with it.
    pub message: String,
}

impl SearchError {
    /// An error of `key`.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
        }
    }
}

/// A run's step grid: steps `0..=steps` of `dt`, times `[0, steps dt]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    dt: f64,
    steps: u64,
    /// Steps per second when it is a whole number: times are then `k / rate` (34.9, not
    /// 34.900000000000006).
    rate: Option<f64>,
}

impl Grid {
    /// The grid of a run of `steps` steps of `dt` seconds.
    pub fn new(dt: f64, steps: u64) -> Result<Self, SearchError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SearchError::new(
                "simulation.dt_s",
                format!("must be > 0 (got {dt})"),
            ));
        }
        if steps == 0 {
            return Err(SearchError::new(
                "simulation.duration_s",
                "the run needs at least one step",
            ));
        }
        let r = (1.0 / dt).round();
        let rate = (r >= 1.0 && (1.0 / dt - r).abs() <= 1e-9 * r).then_some(r);
        Ok(Self { dt, steps, rate })
    }

    /// The step length (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The last step.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The time of step `k` (s).
    pub fn time(&self, k: u64) -> f64 {
        match self.rate {
            Some(r) => k as f64 / r,
            None => k as f64 * self.dt,
        }
    }

    /// The end of the run (s).
    pub fn horizon(&self) -> f64 {
        self.time(self.steps)
    }

    /// The first step at or after `t` (clamped to the grid).
    pub fn ceil(&self, t: f64) -> u64 {
        if t.is_nan() || t <= 0.0 {
            return 0;
        }
        let mut k = ((t / self.dt) - 1e-6).ceil().max(0.0) as u64;
        while k < self.steps && self.time(k) < t {
            k += 1;
        }
        while k > 0 && self.time(k - 1) >= t {
            k -= 1;
        }
        k.min(self.steps)
    }

    /// The last step at or before `t` (clamped to the grid).
    pub fn floor(&self, t: f64) -> u64 {
        if t.is_nan() || t <= 0.0 {
            return 0;
        }
        let mut k = ((t / self.dt) + 1e-6).floor().max(0.0) as u64;
        k = k.min(self.steps);
        while k > 0 && self.time(k) > t {
            k -= 1;
        }
        while k < self.steps && self.time(k + 1) <= t {
            k += 1;
        }
        k
    }
}

/// What a jam hits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "jam")]
pub enum Target {
    /// The whole channel: every packet is lost and every vehicle senses the jamming (the
    /// paper's DoS, `[attack]`).
    Channel,
    /// One link: the packets `sender` sends to `receiver` are lost and nobody is told (a
    /// selective jammer; a `[[channel.attacks]]` Bernoulli loss of 1 on the link).
    Link {
        /// The sending vehicle (0 = leader).
        sender: u16,
        /// The receiving vehicle.
        receiver: u16,
    },
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Target::Channel => f.write_str("channel"),
            Target::Link { sender, receiver } => write!(f, "{sender}->{receiver}"),
        }
    }
}

/// One jam of a [`Schedule`]: `[start_s, start_s + duration_s)` on `target`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Jamming {
    /// Start (s).
    pub start_s: f64,
    /// Length (s), > 0.
    pub duration_s: f64,
    /// What it hits.
    pub target: Target,
}

/// A candidate attack: jams sorted by start, disjoint in time (one jammer, one target at a
/// time). Its jamming activity, the union of its jams, is what a [`Budget`] bounds.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Schedule {
    /// The jams, in order.
    pub jams: Vec<Jamming>,
}

impl Schedule {
    /// The jamming activity as a DoS schedule (every jam, whatever its target, built as a
    /// config's `[start, duration]` pairs are).
    pub fn activity(&self) -> Result<DosSchedule, String> {
        DosSchedule::from_intervals(&self.pairs()).map_err(|e| e.to_string())
    }

    /// `(start, duration)` of every jam.
    pub fn pairs(&self) -> Vec<(f64, f64)> {
        self.jams
            .iter()
            .map(|j| (j.start_s, j.duration_s))
            .collect()
    }

    /// Whether every jam is on the whole channel.
    pub fn whole_channel(&self) -> bool {
        self.jams.iter().all(|j| j.target == Target::Channel)
    }

    /// An identity for caches: the exact bits of every number.
    pub fn key(&self) -> Vec<(u64, u64, Target)> {
        self.jams
            .iter()
            .map(|j| (j.start_s.to_bits(), j.duration_s.to_bits(), j.target))
            .collect()
    }
}

impl fmt::Display for Schedule {
    /// `34.9+6.5 s` per jam, to the millisecond (`@0->1` for a link), `none` without.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.jams.is_empty() {
            return f.write_str("none");
        }
        for (i, j) in self.jams.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{}+{} s", round3(j.start_s), round3(j.duration_s))?;
            if j.target != Target::Channel {
                write!(f, " @{}", j.target)?;
            }
        }
        Ok(())
    }
}

/// `x` to the millisecond, for people (the exact schedule is in [`Schedule::jams`]).
fn round3(x: f64) -> f64 {
    (x * 1e3).round() / 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_times_are_the_decimal_ones() {
        let g = Grid::new(0.01, 5500).unwrap();
        assert_eq!(g.time(3490), 34.9);
        assert_eq!(g.horizon(), 55.0);
        assert_eq!(g.ceil(34.9), 3490);
        assert_eq!(g.ceil(34.901), 3491);
        assert_eq!(g.floor(34.909), 3490);
        assert_eq!(g.floor(100.0), 5500);
        assert_eq!(g.ceil(-1.0), 0);
        let odd = Grid::new(0.03, 100).unwrap();
        assert_eq!(odd.time(10), 10.0 * 0.03);
        assert!(odd.time(odd.ceil(0.1)) >= 0.1 && odd.time(odd.ceil(0.1) - 1) < 0.1);
        assert!(Grid::new(0.0, 10).is_err() && Grid::new(0.01, 0).is_err());
    }

    #[test]
    fn schedules_print_their_jams() {
        let s = Schedule {
            jams: vec![
                Jamming {
                    start_s: 34.9,
                    duration_s: 41.4 - 34.9,
                    target: Target::Channel,
                },
                Jamming {
                    start_s: 50.0,
                    duration_s: 1.0004,
                    target: Target::Link {
                        sender: 0,
                        receiver: 1,
                    },
                },
            ],
        };
        assert_eq!(s.to_string(), "34.9+6.5 s, 50+1 s @0->1");
        assert_eq!(Schedule::default().to_string(), "none");
        assert!(!s.whole_channel());
    }
}
