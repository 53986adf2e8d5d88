//! The composed controller's tests: beaconing, fallbacks, the room offsets, maneuvers.
use super::*;
use crate::fallback::RadarTruth;
use crate::{FallbackMode, FallbackParams, Mode};
use platoon_topology::Preset;

/// A law that echoes the predecessor's speed in its last packet, so a test sees which
/// packet a follower used.
#[derive(Debug, Clone)]
struct Echo;

impl Law for Echo {
    fn command(&mut self, view: &View<'_>) -> f64 {
        view.predecessor().map_or(f64::NAN, |h| h.state[1])
    }
}

/// The parts of the tests' platoons: a step of 0.01 s, a beacon every `beacon_steps`
/// steps, the leader's every step, 10 m constant spacing, `fallback`, default detection
/// and no maneuvers.
fn parts(beacon_steps: u32, fallback: FallbackParams) -> Composition {
    Composition {
        dt: 0.01,
        beaconing: Box::new(Periodic {
            steps: beacon_steps,
        }),
        leader_broadcast_steps: 1,
        spacing: 10.0,
        headway: 0.0,
        fallback,
        detection: Default::default(),
        maneuvers: None,
        security: None,
    }
}

fn controller(beacon_steps: u32, fallback: FallbackParams) -> ComposedController {
    let topology = Topology::preset(Preset::Pf, 3).unwrap();
    let initial: Vec<State> = (0..=3)
        .map(|i| State::new(-10.0 * i as f64, 15.0, 0.0))
        .collect();
    let parts = parts(beacon_steps, fallback);
    ComposedController::new(Box::new(Echo), parts, &topology, &initial).unwrap()
}

/// The platoon at step `k`, 10 m apart, accelerating at 1 m/s^2 from 15 m/s: every packet
/// is plausible.
fn accelerating(k: u64) -> Vec<State> {
    let t = k as f64 * 0.01;
    (0..=3)
        .map(|i| State::new(-10.0 * i as f64 + 15.0 * t + 0.5 * t * t, 15.0 + t, 1.0))
        .collect()
}

fn deliver_all(packets: &[Packet]) -> Vec<Delivery> {
    packets
        .iter()
        .map(|&packet| Delivery {
            receiver: VehicleId(packet.sender.0 + 1),
            packet,
        })
        .collect()
}

#[test]
fn followers_beacon_every_period_and_laws_use_the_last_packet() {
    let mut c = controller(10, FallbackParams::default());
    let mut out = Vec::new();
    for k in 0..25u64 {
        // Accelerating at 1 m/s^2: every packet is plausible.
        let states = accelerating(k);
        out.clear();
        c.transmit(k, &states, &mut out);
        let followers = out.iter().filter(|p| !p.sender.is_leader()).count();
        assert_eq!(followers, if k % 10 == 0 { 3 } else { 0 }, "step {k}");
        let u = c
            .receive(k, &states, &deliver_all(&out), &[false; 4])
            .to_vec();
        // Follower 1 hears the leader every step, the others their predecessor's beacon.
        assert_eq!(u[0], states[0][1]);
        assert_eq!(u[2], 15.0 + (k - k % 10) as f64 * 0.01);
    }
}

#[test]
fn a_jammed_follower_falls_back_and_blends_back() {
    let fallback = FallbackParams {
        mode: FallbackMode::Zero,
        dwell_steps: 2,
        blend_steps: 4,
        ..FallbackParams::default()
    };
    let mut c = controller(1, fallback);
    let states: Vec<State> = (0..=3)
        .map(|i| State::new(-10.0 * i as f64, 15.0, 0.0))
        .collect();
    let mut out = Vec::new();
    let mut seen = Vec::new();
    for k in 0..12u64 {
        out.clear();
        c.transmit(k, &states, &mut out);
        let jammed = [false, (3..5).contains(&k), false, false];
        let u = c.receive(k, &states, &deliver_all(&out), &jammed)[0];
        seen.push((c.follower_step(VehicleId(1)).mode, u));
    }
    let modes: Vec<Mode> = seen.iter().map(|s| s.0).collect();
    use Mode::*;
    assert_eq!(
        modes,
        [Coop, Coop, Coop, Zero, Zero, Zero, Zero, Blend, Blend, Blend, Blend, Coop]
    );
    // From 0 back to the law's 15 in equal steps.
    assert_eq!(seen[7].1, 0.0);
    assert_eq!(seen[9].1, 7.5);
    assert_eq!(seen[11].1, 15.0);
}

/// A law that echoes its leader's speed in its last packet.
#[derive(Debug, Clone)]
struct EchoLeader;

impl Law for EchoLeader {
    fn command(&mut self, view: &View<'_>) -> f64 {
        view.leader().map_or(f64::NAN, |h| h.state[1])
    }
}

/// Follower 1 runs ACC on a car that cut in ahead of it on steps 5 to 14 (but for two steps
/// of an attack's fallback), then blends back to its law on steps 15 to 18, and, with a
/// split, heads followers 2 and 3 meanwhile (until it is back on its law): they hear it
/// (though `plf` gives them only their predecessor and the leader), take its packets as their
/// leader's from the step after it announced itself, blend to the new reference from their
/// last command, and take the leader again once it no longer announces itself. Each vehicle drives at its own speed,
/// 15 + i m/s, so the echoed speed names whom a follower took as its leader.
#[test]
fn a_follower_on_a_cut_in_heads_the_followers_behind_it() {
    let topology = Topology::preset(Preset::Plf, 3).unwrap();
    let hearing = topology.hearing_all_ahead();
    let states = |k: u64| -> Vec<State> {
        let t = k as f64 * 0.01;
        (0..=3)
            .map(|i| {
                let v = 15.0 + i as f64;
                State::new(-10.0 * i as f64 + v * t, v, 0.0)
            })
            .collect()
    };
    let fallback = FallbackParams {
        mode: FallbackMode::Zero,
        radar: crate::radar::RadarParams {
            range_m: 1000.0,
            period_steps: 1,
            noise_m: 0.0,
            noise_mps: 0.0,
            dropout: 0.0,
            seed: 1,
        },
        cut_in: Some(crate::fallback::CutInParams {
            dwell_steps: 0,
            blend_steps: 4,
            split: true,
        }),
        ..FallbackParams::default()
    };
    let mut c = ComposedController::new(
        Box::new(EchoLeader),
        parts(1, fallback),
        &topology,
        &states(0),
    )
    .unwrap();
    let (mut out, mut heads, mut u) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..26u64 {
        let x = states(k);
        out.clear();
        c.transmit(k, &x, &mut out);
        let deliveries: Vec<Delivery> = out
            .iter()
            .flat_map(|&packet| {
                hearing
                    .out_neighbours(packet.sender)
                    .iter()
                    .map(move |&receiver| Delivery { receiver, packet })
            })
            .collect();
        let ahead = |gap: f64, intruder: bool| {
            Some(RadarTruth {
                gap,
                closing: 0.0,
                intruder,
            })
        };
        c.set_radar_truth(&[
            None,
            ahead(5.0, (5..15).contains(&k)),
            ahead(9.0, false),
            ahead(9.0, false),
        ]);
        // An attack drives follower 1 into its fallback on steps 9 and 10, the car still
        // ahead: it keeps heading.
        let jammed = [false, (9..11).contains(&k), false, false];
        let cmd = c.receive(k, &x, &deliveries, &jammed).to_vec();
        if (9..11).contains(&k) {
            assert_eq!(c.follower_step(VehicleId(1)).mode, Mode::Zero, "step {k}");
        }
        heads.push([1, 2, 3].map(|i| c.follower_step(VehicleId(i)).head.0));
        u.push(cmd);
        // Follower 1 announces itself while on the car's ACC, the others their head.
        let announced = |i: u16| out.iter().find(|p| p.sender == VehicleId(i)).unwrap().head;
        if k > 0 {
            let leading = (6..20).contains(&k);
            assert_eq!(announced(1).0, if leading { 1 } else { 0 }, "step {k}");
            assert_eq!(
                announced(3),
                VehicleId(heads[k as usize - 1][2]),
                "step {k}"
            );
        }
    }
    // Follower 1 keeps the platoon's leader; 2 and 3 take follower 1 from step 6 (its
    // first packet as a head) to step 19 (its last), then the leader again.
    for (k, h) in heads.iter().enumerate() {
        let behind = if (6..20).contains(&k) { 1 } else { 0 };
        assert_eq!(*h, [0, behind, behind], "step {k}");
    }
    // Bumpless both ways: from the leader's 15 m/s to follower 1's 16 over 4 steps, and
    // back; follower 1 itself is on the car's ACC meanwhile.
    let f3: Vec<f64> = u.iter().map(|u| u[2]).collect();
    assert_eq!(f3[5], 15.0);
    assert_eq!(&f3[6..11], [15.0, 15.25, 15.5, 15.75, 16.0]);
    assert_eq!(&f3[20..25], [16.0, 15.75, 15.5, 15.25, 15.0]);
    assert_eq!(c.follower_step(VehicleId(3)).mode, Mode::Coop);
}

/// A triggering scheme of the user's: broadcast when the speed moved 0.045 m/s from the last
/// broadcast.
#[derive(Debug, Clone)]
struct OnSpeedChange;

impl Beaconing for OnSpeedChange {
    fn fires(&mut self, _: u64, _: VehicleId, own: &State, last: Option<(u64, &State)>) -> bool {
        last.is_none_or(|(_, x)| (own[1] - x[1]).abs() >= 0.045)
    }
}

#[test]
fn a_users_beaconing_decides_who_broadcasts() {
    let mut c = controller(1, FallbackParams::default());
    c.parts.beaconing = Box::new(OnSpeedChange);
    let mut sent = Vec::new();
    let mut out = Vec::new();
    for k in 0..30u64 {
        // Accelerating at 1 m/s^2: 0.01 m/s per step, so a broadcast every 5 steps.
        let states = accelerating(k);
        out.clear();
        c.transmit(k, &states, &mut out);
        if out.iter().any(|p| p.sender == VehicleId(2)) {
            sent.push(k);
        }
        c.receive(k, &states, &deliver_all(&out), &[false; 4]);
        assert_eq!(
            c.follower_step(VehicleId(2)).triggered,
            sent.last() == Some(&k)
        );
    }
    assert_eq!(sent, [0, 5, 10, 15, 20, 25]);
}

/// A fake clock that ticks once per reading: the seals' timing is counted without a real
/// clock, and the test asserts nothing about durations.
fn ticks() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NOW: AtomicU64 = AtomicU64::new(0);
    NOW.fetch_add(1, Ordering::Relaxed)
}

/// The runtime's clock times the seals' signing and verifying (timing.json's `sign` and
/// `verify`) and changes nothing the controller computes; without `[security]` there is
/// nothing to time.
#[test]
fn a_lent_clock_times_the_seals_and_changes_nothing() {
    let topology = Topology::preset(Preset::Pf, 3).unwrap();
    let initial = accelerating(0);
    let signed = || {
        let mut parts = parts(10, FallbackParams::default());
        parts.security = Some(crate::SecurityParams::default());
        ComposedController::new(Box::new(Echo), parts, &topology, &initial).unwrap()
    };
    let (mut timed, mut plain) = (signed(), signed());
    timed.time_crypto(ticks);
    let mut unsigned = controller(10, FallbackParams::default());
    unsigned.time_crypto(ticks);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for k in 0..12u64 {
        let states = accelerating(k);
        a.clear();
        b.clear();
        timed.transmit(k, &states, &mut a);
        plain.transmit(k, &states, &mut b);
        assert_eq!(a, b, "step {k}: the same packets, seals included");
        let ua = timed
            .receive(k, &states, &deliver_all(&a), &[false; 4])
            .to_vec();
        let ub = plain.receive(k, &states, &deliver_all(&b), &[false; 4]);
        assert_eq!(ua, ub, "step {k}");
    }
    assert_eq!(timed.seals(), plain.seals());
    let t = timed.crypto_time().expect("a signed controller");
    assert!(t.sign_ns > 0 && t.verify_ns > 0, "{t:?}");
    assert_eq!(plain.crypto_time(), Some(crate::CryptoTime::default()));
    assert_eq!(unsigned.crypto_time(), None);
}
