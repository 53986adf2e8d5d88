//! `platoon bench campaign`: campaign throughput on the local pool and through Dask.
use crate::machine::*;
use anyhow::{bail, Context, Result};
use platoon_output::rundir::RunDir;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What `platoon bench campaign` measures.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// Cells of the local runs.
    pub cells: usize,
    /// Local pool sizes to measure.
    pub jobs: Vec<usize>,
    /// Cells sent through Dask (0: skip Dask).
    pub dask_cells: usize,
    /// Output directory; None: runs/bench-campaign.
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    pub force: bool,
}

impl Default for Campaign {
    fn default() -> Self {
        Self {
            cells: 1000,
            jobs: vec![1, 2],
            dask_cells: 1000,
            out: None,
            force: false,
        }
    }
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct CampaignRow {
    /// `throughput` (the pool sizes), `dask` (the Dask comparison, local beside Dask) or
    /// `dask-fifth` (local and Dask in the workers again on a fifth of the cells: the slope
    /// between the two sizes is the cost per cell without the fixed start-up).
    pub part: &'static str,
    pub executor: String,
    pub workers: usize,
    pub cells: usize,
    pub wall_s: f64,
    pub cpu_s: f64,
    pub cells_per_s: f64,
    pub ms_per_cell: f64,
}

/// Runs `platoon bench campaign`.
pub fn campaign(a: Campaign) -> Result<Vec<CampaignRow>> {
    if a.cells == 0 || a.jobs.is_empty() || a.jobs.contains(&0) {
        bail!("--cells and every --jobs value must be at least 1");
    }
    let dir = crate::create_out(a.out, "bench-campaign", a.force)?;
    let exe = platoon_app::platoon_program()?;
    let file = |samples: usize| campaign_file(&dir, &samples.to_string(), samples, None);
    let measure = |case: Case<'_>| measure(&exe, &dir, case);
    let mut rows = Vec::new();
    let big = file(a.cells)?;
    for &j in &a.jobs {
        let jobs = j.to_string();
        rows.push(measure(Case {
            part: "throughput",
            file: &big,
            name: &format!("local-{j}"),
            extra: &["--jobs", &jobs],
            executor: format!("local pool, {j} jobs"),
            workers: j,
            env: &[],
        })?);
    }
    if a.dask_cells > 0 {
        rows.extend(dask_rows(&exe, &dir, a.dask_cells)?);
    }
    // The 802.11p channel's cost per cell beside Bernoulli loss: the same Monte Carlo cells on
    // one job, the paper scenario with each channel.
    let paper = platoon_config::PAPER_TOML;
    let channels = [
        (
            "bernoulli",
            "Bernoulli loss 5 %, 1 job",
            "[channel]\nseed = 1\n[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.05\n",
        ),
        (
            "80211p",
            "802.11p (0.12 veh/m, 25 Hz), 1 job",
            "[channel]\nseed = 1\nmodel = \"80211p\"\nradio = { density_veh_per_m = 0.12, beacon_hz = 25.0 }\n",
        ),
    ];
    let channel_cells = a.cells.min(200);
    for (name, executor, section) in channels {
        let base = dir.path(&format!("base-{name}.toml"));
        std::fs::write(&base, format!("{paper}\n{section}"))
            .with_context(|| format!("writing {}", base.display()))?;
        let path = campaign_file(
            &dir,
            name,
            channel_cells,
            Some(&format!("base-{name}.toml")),
        )?;
        rows.push(measure(Case {
            part: "channel",
            file: &path,
            name: &format!("channel-{name}"),
            extra: &["--jobs", "1"],
            executor: executor.into(),
            workers: 1,
            env: &[],
        })?);
    }
    let mut w = csv::Writer::from_writer(dir.writer("campaign.csv")?);
    for r in &rows {
        w.serialize(r)?;
    }
    w.flush()?;
    let json = serde_json::json!({ "machine_cores": cores(), "rows": rows });
    dir.write(
        "campaign.json",
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;
    println!("outputs: {}", path.display());
    Ok(rows)
}

/// The Dask rows: `cells` cells on the local pool beside a local cluster of two workers
/// (in the workers' processes, then a process per cell), and a fifth of them both ways.
fn dask_rows(exe: &Path, dir: &RunDir, cells: usize) -> Result<Vec<CampaignRow>> {
    let measure = |case: Case<'_>| measure(exe, dir, case);
    let file = |samples: usize| campaign_file(dir, &samples.to_string(), samples, None);
    let mut rows = Vec::new();
    let small = file(cells)?;
    rows.push(measure(Case {
        part: "dask",
        file: &small,
        name: "dask-local-2",
        extra: &["--jobs", "2"],
        executor: "local pool, 2 jobs".into(),
        workers: 2,
        env: &[],
    })?);
    let logs = dir.path("dask-logs");
    std::fs::create_dir_all(&logs)?;
    let cluster = platoon_app::campaign::LocalCluster::start(2, &logs)?;
    // The cells in the workers' processes (batches on the platoon package's core, when
    // bridge/.venv has it), then a `platoon campaign-cell` process per cell.
    let mut in_worker = measure(Case {
        part: "dask",
        file: &small,
        name: "dask-2",
        extra: &["--dask", &cluster.address],
        executor: "Dask, 2 workers (127.0.0.1), in the workers".into(),
        workers: 2,
        env: &[],
    })?;
    let ran = dask_in_worker(&dir.path("dask-2").join("dask.log"));
    if ran != Some(in_worker.cells) {
        eprintln!(
            "warning: through Dask only {} of {} cells ran in the workers' processes (is the \
             platoon package installed in bridge/.venv? `pip install ./bridge`); see {}",
            ran.unwrap_or(0),
            in_worker.cells,
            dir.path("dask-2").join("dask.log").display()
        );
        in_worker.executor = "Dask, 2 workers (127.0.0.1), fell back to a process per cell".into();
    }
    rows.push(in_worker);
    rows.push(measure(Case {
        part: "dask",
        file: &small,
        name: "dask-2-process",
        extra: &["--dask", &cluster.address],
        executor: "Dask, 2 workers (127.0.0.1), a process per cell".into(),
        workers: 2,
        env: &[("PLATOON_DASK_IN_WORKER", "0")],
    })?);
    // A fifth of the cells both ways: what a cell costs beyond the fixed start-up (the
    // driver's Python and its connection) is the slope between the two sizes.
    let fifth = cells / 5;
    if fifth > 0 {
        let path = file(fifth)?;
        rows.push(measure(Case {
            part: "dask-fifth",
            file: &path,
            name: "dask-local-2-fifth",
            extra: &["--jobs", "2"],
            executor: "local pool, 2 jobs".into(),
            workers: 2,
            env: &[],
        })?);
        rows.push(measure(Case {
            part: "dask-fifth",
            file: &path,
            name: "dask-2-fifth",
            extra: &["--dask", &cluster.address],
            executor: "Dask, 2 workers (127.0.0.1), in the workers".into(),
            workers: 2,
            env: &[],
        })?);
    }
    Ok(rows)
}

/// A Monte Carlo campaign of `samples` cells on `base` (a file in the output directory; None:
/// the embedded paper scenario), written as `bench-<name>.toml`.
fn campaign_file(dir: &RunDir, name: &str, samples: usize, base: Option<&str>) -> Result<PathBuf> {
    let path = dir.path(&format!("bench-{name}.toml"));
    let base = base.map_or(String::new(), |b| format!("base = \"{b}\"\n"));
    let text = format!(
        "name = \"bench-{name}\"\n{base}seed = 1\n[monte_carlo]\nsamples = {samples}\n\
         dos = {{ T1 = 2.0, T2 = 9.46, D1 = 6.0, D2 = 11.33, min_gap_s = 1.0, max_gap_s = 12.0, \
         min_duration_s = 0.5, max_duration_s = 3.0 }}\n"
    );
    std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

/// One `platoon campaign` to time: the report's part and executor, the campaign file, the
/// run's directory name, its extra arguments and environment, and its workers.
struct Case<'a> {
    part: &'static str,
    file: &'a Path,
    name: &'a str,
    extra: &'a [&'a str],
    executor: String,
    workers: usize,
    env: &'a [(&'a str, &'a str)],
}

/// Runs `case` with the `platoon` binary `exe` into `dir` and reads its campaign.json.
fn measure(exe: &Path, dir: &RunDir, case: Case<'_>) -> Result<CampaignRow> {
    let Case {
        part,
        file,
        name,
        extra,
        executor,
        workers,
        env,
    } = case;
    let target = dir.path(name);
    let o = Command::new(exe)
        .arg("campaign")
        .arg(file)
        .arg("--out")
        .arg(&target)
        .args(["--no-plots", "--force"])
        .args(extra)
        .envs(env.iter().copied())
        .output()
        .context("running platoon campaign")?;
    if !o.status.success() {
        bail!(
            "platoon campaign {}: {}",
            extra.join(" "),
            String::from_utf8_lossy(&o.stderr).trim()
        );
    }
    let text = std::fs::read_to_string(target.join("campaign.json"))?;
    let j: serde_json::Value = serde_json::from_str(&text)?;
    let cells = j["cells"].as_u64().unwrap_or(0) as usize;
    let wall = j["wall_s"].as_f64().unwrap_or(f64::NAN);
    let row = CampaignRow {
        part,
        executor,
        workers,
        cells,
        wall_s: wall,
        cpu_s: j["cpu_s"].as_f64().unwrap_or(f64::NAN),
        cells_per_s: cells as f64 / wall,
        ms_per_cell: 1e3 * wall / cells as f64,
    };
    println!(
        "{:<28} {:>5} cells in {:>6.2} s: {:>7.1} cells/s",
        row.executor, row.cells, row.wall_s, row.cells_per_s
    );
    Ok(row)
}

/// How many cells a Dask campaign ran in the workers' processes, from the driver's last line
/// in its dask.log ("dask_cells: T s: done: N cells in-worker, ...").
fn dask_in_worker(log: &Path) -> Option<usize> {
    let text = std::fs::read_to_string(log).ok()?;
    let done = text
        .lines()
        .rev()
        .find_map(|l| l.split_once(" s: done: ").map(|(_, done)| done))?;
    done.split_whitespace().next()?.parse().ok()
}
