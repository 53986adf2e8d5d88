//! Where the time of a co-simulation step goes, from the publish time stamps in every sample's
//! header (`CLOCK_MONOTONIC`, shared by all processes on the machine), and in `[security]`
//! runs what the seals' signing and verifying took in each step ([`CryptoStages`], by the clock
//! the runtime lends the controllers: `platoon_control::Controller::time_crypto`).
use platoon_control::CryptoTime;
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

impl Stats {
    /// As the wire carries it (`platoon_wire::ControlMsg::TIMING`): samples, then the 50th,
    /// 90th, 99th and 99.9th percentiles and the largest in ns.
    pub fn to_ns(&self) -> [u64; 6] {
        let ns = |us: f64| (us * 1e3).round() as u64;
        [
            self.n as u64,
            ns(self.p50_us),
            ns(self.p90_us),
            ns(self.p99_us),
            ns(self.p999_us),
            ns(self.max_us),
        ]
    }

    /// From [`Stats::to_ns`]'s form (`None` for no samples): the same figures.
    pub fn from_ns(a: &[u64]) -> Option<Self> {
        let us = |i: usize| a.get(i).copied().unwrap_or(0) as f64 / 1e3;
        let n = a.first().copied().unwrap_or(0) as usize;
        (n > 0).then(|| Self {
            n,
            p50_us: us(1),
            p90_us: us(2),
            p99_us: us(3),
            p999_us: us(4),
            max_us: us(5),
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
            sign: None,
            verify: None,
        }
    }
}

/// The time the seals' cryptography took in each step (`[security]` runs), from the
/// controllers' running totals ([`CryptoTime`]) after every step: every packet's signing in a
/// step, and every delivery's seal check (a signature computed, or shared from the step's
/// memo). Steps with nothing to sign or check count as 0.
#[derive(Debug, Clone, Default)]
pub struct CryptoStages {
    sign: Vec<u64>,
    verify: Vec<u64>,
    last: CryptoTime,
}

impl CryptoStages {
    /// Adds a step from the totals after it (summed over every platoon's controller).
    pub fn push(&mut self, total: CryptoTime) {
        self.sign
            .push(total.sign_ns.saturating_sub(self.last.sign_ns));
        self.verify
            .push(total.verify_ns.saturating_sub(self.last.verify_ns));
        self.last = total;
    }

    /// The steps' percentiles into `timing`'s `sign` and `verify`.
    pub fn report_into(mut self, timing: &mut Timing) {
        timing.sign = Stats::of(&mut self.sign);
        timing.verify = Stats::of(&mut self.verify);
    }

    /// The steps' percentiles as the wire carries them ([`Stats::to_ns`]; all 0 without
    /// steps): signing, verifying.
    pub fn to_ns(&self) -> ([u64; 6], [u64; 6]) {
        let of = |v: &[u64]| Stats::of(&mut v.to_vec()).map_or([0; 6], |s| s.to_ns());
        (of(&self.sign), of(&self.verify))
    }

    /// The steps' times as they are (ns): signing, verifying.
    pub fn per_step(&self) -> (&[u64], &[u64]) {
        (&self.sign, &self.verify)
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
    /// `[security]` runs: the signing of a step's packets, per step (in the controllers'
    /// `transmit`; absent from timing.json otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sign: Option<Stats>,
    /// `[security]` runs: the checks of a step's deliveries' seals, per step (in the
    /// controllers' `receive`; absent from timing.json otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verify: Option<Stats>,
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
        let mut odd: Vec<u64> = (1..=7).map(|x| x * 1234 + 1).collect();
        let s = Stats::of(&mut odd).unwrap();
        assert_eq!(
            Stats::from_ns(&s.to_ns()),
            Some(s),
            "the wire's form is exact"
        );
        assert_eq!(Stats::from_ns(&[0; 6]), None);
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
        let json = serde_json::to_value(&t).unwrap();
        assert!(json.get("sign").is_none() && json.get("verify").is_none());
    }

    #[test]
    fn crypto_stages_are_the_steps_differences_of_the_totals() {
        let mut c = CryptoStages::default();
        for (s, v) in [(2000, 0), (2000, 5000), (9000, 6000)] {
            c.push(CryptoTime {
                sign_ns: s,
                verify_ns: v,
            });
        }
        assert_eq!(c.per_step(), (&[2000, 0, 7000][..], &[0, 5000, 1000][..]));
        let mut t = StageClock::default().report();
        c.report_into(&mut t);
        let (sign, verify) = (t.sign.unwrap(), t.verify.unwrap());
        assert_eq!((sign.n, sign.p50_us, sign.max_us), (3, 2.0, 7.0));
        assert_eq!((verify.p50_us, verify.max_us), (1.0, 5.0));
        let json = serde_json::to_value(&t).unwrap();
        assert_eq!(json["sign"]["max_us"], 7.0);
    }
}
