//! Fig. 9 of the paper ([`robust`]).
use super::*;

/// How [`robust`] designs; [`RobustOptions::default`] is `platoon experiment robust`'s default.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustOptions {
    /// Bound on |K| for the designs.
    pub k_max: f64,
}

impl Default for RobustOptions {
    fn default() -> Self {
        Self { k_max: 20.0 }
    }
}

/// One design of Fig. 9, run on the tau(t) schedule.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustDesign {
    /// `theorem1-nominal`, `theorem2-robust` or `lower-bound`.
    pub name: &'static str,
    /// The taus (13) was imposed at.
    pub taus: Vec<f64>,
    /// K and its certificate (`certificate-<name>.json`).
    pub design: Design,
    /// The run's summary.
    pub summary: Summary,
    /// Fig. 9's curve: the mean over followers of |spacing error| at each step, (t, m).
    pub mean_abs_spacing_error: Vec<(f64, f64)>,
    /// The mean of that curve while tau is low (t < 20 s), on its ramp (20-35 s) and high.
    pub phase_errors: [f64; 3],
}

/// Fig. 9 ([`robust`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Robust {
    /// Theorem 1 at the nominal tau, Theorem 2 over the tau range, Theorem 1 at the lower
    /// bound of tau, in that order.
    pub designs: Vec<RobustDesign>,
    /// fig9.md: the mean tracking error per phase of tau (what `platoon experiment robust`
    /// prints).
    pub markdown: String,
}

/// Fig. 9: controllers designed by Theorem 1 at the nominal tau, by Theorem 2 (robust over
/// the base's tau range: docs/paper-readings.md#R18) and by Theorem 1 at the lower bound of
/// tau (the "lower-bound method" the paper compares to), each run on the base's tau(t)
/// schedule without DoS. `progress` hears which design is under way and of the runs. With
/// `out`: config.toml, designs.csv, the three certificates, one run directory per design,
/// fig9.csv, fig9.png and fig9.md.
pub fn robust(
    base: &Base,
    opts: &RobustOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Robust> {
    super::run::<Robust>(base, opts, out, progress)
}

/// [`robust`]'s cells (and their runs' directories in `out`), without its tables and figures.
fn measure(
    base: &Base,
    opts: &RobustOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Robust> {
    let config = &base.config;
    let mut scenario0 = base.scenario.clone();
    scenario0.dos = platoon_attacks::DosSchedule::none();
    let h = platoon_synthesis::Coupling::time_headway(
        scenario0.topology.h_matrix(),
        scenario0.headway(),
    );
    let tau = scenario0.control.tau_nominal;
    let (lo, hi) = scenario0.tau_range();
    write_config(out, config)?;
    let plan: [(&str, Vec<f64>); 3] = [
        ("theorem1-nominal", vec![tau]),
        ("theorem2-robust", vec![lo, hi]),
        ("lower-bound", vec![lo]),
    ];
    let mut md = String::from(
        "# Fig. 9: designs run on the tau(t) schedule (no DoS)\n\n| design | K | beta1/beta2 | mean error, tau low (m) | mean error, ramp (m) | mean error, tau high (m) |\n|---|---|---|---|---|---|\n",
    );
    let mut designs = Vec::new();
    for (name, taus) in plan {
        progress.message(&format!("designing {name} (tau = {taus:?}) ..."));
        let spec = platoon_synthesis::DesignSpec {
            taus: taus.clone(),
            k_max: opts.k_max,
            ..Default::default()
        };
        let d = platoon_synthesis::design_theorem1(&spec, &h)?.ok_or_else(|| {
            ExperimentError::Infeasible {
                design: name.to_string(),
                k_max: opts.k_max,
            }
        })?;
        if let Some(dir) = out {
            dir.write(
                &format!("certificate-{name}.json"),
                &pretty(&d.certificate)?,
            )?;
        }
        let mut scenario = scenario0.clone();
        scenario.control.gain = nalgebra::RowVector3::from(d.k);
        scenario.control.beta1 = d.certificate.ratio * scenario.control.beta2;
        let (rows, summary) = run_in(config, &scenario, out, name, progress)?;
        let e = average_error(&rows);
        let phase = |a: f64, b: f64| {
            let v: Vec<f64> = e
                .iter()
                .filter(|(t, _)| *t >= a && *t < b)
                .map(|x| x.1)
                .collect();
            v.iter().sum::<f64>() / v.len().max(1) as f64
        };
        let phase_errors = [
            phase(0.0, 20.0),
            phase(20.0, 35.0),
            phase(35.0, f64::INFINITY),
        ];
        let _ = writeln!(
            md,
            "| {name} | [{:.3}, {:.3}, {:.3}] | {:.1} | {:.4} | {:.4} | {:.4} |",
            d.k[0],
            d.k[1],
            d.k[2],
            d.certificate.ratio,
            phase_errors[0],
            phase_errors[1],
            phase_errors[2]
        );
        designs.push(RobustDesign {
            name,
            taus,
            design: d,
            summary,
            mean_abs_spacing_error: e,
            phase_errors,
        });
    }
    let robust = Robust {
        designs,
        markdown: md,
    };
    Ok(robust)
}

impl Robust {
    fn write_files(&self, dir: &RunDir) -> Result<()> {
        let mut table = csv::Writer::from_writer(dir.writer("designs.csv")?);
        table.write_record(["design", "k1", "k2", "k3", "beta1_over_beta2", "taus"])?;
        for r in &self.designs {
            let d = &r.design;
            table.write_record([
                r.name.to_string(),
                d.k[0].to_string(),
                d.k[1].to_string(),
                d.k[2].to_string(),
                d.certificate.ratio.to_string(),
                format!("{:?}", r.taus),
            ])?;
        }
        table.flush()?;
        let curves: Vec<(&str, &[(f64, f64)])> = self
            .designs
            .iter()
            .map(|r| (r.name, r.mean_abs_spacing_error.as_slice()))
            .collect();
        error_figure(dir, "fig9", &curves)?;
        Ok(dir.write("fig9.md", self.markdown.as_bytes())?)
    }
}

impl Experiment for Robust {
    type Options = RobustOptions;
    const NAME: &'static str = "robust";
    const DIR: &'static str = "runs/robust";
    const BASE: Embedded = Embedded::Paper;
    fn validate(_opts: &RobustOptions) -> Result<()> {
        Ok(())
    }
    fn measure(
        base: &Base,
        opts: &RobustOptions,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(base, opts, out, progress)
    }
    fn write(&self, _base: &Base, _opts: &RobustOptions, dir: &RunDir) -> Result<()> {
        self.write_files(dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
