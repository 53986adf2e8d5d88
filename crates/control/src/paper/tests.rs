//! The paper's law on the pipeline: its sign and spacing conventions, the triggers, the
//! resilient mechanism, the packet checks and the open-loop propagation of a late packet.
use crate::{Controller, ControllerParams, Delivery, Packet, TriggerRule};
use nalgebra::RowVector3;
use platoon_model::{FreeFlow, State, VehicleId};
use platoon_topology::Preset;
use platoon_topology::Topology;

/// The paper's controller for `topology`'s followers.
fn paper(
    params: ControllerParams,
    topology: &Topology,
    initial: &[State],
) -> Result<Box<dyn Controller>, crate::ParamsError> {
    crate::build(&params, topology, initial)
}

fn params(rule: TriggerRule) -> ControllerParams {
    ControllerParams {
        law: crate::LawParams::Paper(Default::default()),
        gain: RowVector3::new(4.81, 9.12, 2.97),
        beta1: 319.38,
        beta2: 5.62,
        rule,
        resilient: true,
        h_steps: 2,
        check_steps: 1,
        fallback: crate::FallbackParams::default(),
        dt: 0.01,
        tau_nominal: 0.5,
        spacing: 10.0,
        headway: 0.0,
        leader_broadcast_steps: 1,
        detection: Default::default(),
        maneuvers: None,
        security: None,
    }
}

fn formation(n: usize, v: f64) -> Vec<State> {
    (0..=n)
        .map(|i| State::new(-(i as f64) * 10.0, v, 0.0))
        .collect()
}

fn everyone(topology: &Topology, packets: &[Packet]) -> Vec<Delivery> {
    packets
        .iter()
        .flat_map(|p| {
            topology.out_neighbours(p.sender).iter().map(|&r| Delivery {
                receiver: r,
                packet: *p,
            })
        })
        .collect()
}

#[test]
fn in_formation_there_is_no_error_no_input_and_no_event() {
    let topo = Topology::preset(Preset::Tpsf, 4).unwrap();
    let states = formation(4, 15.0);
    for rule in [
        TriggerRule::Static,
        TriggerRule::Dynamic {
            phi: 0.33,
            rho: 0.5,
            eta: 0.5,
            theta0: 200.0,
        },
    ] {
        let mut c = paper(params(rule), &topo, &states).unwrap();
        let mut tx = Vec::new();
        c.transmit(0, &states, &mut tx);
        assert_eq!(tx.len(), 5, "everyone samples at t = 0");
        let u = c
            .receive(0, &states, &everyone(&topo, &tx), &[false; 5])
            .to_vec();
        assert_eq!(u, vec![0.0; 4]);
        // One step later in exact formation at constant speed the estimators are exact.
        let next: Vec<State> = states
            .iter()
            .map(|x| State::new(x[0] + 0.15, 15.0, 0.0))
            .collect();
        tx.clear();
        c.transmit(1, &next, &mut tx);
        assert_eq!(tx.len(), 1, "only the leader broadcasts: {tx:?}");
    }
}

#[test]
fn control_law_sign_and_spacing_convention() {
    // Follower 1 of a PF platoon 2 m too close to the leader must brake: q_p = +2, u < 0.
    let topo = Topology::preset(Preset::Pf, 1).unwrap();
    let states = vec![State::new(0.0, 15.0, 0.0), State::new(-8.0, 15.0, 0.0)];
    let mut c = paper(params(TriggerRule::Static), &topo, &states).unwrap();
    let mut tx = Vec::new();
    c.transmit(0, &states, &mut tx);
    let u = c.receive(0, &states, &everyone(&topo, &tx), &[false; 2]);
    assert!((u[0] - (-4.81 * 2.0)).abs() < 1e-12, "u = {}", u[0]);
}

#[test]
fn time_headway_regulates_each_gap_to_l_plus_h_v_of_its_rear_vehicle() {
    // At 20 m/s with h_t = 0.5 s the desired gap is 10 + 10 = 20 m. A BPF platoon (links
    // both ways) at those gaps is at rest for the law; the same platoon at 10 m gaps is
    // 10 m too close.
    let topo = Topology::preset(Preset::Bpf, 3).unwrap();
    let mut p = params(TriggerRule::Static);
    p.headway = 0.5;
    let v = [20.0, 20.0, 20.0, 20.0];
    let gap = |v: f64| 10.0 + 0.5 * v;
    let mut at_rest = vec![State::new(0.0, v[0], 0.0)];
    for (i, &vi) in v.iter().enumerate().skip(1) {
        at_rest.push(State::new(at_rest[i - 1][0] - gap(vi), vi, 0.0));
    }
    let run = |states: &[State], p: &ControllerParams| {
        let mut c = paper(p.clone(), &topo, states).unwrap();
        let mut tx = Vec::new();
        c.transmit(0, states, &mut tx);
        c.receive(0, states, &everyone(&topo, &tx), &[false; 4])
            .to_vec()
    };
    for u in run(&at_rest, &p) {
        assert!(u.abs() < 1e-12, "u = {u}");
    }
    // Constant spacing sees every gap 10 m too long: the last follower (no one behind it)
    // accelerates.
    let mut constant = p.clone();
    constant.headway = 0.0;
    assert!((run(&at_rest, &constant)[2] - 4.81 * 10.0).abs() < 1e-9);
    let close = formation(3, 20.0);
    let u = run(&close, &p);
    // Follower 3 (one gap ahead, none behind): q_p = +10, u = -K_p 10.
    assert!((u[2] - (-4.81 * 10.0)).abs() < 1e-9, "u = {u:?}");
    // Bad headways are refused by name.
    p.headway = -1.0;
    let e = paper(p, &topo, &close).unwrap_err();
    assert_eq!(e.field, "headway");
}

#[test]
fn static_rule_fires_when_estimation_error_outweighs_tracking_error() {
    let topo = Topology::preset(Preset::Pf, 1).unwrap();
    let mut states = formation(1, 15.0);
    let mut c = paper(params(TriggerRule::Static), &topo, &states).unwrap();
    let mut tx = Vec::new();
    c.transmit(0, &states, &mut tx);
    c.receive(0, &states, &everyone(&topo, &tx), &[false; 2]);
    // The follower's true state leaves its estimate by 0.1 m while q stays ~0:
    // beta1 * 0.01 > beta2 * |q|^2 -> fires.
    states[0][0] += 0.15;
    states[1][0] += 0.15 + 0.1;
    tx.clear();
    c.transmit(1, &states, &mut tx);
    assert!(tx.iter().any(|p| p.sender == VehicleId(1)));
    assert!(c.follower_step(VehicleId(1)).triggered);
}

#[test]
fn dynamic_rule_waits_for_theta_to_be_outweighed() {
    let topo = Topology::preset(Preset::Pf, 1).unwrap();
    let dynamic = TriggerRule::Dynamic {
        phi: 0.33,
        rho: 0.5,
        eta: 0.5,
        theta0: 200.0,
    };
    let mut states = formation(1, 15.0);
    let mut c = paper(params(dynamic), &topo, &states).unwrap();
    let mut tx = Vec::new();
    c.transmit(0, &states, &mut tx);
    c.receive(0, &states, &everyone(&topo, &tx), &[false; 2]);
    // Same 0.1 m estimation error: beta1 * 0.01 = 3.19 < phi * theta ~ 66: no event.
    states[0][0] += 0.15;
    states[1][0] += 0.25;
    tx.clear();
    c.transmit(1, &states, &mut tx);
    assert!(!c.follower_step(VehicleId(1)).triggered);
    // A 0.5 m error (79.8 > 66) fires.
    states[1][0] += 0.4;
    tx.clear();
    c.transmit(1, &states, &mut tx);
    assert!(c.follower_step(VehicleId(1)).triggered);
}

#[test]
fn resilient_sampling_during_attack_and_recovery() {
    let topo = Topology::preset(Preset::Pf, 1).unwrap();
    let mut states = formation(1, 15.0);
    let mut c = paper(params(TriggerRule::Static), &topo, &states).unwrap();
    let mut tx = Vec::new();
    // Step 0 is a broadcast under attack: the follower goes to resilient sampling every 2 steps.
    c.transmit(0, &states, &mut tx);
    let u = c.receive(0, &states, &[], &[true, true])[0];
    assert_eq!(u, 0.0);
    assert!(c.follower_step(VehicleId(1)).affected);
    let mut fired = Vec::new();
    for k in 1..=6 {
        for x in &mut states {
            x[0] += 0.15; // cruise at 15 m/s: the estimators stay exact
        }
        tx.clear();
        c.transmit(k, &states, &mut tx);
        let jam = k < 4; // the attack ends at step 4
        c.receive(k, &states, &[], &[jam, jam]);
        let s = c.follower_step(VehicleId(1));
        fired.push(s.triggered);
        assert_eq!(s.affected, k < 4, "step {k}");
    }
    // Samples at 2 (jammed) and 4 (gets through), then the event rule again.
    assert_eq!(fired, vec![false, true, false, true, false, false]);
}

#[test]
fn hostile_packets_are_rejected_and_counted() {
    let topo = Topology::preset(Preset::Pf, 2).unwrap();
    let states = formation(2, 15.0);
    let mut c = paper(params(TriggerRule::Static), &topo, &states).unwrap();
    let mut tx = Vec::new();
    c.transmit(0, &states, &mut tx);
    c.receive(0, &states, &everyone(&topo, &tx), &[false; 3]);
    let to = |receiver, sender, seq, step, p: f64| Delivery {
        receiver: VehicleId(receiver),
        packet: Packet::beacon(VehicleId(sender), seq, step, State::new(p, 15.0, 0.0)),
    };
    let bad = [
        to(2, 1, 5, 1, f64::NAN),
        to(2, 0, 5, 1, 0.0), // 2 does not hear the leader
        to(9, 1, 5, 1, 0.0),
        to(2, 1, 5, 7, 0.0),
        to(2, 1, 1, 0, -10.0), // replays the packet of step 0
    ];
    tx.clear();
    c.transmit(1, &states, &mut tx);
    c.receive(1, &states, &bad, &[false; 3]);
    let r = c.rejected();
    assert_eq!(
        (r.non_finite, r.unknown_sender, r.future_step, r.stale_seq),
        (1, 2, 1, 1)
    );
    assert_eq!(r.total(), 5);
}

/// One forged packet with a near-maximum sequence number is refused (it would
/// lock its sender out for the rest of the run), and a forged packet that passes every
/// check holds off genuine ones of its own step only.
#[test]
fn a_forged_packet_never_locks_a_sender_out() {
    let topo = Topology::preset(Preset::Pf, 2).unwrap();
    let mut states = formation(2, 15.0);
    let periodic = TriggerRule::Periodic { period_steps: 2 };
    let mut c = paper(params(periodic), &topo, &states).unwrap();
    let flow = FreeFlow::new(0.5, 0.01);
    let to_2 = |packet| Delivery {
        receiver: VehicleId(2),
        packet,
    };
    let mut genuine_accepted = 0;
    for k in 0..40u64 {
        let mut tx = Vec::new();
        c.transmit(k, &states, &mut tx);
        let mut rx = everyone(&topo, &tx);
        if k == 5 {
            let mut forged = *tx
                .iter()
                .find(|p| p.sender == VehicleId(1))
                .unwrap_or(&Packet::beacon(VehicleId(1), 1, k, states[1]));
            forged.seq = u32::MAX - 1;
            forged.step = k;
            forged.state = states[1];
            rx.insert(0, to_2(forged));
        }
        if k == 10 {
            // Plausible in every way (the sender's true state, the next sequence number):
            // accepted, and it can only shadow step 10.
            rx.insert(0, to_2(Packet::beacon(VehicleId(1), 11, k, states[1])));
        }
        if k == 20 {
            let mut teleported = states[1];
            teleported[0] += 30.0;
            rx.insert(0, to_2(Packet::beacon(VehicleId(1), 21, k, teleported)));
        }
        let before = c.rejected();
        c.receive(k, &states, &rx, &[false; 3]);
        let after = c.rejected();
        let genuine_from_1 = tx.iter().filter(|p| p.sender == VehicleId(1)).count() as u64;
        let refused = after.total() - before.total();
        if k > 10 && k != 20 {
            assert_eq!(refused, 0, "step {k}: genuine packets refused");
            genuine_accepted += genuine_from_1;
        }
        for x in states.iter_mut() {
            *x = flow.advance(x);
        }
    }
    let r = c.rejected();
    assert_eq!(r.implausible_seq, 1, "{r:?}");
    assert_eq!(r.implausible_state, 1, "{r:?}");
    assert!(genuine_accepted > 0, "follower 1 kept being heard");
}

#[test]
fn delayed_packet_is_propagated_to_now() {
    let topo = Topology::preset(Preset::Pf, 1).unwrap();
    let states = formation(1, 15.0);
    let mut a = paper(params(TriggerRule::Static), &topo, &states).unwrap();
    let mut b = a.clone();
    let leader = Packet::beacon(VehicleId(0), 9, 3, State::new(1.0, 16.0, 1.0));
    let flow = FreeFlow::new(0.5, 0.01);
    let now = Packet {
        step: 5,
        state: flow.advance(&flow.advance(&leader.state)),
        ..leader
    };
    let ua = a.receive(
        5,
        &states,
        &[Delivery {
            receiver: VehicleId(1),
            packet: leader,
        }],
        &[false; 2],
    )[0];
    let ub = b.receive(
        5,
        &states,
        &[Delivery {
            receiver: VehicleId(1),
            packet: now,
        }],
        &[false; 2],
    )[0];
    assert_eq!(ua, ub);
}
