//! Misbehaviour detection in the receive path: the detectors see what passed the packet
//! checks, and the reaction decides what a follower does with a flagged sender.
use platoon_control::screening::{DetectorSpec, Sensed};
use platoon_control::{Delivery, DetectionParams, Packet, PacketChecks, Reaction};
use platoon_model::{State, VehicleId};
use platoon_topology::{Preset, Topology};

const DT: f64 = 0.01;

/// Two followers behind a leader at 20 m/s, 10 m apart; follower 1 hears the leader.
fn checks(reaction: Reaction, quiet_steps: u32) -> (PacketChecks, Vec<State>) {
    let topology = Topology::preset(Preset::Pf, 2).unwrap();
    let initial: Vec<State> = (0..3)
        .map(|i| State::new(-10.0 * i as f64, 20.0, 0.0))
        .collect();
    let detection = DetectionParams {
        specs: vec![DetectorSpec::Residual(Default::default())],
        reaction,
        quiet_steps,
        plugin: Vec::new(),
    };
    let checks = PacketChecks::new(&topology, &initial, DT)
        .with_detection(&detection)
        .unwrap();
    (checks, initial)
}

/// The leader's packet of step k, true (20 m/s from 0 m) plus `offset_m` on its position.
fn leader(k: u64, offset_m: f64) -> Delivery {
    Delivery {
        receiver: VehicleId(1),
        packet: Packet::beacon(
            VehicleId::LEADER,
            k as u32 + 1,
            k,
            State::new(20.0 * k as f64 * DT + offset_m, 20.0, 0.0),
        ),
    }
}

fn sensed(k: u64) -> Sensed {
    Sensed {
        own: State::new(20.0 * k as f64 * DT - 10.0, 20.0, 0.0),
        radar: None,
    }
}

#[test]
fn a_flagged_sender_is_refused_for_the_quiet_period_and_the_follower_falls_back() {
    let (mut c, _) = checks(Reaction::Fallback, 50);
    assert_eq!(c.detector_names(), ["residual"]);
    for k in 1..=10 {
        c.begin_step();
        assert!(c
            .admit_sensed(k * 100, &leader(k * 100, 0.0), sensed(k * 100))
            .is_some());
        let i = c.inspections();
        assert_eq!(i.len(), 1);
        assert!(!i[0].flagged && !i[0].refused && i[0].verdicts()[0].tested());
    }
    assert!(!c.distrusts(VehicleId(1), 1100));
    // A 5 m jump in the claimed position a second later (which the packet checks let through:
    // a vehicle could get there): flagged and refused, the follower falls back.
    c.begin_step();
    assert!(c
        .admit_sensed(1100, &leader(1100, 5.0), sensed(1100))
        .is_none());
    assert!(c.inspections()[0].flagged && c.inspections()[0].refused);
    assert!(c.distrusts(VehicleId(1), 1100) && c.distrusts(VehicleId(1), 1150));
    // Genuine packets within the quiet period are refused too; after it, trusted again.
    c.begin_step();
    assert!(c
        .admit_sensed(1120, &leader(1120, 0.0), sensed(1120))
        .is_none());
    assert!(!c.inspections()[0].flagged && c.inspections()[0].refused);
    assert!(!c.distrusts(VehicleId(1), 1171));
    c.begin_step();
    assert!(c
        .admit_sensed(1180, &leader(1180, 0.0), sensed(1180))
        .is_some());
    let counts = c.screened();
    assert_eq!(
        (counts.inspected, counts.flagged, counts.refused),
        (13, 1, 2)
    );
    // Follower 2 was never involved.
    assert!(!c.distrusts(VehicleId(2), 120));
}

#[test]
fn logging_only_changes_nothing_but_the_record() {
    let (mut logged, initial) = checks(Reaction::Log, 50);
    let topology = Topology::preset(Preset::Pf, 2).unwrap();
    let mut plain = PacketChecks::new(&topology, &initial, DT);
    for (k, offset) in [(100, 0.0), (200, 5.0), (300, 5.0), (400, 0.0)] {
        logged.begin_step();
        let a = logged.admit_sensed(k, &leader(k, offset), sensed(k));
        assert_eq!(a, plain.admit(k, &leader(k, offset)));
        assert_eq!(logged.heard(VehicleId(1)), plain.heard(VehicleId(1)));
    }
    assert!(logged.screened().flagged >= 1 && logged.screened().refused == 0);
    assert!(!logged.distrusts(VehicleId(1), 300));
}

#[test]
fn a_packet_the_checks_refuse_is_recorded_with_the_reason_and_no_verdict() {
    use platoon_control::RefusedBy;
    let (mut c, _) = checks(Reaction::Fallback, 50);
    c.begin_step();
    assert!(c
        .admit_sensed(100, &leader(100, 0.0), sensed(100))
        .is_some());
    // The same packet again (a replay: the sequence filter), then one from a stranger.
    c.begin_step();
    assert!(c
        .admit_sensed(101, &leader(100, 0.0), sensed(101))
        .is_none());
    let mut stranger = leader(101, 0.0);
    stranger.receiver = VehicleId(2);
    assert!(c.admit_sensed(101, &stranger, sensed(101)).is_none());
    let i = c.inspections();
    assert_eq!(i.len(), 2);
    assert_eq!(i[0].refused_by, Some(RefusedBy::StaleSeq));
    assert_eq!(i[1].refused_by, Some(RefusedBy::UnknownSender));
    assert!(i
        .iter()
        .all(|i| i.refused_by_checks() && !i.refused && i.verdicts().is_empty()));
    // Not inspections: the detectors' counts and the distrust are unchanged.
    assert_eq!(c.screened().inspected, 1);
    assert!(!c.distrusts(VehicleId(1), 101));
    assert_eq!(
        (c.rejected().stale_seq, c.rejected().unknown_sender),
        (1, 1)
    );
    for r in RefusedBy::ALL {
        assert_eq!(RefusedBy::from_code(r.code()), Some(r));
    }
    assert_eq!(RefusedBy::from_code(0), None);
}

#[test]
fn without_detectors_nothing_is_inspected() {
    let topology = Topology::preset(Preset::Pf, 2).unwrap();
    let initial = vec![State::zeros(); 3];
    let mut c = PacketChecks::new(&topology, &initial, DT)
        .with_detection(&DetectionParams::default())
        .unwrap();
    c.begin_step();
    c.admit_sensed(1, &leader(1, 0.0), sensed(1));
    assert!(c.inspections().is_empty() && c.detector_names().is_empty());
}

/// A detector of the user's own: flags every packet claiming more than 30 m/s.
#[derive(Debug, Clone)]
struct TooFast;

impl platoon_control::screening::Detector for TooFast {
    fn name(&self) -> &'static str {
        "too_fast"
    }

    fn inspect(&mut self, obs: &platoon_detect::Observation) -> platoon_detect::Verdict {
        let v = obs.packet.state[1];
        platoon_detect::Verdict {
            flagged: v > 30.0,
            score: v,
        }
    }
}

#[test]
fn a_users_own_detector_runs_in_the_receive_path() {
    let topology = Topology::preset(Preset::Pf, 2).unwrap();
    let initial = vec![State::new(0.0, 20.0, 0.0); 3];
    let mut detectors = platoon_control::screening::Detectors::default();
    detectors.push(Box::new(TooFast));
    let mut c =
        PacketChecks::new(&topology, &initial, DT).with_detectors(detectors, Reaction::Drop, 0);
    assert_eq!(c.detector_names(), ["too_fast"]);
    let mut fast = leader(100, 0.0);
    fast.packet.state[1] = 31.0;
    c.begin_step();
    assert!(c.admit_sensed(100, &fast, sensed(100)).is_none());
    assert_eq!(c.inspections()[0].verdicts()[0].score, 31.0);
    c.begin_step();
    assert!(c
        .admit_sensed(200, &leader(200, 0.0), sensed(200))
        .is_some());
}
