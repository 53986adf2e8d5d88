//! `platoon design`: Theorem 1 checks of a gain on clarabel's SDP solver, certificates and their
//! independent re-check, and the DoS bounds (16).
use anyhow::{bail, Context, Result};
use platoon_output::rundir::RunDir;
use platoon_synthesis::{
    closed_loop_spectrum, dos_bounds, min_ratio, theorem1_max_decay, Certificate, Coupling,
    Feasibility,
};
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
pub struct SynthesizeArgs {
    /// Scenario config (its topology and nominal tau) [default: the embedded paper config].
    pub config: Option<PathBuf>,
    /// Decay parameter c.
    #[arg(long, default_value_t = 0.0)]
    pub c: f64,
    /// Bound on |K| (2-norm).
    #[arg(long, default_value_t = 20.0)]
    pub k_max: f64,
    /// 1: the nominal tau; 2: both ends of the config's tau range (robust).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub theorem: u8,
    /// Largest beta1/beta2 tried.
    #[arg(long, default_value_t = 1e4)]
    pub ratio_max: f64,
    /// The spacing policy's time headway h_t (s), overriding the config's
    /// (`platoon.spacing_policy`): 0 for constant spacing. (13) is then imposed on the
    /// time-headway error dynamics (README, "Time headway").
    #[arg(long, value_name = "SECONDS")]
    pub time_headway: Option<f64>,
    /// varsigma* as a fraction of varsigma1, in (0, 1): trades the dwell-time bound T2 against
    /// the duration bound D2 of (16).
    #[arg(long, default_value_t = 0.5)]
    pub star_fraction: f64,
    /// Output directory [default: runs/design].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `platoon design check-gain`.
#[derive(Debug, clap::Args)]
pub struct CheckGainArgs {
    /// Scenario config (its topology, tau range and gain) [default: the embedded paper config].
    pub config: Option<PathBuf>,
    /// The gain to check, "k1,k2,k3" [default: the config's control.gain].
    #[arg(long, value_name = "K1,K2,K3")]
    pub gain: Option<String>,
    /// Decay parameter c for the smallest-ratio SDP.
    #[arg(long, default_value_t = 0.0)]
    pub c: f64,
    /// 1: (13) at the nominal tau; 2: at both ends of the config's tau range with one P
    /// (robust to every tau between; our reading of Theorem 2: docs/paper-readings.md#R18).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub theorem: u8,
    /// The spacing policy's time headway h_t (s), overriding the config's
    /// (`platoon.spacing_policy`): 0 for constant spacing. (13) is then imposed on the
    /// time-headway error dynamics (README, "Time headway").
    #[arg(long, value_name = "SECONDS")]
    pub time_headway: Option<f64>,
    /// Output directory [default: runs/design-check].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `platoon design bounds`.
#[derive(Debug, clap::Args)]
pub struct BoundsArgs {
    /// varsigma1, the decay rate without attacks.
    #[arg(long, default_value_t = 0.41)]
    pub varsigma1: f64,
    /// varsigma2, the growth rate under attack.
    #[arg(long, default_value_t = 0.27)]
    pub varsigma2: f64,
    /// varsigma*, in (0, varsigma1).
    #[arg(long, default_value_t = 0.35)]
    pub varsigma_star: f64,
    /// phi, the gain scheduler between the two Lyapunov functions.
    #[arg(long, default_value_t = 5.2)]
    pub phi: f64,
    /// h, the resilient sampling period (s).
    #[arg(long, default_value_t = 0.02)]
    pub h: f64,
}

pub fn run(d: Design) -> Result<()> {
    match d {
        Design::CheckGain(a) => check_gain(a),
        Design::Verify { file } => verify(file),
        Design::Synthesize(a) => synthesize(a),
        Design::Bounds(b) => {
            let (t2, d2) = dos_bounds(b.varsigma1, b.varsigma2, b.varsigma_star, b.phi, b.h)?;
            println!("T2 > {t2:.2}");
            println!("D2 > {d2:.2}");
            Ok(())
        }
    }
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

/// The scenario's graph and spacing policy, the policy's headway replaced by `time_headway`
/// when given.
fn coupling(scenario: &platoon_sim::Scenario, time_headway: Option<f64>) -> Result<Coupling> {
    let headway = time_headway.unwrap_or(scenario.headway());
    if !(headway.is_finite() && headway >= 0.0) {
        bail!("--time-headway {headway}: must be a finite number of seconds >= 0 (0: constant spacing)");
    }
    Ok(Coupling::time_headway(
        scenario.topology.h_matrix(),
        headway,
    ))
}

/// "constant spacing" or "time headway 0.5 s".
fn policy(g: &Coupling) -> String {
    platoon_control::SpacingPolicy::from_headway(g.headway).to_string()
}

/// String stability of `k` for the config's platoon and, for a preset topology, for the same
/// preset with 100 followers (where string instability shows): at the config's tau range, with
/// the spacing policy of `g`.
fn string_report(
    k: [f64; 3],
    config: &platoon_config::Config,
    scenario: &platoon_sim::Scenario,
    g: &Coupling,
) -> Vec<platoon_synthesis::StringStability> {
    let (lo, hi) = scenario.tau_range();
    let mut taus = vec![lo, scenario.control.tau_nominal, hi];
    taus.sort_by(f64::total_cmp);
    taus.dedup();
    let mut out = vec![platoon_synthesis::string_stability(k, g, &taus)];
    let preset = platoon_topology::Preset::from_name(&config.topology.preset);
    if let Some(p) = preset.filter(|_| scenario.topology.followers() < 100) {
        if let Ok(t) = platoon_topology::Topology::preset(p, 100) {
            let long = Coupling::time_headway(t.h_matrix(), g.headway);
            out.push(platoon_synthesis::string_stability(k, &long, &taus));
        }
    }
    out
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

#[derive(serde::Serialize)]
struct CheckReport {
    k: [f64; 3],
    topology_followers: usize,
    /// The time headway the conditions were imposed with (s; 0: constant spacing).
    time_headway_s: f64,
    tau_nominal: f64,
    tau_range: (f64, f64),
    stable_over_tau_range: bool,
    worst_max_real: f64,
    fastest_mode: f64,
    min_ratio_at_c: Option<(f64, f64)>,
    config_ratio: f64,
    config_ratio_certified: bool,
    max_decay_c: Option<f64>,
    /// Theorem 1 at c with one Lyapunov block per follower (certificate-block-diagonal.json);
    /// None where that is infeasible too.
    block_diagonal: Option<BlockReport>,
    /// Whether spacing errors grow along the platoon (see platoon_synthesis::string).
    string_stability: Vec<platoon_synthesis::StringStability>,
}

/// The block-diagonal certificate in `check.json`.
#[derive(serde::Serialize)]
struct BlockReport {
    min_ratio: f64,
    /// sqrt(lambda_max / lambda_min) over every block: the bound on how far the tracking error
    /// may grow before it decays.
    transient_growth: f64,
    config_ratio_certified: bool,
}

fn check_gain(a: CheckGainArgs) -> Result<()> {
    let platoon_config::Loaded {
        config, scenario, ..
    } = platoon_config::load_or(a.config.as_deref(), platoon_config::Embedded::Paper)?;
    let k = match &a.gain {
        Some(g) => parse_gain(g)?,
        None => config.control.gain,
    };
    let n = scenario.topology.followers();
    let g = coupling(&scenario, a.time_headway)?;
    let tau = scenario.control.tau_nominal;
    let (lo, hi) = scenario.tau_range();
    let taus: Vec<f64> = (0..=50)
        .map(|i| lo + (hi - lo) * f64::from(i) / 50.0)
        .collect();
    let spectrum = closed_loop_spectrum(k, &g, &taus);
    let taus_lmi = if a.theorem == 2 {
        vec![lo, hi]
    } else {
        vec![tau]
    };
    let worst = spectrum
        .iter()
        .map(|s| s.max_real)
        .fold(f64::NEG_INFINITY, f64::max);
    let fastest = spectrum.iter().map(|s| s.max_modulus).fold(0.0, f64::max);

    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("design-check"));
    let dir = RunDir::create(&out, a.force)?;
    let mut csv = csv::Writer::from_writer(dir.writer("spectrum.csv")?);
    for s in &spectrum {
        csv.serialize(s)?;
    }
    csv.flush()?;

    let started = std::time::Instant::now();
    let min = min_ratio(k, a.c, &g, &taus_lmi, 1e-6)?;
    let sdp_s = started.elapsed().as_secs_f64();
    let config_ratio = config.control.beta1 / config.control.beta2;
    let (min_ratio, certified) = match &min {
        Feasibility::Feasible(cert) => {
            dir.write(
                "certificate.json",
                (serde_json::to_string_pretty(cert)? + "\n").as_bytes(),
            )?;
            let mut at_config = cert.clone();
            at_config.ratio = config_ratio;
            (
                Some((a.c, cert.ratio)),
                config_ratio >= cert.ratio && at_config.verify()?.holds,
            )
        }
        Feasibility::Infeasible => (None, false),
    };
    // The richer certificate: one P per follower (it holds where I_N kron P does not, e.g. PF
    // and TPSF beyond a few followers, at the price of a transient growth).
    let block = match platoon_synthesis::min_ratio_block_diagonal(k, a.c, &g, &taus_lmi, 1e-6)? {
        Feasibility::Feasible(cert) => {
            dir.write(
                "certificate-block-diagonal.json",
                (serde_json::to_string_pretty(&cert)? + "\n").as_bytes(),
            )?;
            let mut at_config = cert.clone();
            at_config.ratio = config_ratio;
            Some(BlockReport {
                min_ratio: cert.ratio,
                transient_growth: cert.transient_growth()?,
                config_ratio_certified: config_ratio >= cert.ratio && at_config.verify()?.holds,
            })
        }
        Feasibility::Infeasible => None,
    };
    let best = theorem1_max_decay(k, &g, &taus_lmi, 10.0, 1e-3)?;
    if let Some(cert) = &best {
        dir.write(
            "certificate-max-decay.json",
            (serde_json::to_string_pretty(cert)? + "\n").as_bytes(),
        )?;
    }
    let report = CheckReport {
        k,
        topology_followers: n,
        time_headway_s: g.headway,
        tau_nominal: tau,
        tau_range: (lo, hi),
        stable_over_tau_range: worst < 0.0,
        worst_max_real: worst,
        fastest_mode: fastest,
        min_ratio_at_c: min_ratio,
        config_ratio,
        config_ratio_certified: certified,
        max_decay_c: best.as_ref().map(|c| c.c),
        block_diagonal: block,
        string_stability: string_report(k, &config, &scenario, &g),
    };
    dir.write(
        "check.json",
        (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;

    println!(
        "K = [{}, {}, {}] on {n} followers, {}",
        k[0],
        k[1],
        k[2],
        policy(&g)
    );
    print_string(&report.string_stability);
    println!(
        "  closed loop over tau in [{lo}, {hi}] s: {} (largest real part {worst:.4}, fastest mode {fastest:.1} rad/s)",
        if worst < 0.0 { "stable" } else { "UNSTABLE" }
    );
    match min_ratio {
        Some((c, r)) => println!(
            "  Theorem {} (13) at tau = {taus_lmi:?}, c = {c}: smallest beta1/beta2 = {r:.2} ({sdp_s:.2} s); the config's {config_ratio:.2} is {}",
            a.theorem,
            if certified { "certified" } else { "NOT certified" }
        ),
        None => println!(
            "  Theorem {} (13) at tau = {taus_lmi:?}, c = {}: INFEASIBLE for this K",
            a.theorem, a.c
        ),
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
    match &best {
        Some(c) => println!(
            "  largest certified decay c = {:.3} (beta1/beta2 = {:.2})",
            c.c, c.ratio
        ),
        None => println!("  no decay c >= 0 is certified"),
    }
    println!("outputs: {}", path.display());
    Ok(())
}

fn verify(file: PathBuf) -> Result<()> {
    let text =
        std::fs::read_to_string(&file).with_context(|| format!("reading {}", file.display()))?;
    let cert: Certificate = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a certificate", file.display()))?;
    let v = cert.verify()?;
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

/// What `design.json` holds: the design, its decay figures, the DoS bounds (16) and the
/// verdict on the config's attack schedule.
#[derive(serde::Serialize)]
struct DesignReport {
    theorem: u8,
    /// The time headway the conditions were imposed with (s; 0: constant spacing).
    time_headway_s: f64,
    k: [f64; 3],
    beta1: f64,
    beta2: f64,
    beta1_over_beta2: f64,
    c: f64,
    p: [[f64; 3]; 3],
    /// Remark 1's variables for this P: M = P^-1 and U = K M.
    m: [[f64; 3]; 3],
    u: [f64; 3],
    /// The Lyapunov matrix during attacks (we take Q = P, hence phi = 1).
    q: [[f64; 3]; 3],
    varsigma1: f64,
    varsigma2: f64,
    varsigma_star: f64,
    phi: f64,
    t2_bound: Option<f64>,
    d2_bound: Option<f64>,
    schedule_verdict: Option<String>,
    certificate: &'static str,
    certificate_max_decay: Option<&'static str>,
    sdps: usize,
    /// The followers the procedure ran on (the certificate is for all of them).
    designed_on: usize,
    seconds: f64,
    /// Whether spacing errors grow along the platoon with this gain.
    string_stability: Vec<platoon_synthesis::StringStability>,
}

fn synthesize(a: SynthesizeArgs) -> Result<()> {
    if !(a.star_fraction > 0.0 && a.star_fraction < 1.0) {
        bail!("--star-fraction must be in (0, 1)");
    }
    let platoon_config::Loaded {
        config, scenario, ..
    } = platoon_config::load_or(a.config.as_deref(), platoon_config::Embedded::Paper)?;
    let n = scenario.topology.followers();
    let g = coupling(&scenario, a.time_headway)?;
    let tau = scenario.control.tau_nominal;
    let (lo, hi) = scenario.tau_range();
    let taus = if a.theorem == 2 {
        vec![lo, hi]
    } else {
        vec![tau]
    };
    let spec = platoon_synthesis::DesignSpec {
        c: a.c,
        taus: taus.clone(),
        k_max: a.k_max,
        ratio_max: a.ratio_max,
        ..Default::default()
    };
    let out = a
        .out
        .unwrap_or_else(|| PathBuf::from("runs").join("design"));
    if out.exists() && !a.force {
        bail!(
            "output directory {} exists; choose another --out or pass --force to replace it",
            out.display()
        );
    }
    let started = std::time::Instant::now();
    let design = platoon_synthesis::design_theorem1(&spec, &g)?;
    let Some(d) = design else {
        // Nothing is written for an infeasible request.
        bail!(
            "infeasible: no gain with |K| <= {} satisfies Theorem {} on this topology ({n} followers, {}) with beta1/beta2 <= {} at c = {} ({:.2} s); raise --k-max or --ratio-max, or lower --c{}",
            a.k_max, a.theorem, policy(&g), a.ratio_max, a.c, started.elapsed().as_secs_f64(),
            if g.headway > 0.0 { "; with a time headway the gain is designed for constant spacing and then checked, so a smaller --time-headway may pass" } else { "" }
        );
    };
    // The decay it guarantees (ratio kept within twice the design's) and what DoS it tolerates.
    let decay = platoon_synthesis::max_decay_within_ratio(
        d.k,
        &g,
        &taus,
        2.0 * d.certificate.ratio,
        (5.0, 1e-3),
        d.certificate.p_blocks.is_some(),
    )?;
    let seconds = started.elapsed().as_secs_f64();
    let c = decay.as_ref().map_or(d.certificate.c, |x| x.c);
    let trigger_cap = match scenario.control.rule {
        platoon_control::TriggerRule::Dynamic { phi, rho, eta, .. } => rho - phi * (1.0 - eta),
        _ => f64::INFINITY,
    };
    let varsigma1 = c.min(trigger_cap);
    let p_cert = decay.as_ref().unwrap_or(&d.certificate);
    let p = nalgebra::Matrix3::from_fn(|i, j| p_cert.p[i][j]);
    // With one P per follower, V grows under attack as fast as its fastest block.
    let blocks: Vec<nalgebra::Matrix3<f64>> = match &p_cert.p_blocks {
        Some(b) => b
            .iter()
            .map(|m| nalgebra::Matrix3::from_fn(|i, j| m[i][j]))
            .collect(),
        None => vec![p],
    };
    let varsigma2 = taus
        .iter()
        .flat_map(|&t| {
            blocks
                .iter()
                .map(move |b| platoon_synthesis::growth_rate(b, t))
        })
        .fold(0.0, f64::max);
    let minv = p
        .try_inverse()
        .ok_or_else(|| anyhow::anyhow!("the certificate's P is singular"))?;
    let varsigma_star = a.star_fraction * varsigma1;
    let h_s = f64::from(scenario.control.h_steps) * scenario.dt();
    // One Lyapunov matrix in and out of attacks: Q = P, so phi = 1.
    let bounds = dos_bounds(varsigma1, varsigma2, varsigma_star, 1.0, h_s).ok();
    let verdict = match (bounds, scenario.assumption2) {
        (Some((t2, d2)), Some(a2)) => {
            let need = platoon_attacks::Assumption2 {
                T2: t2,
                D2: d2,
                ..a2
            };
            let r = need.check(&scenario.dos, scenario.duration());
            Some(if r.holds {
                format!("the config's DoS schedule satisfies Assumption 2 with T1 = {}, D1 = {}, T2 = {t2:.2}, D2 = {d2:.2}", a2.T1, a2.D1)
            } else {
                format!("the config's DoS schedule VIOLATES Assumption 2 with T1 = {}, D1 = {}, T2 = {t2:.2}, D2 = {d2:.2}: the design does not guarantee stability under it", a2.T1, a2.D1)
            })
        }
        (None, _) => Some("no DoS bounds: varsigma1 must be positive".into()),
        (_, None) => None,
    };
    let report = DesignReport {
        theorem: a.theorem,
        time_headway_s: g.headway,
        k: d.k,
        beta1: d.certificate.ratio * config.control.beta2,
        beta2: config.control.beta2,
        beta1_over_beta2: d.certificate.ratio,
        c,
        p: p_cert.p,
        m: rows3(&minv),
        u: {
            let u = nalgebra::RowVector3::from(d.k) * minv;
            [u[0], u[1], u[2]]
        },
        q: p_cert.p,
        varsigma1,
        varsigma2,
        varsigma_star,
        phi: 1.0,
        t2_bound: bounds.map(|b| b.0),
        d2_bound: bounds.map(|b| b.1),
        schedule_verdict: verdict.clone(),
        certificate: "certificate.json",
        certificate_max_decay: decay.as_ref().map(|_| "certificate-max-decay.json"),
        sdps: d.sdps,
        designed_on: d.designed_on,
        seconds,
        string_stability: string_report(d.k, &config, &scenario, &g),
    };
    let dir = RunDir::create(&out, a.force)?;
    dir.write(
        "certificate.json",
        (serde_json::to_string_pretty(&d.certificate)? + "\n").as_bytes(),
    )?;
    if let Some(x) = &decay {
        dir.write(
            "certificate-max-decay.json",
            (serde_json::to_string_pretty(x)? + "\n").as_bytes(),
        )?;
    }
    dir.write(
        "design.json",
        (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
    )?;
    let path = dir.commit()?;
    let norm = d.k.iter().map(|x| x * x).sum::<f64>().sqrt();
    print_string(&report.string_stability);
    println!(
        "K = [{:.4}, {:.4}, {:.4}] (|K| = {norm:.2} <= {}), beta1/beta2 = {:.2} on {n} followers, {}",
        d.k[0], d.k[1], d.k[2], a.k_max, d.certificate.ratio, policy(&g)
    );
    println!(
        "  certified by the exact SDP of {} at tau = {:?} (margin {:.2e}{}); {} SDPs in {seconds:.2} s",
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
        d.sdps
    );
    if d.designed_on < n {
        println!(
            "  designed on the first {} followers (with {}), certified on all {n}",
            d.designed_on,
            if g.headway > 0.0 {
                "a time headway the procedure is not linear"
            } else {
                "constant spacing the whole platoon admits no common P for this procedure"
            }
        );
    }
    println!(
        "  varsigma1 = {varsigma1:.4} (c = {c:.4}, trigger cap {trigger_cap:.4}), varsigma2 = {varsigma2:.4}, varsigma* = {varsigma_star:.4}, phi = 1"
    );
    if let Some((t2, d2)) = bounds {
        println!("  DoS bounds (16): T2 > {t2:.2}, D2 > {d2:.2}");
    }
    if let Some(v) = verdict {
        println!("  {v}");
    }
    println!("outputs: {}", path.display());
    Ok(())
}

fn rows3(m: &nalgebra::Matrix3<f64>) -> [[f64; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}
