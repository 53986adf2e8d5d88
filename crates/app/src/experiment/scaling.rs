//! Long platoons ([`scaling`]).
use super::*;

/// How [`scaling`] runs; [`ScalingOptions::default`] is `platoon experiment scaling`'s
/// default.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalingOptions {
    /// Platoon sizes (followers; `--sizes`).
    pub sizes: Vec<usize>,
    /// Topologies.
    pub presets: Vec<Preset>,
    /// The time headway h_t of the designed gains (s; `--time-headway`).
    pub time_headway: f64,
    /// The platoon size the time-headway gains are designed and certified on
    /// (`--design-followers`).
    pub design_followers: usize,
    /// Bound on |K| for the designs.
    pub k_max: f64,
    /// Certify (Theorem 1 at the nominal tau, with a common and with a block-diagonal
    /// Lyapunov matrix) each gain on each size up to this many followers.
    pub certify_up_to: usize,
}

impl Default for ScalingOptions {
    fn default() -> Self {
        Self {
            sizes: vec![4, 10, 25, 50, 100],
            presets: vec![Preset::Pf, Preset::Plf, Preset::Tpsf, Preset::Bpf],
            time_headway: 1.0,
            design_followers: 4,
            k_max: 20.0,
            certify_up_to: 100,
        }
    }
}

impl ScalingOptions {
    /// Fails on options no experiment can use (empty or zero sizes, a time headway that is not
    /// a positive number of seconds, no followers to design on), before anything runs or is
    /// written.
    pub fn validate(&self) -> Result<()> {
        check_sizes(&self.sizes, "--sizes", "4,10,25")?;
        if !(self.time_headway.is_finite() && self.time_headway > 0.0) {
            refuse!(Options, "--time-headway must be a number of seconds > 0");
        }
        if self.design_followers == 0 {
            refuse!(Options, "--design-followers must be at least 1");
        }
        Ok(())
    }
}

/// One run of [`scaling`] (a row of scaling.csv).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ScalingRow {
    /// The topology.
    pub preset: Preset,
    /// Followers.
    pub followers: usize,
    /// `paper-constant` or `designed-time-headway`.
    pub gain: &'static str,
    /// K.
    pub k1: f64,
    /// K.
    pub k2: f64,
    /// K.
    pub k3: f64,
    /// The spacing policy's time headway (s; 0: constant spacing).
    pub time_headway_s: f64,
    /// The trigger's beta1/beta2 in the run: the base's for the paper's gain, the design's for
    /// the designed one.
    pub beta1_over_beta2: f64,
    /// `none` or `base` (the base config's DoS schedule).
    pub dos: &'static str,
    /// Measured in the plant.
    pub max_gap_error_m: f64,
    /// The last follower's largest |gap error| over the first's, measured.
    pub gap_error_growth: Option<f64>,
    /// The largest |spacing error| (m).
    pub max_spacing_error_m: f64,
    /// The smallest gap (m).
    pub min_gap_m: f64,
    /// Whether two vehicles collided.
    pub collided: bool,
    /// The safety class.
    pub class: SafetyClass,
    /// Predicted by the linearised analysis over the base's tau range.
    pub string_stable: bool,
    /// max |T_N1 / T_11|, the worst over the tau range.
    pub predicted_amplification: f64,
    /// The largest modulus of a closed-loop eigenvalue over the tau range (rad/s): against
    /// 1 / dt it tells whether the step can follow the loop at all.
    pub fastest_mode_rad_s: f64,
    /// The smallest beta1/beta2 of Theorem 1 (nominal tau) for this size with the common
    /// Lyapunov matrix I_N kron P; empty when not computed (above `certify_up_to`), `inf` when
    /// infeasible.
    pub certified_ratio: Option<f64>,
    /// The same with one P per follower (block-diagonal).
    pub block_diagonal_ratio: Option<f64>,
    /// That certificate's transient growth sqrt(lambda_max / lambda_min).
    pub block_diagonal_growth: Option<f64>,
}

/// A time-headway gain designed by [`scaling`] (a row of designs.csv).
#[derive(Debug, Clone, PartialEq)]
pub struct ScalingDesign {
    /// The topology it was designed on.
    pub preset: Preset,
    /// K and its certificate (`certificate-<preset>.json`).
    pub design: Design,
}

/// Long platoons ([`scaling`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Scaling {
    /// Preset by preset, size by size, the paper's gain then the designed one, without then
    /// with DoS.
    pub rows: Vec<ScalingRow>,
    /// The gains designed for the time headway (a preset with none is missing).
    pub designs: Vec<ScalingDesign>,
    /// scaling.md: the table (what `platoon experiment scaling` prints).
    pub markdown: String,
}

/// Long platoons: the largest gap error against the platoon's size for each topology, the
/// base's gain with constant spacing beside a gain designed for a time headway (Theorem 1 on
/// the time-headway error dynamics, designed on `design_followers`), with and without the
/// base's DoS, in process, in formation at t = 0. Each row also holds what the analysis
/// predicts: string stability and, up to `certify_up_to` followers, the smallest beta1/beta2
/// Theorem 1 certifies. `progress` counts the runs and hears of a preset with no design.
/// With `out`: config.toml, designs.csv, the designs' certificates, scaling.csv, scaling.md
/// and scaling.png (one panel per topology, log-log).
pub fn scaling(
    base: &Base,
    opts: &ScalingOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Scaling> {
    super::run::<Scaling>(base, opts, out, progress)
}

/// [`scaling`]'s cells (and their runs' directories in `out`), without its tables and figures.
fn measure(
    base: &Base,
    opts: &ScalingOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Scaling> {
    use platoon_synthesis::Coupling;
    use platoon_topology::Topology;
    let label = &base.label;
    let scenario0 = &base.scenario;
    let base_config = &base.config;
    write_config(out, base_config)?;
    let tau = scenario0.control.tau_nominal;
    let (lo, hi) = scenario0.tau_range();
    let mut taus = vec![lo, tau, hi];
    taus.sort_by(f64::total_cmp);
    taus.dedup();
    let h_t = opts.time_headway;
    let paper_k = base_config.control.paper_law().gain;
    let total = opts.presets.len() * opts.sizes.len() * 4;
    progress.start("simulating", total as u64);
    let mut rows = Vec::with_capacity(total);
    let mut designs = Vec::new();
    for &preset in &opts.presets {
        let name = preset.name();
        progress.detail(&format!("designing for {name}"));
        let h_design = Topology::preset(preset, opts.design_followers)?.h_matrix();
        let spec = platoon_synthesis::DesignSpec {
            taus: vec![tau],
            k_max: opts.k_max,
            ..Default::default()
        };
        let design =
            platoon_synthesis::design_theorem1(&spec, &Coupling::time_headway(h_design, h_t))?;
        let designed_k = match design {
            Some(d) => {
                let k = (d.k, d.certificate.ratio);
                designs.push(ScalingDesign { preset, design: d });
                Some(k)
            }
            None => {
                progress.message(&format!("{name}: no gain designed for a {h_t} s headway on {} followers (the row is missing from the figure)", opts.design_followers));
                None
            }
        };
        // The designed gain runs with the trigger ratio it was designed with (the paper's
        // co-design of K and beta1/beta2); the paper's gain with the base's.
        let base_ratio =
            base_config.control.paper_law().beta1 / base_config.control.paper_law().beta2;
        let variants: Vec<(&'static str, [f64; 3], f64, f64)> =
            std::iter::once(("paper-constant", paper_k, 0.0, base_ratio))
                .chain(designed_k.map(|(k, r)| ("designed-time-headway", k, h_t, r)))
                .collect();
        for &n in &opts.sizes {
            let h = Topology::preset(preset, n)?.h_matrix();
            for &(gain, k, headway, ratio) in &variants {
                let coupling = Coupling::time_headway(h.clone(), headway);
                let ss = platoon_synthesis::string_stability(k, &coupling, &taus);
                let fastest = platoon_synthesis::closed_loop_spectrum(k, &coupling, &taus)
                    .iter()
                    .map(|s| s.max_modulus)
                    .fold(0.0, f64::max);
                let (certified_ratio, block) = if n <= opts.certify_up_to {
                    progress.detail(&format!("certifying {name} {n} {gain}"));
                    let (common, block) = certified_ratios(k, &coupling, tau)?;
                    (Some(common), Some(block))
                } else {
                    (None, None)
                };
                for dos in ["none", "base"] {
                    progress.detail(&format!("{name} {n} {gain} dos={dos}"));
                    let mut c = base_config.clone();
                    resize(&mut c, n);
                    c.platoon.spacing =
                        platoon_control::SpacingPolicy::from_headway(headway).into();
                    c.topology = preset.into();
                    let paper = c.control.paper_law_mut();
                    paper.gain = k;
                    paper.beta1 = ratio * paper.beta2;
                    if dos == "none" {
                        c.attack = platoon_config::Attack::default();
                    }
                    let scenario = platoon_config::to_scenario(&mut c).map_err(|e| {
                        let (key, e) = (e.key, e.reason);
                        ExperimentError::Variant(format!(
                            "{label}: key `{key}` with {n} followers ({name}, {gain}): {e}"
                        ))
                    })?;
                    let s = platoon_sim::run(scenario, |_| {})?;
                    let worst = ss
                        .per_tau
                        .iter()
                        .map(|t| t.amplification)
                        .fold(0.0, f64::max);
                    rows.push(ScalingRow {
                        preset,
                        followers: n,
                        gain,
                        k1: k[0],
                        k2: k[1],
                        k3: k[2],
                        time_headway_s: headway,
                        beta1_over_beta2: ratio,
                        dos,
                        max_gap_error_m: s.max_gap_error_m(),
                        gap_error_growth: s.gap_error_growth(),
                        max_spacing_error_m: s.max_spacing_error_m(),
                        min_gap_m: s.safety.min_gap_m,
                        collided: s.safety.collided,
                        class: s.safety.class,
                        string_stable: ss.string_stable,
                        predicted_amplification: worst,
                        fastest_mode_rad_s: fastest,
                        certified_ratio,
                        block_diagonal_ratio: block.map(|b| b.0),
                        block_diagonal_growth: block.and_then(|b| b.1),
                    });
                    progress.at(rows.len() as u64);
                }
            }
        }
    }
    progress.finish();
    let markdown = scaling_markdown(&rows, label, opts);
    let result = Scaling {
        rows,
        designs,
        markdown,
    };
    Ok(result)
}

/// The smallest beta1/beta2 for which LMI (13) certifies gain `k` on `coupling` at lag `tau`
/// (c = 0), with one common P and with one P per follower (and that certificate's transient
/// growth); infinite where it certifies none.
fn certified_ratios(
    k: [f64; 3],
    coupling: &platoon_synthesis::Coupling,
    tau: f64,
) -> Result<(f64, (f64, Option<f64>)), platoon_synthesis::LmiError> {
    use platoon_synthesis::{Feasibility, LmiError};
    let ratio = |f: Result<Feasibility, LmiError>| match f {
        Ok(Feasibility::Feasible(c)) => {
            let growth = c.transient_growth()?;
            Ok((c.ratio, Some(growth)))
        }
        Ok(Feasibility::Infeasible) | Err(LmiError::NotCertified(_)) => Ok((f64::INFINITY, None)),
        Err(e) => Err(e),
    };
    let common = ratio(platoon_synthesis::theorem1_min_ratio(
        k, 0.0, coupling, tau, 1e-6,
    ))?;
    let block = ratio(platoon_synthesis::min_ratio(
        k,
        0.0,
        coupling,
        &[tau],
        1e-6,
        platoon_synthesis::LyapunovForm::BlockDiagonal,
    ))?;
    Ok((common.0, block))
}

fn scaling_markdown(rows: &[ScalingRow], label: &str, opts: &ScalingOptions) -> String {
    let mut md = format!(
        "Largest gap error to the predecessor (m) by platoon size; base {label}; designed gains: Theorem 1 with a {} s time headway on {} followers.\n\n| topology | followers | gain | DoS | max gap error (m) | growth last/first | min gap (m) | class | string stable (predicted) | fastest mode (rad/s) | Theorem 1 ratio, common P | one P per follower (growth) |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        opts.time_headway, opts.design_followers
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {}{} | {} ({}) | {:.1} | {} | {} |",
            r.preset.name(),
            r.followers,
            r.gain,
            r.dos,
            short(r.max_gap_error_m),
            r.gap_error_growth.map_or("-".into(), short),
            short(r.min_gap_m),
            r.class,
            if r.collided { " (collision)" } else { "" },
            if r.string_stable { "yes" } else { "no" },
            short(r.predicted_amplification),
            r.fastest_mode_rad_s,
            ratio_text(r.certified_ratio),
            match (r.block_diagonal_ratio, r.block_diagonal_growth) {
                (Some(x), Some(g)) => format!("{} ({g:.1}x)", ratio_text(Some(x))),
                (x, _) => ratio_text(x),
            },
        );
    }
    md
}

impl Scaling {
    fn write_files(&self, opts: &ScalingOptions, dir: &RunDir) -> Result<()> {
        let mut designs = csv::Writer::from_writer(dir.writer("designs.csv")?);
        designs.write_record([
            "preset",
            "design_followers",
            "time_headway_s",
            "k1",
            "k2",
            "k3",
            "beta1_over_beta2",
            "certificate",
        ])?;
        for ScalingDesign { preset, design: d } in &self.designs {
            let file = format!("certificate-{}.json", preset.name());
            dir.write(&file, &pretty(&d.certificate)?)?;
            designs.write_record([
                preset.name().to_string(),
                opts.design_followers.to_string(),
                opts.time_headway.to_string(),
                d.k[0].to_string(),
                d.k[1].to_string(),
                d.k[2].to_string(),
                d.certificate.ratio.to_string(),
                file,
            ])?;
        }
        designs.flush()?;
        drop(designs);
        write_table(dir, "scaling", &self.rows, &self.markdown)?;
        let panels: Vec<(String, Vec<Series>)> = opts
            .presets
            .iter()
            .map(|&preset| {
                let series = [
                    ("paper-constant", "none"),
                    ("paper-constant", "base"),
                    ("designed-time-headway", "none"),
                    ("designed-time-headway", "base"),
                ]
                .iter()
                .enumerate()
                .map(|(i, (gain, dos))| Series {
                    label: format!(
                        "{} {}",
                        if *gain == "paper-constant" {
                            "paper K, constant"
                        } else {
                            "designed K, time headway"
                        },
                        if *dos == "none" { "no DoS" } else { "DoS" }
                    ),
                    color: i,
                    points: self
                        .rows
                        .iter()
                        .filter(|r| r.preset == preset && r.gain == *gain && r.dos == *dos)
                        .map(|r| (r.followers as f64, r.max_gap_error_m))
                        .collect(),
                })
                .filter(|s| !s.points.is_empty())
                .collect();
                (preset.name().to_uppercase(), series)
            })
            .collect();
        Ok(plots::log_log_panels(
            &dir.path("scaling.png"),
            "Largest gap error against platoon size",
            "followers",
            "largest |gap error| (m)",
            &panels,
        )?)
    }
}

impl Experiment for Scaling {
    type Options = ScalingOptions;
    const NAME: &'static str = "scaling";
    const DIR: &'static str = "runs/scaling-experiment";
    const BASE: Embedded = Embedded::Paper;
    fn validate(opts: &ScalingOptions) -> Result<()> {
        opts.validate()
    }
    fn measure(
        base: &Base,
        opts: &ScalingOptions,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(base, opts, out, progress)
    }
    fn write(&self, _base: &Base, opts: &ScalingOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts, dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
