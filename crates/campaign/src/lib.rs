//! Campaigns: many runs of one scenario over axes of config values, a DoS-window map and
//! Monte Carlo draws, each run a *cell*.
//!
//! [`Campaign::load`] reads a campaign file (TOML, unknown keys are errors, errors name the file,
//! line and key) and expands it into cells, each a resolved scenario config (every default
//! written out, as `platoon run` saves it), a hash of that config (what identifies a finished cell
//! when an interrupted campaign resumes), and, with Monte Carlo, a seed derived only from the
//! campaign seed and the sample index. Running cells and writing outputs is the CLI's job; this
//! crate only decides what each cell is and reads its metrics back from its `summary.json`.
#![warn(missing_docs)]

pub mod metrics;
pub mod overrides;
mod spec;

pub use overrides::{drop_excluded, set};
pub use spec::*;

use platoon_config::ConfigError;
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// More cells than this is surely a typo in a range.
pub const MAX_CELLS: usize = 1_000_000;

/// One `cells.csv` column that comes from the campaign: an axis (or a DoS-window axis).
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// The column's name: the config key, or `dos.onset_s` / `dos.duration_s`.
    pub name: String,
    /// Its values, in order.
    pub values: Vec<toml::Value>,
    /// The dimension it belongs to (zipped axes share one).
    pub dim: usize,
}

/// One run of the campaign.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Row-major index over the dimensions (the first slowest), then the sample.
    pub index: usize,
    /// The value index in each dimension.
    pub coords: Vec<usize>,
    /// Monte Carlo sample (0 without Monte Carlo).
    pub sample: usize,
    /// The sample's seed (Monte Carlo only).
    pub seed: Option<u64>,
    /// The drawn values of [`Campaign::drawn_columns`].
    pub drawn: Vec<f64>,
    /// The resolved scenario config (TOML), or why this combination is not a valid scenario.
    pub config: Result<String, String>,
    /// SHA-256 of the resolved config and the transport: a finished cell with the same hash is
    /// not run again.
    pub hash: String,
    /// Followers per platoon (0 for an invalid config).
    pub followers: usize,
    /// The cell's plant (`None` for an invalid config).
    pub plant: Option<platoon_config::PlantKind>,
}

impl Cell {
    /// The cell's directory name (`c0042`), zero-padded to the campaign's size.
    pub fn dir_name(&self, cells: usize) -> String {
        let width = cells.saturating_sub(1).to_string().len().max(4);
        format!("c{:0width$}", self.index)
    }
}

/// A campaign file expanded into cells.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// The campaign file (used in errors).
    pub file: PathBuf,
    /// The file as parsed, with the defaults written out (`metrics`) and `base` absolute.
    pub spec: CampaignFile,
    /// The campaign's name.
    pub name: String,
    /// The base scenario's resolved config (TOML).
    pub base_toml: String,
    /// Where the base came from (a path or the embedded paper scenario).
    pub base_label: String,
    /// Axis columns.
    pub columns: Vec<Column>,
    /// Values per dimension.
    pub dims: Vec<usize>,
    /// Monte Carlo samples per combination (1 without Monte Carlo).
    pub samples: usize,
    /// Columns of the values drawn per sample (`mc.loss`, `mc.tau_s`).
    pub drawn_columns: Vec<String>,
    /// The metric names.
    pub metrics: Vec<String>,
    /// Every cell.
    pub cells: Vec<Cell>,
}

fn error(file: &Path, line: Option<usize>, key: &str, message: impl Into<String>) -> ConfigError {
    ConfigError::new(file, key, message).at_line(line)
}

/// The scenario a campaign or search file starts from.
#[derive(Debug, Clone)]
pub struct BaseScenario {
    /// Its resolved config.
    pub config: platoon_config::Config,
    /// Where it came from: the absolute path, or the embedded paper scenario's label.
    pub label: String,
    /// The absolute path of a base given as a file.
    pub path: Option<PathBuf>,
}

impl BaseScenario {
    /// The file's `base`, relative to the folder of `file` and rewritten absolute (an error at
    /// the key `base`, its line from `lines`, when it does not load), or without one the
    /// embedded paper scenario.
    pub fn load(
        base: &mut Option<String>,
        file: &Path,
        lines: &platoon_config::KeyLines,
    ) -> Result<Self, ConfigError> {
        let Some(b) = base else {
            let (config, _) = platoon_config::Embedded::Paper.parse()?;
            return Ok(Self {
                config,
                label: platoon_config::Embedded::Paper.label(),
                path: None,
            });
        };
        let path = file.parent().unwrap_or(Path::new(".")).join(b.as_str());
        let (config, _) = platoon_config::load(&path).map_err(|e| {
            ConfigError::at_key(file, lines, "base", format!("the base scenario: {e}"))
        })?;
        let abs = std::path::absolute(&path).unwrap_or(path);
        *b = abs.display().to_string();
        Ok(Self {
            config,
            label: b.clone(),
            path: Some(abs),
        })
    }
}

/// A file's name: its `name` key, or the file's stem, or `fallback` for a path without one.
pub fn file_name(name: Option<&str>, file: &Path, fallback: &str) -> String {
    match name {
        Some(n) => n.to_string(),
        None => file
            .file_stem()
            .map_or_else(|| fallback.into(), |s| s.to_string_lossy().into_owned()),
    }
}

/// Rounds away the last bits of `from + i step` (0.30000000000000004 -> 0.3).
fn tidy(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.12e}").parse().unwrap_or(x)
}

fn as_f64(v: &toml::Value) -> Option<f64> {
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
}

/// The values of a range.
pub fn expand_range(r: &Range) -> Result<Vec<toml::Value>, String> {
    let (Some(from), Some(to)) = (as_f64(&r.from), as_f64(&r.to)) else {
        return Err("`from` and `to` must be numbers".into());
    };
    match (&r.step, r.count) {
        (Some(_), Some(_)) | (None, None) => Err("give either `step` or `count`".into()),
        (Some(step), None) => {
            let Some(s) = as_f64(step) else {
                return Err("`step` must be a number".into());
            };
            if !(s.is_finite() && s > 0.0 && from.is_finite() && to.is_finite()) || to < from {
                return Err(format!(
                    "needs finite from <= to and step > 0 (got from {from}, to {to}, step {s})"
                ));
            }
            let n = ((to - from) / s + 1e-9).floor() as usize + 1;
            if n > MAX_CELLS {
                return Err(format!("has {n} values"));
            }
            let ints = (r.from.as_integer(), r.to.as_integer(), step.as_integer());
            Ok((0..n)
                .map(|i| match ints {
                    (Some(a), Some(_), Some(d)) => toml::Value::Integer(a + i as i64 * d),
                    _ => toml::Value::Float(tidy(from + i as f64 * s)),
                })
                .collect())
        }
        (None, Some(count)) => {
            if count == 0 || !(from.is_finite() && to.is_finite()) {
                return Err("needs count >= 1 and finite from, to".into());
            }
            if count == 1 {
                return Ok(vec![toml::Value::Float(from)]);
            }
            let d = (to - from) / (count - 1) as f64;
            Ok((0..count)
                .map(|i| toml::Value::Float(tidy(from + i as f64 * d)))
                .collect())
        }
    }
}

fn values_of(v: &Values) -> Result<Vec<toml::Value>, String> {
    match v {
        Values::List(xs) => Ok(xs.iter().map(|x| toml::Value::Float(*x)).collect()),
        Values::Range(r) => expand_range(r),
    }
}

/// The seed of Monte Carlo sample `sample`: from the campaign seed and the index alone.
pub fn sample_seed(campaign_seed: u64, sample: usize) -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(campaign_seed);
    rng.set_stream(sample as u64);
    rng.next_u64()
}

/// A cell's config table `v` resolved (errors as `cells.csv` gives them: the key and the
/// message; `label` names the cell for the parser).
fn cell_config(
    v: &toml::Value,
    label: &str,
) -> Result<(platoon_config::Config, platoon_sim::Scenario), String> {
    let text = toml::to_string(v).map_err(|e| e.to_string())?;
    let (config, scenario) = platoon_config::parse(&text, Path::new(label)).map_err(|e| {
        // The label adds nothing in cells.csv: key and message only.
        if e.key.is_empty() {
            e.message
        } else {
            format!("key `{}`: {}", e.key, e.message)
        }
    })?;
    // A cell runs on its config's plant: SUMO's traffic on the native one would be dropped
    // without a word (as `platoon run` refuses it).
    if config.simulation.plant == platoon_config::PlantKind::Native {
        platoon_config::native_plant_check(&config)
            .map_err(|e| format!("key `{}`: {}", e.key, e.reason))?;
    }
    Ok((config, scenario))
}

/// A cell's identity: the hash of its resolved config and how it runs.
pub fn cell_hash(config: &str, transport: Transport) -> String {
    let mut h = Sha256::new();
    h.update(config.as_bytes());
    h.update(b"\n# platoon campaign cell, transport = ");
    h.update(transport.name().as_bytes());
    format!("{:x}", h.finalize())
}

/// The base scenario as a TOML value, its relative SUMO network made absolute (relative to the
/// base file `base_path`), since cell configs are written elsewhere.
fn base_value(
    base_config: &platoon_config::Config,
    base_path: Option<&Path>,
    file: &Path,
) -> Result<toml::Value, ConfigError> {
    let base_dir = base_path.map(|p| p.parent().map(Path::to_path_buf).unwrap_or_default());
    let mut base = toml::Value::try_from(base_config).map_err(|e| {
        error(
            file,
            None,
            "base",
            format!("cannot represent the base: {e}"),
        )
    })?;
    if let (Some(net), Some(bdir)) = (&base_config.sumo.net, &base_dir) {
        if Path::new(net).is_relative() {
            let abs = bdir.join(net);
            let abs = abs.canonicalize().unwrap_or(abs);
            set(
                &mut base,
                "sumo.net",
                toml::Value::String(abs.display().to_string()),
            )
            .map_err(|e| error(file, None, "base", e))?;
        }
    }
    Ok(base)
}

/// The keys a campaign file (`file`) sets on its base scenario.
struct Settings<'a> {
    base: &'a toml::Value,
    file: &'a Path,
}

impl Settings<'_> {
    /// `key` exists in the schema and takes `value` (the setting `what` of the campaign, at
    /// `line`).
    fn check(
        &self,
        key: &str,
        value: &toml::Value,
        what: &str,
        line: Option<usize>,
    ) -> Result<(), ConfigError> {
        let file = self.file;
        let mut v = self.base.clone();
        set(&mut v, key, value.clone()).map_err(|m| error(file, line, what, m))?;
        drop_excluded(&mut v, &[key]);
        platoon_config::from_value(v).map(|_| ()).map_err(|e| {
            error(
                file,
                line,
                what,
                format!(
                    "`{key}` = {value}: {} (at scenario key `{}`)",
                    e.reason, e.key
                ),
            )
        })
    }
}

/// `[[axes]]`: a column each, and the dimensions they span (zipped axes share one).
fn axes(
    spec: &CampaignFile,
    settings: &Settings<'_>,
    lines: &platoon_config::KeyLines,
) -> Result<(Vec<Column>, Vec<usize>), ConfigError> {
    let file = settings.file;
    let mut columns: Vec<Column> = Vec::new();
    let mut dims: Vec<usize> = Vec::new();
    let mut zip_dims: Vec<(String, usize)> = Vec::new();
    for (i, axis) in spec.axes.iter().enumerate() {
        let what = format!("axes[{i}]");
        let line = lines.line_of(&format!("{what}.key"));
        let values = match (&axis.values, &axis.range) {
            (Some(v), None) => v.clone(),
            (None, Some(r)) => {
                expand_range(r).map_err(|m| error(file, line, &format!("{what}.range"), m))?
            }
            _ => {
                return Err(error(
                    file,
                    line,
                    &what,
                    format!("axis `{}` needs either `values` or `range`", axis.key),
                ))
            }
        };
        let refused = if values.is_empty() {
            Some(format!("axis `{}` has no values", axis.key))
        } else if columns.iter().any(|c| c.name == axis.key) {
            Some(format!("`{}` is on two axes", axis.key))
        } else if spec.set.contains_key(&axis.key) {
            Some(format!("`{}` is both in `set` and on an axis", axis.key))
        } else {
            None
        };
        if let Some(message) = refused {
            return Err(error(file, line, &what, message));
        }
        for v in &values {
            settings.check(&axis.key, v, &what, line)?;
        }
        let dim = match &axis.zip {
            Some(group) => match zip_dims.iter().find(|(g, _)| g == group) {
                Some(&(_, d)) => {
                    if dims[d] != values.len() {
                        return Err(error(
                            file,
                            line,
                            &format!("{what}.zip"),
                            format!(
                                "zip group \"{group}\" has axes of {} and {} values; zipped axes need equal lengths",
                                dims[d],
                                values.len()
                            ),
                        ));
                    }
                    d
                }
                None => {
                    zip_dims.push((group.clone(), dims.len()));
                    dims.push(values.len());
                    dims.len() - 1
                }
            },
            None => {
                dims.push(values.len());
                dims.len() - 1
            }
        };
        columns.push(Column {
            name: axis.key.clone(),
            values,
            dim,
        });
    }
    Ok((columns, dims))
}

/// `[dos_window]`: its onsets and durations as two more axes.
fn dos_window(
    w: &DosWindow,
    file: &Path,
    lines: &platoon_config::KeyLines,
    columns: &mut Vec<Column>,
    dims: &mut Vec<usize>,
) -> Result<(), ConfigError> {
    for (name, v) in [("onset_s", &w.onset_s), ("duration_s", &w.duration_s)] {
        let key = format!("dos_window.{name}");
        let at = lines.line_of(&key);
        let values = values_of(v).map_err(|m| error(file, at, &key, m))?;
        let bad = values.iter().any(|x| {
            let x = as_f64(x).unwrap_or(f64::NAN);
            !(x.is_finite() && (x > 0.0 || (name == "onset_s" && x == 0.0)))
        });
        if values.is_empty() || bad {
            return Err(error(
                file,
                at,
                &key,
                "needs at least one value; onsets >= 0 and durations > 0 (s)",
            ));
        }
        dims.push(values.len());
        columns.push(Column {
            name: format!("dos.{name}"),
            values,
            dim: dims.len() - 1,
        });
    }
    Ok(())
}

/// `[monte_carlo]` (its sample count overridden by `samples`): the samples per combination of
/// the axes, and the columns of what each draws.
fn monte_carlo(
    monte_carlo: &mut Option<MonteCarlo>,
    samples: Option<usize>,
    file: &Path,
    lines: &platoon_config::KeyLines,
) -> Result<(usize, Vec<String>), ConfigError> {
    let at = |key: &str| lines.line_of(key);
    let mut drawn_columns = Vec::new();
    let Some(mc) = monte_carlo else {
        if samples.is_some() {
            return Err(error(
                file,
                None,
                "monte_carlo",
                "a sample count (--samples, or samples= from Python) needs a [monte_carlo] section",
            ));
        }
        return Ok((1, drawn_columns));
    };
    if let Some(n) = samples {
        mc.samples = n;
    }
    if mc.samples == 0 {
        return Err(error(
            file,
            at("monte_carlo.samples"),
            "monte_carlo.samples",
            "must be >= 1",
        ));
    }
    for (key, range) in [("loss", mc.loss), ("tau_s", mc.tau_s)] {
        if let Some([lo, hi]) = range {
            let ok = lo.is_finite() && hi.is_finite() && lo <= hi && lo >= 0.0;
            let ok = ok && (key != "loss" || hi <= 1.0) && (key != "tau_s" || lo > 0.0);
            if !ok {
                return Err(error(
                    file,
                    at(&format!("monte_carlo.{key}")),
                    &format!("monte_carlo.{key}"),
                    "needs [min, max] with 0 <= min <= max (a loss rate at most 1, a tau above 0)",
                ));
            }
            drawn_columns.push(format!("mc.{key}"));
        }
    }
    for (key, x) in [
        ("position_jitter_m", mc.position_jitter_m),
        ("speed_jitter_mps", mc.speed_jitter_mps),
    ] {
        if !(x.is_finite() && x >= 0.0) {
            return Err(error(
                file,
                at(&format!("monte_carlo.{key}")),
                &format!("monte_carlo.{key}"),
                "must be a number >= 0",
            ));
        }
    }
    Ok((mc.samples, drawn_columns))
}

/// The cells of `samples` samples of every combination of `dims`, at most [`MAX_CELLS`].
fn cell_count(dims: &[usize], samples: usize, file: &Path) -> Result<usize, ConfigError> {
    let combos = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
    match combos.and_then(|c| c.checked_mul(samples)) {
        Some(t) if t <= MAX_CELLS => Ok(t),
        _ => Err(error(
            file,
            None,
            "",
            format!("the campaign would have more than {MAX_CELLS} cells; check the ranges"),
        )),
    }
}

impl Campaign {
    /// Reads and expands a campaign file. `samples` overrides `monte_carlo.samples` (a quick
    /// pilot of a large study).
    pub fn load(path: &Path, samples: Option<usize>) -> Result<Campaign, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| error(path, None, "", format!("cannot read the campaign: {e}")))?;
        Self::parse(&text, path, samples)
    }

    /// Parses and expands campaign text (`file` names it in errors and anchors `base`).
    pub fn parse(text: &str, file: &Path, samples: Option<usize>) -> Result<Campaign, ConfigError> {
        let mut spec: CampaignFile = platoon_config::deserialize(text, file)?;
        let lines = platoon_config::KeyLines::new(text);
        let at = |key: &str| lines.line_of(key);

        // The base scenario, resolved.
        let BaseScenario {
            config: base_config,
            label: base_label,
            path: base_path,
        } = BaseScenario::load(&mut spec.base, file, &lines)?;
        let base = base_value(&base_config, base_path.as_deref(), file)?;
        let base_toml = platoon_config::to_toml(&base_config);

        // Metrics.
        let metrics = spec
            .metrics
            .clone()
            .unwrap_or_else(|| metrics::DEFAULT.iter().map(|s| s.to_string()).collect());
        metrics::validate(&metrics).map_err(|m| error(file, at("metrics"), "metrics", m))?;
        spec.metrics = Some(metrics.clone());

        // Every key the campaign sets must exist in the schema and take the values given:
        // checked on the base alone, so a typo is a campaign error, not a thousand failed cells.
        let settings = Settings { base: &base, file };
        for (key, value) in &spec.set {
            settings.check(key, value, &format!("set.{key}"), lines.line(&["set", key]))?;
        }
        let (mut columns, mut dims) = axes(&spec, &settings, &lines)?;
        if let Some(w) = &spec.dos_window {
            dos_window(w, file, &lines, &mut columns, &mut dims)?;
        }
        let (samples, drawn_columns) = monte_carlo(&mut spec.monte_carlo, samples, file, &lines)?;
        let total = cell_count(&dims, samples, file)?;

        let name = file_name(spec.name.as_deref(), file, "campaign");
        let mut campaign = Campaign {
            file: file.to_path_buf(),
            spec,
            name,
            base_toml,
            base_label,
            columns,
            dims,
            samples,
            drawn_columns,
            metrics,
            cells: Vec::with_capacity(total),
        };
        let mut coords = vec![0usize; campaign.dims.len()];
        for index in 0..total {
            let combo = index / samples;
            let sample = index % samples;
            let mut rest = combo;
            for d in (0..coords.len()).rev() {
                coords[d] = rest % campaign.dims[d];
                rest /= campaign.dims[d];
            }
            let cell = campaign.resolve(&base, index, &coords, sample);
            campaign.cells.push(cell);
        }
        if campaign.spec.transport == Transport::Inproc {
            let sumo = Some(platoon_config::PlantKind::Sumo);
            if let Some(c) = campaign.cells.iter().find(|c| c.plant == sumo) {
                return Err(error(
                    file,
                    at("transport"),
                    "transport",
                    format!(
                        "cell {} runs SUMO as the plant, which is a process: set transport = \"iceoryx2\"",
                        c.index
                    ),
                ));
            }
        }
        Ok(campaign)
    }

    /// Builds one cell's config from the base.
    fn resolve(&self, base: &toml::Value, index: usize, coords: &[usize], sample: usize) -> Cell {
        let mut v = base.clone();
        let mut touched: Vec<String> = Vec::new();
        let mut result: Result<(), String> = Ok(());
        let mut apply = |v: &mut toml::Value, key: &str, value: toml::Value| {
            if result.is_ok() {
                result = set(v, key, value).map_err(|m| format!("key `{key}`: {m}"));
                touched.push(key.to_string());
            }
        };
        for (key, value) in &self.spec.set {
            apply(&mut v, key, value.clone());
        }
        let mut window = (None, None);
        for c in &self.columns {
            let value = c.values[coords[c.dim]].clone();
            match c.name.as_str() {
                "dos.onset_s" => window.0 = as_f64(&value),
                "dos.duration_s" => window.1 = as_f64(&value),
                key => apply(&mut v, key, value),
            }
        }
        if let (Some(onset), Some(duration)) = window {
            apply(
                &mut v,
                "attack.kind",
                toml::Value::String("intervals".into()),
            );
            apply(
                &mut v,
                "attack.intervals",
                toml::Value::Array(vec![toml::Value::Array(vec![
                    toml::Value::Float(onset),
                    toml::Value::Float(duration),
                ])]),
            );
        }
        let mut seed = None;
        let mut drawn = Vec::new();
        if let Some(mc) = &self.spec.monte_carlo {
            let s = sample_seed(self.spec.seed, sample);
            seed = Some(s);
            let mut rng = ChaCha8Rng::seed_from_u64(s);
            // Always the same draws in the same order, whatever is enabled.
            let dos_seed = rng.next_u64();
            let channel_seed = rng.next_u64();
            let loss_u: f64 = rng.gen();
            let tau_u: f64 = rng.gen();
            let jitter_seed = rng.next_u64();
            if let Some(d) = &mc.dos {
                let mut attack: toml::Table = toml::Table::new();
                attack.insert("kind".into(), "random".into());
                attack.insert("seed".into(), toml::Value::Integer((dos_seed >> 1) as i64));
                for (k, x) in [
                    ("min_gap_s", d.min_gap_s),
                    ("max_gap_s", d.max_gap_s),
                    ("min_duration_s", d.min_duration_s),
                    ("max_duration_s", d.max_duration_s),
                ] {
                    attack.insert(k.into(), toml::Value::Float(x));
                }
                let mut bounds = toml::Table::new();
                for (k, x) in [("T1", d.T1), ("T2", d.T2), ("D1", d.D1), ("D2", d.D2)] {
                    bounds.insert(k.into(), toml::Value::Float(x));
                }
                attack.insert("assumption2".into(), toml::Value::Table(bounds));
                apply(&mut v, "attack", toml::Value::Table(attack));
            }
            if let Some([lo, hi]) = mc.loss {
                let loss = tidy(lo + (hi - lo) * loss_u);
                drawn.push(loss);
                let mut attack = toml::Table::new();
                attack.insert("kind".into(), "bernoulli".into());
                attack.insert("loss".into(), toml::Value::Float(loss));
                apply(
                    &mut v,
                    "channel.seed",
                    toml::Value::Integer((channel_seed >> 1) as i64),
                );
                let list = v
                    .get("channel")
                    .and_then(|c| c.get("attacks"))
                    .and_then(|a| a.as_array())
                    .cloned()
                    .unwrap_or_default();
                let mut list = list;
                list.push(toml::Value::Table(attack));
                apply(&mut v, "channel.attacks", toml::Value::Array(list));
            }
            if let Some([lo, hi]) = mc.tau_s {
                let tau = tidy(lo + (hi - lo) * tau_u);
                drawn.push(tau);
                let mut t = toml::Table::new();
                t.insert("kind".into(), "constant".into());
                t.insert("value_s".into(), toml::Value::Float(tau));
                apply(&mut v, "plant.tau", toml::Value::Table(t));
                if let Some(p) = v.get_mut("plant").and_then(|p| p.as_table_mut()) {
                    p.remove("tau_per_vehicle");
                }
            }
            if mc.position_jitter_m > 0.0 || mc.speed_jitter_mps > 0.0 {
                jitter(&mut v, mc, jitter_seed, &mut apply);
            }
        }
        let touched_refs: Vec<&str> = touched.iter().map(String::as_str).collect();
        drop_excluded(&mut v, &touched_refs);
        let label = format!("cell {index}");
        let resolved = result.and_then(|()| cell_config(&v, &label));
        let transport = self.spec.transport;
        match resolved {
            Ok((config, scenario)) => {
                let text = platoon_config::to_toml(&config);
                Cell {
                    index,
                    coords: coords.to_vec(),
                    sample,
                    seed,
                    drawn,
                    hash: cell_hash(&text, transport),
                    config: Ok(text),
                    followers: scenario.topology.followers(),
                    plant: Some(config.simulation.plant),
                }
            }
            Err(e) => Cell {
                index,
                coords: coords.to_vec(),
                sample,
                seed,
                drawn,
                hash: cell_hash(&e, transport),
                config: Err(e),
                followers: 0,
                plant: None,
            },
        }
    }

    /// Followers of the largest platoon in any cell.
    pub fn max_followers(&self) -> usize {
        self.cells.iter().map(|c| c.followers).max().unwrap_or(0)
    }

    /// The resolved campaign file (defaults written out, `base` absolute).
    pub fn resolved_toml(&self) -> String {
        toml::to_string_pretty(&self.spec).unwrap_or_default()
    }

    /// The value of column `c` in `cell`.
    pub fn value(&self, c: &Column, cell: &Cell) -> toml::Value {
        c.values[cell.coords[c.dim]].clone()
    }
}

/// Moves the followers' initial states: through `[platoon.formation]` when the base uses one,
/// otherwise on the listed `platoon.initial_states` (uniform offsets, ChaCha8 from `seed`).
fn jitter(
    v: &mut toml::Value,
    mc: &MonteCarlo,
    seed: u64,
    apply: &mut impl FnMut(&mut toml::Value, &str, toml::Value),
) {
    let formation = v.get("platoon").and_then(|p| p.get("formation")).is_some();
    if formation {
        apply(
            v,
            "platoon.formation.position_jitter_m",
            toml::Value::Float(mc.position_jitter_m),
        );
        apply(
            v,
            "platoon.formation.speed_jitter_mps",
            toml::Value::Float(mc.speed_jitter_mps),
        );
        apply(
            v,
            "platoon.formation.seed",
            toml::Value::Integer((seed >> 1) as i64),
        );
        return;
    }
    let Some(states) = v
        .get("platoon")
        .and_then(|p| p.get("initial_states"))
        .and_then(|s| s.as_array())
        .cloned()
    else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let moved: Vec<toml::Value> = states
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut row = row.as_array().cloned().unwrap_or_default();
            if i > 0 && row.len() == 3 {
                let dp: f64 = rng.gen_range(-1.0..=1.0) * mc.position_jitter_m;
                let dv: f64 = rng.gen_range(-1.0..=1.0) * mc.speed_jitter_mps;
                for (k, d) in [(0, dp), (1, dv)] {
                    if let Some(x) = as_f64(&row[k]) {
                        row[k] = toml::Value::Float(x + d);
                    }
                }
            }
            toml::Value::Array(row)
        })
        .collect();
    apply(v, "platoon.initial_states", toml::Value::Array(moved));
}

#[cfg(test)]
mod tests;
