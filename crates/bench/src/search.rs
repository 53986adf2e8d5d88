//! `platoon bench search`: the worst-case DoS search's throughput against the pool size.
use crate::machine::*;
use anyhow::{bail, Context, Result};
use std::path::PathBuf;

/// What `platoon bench search` measures.
#[derive(Debug, Clone)]
pub struct Search {
    /// Evaluations of the search.
    pub evaluations: usize,
    /// Local pool sizes to measure.
    pub jobs: Vec<usize>,
    /// Output directory; None: runs/bench-search.
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    pub force: bool,
}

impl Default for Search {
    fn default() -> Self {
        Self {
            evaluations: 1000,
            jobs: vec![1, 2],
            out: None,
            force: false,
        }
    }
}

/// One measured search.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SearchRow {
    pub jobs: usize,
    pub evaluations: usize,
    pub wall_s: f64,
    pub evaluations_per_s: f64,
    pub ms_per_evaluation: f64,
    /// The largest spacing error found (m), the same for every pool size.
    pub harm: f64,
}

/// Runs `platoon bench search`.
pub fn search(a: Search) -> Result<Vec<SearchRow>> {
    if a.evaluations == 0 || a.jobs.is_empty() || a.jobs.contains(&0) {
        bail!("--evaluations and every --jobs value must be at least 1");
    }
    let dir = crate::create_out(a.out, "bench-search", a.force)?;
    let file = dir.path("bench.toml");
    std::fs::write(&file, "name = \"bench\"\nseed = 1\ncompare = []\n")
        .with_context(|| format!("writing {}", file.display()))?;
    let spec = platoon_app::search::load(&file, Some(a.evaluations))?;
    let mut rows = Vec::new();
    for &j in &a.jobs {
        let pool = platoon_app::campaign::LocalPool::new(std::num::NonZeroUsize::new(j));
        let opts = platoon_app::search::SearchOptions {
            force: true,
            plots: false,
        };
        let o = platoon_app::search::run(
            &spec,
            &dir.path(&format!("jobs-{j}")),
            &opts,
            &pool,
            &platoon_app::Stop::default(),
            &(),
        )?;
        let m = &o.problems[0].methods[0];
        let row = SearchRow {
            jobs: j,
            evaluations: m.evaluations,
            wall_s: m.wall_s,
            evaluations_per_s: m.evaluations as f64 / m.wall_s,
            ms_per_evaluation: 1e3 * m.wall_s / m.evaluations as f64,
            harm: m.best.as_ref().and_then(|b| b.harm).unwrap_or(f64::NAN),
        };
        println!(
            "search, local pool {:>2} jobs: {:>5} evaluations in {:>6.2} s ({:>6.1}/s), largest spacing error {:.2} m",
            j, row.evaluations, row.wall_s, row.evaluations_per_s, row.harm
        );
        rows.push(row);
    }
    let mut w = csv::Writer::from_writer(dir.writer("search.csv")?);
    for r in &rows {
        w.serialize(r)?;
    }
    w.flush()?;
    let json = serde_json::json!({ "machine_cores": cores(), "rows": rows });
    dir.write(
        "search.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;
    println!("outputs: {}", path.display());
    Ok(rows)
}
