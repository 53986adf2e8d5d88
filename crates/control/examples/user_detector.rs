//! A misbehaviour detector of one's own on the built-in controller, in process.
//!
//! `SpeedGap` flags a packet whose claimed speed (brought to the receive step) is more than
//! `max_mps` from the receiver's own: a platoon drives at one speed, so a neighbour claiming
//! to be much faster or slower is lying. It is any [`Detector`]; [`platoon_control::build_with`]
//! puts it on the controller the config names, after the config's own detectors, under the
//! config's `[detection]` reaction. A [`ControllerFactory`] hands that controller to the
//! in-process runner, which measures the detector against ground truth like a built-in one.
//!
//! The run: a platoon cruising at 15 m/s on a predecessor-following graph, with follower 1 lying about
//! its speed (+3 m/s) from 12 s to 14 s. Under `reaction = "log"` the lies follower 2 accepts
//! steer it to the claimed speed, and the detector sees their onset only; under
//! `reaction = "fallback"` follower 2, who hears follower 1, refuses every lie and runs its
//! fallback until half a second after the last one.
//!
//! `cargo run -p platoon-control --example user_detector`
use platoon_control::screening::Detector;
use platoon_control::Reaction;
use platoon_detect::{Observation, Verdict};
use platoon_sim::{ControllerFactory, Summary};
use std::path::Path;

/// Flags a claimed speed more than `max_mps` from the receiver's own.
#[derive(Debug, Clone)]
pub struct SpeedGap {
    /// The largest believable difference (m/s).
    pub max_mps: f64,
}

impl Detector for SpeedGap {
    fn name(&self) -> &'static str {
        "speed_gap"
    }

    fn inspect(&mut self, obs: &Observation) -> Verdict {
        let gap = (obs.claim_now()[1] - obs.own[1]).abs();
        Verdict {
            // A NaN claim is flagged too.
            flagged: gap > self.max_mps || gap.is_nan(),
            score: gap,
        }
    }
}

/// The scenario: 20 s of a platoon cruising at 15 m/s on PF, follower 1 lying from 12 s to
/// 14 s.
pub const CONFIG: &str = r#"
name = "user-detector"

[simulation]
duration_s = 20.0
dt_s = 0.01

[platoon]
followers = 4
spacing_m = 10.0
initial_states = [
  [20.0, 15.0, 0.0],
  [10.0, 15.0, 0.0],
  [0.0, 15.0, 0.0],
  [-10.0, 15.0, 0.0],
  [-20.0, 15.0, 0.0],
]

[leader]
profile = { kind = "constant", speed_mps = 15.0 }

[topology]
preset = "pf"

[plant]
tau_nominal_s = 0.5
tau = { kind = "constant", value_s = 0.5 }

[control]
gain = [4.81, 9.12, 2.97]
beta1 = 319.38
beta2 = 5.62

[trigger]
rule = "periodic"
period_s = 0.1
h_s = 0.02

[[channel.attacks]]
kind = "false_data"
senders = [1]
start_s = 12.0
end_s = 14.0
offset = [0.0, 3.0, 0.0]
"#;

/// Runs the scenario with `SpeedGap` under `reaction` (with a quiet period of 0.5 s).
pub fn run(reaction: Reaction) -> Summary {
    let (_, mut scenario) = platoon_config::parse(CONFIG, Path::new("user-detector.toml"))
        .expect("the example's config parses");
    // The config's `[detection]` reaction, set here because this config names no built-in
    // detector (a config with `[detection.<name>]` tables would carry it).
    scenario.control.detection.reaction = reaction;
    scenario.control.detection.quiet_steps = 50;
    let factory = ControllerFactory::new(|s| {
        platoon_control::build_with(
            &s.control,
            &s.topology,
            &s.initial,
            vec![Box::new(SpeedGap { max_mps: 2.0 })],
        )
    });
    platoon_sim::run_until_with(&scenario, &factory, |_| std::ops::ControlFlow::Continue(()))
        .expect("the scenario runs")
}

fn main() {
    for reaction in [Reaction::Log, Reaction::Fallback] {
        let summary = run(reaction);
        let d = summary
            .detection
            .as_ref()
            .expect("the detector is measured");
        let score = &d.detectors[0];
        println!(
            "reaction = {:?}: {} flagged {} of {} packets ({} refused), recall {:?}, \
             false alarms {}; follower 2 affected for {:.2} s",
            reaction.name(),
            score.name,
            d.flagged,
            d.inspected,
            d.refused,
            score.recall,
            score.totals.fp,
            summary
                .vehicles
                .iter()
                .find(|v| v.vehicle == 2)
                .map_or(0.0, |v| v.affected_time_s),
        );
    }
}
