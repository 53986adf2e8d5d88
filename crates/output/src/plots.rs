//! PNG figures in the manner of the paper's Fig. 6, 7 and 8 (plotters, bitmap backend, an
//! embedded DejaVu font so no system fonts are needed).
use crate::error::{OutputError, Result};
use platoon_attacks::Interval;
use platoon_sim::{Scenario, StepRow};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters_backend::DrawingErrorKind;
use std::path::Path;
use std::sync::Once;

const ATTACK_SHADE: RGBColor = RGBColor(250, 210, 210);

pub fn ensure_font() {
    static FONT: Once = Once::new();
    FONT.call_once(|| {
        // The bytes are a valid TTF shipped by the dejavu crate; failure would be a build defect.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// The error type of the bitmap backend every figure is drawn with.
type BitmapError = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

/// A drawing error in words (a full disk reads "No space left on device", not the backend's
/// nested debug form); the caller's context names the file.
pub fn err(e: DrawingAreaErrorKind<BitmapError>) -> OutputError {
    OutputError::Plot(match e {
        DrawingAreaErrorKind::BackendError(DrawingErrorKind::DrawingError(b)) => match b {
            BitmapError::IOError(io) => io.to_string(),
            BitmapError::ImageError(image) => image.to_string(),
            other => other.to_string(),
        },
        DrawingAreaErrorKind::BackendError(DrawingErrorKind::FontError(f)) => format!("font: {f}"),
        other => other.to_string(),
    })
}

/// The series' legend, boxed, at `position`: every figure's legend looks the same.
pub fn legend<'a, 'b: 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, BitMapBackend<'b>, CT>,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()
        .map_err(err)
}

/// One named series of `(x, y)` points.
pub struct Series {
    pub label: String,
    /// Palette index, so a vehicle keeps its colour across panels.
    pub color: usize,
    pub points: Vec<(f64, f64)>,
}

fn bounds(series: &[Series]) -> (f64, f64, f64, f64) {
    let mut b = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in series {
        for &(x, y) in &s.points {
            if x.is_finite() && y.is_finite() {
                b = (b.0.min(x), b.1.max(x), b.2.min(y), b.3.max(y));
            }
        }
    }
    if !b.0.is_finite() {
        return (0.0, 1.0, 0.0, 1.0);
    }
    let pad = ((b.3 - b.2) * 0.05).max(1e-6);
    (b.0, b.1.max(b.0 + 1e-9), b.2 - pad, b.3 + pad)
}

type TimeChart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Axes over time with a caption, a mesh and the attack intervals shaded.
fn time_axes<'a, 'b>(
    area: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    caption: &str,
    y_label: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    attacks: &[Interval],
) -> Result<TimeChart<'a, 'b>> {
    ensure_font();
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc(y_label)
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    chart
        .draw_series(attacks.iter().map(|iv| {
            Rectangle::new(
                [(iv.start.max(x0), y0), (iv.end.min(x1), y1)],
                ATTACK_SHADE.filled(),
            )
        }))
        .map_err(err)?;
    Ok(chart)
}

/// A line chart in `area`, with shaded attack intervals.
pub fn line_panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    title: &str,
    y_label: &str,
    series: &[Series],
    attacks: &[Interval],
) -> Result<()> {
    let (x0, x1, y0, y1) = bounds(series);
    let mut chart = time_axes(area, title, y_label, (x0, x1), (y0, y1), attacks)?;
    for s in series {
        let color = Palette99::pick(s.color).to_rgba();
        chart
            .draw_series(LineSeries::new(
                s.points.iter().copied(),
                color.stroke_width(2),
            ))
            .map_err(err)?
            .label(s.label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    Ok(())
}

/// One line chart of its own, 1200 x 600 (Fig. 8 and 9: the average tracking error over time).
pub fn lines(path: &Path, title: &str, y_label: &str, series: &[Series]) -> Result<()> {
    let root = BitMapBackend::new(path, (1200, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    line_panel(&root, title, y_label, series, &[])?;
    root.present().map_err(err)?;
    Ok(())
}

fn per_vehicle(
    rows: &[StepRow],
    n: usize,
    followers_only: bool,
    f: impl Fn(&StepRow) -> f64,
) -> Vec<Series> {
    let first = usize::from(followers_only);
    (first..=n)
        .map(|v| Series {
            label: if v == 0 {
                "leader".into()
            } else {
                format!("follower {v}")
            },
            color: v,
            points: rows
                .iter()
                .filter(|r| r.vehicle as usize == v)
                .map(|r| (r.t, f(r)))
                .collect(),
        })
        .collect()
}

/// Fig. 6: positions, positions relative to the leader, velocities, internal variables.
/// The intervals in which some vehicle was told its channel was jammed, from the rows: what
/// happened on the wire, whatever injector ran (for the built-in channel, the DoS schedule on
/// the step grid).
pub fn observed_attacks(rows: &[StepRow], dt: f64) -> Vec<Interval> {
    let mut out: Vec<Interval> = Vec::new();
    let mut open: Option<u64> = None;
    let mut last = 0;
    let mut i = 0;
    while i < rows.len() {
        let k = rows[i].step;
        let mut jammed = false;
        while i < rows.len() && rows[i].step == k {
            jammed |= rows[i].under_attack;
            i += 1;
        }
        match (jammed, open) {
            (true, None) => open = Some(k),
            (false, Some(a)) => {
                out.push(Interval {
                    start: a as f64 * dt,
                    end: k as f64 * dt,
                });
                open = None;
            }
            _ => {}
        }
        last = k;
    }
    if let Some(a) = open {
        out.push(Interval {
            start: a as f64 * dt,
            end: (last + 1) as f64 * dt,
        });
    }
    out
}

pub fn fig6(path: &Path, scenario: &Scenario, rows: &[StepRow]) -> Result<()> {
    let n = scenario.topology.followers();
    let attacks = observed_attacks(rows, scenario.dt());
    let root = BitMapBackend::new(path, (1400, 1000)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let panels = root.split_evenly((2, 2));
    let leader_p: Vec<f64> = rows
        .iter()
        .filter(|r| r.vehicle == 0)
        .map(|r| r.p)
        .collect();
    line_panel(
        &panels[0],
        "(a) Positions",
        "p (m)",
        &per_vehicle(rows, n, false, |r| r.p),
        &attacks,
    )?;
    line_panel(
        &panels[1],
        "(b) Positions relative to the leader",
        "p_i - p_0 (m)",
        &per_vehicle(rows, n, true, |r| r.p - leader_p[r.step as usize]),
        &attacks,
    )?;
    line_panel(
        &panels[2],
        "(c) Velocities",
        "v (m/s)",
        &per_vehicle(rows, n, false, |r| r.v),
        &attacks,
    )?;
    line_panel(
        &panels[3],
        "(d) Internal dynamic variables",
        "theta",
        &per_vehicle(rows, n, true, |r| r.theta),
        &attacks,
    )?;
    root.present().map_err(err)?;
    Ok(())
}

/// Colour of a status in `modes.png` (`coop` is left white).
fn mode_color(m: platoon_control::Status) -> RGBColor {
    use platoon_control::{Mode, Role};
    match (m.role(), m.mode()) {
        (_, Some(Mode::Coop)) => WHITE,
        (_, Some(Mode::Zero)) => RGBColor(120, 120, 120),
        (_, Some(Mode::Hold)) => RGBColor(230, 159, 0),
        (_, Some(Mode::Predict)) => RGBColor(86, 180, 233),
        (_, Some(Mode::Acc)) => RGBColor(0, 158, 115),
        (_, Some(Mode::Blend)) => RGBColor(204, 121, 167),
        (_, Some(Mode::CutIn)) => RGBColor(213, 94, 0),
        (Role::Left, None) => RGBColor(0, 114, 178),
        (Role::Beside, None) => RGBColor(170, 170, 40),
        (_, None) => RGBColor(240, 228, 66),
    }
}

/// The band of a follower led by a member ahead heading a split platoon.
const SPLIT: RGBColor = RGBColor(90, 40, 140);

/// The mode of every follower over time, one band each (white: cooperative; a colour per
/// fallback and for the blend back), the guard's braking as red ticks above the band, the
/// packets its misbehaviour detectors flagged (`flags`: follower, t) as black ticks below it,
/// and the observed jams shaded: drawn when some follower left the cooperative law or a
/// detector flagged something; in runs that split behind a cut-in, a thin band along the row
/// while a member ahead heading the split leads the follower.
pub fn modes(
    path: &Path,
    scenario: &Scenario,
    rows: &[StepRow],
    flags: &[(u16, f64)],
) -> Result<()> {
    use platoon_control::{Mode, Role, Status};
    ensure_font();
    let n = scenario.topology.followers();
    let attacks = observed_attacks(rows, scenario.dt());
    let dt = scenario.dt();
    let root = BitMapBackend::new(path, (1400, 120 + 60 * n.max(1) as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let mut chart = time_axes(
        &root,
        "Mode of each follower (white: cooperative)",
        "follower",
        (0.0, scenario.duration()),
        (0.5, n as f64 + 0.5),
        &attacks,
    )?;
    for v in 1..=n {
        let y = v as f64;
        // Runs of one mode, and of the guard braking.
        let mine: Vec<&StepRow> = rows.iter().filter(|r| r.vehicle as usize == v).collect();
        let mut start = 0;
        for i in 1..=mine.len() {
            if i == mine.len() || mine[i].mode != mine[start].mode {
                let m = mine[start].mode;
                if m != Mode::Coop {
                    let (t0, t1) = (mine[start].t, mine[i - 1].t + dt);
                    chart
                        .draw_series(std::iter::once(Rectangle::new(
                            [(t0, y - 0.3), (t1, y + 0.3)],
                            mode_color(m).filled(),
                        )))
                        .map_err(err)?;
                }
                start = i;
            }
        }
        chart
            .draw_series(
                mine.iter()
                    .filter(|r| r.guard)
                    .map(|r| Rectangle::new([(r.t, y + 0.32), (r.t + dt, y + 0.45)], RED.filled())),
            )
            .map_err(err)?;
        // Led by a member ahead heading a split platoon: a thin band along the row.
        chart
            .draw_series(
                mine.iter()
                    .filter(|r| r.head.is_some_and(|h| h != 0))
                    .map(|r| {
                        Rectangle::new([(r.t, y - 0.05), (r.t + dt, y + 0.05)], SPLIT.filled())
                    }),
            )
            .map_err(err)?;
        chart
            .draw_series(
                flags
                    .iter()
                    .filter(|(f, _)| usize::from(*f) == v)
                    .map(|&(_, t)| {
                        Rectangle::new([(t, y - 0.45), (t + dt, y - 0.32)], BLACK.filled())
                    }),
            )
            .map_err(err)?;
    }
    // `outside`, `left` and `beside` only with maneuvers: other runs keep their figure.
    let maneuvers = scenario.control.maneuvers.is_some();
    for m in Status::ALL
        .into_iter()
        .filter(|m| *m != Mode::Coop && (maneuvers || *m == Role::Member))
    {
        let c = mode_color(m);
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(err)?
            .label(m.name())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], c.filled()));
    }
    chart
        .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
        .map_err(err)?
        .label("guard braking")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], RED.filled()));
    if scenario.splits() {
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(err)?
            .label("led by a split's head")
            .legend(|(x, y)| Rectangle::new([(x, y - 2), (x + 12, y + 2)], SPLIT.filled()));
    }
    if !flags.is_empty() {
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(err)?
            .label("detector flag")
            .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], BLACK.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Fig. 7: each follower's release instants (stems) with the time since its previous release.
pub fn fig7(path: &Path, scenario: &Scenario, rows: &[StepRow]) -> Result<()> {
    ensure_font();
    let n = scenario.topology.followers();
    let attacks = observed_attacks(rows, scenario.dt());
    let t_end = scenario.duration();
    let height = 250 * n.max(1) as u32;
    let root = BitMapBackend::new(path, (1400, height)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    for (v, area) in (1..=n).zip(root.split_evenly((n, 1))) {
        let mut last = None;
        let mut stems = Vec::new();
        for r in rows
            .iter()
            .filter(|r| r.vehicle as usize == v && r.triggered)
        {
            if let Some(p) = last {
                stems.push((r.t, r.t - p));
            }
            last = Some(r.t);
        }
        let y1 = stems.iter().map(|s| s.1).fold(0.0, f64::max).max(1e-3) * 1.1;
        let caption = format!(
            "Follower {v}: release instants ({} broadcasts)",
            stems.len() + usize::from(last.is_some())
        );
        let mut chart = time_axes(
            &area,
            &caption,
            "interval (s)",
            (0.0, t_end),
            (0.0, y1),
            &attacks,
        )?;
        let color = Palette99::pick(v).to_rgba();
        chart
            .draw_series(
                stems
                    .iter()
                    .map(|&(t, d)| PathElement::new(vec![(t, 0.0), (t, d)], color)),
            )
            .map_err(err)?;
        chart
            .draw_series(
                stems
                    .iter()
                    .map(|&(t, d)| Circle::new((t, d), 2, color.filled())),
            )
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// A grouped bar chart: `groups` (e.g. rules) of `values` per category (e.g. vehicles).
pub fn grouped_bars(
    path: &Path,
    title: &str,
    y_label: &str,
    categories: &[String],
    groups: &[(String, Vec<f64>)],
) -> Result<()> {
    ensure_font();
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let ymax = groups
        .iter()
        .flat_map(|g| g.1.iter().copied())
        .fold(0.0, f64::max);
    let ymax = if ymax > 0.0 { ymax * 1.5 } else { 1.0 }; // room for the legend
    let nc = categories.len() as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..nc, 0.0..ymax)
        .map_err(err)?;
    let cats = categories.to_vec();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(categories.len() * 2 + 1)
        .x_label_formatter(&move |x| {
            let i = x.floor() as usize;
            if (x - x.floor() - 0.5).abs() < 1e-6 && i < cats.len() {
                cats[i].clone()
            } else {
                String::new()
            }
        })
        .y_desc(y_label)
        .draw()
        .map_err(err)?;
    let width = 0.8 / groups.len().max(1) as f64;
    for (g, (label, values)) in groups.iter().enumerate() {
        let color = Palette99::pick(g).to_rgba();
        chart
            .draw_series(values.iter().enumerate().map(|(c, &v)| {
                let x0 = c as f64 + 0.1 + g as f64 * width;
                Rectangle::new([(x0, 0.0), (x0 + width * 0.95, v)], color.filled())
            }))
            .map_err(err)?
            .label(label.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Measured points of each series with straight lines through them (x and y linear).
pub fn scatter_with_lines(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<()> {
    ensure_font();
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let pts = series.iter().flat_map(|s| s.points.iter().copied());
    let (x1, y1) = pts.fold((1.0f64, 1.0f64), |(a, b), (x, y)| {
        (a.max(x), if y.is_finite() { b.max(y) } else { b })
    });
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..x1 * 1.05, 0.0..y1 * 1.1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .draw()
        .map_err(err)?;
    points_and_lines(&mut chart, series, |p| p.1.is_finite(), 5)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Each series' points (those `keep` keeps) joined by lines, with its legend entry; then the
/// legend, upper left.
fn points_and_lines<'a, 'b: 'a, CT>(
    chart: &mut ChartContext<'a, BitMapBackend<'b>, CT>,
    series: &[Series],
    keep: impl Fn(&(f64, f64)) -> bool,
    radius: i32,
) -> Result<()>
where
    CT: plotters::coord::CoordTranslate<From = (f64, f64)>,
{
    for s in series {
        let color = Palette99::pick(s.color).to_rgba();
        let kept: Vec<(f64, f64)> = s.points.iter().copied().filter(|p| keep(p)).collect();
        chart
            .draw_series(LineSeries::new(kept.clone(), color.stroke_width(2)))
            .map_err(err)?
            .label(s.label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
        chart
            .draw_series(kept.iter().map(|&p| Circle::new(p, radius, color.filled())))
            .map_err(err)?;
    }
    legend(chart, SeriesLabelPosition::UpperLeft)
}

/// One log-log panel per entry, side by side in a grid (two columns): measured points of each
/// series joined by lines. Non-finite and non-positive values are left out (a log axis has no
/// place for them).
pub fn log_log_panels(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    panels: &[(String, Vec<Series>)],
) -> Result<()> {
    ensure_font();
    let rows = panels.len().div_ceil(2).max(1);
    let root = BitMapBackend::new(path, (1400, 450 * rows as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 24)).map_err(err)?;
    let areas = root.split_evenly((rows, if panels.len() > 1 { 2 } else { 1 }));
    let usable = |p: &(f64, f64)| p.0 > 0.0 && p.1 > 0.0 && p.1.is_finite();
    for ((name, series), area) in panels.iter().zip(&areas) {
        let pts: Vec<(f64, f64)> = series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(usable)
            .collect();
        let (x0, x1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
        let (y0, y1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
        let (x0, x1, y0, y1) = if pts.is_empty() {
            (1.0, 10.0, 0.1, 10.0)
        } else {
            (x0 * 0.8, x1 * 1.25, y0 * 0.5, y1 * 2.0)
        };
        let mut chart = ChartBuilder::on(area)
            .caption(name, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .max_light_lines(0)
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| {
                let s = format!("{y:.3}");
                s.trim_end_matches('0').trim_end_matches('.').to_string()
            })
            .x_desc(x_label)
            .y_desc(y_label)
            .draw()
            .map_err(err)?;
        points_and_lines(&mut chart, series, usable, 4)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// One histogram per method (µs, up to each method's p99.9).
pub fn histograms(path: &Path, samples: &[(&str, Vec<u64>)]) -> Result<()> {
    ensure_font();
    let root =
        BitMapBackend::new(path, (1000, 250 * samples.len().max(1) as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let areas = root.split_evenly((samples.len().max(1), 1));
    for ((name, v), area) in samples.iter().zip(areas) {
        let mut us: Vec<f64> = v.iter().map(|&x| x as f64 / 1e3).collect();
        us.sort_by(f64::total_cmp);
        if us.is_empty() {
            continue;
        }
        let hi = us[((us.len() as f64 * 0.999) as usize).min(us.len() - 1)].max(1.0);
        let bins = 60;
        let width = hi / bins as f64;
        let mut counts = vec![0u32; bins];
        for x in &us {
            let b = ((x / width) as usize).min(bins - 1);
            counts[b] += 1;
        }
        let top = f64::from(*counts.iter().max().unwrap_or(&1));
        let mut chart = ChartBuilder::on(&area)
            .caption(format!("{name} (µs, n = {})", us.len()), ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..hi, 0.0..top * 1.1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .draw()
            .map_err(err)?;
        chart
            .draw_series(counts.iter().enumerate().map(|(i, &c)| {
                let x0 = i as f64 * width;
                Rectangle::new(
                    [(x0, 0.0), (x0 + width, f64::from(c))],
                    BLUE.mix(0.6).filled(),
                )
            }))
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context as _;

    /// A full disk while drawing is one line of error with the file and the reason (not the
    /// plot backend's `BackendError(IOError(Os { .. }))` dump).
    #[test]
    fn a_full_disk_is_reported_in_words_with_the_file() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("fig6.png");
        std::os::unix::fs::symlink("/dev/full", &path).unwrap();
        let (_, scenario) = platoon_config::parse(
            &platoon_config::PAPER_TOML.replace("duration_s = 55.0", "duration_s = 1.0"),
            Path::new("paper.toml"),
        )
        .unwrap();
        let mut rows = Vec::new();
        platoon_sim::run(scenario.clone(), |r| rows.extend_from_slice(r)).unwrap();
        let e = fig6(&path, &scenario, &rows)
            .with_context(|| format!("drawing {}", path.display()))
            .unwrap_err();
        let line = format!("{e:#}");
        assert!(!line.contains('\n'), "{line}");
        assert!(line.contains("fig6.png"), "{line}");
        assert!(line.contains("No space left on device"), "{line}");
        assert!(!line.contains("BackendError"), "{line}");
    }
}
