//! A jammer that follows one vehicle: from START_S to END_S (seconds), vehicle VEHICLE of every
//! platoon can neither send nor receive (an attacker driving alongside it), and is told its
//! channel is jammed; everyone else communicates as usual. The built-in channel has no such
//! attack (its range jammer is tied to a road position).
//!
//! ```sh
//! platoon run configs/table1.toml --injector "target/debug/examples/follow_jammer 2 10 20"
//! ```
use platoon_injector_sdk::{jammed, run_wire, InjectError, LinkPacket, Numbering};
use platoon_injector_sdk::{WireInjector, WireStep};

struct FollowJammer {
    vehicle: u32,
    window: (f64, f64),
    num: Numbering,
}

impl WireInjector for FollowJammer {
    fn step(&mut self, step: &WireStep<'_>, rx: &mut Vec<LinkPacket>) -> Result<(), InjectError> {
        let active = step.t >= self.window.0 && step.t < self.window.1;
        if !active {
            rx.extend_from_slice(step.tx);
            return Ok(());
        }
        let target = |id: u32| self.num.local(id) == self.vehicle;
        rx.extend(
            step.tx
                .iter()
                .filter(|it| !target(it.packet.sender) && !target(it.receiver)),
        );
        rx.extend((0..self.num.platoons).map(|j| jammed(self.num.global(j, self.vehicle))));
        Ok(())
    }
}

fn main() -> Result<(), platoon_injector_sdk::Error> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let parse = |i: usize, what: &str| -> f64 {
        args.get(i).and_then(|a| a.parse().ok()).unwrap_or_else(|| {
            eprintln!(
                "usage: follow_jammer VEHICLE START_S END_S ({what} is missing or not a number)"
            );
            std::process::exit(2)
        })
    };
    let vehicle = parse(0, "VEHICLE") as u32;
    let window = (parse(1, "START_S"), parse(2, "END_S"));
    run_wire(|scenario| FollowJammer {
        vehicle,
        window,
        num: Numbering::of(scenario),
    })
}
