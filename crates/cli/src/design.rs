//! `platoon design`: the arguments and what is printed; the checks, designs and certificates are
//! [`platoon_app::design`]'s.
use crate::outdir::OutDir;
use crate::{bail, Result};
use anyhow::Context;
use platoon_app::design::{
    self, BoundsOptions, CheckOptions, CheckReport, Synthesis, SynthesisOptions, Theorem,
};
use platoon_output::rundir::RunDir;
use std::path::PathBuf;

/// LMI design and checks (Theorems 1 and 2 of the paper, as readings R8 and R14-R21 of
/// docs/paper-readings.md read them).
#[derive(Debug, clap::Subcommand)]
pub enum Design {
    /// Evaluate a gain K on a scenario's topology: closed-loop eigenvalues over the tau range,
    /// the smallest beta1/beta2 for which Theorem 1's LMI (13) holds (an exact SDP for a fixed
    /// K) with a common Lyapunov matrix (I_N kron P) and with one P per follower
    /// (block-diagonal: it holds where the common one fails, at a transient growth it reports),
    /// the largest decay c the common one certifies, and string stability. Writes
    /// certificate.json (the smallest-ratio certificate), certificate-block-diagonal.json,
    /// certificate-max-decay.json, spectrum.csv and check.json.
    CheckGain(CheckGainArgs),
    /// Re-check a certificate independently of the solver: assemble (13) from its numbers and
    /// print the eigenvalue margin. Exits 1 if it does not hold.
    Verify {
        /// A certificate.json.
        file: PathBuf,
    },
    /// The DoS bounds (16): T2 > (2 ln phi + (s1 + s2) h) / s*, D2 > (s1 + s2) / (s1 - s*).
    Bounds(BoundsArgs),
    /// Design K and beta1/beta2 for Theorem 1 (or 2, robust) on a scenario's topology (Remark 1
    /// with its non-convex block linearised, a convex-concave procedure, bisection on
    /// beta1/beta2, and |K| <= --k-max so the gain stays usable at the run's step). The gain is
    /// then certified by the exact SDP. Writes certificate.json (which `platoon run --design`
    /// uses), certificate-max-decay.json and design.json (decay rates, DoS bounds (16) and the
    /// verdict on the config's attack schedule). An infeasible request writes nothing.
    Synthesize(SynthesizeArgs),
}

/// Arguments of `platoon design synthesize`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/design]")))]
pub struct SynthesizeArgs {
    /// Scenario config (its topology and nominal tau) [default: the embedded paper config].
    pub config: Option<PathBuf>,
    /// Decay parameter c.
    #[arg(long, default_value_t = SynthesisOptions::default().c)]
    pub c: f64,
    /// Bound on |K| (2-norm).
    #[arg(long, default_value_t = SynthesisOptions::default().k_max)]
    pub k_max: f64,
    /// 1: the nominal tau; 2: both ends of the config's tau range (robust).
    #[arg(long, default_value_t = SynthesisOptions::default().theorem.number(), value_parser = clap::value_parser!(u8).range(1..=2))]
    pub theorem: u8,
    /// Largest beta1/beta2 tried.
    #[arg(long, default_value_t = SynthesisOptions::default().ratio_max)]
    pub ratio_max: f64,
    /// The spacing policy's time headway h_t (s), overriding the config's
    /// (`platoon.spacing_policy`): 0 for constant spacing. (13) is then imposed on the
    /// time-headway error dynamics (docs/long-platoons.md, "Error dynamics and Theorem 1").
    #[arg(long, value_name = "SECONDS")]
    pub time_headway: Option<f64>,
    /// varsigma* as a fraction of varsigma1, in (0, 1): trades the dwell-time bound T2 against
    /// the duration bound D2 of (16).
    #[arg(long, default_value_t = SynthesisOptions::default().star_fraction)]
    pub star_fraction: f64,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon design check-gain`.
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/design-check]")))]
pub struct CheckGainArgs {
    /// Scenario config (its topology, tau range and gain) [default: the embedded paper config].
    pub config: Option<PathBuf>,
    /// The gain to check, "k1,k2,k3" [default: the config's control.gain].
    #[arg(long, value_name = "K1,K2,K3")]
    pub gain: Option<String>,
    /// Decay parameter c for the smallest-ratio SDP.
    #[arg(long, default_value_t = CheckOptions::default().c)]
    pub c: f64,
    /// 1: (13) at the nominal tau; 2: at both ends of the config's tau range with one P
    /// (robust to every tau between; our reading of Theorem 2: docs/paper-readings.md#R18).
    #[arg(long, default_value_t = CheckOptions::default().theorem.number(), value_parser = clap::value_parser!(u8).range(1..=2))]
    pub theorem: u8,
    /// The spacing policy's time headway h_t (s), overriding the config's
    /// (`platoon.spacing_policy`): 0 for constant spacing. (13) is then imposed on the
    /// time-headway error dynamics (docs/long-platoons.md, "Error dynamics and Theorem 1").
    #[arg(long, value_name = "SECONDS")]
    pub time_headway: Option<f64>,
    #[command(flatten)]
    pub output: OutDir,
}

/// Arguments of `platoon design bounds`.
#[derive(Debug, clap::Args)]
pub struct BoundsArgs {
    /// varsigma1, the decay rate without attacks.
    #[arg(long, default_value_t = BoundsOptions::default().varsigma1)]
    pub varsigma1: f64,
    /// varsigma2, the growth rate under attack.
    #[arg(long, default_value_t = BoundsOptions::default().varsigma2)]
    pub varsigma2: f64,
    /// varsigma*, in (0, varsigma1).
    #[arg(long, default_value_t = BoundsOptions::default().varsigma_star)]
    pub varsigma_star: f64,
    /// phi, the gain scheduler between the two Lyapunov functions.
    #[arg(long, default_value_t = BoundsOptions::default().phi)]
    pub phi: f64,
    /// h, the resilient sampling period (s).
    #[arg(long, default_value_t = BoundsOptions::default().h)]
    pub h: f64,
}

pub fn run(d: Design) -> Result<()> {
    match d {
        Design::CheckGain(a) => check_gain(a),
        Design::Verify { file } => verify(file),
        Design::Synthesize(a) => synthesize(a),
        Design::Bounds(b) => {
            let (t2, d2) = design::bounds(&BoundsOptions {
                varsigma1: b.varsigma1,
                varsigma2: b.varsigma2,
                varsigma_star: b.varsigma_star,
                phi: b.phi,
                h: b.h,
            })?;
            println!("T2 > {t2:.2}");
            println!("D2 > {d2:.2}");
            Ok(())
        }
    }
}

/// `--theorem`, 1 or 2 (clap checks the range).
fn theorem(n: u8) -> Theorem {
    Theorem::from_number(n).expect("clap keeps --theorem in 1..=2")
}

fn parse_gain(s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .trim_start_matches("K=")
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--gain {s:?}: expected three numbers like 4.81,9.12,2.97"))?;
    match v.as_slice() {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, *c]),
        _ => bail!("--gain {s:?}: expected three finite numbers like 4.81,9.12,2.97"),
    }
}

fn print_string(report: &[platoon_synthesis::StringStability]) {
    for r in report {
        let worst = r
            .per_tau
            .iter()
            .max_by(|a, b| a.amplification.total_cmp(&b.amplification));
        if let Some(w) = worst {
            println!(
                "  string stability, {} followers: {} (a disturbance at follower 1 reaches follower {} amplified {:.3e}x, {:.4}x per follower, at {:.2} rad/s, tau = {} s)",
                r.followers,
                if r.string_stable { "string stable" } else { "STRING UNSTABLE: spacing errors grow along the platoon" },
                r.followers,
                w.amplification,
                w.per_follower,
                w.at_rad_s,
                w.tau
            );
        }
    }
}

fn check_gain(a: CheckGainArgs) -> Result<()> {
    let platoon_config::Loaded {
        config, scenario, ..
    } = platoon_config::load_or(a.config.as_deref(), platoon_config::Embedded::Paper)?;
    let opts = CheckOptions {
        gain: a.gain.as_deref().map(parse_gain).transpose()?,
        c: a.c,
        theorem: theorem(a.theorem),
        time_headway: a.time_headway,
    };
    opts.validate()?;
    let dir = RunDir::create(&a.output.path_or("runs/design-check"), a.output.force)?;
    let report = design::check_gain(&config, &scenario, &opts)?;
    report.write(&dir)?;
    let path = dir.commit()?;
    print_check(&report);
    println!("outputs: {}", path.display());
    if !report.certified() {
        // A script tells by the exit status (1), the files are written all the same.
        return Err(anyhow::anyhow!(
            "K = [{}, {}, {}] is NOT certified for this config's beta1/beta2 = {:.2} (see above \
             and {})",
            report.k[0],
            report.k[1],
            report.k[2],
            report.config_ratio,
            path.join("check.json").display()
        )
        .into());
    }
    Ok(())
}

fn print_check(report: &CheckReport) {
    let CheckReport {
        k,
        topology_followers: n,
        tau_range: (lo, hi),
        worst_max_real: worst,
        fastest_mode: fastest,
        config_ratio,
        ..
    } = *report;
    println!(
        "K = [{}, {}, {}] on {n} followers, {}",
        k[0],
        k[1],
        k[2],
        platoon_control::SpacingPolicy::from_headway(report.time_headway_s)
    );
    print_string(&report.string_stability);
    println!(
        "  closed loop over tau in [{lo}, {hi}] s: {} (largest real part {worst:.4}, fastest mode {fastest:.1} rad/s)",
        if worst < 0.0 { "stable" } else { "UNSTABLE" }
    );
    let taus_lmi = &report.lmi_taus;
    match report.min_ratio_at_c {
        Some((c, r)) => println!(
            "  Theorem {} (13) at tau = {taus_lmi:?}, c = {c}: smallest beta1/beta2 = {r:.2} ({:.2} s); the config's {config_ratio:.2} is {}",
            report.theorem.number(),
            report.sdp_seconds,
            if report.config_ratio_certified { "certified" } else { "NOT certified" }
        ),
        None => println!(
            "  Theorem {} (13) at tau = {taus_lmi:?}, c = {}: INFEASIBLE for this K",
            report.theorem.number(),
            report.c
        ),
    }
    if let Some(m) = &report.heterogeneous {
        println!(
            "  mixed vehicles, each follower its own lag range {:?} s: at the {} vertices the closed loop is {} (largest real part {:.4}); (13) with the common P {}",
            m.tau_ranges,
            m.vertices,
            if m.worst_max_real < 0.0 { "stable" } else { "UNSTABLE" },
            m.worst_max_real,
            match m.max_eigenvalue {
                Some(e) if m.certified => format!("holds at every vertex (largest eigenvalue {e:.3e}): certified for every lag in the box"),
                Some(e) => format!("FAILS at a vertex (largest eigenvalue {e:.3e}): NOT certified"),
                None => "was not found: NOT certified".to_string(),
            }
        );
        println!(
            "  mixed vehicles, the direct SDP over the {} vertices (one P per follower): {}",
            m.vertices,
            match (m.direct_min_ratio, m.direct_max_eigenvalue) {
                (Some(r), Some(e)) if e < 0.0 => format!(
                    "smallest beta1/beta2 = {r:.2} (re-checked, largest eigenvalue {e:.3e}, the error may grow {:.1}x before it decays); the config's {config_ratio:.2} is {}",
                    m.direct_transient_growth.unwrap_or(f64::NAN),
                    if config_ratio >= r { "certified" } else { "NOT certified" }
                ),
                (Some(r), _) => format!("beta1/beta2 = {r:.2} fails the re-check: NOT certified"),
                _ => "INFEASIBLE for this K".to_string(),
            }
        );
    }
    match &report.block_diagonal {
        Some(b) => println!(
            "  with one P per follower (block-diagonal): smallest beta1/beta2 = {:.2}, the error may grow {:.1}x before it decays; the config's {config_ratio:.2} is {}",
            b.min_ratio,
            b.transient_growth,
            if b.config_ratio_certified { "certified" } else { "NOT certified" }
        ),
        None => println!(
            "  with one P per follower (block-diagonal): INFEASIBLE too (within delta I <= P_i <= {:.0e} I)",
            platoon_synthesis::P_MAX
        ),
    }
    match &report.max_decay {
        Some(c) => println!(
            "  largest certified decay c = {:.3} (beta1/beta2 = {:.2})",
            c.c, c.ratio
        ),
        None => println!("  no decay c >= 0 is certified"),
    }
}

fn verify(file: PathBuf) -> Result<()> {
    let cert = design::read_certificate(&file)?;
    let v = design::verify(&cert)?;
    println!(
        "{}: {} (13) {} (largest eigenvalue {:.4e}, margin {:.4e}; smallest eigenvalue of P {:.4e}; transient growth {:.2}x)",
        file.display(),
        cert.condition,
        if v.holds { "holds" } else { "does NOT hold" },
        v.max_eigenvalue,
        -v.max_eigenvalue,
        v.p_min_eigenvalue,
        v.transient_growth
    );
    if !v.holds {
        bail!("the certificate does not hold");
    }
    Ok(())
}

fn synthesize(a: SynthesizeArgs) -> Result<()> {
    let opts = SynthesisOptions {
        c: a.c,
        k_max: a.k_max,
        theorem: theorem(a.theorem),
        ratio_max: a.ratio_max,
        time_headway: a.time_headway,
        star_fraction: a.star_fraction,
    };
    opts.validate()?;
    let platoon_config::Loaded {
        config, scenario, ..
    } = platoon_config::load_or(a.config.as_deref(), platoon_config::Embedded::Paper)?;
    let out = a.output.path_or("runs/design");
    if out.exists() && !a.output.force {
        bail!(
            "output directory {} exists; choose another --out or pass --force to replace it",
            out.display()
        );
    }
    // Nothing is written for an infeasible request: the directory is opened once it succeeded.
    let s = design::synthesize(&config, &scenario, &opts)?;
    let dir = RunDir::create(&out, a.output.force)?;
    s.write(&dir)?;
    let path = dir.commit()?;
    print_synthesis(&s, &opts, scenario.topology.followers())?;
    println!("outputs: {}", path.display());
    Ok(())
}

fn print_synthesis(s: &Synthesis, opts: &SynthesisOptions, n: usize) -> Result<()> {
    let Synthesis {
        design: d, report, ..
    } = s;
    let norm = d.k.iter().map(|x| x * x).sum::<f64>().sqrt();
    let policy = platoon_control::SpacingPolicy::from_headway(report.time_headway_s);
    print_string(&report.string_stability);
    println!(
        "K = [{:.4}, {:.4}, {:.4}] (|K| = {norm:.2} <= {}), beta1/beta2 = {:.2} on {n} followers, {policy}",
        d.k[0], d.k[1], d.k[2], opts.k_max, d.certificate.ratio
    );
    println!(
        "  certified by the exact SDP of {} at tau = {:?} (margin {:.2e}{}); {} SDPs in {:.2} s",
        d.certificate.condition,
        d.certificate.taus,
        -d.certificate.max_eigenvalue,
        match &d.certificate.p_blocks {
            Some(_) => format!(
                ", one P per follower: the error may grow {:.1}x before it decays",
                d.certificate.transient_growth()?
            ),
            None => String::new(),
        },
        d.sdps,
        report.seconds
    );
    if d.designed_on < n {
        println!(
            "  designed on the first {} followers (with {}), certified on all {n}",
            d.designed_on,
            if report.time_headway_s > 0.0 {
                "a time headway the procedure is not linear"
            } else {
                "constant spacing the whole platoon admits no common P for this procedure"
            }
        );
    }
    println!(
        "  varsigma1 = {:.4} (c = {:.4}, trigger cap {:.4}), varsigma2 = {:.4}, varsigma* = {:.4}, phi = 1",
        report.varsigma1, report.c, s.trigger_cap, report.varsigma2, report.varsigma_star
    );
    if let (Some(t2), Some(d2)) = (report.t2_bound, report.d2_bound) {
        println!("  DoS bounds (16): T2 > {t2:.2}, D2 > {d2:.2}");
    }
    if let Some(v) = &report.schedule_verdict {
        println!("  {v}");
    }
    Ok(())
}
