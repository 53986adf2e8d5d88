//! `platoon bench all`: every benchmark with its defaults, and BENCHMARKS.md.
use crate::campaign::CampaignRow;
use crate::design::growth_exponent;
use crate::machine::*;
use crate::step::{peers_section, StepReport};
use crate::{campaign, design, latency, search, step};
use crate::{Campaign, Design, Latency, Search, Step};
use anyhow::{bail, Context, Result};
use platoon_output::markdown;
use std::fmt::Write as _;
use std::path::PathBuf;

/// What `platoon bench all` writes.
#[derive(Debug, Clone)]
pub struct All {
    /// Output directory; None: runs/bench.
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    pub force: bool,
    /// Where to write the report.
    pub markdown: PathBuf,
}

impl Default for All {
    fn default() -> Self {
        Self {
            out: None,
            force: false,
            markdown: PathBuf::from("BENCHMARKS.md"),
        }
    }
}

/// Runs `platoon bench all`.
pub fn all(a: All) -> Result<()> {
    let out = a.out.unwrap_or_else(|| PathBuf::from("runs").join("bench"));
    if out.exists() && !a.force {
        bail!(
            "output directory {} exists; choose another --out or pass --force",
            out.display()
        );
    }
    std::fs::create_dir_all(&out)?;
    // Read before anything runs: the commit that measures every section below.
    let commit = commit();
    println!("benchmarking commit {commit}");
    let lat = latency(Latency {
        out: Some(out.join("latency")),
        force: true,
        ..Latency::default()
    })?;
    let StepReport {
        rows: steps,
        peers: peer_rows,
        ratios,
    } = step(Step {
        out: Some(out.join("step")),
        force: true,
        ..Step::default()
    })?;
    let (designs, checks) = design(Design {
        out: Some(out.join("design")),
        force: true,
        ..Design::default()
    })?;
    let campaigns = campaign(Campaign {
        out: Some(out.join("campaign")),
        force: true,
        ..Campaign::default()
    })?;
    let searches = search(Search {
        out: Some(out.join("search")),
        force: true,
        ..Search::default()
    })?;
    let mut md = String::new();
    let _ = writeln!(md, "# Benchmarks\n");
    let _ = writeln!(
        md,
        "Regenerate with `cargo run --release -- bench all --force` (writes this file and runs/bench/). \
         Measured in one `platoon bench all` run at commit `{commit}` (`git rev-parse --short HEAD` \
         when the run started, \"+ uncommitted changes\" when tracked files differed from it); \
         each section repeats the commit that measured it. \
         Machine: {} cores, `{}`; {}. The machines are shared and noisy: read medians and ratios \
         measured side by side in one run, not absolute thresholds.\n",
        cores(),
        std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|c| c.lines().find(|l| l.starts_with("model name")).map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string()))
            .unwrap_or_else(|| "unknown CPU".into()),
        describe_halt_poll(lat.guest_halt_poll_ns.as_deref())
    );
    latency_section(&mut md, &commit, &lat);
    step_section(&mut md, &commit, &steps);
    peers_section(&mut md, &peer_rows, &ratios);
    // What was measured by hand (a `### ... (measured by hand` subsection of the report being
    // replaced) is carried over: no run of `bench all` drops it.
    let previous = std::fs::read_to_string(&a.markdown).unwrap_or_default();
    md.push_str(&hand_sections(&previous));
    design_section(&mut md, &commit, &designs, &checks);
    campaign_section(&mut md, &commit, &campaigns);
    search_section(&mut md, &commit, &searches);
    // Written whole or not at all: a killed run leaves the previous report.
    let partial = a.markdown.with_extension("md.partial");
    std::fs::write(&partial, md)
        .and_then(|()| std::fs::rename(&partial, &a.markdown))
        .with_context(|| format!("writing {}", a.markdown.display()))?;
    println!("wrote {}", a.markdown.display());
    Ok(())
}

/// BENCHMARKS.md's section of `platoon bench latency`: the hops and the step overhead.
fn latency_section(md: &mut String, commit: &str, lat: &crate::latency::LatencyReport) {
    let _ = writeln!(
        md,
        "## V2V hop and step overhead (`platoon bench latency`)\n\n{}",
        measured(commit, "bench latency")
    );
    let _ = writeln!(
        md,
        "Ping-pong between two processes with the paper scenario's tx batch ({} link packets), {} iterations after a warm-up; \
         each hop is publish to publish (CLOCK_MONOTONIC stamps in the payload). µs:\n",
        lat.batch_items, Latency::default().iterations
    );
    md.push_str(&markdown::header(&[
        "quantity",
        "p50",
        "p90",
        "p99",
        "p99.9",
        "max",
        "x raw iceoryx2 (p50)",
    ]));
    for r in &lat.rows {
        let (figures, over) = r.figures();
        let [p50, p90, p99, p999, max] = figures.map(|x| format!("{x:.2}"));
        markdown::row(md, &[&r.quantity, &p50, &p90, &p99, &p999, &max, &over]);
    }
    let _ = writeln!(
        md,
        "\nInjector hop / raw iceoryx2 hop (p50): **{:.2}** (target < 2: {}). Step overhead over in-process (p50): **{:.1} µs** (target < 60 µs: {}); with the nodes on one core (`--cpus`): **{:.1} µs** ({}).\n",
        lat.injector_hop_over_raw_hop_p50,
        if lat.injector_hop_over_raw_hop_p50 < 2.0 { "met" } else { "missed" },
        lat.step_overhead_p50_us,
        if lat.step_overhead_p50_us < 60.0 { "met" } else { "missed: a step is four event-driven hops, each a wake-up of another process, possibly on the other core" },
        lat.step_overhead_p50_us_one_core,
        if lat.step_overhead_p50_us_one_core < 60.0 { "met" } else { "missed" }
    );
    let p50 = |q: &str| {
        lat.rows
            .iter()
            .find(|r| r.quantity == q)
            .map_or(f64::NAN, |r| r.stats.p50_us)
    };
    let step_ratio = lat.step_overhead_p50_us / lat.step_overhead_p50_us_one_core;
    let hop_ratio = p50("injector_hop") / p50("unix_socket_hop");
    let _ = writeln!(
        md,
        "Nodes on any CPU against one core: the step overhead is **{step_ratio:.2}x** the one-core figure (target <= 2: {}); the injector hop on any CPU is **{hop_ratio:.2}x** a Unix-datagram hop measured in the same run (target <= 3: {}). On one core the raw iceoryx2 hop is {:.2} µs and the Unix-datagram hop {:.2} µs. A node that wakes another first hands the sleeping reader its own CPU unless the reader already has just that one, and the reader keeps it for 64 wake-ups before it returns to its CPU set (`crates/runtime/src/handoff.rs`; `PLATOON_WAKE_HANDOFF=0` turns it off): without it, the woken process lands on the idle vCPU, which is halted (`guest_halt_poll_ns` above) and costs 20-30 µs to wake.\n",
        if step_ratio <= 2.0 { "met" } else { "missed" },
        if hop_ratio <= 3.0 { "met" } else { "missed" },
        p50("raw_iceoryx2_hop_one_core"),
        p50("unix_socket_hop_one_core"),
    );
    let (any, one) = (
        lat.python_sdk_over_builtin_injector_p50,
        lat.python_sdk_over_builtin_injector_p50_one_core,
    );
    let _ = writeln!(
        md,
        "Injector SDKs: the built-in injector is written on the Rust SDK (`platoon_runtime::injector`), so its hop is the Rust SDK's (1.0x by construction). The Python SDK's `bridge/examples/dos_jammer.py` in the same scenario, with the nodes on one core (`--cpus`, the `_one_core` rows): **{one:.2}x** the built-in hop (p50; target <= 2: {}). With the nodes on any CPU: **{any:.2}x** ({}).\n",
        if one <= 2.0 { "met" } else { "missed: each step crosses into Python and copies the batch through ctypes" },
        if any <= 2.0 {
            "within the target too"
        } else {
            "what the one-core rows do not pay is the wake-up of a process on the other core; `platoon run --cpus 0` avoids it"
        }
    );
}

/// BENCHMARKS.md's section of `platoon bench step`: the step cost against the size.
fn step_section(md: &mut String, commit: &str, steps: &[crate::step::StepRow]) {
    let _ = writeln!(
        md,
        "## Step cost against size (`platoon bench step`)\n\n{}",
        measured(commit, "bench step")
    );
    let _ = writeln!(md, "Platoons of 4 followers (PF, dynamic ETM, no DoS), 5 simulated seconds per case, dt = 0.01 s, every case run in 3 rounds (interleaved). p50 µs per step, each figure the median over the rounds:\n");
    let _ = writeln!(md, "Modes ending in -1cpu run the nodes on one core (`platoon run --cpus`). Peak RSS is the sum over every process of the run (`platoon run` and its nodes; `timing.json` has each), in MiB.\n");
    md.push_str(&markdown::header(&[
        "mode",
        "followers",
        "vehicles",
        "step",
        "x real time",
        "plant",
        "controller",
        "injector",
        "SUMO step",
        "bridge",
        "SUMO step, tight loop",
        "bridge, tight loop",
        "peak RSS",
    ]));
    let f = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.1}"));
    for r in steps {
        markdown::row(
            md,
            &[
                &r.mode,
                &r.followers,
                &r.vehicles,
                &format_args!("{:.1}", r.step_p50_us),
                &format_args!("{:.1}", r.real_time_factor),
                &f(r.plant_p50_us),
                &f(r.controller_p50_us),
                &f(r.injector_p50_us),
                &f(r.sumo_step_p50_us),
                &f(r.bridge_p50_us),
                &f(r.sumo_step_tight_p50_us),
                &f(r.bridge_tight_p50_us),
                &f(r.peak_rss_mib),
            ],
        );
    }
    let find = |mode: &str, n: usize| steps.iter().find(|r| r.mode == mode && r.followers == n);
    let met = |ok: bool| if ok { "met" } else { "missed" };
    for (sumo, native, label) in [
        ("sumo", "native", "nodes on any CPU"),
        ("sumo-1cpu", "native-1cpu", "nodes on one core"),
    ] {
        if let Some(big) = find(sumo, 1000) {
            let s = big.sumo_step_p50_us.unwrap_or(f64::NAN);
            let ours = big.step_p50_us - s;
            let floor = big.bridge_tight_p50_us.unwrap_or(f64::NAN);
            let _ = writeln!(
                md,
                "\nN = 1000 with SUMO, {label}: {:.1}x real time (target >= 2: {}); our overhead {:.0} µs = {:.0} % of SUMO's step (target <= 30 %: {}); of it, {:.0} µs ({:.0} % of SUMO's step) is the bridge's work that remains with no co-simulation around it (the tight loop: one libsumo call per vehicle to set its acceleration and two to read it back).",
                big.real_time_factor,
                met(big.real_time_factor >= 2.0),
                ours,
                100.0 * ours / s,
                met(ours <= 0.3 * s),
                floor,
                100.0 * floor / s,
            );
        }
        if let (Some(small), Some(nat)) = (find(sumo, 4), find(native, 4)) {
            let x = small.step_p50_us / nat.step_p50_us;
            let _ = writeln!(
                md,
                "\n5 vehicles, {label}: the SUMO co-simulation step is {x:.1}x the native one ({:.1} against {:.1} µs; target <= 3: {}). SUMO's own step: {} µs in the co-simulation, {} µs in the tight loop.",
                small.step_p50_us,
                nat.step_p50_us,
                met(x <= 3.0),
                f(small.sumo_step_p50_us),
                f(small.sumo_step_tight_p50_us),
            );
        }
    }
    if let (Some(busy), Some(calm)) = (find("sumo-traffic", 1000), find("sumo", 1000)) {
        let _ = writeln!(
            md,
            "\nN = 1000 with SUMO and traffic that touches every platoon (`sumo-traffic`: the platoons of `configs/cut-in.toml`, 20 m front to front, a car cutting in mid-gap ahead of each platoon's follower 3 from 30 % to 70 % of the run, handled by `[fallback.cut_in]`, and {} SUMO background vehicles on the platoons' lanes changing lanes by LC2013, a fifth of them trucks; the vehicles column counts the platoons' alone): {:.1}x real time (target >= 3: {}), its step {:.2}x the `sumo` case's without traffic ({:.1} against {:.1} µs; SUMO's own step {} against {} µs).",
            1000usize.div_ceil(5),
            busy.real_time_factor,
            met(busy.real_time_factor >= 3.0),
            busy.step_p50_us / calm.step_p50_us,
            busy.step_p50_us,
            calm.step_p50_us,
            f(busy.sumo_step_p50_us),
            f(calm.sumo_step_p50_us),
        );
    }
    let _ = writeln!(md);
    let _ = writeln!(
        md,
        "The scaling plot with the least-squares lines is runs/bench/step/step.png.\n"
    );
}

/// BENCHMARKS.md's section of `platoon bench design`: the LMI design and check times.
fn design_section(
    md: &mut String,
    commit: &str,
    designs: &[crate::design::DesignRow],
    checks: &[crate::design::CheckRow],
) {
    let _ = writeln!(
        md,
        "## LMI design time (`platoon bench design`)\n\n{}",
        measured(commit, "bench design")
    );
    md.push_str(&markdown::header(&[
        "followers (TPSF)",
        "seconds",
        "SDPs",
        "beta1/beta2",
        "certificate",
        "designed on",
    ]));
    let ratio = |x: Option<f64>| x.map_or("infeasible".to_string(), |x| format!("{x:.1}"));
    for r in designs {
        markdown::row(
            md,
            &[
                &r.followers,
                &format_args!("{:.2}", r.seconds),
                &r.sdps,
                &ratio(r.beta1_over_beta2),
                &r.certificate.as_deref().unwrap_or("-"),
                &r.designed_on.map_or("-".into(), |n| n.to_string()),
            ],
        );
    }
    let _ = writeln!(md, "\nTargets: under 1 s for N = 4, under 30 s for N = 20.");
    let _ = writeln!(
        md,
        "\nThe checks of `design check-gain` for the paper's K on PLF (the LMIs at the nominal tau; \
         the closed-loop spectrum at 51 taus and string stability at the smallest, nominal and \
         largest tau of the paper's range):\n"
    );
    md.push_str(&markdown::header(&[
        "followers (PLF)",
        "common P (s)",
        "ratio",
        "one P per follower (s)",
        "ratio",
        "largest decay (s)",
        "spectrum (s)",
        "string stability (s)",
        "all (s)",
    ]));
    for r in checks {
        let [common, block_diagonal, decay, spectrum, string, all] = [
            r.common_s,
            r.block_diagonal_s,
            r.max_decay_s,
            r.spectrum_s,
            r.string_stability_s,
            r.total_s,
        ]
        .map(|x| format!("{x:.2}"));
        markdown::row(
            md,
            &[
                &r.followers,
                &common,
                &ratio(r.common_ratio),
                &block_diagonal,
                &ratio(r.block_diagonal_ratio),
                &decay,
                &spectrum,
                &string,
                &all,
            ],
        );
    }
    if let Some(e) = growth_exponent(checks) {
        let _ = writeln!(
            md,
            "\nThe check time grows as N^{e:.2} (least squares on log-log). Target: under 60 s for N = 100."
        );
    }
}

/// BENCHMARKS.md's section of `platoon bench campaign`: the campaign throughput.
fn campaign_section(md: &mut String, commit: &str, campaigns: &[CampaignRow]) {
    let _ = writeln!(
        md,
        "\n## Campaign throughput (`platoon bench campaign`)\n\n{}",
        measured(commit, "bench campaign")
    );
    let _ = writeln!(
        md,
        "The paper scenario with a random admissible DoS schedule per cell, in process, metrics only, \
         no plots; wall time as campaign.json reports it (start-up, per-cell records and cells.csv \
         included). The Dask rows send the same cells to a scheduler and two single-threaded workers \
         on 127.0.0.1, beside the local pool with two jobs: in batches run in the workers' processes \
         on the platoon package's core, then (`PLATOON_DASK_IN_WORKER=0`) with a \
         `platoon campaign-cell` process per cell on its worker.\n"
    );
    md.push_str(&markdown::header(&[
        "executor",
        "cells",
        "wall (s)",
        "CPU (s)",
        "cells/s",
        "ms per cell",
    ]));
    for r in campaigns {
        markdown::row(
            md,
            &[
                &r.executor,
                &r.cells,
                &format_args!("{:.2}", r.wall_s),
                &format_args!("{:.2}", r.cpu_s),
                &format_args!("{:.0}", r.cells_per_s),
                &format_args!("{:.2}", r.ms_per_cell),
            ],
        );
    }
    if let Some(r) = campaigns
        .iter()
        .find(|r| r.part == "throughput" && r.workers == 2)
    {
        let _ = writeln!(
            md,
            "\n1000 cells on 2 jobs: {:.2} s (target <= 10 s: {}).",
            r.wall_s,
            if r.wall_s <= 10.0 { "met" } else { "missed" }
        );
    }
    let channel: Vec<&CampaignRow> = campaigns.iter().filter(|r| r.part == "channel").collect();
    if let [bernoulli, radio] = channel[..] {
        let ratio = radio.ms_per_cell / bernoulli.ms_per_cell;
        let _ = writeln!(
            md,
            "A cell on the 802.11p channel costs {:.2} ms against {:.2} ms with Bernoulli loss \
             ({ratio:.2}x; target within 2x: {}).",
            radio.ms_per_cell,
            bernoulli.ms_per_cell,
            if ratio <= 2.0 { "met" } else { "missed" }
        );
    }
    let dask: Vec<&CampaignRow> = campaigns.iter().filter(|r| r.part == "dask").collect();
    if let [local, in_worker, process] = dask[..] {
        let ratio = in_worker.ms_per_cell / local.ms_per_cell;
        let _ = writeln!(
            md,
            "Through Dask a cell costs {:.2} ms of wall time in the workers' processes against \
             {:.2} ms in the local pool ({ratio:.2}x; target <= 1.5x: {}), and {:.2} ms ({:.1}x) \
             with a process per cell.",
            in_worker.ms_per_cell,
            local.ms_per_cell,
            if ratio <= 1.5 { "met" } else { "missed" },
            process.ms_per_cell,
            process.ms_per_cell / local.ms_per_cell
        );
        let fifth: Vec<&CampaignRow> = campaigns
            .iter()
            .filter(|r| r.part == "dask-fifth")
            .collect();
        if let [local_fifth, in_worker_fifth] = fifth[..] {
            // ms per cell between the two sizes, and what is left at zero cells (s).
            let slope = |big: &CampaignRow, small: &CampaignRow| {
                (big.wall_s - small.wall_s) / (big.cells - small.cells) as f64 * 1e3
            };
            let fixed = |big: &CampaignRow, ms: f64| big.wall_s - ms * 1e-3 * big.cells as f64;
            let (l, d) = (slope(local, local_fifth), slope(in_worker, in_worker_fifth));
            let ratio = d / l;
            let _ = writeln!(
                md,
                "Per cell beyond the fixed start-up (the slope between {} and {} cells): {d:.2} ms \
                 through Dask in the workers against {l:.2} ms in the local pool ({ratio:.2}x; \
                 target <= 1.5x: {}). Dask's fixed cost, the driver's start (a Python process \
                 importing distributed) and its connection, is {:.2} s against the local pool's \
                 {:.2} s.",
                in_worker_fifth.cells,
                in_worker.cells,
                if ratio <= 1.5 { "met" } else { "missed" },
                fixed(in_worker, d),
                fixed(local, l)
            );
        }
    }
}

/// BENCHMARKS.md's section of `platoon bench search`: the search's evaluations per second.
fn search_section(md: &mut String, commit: &str, searches: &[crate::search::SearchRow]) {
    let _ = writeln!(
        md,
        "\n## Worst-case DoS search (`platoon bench search`)\n\n{}",
        measured(commit, "bench search")
    );
    let _ = writeln!(
        md,
        "`platoon search`'s search alone (no baselines, no figures) on the paper scenario under its \
         Assumption 2, in process; wall time as search.json reports it (proposing, certifying, \
         running and measuring every candidate).\n"
    );
    md.push_str(&markdown::header(&[
        "jobs",
        "evaluations",
        "wall (s)",
        "evaluations/s",
        "ms per evaluation",
        "largest spacing error found (m)",
    ]));
    for r in searches {
        markdown::row(
            md,
            &[
                &r.jobs,
                &r.evaluations,
                &format_args!("{:.2}", r.wall_s),
                &format_args!("{:.0}", r.evaluations_per_s),
                &format_args!("{:.2}", r.ms_per_evaluation),
                &format_args!("{:.2}", r.harm),
            ],
        );
    }
    if let Some(r) = searches.iter().find(|r| r.jobs == 2) {
        let _ = writeln!(
            md,
            "\n1000 evaluations on 2 jobs: {:.2} s (target < 5 s: {}).",
            r.wall_s,
            if r.wall_s < 5.0 { "met" } else { "missed" }
        );
    }
}

/// Who measured a section, and at which commit.
fn measured(commit: &str, command: &str) -> String {
    format!("Measured by `platoon {command}` at commit `{commit}`.\n")
}

/// The subsections of a report measured by hand (a `### ` heading that says "(measured by
/// hand"), each up to the next heading of level 2 or 3, in order.
fn hand_sections(report: &str) -> String {
    let mut out = String::new();
    let mut keep = false;
    for line in report.lines() {
        if line.starts_with("## ") || line.starts_with("### ") {
            keep = line.starts_with("### ") && line.contains("(measured by hand");
        }
        if keep {
            out.push_str(line);
            out.push('\n');
        }
    }
    if !out.is_empty() && !out.ends_with("\n\n") {
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_measured_subsections_are_carried_over_and_nothing_else() {
        let old = "# Benchmarks\n\nintro\n\n## Step cost\n\n| generated |\n\n\
                   ### The loop in C++ (measured by hand, not by `platoon bench`)\n\nfig 1\n\n\
                   ### SUMO's FCD (measured by hand, not by `platoon bench`)\nfig 2\n\
                   ## LMI design time\n\n| generated |\n### Other\nno\n";
        assert_eq!(
            hand_sections(old),
            "### The loop in C++ (measured by hand, not by `platoon bench`)\n\nfig 1\n\n\
             ### SUMO's FCD (measured by hand, not by `platoon bench`)\nfig 2\n\n"
        );
        assert_eq!(hand_sections("# Benchmarks\n## A\n### B\n"), "");
    }
}
