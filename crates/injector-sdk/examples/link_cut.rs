//! An attack on the pure seam: the config's own channel (its DoS schedule and link attacks),
//! and one link cut for a window: from START_S to END_S (seconds) every packet from SENDER to
//! RECEIVER is lost, in every platoon, and the receiver is not told. The same factory runs in
//! process (`platoon_app`'s `LocalPool::plugins`, `platoon_sim::run_until_plugins`) and here
//! as the injector process of a co-simulation:
//!
//! ```sh
//! cargo build --example link_cut
//! platoon run configs/table1.toml --injector "target/debug/examples/link_cut 0 1 10 20"
//! ```
use platoon_injector_sdk::{run, Channel, InjectError, Injector, InjectorFactory, Reception, Step};
use platoon_injector_sdk::{Scenario, VehicleId};

#[derive(Debug, Clone)]
struct LinkCut {
    channel: Channel,
    link: (VehicleId, VehicleId),
    window: (f64, f64),
}

impl Injector for LinkCut {
    fn step(&mut self, step: &Step<'_>, out: &mut Reception<'_>) -> Result<(), InjectError> {
        self.channel.step(step, out)?;
        if step.t >= self.window.0 && step.t < self.window.1 {
            out.deliveries
                .retain(|d| (d.packet.sender, d.receiver) != self.link);
        }
        Ok(())
    }

    fn radio_stats(&self) -> Option<platoon_injector_sdk::RadioStats> {
        self.channel.radio_stats()
    }
}

fn main() -> Result<(), platoon_injector_sdk::Error> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let parse = |i: usize, what: &str| -> f64 {
        args.get(i).and_then(|a| a.parse().ok()).unwrap_or_else(|| {
            eprintln!(
                "usage: link_cut SENDER RECEIVER START_S END_S ({what} is missing or not a number)"
            );
            std::process::exit(2)
        })
    };
    let link = (
        VehicleId(parse(0, "SENDER") as u16),
        VehicleId(parse(1, "RECEIVER") as u16),
    );
    let window = (parse(2, "START_S"), parse(3, "END_S"));
    run(InjectorFactory::new(move |s: &Scenario| {
        Ok(Box::new(LinkCut {
            channel: Channel::new(s.channel_spec(), s.vehicles_per_platoon()),
            link,
            window,
        }))
    }))
}
