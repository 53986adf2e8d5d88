//! The model against the authors' published simulations (`data/published/`, extracted from the
//! `simulations/*.fig` files of msepulcre/IEEE802.11p-model): the PDR against distance for every
//! published configuration, its four error types and the CBR.
//!
//! Run with `-- --nocapture` to see the per-curve table (docs/channel-80211p.md quotes it).

mod common;

use platoon_radio::Model;

/// The RMS error of the PDR curve the model must stay within: 0.03 for every published curve
/// except two, where the paper's model itself (as the authors' MATLAB computes it, which ours
/// reproduces to 1e-4 in RMS) underestimates the collisions at short and medium distance under
/// a channel busy ratio of 0.6 to 0.8, the highest loads published: the simulated COL at 100 m is
/// 0.17 where the model gives 0.05 (0.12 veh/m, 25 Hz, 500 B), 0.05 where it gives 0.01
/// (0.12 veh/m, 25 Hz, 30 dBm). Those two are held to what the model achieves, with a margin of
/// 0.002, so a regression still fails.
fn bound(label: &str) -> (f64, &'static str) {
    match label {
        "0.12 veh/m, 6 Mbps, 25 Hz, 23 dBm, 500 B" => {
            (0.0435, "model limit: collisions underestimated at CBR 0.77")
        }
        "0.12 veh/m, 6 Mbps, 25 Hz, 30 dBm, 190 B" => {
            (0.0330, "model limit: collisions underestimated at CBR 0.61")
        }
        _ => (0.03, ""),
    }
}

#[test]
fn pdr_against_distance_matches_every_published_curve() {
    let curves = common::all();
    // 22 PDR figures, 21 distances each (0 to 500 m every 25 m).
    assert_eq!(curves.len(), 22);
    assert!(curves.iter().all(|c| c.pdr.len() == 21));
    println!("| configuration | CBR ours | CBR sim | PDR RMS | SEN | RXB | PRO | COL | bound |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut failures = Vec::new();
    for c in &curves {
        let label = c.label();
        let model = Model::new(c.params).unwrap_or_else(|e| panic!("{label}: {e}"));
        let pdr_rms = common::rms(c.pdr.iter().map(|&(d, sim)| (model.pdr(d), sim)));
        let component = |k: usize| {
            common::rms(c.losses.iter().map(|(d, sim)| {
                let l = model.losses(*d);
                let ours = [l.below_sensing, l.receiver_busy, l.propagation, l.collision][k];
                (ours, sim[k])
            }))
        };
        let (limit, why) = bound(&label);
        println!(
            "| {label} | {:.3} | {} | {pdr_rms:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {limit}{} |",
            model.cbr(),
            c.cbr.map_or("-".into(), |v| format!("{v:.3}")),
            component(0),
            component(1),
            component(2),
            component(3),
            if why.is_empty() {
                String::new()
            } else {
                format!(" ({why})")
            },
        );
        if pdr_rms > limit {
            failures.push(format!("{label}: PDR RMS {pdr_rms:.4} > {limit}"));
        }
        // The simulated CBR is the mean of a distribution; the paper's fit is within 0.02 of it.
        if let Some(sim) = c.cbr {
            if (model.cbr() - sim).abs() > 0.02 {
                failures.push(format!("{label}: CBR {:.3} vs {sim:.3}", model.cbr()));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Between the published distances, too, the lookup is the model: the table is dense enough
/// that a table four times as fine changes no PDR by more than 1e-3.
#[test]
fn the_table_resolution_does_not_matter() {
    let c = &common::all()[0];
    let coarse = Model::new(c.params).unwrap();
    let fine = Model::new(platoon_radio::Params80211p {
        table_step_m: 0.25,
        ..c.params
    })
    .unwrap();
    let mut d = 0.0;
    while d < 600.0 {
        let (a, b) = (coarse.pdr(d), fine.pdr(d));
        assert!((a - b).abs() < 1e-3, "{d} m: {a} vs {b}");
        d += 0.37;
    }
}
