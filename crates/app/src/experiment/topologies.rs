//! Fig. 10 of the paper ([`topologies`]).
use super::*;

/// How [`topologies`] designs; [`TopologiesOptions::default`] is `platoon experiment
/// topologies`' default.
#[derive(Debug, Clone, PartialEq)]
pub struct TopologiesOptions {
    /// Platoon sizes (followers; `--sizes`).
    pub sizes: Vec<usize>,
    /// The conservative trigger: varrho (the base's eta and phi are kept).
    pub conservative_rho: f64,
    /// Bound on |K| for the designs.
    pub k_max: f64,
}

impl Default for TopologiesOptions {
    fn default() -> Self {
        Self {
            sizes: vec![2, 4, 6, 8],
            conservative_rho: 0.3,
            k_max: 20.0,
        }
    }
}

impl TopologiesOptions {
    /// Fails on sizes no platoon has, before anything runs or is written.
    pub fn validate(&self) -> Result<()> {
        check_sizes(&self.sizes, "--sizes", "2,4,6")
    }
}

/// Fails unless `base` can be Fig. 10's base (the dynamic rule, whose parameters bound
/// varsigma1, and Assumption-2 bounds for the DoS condition), before anything runs or is
/// written.
pub fn check_topologies_base(base: &Base) -> Result<()> {
    dynamic_with_bounds(&base.scenario).map(|_| ())
}

/// The dynamic rule's (phi, rho, eta) and the Assumption-2 bounds of `base`.
fn dynamic_with_bounds(base: &Scenario) -> Result<((f64, f64, f64), platoon_attacks::Assumption2)> {
    let TriggerRule::Dynamic { phi, rho, eta, .. } = base.control.rule else {
        refuse!(Base, "the base config must use trigger.rule = \"dynamic\" (varsigma1 depends on its phi, rho, eta)");
    };
    let Some(a2) = base.assumption2 else {
        refuse!(
            Base,
            "the base config needs [attack.assumption2] bounds (T2, D2) for the DoS condition"
        );
    };
    Ok(((phi, rho, eta), a2))
}

/// One point of Fig. 10: a design's guaranteed decay under one condition.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TopologyRow {
    /// `PF`, `TPSF` or `BPF`.
    pub topology: &'static str,
    /// Followers.
    pub followers: usize,
    /// `nominal`, `uncertainty`, `conservative` or `dos`.
    pub condition: &'static str,
    /// The guaranteed decay rate.
    pub varsigma1: f64,
    /// The largest decay c certified within twice the design's beta1/beta2.
    pub c: f64,
    /// That certificate's beta1/beta2.
    pub beta1_over_beta2: f64,
    /// The growth rate under attack (the `dos` condition).
    pub varsigma2: Option<f64>,
    /// K.
    pub k1: f64,
    /// K.
    pub k2: f64,
    /// K.
    pub k3: f64,
}

/// Fig. 10 ([`topologies`]): topologies.csv's rows, in order (a design that failed has none).
#[derive(Debug, Clone, PartialEq)]
pub struct Topologies {
    /// PF, TPSF, BPF, each size, each condition.
    pub rows: Vec<TopologyRow>,
}

/// Fig. 10: varsigma1 = min(c, varrho - phi (1 - eta)) (docs/paper-readings.md#R19) for PF,
/// TPSF and BPF platoons of each size under four conditions: nominal (Theorem 1 design), with
/// tau uncertainty (robust design), with conservative trigger parameters, and with DoS; c is
/// the largest decay certified while beta1/beta2 stays within twice the design's. `progress`
/// counts the platoons designed. With `out`: config.toml, topologies.csv and fig10.png.
pub fn topologies(
    base: &Base,
    opts: &TopologiesOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Topologies> {
    super::run::<Topologies>(base, opts, out, progress)
}

/// [`topologies`]'s cells (and their runs' directories in `out`), without its tables and figures.
fn measure(
    base: &Base,
    opts: &TopologiesOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Topologies> {
    let ((phi, rho, eta), a2) = dynamic_with_bounds(&base.scenario)?;
    let base_scenario = &base.scenario;
    let tau = base_scenario.control.tau_nominal;
    let (lo, hi) = base_scenario.tau_range();
    let h_step = f64::from(base_scenario.control.h_steps) * base_scenario.dt();
    write_config(out, &base.config)?;
    progress.start("designing", (TOPOLOGIES.len() * opts.sizes.len()) as u64);
    let mut rows: Vec<TopologyRow> = Vec::new();
    let mut done = 0;
    for (name, preset) in TOPOLOGIES {
        for &n in &opts.sizes {
            progress.detail(&format!("{name} {n}"));
            let topology = platoon_topology::Topology::preset(preset, n)?;
            let h = platoon_synthesis::Coupling::constant(topology.h_matrix());
            for (robust, taus) in [(false, vec![tau]), (true, vec![lo, hi])] {
                let spec = platoon_synthesis::DesignSpec {
                    taus: taus.clone(),
                    k_max: opts.k_max,
                    ..Default::default()
                };
                let Some(d) = platoon_synthesis::design_theorem1(&spec, &h)? else {
                    continue; // no design: the point is missing from the figure (and the CSV)
                };
                let Some(cert) = d.guaranteed_decay(&h, &taus)? else {
                    continue;
                };
                let row = |condition, varsigma1, varsigma2| TopologyRow {
                    topology: name,
                    followers: n,
                    condition,
                    varsigma1,
                    c: cert.c,
                    beta1_over_beta2: cert.ratio,
                    varsigma2,
                    k1: d.k[0],
                    k2: d.k[1],
                    k3: d.k[2],
                };
                let nominal = cert.c.min(rho - phi * (1.0 - eta));
                if robust {
                    rows.push(row("uncertainty", nominal, None));
                    // DoS: the decay left over after attacks, -(-s1 + (s1 + s2)/D2 + s*), with
                    // s* = (s1 + s2) h / T2 (one Lyapunov matrix: phi = 1, ln phi = 0).
                    let p = nalgebra::Matrix3::from_fn(|i, j| cert.p[i][j]);
                    let s2 = platoon_synthesis::growth_rate(&p, hi).max(0.0);
                    let s1 = nominal;
                    let dos = s1 - (s1 + s2) / a2.D2 - (s1 + s2) * h_step / a2.T2;
                    rows.push(row("dos", dos, Some(s2)));
                } else {
                    rows.push(row("nominal", nominal, None));
                    rows.push(row(
                        "conservative",
                        cert.c.min(opts.conservative_rho - phi * (1.0 - eta)),
                        None,
                    ));
                }
            }
            done += 1;
            progress.at(done);
        }
    }
    progress.finish();
    Ok(Topologies { rows })
}

/// Fig. 10's topologies, as its rows name them.
const TOPOLOGIES: [(&str, Preset); 3] = [
    ("PF", Preset::Pf),
    ("TPSF", Preset::Tpsf),
    ("BPF", Preset::Bpf),
];

impl Topologies {
    fn write_files(&self, opts: &TopologiesOptions, dir: &RunDir) -> Result<()> {
        let rows = &self.rows;
        write_csv(dir, "topologies", rows)?;
        let conditions = ["nominal", "uncertainty", "conservative", "dos"];
        let mut categories: Vec<String> = Vec::new();
        for (name, _) in TOPOLOGIES {
            for &n in &opts.sizes {
                categories.push(format!("{name}_{n}"));
            }
        }
        let groups: Vec<(String, Vec<f64>)> = conditions
            .iter()
            .map(|c| {
                (
                    c.to_string(),
                    categories
                        .iter()
                        .map(|cat| {
                            rows.iter()
                                .find(|r| {
                                    format!("{}_{}", r.topology, r.followers) == *cat
                                        && r.condition == *c
                                })
                                .map_or(0.0, |r| r.varsigma1.max(0.0))
                        })
                        .collect(),
                )
            })
            .collect();
        Ok(plots::grouped_bars(
            &dir.path("fig10.png"),
            "Fig. 10: varsigma1 (guaranteed decay rate) by topology and size",
            "varsigma1 (1/s)",
            &categories,
            &groups,
        )?)
    }
}

impl Experiment for Topologies {
    type Options = TopologiesOptions;
    const NAME: &'static str = "topologies";
    const DIR: &'static str = "runs/topologies";
    const BASE: Embedded = Embedded::Paper;
    fn validate(opts: &TopologiesOptions) -> Result<()> {
        opts.validate()
    }
    fn check_base(base: &Base) -> Result<()> {
        check_topologies_base(base)
    }
    fn measure(
        base: &Base,
        opts: &TopologiesOptions,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(base, opts, out, progress)
    }
    fn write(&self, _base: &Base, opts: &TopologiesOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts, dir)
    }
    /// One line per topology, size and condition (varsigma1, c, beta1/beta2), in columns.
    fn summary(&self) -> String {
        let mut text = format!(
            "{:<6} {:>3} {:>13} {:>10} {:>8} {:>12}\n",
            "graph", "N", "condition", "varsigma1", "c", "b1/b2"
        );
        for r in &self.rows {
            let _ = writeln!(
                text,
                "{:<6} {:>3} {:>13} {:>10.4} {:>8.4} {:>12.1}",
                r.topology, r.followers, r.condition, r.varsigma1, r.c, r.beta1_over_beta2
            );
        }
        text
    }
}
