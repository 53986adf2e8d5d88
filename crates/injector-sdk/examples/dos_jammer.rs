//! The built-in DoS channel, rewritten on the SDK: during an attack interval of the run's
//! config (`[attack]`) nothing is delivered and every vehicle, the leader included, is told its
//! channel is jammed; otherwise every packet is delivered as sent. With a config that has no
//! link attacks, a run with this injector equals the built-in run byte for byte (tested):
//!
//! ```sh
//! cargo build --example dos_jammer
//! platoon run configs/table1.toml --injector target/debug/examples/dos_jammer
//! ```
use platoon_injector_sdk::{jammed, run_wire, InjectError, LinkPacket, Numbering, Scenario};
use platoon_injector_sdk::{WireInjector, WireStep};

struct DosJammer {
    dos: platoon_attacks_free::Schedule,
    num: Numbering,
}

/// The attack intervals, as `[start, end)` pairs (no dependency beyond the SDK).
mod platoon_attacks_free {
    pub struct Schedule(pub Vec<(f64, f64)>);
    impl Schedule {
        pub fn active(&self, t: f64) -> bool {
            self.0.iter().any(|&(a, b)| t >= a && t < b)
        }
    }
}

impl WireInjector for DosJammer {
    fn step(&mut self, step: &WireStep<'_>, rx: &mut Vec<LinkPacket>) -> Result<(), InjectError> {
        if self.dos.active(step.t) {
            rx.extend(self.num.all().map(jammed));
        } else {
            rx.extend_from_slice(step.tx);
        }
        Ok(())
    }
}

fn schedule(scenario: &Scenario) -> platoon_attacks_free::Schedule {
    platoon_attacks_free::Schedule(
        scenario
            .dos
            .intervals()
            .iter()
            .map(|iv| (iv.start, iv.end))
            .collect(),
    )
}

fn main() -> Result<(), platoon_injector_sdk::Error> {
    run_wire(|scenario| DosJammer {
        dos: schedule(scenario),
        num: Numbering::of(scenario),
    })
}
