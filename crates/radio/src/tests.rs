use super::*;

#[test]
fn a_jammer_is_heard_out_to_its_sensing_radius() {
    let p = Params80211p::default();
    let r10 = p.sensing_radius_m(10.0);
    let r23 = p.sensing_radius_m(23.0);
    assert!(r10 > 1.0 && r23 > r10, "{r10} {r23}");
    // At the radius the mean received power is the sensing threshold.
    let path_loss = p.path_loss();
    assert!((23.0 - path_loss.db(r23) - p.sensing_threshold_dbm).abs() < 1e-3);
    assert_eq!(p.sensing_radius_m(-200.0), 0.0);
    // What docs/channel-80211p.md says: 20 dBm is heard out to a few hundred metres.
    let r20 = p.sensing_radius_m(20.0);
    println!("sensing radius: 10 dBm {r10:.0} m, 20 dBm {r20:.0} m, 23 dBm {r23:.0} m");
    assert!((100.0..1000.0).contains(&r20), "{r20}");
}

#[test]
fn defaults_are_valid_and_each_bad_field_is_named() {
    Params80211p::default().validate().unwrap();
    let bad = |f: fn(&mut Params80211p)| {
        let mut p = Params80211p::default();
        f(&mut p);
        match Model::new(p).unwrap_err() {
            Error::Parameter { name, .. } => name,
            other => panic!("{other}"),
        }
    };
    assert_eq!(bad(|p| p.density_veh_per_m = -0.01), "density_veh_per_m");
    assert_eq!(bad(|p| p.beacon_hz = f64::NAN), "beacon_hz");
    assert_eq!(bad(|p| p.tx_power_dbm = 40.0), "tx_power_dbm");
    assert_eq!(bad(|p| p.data_rate_mbps = 7.0), "data_rate_mbps");
    assert_eq!(bad(|p| p.packet_bytes = 0), "packet_bytes");
    assert_eq!(bad(|p| p.antenna_height_m = 0.4), "antenna_height_m");
    assert_eq!(bad(|p| p.shadowing_db = 0.0), "shadowing_db");
    assert_eq!(bad(|p| p.table_step_m = 0.0), "table_step_m");
    assert_eq!(bad(|p| p.noise_dbm = f64::INFINITY), "noise_dbm");
    let msg = Model::new(Params80211p {
        data_rate_mbps: 7.0,
        ..Params80211p::default()
    })
    .unwrap_err()
    .to_string();
    assert!(msg.contains("data_rate_mbps = 7"), "{msg}");
    // Every 10 MHz rate is accepted, and 20 MHz rates with a 20 MHz channel.
    for r in [3.0, 4.5, 6.0, 9.0, 12.0, 18.0, 24.0, 27.0] {
        let p = Params80211p {
            data_rate_mbps: r,
            ..Params80211p::default()
        };
        p.validate().unwrap();
    }
    Params80211p {
        data_rate_mbps: 54.0,
        bandwidth_mhz: 20.0,
        ..Params80211p::default()
    }
    .validate()
    .unwrap();
}

/// The corners of the accepted ranges build, and stay probabilities: no interferer at all,
/// and the densest, loudest, busiest channel (whose offered load saturates the CBR fit).
#[test]
fn extreme_configurations_stay_probabilities() {
    let lonely = Model::new(Params80211p {
        density_veh_per_m: 1e-4,
        tx_power_dbm: -10.0,
        ..Params80211p::default()
    })
    .unwrap();
    let crowded = Model::new(Params80211p {
        density_veh_per_m: 1.0,
        beacon_hz: 100.0,
        tx_power_dbm: 33.0,
        data_rate_mbps: 3.0,
        packet_bytes: 2304,
        ..Params80211p::default()
    })
    .unwrap();
    assert!(crowded.offered_load() > 1.84 && (crowded.cbr() - cbr_fit(1.84)).abs() < 1e-3);
    for m in [&lonely, &crowded] {
        for (d, l) in m.table() {
            for v in [l.below_sensing, l.receiver_busy, l.propagation, l.collision] {
                assert!((0.0..=1.0).contains(&v), "{d}: {l:?}");
            }
            assert!(l.pdr() <= 1.0 && l.pdr() >= 0.0);
        }
    }
    // Without interferers only sensing and propagation lose packets.
    assert_eq!(lonely.losses(10.0).receiver_busy, 0.0);
    assert_eq!(lonely.losses(10.0).collision, 0.0);
    assert!(lonely.range_m() < 200.0, "{}", lonely.range_m());
    // So loaded a channel delivers little even close by.
    assert!(crowded.pdr(50.0) < 0.5, "{}", crowded.pdr(50.0));
}

#[test]
fn models_are_shareable_across_threads() {
    fn shareable<T: Send + Sync + Clone>() {}
    shareable::<Model>();
}

#[test]
fn power_sum_is_the_sum_of_powers() {
    assert!((power_sum_dbm(-95.0, -95.0) - (-95.0 + 10.0 * 2f64.log10())).abs() < 1e-12);
    assert!((power_sum_dbm(-300.0, -95.0) + 95.0).abs() < 1e-12);
    assert!(
        (power_sum_dbm(-40.0, -95.0) + 40.0 - 10.0 * (1.0 + 10f64.powf(-5.5)).log10()).abs()
            < 1e-12
    );
}

#[test]
fn the_cbr_fit_saturates_at_its_vertex() {
    assert!((cbr_fit(0.0) - 0.003844).abs() < 1e-15);
    let top = cbr_fit(1.84);
    assert!(cbr_fit(3.0) >= top - 1e-12 && cbr_fit(3.0) == cbr_fit(10.0));
}

#[test]
fn autocorrelation_of_a_known_sequence() {
    // s = [1, 0.5] means the sequence 0.5, 1, 0.5: lags 0, 1, 2 give 1.5, 1, 0.25.
    let r = autocorrelation(&[1.0, 0.5, 0.0]);
    assert_eq!(r.len(), 3);
    assert!((r[1] - 1.0 / 1.5).abs() < 1e-15 && (r[2] - 0.25 / 1.5).abs() < 1e-15);
}

#[test]
fn lookups_are_symmetric_bounded_and_zero_out_of_range() {
    let m = Model::new(Params80211p::default()).unwrap();
    assert_eq!(m.pdr(-100.0), m.pdr(100.0));
    assert_eq!(m.pdr(f64::NAN), 0.0);
    assert_eq!(m.pdr(f64::INFINITY), 0.0);
    assert_eq!(m.pdr(m.range_m() + 1.0), 0.0);
    assert!(
        m.range_m() > 400.0 && m.range_m() < 1000.0,
        "{}",
        m.range_m()
    );
    let mut last = 1.0;
    for (d, l) in m.table() {
        let pdr = l.pdr();
        assert!((0.0..=1.0).contains(&pdr));
        // (At the range the lookup says 0, the table at most 1e-9.)
        assert!((pdr - m.pdr(d)).abs() < 1e-9);
        // The PDR never rises by more than the tiny steps of the same-slot terms.
        assert!(pdr <= last + 1e-3, "{d}");
        last = pdr;
    }
    assert_eq!(m.losses(1e6).below_sensing, 1.0);
}
