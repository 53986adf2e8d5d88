//! Where the time of a co-simulation step goes, from the publish time stamps in every sample's
//! header (`CLOCK_MONOTONIC`, shared by all processes on the machine).
use serde::Serialize;

/// Percentiles of one stage's duration (µs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stats {
    /// Samples.
    pub n: usize,
    /// Median.
    pub p50_us: f64,
    /// 90th percentile.
    pub p90_us: f64,
    /// 99th percentile.
    pub p99_us: f64,
    /// 99.9th percentile.
    pub p999_us: f64,
    /// Largest.
    pub max_us: f64,
}

impl Stats {
    /// Percentiles (nearest rank) of `ns`, sorted in place.
    pub fn of(ns: &mut [u64]) -> Option<Self> {
        if ns.is_empty() {
            return None;
        }
        ns.sort_unstable();
        let at = |q: f64| {
            let i = ((q * ns.len() as f64).ceil() as usize).clamp(1, ns.len()) - 1;
            ns[i] as f64 / 1e3
        };
        Some(Self {
            n: ns.len(),
            p50_us: at(0.5),
            p90_us: at(0.9),
            p99_us: at(0.99),
            p999_us: at(0.999),
            max_us: ns[ns.len() - 1] as f64 / 1e3,
        })
    }
}

/// Each stage of a step, from one publish to the next: the time includes the wake-up of the
/// process that publishes next, its computation, and the publish itself.
#[derive(Debug, Clone, Default)]
pub struct StageClock {
    /// `states[k] -> tx[k]`: the controllers' triggering rules.
    pub controller_tx: Vec<u64>,
    /// `tx[k] -> rx[k]`: the injector hop.
    pub injector: Vec<u64>,
    /// `rx[k] -> commands[k]`: estimators and control law.
    pub controller_rx: Vec<u64>,
    /// `commands[k] -> states[k+1]`: the plant.
    pub plant: Vec<u64>,
    /// `states[k] -> states[k+1]`: one whole step.
    pub step: Vec<u64>,
    last: Option<(u64, u64)>,
}

impl StageClock {
    /// Adds step k from the publish stamps of its four samples.
    pub fn push(&mut self, states: u64, tx: u64, rx: u64, commands: u64) {
        if let Some((prev_states, prev_commands)) = self.last {
            self.plant.push(states.saturating_sub(prev_commands));
            self.step.push(states.saturating_sub(prev_states));
        }
        self.controller_tx.push(tx.saturating_sub(states));
        self.injector.push(rx.saturating_sub(tx));
        self.controller_rx.push(commands.saturating_sub(rx));
        self.last = Some((states, commands));
    }

    /// The percentiles of every stage.
    pub fn report(mut self) -> Timing {
        Timing {
            step: Stats::of(&mut self.step),
            controller_tx: Stats::of(&mut self.controller_tx),
            injector: Stats::of(&mut self.injector),
            controller_rx: Stats::of(&mut self.controller_rx),
            plant: Stats::of(&mut self.plant),
        }
    }
}

/// What `timing.json` holds: percentiles of each stage of a step (µs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Timing {
    /// One whole step (`states[k] -> states[k+1]`).
    pub step: Option<Stats>,
    /// `states[k] -> tx[k]`.
    pub controller_tx: Option<Stats>,
    /// `tx[k] -> rx[k]`: the V2V hop through the injector.
    pub injector: Option<Stats>,
    /// `rx[k] -> commands[k]`.
    pub controller_rx: Option<Stats>,
    /// `commands[k] -> states[k+1]`.
    pub plant: Option<Stats>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_use_the_nearest_rank() {
        let mut v: Vec<u64> = (1..=100).map(|x| x * 1000).collect();
        let s = Stats::of(&mut v).unwrap();
        assert_eq!(
            (s.p50_us, s.p90_us, s.p99_us, s.max_us),
            (50.0, 90.0, 99.0, 100.0)
        );
        assert!(Stats::of(&mut []).is_none());
    }

    #[test]
    fn stages_are_the_gaps_between_publishes() {
        let mut c = StageClock::default();
        c.push(0, 10, 30, 60);
        c.push(100, 110, 130, 160);
        let t = c.report();
        assert_eq!(t.step.unwrap().p50_us, 0.1);
        assert_eq!(t.plant.unwrap().p50_us, 0.04);
        assert_eq!(t.injector.unwrap().p50_us, 0.02);
    }
}
