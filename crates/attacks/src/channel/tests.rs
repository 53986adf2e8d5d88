//! The channel's unit tests: each attack model, the radio, DCC and jammers.
use super::*;
use platoon_topology::Preset;

fn pf(n: usize) -> Topology {
    Topology::preset(Preset::Pf, n).unwrap()
}

fn packet(sender: u16, seq: u32, step: u64) -> Packet {
    Packet::beacon(
        VehicleId(sender),
        seq,
        step,
        State::new(f64::from(sender), 1.0, 0.0),
    )
}

struct Out {
    deliveries: Vec<Delivery>,
    jammed: Vec<bool>,
    log: Vec<ChannelEvent>,
}

fn gate(c: &mut Channel, k: u64, tx: &[Packet], states: &[State]) -> Out {
    let mut o = Out {
        deliveries: Vec::new(),
        jammed: vec![false; states.len()],
        log: Vec::new(),
    };
    let topology = pf(states.len() - 1);
    c.gate(
        &ChannelStep {
            k,
            t: k as f64 * 0.01,
            topology: &topology,
            states,
            tx,
        },
        &mut o.deliveries,
        &mut o.jammed,
        &mut o.log,
    );
    o
}

fn states(n: usize) -> Vec<State> {
    (0..=n)
        .map(|i| State::new(-10.0 * i as f64, 15.0, 0.0))
        .collect()
}

fn channel(attacks: Vec<LinkAttack>) -> Channel {
    Channel::new(
        ChannelSpec {
            dos: DosSchedule::none(),
            attacks,
            seed: 1,
            platoon: 0,
            radio: None,
            jammers: Vec::new(),
            keys: None,
        },
        4,
    )
}

fn radio(params: platoon_radio::Params80211p, load: LoadSource, dcc: Option<Dcc>) -> RadioSpec {
    RadioSpec {
        family: std::sync::Arc::new(platoon_radio::LoadFamily::new(params).unwrap()),
        load,
        background_beacons: BackgroundBeacons::Fixed,
        dcc,
        window_steps: 100,
        dt: 0.01,
    }
}

/// The ETSI reactive table the config defaults to.
fn etsi() -> Dcc {
    Dcc {
        cbr_thresholds: vec![0.3, 0.4, 0.5, 0.65],
        t_off_s: vec![0.06, 0.1, 0.18, 0.26, 1.0],
    }
}

#[test]
fn the_load_counts_the_platoons_measured_beacons_the_fleet_and_the_background() {
    let quiet = platoon_radio::Params80211p {
        density_veh_per_m: 0.0,
        ..Default::default()
    };
    let states = vec![
        State::new(100.0, 15.0, 0.0),
        State::new(80.0, 15.0, 0.0),
        State::new(60.0, 15.0, 0.0),
    ];
    let mut c = Channel::new(
        ChannelSpec {
            radio: Some(radio(quiet, LoadSource::Scenario, None)),
            ..channel(vec![]).spec().clone()
        },
        3,
    );
    assert!(c.counts_fleet());
    // The leader beacons every 5 steps (20 Hz), follower 1 every 10 (10 Hz); follower 2's
    // broadcasts have no listener in the predecessor-following graph, so they are not sent.
    for k in 0..200 {
        let tx: Vec<Packet> = [(0u16, 5), (1, 10), (2, 1)]
            .iter()
            .filter(|(_, every)| k % every == 0)
            .map(|&(v, _)| packet(v, k as u32, k))
            .collect();
        gate(&mut c, k, &tx, &states);
    }
    assert_eq!(c.beacon_rate(VehicleId(0), 200), 20.0);
    assert_eq!(c.beacon_rate(VehicleId(1), 200), 10.0);
    assert_eq!(c.beacon_rate(VehicleId(2), 200), 0.0);
    // 30 packets a second within 1000 m: 30 / 2000 m.
    let own = c.medium.as_ref().unwrap().load(1);
    assert!((own - 30.0 / 2000.0).abs() < 1e-12, "{own}");
    let cbr_alone = c.cbr()[1];
    // A fleet vehicle 500 m away at 10 Hz, one 5 km away (out of range), and two SUMO
    // background vehicles at the configured 10 Hz.
    c.set_fleet(&[(100.0, 7.0), (600.0, 10.0), (5100.0, 10.0)], 0..1);
    c.set_background(&[50.0, f64::NAN, 900.0]);
    gate(&mut c, 200, &[], &states);
    let load = c.medium.as_ref().unwrap().load(1);
    assert!(
        (load - (30.0 + 10.0 + 20.0) / 2000.0).abs() < 1e-12,
        "{load}"
    );
    assert!(c.cbr()[1] > cbr_alone);
    let stats = c.radio_stats().unwrap();
    assert_eq!(stats.transmissions, 40 + 20);
    assert_eq!(stats.samples, 3 * 201);
    // The fixed load is the configured traffic alone, whatever the vehicles send.
    let mut fixed = Channel::new(
        ChannelSpec {
            radio: Some(radio(
                platoon_radio::Params80211p::default(),
                LoadSource::Fixed,
                None,
            )),
            ..channel(vec![]).spec().clone()
        },
        3,
    );
    gate(&mut fixed, 0, &[packet(0, 0, 0)], &states);
    assert_eq!(fixed.medium.as_ref().unwrap().load(1), 0.6);
    assert!(!fixed.counts_fleet());
}

#[test]
fn dcc_spaces_a_vehicles_transmissions_by_t_off_and_sends_the_newest_late() {
    let mut c = Channel::new(
        ChannelSpec {
            radio: Some(radio(
                platoon_radio::Params80211p {
                    density_veh_per_m: 0.0,
                    ..Default::default()
                },
                LoadSource::Fixed,
                Some(etsi()),
            )),
            ..channel(vec![]).spec().clone()
        },
        2,
    );
    // The leader wants to send at every step; relaxed DCC lets it out every 6 (60 ms).
    let states = vec![State::new(10.0, 15.0, 0.0), State::new(0.0, 15.0, 0.0)];
    let mut delivered = Vec::new();
    let mut actions = Vec::new();
    for k in 0..13 {
        let o = gate(&mut c, k, &[packet(0, k as u32, k)], &states);
        delivered.extend(o.deliveries.iter().map(|d| (k, d.packet.seq)));
        actions.extend(o.log.iter().map(|e| (e.step, e.seq, e.action)));
    }
    // Sent at 0, 6, 12; at 6 and 12 the packet of that very step (the held one of step 5
    // is replaced at step 6 before it could go).
    let sent: Vec<u64> = delivered.iter().map(|d| d.0).collect();
    assert_eq!(sent, vec![0, 6, 12], "{delivered:?}");
    assert!(delivered.iter().all(|(k, seq)| u64::from(*seq) == *k));
    assert!(actions.contains(&(1, 1, Action::DccDeferred)));
    assert!(actions.contains(&(2, 1, Action::DroppedDcc)));
    let stats = c.radio_stats().unwrap();
    assert_eq!((stats.transmissions, stats.dcc_deferred), (3, 10));
    assert_eq!(stats.dcc_dropped, 10);
    // A packet held back and not replaced goes out late, when T_off has passed.
    let mut c = Channel::new(c.spec().clone(), 2);
    let mut late = Vec::new();
    for k in 0..8 {
        let tx: Vec<Packet> = [0u64, 2]
            .iter()
            .filter(|&&s| s == k)
            .map(|&s| packet(0, s as u32, s))
            .collect();
        let o = gate(&mut c, k, &tx, &states);
        late.extend(o.deliveries.iter().map(|d| (k, d.packet.step)));
        if k == 6 {
            assert!(o.log.iter().any(|e| e.action == Action::DeliveredLate));
        }
    }
    assert_eq!(late, vec![(0, 0), (6, 2)]);
    assert_eq!(etsi().state(0.29), 0);
    assert_eq!(etsi().state(0.3), 1);
    assert_eq!(etsi().state(0.9), 4);
}

#[test]
fn the_80211p_radio_delivers_each_link_with_the_models_ratio_at_its_distance() {
    let model = platoon_radio::Model::new(platoon_radio::Params80211p {
        density_veh_per_m: 0.12,
        beacon_hz: 25.0,
        ..Default::default()
    })
    .unwrap();
    // Follower 1 is 50 m behind the leader, follower 2 400 m behind follower 1.
    let states = vec![
        State::new(450.0, 15.0, 0.0),
        State::new(400.0, 15.0, 0.0),
        State::new(0.0, 15.0, 0.0),
    ];
    let (near, far) = (model.pdr(50.0), model.pdr(400.0));
    assert!(near > 0.5 && far < near, "{near} {far}");
    let mut c = Channel::new(
        ChannelSpec {
            radio: Some(radio(*model.params(), LoadSource::Fixed, None)),
            ..channel(vec![]).spec().clone()
        },
        3,
    );
    let (mut got_near, mut got_far) = (0, 0);
    let steps = 4000;
    for k in 0..steps {
        let o = gate(&mut c, k, &[packet(0, 1, k), packet(1, 1, k)], &states);
        got_near += o.deliveries.iter().filter(|d| d.receiver.0 == 1).count();
        got_far += o.deliveries.iter().filter(|d| d.receiver.0 == 2).count();
        assert!(o.log.iter().all(|e| e.action == Action::DroppedRadio));
        assert_eq!(o.deliveries.len() + o.log.len(), 2);
    }
    // Within 4 standard deviations of the binomial.
    for (got, p) in [(got_near, near), (got_far, far)] {
        let n = steps as f64;
        let sd = (n * p * (1.0 - p)).sqrt().max(1.0);
        assert!(
            (got as f64 - n * p).abs() < 4.0 * sd,
            "{got} of {n} at p = {p}"
        );
    }
}

#[test]
fn without_attacks_every_packet_reaches_every_out_neighbour() {
    let mut c = channel(vec![]);
    let o = gate(&mut c, 0, &[packet(0, 1, 0), packet(1, 1, 0)], &states(3));
    let got: Vec<(u16, u16)> = o
        .deliveries
        .iter()
        .map(|d| (d.packet.sender.0, d.receiver.0))
        .collect();
    assert_eq!(got, vec![(0, 1), (1, 2)]);
    assert!(o.log.is_empty() && o.jammed.iter().all(|j| !j));
}

#[test]
fn dos_drops_everything_and_every_vehicle_senses_it() {
    let mut c = Channel::new(
        ChannelSpec {
            dos: DosSchedule::from_intervals(&[(0.0, 1.0)]).unwrap(),
            ..ChannelSpec::default()
        },
        4,
    );
    let o = gate(&mut c, 5, &[packet(0, 1, 5)], &states(3));
    assert!(o.deliveries.is_empty());
    assert!(o.jammed.iter().all(|j| *j));
    assert_eq!(o.log[0].action, Action::DroppedDos);
}

#[test]
fn bernoulli_loss_is_seeded_and_has_its_rate() {
    let run = || {
        let mut c = channel(vec![LinkAttack::everywhere(LinkAttackKind::Bernoulli {
            loss: 0.3,
        })]);
        (0..2000)
            .map(|k| {
                gate(&mut c, k, &[packet(1, k as u32 + 1, k)], &states(3))
                    .deliveries
                    .len()
            })
            .collect::<Vec<_>>()
    };
    let a = run();
    assert_eq!(a, run(), "the same seed gives the same losses");
    let rate = 1.0 - a.iter().sum::<usize>() as f64 / 2000.0;
    assert!((rate - 0.3).abs() < 0.04, "loss rate {rate}");
}

#[test]
fn gilbert_elliott_loses_in_bursts() {
    let mut c = channel(vec![LinkAttack::everywhere(
        LinkAttackKind::GilbertElliott {
            p_good_bad: 0.05,
            p_bad_good: 0.2,
            loss_good: 0.0,
            loss_bad: 1.0,
        },
    )]);
    let lost: Vec<bool> = (0..5000)
        .map(|k| {
            gate(&mut c, k, &[packet(1, k as u32 + 1, k)], &states(3))
                .deliveries
                .is_empty()
        })
        .collect();
    let losses = lost.iter().filter(|l| **l).count();
    let bursts = lost.windows(2).filter(|w| !w[0] && w[1]).count();
    // Stationary bad share 0.05 / 0.25 = 0.2, mean burst 1 / 0.2 = 5 packets.
    let share = losses as f64 / 5000.0;
    assert!((share - 0.2).abs() < 0.05, "loss share {share}");
    assert!(losses as f64 / bursts as f64 > 3.0, "losses come in bursts");
}

#[test]
fn delayed_packets_arrive_exactly_late() {
    let mut c = channel(vec![LinkAttack::everywhere(LinkAttackKind::Delay {
        steps: 3,
    })]);
    assert!(gate(&mut c, 0, &[packet(1, 1, 0)], &states(3))
        .deliveries
        .is_empty());
    assert!(gate(&mut c, 2, &[], &states(3)).deliveries.is_empty());
    let o = gate(&mut c, 3, &[], &states(3));
    assert_eq!(o.deliveries.len(), 1);
    assert_eq!(o.deliveries[0].packet.step, 0);
    assert_eq!(o.log[0].action, Action::DeliveredLate);
}

#[test]
fn replay_sends_the_old_packet_with_its_old_sequence_number() {
    let mut a = LinkAttack::everywhere(LinkAttackKind::Replay { lag_steps: 10 });
    a.start_s = 0.15;
    let mut c = channel(vec![a]);
    gate(&mut c, 0, &[packet(1, 1, 0)], &states(3));
    gate(&mut c, 5, &[packet(1, 2, 5)], &states(3));
    let o = gate(&mut c, 16, &[packet(1, 3, 16)], &states(3));
    assert_eq!(
        o.deliveries[0].packet.seq, 2,
        "the packet of step 5 <= 16 - 10"
    );
    assert_eq!(o.log[0].action, Action::Replayed);
    assert_eq!(o.log[0].detail, Some(5));
}

#[test]
fn false_data_offsets_only_the_targeted_sender() {
    let mut a = LinkAttack::everywhere(LinkAttackKind::FalseData {
        offset: [2.0, 0.0, 0.0],
    });
    a.senders = vec![VehicleId(1)];
    let mut c = channel(vec![a]);
    let o = gate(&mut c, 0, &[packet(0, 1, 0), packet(1, 1, 0)], &states(3));
    assert_eq!(o.deliveries[0].packet.state[0], 0.0);
    assert_eq!(o.deliveries[1].packet.state[0], 3.0);
}

/// Follower 1's packet to followers 2 and 3 (a two-predecessor graph) under `attacks`, at
/// steps `0..steps`: what each receiver got, per step.
fn two_receivers(attacks: Vec<LinkAttack>, steps: u64) -> (Vec<[State; 2]>, Vec<ChannelEvent>) {
    let topology = Topology::preset(platoon_topology::Preset::Tpsf, 3).unwrap();
    let mut c = channel(attacks);
    let (mut got, mut log) = (Vec::new(), Vec::new());
    for k in 0..steps {
        let mut out = Vec::new();
        c.gate(
            &ChannelStep {
                k,
                t: k as f64 * 0.01,
                topology: &topology,
                states: &states(3),
                tx: &[packet(1, k as u32 + 1, k)],
            },
            &mut out,
            &mut [false; 4],
            &mut log,
        );
        assert_eq!(out.len(), 2);
        got.push([out[0].packet.state, out[1].packet.state]);
    }
    (got, log)
}

#[test]
fn a_random_offset_is_seeded_zero_mean_per_link_and_one_lie_per_packet_for_an_insider() {
    let noisy = |insider| {
        vec![LinkAttack {
            acts_as: if insider {
                ActsAs::Insider
            } else {
                ActsAs::Outsider
            },
            ..LinkAttack::everywhere(LinkAttackKind::RandomOffset {
                std: [0.5, 0.1, 0.0],
            })
        }]
    };
    let (outsider, log) = two_receivers(noisy(false), 4000);
    assert_eq!(outsider, two_receivers(noisy(false), 4000).0, "seeded");
    assert_eq!(log.len(), 8000);
    assert!(log.iter().all(|e| e.action == Action::Altered));
    let sent = packet(1, 1, 0).state;
    let errors: Vec<State> = outsider.iter().flatten().map(|x| x - sent).collect();
    let n = errors.len() as f64;
    for (i, sd) in [0.5, 0.1].into_iter().enumerate() {
        let mean = errors.iter().map(|e| e[i]).sum::<f64>() / n;
        let var = errors.iter().map(|e| (e[i] - mean).powi(2)).sum::<f64>() / n;
        assert!(mean.abs() < 4.0 * sd / n.sqrt(), "mean {mean}");
        assert!((var.sqrt() / sd - 1.0).abs() < 0.05, "sd {}", var.sqrt());
    }
    assert!(errors.iter().all(|e| e[2] == 0.0));
    // An outsider's receivers get different noise; an insider's the same lie.
    assert!(outsider.iter().all(|[a, b]| a != b));
    let (insider, log) = two_receivers(noisy(true), 100);
    assert!(insider.iter().all(|[a, b]| a == b && *a != sent));
    assert_eq!(log.len(), 200);
    assert!(log.iter().all(|e| e.action == Action::Altered));
}

#[test]
fn a_drift_grows_from_the_attacks_start() {
    let mut a = LinkAttack::everywhere(LinkAttackKind::Drift {
        rate: [0.1, 0.0, 0.0],
    });
    a.start_s = 0.5;
    let (got, log) = two_receivers(vec![a], 151);
    let sent = packet(1, 1, 0).state;
    assert_eq!(got[49][0], sent, "inactive before its start");
    assert_eq!(got[50][0], sent, "no offset yet at its start");
    assert!((got[150][0][0] - sent[0] - 0.1).abs() < 1e-12);
    assert_eq!(got[150][0].as_slice()[1..], sent.as_slice()[1..]);
    assert_eq!(log.len(), 2 * 101);
}

#[test]
fn feigned_braking_and_a_scaled_acceleration_change_only_the_acceleration() {
    let mut sent = packet(1, 1, 0).state;
    sent[2] = 0.5;
    for (kind, a) in [
        (LinkAttackKind::FeignedBraking { accel: -6.0 }, -6.0),
        (LinkAttackKind::AccelScale { factor: 3.0 }, 1.5),
    ] {
        let mut c = channel(vec![LinkAttack::everywhere(kind)]);
        let mut tx = packet(1, 1, 0);
        tx.state = sent;
        let o = gate(&mut c, 0, &[tx], &states(3));
        let got = o.deliveries[0].packet.state;
        assert_eq!((got[0], got[1], got[2]), (sent[0], sent[1], a));
        assert_eq!(o.log[0].action, Action::Altered);
    }
}

#[test]
fn the_new_kinds_draw_nothing_from_the_stream_of_the_old_ones() {
    let loss = || LinkAttack::everywhere(LinkAttackKind::Bernoulli { loss: 0.5 });
    let mut later = LinkAttack::everywhere(LinkAttackKind::RandomOffset { std: [1.0; 3] });
    later.start_s = 100.0;
    let drift = LinkAttack::everywhere(LinkAttackKind::Drift { rate: [1.0; 3] });
    let received = |attacks: Vec<LinkAttack>| {
        let mut c = channel(attacks);
        (0..500)
            .map(|k| {
                gate(&mut c, k, &[packet(1, 1, k)], &states(3))
                    .deliveries
                    .len()
            })
            .collect::<Vec<_>>()
    };
    let alone = received(vec![loss()]);
    assert_eq!(alone, received(vec![loss(), later]));
    assert_eq!(alone, received(vec![drift, loss()]));
}

#[test]
fn a_range_jammer_silences_the_vehicles_within_its_radius() {
    let mut c = channel(vec![LinkAttack::everywhere(LinkAttackKind::RangeJamming {
        position_m: -10.0,
        speed_mps: 0.0,
        radius_m: 5.0,
    })]);
    // Vehicle 1 sits at -10 m: it neither sends nor receives; 2 -> 3 still works.
    let tx = [packet(0, 1, 0), packet(1, 1, 0), packet(2, 1, 0)];
    let o = gate(&mut c, 0, &tx, &states(3));
    assert_eq!(o.jammed, vec![false, true, false, false]);
    let got: Vec<(u16, u16)> = o
        .deliveries
        .iter()
        .map(|d| (d.packet.sender.0, d.receiver.0))
        .collect();
    assert_eq!(got, vec![(2, 3)]);
    assert_eq!(o.log.len(), 2);
}

/// In a signed run an insider signs its lie with its own key, a thief with the member's it
/// stole (in the form and at the time of the seal it replaces), and an outsider's alteration
/// keeps the seal it breaks; an unsealed packet stays unsealed.
#[test]
fn insiders_and_thieves_sign_what_they_alter_and_outsiders_cannot() {
    use platoon_security::{AttachRule, KeySlot, Keyring, SecurityHeader, Signer};
    let keys = ChannelKeys {
        seed: 5,
        platoon: 0,
    };
    let mut ring = Keyring::new(keys.seed, keys.platoon, 4);
    let slot = |vehicle| KeySlot { epoch: 0, vehicle };
    let mut signer = Signer::new(
        ring.pseudonym(slot(1)).unwrap().clone(),
        AttachRule::STANDARD,
    );
    let mut sealed = packet(1, 1, 0);
    let header = signer.sign(&sealed.signed_bytes(), 0);
    sealed.seal = platoon_v2v::Seal::new(&header.to_bytes());
    let braking = LinkAttackKind::FeignedBraking { accel: -6.0 };
    for (acts_as, signed_by) in [
        (ActsAs::Outsider, None),
        (ActsAs::Insider, Some(slot(1))),
        (
            ActsAs::Thief {
                key_of: VehicleId(3),
            },
            Some(slot(3)),
        ),
    ] {
        let attack = LinkAttack {
            acts_as,
            ..LinkAttack::everywhere(braking.clone())
        };
        let mut c = Channel::new(
            ChannelSpec {
                keys: Some(keys),
                ..channel(vec![attack]).spec().clone()
            },
            4,
        );
        let out = gate(&mut c, 0, &[sealed], &states(3));
        let got = out.deliveries[0].packet;
        assert_eq!(got.state[2], -6.0, "{acts_as:?}");
        let h = SecurityHeader::decode(got.seal.unwrap().as_bytes()).unwrap();
        assert_eq!(
            ring.signed_by(&got.signed_bytes(), &h, 1),
            signed_by,
            "{acts_as:?}"
        );
        // The time and form of the seal it replaces (here the first packet's certificate).
        assert_eq!(h.generated_ms, header.generated_ms);
        let certificate_of = |v| *ring.pseudonym(slot(v)).unwrap().certificate();
        let form = platoon_security::SignerId::Certificate(certificate_of(match acts_as {
            ActsAs::Thief { key_of } => key_of.index(),
            _ => 1,
        }));
        assert_eq!(h.signer, form, "{acts_as:?}");
        // Unsealed (an unsigned run's packet): nothing to sign.
        let out = gate(&mut c, 1, &[packet(1, 2, 1)], &states(3));
        assert!(out.deliveries[0].packet.seal.is_none());
    }
}
