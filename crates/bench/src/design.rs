//! `platoon bench design`: LMI design time and the time of `design check-gain`'s checks
//! against the number of followers.
use crate::step::fit;
use anyhow::{bail, Result};
use std::path::PathBuf;
use std::time::Instant;

/// What `platoon bench design` measures.
#[derive(Debug, Clone)]
pub struct Design {
    /// Numbers of followers of the designs.
    pub followers: Vec<usize>,
    /// Numbers of followers of the checks (PLF, the paper's K).
    pub check_followers: Vec<usize>,
    /// Output directory; None: runs/bench-design.
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    pub force: bool,
}

impl Default for Design {
    fn default() -> Self {
        Self {
            followers: vec![4, 10, 20],
            check_followers: vec![10, 25, 50, 100],
            out: None,
            force: false,
        }
    }
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct DesignRow {
    pub followers: usize,
    pub seconds: f64,
    pub sdps: usize,
    pub feasible: bool,
    pub beta1_over_beta2: Option<f64>,
    /// `theorem1` (common P) or `theorem1-block-diagonal`.
    pub certificate: Option<String>,
    /// The followers the procedure ran on.
    pub designed_on: Option<usize>,
}

/// One measured `check-gain` on PLF.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CheckRow {
    pub followers: usize,
    /// The smallest ratio with I_N kron P (one SDP and its re-check).
    pub common_s: f64,
    pub common_ratio: Option<f64>,
    /// The same with one P per follower.
    pub block_diagonal_s: f64,
    pub block_diagonal_ratio: Option<f64>,
    /// The largest-decay bisection.
    pub max_decay_s: f64,
    /// The closed-loop spectrum at 51 taus over the paper's tau range.
    pub spectrum_s: f64,
    /// String stability at the paper's smallest, nominal and largest tau.
    pub string_stability_s: f64,
    /// Everything above: what `design check-gain` computes for this platoon.
    pub total_s: f64,
}

/// Runs `platoon bench design`.
pub fn design(a: Design) -> Result<(Vec<DesignRow>, Vec<CheckRow>)> {
    if a.followers.is_empty() || a.followers.contains(&0) || a.check_followers.contains(&0) {
        bail!("--followers and --check-followers need positive platoon sizes, e.g. 4,10,20");
    }
    let dir = crate::create_out(a.out, "bench-design", a.force)?;
    let mut rows = Vec::new();
    for &n in &a.followers {
        eprintln!("designing for {n} followers (TPSF) ...");
        let t = platoon_topology::Topology::preset(platoon_topology::Preset::Tpsf, n)?;
        let h = platoon_synthesis::Coupling::constant(t.h_matrix());
        let started = Instant::now();
        let d = platoon_synthesis::design_theorem1(&Default::default(), &h)?;
        rows.push(DesignRow {
            followers: n,
            seconds: started.elapsed().as_secs_f64(),
            sdps: d.as_ref().map_or(0, |d| d.sdps),
            feasible: d.is_some(),
            beta1_over_beta2: d.as_ref().map(|d| d.certificate.ratio),
            certificate: d.as_ref().map(|d| d.certificate.condition.clone()),
            designed_on: d.as_ref().map(|d| d.designed_on),
        });
    }
    // The tau grids of `design check-gain` for the paper scenario: 51 taus over its range for
    // the spectrum; its smallest, nominal and largest for string stability.
    let (_, paper) = platoon_config::Embedded::Paper.parse()?;
    let (lo, hi) = paper.tau_range();
    let spectrum_taus: Vec<f64> = (0..=50)
        .map(|i| lo + (hi - lo) * f64::from(i) / 50.0)
        .collect();
    let mut string_taus = vec![lo, paper.control.tau_nominal, hi];
    string_taus.sort_by(f64::total_cmp);
    string_taus.dedup();
    let mut checks = Vec::new();
    for &n in &a.check_followers {
        eprintln!("checking the paper's K on {n} followers (PLF) ...");
        let t = platoon_topology::Topology::preset(platoon_topology::Preset::Plf, n)?;
        let g = platoon_synthesis::Coupling::constant(t.h_matrix());
        let k = [4.81, 9.12, 2.97];
        let ratio = |f: platoon_synthesis::Feasibility| match f {
            platoon_synthesis::Feasibility::Feasible(c) => Some(c.ratio),
            platoon_synthesis::Feasibility::Infeasible => None,
        };
        let started = Instant::now();
        let common = ratio(platoon_synthesis::min_ratio(
            k,
            0.0,
            &g,
            &[0.5],
            1e-6,
            platoon_synthesis::LyapunovForm::Common,
        )?);
        let common_s = started.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let block = ratio(platoon_synthesis::min_ratio(
            k,
            0.0,
            &g,
            &[0.5],
            1e-6,
            platoon_synthesis::LyapunovForm::BlockDiagonal,
        )?);
        let block_s = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        platoon_synthesis::theorem1_max_decay(k, &g, &[0.5], 10.0, 1e-3)?;
        let max_decay_s = t2.elapsed().as_secs_f64();
        let t3 = Instant::now();
        std::hint::black_box(platoon_synthesis::closed_loop_spectrum(
            k,
            &g,
            &spectrum_taus,
        ));
        let spectrum_s = t3.elapsed().as_secs_f64();
        let t4 = Instant::now();
        std::hint::black_box(platoon_synthesis::string_stability(k, &g, &string_taus));
        let string_stability_s = t4.elapsed().as_secs_f64();
        checks.push(CheckRow {
            followers: n,
            common_s,
            common_ratio: common,
            block_diagonal_s: block_s,
            block_diagonal_ratio: block,
            max_decay_s,
            spectrum_s,
            string_stability_s,
            total_s: started.elapsed().as_secs_f64(),
        });
    }
    let mut csv = csv::Writer::from_writer(dir.writer("design.csv")?);
    for r in &rows {
        csv.serialize(r)?;
    }
    csv.flush()?;
    let mut csv = csv::Writer::from_writer(dir.writer("check.csv")?);
    for r in &checks {
        csv.serialize(r)?;
    }
    csv.flush()?;
    let path = dir.commit()?;
    for r in &rows {
        println!(
            "N = {:>3}: {:>7.2} s, {:>3} SDPs, {}{}",
            r.followers,
            r.seconds,
            r.sdps,
            r.beta1_over_beta2
                .map_or("infeasible".to_string(), |x| format!(
                    "beta1/beta2 = {x:.1}"
                )),
            match (&r.certificate, r.designed_on) {
                (Some(c), Some(on)) => format!(" ({c}, designed on {on} followers)"),
                _ => String::new(),
            }
        );
    }
    for r in &checks {
        println!(
            "check, N = {:>3} (PLF): {:>6.2} s in all (common P {:.2} s, one P per follower {:.2} s, largest decay {:.2} s, spectrum {:.2} s, string stability {:.2} s)",
            r.followers, r.total_s, r.common_s, r.block_diagonal_s, r.max_decay_s, r.spectrum_s, r.string_stability_s
        );
    }
    if let Some(e) = growth_exponent(&checks) {
        println!("check time grows as N^{e:.2}");
    }
    println!("outputs: {}", path.display());
    Ok((rows, checks))
}

/// The slope of log(total time) against log(N): the check time grows as N^slope.
pub(crate) fn growth_exponent(checks: &[CheckRow]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = checks
        .iter()
        .map(|r| ((r.followers as f64).ln(), r.total_s.ln()))
        .collect();
    let (_, b) = fit(&pts);
    b.is_finite().then_some(b)
}
