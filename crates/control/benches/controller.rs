//! Criterion benches for the controller's hot paths (not tests; read medians side by side):
//! the event-triggering check of every follower (`transmit`), one estimator update, and one
//! full controller step (transmit + receive with every packet delivered), for the paper's
//! 4-follower TPSF platoon and a 100-follower PF platoon.
//!
//! Method: state from a running scenario (step 500 of the paper scenario, so estimators and
//! theta are not trivial); each iteration works on a clone, so all see the same state.
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use platoon_control::{Delivery, Packet};
use platoon_model::{FreeFlow, State, VehicleId};
use platoon_sim::Simulation;

fn scenario(followers: usize) -> platoon_sim::Scenario {
    let text = platoon_config::PAPER_TOML;
    let (_, s) = platoon_config::parse(text, std::path::Path::new("paper")).unwrap();
    if followers == 4 {
        return s;
    }
    let mut initial = vec![State::new(20.0, 15.0, 0.0)];
    initial.extend((1..=followers).map(|i| State::new(20.0 - 10.0 * i as f64, 15.0, 0.0)));
    let mut s2 = s.clone();
    s2.topology =
        platoon_topology::Topology::preset(platoon_topology::Preset::Pf, followers).unwrap();
    s2.initial = initial;
    s2.taus = vec![s.taus[0].clone(); followers];
    s2
}

fn benches(c: &mut Criterion) {
    for followers in [4usize, 100] {
        let sc = scenario(followers);
        let mut sim = Simulation::new(sc.clone()).unwrap();
        for _ in 0..500 {
            sim.step();
        }
        let rows = sim.step().to_vec();
        let states: Vec<State> = rows.iter().map(|r| State::new(r.p, r.v, r.a)).collect();
        let controller = dyn_clone::clone_box(sim.controller());
        let k = rows[0].step + 1;

        c.bench_with_input(
            BenchmarkId::new("etm_check_all_followers", followers),
            &followers,
            |b, _| {
                b.iter_batched(
                    || (controller.clone(), Vec::with_capacity(followers + 1)),
                    |(mut ctl, mut tx): (_, Vec<Packet>)| {
                        ctl.transmit(black_box(k), black_box(&states), &mut tx);
                        tx.len()
                    },
                    criterion::BatchSize::SmallInput,
                )
            },
        );
        c.bench_with_input(
            BenchmarkId::new("controller_step", followers),
            &followers,
            |b, _| {
                b.iter_batched(
                    || (controller.clone(), Vec::with_capacity(followers + 1)),
                    |(mut ctl, mut tx): (_, Vec<Packet>)| {
                        ctl.transmit(k, black_box(&states), &mut tx);
                        let deliveries: Vec<Delivery> =
                            tx.iter()
                                .flat_map(|p| {
                                    sc.topology.out_neighbours(p.sender).iter().map(
                                        move |&receiver| Delivery {
                                            receiver,
                                            packet: *p,
                                        },
                                    )
                                })
                                .collect();
                        let jammed = vec![false; followers + 1];
                        ctl.receive(k, &states, &deliveries, &jammed)[0]
                    },
                    criterion::BatchSize::SmallInput,
                )
            },
        );
        let _ = VehicleId::LEADER;
    }
    let flow = FreeFlow::new(0.5, 0.01);
    let x = State::new(1.0, 15.0, 0.3);
    c.bench_function("estimator_update", |b| {
        b.iter(|| flow.advance(black_box(&x)))
    });
}

criterion_group!(controller, benches);
criterion_main!(controller);
