//! An attack of the caller's, in Rust, on the pure injector seam: it runs in an in-process
//! campaign and in a search through `platoon_app`'s library calls, with no process per cell,
//! and what it did shows in the outputs (the drops measured on the wire, the gaps).
use platoon_app::campaign::{self, Campaign, CampaignOptions, CellPlugins, LocalPool};
use platoon_app::search::{self, SearchOptions};
use platoon_app::Stop;
use platoon_attacks::channel::Channel;
use platoon_attacks::inject::{InjectError, Injector, Reception, Step};
use platoon_model::VehicleId;
use platoon_sim::{InjectorFactory, Scenario};
use std::path::Path;

/// The built-in channel, and a cut link: every packet from `sender` to `receiver` is lost
/// from `from_s` to `to_s`.
#[derive(Debug, Clone)]
struct LinkCut {
    channel: Channel,
    sender: VehicleId,
    receiver: VehicleId,
    window: (f64, f64),
}

impl Injector for LinkCut {
    fn step(&mut self, step: &Step<'_>, out: &mut Reception<'_>) -> Result<(), InjectError> {
        self.channel.step(step, out)?;
        if step.t >= self.window.0 && step.t < self.window.1 {
            let cut = (self.sender, self.receiver);
            out.deliveries
                .retain(|d| (d.packet.sender, d.receiver) != cut);
        }
        Ok(())
    }
}

/// Vehicle 1 hears nothing from the leader from 9 s to 16 s (over its speed-up on [10, 15)).
fn link_cut() -> InjectorFactory {
    InjectorFactory::new(|s: &Scenario| {
        Ok(Box::new(LinkCut {
            channel: Channel::new(s.channel_spec(), s.vehicles_per_platoon()),
            sender: VehicleId(0),
            receiver: VehicleId(1),
            window: (9.0, 16.0),
        }))
    })
}

fn pool(injector: Option<InjectorFactory>) -> LocalPool {
    LocalPool {
        plugins: CellPlugins {
            controller: None,
            injector,
        },
        ..LocalPool::new(std::num::NonZeroUsize::new(2))
    }
}

const CAMPAIGN: &str = r#"
name = "cut"
set = { "simulation.duration_s" = 20.0 }
metrics = ["max_spacing_error_m", "triggers_total"]
[[axes]]
key = "trigger.rule"
values = ["dynamic", "static"]
"#;

fn no_plots() -> CampaignOptions {
    CampaignOptions {
        plots: false,
        ..CampaignOptions::default()
    }
}

fn campaign(dir: &Path, injector: Option<InjectorFactory>) -> Vec<serde_json::Value> {
    let c = Campaign::parse(CAMPAIGN, &dir.join("cut.toml"), None).unwrap();
    let done = campaign::run(&c, dir, &no_plots(), &pool(injector), &Stop::default(), &()).unwrap();
    done.cells
        .iter()
        .map(|c| c.summary_json().unwrap().clone())
        .collect()
}

/// Vehicle 1's link packets over the run, from `summary.json`'s wire tally.
fn dropped(summary: &serde_json::Value, vehicle: usize) -> u64 {
    summary["wire"]["per_vehicle"][vehicle]["dropped"]
        .as_u64()
        .unwrap()
}

#[test]
fn a_callers_attack_runs_in_an_in_process_campaign_and_cuts_its_link() {
    let tmp = tempfile::tempdir().unwrap();
    let builtin = campaign(&tmp.path().join("builtin"), None);
    let seam = campaign(&tmp.path().join("seam"), Some(InjectorFactory::builtin()));
    let cut = campaign(&tmp.path().join("cut"), Some(link_cut()));
    for ((b, s), c) in builtin.iter().zip(&seam).zip(&cut) {
        // The built-in channel through the factory is the built-in run, bit for bit.
        assert_eq!(b["vehicles"], s["vehicles"]);
        assert_eq!(b["wire"], s["wire"]);
        // The leader's packets to vehicle 1 were dropped on the cut link, and nothing else.
        assert!(dropped(c, 1) > dropped(b, 1), "{}", c["wire"]);
        assert_eq!(dropped(c, 2), dropped(b, 2));
        assert_eq!(c["injector"]["program"], "in process");
        // Vehicle 1 lost its leader's state over the speed-up: its gap moved differently.
        let gap = |s: &serde_json::Value| s["vehicles"][0]["gap_error_m"]["max_abs"].clone();
        assert_ne!(gap(c), gap(b));
    }
}

/// Two small searches of the worst DoS on the paper scenario: the candidates run with the link
/// cut of the caller's, in process; the harms differ from the built-in channel's, and the
/// worst schedule re-run with the same attack reproduces its harm.
#[test]
fn a_callers_attack_runs_in_a_search() {
    let tmp = tempfile::tempdir().unwrap();
    let text = "seed = 1\nevaluations = 8\ncompare = []\n[search]\npopulation = 8\n";
    let s = search::parse(text, &tmp.path().join("s.toml"), None).unwrap();
    let opts = SearchOptions {
        force: false,
        plots: false,
    };
    let run = |out: &str, injector| {
        search::run(
            &s,
            &tmp.path().join(out),
            &opts,
            &pool(injector),
            &Stop::default(),
            &(),
        )
        .unwrap()
    };
    let builtin = run("builtin", None);
    let cut = run("cut", Some(link_cut()));
    let harms = |o: &search::SearchOutcome| -> Vec<Option<f64>> {
        o.problems[0].methods[0]
            .history
            .iter()
            .map(|e| e.harm)
            .collect()
    };
    let (b, c) = (harms(&builtin), harms(&cut));
    assert_eq!(b.len(), 8);
    assert_eq!(c.len(), 8);
    assert_ne!(b, c, "the cut link changes what each schedule does");
    assert_eq!(cut.problems[0].reproduced, Some(true));
}
