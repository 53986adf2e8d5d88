//! The authors' published simulation results (`data/published/`, see its README): one curve per
//! configuration, read for the validation test and the validation figure.
#![allow(dead_code)]

use platoon_radio::Params80211p;

/// One published configuration with its simulated curves.
pub struct Published {
    /// The configuration, on the model's defaults for everything the files do not name.
    pub params: Params80211p,
    /// `(distance_m, pdr)` from `PDR_*.fig`.
    pub pdr: Vec<(f64, f64)>,
    /// `(distance_m, [sen, rxb, pro, col])` from `ERRORS_*.fig`, where published.
    pub losses: Vec<(f64, [f64; 4])>,
    /// Mean of the simulated CBR distribution from `CBR_*.fig`, where published.
    pub cbr: Option<f64>,
    /// The authors' MATLAB model (`data/authors-matlab/model.csv`) at the same distances.
    pub authors: Authors,
}

/// What the authors' own MATLAB model (`model80211p.m`, run in GNU Octave) computes for one
/// configuration.
#[derive(Default)]
pub struct Authors {
    /// `(distance_m, [pdr, sen, rxb, pro, col])`.
    pub points: Vec<(f64, [f64; 5])>,
    /// Its channel busy ratio.
    pub cbr: f64,
    /// `(distance_m, [pdr, sen, rxb, pro, col])` with its probability densities on a grid of
    /// 0.05 dB instead of 0.1 (`data/authors-matlab/model-0.05dB.csv`).
    pub fine: Vec<(f64, [f64; 5])>,
}

impl Published {
    /// "0.12 veh/m, 6 Mbps, 25 Hz, 23 dBm, 500 B", the authors' figure titles.
    pub fn label(&self) -> String {
        let p = &self.params;
        format!(
            "{} veh/m, {} Mbps, {} Hz, {} dBm, {} B",
            p.density_veh_per_m, p.data_rate_mbps, p.beacon_hz, p.tx_power_dbm, p.packet_bytes
        )
    }
}

const PDR: &str = include_str!("../../data/published/pdr.csv");
const ERRORS: &str = include_str!("../../data/published/errors.csv");
const CBR: &str = include_str!("../../data/published/cbr.csv");
const AUTHORS: &str = include_str!("../../data/authors-matlab/model.csv");
const AUTHORS_FINE: &str = include_str!("../../data/authors-matlab/model-0.05dB.csv");

/// The leading five columns of every file: density, rate, beacon, power, bytes.
fn key(fields: &[&str]) -> Params80211p {
    let num = |i: usize| -> f64 { fields[i].parse().expect("published CSV: a number") };
    Params80211p {
        density_veh_per_m: num(0),
        data_rate_mbps: num(1),
        beacon_hz: num(2),
        tx_power_dbm: num(3),
        packet_bytes: fields[4].parse().expect("published CSV: packet bytes"),
        ..Params80211p::default()
    }
}

fn rows(text: &str) -> impl Iterator<Item = Vec<&str>> {
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').collect())
}

/// Every published configuration, in the order of `pdr.csv`.
pub fn all() -> Vec<Published> {
    let mut out: Vec<Published> = Vec::new();
    for f in rows(PDR) {
        let params = key(&f);
        let point = (f[5].parse().unwrap(), f[6].parse().unwrap());
        match out.iter_mut().find(|c| c.params == params) {
            Some(c) => c.pdr.push(point),
            None => out.push(Published {
                params,
                pdr: vec![point],
                losses: Vec::new(),
                cbr: None,
                authors: Authors::default(),
            }),
        }
    }
    for f in rows(ERRORS) {
        let params = key(&f);
        let v = |i: usize| -> f64 { f[i].parse().unwrap() };
        let c = out
            .iter_mut()
            .find(|c| c.params == params)
            .expect("errors.csv: a configuration without a PDR curve");
        c.losses.push((v(5), [v(6), v(7), v(8), v(9)]));
    }
    for f in rows(CBR) {
        let params = key(&f);
        if let Some(c) = out.iter_mut().find(|c| c.params == params) {
            c.cbr = Some(f[5].parse().unwrap());
        }
    }
    for f in rows(AUTHORS) {
        let params = key(&f);
        let v = |i: usize| -> f64 { f[i].parse().unwrap() };
        let c = out
            .iter_mut()
            .find(|c| c.params == params)
            .expect("authors-matlab/model.csv: a configuration that is not published");
        c.authors
            .points
            .push((v(5), [v(6), v(7), v(8), v(9), v(10)]));
        c.authors.cbr = v(11);
    }
    for f in rows(AUTHORS_FINE) {
        let params = key(&f);
        let v = |i: usize| -> f64 { f[i].parse().unwrap() };
        let c = out
            .iter_mut()
            .find(|c| c.params == params)
            .expect("authors-matlab/model-0.05dB.csv: a configuration that is not published");
        c.authors.fine.push((v(5), [v(6), v(7), v(8), v(9), v(10)]));
    }
    out
}

/// Root mean square of `ours - published` over a curve.
pub fn rms(points: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (ours, theirs) in points {
        sum += (ours - theirs).powi(2);
        n += 1;
    }
    (sum / n as f64).sqrt()
}

/// The text of `docs/channel-80211p.md`, or another file from the repository root.
pub fn repo_file(path: &str) -> String {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    std::fs::read_to_string(root.join(path)).unwrap_or_else(|e| panic!("cannot read {path}: {e}"))
}

/// Runs of whitespace as one space: a Markdown paragraph may wrap anywhere.
pub fn squash(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The statements of `doc` (a path from the repository root) that the text does not hold, with
/// runs of whitespace compared as one space: each is a figure computed by the test and
/// formatted to the digits the doc prints.
pub fn unpublished(doc: &str, statements: &[String]) -> Vec<String> {
    let text = squash(&repo_file(doc));
    statements
        .iter()
        .filter(|s| !text.contains(&squash(s)))
        .map(|s| format!("{doc} does not say: {s}"))
        .collect()
}
