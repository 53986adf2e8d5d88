//! What a campaign writes once its cells are in: `cells.csv`, `campaign.json` ([`Report`]) and
//! the plots.
use super::Result;
use super::{CellResult, CellStatus};
use crate::error::Context;
use platoon_campaign::metrics::{self, Metric};
use platoon_campaign::{Campaign, Cell};
use platoon_output::plots::{ensure_font, err};
use platoon_sim::SafetyClass;
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The metric values of every cell (None for cells that are not ok).
pub(crate) struct Table<'a> {
    pub(crate) campaign: &'a Campaign,
    pub(crate) columns: Vec<String>,
    pub(crate) values: Vec<Option<Vec<Metric>>>,
}

impl<'a> Table<'a> {
    pub(crate) fn new(campaign: &'a Campaign, outcomes: &[CellResult]) -> Self {
        let columns = metrics::columns(&campaign.metrics, campaign.max_followers());
        let values = outcomes.iter().map(|o| o.metrics.clone()).collect();
        Self {
            campaign,
            columns,
            values,
        }
    }

    fn metric(&self, cell: usize, column: usize) -> Option<&Metric> {
        self.values[cell].as_ref().map(|v| &v[column])
    }
}

fn field(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Float(x) => format!("{x}"),
        other => other.to_string(),
    }
}

/// `cells.csv`: one row per cell, in cell order, whatever order the cells finished in.
pub(crate) fn cells_csv(path: &Path, table: &Table, outcomes: &[CellResult]) -> Result<()> {
    let c = table.campaign;
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    let mut header: Vec<String> = vec!["cell".into()];
    header.extend(c.columns.iter().map(|col| col.name.clone()));
    header.extend(["sample".into(), "seed".into()]);
    header.extend(c.drawn_columns.iter().cloned());
    header.push("status".into());
    header.extend(table.columns.iter().cloned());
    header.push("error".into());
    w.write_record(&header)?;
    for (cell, outcome) in c.cells.iter().zip(outcomes) {
        let mut row: Vec<String> = vec![cell.index.to_string()];
        row.extend(c.columns.iter().map(|col| field(&c.value(col, cell))));
        row.push(cell.sample.to_string());
        row.push(cell.seed.map(|s| s.to_string()).unwrap_or_default());
        row.extend(cell.drawn.iter().map(|x| format!("{x}")));
        let error = match outcome.status {
            CellStatus::Failed => outcome.error.clone().unwrap_or_default(),
            CellStatus::Ok | CellStatus::NotRun => String::new(),
        };
        row.push(outcome.status.name().into());
        match &table.values[cell.index] {
            Some(v) => row.extend(v.iter().map(|m| m.to_string())),
            None => row.extend(std::iter::repeat_n(String::new(), table.columns.len())),
        }
        row.push(error);
        w.write_record(&row)?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// A `triggers_by_follower` column (`triggers_3`).
fn per_follower(column: &str) -> bool {
    column
        .strip_prefix("triggers_")
        .is_some_and(|i| i.parse::<usize>().is_ok())
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

/// The dimensions with more than one value, the ones plots and groups are made of.
fn varying(c: &Campaign) -> Vec<usize> {
    (0..c.dims.len()).filter(|&d| c.dims[d] > 1).collect()
}

fn dim_name(c: &Campaign, d: usize) -> String {
    c.columns
        .iter()
        .filter(|col| col.dim == d)
        .map(|col| col.name.clone())
        .collect::<Vec<_>>()
        .join(" + ")
}

fn dim_label(c: &Campaign, d: usize, j: usize) -> String {
    c.columns
        .iter()
        .filter(|col| col.dim == d)
        .map(|col| field(&col.values[j]))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The dimension's values as numbers, when its first column is numeric.
fn dim_numbers(c: &Campaign, d: usize) -> Option<Vec<f64>> {
    let col = c.columns.iter().find(|col| col.dim == d)?;
    col.values
        .iter()
        .map(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
        .collect()
}

fn group_label(c: &Campaign, dims: &[usize], cell: &Cell) -> String {
    dims.iter()
        .map(|&d| format!("{} = {}", dim_name(c, d), dim_label(c, d, cell.coords[d])))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Quantiles of one metric over a group's ok cells (its finite values).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Quantiles {
    /// The smallest value.
    pub min: f64,
    /// The 10th percentile (linear interpolation).
    pub p10: f64,
    /// The median.
    pub median: f64,
    /// The 90th percentile.
    pub p90: f64,
    /// The largest value.
    pub max: f64,
    /// The mean.
    pub mean: f64,
}

/// One combination of the varying dimensions (every sample of it): counts, the safety
/// classes and the quantiles of every numeric metric (what a Monte Carlo study reads first).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Group {
    /// The combination, e.g. `trigger.rule = dynamic, dos.duration_s = 1`.
    pub group: String,
    /// Its cells.
    pub cells: usize,
    /// Its ok cells.
    pub ok: usize,
    /// How many ok cells fell in each safety class (with the `safety_class` metric).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub safety_classes: Option<BTreeMap<String, usize>>,
    /// The share of ok cells classed severe (with the `safety_class` metric and ok cells).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub severe_fraction: Option<f64>,
    /// Per numeric metric with a finite value (not the per-follower trigger counts): its
    /// quantiles.
    #[serde(flatten)]
    pub metrics: BTreeMap<String, Quantiles>,
}

/// Per combination of the varying dimensions: counts, the safety classes and quantiles of
/// every numeric metric over its samples.
fn groups(table: &Table) -> Vec<Group> {
    let c = table.campaign;
    let dims = varying(c);
    let mut by: BTreeMap<Vec<usize>, Vec<usize>> = BTreeMap::new();
    for cell in &c.cells {
        let key: Vec<usize> = dims.iter().map(|&d| cell.coords[d]).collect();
        by.entry(key).or_default().push(cell.index);
    }
    let class_col = table.columns.iter().position(|n| n == "safety_class");
    by.values()
        .map(|cells| {
            let first = &c.cells[cells[0]];
            let ok: Vec<usize> = cells
                .iter()
                .copied()
                .filter(|&i| table.values[i].is_some())
                .collect();
            let mut g = Group {
                group: group_label(c, &dims, first),
                cells: cells.len(),
                ok: ok.len(),
                safety_classes: None,
                severe_fraction: None,
                metrics: BTreeMap::new(),
            };
            if let Some(k) = class_col {
                let mut classes: BTreeMap<String, usize> = BTreeMap::new();
                for &i in &ok {
                    if let Some(Metric::Text(s)) = table.metric(i, k) {
                        *classes.entry(s.clone()).or_default() += 1;
                    }
                }
                let severe = classes
                    .get(SafetyClass::Severe.name())
                    .copied()
                    .unwrap_or(0);
                g.safety_classes = Some(classes);
                if !ok.is_empty() {
                    g.severe_fraction = Some(severe as f64 / ok.len() as f64);
                }
            }
            for (k, name) in table.columns.iter().enumerate() {
                let mut xs: Vec<f64> = ok
                    .iter()
                    .filter_map(|&i| table.metric(i, k).and_then(Metric::as_f64))
                    .filter(|x| x.is_finite())
                    .collect();
                if xs.is_empty()
                    || name.starts_with("triggers_")
                        && name != "triggers_total"
                        && name != "triggers_per_follower"
                {
                    continue;
                }
                xs.sort_by(f64::total_cmp);
                g.metrics.insert(
                    name.clone(),
                    Quantiles {
                        min: xs[0],
                        p10: quantile(&xs, 0.1),
                        median: quantile(&xs, 0.5),
                        p90: quantile(&xs, 0.9),
                        max: xs[xs.len() - 1],
                        mean: xs.iter().sum::<f64>() / xs.len() as f64,
                    },
                );
            }
            g
        })
        .collect()
}

/// How the run went, beside the cells.
pub(crate) struct RunInfo {
    pub(crate) complete: bool,
    pub(crate) interrupted: Option<String>,
    pub(crate) executor: String,
    pub(crate) wall_s: f64,
    pub(crate) cpu_s: f64,
    pub(crate) plots: Vec<String>,
}

/// An axis of the campaign (a `cells.csv` column).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Axis {
    /// The config key (dotted path) or the drawn value's name.
    pub name: String,
    /// How many values it takes.
    pub values: usize,
    /// The dimension it varies along (axes of one zip group share one).
    pub dimension: usize,
}

/// A failed cell.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Failure {
    /// Its index.
    pub cell: usize,
    /// Its record, relative to the campaign directory (`cells/c0001`).
    pub directory: String,
    /// Why it failed.
    pub error: Option<String>,
}

/// The campaign's report: what `campaign.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The campaign's name.
    pub name: String,
    /// The campaign file.
    pub campaign_file: String,
    /// The base scenario it varies.
    pub base: String,
    /// Every cell done and nothing stopped the run (the directory is in place).
    pub complete: bool,
    /// Why the run was stopped, if it was (`SIGINT` from the `platoon` binary).
    pub interrupted_by: Option<String>,
    /// How many cells the campaign has.
    pub cells: usize,
    /// How many are ok.
    pub ok: usize,
    /// How many failed.
    pub failed: usize,
    /// How many did not run.
    pub not_run: usize,
    /// How many were kept from an earlier, unfinished run.
    pub reused_from_an_earlier_run: usize,
    /// How the cells ran: `inproc` or `iceoryx2`.
    pub transport: &'static str,
    /// What executed them ([`super::Executor::name`]).
    pub executor: String,
    /// The campaign seed.
    pub seed: u64,
    /// Monte Carlo samples per combination of the axes.
    pub samples: usize,
    /// The axes.
    pub axes: Vec<Axis>,
    /// The metric columns.
    pub metrics: Vec<String>,
    /// Wall time of this run (s).
    pub wall_s: f64,
    /// CPU time of this process and its children during this run (s).
    pub cpu_s: f64,
    /// The failed cells, with their errors.
    pub failures: Vec<Failure>,
    /// Statistics per combination of the varying dimensions.
    pub groups: Vec<Group>,
    /// The plots drawn, relative to the campaign directory.
    pub plots: Vec<String>,
}

impl Report {
    pub(crate) fn new(table: &Table, outcomes: &[CellResult], info: RunInfo) -> Self {
        let c = table.campaign;
        let count = |s: CellStatus| outcomes.iter().filter(|o| o.status == s).count();
        let failures: Vec<Failure> = c
            .cells
            .iter()
            .zip(outcomes)
            .filter(|(_, o)| o.status == CellStatus::Failed)
            .map(|(cell, o)| Failure {
                cell: cell.index,
                directory: format!("cells/{}", cell.dir_name(c.cells.len())),
                error: o.error.clone(),
            })
            .collect();
        Self {
            name: c.name.clone(),
            campaign_file: c.file.display().to_string(),
            base: c.base_label.clone(),
            complete: info.complete,
            interrupted_by: info.interrupted,
            cells: c.cells.len(),
            ok: count(CellStatus::Ok),
            failed: failures.len(),
            not_run: count(CellStatus::NotRun),
            reused_from_an_earlier_run: outcomes.iter().filter(|o| o.reused).count(),
            transport: c.spec.transport.name(),
            executor: info.executor,
            seed: c.spec.seed,
            samples: c.samples,
            axes: c
                .columns
                .iter()
                .map(|col| Axis {
                    name: col.name.clone(),
                    values: col.values.len(),
                    dimension: col.dim,
                })
                .collect(),
            metrics: table.columns.clone(),
            wall_s: info.wall_s,
            cpu_s: info.cpu_s,
            failures,
            groups: groups(table),
            plots: info.plots,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Plots

const CLASSES: [(SafetyClass, RGBColor); 4] = [
    (SafetyClass::None, RGBColor(46, 139, 87)),
    (SafetyClass::Negligible, RGBColor(154, 205, 50)),
    (SafetyClass::Benign, RGBColor(255, 165, 0)),
    (SafetyClass::Severe, RGBColor(200, 30, 30)),
];
const FAILED: RGBColor = RGBColor(170, 170, 170);

/// Which plots a campaign gets: heatmaps for two varying dimensions, lines with spread bands
/// over one, ECDFs for Monte Carlo. Returns the files written (relative to `dir`).
pub(crate) fn plots(dir: &Path, table: &Table) -> Result<Vec<String>> {
    let c = table.campaign;
    let dims = varying(c);
    let mut written = Vec::new();
    let numeric: Vec<usize> = table
        .columns
        .iter()
        .enumerate()
        .filter(|(_, n)| {
            !(matches!(n.as_str(), "safety_class" | "assumption2" | "collided") || per_follower(n))
        })
        .map(|(k, _)| k)
        .collect();
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut save = |name: String, draw: &dyn Fn(&Path) -> Result<()>| -> Result<()> {
        let path = dir.join(&name);
        draw(&path).with_context(|| format!("drawing {}", path.display()))?;
        written.push(format!("plots/{name}"));
        Ok(())
    };
    if dims.len() == 2 {
        let (dx, dy) = (dims[0], dims[1]);
        for &k in &numeric {
            let name = &table.columns[k];
            let z = grid(table, dx, dy, median, k);
            save(format!("heatmap_{name}.png"), &|p| {
                heatmap(p, table, (dx, dy), name, &z)
            })?;
        }
        if let Some(k) = table.columns.iter().position(|n| n == "safety_class") {
            save("heatmap_safety_class.png".into(), &|p| {
                class_map(p, table, (dx, dy), k)
            })?;
        }
    }
    if !dims.is_empty() {
        // x: the last numeric varying dimension (else the last one); series: the others.
        let x = *dims
            .iter()
            .rev()
            .find(|&&d| dim_numbers(c, d).is_some())
            .unwrap_or(dims.last().unwrap_or(&0));
        let others: Vec<usize> = dims.iter().copied().filter(|&d| d != x).collect();
        for &k in &numeric {
            let name = table.columns[k].clone();
            save(format!("lines_{name}.png"), &|p| {
                lines(p, table, x, &others, k)
            })?;
        }
    }
    if c.samples > 1 {
        for &k in &numeric {
            let name = table.columns[k].clone();
            save(format!("ecdf_{name}.png"), &|p| ecdf(p, table, &dims, k))?;
        }
    }
    Ok(written)
}

fn median(vals: &mut [f64]) -> Option<f64> {
    if vals.is_empty() {
        return None;
    }
    vals.sort_by(f64::total_cmp);
    Some(quantile(vals, 0.5))
}

/// `z[iy][ix]`: `agg` of metric `k` over the cells at (ix, iy) (samples and other dimensions).
fn grid(
    table: &Table,
    dx: usize,
    dy: usize,
    agg: impl Fn(&mut [f64]) -> Option<f64>,
    k: usize,
) -> Vec<Vec<Option<f64>>> {
    let c = table.campaign;
    let mut vals = vec![vec![Vec::new(); c.dims[dx]]; c.dims[dy]];
    for cell in &c.cells {
        if let Some(x) = table.metric(cell.index, k).and_then(Metric::as_f64) {
            if x.is_finite() {
                vals[cell.coords[dy]][cell.coords[dx]].push(x);
            }
        }
    }
    vals.into_iter()
        .map(|row| row.into_iter().map(|mut v| agg(&mut v)).collect())
        .collect()
}

fn tick_labels(c: &Campaign, d: usize) -> Vec<String> {
    (0..c.dims[d]).map(|j| dim_label(c, d, j)).collect()
}

type GridChart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Axes with one unit cell per value of `dx` (x) and `dy` (y), labelled with the values;
/// `room` widens x (for a legend).
fn grid_axes<'a, 'b>(
    area: &'a DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>,
    caption: String,
    c: &Campaign,
    (dx, dy): (usize, usize),
    room: f64,
) -> Result<GridChart<'a, 'b>> {
    let (nx, ny) = (c.dims[dx], c.dims[dy]);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(90)
        .build_cartesian_2d(-0.5..nx as f64 * room - 0.5, -0.5..ny as f64 - 0.5)
        .map_err(err)?;
    let (xl, yl) = (tick_labels(c, dx), tick_labels(c, dy));
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(nx.min(12))
        .y_labels(ny.min(20))
        .x_label_formatter(&move |v| label_at(&xl, *v))
        .y_label_formatter(&move |v| label_at(&yl, *v))
        .x_desc(dim_name(c, dx))
        .y_desc(dim_name(c, dy))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// The unit cell of value (ix, iy).
fn unit(ix: usize, iy: usize, style: ShapeStyle) -> Rectangle<(f64, f64)> {
    let (x, y) = (ix as f64, iy as f64);
    Rectangle::new([(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)], style)
}

fn heatmap(
    path: &Path,
    table: &Table,
    (dx, dy): (usize, usize),
    metric: &str,
    z: &[Vec<Option<f64>>],
) -> Result<()> {
    ensure_font();
    let c = table.campaign;
    let finite: Vec<f64> = z.iter().flatten().flatten().copied().collect();
    let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let log = lo > 0.0 && hi / lo > 1e3;
    let scale = |v: f64| if log { v.log10() } else { v };
    let (slo, shi) = if finite.is_empty() {
        (0.0, 1.0)
    } else {
        (scale(lo), scale(hi).max(scale(lo) + 1e-12))
    };
    let root = BitMapBackend::new(path, (1100, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let (main, bar) = root.split_horizontally(960);
    let agg = if c.samples > 1 {
        " (median over samples)"
    } else {
        ""
    };
    let caption = format!("{}: {metric}{agg}", c.name);
    let mut chart = grid_axes(&main, caption, c, (dx, dy), 1.0)?;
    chart
        .draw_series(z.iter().enumerate().flat_map(|(iy, row)| {
            row.iter().enumerate().map(move |(ix, v)| {
                let color = match v {
                    Some(v) => {
                        let t = ((scale(*v) - slo) / (shi - slo)).clamp(0.0, 1.0);
                        ViridisRGB.get_color(t as f32).filled()
                    }
                    None => FAILED.filled(),
                };
                unit(ix, iy, color)
            })
        }))
        .map_err(err)?;
    // The colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(50)
        .margin_bottom(60)
        .margin_right(10)
        .y_label_area_size(95)
        .build_cartesian_2d(0.0..1.0, slo..shi)
        .map_err(err)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .y_label_formatter(&|v| {
            let v = if log { 10f64.powf(*v) } else { *v };
            format!("{v:.3}")
        })
        .y_desc(if log {
            format!("{metric} (log)")
        } else {
            metric.to_string()
        })
        .draw()
        .map_err(err)?;
    let steps = 100;
    cb.draw_series((0..steps).map(|i| {
        let a = slo + (shi - slo) * i as f64 / steps as f64;
        let b = slo + (shi - slo) * (i + 1) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            ViridisRGB.get_color(i as f32 / steps as f32).filled(),
        )
    }))
    .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// The label of the cell centred at `v` (plotters picks how many ticks fit).
fn label_at(labels: &[String], v: f64) -> String {
    let i = v.round();
    if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() {
        labels[i as usize].clone()
    } else {
        String::new()
    }
}

/// The safety class per cell as a categorical map (the worst class over samples; grey: failed).
fn class_map(path: &Path, table: &Table, (dx, dy): (usize, usize), k: usize) -> Result<()> {
    ensure_font();
    let c = table.campaign;
    let (nx, ny) = (c.dims[dx], c.dims[dy]);
    let mut worst = vec![vec![None::<usize>; nx]; ny];
    for cell in &c.cells {
        if let Some(Metric::Text(s)) = table.metric(cell.index, k) {
            let rank = CLASSES.iter().position(|(n, _)| n.name() == s);
            let w = &mut worst[cell.coords[dy]][cell.coords[dx]];
            *w = (*w).max(rank);
        }
    }
    let root = BitMapBackend::new(path, (1100, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let worst_of = if c.samples > 1 {
        " (worst over samples)"
    } else {
        ""
    };
    let caption = format!("{}: safety class{worst_of}", c.name);
    let mut chart = grid_axes(&root, caption, c, (dx, dy), 1.2)?;
    chart
        .draw_series(worst.iter().enumerate().flat_map(|(iy, row)| {
            row.iter().enumerate().map(move |(ix, r)| {
                let color = r.map_or(FAILED, |r| CLASSES[r].1);
                unit(ix, iy, color.filled())
            })
        }))
        .map_err(err)?;
    let legend = CLASSES
        .iter()
        .map(|&(class, color)| (class.name(), color))
        .chain(std::iter::once(("failed / not run", FAILED)));
    for (name, color) in legend {
        // An empty rectangle: only its legend entry shows.
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(0.0, 0.0), (0.0, 0.0)],
                color.filled(),
            )))
            .map_err(err)?
            .label(name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], color.filled()));
    }
    platoon_output::plots::legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(err)?;
    Ok(())
}

/// A series' label and its points: (x, min, median, max).
type Band = (String, Vec<(f64, f64, f64, f64)>);

/// Median line with a min-max band per x value, a series per combination of `others` (at
/// most 8; beyond that they join the band).
fn lines(path: &Path, table: &Table, x: usize, others: &[usize], k: usize) -> Result<()> {
    ensure_font();
    let c = table.campaign;
    let metric = &table.columns[k];
    let combos: usize = others.iter().map(|&d| c.dims[d]).product();
    let split = combos <= 8;
    let numbers = dim_numbers(c, x);
    let xpos = |j: usize| numbers.as_ref().map_or(j as f64, |n| n[j]);
    // series label -> x index -> values
    let mut series: BTreeMap<(Vec<usize>, String), Vec<Vec<f64>>> = BTreeMap::new();
    for cell in &c.cells {
        let Some(v) = table.metric(cell.index, k).and_then(Metric::as_f64) else {
            continue;
        };
        if !v.is_finite() {
            continue;
        }
        let (key, label) = if split {
            (
                others.iter().map(|&d| cell.coords[d]).collect::<Vec<_>>(),
                group_label(c, others, cell),
            )
        } else {
            (Vec::new(), "all".to_string())
        };
        series
            .entry((key, label))
            .or_insert_with(|| vec![Vec::new(); c.dims[x]])[cell.coords[x]]
            .push(v);
    }
    let bands: Vec<Band> = series
        .into_iter()
        .map(|((_, label), per_x)| {
            let pts = per_x
                .into_iter()
                .enumerate()
                .filter_map(|(j, mut v)| {
                    let m = median(&mut v)?;
                    Some((xpos(j), v[0], m, v[v.len() - 1]))
                })
                .collect();
            (label, pts)
        })
        .collect();
    let all: Vec<f64> = bands
        .iter()
        .flat_map(|(_, p)| p.iter().flat_map(|q| [q.1, q.3]))
        .collect();
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let log = lo > 0.0 && hi / lo > 1e3;
    let xs: Vec<f64> = (0..c.dims[x]).map(xpos).collect();
    let (x0, x1) = (
        xs.iter().copied().fold(f64::INFINITY, f64::min),
        xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    let xpad = ((x1 - x0) * 0.03).max(0.5);
    let root = BitMapBackend::new(path, (1000, 620)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let spread = if c.samples > 1 || !split {
        ": median, band min to max"
    } else {
        ""
    };
    let caption = format!("{}: {metric}{spread}", c.name);
    let labels = tick_labels(c, x);
    let categorical = numbers.is_none();
    let xfmt = move |v: &f64| {
        if categorical {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() {
                labels[i as usize].clone()
            } else {
                String::new()
            }
        } else {
            format!("{v}")
        }
    };
    let (lo, hi) = if all.is_empty() { (0.0, 1.0) } else { (lo, hi) };
    macro_rules! draw {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(dim_name(c, x))
                .y_desc(if log {
                    format!("{metric} (log)")
                } else {
                    metric.clone()
                })
                .x_label_formatter(&xfmt)
                .draw()
                .map_err(err)?;
            for (i, (label, pts)) in bands.iter().enumerate() {
                let color = Palette99::pick(i).to_rgba();
                if pts.iter().any(|p| p.1 != p.3) {
                    let mut poly: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1)).collect();
                    poly.extend(pts.iter().rev().map(|p| (p.0, p.3)));
                    chart
                        .draw_series(std::iter::once(Polygon::new(poly, color.mix(0.2).filled())))
                        .map_err(err)?;
                }
                chart
                    .draw_series(LineSeries::new(
                        pts.iter().map(|p| (p.0, p.2)),
                        color.stroke_width(2),
                    ))
                    .map_err(err)?
                    .label(label.clone())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                    });
                chart
                    .draw_series(
                        pts.iter()
                            .map(|p| Circle::new((p.0, p.2), 4, color.filled())),
                    )
                    .map_err(err)?;
            }
            platoon_output::plots::legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        }};
    }
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(caption, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(80);
    if log {
        draw!(builder
            .build_cartesian_2d(x0 - xpad..x1 + xpad, (lo * 0.8..hi * 1.25).log_scale())
            .map_err(err)?);
    } else {
        let pad = ((hi - lo) * 0.08).max(1e-9);
        draw!(builder
            .build_cartesian_2d(x0 - xpad..x1 + xpad, lo - pad..hi + pad * 3.0)
            .map_err(err)?);
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Empirical CDF of metric `k` over the samples, one curve per combination of `dims` (at most
/// 8; beyond that one curve of all cells).
fn ecdf(path: &Path, table: &Table, dims: &[usize], k: usize) -> Result<()> {
    ensure_font();
    let c = table.campaign;
    let metric = &table.columns[k];
    let combos: usize = dims.iter().map(|&d| c.dims[d]).product();
    let split = combos <= 8;
    let mut series: BTreeMap<(Vec<usize>, String), Vec<f64>> = BTreeMap::new();
    for cell in &c.cells {
        let Some(v) = table.metric(cell.index, k).and_then(Metric::as_f64) else {
            continue;
        };
        if !v.is_finite() {
            continue;
        }
        let key = if split {
            (
                dims.iter().map(|&d| cell.coords[d]).collect(),
                group_label(c, dims, cell),
            )
        } else {
            (Vec::new(), "all cells".to_string())
        };
        series.entry(key).or_default().push(v);
    }
    let all: Vec<f64> = series.values().flatten().copied().collect();
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if all.is_empty() { (0.0, 1.0) } else { (lo, hi) };
    let pad = ((hi - lo) * 0.03).max(1e-9);
    let root = BitMapBackend::new(path, (1000, 620)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "{}: {metric}, empirical CDF over {} samples",
                c.name, c.samples
            ),
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(lo - pad..hi + pad, 0.0..1.05)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(metric.as_str())
        .y_desc("fraction of samples <= x")
        .draw()
        .map_err(err)?;
    for (i, ((_, label), mut v)) in series.into_iter().enumerate() {
        v.sort_by(f64::total_cmp);
        let n = v.len() as f64;
        let mut pts = vec![(lo - pad, 0.0)];
        for (j, x) in v.iter().enumerate() {
            pts.push((*x, j as f64 / n));
            pts.push((*x, (j + 1) as f64 / n));
        }
        pts.push((hi + pad, 1.0));
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
    }
    platoon_output::plots::legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present().map_err(err)?;
    Ok(())
}
