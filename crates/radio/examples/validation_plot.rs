//! Draws the 802.11p model against the authors' published simulations: every published PDR
//! curve (`docs/img/80211p-validation.png`) and the four error types of two configurations
//! (`docs/img/80211p-errors.png`), and prints the per-curve RMS table of the docs.
//!
//! Run from the repository root: `cargo run -p platoon-radio --example validation_plot
//! [OUT_DIR]` (default `docs/img`).
use platoon_radio::Model;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

#[path = "../tests/common/mod.rs"]
mod common;

type Fallible<T> = Result<T, Box<dyn std::error::Error>>;

const OURS: RGBColor = RGBColor(31, 119, 180);
const THEIRS: RGBColor = RGBColor(214, 39, 40);
/// SEN, RXB, PRO, COL.
const KINDS: [(&str, RGBColor); 4] = [
    ("SEN", RGBColor(148, 103, 189)),
    ("RXB", RGBColor(44, 160, 44)),
    ("PRO", RGBColor(214, 39, 40)),
    ("COL", RGBColor(0, 0, 0)),
];

fn main() -> Fallible<()> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "docs/img".into()));
    std::fs::create_dir_all(&out)?;
    // The DejaVu font the crate's figures use everywhere (no system fonts needed).
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "registering the DejaVu font")?;
    let curves = common::all();
    let models: Vec<Model> = curves
        .iter()
        .map(|c| Model::new(c.params))
        .collect::<Result<_, _>>()?;
    pdr_grid(&out.join("80211p-validation.png"), &curves, &models)?;
    let pick = |label: &str| curves.iter().position(|c| c.label() == label).unwrap();
    errors(
        &out.join("80211p-errors.png"),
        &[
            pick("0.06 veh/m, 6 Mbps, 10 Hz, 23 dBm, 190 B"),
            pick("0.12 veh/m, 6 Mbps, 25 Hz, 23 dBm, 500 B"),
        ],
        &curves,
        &models,
    )?;
    println!("| configuration | CBR (ours / simulated) | PDR RMS error |");
    println!("|---|---|---|");
    for (c, m) in curves.iter().zip(&models) {
        let rms = common::rms(c.pdr.iter().map(|&(d, sim)| (m.pdr(d), sim)));
        let cbr = c.cbr.map_or("-".into(), |v| format!("{v:.3}"));
        println!("| {} | {:.3} / {cbr} | {rms:.4} |", c.label(), m.cbr());
    }
    Ok(())
}

/// Every published PDR curve in its own panel: the simulation as points, the model as a line.
fn pdr_grid(path: &Path, curves: &[common::Published], models: &[Model]) -> Fallible<()> {
    let (cols, rows) = (4, curves.len().div_ceil(4));
    let root = BitMapBackend::new(path, (1600, 300 * rows as u32 + 40)).into_drawing_area();
    root.fill(&WHITE)?;
    let (title, body) = root.split_vertically(40);
    title.draw_text(
        "802.11p PDR against distance: model (line) vs published simulations (points)",
        &("sans-serif", 22).into_font().color(&BLACK),
        (330, 10),
    )?;
    for ((panel, c), m) in body
        .split_evenly((rows, cols))
        .iter()
        .zip(curves)
        .zip(models)
    {
        let rms = common::rms(c.pdr.iter().map(|&(d, sim)| (m.pdr(d), sim)));
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{}  (RMS {rms:.3})", c.label()), ("sans-serif", 13))
            .margin(6)
            .x_label_area_size(28)
            .y_label_area_size(36)
            .build_cartesian_2d(0.0..500.0, 0.0..1.0)?;
        chart
            .configure_mesh()
            .x_labels(6)
            .y_labels(6)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .light_line_style(WHITE)
            .x_desc("distance (m)")
            .y_desc("PDR")
            .label_style(("sans-serif", 11))
            .draw()?;
        chart.draw_series(LineSeries::new(
            (0..=500).map(|d| (d as f64, m.pdr(d as f64))),
            OURS.stroke_width(2),
        ))?;
        chart.draw_series(
            c.pdr
                .iter()
                .map(|&(d, y)| Circle::new((d, y), 3, THEIRS.filled())),
        )?;
    }
    root.present()?;
    Ok(())
}

/// The four error types of the chosen configurations: published (points) and ours (lines).
fn errors(
    path: &Path,
    picks: &[usize],
    curves: &[common::Published],
    models: &[Model],
) -> Fallible<()> {
    let root = BitMapBackend::new(path, (1400, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    for (panel, &i) in root.split_evenly((1, picks.len())).iter().zip(picks) {
        let (c, m) = (&curves[i], &models[i]);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{} (CBR {:.2})", c.label(), m.cbr()),
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(48)
            .build_cartesian_2d(0.0..500.0, 0.0..1.0)?;
        chart
            .configure_mesh()
            .x_desc("distance (m)")
            .y_desc("probability of loss")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .light_line_style(WHITE)
            .label_style(("sans-serif", 13))
            .draw()?;
        for (k, (name, color)) in KINDS.iter().enumerate() {
            let value = |d: f64| {
                let l = m.losses(d);
                [l.below_sensing, l.receiver_busy, l.propagation, l.collision][k]
            };
            chart
                .draw_series(LineSeries::new(
                    (0..=500).map(|d| (d as f64, value(d as f64))),
                    color.stroke_width(2),
                ))?
                .label(format!("{name} model"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
            chart
                .draw_series(
                    c.losses
                        .iter()
                        .map(|(d, v)| Circle::new((*d, v[k]), 3, color.filled())),
                )?
                .label(format!("{name} simulated"))
                .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(("sans-serif", 12))
            .draw()?;
    }
    root.present()?;
    Ok(())
}
