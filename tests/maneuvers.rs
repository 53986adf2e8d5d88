//! Maneuvers negotiated over V2V, in process: the join at the tail of `configs/join.toml`
//! (vehicle 4 starts 60 m behind the platoon, asks at 5 s), its messages as the injector sees
//! them on the packets, the joiner's command at the hand-over to the law, a join whose
//! messages the channel loses, and the errors a bad `[maneuvers]` gets. Both transports
//! agree on it bit for bit: tests/cosim.rs.
mod common;

use common::repo;
use platoon_attacks::inject::{InjectError, Injector, Reception, Step};
use platoon_control::Mode;
use platoon_maneuver::{Body, Change, Message};
use platoon_model::VehicleId;
use platoon_sim::{InjectorFactory, Plugins, Scenario, Simulation, StepRow};
use std::sync::{Arc, Mutex};

fn join_config() -> String {
    std::fs::read_to_string(repo().join("configs/join.toml")).unwrap()
}

fn scenario(text: &str) -> Scenario {
    platoon_config::parse(text, std::path::Path::new("join.toml"))
        .unwrap()
        .1
}

/// The built-in channel, recording every maneuver message broadcast (step, message) and
/// dropping every delivery of the messages `drop` picks.
#[derive(Debug, Clone)]
struct Recording {
    inner: Box<dyn Injector>,
    sent: Arc<Mutex<Vec<(u64, Message)>>>,
    drop: fn(u64, &Message) -> bool,
}

impl Injector for Recording {
    fn step(&mut self, step: &Step<'_>, out: &mut Reception<'_>) -> Result<(), InjectError> {
        self.inner.step(step, out)?;
        let mut sent = self.sent.lock().unwrap();
        sent.extend(
            step.tx
                .iter()
                .filter_map(|p| p.maneuver.map(|m| (step.k, m))),
        );
        let drop = self.drop;
        out.deliveries
            .retain(|d| !d.packet.maneuver.is_some_and(|m| drop(step.k, &m)));
        Ok(())
    }
}

/// Runs `s` in process through [`Recording`]: every row and every message sent.
fn run(s: Scenario, drop: fn(u64, &Message) -> bool) -> (Vec<StepRow>, Vec<(u64, Message)>) {
    let sent = Arc::new(Mutex::new(Vec::new()));
    let log = sent.clone();
    let plugins = Plugins {
        injector: InjectorFactory::new(move |s| {
            Ok(Box::new(Recording {
                inner: InjectorFactory::builtin().make(s)?,
                sent: log.clone(),
                drop,
            }))
        }),
        ..Plugins::default()
    };
    let mut sim = Simulation::with_plugins(s, &plugins).unwrap();
    let mut rows = Vec::new();
    while !sim.is_done() {
        rows.extend_from_slice(sim.step());
    }
    let sent = sent.lock().unwrap().clone();
    (rows, sent)
}

fn of(rows: &[StepRow], v: u16) -> Vec<&StepRow> {
    rows.iter().filter(|r| r.vehicle == v).collect()
}

/// The smallest gap between consecutive vehicles over the run (m, bumper to bumper).
fn smallest_gap(rows: &[StepRow], length: f64) -> f64 {
    rows.chunks(5)
        .flat_map(|step| step.windows(2).map(|w| w[0].p - w[1].p - length))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_join_at_the_tail_is_negotiated_on_the_packets_and_taken_without_a_jump() {
    let s = scenario(&join_config());
    let dt = s.dt();
    let (rows, sent) = run(s, |_, _| false);
    let joiner = of(&rows, 4);
    // Outside from the start; the law from the step the update reached it, blended.
    assert_eq!(joiner[0].mode, Mode::Outside);
    let joined = joiner.iter().position(|r| r.mode != Mode::Outside).unwrap();
    assert_eq!(joiner[joined].mode, Mode::Blend);
    assert!(joiner[joined..].iter().all(|r| r.mode != Mode::Outside));
    // The messages, on the packets the injector saw: request at 5 s, the leader's accept the
    // step after it arrived, in position, then the update announced three times.
    let bodies: Vec<(u16, Body)> = sent.iter().map(|(_, m)| (m.sender.0, m.body)).collect();
    let update = Body::Update {
        generation: 1,
        change: Change::Joined {
            vehicle: VehicleId(4),
            behind: VehicleId(3),
        },
    };
    assert_eq!(
        bodies,
        vec![
            (
                4,
                Body::JoinRequest {
                    behind: VehicleId(3)
                }
            ),
            (
                0,
                Body::JoinAccept {
                    behind: VehicleId(3),
                    middle: false
                }
            ),
            (4, Body::InPosition),
            (0, update),
            (0, update),
            (0, update),
        ]
    );
    let at = |i: usize| sent[i].0;
    // Asked at 5 s, on the next step's packet (a step decides in its receive phase and sends
    // in the next one's transmit phase).
    assert_eq!(at(0), (5.0 / dt).round() as u64 + 1);
    assert_eq!(
        at(1),
        at(0) + 1,
        "the leader answers the step after it heard"
    );
    // The joiner took the law at the step the update reached it (a packet sent in a step's
    // transmit phase arrives in its receive phase).
    assert_eq!(joiner[joined].step, at(3));
    // In position when it said so: its gap within 1 m of the platoon's 15.5 m.
    let in_position = joiner[(at(2) - 1) as usize];
    let ahead = &rows[(at(2) - 1) as usize * 5 + 3];
    assert!((ahead.p - in_position.p - 4.5 - 15.5).abs() <= 1.0);
    // No step in its command larger than the blend's first share of the mismatch allows:
    // the hand-over and the accept are smooth (the largest step is the leader's braking
    // ramp ending, fed forward by the law, as every follower has it).
    let steps = |v: u16| {
        of(&rows, v)
            .windows(2)
            .map(|w| (w[1].u - w[0].u).abs())
            .fold(0.0, f64::max)
    };
    let member = steps(3);
    assert!(steps(4) <= member + 1e-9, "{} vs {member}", steps(4));
    let around = |i: usize| (joiner[i].u - joiner[i - 1].u).abs();
    let accepted = at(1) as usize;
    assert!(around(joined) < 0.05 && around(accepted) < 0.05 && around(accepted + 1) < 0.05);
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

#[test]
fn a_join_whose_update_never_arrives_is_withdrawn_and_the_joiner_stays_out() {
    // The channel loses every update: the joiner says it is in position three times, then
    // withdraws with leave notices; the leader, which admitted it, lets it go again (its
    // update of that is lost as well).
    let (rows, sent) = run(scenario(&join_config()), |_, m| {
        matches!(m.body, Body::Update { .. })
    });
    let joiner = of(&rows, 4);
    assert!(joiner.iter().all(|r| r.mode == Mode::Outside));
    let count = |b: fn(&Body) -> bool| sent.iter().filter(|(_, m)| b(&m.body)).count();
    assert_eq!(count(|b| *b == Body::InPosition), 3);
    // Its notices go unanswered too (the update is lost): it sends all three.
    assert_eq!(count(|b| *b == Body::LeaveNotice), 3);
    let left = sent.iter().any(|(_, m)| {
        m.body
            == Body::Update {
                generation: 2,
                change: Change::Left {
                    vehicle: VehicleId(4),
                },
            }
    });
    assert!(left, "the leader announces that vehicle 4 left");
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

#[test]
fn without_maneuvers_the_packets_carry_none_and_the_outputs_are_unchanged() {
    let text = join_config();
    let plain = text[..text.find("[maneuvers]").unwrap()].to_string();
    let (rows, sent) = run(scenario(&plain), |_, _| false);
    assert!(sent.is_empty());
    assert!(rows.iter().all(|r| r.mode != Mode::Outside));
}

#[test]
fn a_bad_maneuvers_table_names_its_key() {
    let text = join_config();
    let err = |from: &str, to: &str| {
        let t = text.replace(from, to);
        assert_ne!(t, text, "{from}");
        platoon_config::parse(&t, std::path::Path::new("join.toml"))
            .unwrap_err()
            .to_string()
    };
    let e = err("vehicle = 4", "vehicle = 2");
    assert!(
        e.contains("maneuvers.joins") && e.contains("at the tail"),
        "{e}"
    );
    let e = err("vehicle = 4", "vehicle = 9");
    assert!(e.contains("maneuvers.joins[0].vehicle"), "{e}");
    let e = err(
        "law = \"path_cacc\"\nspacing_m = 15.5",
        "gain = [4.81, 9.12, 2.97]\nbeta1 = 319.38\nbeta2 = 5.62",
    );
    assert!(e.contains("maneuvers") && e.contains("paper's law"), "{e}");
    let e = err("tries = 3", "tries = 3\nin_position_km = 1.0");
    assert!(e.contains("in_position_km"), "{e}");
}
