//! LMI design as library calls: Theorem 1 (or 2) checks of a gain on clarabel's SDP solver
//! ([`check_gain`]), gain synthesis ([`synthesize`]), certificates and their independent
//! re-check ([`verify`]), and the DoS bounds (16) ([`bounds`]). Results come back in memory;
//! [`CheckReport::write`] and [`Synthesis::write`] put the files of `platoon design` into a run
//! directory the caller opened.
use platoon_config::{Config, ConfigError};
use platoon_output::error::OutputError;
use platoon_output::rundir::RunDir;
use platoon_sim::Scenario;
use platoon_synthesis::{
    closed_loop_spectrum, dos_bounds, min_ratio, theorem1_max_decay, Certificate, Coupling, Design,
    Feasibility, LyapunovForm, Spectrum, StringStability, Verdict,
};
use std::path::{Path, PathBuf};

/// The result of this module's operations.
pub type Result<T, E = DesignError> = std::result::Result<T, E>;

/// Why a design operation failed, by kind: what a caller branches on (the Python package
/// raises one exception class per kind). Each message is the one `platoon design` prints. A
/// gain that (13) does not certify is no error: [`check_gain`] reports it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DesignError {
    /// The config is refused (for a caller that loads and designs with one error type;
    /// `platoon design` exits 2).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Options no design or check can use (a negative time headway, a gain that is not three
    /// finite numbers, a star fraction outside (0, 1)), refused before anything is computed.
    #[error("{0}")]
    Options(String),
    /// [`synthesize`] found no gain within the bounds asked for.
    #[error(
        "infeasible: no gain with |K| <= {k_max} satisfies Theorem {theorem} on this topology ({followers} followers, {policy}) with beta1/beta2 <= {ratio_max} at c = {c} ({seconds:.2} s); raise --k-max or --ratio-max, or lower --c{}",
        headway_hint(.time_headway_s)
    )]
    Infeasible {
        /// 1 or 2.
        theorem: u8,
        /// The followers of the topology.
        followers: usize,
        /// The spacing policy, in words.
        policy: String,
        /// Its time headway (s; 0: constant spacing).
        time_headway_s: f64,
        /// The bound on |K|.
        k_max: f64,
        /// The largest beta1/beta2 tried.
        ratio_max: f64,
        /// The decay asked for.
        c: f64,
        /// How long the search took (s).
        seconds: f64,
    },
    /// The SDP solver failed, or was given inputs out of its range, or this build has none.
    #[error(transparent)]
    Solver(#[from] platoon_synthesis::LmiError),
    /// A certificate file could not be read.
    #[error("reading {}", path.display())]
    ReadCertificate {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A file is not a certificate.
    #[error("{} is not a certificate", path.display())]
    NotACertificate {
        /// The file.
        path: PathBuf,
        /// What JSON says of it.
        #[source]
        source: serde_json::Error,
    },
    /// A designed certificate's P has no inverse (Remark 1's M = P^-1).
    #[error("the certificate's P is singular")]
    Singular,
    /// The output directory or one of its files.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Anything else (a table that could not be written).
    #[error(transparent)]
    Other(crate::error::OtherError),
}

operation_error!(DesignError);

impl DesignError {
    /// The config error this is, if it is one (`platoon design` exits 2 on it).
    pub fn config(&self) -> Option<&ConfigError> {
        match self {
            Self::Config(c) => Some(c),
            _ => None,
        }
    }

    /// The output error this is, if it is one.
    pub fn output(&self) -> Option<&OutputError> {
        match self {
            Self::Output(o) => Some(o),
            _ => None,
        }
    }
}

/// What an infeasible design with a time headway adds to its message.
fn headway_hint(time_headway_s: &f64) -> &'static str {
    if *time_headway_s > 0.0 {
        "; with a time headway the gain is designed for constant spacing and then checked, so a smaller --time-headway may pass"
    } else {
        ""
    }
}

/// Which of the paper's conditions (13) is imposed at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Theorem {
    /// Theorem 1: (13) at the nominal tau.
    #[default]
    Nominal,
    /// Theorem 2 as we read it (docs/paper-readings.md#R18): (13) at both ends of the
    /// scenario's tau range with one P, robust to every tau between.
    Robust,
}

impl Theorem {
    /// 1 or 2, as the paper numbers them.
    pub fn number(self) -> u8 {
        match self {
            Theorem::Nominal => 1,
            Theorem::Robust => 2,
        }
    }

    /// The theorem numbered `n` (1 or 2).
    pub fn from_number(n: u8) -> Option<Self> {
        match n {
            1 => Some(Theorem::Nominal),
            2 => Some(Theorem::Robust),
            _ => None,
        }
    }

    /// The taus (13) is imposed at for `scenario`.
    pub fn taus(self, scenario: &Scenario) -> Vec<f64> {
        match self {
            Theorem::Nominal => vec![scenario.control.tau_nominal],
            Theorem::Robust => {
                let (lo, hi) = scenario.tau_range();
                vec![lo, hi]
            }
        }
    }
}

/// The scenario's graph and spacing policy, the policy's headway replaced by `time_headway`
/// when given (which must be a finite number of seconds >= 0; 0: constant spacing).
pub fn coupling(scenario: &Scenario, time_headway: Option<f64>) -> Result<Coupling> {
    let headway = time_headway.unwrap_or(scenario.headway());
    check_headway(headway)?;
    Ok(Coupling::time_headway(
        scenario.topology.h_matrix(),
        headway,
    ))
}

fn check_headway(headway: f64) -> Result<()> {
    if !(headway.is_finite() && headway >= 0.0) {
        return Err(DesignError::Options(format!(
            "--time-headway {headway}: must be a finite number of seconds >= 0 (0: constant spacing)"
        )));
    }
    Ok(())
}

/// String stability of `k` for the config's platoon and, for a preset topology, for the same
/// preset with 100 followers (where string instability shows): at the config's tau range, with
/// the spacing policy of `g`.
pub fn string_report(
    k: [f64; 3],
    config: &Config,
    scenario: &Scenario,
    g: &Coupling,
) -> Vec<StringStability> {
    let (lo, hi) = scenario.tau_range();
    let mut taus = vec![lo, scenario.control.tau_nominal, hi];
    taus.sort_by(f64::total_cmp);
    taus.dedup();
    let mut out = vec![platoon_synthesis::string_stability(k, g, &taus)];
    let preset = config.topology.preset();
    if let Some(p) = preset.filter(|_| scenario.topology.followers() < 100) {
        if let Ok(t) = platoon_topology::Topology::preset(p, 100) {
            let long = Coupling::time_headway(t.h_matrix(), g.headway);
            out.push(platoon_synthesis::string_stability(k, &long, &taus));
        }
    }
    out
}

/// How [`check_gain`] checks; [`CheckOptions::default`] is `platoon design check-gain`'s default.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckOptions {
    /// The gain to check (None: the config's `control.gain`).
    pub gain: Option<[f64; 3]>,
    /// Decay parameter c for the smallest-ratio SDP.
    pub c: f64,
    /// (13) at the nominal tau, or at both ends of the tau range.
    pub theorem: Theorem,
    /// The spacing policy's time headway (s), overriding the config's: 0 for constant spacing
    /// (`--time-headway`).
    pub time_headway: Option<f64>,
}

impl Default for CheckOptions {
    fn default() -> Self {
        Self {
            gain: None,
            c: 0.0,
            theorem: Theorem::Nominal,
            time_headway: None,
        }
    }
}

impl CheckOptions {
    /// Fails on options no check can use (a negative or non-finite time headway), before
    /// anything is computed.
    pub fn validate(&self) -> Result<()> {
        if let Some(h) = self.time_headway {
            check_headway(h)?;
        }
        if let Some(k) = self.gain {
            if !k.iter().all(|x| x.is_finite()) {
                return Err(DesignError::Options(format!(
                    "gain {k:?}: expected three finite numbers"
                )));
            }
        }
        Ok(())
    }
}

/// What [`check_gain`] found. Serialised, it is `check.json`; the fields `serde` skips are the
/// other files (the spectrum and the certificates) and what `platoon design check-gain` prints.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CheckReport {
    /// The gain checked.
    pub k: [f64; 3],
    /// The followers of the scenario's platoon.
    pub topology_followers: usize,
    /// The time headway the conditions were imposed with (s; 0: constant spacing).
    pub time_headway_s: f64,
    /// The nominal tau (s).
    pub tau_nominal: f64,
    /// The scenario's tau range (s).
    pub tau_range: (f64, f64),
    /// Whether every closed-loop eigenvalue has a negative real part over the tau range.
    pub stable_over_tau_range: bool,
    /// The largest real part of a closed-loop eigenvalue over the tau range.
    pub worst_max_real: f64,
    /// The largest modulus of a closed-loop eigenvalue over the tau range (rad/s).
    pub fastest_mode: f64,
    /// (c, the smallest beta1/beta2) with a common Lyapunov matrix I_N kron P; None where
    /// (13) is infeasible for this gain.
    pub min_ratio_at_c: Option<(f64, f64)>,
    /// The config's beta1/beta2.
    pub config_ratio: f64,
    /// Whether the config's ratio is certified with the common Lyapunov matrix.
    pub config_ratio_certified: bool,
    /// The largest decay c the common Lyapunov matrix certifies.
    pub max_decay_c: Option<f64>,
    /// Theorem 1 at c with one Lyapunov block per follower (certificate-block-diagonal.json);
    /// None where that is infeasible too.
    pub block_diagonal: Option<BlockReport>,
    /// Whether spacing errors grow along the platoon (see platoon_synthesis::string_stability).
    pub string_stability: Vec<StringStability>,
    /// With vehicle classes: the heterogeneous closed loop (each follower its own lag range)
    /// at every vertex of the followers' lag box, and (13) there with the common-P certificate
    /// (docs/design.md#mixed-vehicles); absent without classes or beyond
    /// `platoon_synthesis::MIXED_MAX_FREE` followers with a lag range.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heterogeneous: Option<platoon_synthesis::MixedCheck>,
    /// The theorem checked.
    #[serde(skip)]
    pub theorem: Theorem,
    /// The decay parameter c of the smallest-ratio SDPs.
    #[serde(skip)]
    pub c: f64,
    /// The taus (13) was imposed at.
    #[serde(skip)]
    pub lmi_taus: Vec<f64>,
    /// The closed-loop spectrum at 51 taus over the tau range (spectrum.csv).
    #[serde(skip)]
    pub spectrum: Vec<Spectrum>,
    /// The smallest-ratio certificate with a common P (certificate.json).
    #[serde(skip)]
    pub certificate: Option<Certificate>,
    /// The smallest-ratio certificate with one P per follower
    /// (certificate-block-diagonal.json).
    #[serde(skip)]
    pub block_diagonal_certificate: Option<Certificate>,
    /// The certificate of the largest decay c (certificate-max-decay.json).
    #[serde(skip)]
    pub max_decay: Option<Certificate>,
    /// Wall time of the smallest-ratio SDP with a common P (s).
    #[serde(skip)]
    pub sdp_seconds: f64,
}

/// The block-diagonal certificate in `check.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BlockReport {
    /// The smallest beta1/beta2 with one P per follower.
    pub min_ratio: f64,
    /// sqrt(lambda_max / lambda_min) over every block: the bound on how far the tracking error
    /// may grow before it decays.
    pub transient_growth: f64,
    /// Whether the config's ratio is certified with one P per follower.
    pub config_ratio_certified: bool,
}

/// Evaluates a gain on `scenario`'s topology (`config` gives its beta1/beta2 and preset): the
/// closed-loop eigenvalues over the tau range, the smallest beta1/beta2 for which (13) holds
/// (an exact SDP for a fixed K) with a common Lyapunov matrix and with one P per follower, the
/// largest decay c the common one certifies, and string stability. Writes nothing.
pub fn check_gain(
    config: &Config,
    scenario: &Scenario,
    opts: &CheckOptions,
) -> Result<CheckReport> {
    opts.validate()?;
    let k = opts.gain.unwrap_or(config.control.paper_law().gain);
    let n = scenario.topology.followers();
    let g = coupling(scenario, opts.time_headway)?;
    let tau = scenario.control.tau_nominal;
    let (lo, hi) = scenario.tau_range();
    let taus: Vec<f64> = (0..=50)
        .map(|i| lo + (hi - lo) * f64::from(i) / 50.0)
        .collect();
    let spectrum = closed_loop_spectrum(k, &g, &taus);
    let taus_lmi = opts.theorem.taus(scenario);
    let worst = spectrum
        .iter()
        .map(|s| s.max_real)
        .fold(f64::NEG_INFINITY, f64::max);
    let fastest = spectrum.iter().map(|s| s.max_modulus).fold(0.0, f64::max);

    let started = std::time::Instant::now();
    let min = min_ratio(k, opts.c, &g, &taus_lmi, 1e-6, LyapunovForm::Common)?;
    let sdp_seconds = started.elapsed().as_secs_f64();
    let config_ratio = config.control.paper_law().beta1 / config.control.paper_law().beta2;
    let (certificate, min_ratio, certified) = match min {
        Feasibility::Feasible(cert) => {
            let mut at_config = cert.clone();
            at_config.ratio = config_ratio;
            let certified = config_ratio >= cert.ratio && at_config.verify()?.holds;
            let ratio = cert.ratio;
            (Some(cert), Some((opts.c, ratio)), certified)
        }
        Feasibility::Infeasible => (None, None, false),
    };
    // The richer certificate: one P per follower (it holds where I_N kron P does not, e.g. PF
    // and TPSF beyond a few followers, at the price of a transient growth).
    let (block_certificate, block) = match platoon_synthesis::min_ratio(
        k,
        opts.c,
        &g,
        &taus_lmi,
        1e-6,
        LyapunovForm::BlockDiagonal,
    )? {
        Feasibility::Feasible(cert) => {
            let mut at_config = cert.clone();
            at_config.ratio = config_ratio;
            let report = BlockReport {
                min_ratio: cert.ratio,
                transient_growth: cert.transient_growth()?,
                config_ratio_certified: config_ratio >= cert.ratio && at_config.verify()?.holds,
            };
            (Some(cert), Some(report))
        }
        Feasibility::Infeasible => (None, None),
    };
    let best = theorem1_max_decay(k, &g, &taus_lmi, 10.0, 1e-3)?;
    let heterogeneous = if scenario.vehicles.is_empty() {
        None
    } else {
        platoon_synthesis::check_mixed(
            k,
            opts.c,
            &g,
            &scenario.member_tau_ranges(),
            certificate.as_ref(),
        )?
    };
    Ok(CheckReport {
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
        string_stability: string_report(k, config, scenario, &g),
        heterogeneous,
        theorem: opts.theorem,
        c: opts.c,
        lmi_taus: taus_lmi,
        spectrum,
        certificate,
        block_diagonal_certificate: block_certificate,
        max_decay: best,
        sdp_seconds,
    })
}

/// A value as pretty JSON with a final newline, as every JSON file of platoon is written.
fn pretty(value: &impl serde::Serialize) -> Result<Vec<u8>> {
    Ok((serde_json::to_string_pretty(value)? + "\n").into_bytes())
}

impl CheckReport {
    /// Whether the check certifies the gain for the config's beta1/beta2: (13) holds at that
    /// ratio with a common Lyapunov matrix or with one per follower, and, for followers of
    /// different lags (vehicle classes), at every vertex of their lag box too (with the
    /// common P or by the direct SDP). What `platoon design check-gain`'s exit status says.
    pub fn certified(&self) -> bool {
        let nominal = self.config_ratio_certified
            || self
                .block_diagonal
                .as_ref()
                .is_some_and(|b| b.config_ratio_certified);
        let mixed = self.heterogeneous.as_ref().is_none_or(|m| {
            m.certified
                || matches!(
                    (m.direct_min_ratio, m.direct_max_eigenvalue),
                    (Some(r), Some(e)) if e < 0.0 && self.config_ratio >= r
                )
        });
        nominal && mixed
    }

    /// Writes `platoon design check-gain`'s files into `dir`: spectrum.csv, the certificates
    /// found (certificate.json, certificate-block-diagonal.json, certificate-max-decay.json)
    /// and check.json.
    pub fn write(&self, dir: &RunDir) -> Result<()> {
        let mut csv = csv::Writer::from_writer(dir.writer("spectrum.csv")?);
        for s in &self.spectrum {
            csv.serialize(s)?;
        }
        csv.flush()?;
        for (name, cert) in [
            ("certificate.json", &self.certificate),
            (
                "certificate-block-diagonal.json",
                &self.block_diagonal_certificate,
            ),
            ("certificate-max-decay.json", &self.max_decay),
        ] {
            if let Some(cert) = cert {
                dir.write(name, &pretty(cert)?)?;
            }
        }
        Ok(dir.write("check.json", &pretty(self)?)?)
    }
}

/// Reads a certificate (`certificate*.json`).
pub fn read_certificate(file: &Path) -> Result<Certificate> {
    let path = || file.to_path_buf();
    let text = std::fs::read_to_string(file).map_err(|source| DesignError::ReadCertificate {
        path: path(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|source| DesignError::NotACertificate {
        path: path(),
        source,
    })
}

/// Re-checks a certificate independently of the solver: (13) assembled from its numbers, its
/// eigenvalue margin, the smallest eigenvalue of P and the transient growth.
pub fn verify(cert: &Certificate) -> Result<Verdict> {
    Ok(cert.verify()?)
}

/// The parameters of the DoS bounds (16); [`BoundsOptions::default`] is
/// `platoon design bounds`'s default (the paper's Section IV).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundsOptions {
    /// varsigma1, the decay rate without attacks.
    pub varsigma1: f64,
    /// varsigma2, the growth rate under attack.
    pub varsigma2: f64,
    /// varsigma*, in (0, varsigma1).
    pub varsigma_star: f64,
    /// phi, the gain scheduler between the two Lyapunov functions.
    pub phi: f64,
    /// h, the resilient sampling period (s).
    pub h: f64,
}

impl Default for BoundsOptions {
    fn default() -> Self {
        Self {
            varsigma1: 0.41,
            varsigma2: 0.27,
            varsigma_star: 0.35,
            phi: 5.2,
            h: 0.02,
        }
    }
}

/// The DoS bounds (16): (T2, D2) with T2 > (2 ln phi + (s1 + s2) h) / s* and
/// D2 > (s1 + s2) / (s1 - s*).
pub fn bounds(b: &BoundsOptions) -> Result<(f64, f64)> {
    Ok(dos_bounds(
        b.varsigma1,
        b.varsigma2,
        b.varsigma_star,
        b.phi,
        b.h,
    )?)
}

/// How [`synthesize`] designs; [`SynthesisOptions::default`] is `platoon design synthesize`'s
/// default.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthesisOptions {
    /// Decay parameter c.
    pub c: f64,
    /// Bound on |K| (2-norm).
    pub k_max: f64,
    /// (13) at the nominal tau, or at both ends of the tau range (robust).
    pub theorem: Theorem,
    /// Largest beta1/beta2 tried.
    pub ratio_max: f64,
    /// The spacing policy's time headway (s), overriding the config's: 0 for constant spacing
    /// (`--time-headway`).
    pub time_headway: Option<f64>,
    /// varsigma* as a fraction of varsigma1, in (0, 1) (`--star-fraction`): trades the
    /// dwell-time bound T2 against the duration bound D2 of (16).
    pub star_fraction: f64,
}

impl Default for SynthesisOptions {
    fn default() -> Self {
        Self {
            c: 0.0,
            k_max: 20.0,
            theorem: Theorem::Nominal,
            ratio_max: 1e4,
            time_headway: None,
            star_fraction: 0.5,
        }
    }
}

impl SynthesisOptions {
    /// Fails on options no design can use (a star fraction outside (0, 1), a negative or
    /// non-finite time headway), before anything is computed.
    pub fn validate(&self) -> Result<()> {
        if !(self.star_fraction > 0.0 && self.star_fraction < 1.0) {
            return Err(DesignError::Options(
                "--star-fraction must be in (0, 1)".into(),
            ));
        }
        if let Some(h) = self.time_headway {
            check_headway(h)?;
        }
        Ok(())
    }
}

/// What `design.json` holds: the design, its decay figures, the DoS bounds (16) and the
/// verdict on the config's attack schedule.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DesignReport {
    /// 1 or 2.
    pub theorem: u8,
    /// The time headway the conditions were imposed with (s; 0: constant spacing).
    pub time_headway_s: f64,
    /// The designed gain.
    pub k: [f64; 3],
    /// beta1 = the certified ratio x the config's beta2.
    pub beta1: f64,
    /// The config's beta2.
    pub beta2: f64,
    /// The certified beta1/beta2.
    pub beta1_over_beta2: f64,
    /// The decay the design guarantees.
    pub c: f64,
    /// The Lyapunov matrix (of the max-decay certificate where there is one).
    pub p: [[f64; 3]; 3],
    /// Remark 1's variables for this P: M = P^-1 and U = K M.
    pub m: [[f64; 3]; 3],
    /// U = K M.
    pub u: [f64; 3],
    /// The Lyapunov matrix during attacks (we take Q = P, hence phi = 1).
    pub q: [[f64; 3]; 3],
    /// The decay rate without attacks: min(c, the dynamic trigger's cap).
    pub varsigma1: f64,
    /// The growth rate under attack.
    pub varsigma2: f64,
    /// varsigma* = the star fraction x varsigma1.
    pub varsigma_star: f64,
    /// 1: one Lyapunov matrix in and out of attacks.
    pub phi: f64,
    /// T2 of (16), if varsigma1 > 0.
    pub t2_bound: Option<f64>,
    /// D2 of (16), if varsigma1 > 0.
    pub d2_bound: Option<f64>,
    /// Whether the config's DoS schedule satisfies Assumption 2 with these bounds (None: the
    /// config has no Assumption-2 bounds).
    pub schedule_verdict: Option<String>,
    /// The certificate's file name.
    pub certificate: &'static str,
    /// The max-decay certificate's file name, if there is one.
    pub certificate_max_decay: Option<&'static str>,
    /// SDPs solved.
    pub sdps: usize,
    /// The followers the procedure ran on (the certificate is for all of them).
    pub designed_on: usize,
    /// Wall time of the design and its decay figures (s).
    pub seconds: f64,
    /// Whether spacing errors grow along the platoon with this gain.
    pub string_stability: Vec<StringStability>,
}

/// A designed gain ([`synthesize`]): the design with its certificate, the certificate of the
/// largest decay within twice its ratio, and `design.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct Synthesis {
    /// K, its exact certificate (certificate.json), the SDPs solved and the followers it was
    /// designed on.
    pub design: Design,
    /// The largest decay certified with beta1/beta2 within twice the design's
    /// (certificate-max-decay.json).
    pub max_decay: Option<Certificate>,
    /// design.json.
    pub report: DesignReport,
    /// The dynamic trigger's cap on varsigma1, varrho - phi (1 - eta) (infinite for the other
    /// rules).
    pub trigger_cap: f64,
}

/// Designs K and beta1/beta2 for Theorem 1 (or 2, robust) on `scenario`'s topology (Remark 1
/// with its non-convex block linearised, a convex-concave procedure, bisection on
/// beta1/beta2, |K| <= `k_max`), certified by the exact SDP; then its decay rates, the DoS
/// bounds (16) and the verdict on the scenario's attack schedule. `config` gives beta2 and the
/// preset. An infeasible request is an error. Writes nothing.
pub fn synthesize(
    config: &Config,
    scenario: &Scenario,
    opts: &SynthesisOptions,
) -> Result<Synthesis> {
    opts.validate()?;
    let n = scenario.topology.followers();
    let g = coupling(scenario, opts.time_headway)?;
    let taus = opts.theorem.taus(scenario);
    let spec = platoon_synthesis::DesignSpec {
        c: opts.c,
        taus: taus.clone(),
        k_max: opts.k_max,
        ratio_max: opts.ratio_max,
        ..Default::default()
    };
    let started = std::time::Instant::now();
    let design = platoon_synthesis::design_theorem1(&spec, &g)?;
    let Some(d) = design else {
        return Err(DesignError::Infeasible {
            theorem: opts.theorem.number(),
            followers: n,
            policy: platoon_control::SpacingPolicy::from_headway(g.headway).to_string(),
            time_headway_s: g.headway,
            k_max: opts.k_max,
            ratio_max: opts.ratio_max,
            c: opts.c,
            seconds: started.elapsed().as_secs_f64(),
        });
    };
    // The decay it guarantees (ratio kept within twice the design's) and what DoS it tolerates.
    let decay = d.guaranteed_decay(&g, &taus)?;
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
    let minv = p.try_inverse().ok_or(DesignError::Singular)?;
    let varsigma_star = opts.star_fraction * varsigma1;
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
        theorem: opts.theorem.number(),
        time_headway_s: g.headway,
        k: d.k,
        beta1: d.certificate.ratio * config.control.paper_law().beta2,
        beta2: config.control.paper_law().beta2,
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
        schedule_verdict: verdict,
        certificate: "certificate.json",
        certificate_max_decay: decay.as_ref().map(|_| "certificate-max-decay.json"),
        sdps: d.sdps,
        designed_on: d.designed_on,
        seconds,
        string_stability: string_report(d.k, config, scenario, &g),
    };
    Ok(Synthesis {
        design: d,
        max_decay: decay,
        report,
        trigger_cap,
    })
}

impl Synthesis {
    /// Writes `platoon design synthesize`'s files into `dir`: certificate.json (which
    /// `platoon run --design` uses), certificate-max-decay.json and design.json.
    pub fn write(&self, dir: &RunDir) -> Result<()> {
        dir.write("certificate.json", &pretty(&self.design.certificate)?)?;
        if let Some(x) = &self.max_decay {
            dir.write("certificate-max-decay.json", &pretty(x)?)?;
        }
        Ok(dir.write("design.json", &pretty(&self.report)?)?)
    }
}

fn rows3(m: &nalgebra::Matrix3<f64>) -> [[f64; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}
