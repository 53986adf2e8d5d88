//! Graceful degradation under jams ([`degradation`]).
use super::*;
use platoon_output::markdown;

/// How [`degradation`] runs; [`DegradationOptions::default`] is `platoon experiment
/// degradation`'s default.
#[derive(Debug, Clone, PartialEq)]
pub struct DegradationOptions {
    /// Platoon sizes (followers; `--followers`); the base's initial states are replaced by a
    /// formation when the size differs.
    pub followers: Vec<usize>,
}

impl Default for DegradationOptions {
    fn default() -> Self {
        Self {
            followers: vec![4, 10],
        }
    }
}

impl DegradationOptions {
    /// Fails on sizes no platoon has, before anything runs or is written.
    pub fn validate(&self) -> Result<()> {
        check_sizes(&self.followers, "--followers", "4,10")
    }
}

/// One run of [`degradation`] (a row of degradation.csv).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DegradationRow {
    /// The attack's name ([`DEGRADATION_ATTACKS`]).
    pub attack: &'static str,
    /// Followers.
    pub followers: usize,
    /// `zero`, `hold`, `predict` or `acc`.
    pub fallback: &'static str,
    /// Whether the emergency-braking guard was on.
    pub guard: bool,
    /// The largest |spacing error| (m).
    pub max_spacing_error_m: f64,
    /// The smallest gap (m; below 0: a collision).
    pub min_gap_m: f64,
    /// The smallest time to collision (s).
    pub min_ttc_s: Option<f64>,
    /// The largest deceleration (m/s^2).
    pub max_deceleration_mps2: f64,
    /// The safety class.
    pub class: SafetyClass,
    /// Whether two vehicles collided.
    pub collided: bool,
    /// Broadcasts.
    pub messages: u64,
    /// Times the guard took over.
    pub guard_activations: u64,
    /// Time followers spent out of the cooperative law (s, summed).
    pub fallback_time_s: f64,
}

/// Graceful degradation ([`degradation`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Degradation {
    /// Attack by attack, size by size, fallback by fallback, guard off then on.
    pub rows: Vec<DegradationRow>,
    /// degradation.md: the table (what `platoon experiment degradation` prints).
    pub markdown: String,
}

/// The attacks of [`degradation`]: `[start, duration]` intervals.
pub const DEGRADATION_ATTACKS: [(&str, &[[f64; 2]]); 5] = [
    ("acceleration-ramp", &[[9.0, 8.0]]),
    ("braking-ramp", &[[34.0, 8.0]]),
    ("cruise", &[[20.0, 10.0]]),
    (
        "paper",
        &[
            [1.0, 1.5],
            [5.0, 1.5],
            [16.0, 1.5],
            [22.0, 1.5],
            [30.0, 1.5],
            [42.0, 1.5],
            [49.0, 1.0],
        ],
    ),
    ("long-jam", &[[25.0, 20.0]]),
];

/// The fallbacks compared, by name.
const MODES: [(&str, platoon_control::FallbackMode); 4] = [
    ("zero", platoon_control::FallbackMode::Zero),
    ("hold", platoon_control::FallbackMode::Hold),
    ("predict", platoon_control::FallbackMode::Predict),
    ("acc", platoon_control::FallbackMode::Acc),
];

/// Graceful degradation: the same attacks ([`DEGRADATION_ATTACKS`]: an 8 s jam on the
/// leader's acceleration ramp, one on its braking ramp, a 10 s jam during cruise, the paper's
/// schedule, and a 20 s jam) on platoons of each size, for every fallback (zero, hold,
/// predict, acc), each with and without the emergency-braking guard, in process; the base's
/// `[fallback]`, `[radar]` and `[guard]` settings are kept. `progress` counts the runs. With
/// `out`: config.toml, degradation.csv, degradation.md and degradation.png (smallest gap per
/// attack and fallback, for the first size).
pub fn degradation(
    base: &Base,
    opts: &DegradationOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Degradation> {
    super::run::<Degradation>(base, opts, out, progress)
}

/// [`degradation`]'s cells (and their runs' directories in `out`), without its tables and figures.
fn measure(
    base: &Base,
    opts: &DegradationOptions,
    out: Option<&RunDir>,
    progress: &dyn Progress,
) -> Result<Degradation> {
    let label = &base.label;
    write_config(out, &base.config)?;
    let modes = MODES;
    let mut cells = Vec::new();
    for (attack, intervals) in DEGRADATION_ATTACKS {
        for &n in &opts.followers {
            for (name, mode) in modes {
                cells.extend([false, true].map(|guard| (attack, intervals, n, name, mode, guard)));
            }
        }
    }
    let rows = walk(
        progress,
        "simulating",
        cells,
        |&(attack, _, n, name, _, guard)| {
            format!(
                "{attack}, {n} followers, {name}{}",
                if guard { " + guard" } else { "" }
            )
        },
        |(attack, intervals, n, name, mode, guard)| {
            let mut c = base.config.clone();
            if n != c.platoon.followers {
                resize(&mut c, n);
            }
            c.control.attack_input = None;
            c.fallback.mode = Some(mode);
            c.guard.enabled = guard;
            c.attack = platoon_config::Attack {
                kind: platoon_config::DosConfig::Intervals {
                    intervals: intervals.to_vec(),
                },
                ..Default::default()
            };
            let scenario = platoon_config::to_scenario(&mut c).map_err(|e| {
                let (key, e) = (e.key, e.reason);
                ExperimentError::Variant(format!("{label}: key `{key}` with {n} followers: {e}"))
            })?;
            let s = platoon_sim::run(scenario, |_| {})?;
            Ok(DegradationRow {
                attack,
                followers: n,
                fallback: name,
                guard,
                max_spacing_error_m: s.max_spacing_error_m(),
                min_gap_m: s.safety.min_gap_m,
                min_ttc_s: s.safety.min_ttc_s,
                max_deceleration_mps2: s.safety.max_deceleration_mps2,
                class: s.safety.class,
                collided: s.safety.collided,
                messages: s.triggers_total,
                guard_activations: s.vehicles.iter().map(|v| v.guard_activations).sum(),
                fallback_time_s: s
                    .vehicles
                    .iter()
                    .flat_map(|v| v.mode_time_s.iter())
                    .filter(|(m, _)| m.as_str() != "coop")
                    .map(|(_, t)| t)
                    .sum(),
            })
        },
    )?;
    let mut md = markdown::header(&[
        "attack",
        "followers",
        "fallback",
        "guard",
        "max spacing error (m)",
        "min gap (m)",
        "min TTC (s)",
        "max decel (m/s^2)",
        "class",
        "messages",
        "guard activations",
    ]);
    for r in &rows {
        markdown::row(
            &mut md,
            &[
                &r.attack,
                &r.followers,
                &r.fallback,
                &if r.guard { "on" } else { "off" },
                &format_args!("{:.2}", r.max_spacing_error_m),
                &format_args!("{:.2}", r.min_gap_m),
                &r.min_ttc_s.map_or("-".into(), |t| format!("{t:.2}")),
                &format_args!("{:.2}", r.max_deceleration_mps2),
                &format_args!(
                    "{}{}",
                    r.class,
                    if r.collided { " (collision)" } else { "" }
                ),
                &r.messages,
                &r.guard_activations,
            ],
        );
    }
    Ok(Degradation { rows, markdown: md })
}

impl Degradation {
    fn write_files(&self, n0: usize, modes: &[&str], dir: &RunDir) -> Result<()> {
        let rows = &self.rows;
        write_table(dir, "degradation", rows, &self.markdown)?;
        // The smallest gap per attack (the first size, guard off and on) for each fallback.
        let categories: Vec<String> = DEGRADATION_ATTACKS
            .iter()
            .map(|(a, _)| a.to_string())
            .collect();
        let groups: Vec<(String, Vec<f64>)> = modes
            .iter()
            .flat_map(|name| [(name, false), (name, true)])
            .map(|(name, guard)| {
                let values = DEGRADATION_ATTACKS
                    .iter()
                    .map(|(a, _)| {
                        rows.iter()
                            .find(|r| {
                                r.attack == *a
                                    && r.followers == n0
                                    && r.fallback == *name
                                    && r.guard == guard
                            })
                            .map_or(0.0, |r| r.min_gap_m.max(0.0))
                    })
                    .collect();
                (
                    format!("{name}{}", if guard { " + guard" } else { "" }),
                    values,
                )
            })
            .collect();
        Ok(plots::grouped_bars(
            &dir.path("degradation.png"),
            &format!("Smallest gap by attack and fallback ({n0} followers; 0 = collision)"),
            "smallest gap (m)",
            &categories,
            &groups,
        )?)
    }
}

impl Experiment for Degradation {
    type Options = DegradationOptions;
    const NAME: &'static str = "degradation";
    const DIR: &'static str = "runs/degradation";
    const BASE: Embedded = Embedded::Degradation;
    fn validate(opts: &DegradationOptions) -> Result<()> {
        opts.validate()
    }
    fn measure(
        base: &Base,
        opts: &DegradationOptions,
        out: Option<&RunDir>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        measure(base, opts, out, progress)
    }
    fn write(&self, _base: &Base, opts: &DegradationOptions, dir: &RunDir) -> Result<()> {
        self.write_files(opts.followers[0], &MODES.map(|m| m.0), dir)
    }
    fn summary(&self) -> String {
        self.markdown.clone()
    }
}
