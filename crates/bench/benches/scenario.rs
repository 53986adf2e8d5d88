//! Compute cost of a whole scenario in process, no I/O: the paper's Section IV (configs/paper.toml:
//! 5 vehicles, 55 s, dt = 0.01 s, 5501 steps, DoS and tau uncertainty) with the dynamic and the
//! static rule.
//!
//! Method: the scenario is parsed once; each iteration runs `platoon_sim::run` from scratch and
//! folds every step into a checksum so nothing is optimised away. Criterion reports the median of
//! its samples. Run: `cargo bench -p platoon-bench --bench scenario`.
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use platoon_control::TriggerRule;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let (_, dynamic) =
        platoon_config::parse(platoon_config::PAPER_TOML, Path::new("paper.toml")).unwrap();
    let mut stat = dynamic.clone();
    stat.control.rule = TriggerRule::Static;
    let mut g = c.benchmark_group("paper_scenario_55s");
    for (name, sc) in [("dynamic", &dynamic), ("static", &stat)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut sum = 0.0;
                let s = platoon_sim::run(black_box(sc.clone()), |rows| sum += rows[1].p).unwrap();
                black_box((sum, s.triggers_total))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
