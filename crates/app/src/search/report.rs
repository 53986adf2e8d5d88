//! The search's outputs: each problem's CSV, convergence figure and worst config, and the
//! study's tables.
use super::SearchError;
use super::{MethodOutcome, Problem, ProblemOutcome, Search, SearchOptions};

type Result<T, E = SearchError> = std::result::Result<T, E>;
use platoon_output::rundir::RunDir;
use platoon_output::{markdown, plots};
use std::fmt::Write as _;
use std::path::Path;

pub(super) fn fmt_harm(h: Option<f64>) -> String {
    h.map_or("-".into(), |h| format!("{h:.2}"))
}

/// evaluations.csv, convergence.csv, convergence.png, worst.toml and the reference.
pub(super) fn write_problem(
    search: &Search,
    problem: &Problem,
    dir: &RunDir,
    sub: &Path,
    outcome: &ProblemOutcome,
    opts: &SearchOptions,
) -> Result<()> {
    let path = |name: &str| sub.join(name).to_string_lossy().into_owned();
    let mut w = csv::Writer::from_writer(dir.writer(&path("evaluations.csv"))?);
    w.write_record([
        "method",
        "evaluation",
        "schedule",
        "jams",
        "jammed_s",
        "harm",
        "class",
        "error",
    ])?;
    for m in &outcome.methods {
        for e in &m.history {
            let jammed = e
                .schedule
                .activity()
                .map(|a| a.active_time(0.0, problem.grid.horizon()))
                .unwrap_or(f64::NAN);
            w.write_record([
                m.method.to_string(),
                e.evaluation.to_string(),
                e.schedule.to_string(),
                e.schedule.jams.len().to_string(),
                format!("{jammed}"),
                e.harm.map_or(String::new(), |h| h.to_string()),
                e.class.map_or(String::new(), |c| c.name().to_string()),
                e.error.clone().unwrap_or_default(),
            ])?;
        }
    }
    w.flush()?;
    let mut w = csv::Writer::from_writer(dir.writer(&path("convergence.csv"))?);
    w.write_record(["method", "evaluation", "best_harm"])?;
    for m in &outcome.methods {
        for (i, b) in m.convergence().iter().enumerate() {
            w.write_record([
                m.method.to_string(),
                (i + 1).to_string(),
                b.map_or(String::new(), |h| h.to_string()),
            ])?;
        }
    }
    w.flush()?;
    if let Some((_, worst)) = outcome.worst() {
        let config = problem.config_of(&worst.schedule);
        let mut text = format!(
            "# The most harmful schedule `platoon search` found for {} ({} = {}): re-run it with\n\
             #   platoon run worst.toml --transport {}\n",
            problem.label,
            search.harm.name(),
            fmt_harm(worst.harm),
            search.spec.transport.name()
        );
        text.push_str(&platoon_config::to_toml(&config));
        dir.write(&path("worst.toml"), text.as_bytes())?;
    }
    if opts.plots {
        convergence_plot(
            &dir.path(&path("convergence.png")),
            &format!(
                "{}: most harmful {} found against runs",
                problem.label,
                search.harm.name()
            ),
            search.harm.name(),
            &outcome.methods,
            outcome.reference.as_ref().and_then(|r| r.harm),
        )?;
    }
    Ok(())
}

/// The best harm against runs, one step line per strategy, the reference dashed.
pub(super) fn convergence_plot(
    path: &Path,
    title: &str,
    harm: &str,
    methods: &[MethodOutcome],
    reference: Option<f64>,
) -> Result<()> {
    use plotters::prelude::*;
    let lines: Vec<(&str, Vec<(f64, f64)>)> = methods
        .iter()
        .map(|m| {
            let mut pts: Vec<(f64, f64)> = Vec::new();
            for (k, b) in m.convergence().iter().enumerate() {
                let Some(b) = *b else { continue };
                let x = (k + 1) as f64;
                if let Some(&(_, last)) = pts.last() {
                    if last != b {
                        pts.push((x, last));
                    }
                }
                pts.push((x, b));
            }
            (m.method, pts)
        })
        .filter(|(_, p)| !p.is_empty())
        .collect();
    let ys = lines
        .iter()
        .flat_map(|(_, p)| p.iter().map(|q| q.1))
        .chain(reference)
        .filter(|y| y.is_finite());
    let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    if !lo.is_finite() {
        return Ok(());
    }
    let pad = ((hi - lo) * 0.08).max(0.5);
    let (y0, y1) = (if lo >= 0.0 { 0.0 } else { lo - pad }, hi + pad);
    let x1 = lines
        .iter()
        .flat_map(|(_, p)| p.iter().map(|q| q.0))
        .fold(1.0, f64::max);
    plots::ensure_font();
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(plots::err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..x1 * 1.02, y0..y1)
        .map_err(plots::err)?;
    chart
        .configure_mesh()
        .x_desc("runs")
        .y_desc(harm)
        .draw()
        .map_err(plots::err)?;
    for (i, (name, pts)) in lines.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(3)))
            .map_err(plots::err)?
            .label(name.to_string())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3))
            });
    }
    if let Some(r) = reference {
        let black = BLACK.stroke_width(1);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(0.0, r), (x1 * 1.02, r)],
                6,
                4,
                black,
            ))
            .map_err(plots::err)?
            .label("reference")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], black));
    }
    plots::legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present().map_err(plots::err)?;
    Ok(())
}

/// study.csv and study.md: per law and topology, what each strategy found.
pub(super) fn study_tables(search: &Search, outcomes: &[ProblemOutcome]) -> (String, String) {
    let harm = search.harm.name();
    let mut csv = format!(
        "problem,{harm}_search,{harm}_random,{harm}_grid,{harm}_reference,class_search,worst_schedule,worst_by,duration_margin_s,frequency_margin,reproduced,not_run\n"
    );
    let mut md = format!(
        "Harm: `{harm}`{} per strategy; duration margin: the Assumption-2 duration bound's margin on the worst schedule's tightest window.\n\n\
         {}",
        if search.harm.minimised() { " (smallest found: most harmful)" } else { " (largest found: most harmful)" },
        markdown::header(&[
            "law-topology",
            "search",
            "random",
            "grid",
            "reference",
            "class",
            "worst schedule",
            "duration margin (s)",
        ])
    );
    for o in outcomes {
        let best = |m: &str| {
            o.method(m)
                .and_then(|m| m.best.as_ref())
                .and_then(|b| b.harm)
        };
        let s = o.method("search").and_then(|m| m.best.as_ref());
        let worst = o.worst();
        let margins = worst
            .and_then(|(_, w)| w.certificate.assumption2.as_ref())
            .map(|r| {
                (
                    r.worst_duration.map(|w| w.margin()),
                    r.worst_frequency.map(|w| w.margin()),
                )
            });
        let opt = |x: Option<f64>| x.map_or(String::new(), |x| x.to_string());
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},\"{}\",{},{},{},{},\"{}\"",
            o.label,
            opt(best("search")),
            opt(best("random")),
            opt(best("grid")),
            opt(o.reference.as_ref().and_then(|r| r.harm)),
            s.and_then(|s| s.class)
                .map_or(String::new(), |c| c.name().into()),
            worst.map_or(String::new(), |(_, w)| w.text.clone()),
            worst.map_or("", |(m, _)| m),
            opt(margins.and_then(|m| m.0)),
            opt(margins.and_then(|m| m.1)),
            o.reproduced.map_or(String::new(), |r| r.to_string()),
            o.not_run.clone().unwrap_or_default(),
        );
        if o.not_run.is_some() {
            let _ = writeln!(
                md,
                "| {} | not run: the topology lacks a neighbour the law reads | | | | | | |",
                o.label
            );
            continue;
        }
        markdown::row(
            &mut md,
            &[
                &o.label,
                &fmt_harm(best("search")),
                &fmt_harm(best("random")),
                &fmt_harm(best("grid")),
                &fmt_harm(o.reference.as_ref().and_then(|r| r.harm)),
                &s.and_then(|s| s.class)
                    .map_or("-".into(), |c| c.to_string()),
                &worst.map_or("-".into(), |(_, w)| w.text.clone()),
                &margins
                    .and_then(|m| m.0)
                    .map_or("-".into(), |m| format!("{m:.3}")),
            ],
        );
    }
    (csv, md)
}
