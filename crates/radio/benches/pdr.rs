//! Cost of the 802.11p model: one `pdr()` lookup (what the channel pays per packet), one
//! `pdr_with_interference()` lookup (what it pays per packet while a jammer transmits) and one
//! `Model::new` (once per configuration), for the paper's base case and its densest published
//! configuration. Run: `cargo bench -p platoon-radio --bench pdr`.
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use platoon_radio::{Model, Params80211p};

fn bench(c: &mut Criterion) {
    let base = Params80211p::default();
    let dense = Params80211p {
        density_veh_per_m: 0.12,
        beacon_hz: 25.0,
        tx_power_dbm: 30.0,
        ..base
    };
    let model = Model::new(base).unwrap();
    // 1000 distances spread over the platoon's and the model's range, so the branch and the
    // cache see a realistic mix.
    let distances: Vec<f64> = (0..1000).map(|i| (i as f64 * 7.31) % 900.0).collect();
    c.bench_function("pdr_1000_lookups", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for &d in &distances {
                sum += model.pdr(black_box(d));
            }
            black_box(sum)
        })
    });
    // With a jammer on, the channel pays this per packet per link instead (the table behind it
    // is built before timing starts).
    let interference: Vec<f64> = (0..1000)
        .map(|i| -110.0 + (i as f64 * 3.7) % 70.0)
        .collect();
    model.pdr_with_interference(1.0, -90.0);
    c.bench_function("pdr_with_interference_1000_lookups", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for (&d, &i) in distances.iter().zip(&interference) {
                sum += model.pdr_with_interference(black_box(d), black_box(i));
            }
            black_box(sum)
        })
    });
    let mut g = c.benchmark_group("model_new");
    g.sample_size(20);
    g.bench_function("base_0.06vehm_10Hz_23dBm", |b| {
        b.iter(|| Model::new(black_box(base)).unwrap())
    });
    g.bench_function("dense_0.12vehm_25Hz_30dBm", |b| {
        b.iter(|| Model::new(black_box(dense)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
