//! The studies' figures: `platoon experiment controllers` (docs/controllers.md, README), the
//! density and jammer campaigns on the 802.11p channel (README, docs/channel-80211p.md), the
//! Monte Carlo campaign (docs/campaigns.md), each computed in process by the same library calls
//! the commands make and compared with the text at the digits it prints.
use crate::common::{published, published_close};
use platoon_app::campaign::{self, Campaign, CellResult, CellStatus};
use platoon_app::experiment::{self, Base, ControllersOptions, ControllersRow};
use platoon_app::Stop;
use platoon_config::Embedded;
use platoon_topology::Preset;

const CONTROLLERS_DOC: &str = "docs/controllers.md";
const README: &str = "README.md";
const CHANNEL_DOC: &str = "docs/channel-80211p.md";

/// `platoon experiment controllers` on `plf`, the topology its table shows (on `pf` the laws
/// that read the leader do not run: tested in crates/app/tests/experiment.rs).
fn controllers_on_plf() -> (Base, Vec<ControllersRow>) {
    let base = Base::load(None, Embedded::Paper).unwrap();
    let opts = ControllersOptions {
        topologies: vec![Preset::Plf],
        ..ControllersOptions::default()
    };
    let c = experiment::controllers(&base, &opts, None, &()).unwrap();
    (base, c.rows)
}

/// The whole table of docs/controllers.md, row by row, and the figures its prose and the
/// README quote from it.
#[test]
fn controllers_table_and_findings() {
    let (base, rows) = controllers_on_plf();
    let cell = |law: &str, attack: &str| -> &ControllersRow {
        rows.iter()
            .find(|r| r.law == law && r.attack == attack)
            .unwrap_or_else(|| panic!("no row for {law} under {attack}"))
    };
    let gap = |law: &str, attack: &str| cell(law, attack).min_gap_m.unwrap();
    let error = |law: &str, attack: &str| cell(law, attack).max_gap_error_m.unwrap();
    let two = |x: f64| format!("{x:.2}");
    let one = |x: f64| format!("{x:.1}");

    // The table: largest gap error to the predecessor / smallest gap, a collision in bold.
    for law in ["paper", "acc", "path_cacc", "ploeg", "consensus", "flatbed"] {
        let text = |attack: &str| {
            let (e, g) = (error(law, attack), gap(law, attack));
            let g = if g < 0.0 {
                format!("**{}**", two(g))
            } else {
                two(g)
            };
            format!("{} / {g}", two(e))
        };
        let mut line = format!("| {law} |");
        for attack in experiment::CONTROLLER_ATTACKS {
            let shown = if law == "acc" && attack != "none" {
                // The radar-only ACC: every V2V attack gives the unattacked row ("the same").
                assert_eq!(text(attack), text("none"), "acc under {attack}");
                assert_eq!(
                    cell(law, attack),
                    &ControllersRow {
                        attack,
                        ..cell(law, "none").clone()
                    }
                );
                "the same".to_string()
            } else {
                text(attack)
            };
            line += &format!(" {shown} |");
        }
        published(CONTROLLERS_DOC, &line, &[]);
    }

    // PATH CACC collides under four of the six attacks, the ones the README names.
    let attacks = &experiment::CONTROLLER_ATTACKS[1..];
    let path_collisions: Vec<&str> = attacks
        .iter()
        .copied()
        .filter(|a| gap("path_cacc", a) < 0.0)
        .collect();
    assert_eq!(
        path_collisions,
        ["periodic-dos", "delay", "fdi-bias", "replay"]
    );
    published(
        CONTROLLERS_DOC,
        "**The PATH CACC collides under {} of the six attacks.**",
        &[match path_collisions.len() {
            4 => "four".to_string(),
            n => n.to_string(),
        }],
    );

    // Ploeg: no collision; its smallest gap, under the replay.
    let ploeg_worst = attacks
        .iter()
        .copied()
        .min_by(|a, b| gap("ploeg", a).total_cmp(&gap("ploeg", b)))
        .unwrap();
    assert_eq!(ploeg_worst, "replay");
    for attack in attacks {
        assert!(gap("ploeg", attack) > 0.0, "ploeg under {attack}");
    }
    published(
        README,
        "Its smallest gap is {} m, under the replay.",
        &[one(gap("ploeg", "replay"))],
    );
    published(
        CONTROLLERS_DOC,
        "keep {} m even under the replay",
        &[one(gap("ploeg", "replay"))],
    );

    // Consensus: what the replay costs it.
    published(
        CONTROLLERS_DOC,
        "The replay costs it {} m of its {} m.",
        &[
            one(gap("consensus", "none") - gap("consensus", "replay")),
            format!("{:.0}", gap("consensus", "none")),
        ],
    );

    // Flatbed: tight without attack, severe when jammed without a collision, collides only
    // under the replay.
    published(
        README,
        "The flatbed controller tracks tightly ({} m) but is brittle.",
        &[one(error("flatbed", "none"))],
    );
    published(
        CONTROLLERS_DOC,
        "Without attack it tracks within {} m.",
        &[two(error("flatbed", "none"))],
    );
    for attack in ["periodic-dos", "random-dos"] {
        let c = cell("flatbed", attack);
        assert_eq!(c.class.unwrap().name(), "severe", "flatbed under {attack}");
        assert!(c.min_gap_m.unwrap() > 0.0, "flatbed under {attack}");
    }
    let flatbed_collisions: Vec<&str> = attacks
        .iter()
        .copied()
        .filter(|a| gap("flatbed", a) < 0.0)
        .collect();
    assert_eq!(flatbed_collisions, ["replay"]);

    // The paper's law: how far it closes a gap at worst, and where.
    let spacing = base.config.platoon.spacing_m;
    let paper_worst = attacks
        .iter()
        .copied()
        .min_by(|a, b| gap("paper", a).total_cmp(&gap("paper", b)))
        .unwrap();
    assert_eq!(paper_worst, "replay");
    let closed = spacing - gap("paper", "replay");
    published(
        README,
        "**The paper's resilient law never closes a gap by more than {} m** (to {} m, under the replay).",
        &[one(closed), one(gap("paper", "replay"))],
    );
    published(
        CONTROLLERS_DOC,
        "**The paper's law never closes a gap by more than {} m.** Its worst case is {} m, under the replay.",
        &[one(closed), two(gap("paper", "replay"))],
    );
    let paper_largest = attacks
        .iter()
        .copied()
        .max_by(|a, b| error("paper", a).total_cmp(&error("paper", b)))
        .unwrap();
    assert_eq!(paper_largest, "random-dos");
    assert!(gap("paper", "random-dos") >= spacing - error("paper", "random-dos") - 1e-9);
    published(
        CONTROLLERS_DOC,
        "Its largest error, {} m under the random DoS, is a gap *opening*",
        &[one(error("paper", "random-dos"))],
    );
}

/// A shipped campaign (`campaigns/<name>.toml`), every cell run in this process
/// (`campaign::evaluate`, what `platoon campaign` runs for in-process cells, without the
/// campaign directory).
struct Study {
    campaign: Campaign,
    cells: Vec<CellResult>,
    columns: Vec<String>,
}

impl Study {
    fn run(name: &str, samples: Option<usize>) -> Self {
        Self::reduced(name, samples, |_| {})
    }

    /// The campaign with its file edited by `edit` (a reduced grid).
    fn reduced(name: &str, samples: Option<usize>, edit: impl FnOnce(&mut toml::Table)) -> Self {
        let file = crate::common::repo()
            .join("campaigns")
            .join(format!("{name}.toml"));
        let mut spec: toml::Table =
            toml::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        edit(&mut spec);
        let text = toml::to_string(&spec).unwrap();
        let campaign = Campaign::parse(&text, &file, samples).unwrap();
        let cells = campaign::evaluate(&campaign, None, &Stop::default(), &());
        for (cell, result) in campaign.cells.iter().zip(&cells) {
            assert_eq!(
                result.status,
                CellStatus::Ok,
                "{name}: cell {}: {:?}",
                cell.index,
                result.error
            );
        }
        let columns =
            platoon_campaign::metrics::columns(&campaign.metrics, campaign.max_followers());
        Self {
            campaign,
            cells,
            columns,
        }
    }

    /// Cell `i`'s value of the axis `key`.
    fn axis(&self, i: usize, key: &str) -> &toml::Value {
        let column = self
            .campaign
            .columns
            .iter()
            .find(|c| c.name == key)
            .unwrap_or_else(|| panic!("no axis {key}"));
        &column.values[self.campaign.cells[i].coords[column.dim]]
    }

    /// Cell `i`'s axis `key` as a number.
    fn axis_num(&self, i: usize, key: &str) -> f64 {
        let v = self.axis(i, key);
        v.as_float()
            .or_else(|| v.as_integer().map(|n| n as f64))
            .unwrap_or_else(|| panic!("{key} = {v} is no number"))
    }

    /// Cell `i`'s metric `name`.
    fn metric(&self, i: usize, name: &str) -> &platoon_app::campaign::Metric {
        let at = self
            .columns
            .iter()
            .position(|c| c == name)
            .unwrap_or_else(|| panic!("no metric {name}"));
        &self.cells[i].metrics.as_ref().unwrap()[at]
    }

    fn num(&self, i: usize, name: &str) -> f64 {
        self.metric(i, name)
            .as_f64()
            .unwrap_or_else(|| panic!("{name} of cell {i} is no number"))
    }

    fn text(&self, i: usize, name: &str) -> String {
        self.metric(i, name).to_string()
    }

    /// The cells for which `keep` holds.
    fn select(&self, keep: impl Fn(usize) -> bool) -> Vec<usize> {
        (0..self.cells.len()).filter(|&i| keep(i)).collect()
    }

    /// The one cell for which `keep` holds.
    fn one(&self, keep: impl Fn(usize) -> bool) -> usize {
        let found = self.select(keep);
        assert_eq!(found.len(), 1, "{} cells match", found.len());
        found[0]
    }
}

/// A count in words, as the README spells small ones.
fn words(n: usize) -> String {
    const SMALL: [&str; 13] = [
        "zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten",
        "eleven", "twelve",
    ];
    SMALL
        .get(n)
        .map_or_else(|| n.to_string(), |w| w.to_string())
}

/// `campaigns/jammer.toml` at full size (72 cells): the README's findings.
#[test]
fn jammer_study() {
    let s = Study::run("jammer", None);
    assert_eq!(s.cells.len(), 72);
    let power = |i| s.axis_num(i, "channel.jammers[0].power_dbm");
    let lateral = |i| s.axis_num(i, "channel.jammers[0].lateral_m");
    let mode = |i| s.axis(i, "fallback.mode").as_str().unwrap().to_string();
    let jammed = |i| s.num(i, "observed_jammed_s");
    let gap = |i| s.num(i, "min_gap_m");
    let one = |x: f64| format!("{x:.1}");

    // Where the jammer reaches the road, it does so with either fallback.
    let zero = s.select(|i| mode(i) == "zero" && jammed(i) > 0.0);
    let acc = s.select(|i| mode(i) == "acc" && jammed(i) > 0.0);
    let position = |i| (power(i), lateral(i));
    assert_eq!(
        zero.iter().map(|&i| position(i)).collect::<Vec<_>>(),
        acc.iter().map(|&i| position(i)).collect::<Vec<_>>()
    );
    let zero_collides = zero.iter().filter(|&&i| gap(i) < 0.0).count();
    let acc_collides: Vec<usize> = acc.iter().copied().filter(|&i| gap(i) < 0.0).collect();

    // u = 0: every jam longer than 5 s collides, the one shorter does not.
    for &i in &zero {
        assert_eq!(gap(i) < 0.0, jammed(i) > 5.0, "{:?}", position(i));
    }
    let short: Vec<usize> = zero.iter().copied().filter(|&i| jammed(i) <= 5.0).collect();
    assert_eq!(short.len(), 1);
    let weak = s.one(|i| mode(i) == "zero" && power(i) == 0.0 && lateral(i) == 50.0);
    assert_eq!(s.text(weak, "observed_assumption2"), "holds");
    published(
        README,
        "That includes 0 dBm at 50 m from the road: {} s of jamming, which Assumption 2 admits. \
         The one shorter jam ({} s) does not.",
        &[one(jammed(weak)), one(jammed(short[0]))],
    );

    // 20 dBm: from 200 m still, not from 300 m.
    let far = s.one(|i| mode(i) == "zero" && power(i) == 20.0 && lateral(i) == 200.0);
    let farther = s.one(|i| mode(i) == "zero" && power(i) == 20.0 && lateral(i) == 300.0);
    assert!(gap(far) < 0.0);
    assert_eq!(jammed(farther), 0.0);
    published(
        README,
        "**20 dBm still breaks the platoon from 200 m away** ({} s jammed). Only at 300 m does it miss the road.",
        &[one(jammed(far))],
    );

    // ACC on the radar: the collisions it avoids, every 25 dBm position among them.
    for &i in &acc {
        if power(i) == 25.0 {
            assert!(gap(i) > 0.0, "{:?}", position(i));
        }
    }
    // docs/channel-80211p.md's table: every cell, jammed time / Assumption 2 / smallest gap.
    let laterals = [10.0, 50.0, 100.0, 150.0, 200.0, 300.0];
    for p in [0.0, 5.0, 10.0, 15.0, 20.0, 25.0] {
        for m in ["zero", "acc"] {
            let cells: Vec<String> = laterals
                .iter()
                .map(|&l| {
                    let i = s.one(|i| mode(i) == m && power(i) == p && lateral(i) == l);
                    if jammed(i) == 0.0 {
                        "0".to_string()
                    } else {
                        format!(
                            "{} / {} / {}",
                            one(jammed(i)),
                            s.text(i, "observed_assumption2"),
                            one(gap(i))
                        )
                    }
                })
                .collect();
            published(
                CHANNEL_DOC,
                &format!("| {p} dBm, {m} | {} |", cells.join(" | ")),
                &[],
            );
        }
    }
    let untouched = s.one(|i| mode(i) == "zero" && power(i) == 0.0 && lateral(i) == 300.0);
    published(
        CHANNEL_DOC,
        "the platoon then keeps {} m, as without attack.) Of the {} positions where the jammer \
         reaches the road, {} end in a collision with `u = 0`: every observed jam longer than 5 s, \
         admissible ones included. With ACC, {} do.",
        &[
            format!("{:.2}", gap(untouched)),
            zero.len().to_string(),
            zero_collides.to_string(),
            acc_collides.len().to_string(),
        ],
    );
    let example = s.one(|i| mode(i) == "acc" && power(i) == 15.0 && lateral(i) == 100.0);
    assert!(acc_collides.contains(&example));
    published(
        README,
        "**ACC on the radar as the fallback avoids the collision at {} of the {} jammer positions that \
         reach the road** (`u = 0` collides at {} of them), every 25 dBm one among them. {} still \
         collide, at low and intermediate powers (for example 15 dBm at 100 m).",
        &[
            (acc.len() - acc_collides.len()).to_string(),
            acc.len().to_string(),
            zero_collides.to_string(),
            {
                let w = words(acc_collides.len());
                w[..1].to_uppercase() + &w[1..]
            },
        ],
    );
}

/// `campaigns/density.toml` at full size (96 cells): the README's findings.
#[test]
fn density_study() {
    let s = Study::run("density", None);
    assert_eq!(s.cells.len(), 96);
    let density = |i| s.axis_num(i, "channel.radio.density_veh_per_m");
    let rule = |i| {
        s.axis(i, "trigger").as_table().unwrap()["rule"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let background = |i| {
        s.axis(i, "channel.background_beacons")
            .as_str()
            .unwrap()
            .to_string()
    };
    let dcc = |i| {
        s.axis(i, "channel.dcc.t_off_s")
            .as_array()
            .unwrap()
            .iter()
            .any(|t| t.as_float() != Some(0.0))
    };
    let at = |d: f64, r: &str, b: &str, on: bool| {
        s.one(|i| density(i) == d && rule(i) == r && background(i) == b && dcc(i) == on)
    };
    let two = |x: f64| format!("{x:.2}");
    let three = |x: f64| format!("{x:.3}");
    let cbr = |i| s.num(i, "mean_cbr");
    let delivery = |i| s.num(i, "delivery_ratio");

    // Around traffic at 10 Hz every rule sees the same channel and delivers the same share.
    let rules = ["periodic", "cam", "static", "dynamic"];
    let fixed: Vec<usize> = rules.iter().map(|r| at(0.48, r, "fixed", false)).collect();
    for &i in &fixed {
        assert_eq!(two(cbr(i)), two(cbr(fixed[0])), "{}", rule(i));
    }
    let shares: Vec<f64> = fixed.iter().map(|&i| delivery(i)).collect();
    let (least, most) = (
        shares.iter().cloned().fold(1.0, f64::min),
        shares.iter().cloned().fold(0.0, f64::max),
    );
    assert!(most - least < 0.01, "{shares:?}");
    published(
        README,
        "every rule sees the same channel busy ratio ({} at 0.48 veh/m) and delivers about the \
         same share of its packets ({} to {}).",
        &[two(cbr(fixed[0])), two(least), two(most)],
    );

    // docs/channel-80211p.md's table at 0.48 veh/m, DCC off: packets on air with the others at
    // 10 Hz, then the channel and delivery with the others at 10 Hz and as the platoon.
    for (r, label) in [
        ("periodic", "periodic 10 Hz"),
        ("cam", "CAM rules"),
        ("static", "static trigger (21)"),
        ("dynamic", "dynamic trigger (4)+(12)"),
    ] {
        let (f, p) = (at(0.48, r, "fixed", false), at(0.48, r, "platoon", false));
        published(
            CHANNEL_DOC,
            &format!(
                "| {label} | {} | {} | {} | {} | {} |",
                s.num(f, "transmissions"),
                three(cbr(f)),
                three(delivery(f)),
                three(cbr(p)),
                three(delivery(p))
            ),
            &[],
        );
    }

    // Every vehicle as the platoon: the dynamic trigger's fewer packets against the static's.
    let (st, dy) = (
        at(0.48, "static", "platoon", false),
        at(0.48, "dynamic", "platoon", false),
    );
    let fewer = 100.0 * (1.0 - s.num(dy, "transmissions") / s.num(st, "transmissions"));
    let (st12, dy12) = (
        at(0.12, "static", "platoon", false),
        at(0.12, "dynamic", "platoon", false),
    );
    for d in [0.0, 0.03] {
        let (a, b) = (
            at(d, "static", "platoon", false),
            at(d, "dynamic", "platoon", false),
        );
        assert!((delivery(a) - delivery(b)).abs() < 0.01, "at {d} veh/m");
    }
    published(
        README,
        "{} % fewer packets on the air than the static trigger's lower the busy ratio from {} to {} \
         and raise delivery from {} to {} at 0.48 veh/m ({} to {} at 0.12; under 0.01 apart below \
         0.06).",
        &[
            format!("{fewer:.0}"),
            two(cbr(st)),
            two(cbr(dy)),
            two(delivery(st)),
            two(delivery(dy)),
            three(delivery(st12)),
            three(delivery(dy12)),
        ],
    );

    let triggers = |i| s.num(i, "triggers_total");
    let fewer_triggers = 100.0 * (1.0 - triggers(dy) / triggers(st));
    published(
        CHANNEL_DOC,
        "It puts {} % fewer packets on the air than the static trigger ({} % fewer triggers); the \
         CBR drops from {} to {} and the delivery ratio rises from {} to {} at 0.48 veh/m ({} to \
         {} at 0.12, under 0.01 apart below 0.06).",
        &[
            format!("{fewer:.0}"),
            format!("{fewer_triggers:.0}"),
            two(cbr(st)),
            two(cbr(dy)),
            two(delivery(st)),
            two(delivery(dy)),
            three(delivery(st12)),
            three(delivery(dy12)),
        ],
    );
    let fixed12: Vec<usize> = rules.iter().map(|r| at(0.12, r, "fixed", false)).collect();
    for &i in &fixed12 {
        assert_eq!(two(delivery(i)), two(delivery(fixed12[0])), "{}", rule(i));
    }
    published(
        CHANNEL_DOC,
        "every rule sees the same CBR and delivers the same share ({} at 0.48 veh/m, {} at 0.12).",
        &[two(delivery(fixed[0])), two(delivery(fixed12[0]))],
    );
    published(
        CHANNEL_DOC,
        "periodic 10 Hz beacons load the channel less than either (CBR {}, delivery {}).",
        &[two(cbr(fixed[0])), three(delivery(fixed[0]))],
    );

    // How often the paper's triggers fire, per follower and second, against 10 Hz beacons.
    let seconds = 55.0;
    let followers = 4.0;
    let rates: Vec<f64> = s
        .select(|i| matches!(rule(i).as_str(), "static" | "dynamic") && !dcc(i))
        .into_iter()
        .map(|i| s.num(i, "triggers_total") / followers / seconds)
        .collect();
    let (low, high) = (
        rates.iter().cloned().fold(f64::INFINITY, f64::min),
        rates.iter().cloned().fold(0.0, f64::max),
    );
    assert!(low > 10.0);
    published(
        README,
        "Yet the paper's triggers fire {} to {} times a second per follower, more than periodic \
         10 Hz beacons, which load the channel less.",
        &[format!("{low:.1}"), format!("{high:.1}")],
    );
    published(
        CHANNEL_DOC,
        "But the paper's triggers fire {} to {} times a second per follower, more than 10 Hz \
         beaconing",
        &[format!("{low:.1}"), format!("{high:.1}")],
    );

    // The paper's law on CAM beacons collides on an empty channel; DCC in a busy channel (the
    // others at 10 Hz) doubles its RMS spacing error.
    assert!(s.num(at(0.0, "cam", "fixed", false), "min_gap_m") < 0.0);
    let (off, on) = (
        at(0.48, "dynamic", "fixed", false),
        at(0.48, "dynamic", "fixed", true),
    );
    let ratio = s.num(on, "rms_spacing_error_m") / s.num(off, "rms_spacing_error_m");
    assert!((1.8..2.2).contains(&ratio), "{ratio}");
    published(
        README,
        "reactive DCC in a busy channel (260 ms between packets) doubles its spacing error (RMS {} \
         to {} m).",
        &[
            two(s.num(off, "rms_spacing_error_m")),
            two(s.num(on, "rms_spacing_error_m")),
        ],
    );
}

/// `campaigns/monte-carlo.toml` on 100 of its 1000 samples (`--samples 100`, 200 cells; the
/// full size costs about 8 CPU minutes in the dev profile): what docs/campaigns.md publishes.
#[test]
fn monte_carlo_shares() {
    let samples = 100;
    let s = Study::run("monte-carlo", Some(samples));
    assert_eq!(s.cells.len(), 2 * samples);
    let rule = |i| s.axis(i, "trigger.rule").as_str().unwrap().to_string();
    let dynamic = s.select(|i| rule(i) == "dynamic");
    let static_ = s.select(|i| rule(i) == "static");
    assert_eq!((dynamic.len(), static_.len()), (samples, samples));
    let mean = |cells: &[usize], m: &str| {
        cells.iter().map(|&i| s.num(i, m)).sum::<f64>() / cells.len() as f64
    };
    let median = |cells: &[usize], m: &str| {
        let mut v: Vec<f64> = cells.iter().map(|&i| s.num(i, m)).collect();
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2 - 1] + v[v.len() / 2]) / 2.0
    };
    let severe = |cells: &[usize]| {
        100.0
            * cells
                .iter()
                .filter(|&&i| s.text(i, "safety_class") == "severe")
                .count() as f64
            / cells.len() as f64
    };
    // Common random numbers: sample s is the same schedule for both rules, admissible.
    for (&d, &t) in dynamic.iter().zip(&static_) {
        assert_eq!(s.campaign.cells[d].sample, s.campaign.cells[t].sample);
        assert_eq!(s.num(d, "attacked_time_s"), s.num(t, "attacked_time_s"));
        assert_eq!(s.text(d, "assumption2"), "holds");
    }
    let same_class = dynamic
        .iter()
        .zip(&static_)
        .filter(|(&d, &t)| s.text(d, "safety_class") == s.text(t, "safety_class"))
        .count();
    assert_eq!(same_class, samples);
    let (md, ms) = (
        mean(&dynamic, "triggers_total"),
        mean(&static_, "triggers_total"),
    );
    published(
        "docs/campaigns.md",
        "`--samples 100`, the first 100 of its 1000 schedules (200 cells; tested): the dynamic \
         rule sends {} % fewer messages (mean {} vs {}) with the same errors (median largest \
         spacing error {} m vs {} m); {} % of admissible schedules end `severe` with the dynamic \
         rule, {} % with the static one, and each schedule gives both rules the same class",
        &[
            format!("{:.0}", 100.0 * (1.0 - md / ms)),
            format!("{md:.0}"),
            format!("{ms:.0}"),
            format!("{:.2}", median(&dynamic, "max_spacing_error_m")),
            format!("{:.2}", median(&static_, "max_spacing_error_m")),
            format!("{:.0}", severe(&dynamic)),
            format!("{:.0}", severe(&static_)),
        ],
    );
}

/// `platoon experiment degradation` (its default sizes, 4 and 10 followers): the table of
/// docs/degradation.md (4 followers, guard off) and its findings.
#[test]
fn degradation_table_and_findings() {
    const DOC: &str = "docs/degradation.md";
    let base = Base::load(None, Embedded::Degradation).unwrap();
    let d = experiment::degradation(&base, &experiment::DegradationOptions::default(), None, &())
        .unwrap();
    let row = |attack: &str, followers: usize, fallback: &str, guard: bool| {
        d.rows
            .iter()
            .find(|r| {
                r.attack == attack
                    && r.followers == followers
                    && r.fallback == fallback
                    && r.guard == guard
            })
            .unwrap_or_else(|| panic!("no {attack} {followers} {fallback} {guard}"))
    };
    let fallbacks = ["zero", "hold", "predict", "acc"];
    for (attack, label) in [
        ("braking-ramp", "braking ramp (8 s)"),
        ("long-jam", "20 s jam"),
        ("acceleration-ramp", "acceleration ramp (8 s)"),
        ("cruise", "cruise (10 s)"),
        ("paper", "paper schedule"),
    ] {
        let mut line = format!("| {label} |");
        for fallback in fallbacks {
            let r = row(attack, 4, fallback, false);
            let class = if r.collided {
                "collision".to_string()
            } else {
                r.class.name().to_string()
            };
            line += &format!(
                " {class}, {:.1} m ({:.1} m/s^2) |",
                r.min_gap_m, r.max_deceleration_mps2
            );
        }
        published(DOC, &line, &[]);
    }
    for followers in [4, 10] {
        // ACC is the only fallback that survives the long jam and the one over the braking
        // ramp, with 10 followers as with 4.
        for attack in ["braking-ramp", "long-jam"] {
            for fallback in fallbacks {
                assert_eq!(
                    row(attack, followers, fallback, false).collided,
                    fallback != "acc",
                    "{attack}, {followers} followers, {fallback}"
                );
            }
        }
        // ACC during cruise: worse than drifting with u = 0.
        let (acc, zero) = (
            row("cruise", followers, "acc", false),
            row("cruise", followers, "zero", false),
        );
        assert!(acc.class > zero.class, "{followers} followers");
    }
    // ACC's largest spacing error is the largest of all (the gap it opens), and predict is the
    // worst on the acceleration ramp.
    let four: Vec<_> = d
        .rows
        .iter()
        .filter(|r| r.followers == 4 && !r.guard)
        .collect();
    let largest = four
        .iter()
        .max_by(|a, b| a.max_spacing_error_m.total_cmp(&b.max_spacing_error_m))
        .unwrap();
    assert_eq!(largest.fallback, "acc");
    let ramp = four
        .iter()
        .filter(|r| r.attack == "acceleration-ramp")
        .max_by(|a, b| a.max_deceleration_mps2.total_cmp(&b.max_deceleration_mps2))
        .unwrap();
    assert_eq!(ramp.fallback, "predict");
    // The guard keeps u = 0 on the braking ramp from colliding.
    assert!(row("braking-ramp", 4, "zero", false).collided);
    assert!(!row("braking-ramp", 4, "zero", true).collided);
    assert_eq!(d.rows.len(), 80);
    published(
        DOC,
        "for every fallback with and without the guard ({} runs)",
        &[d.rows.len().to_string()],
    );
}

/// `platoon experiment scaling --sizes 4,10 --certify-up-to 10` (the default sizes, up to 100
/// followers with 160 certificates, cost minutes): both tables of docs/long-platoons.md and
/// the figures its findings and docs/design.md quote.
#[test]
fn scaling_on_4_and_10_followers() {
    const DOC: &str = "docs/long-platoons.md";
    let base = Base::load(None, Embedded::Paper).unwrap();
    let opts = experiment::ScalingOptions {
        sizes: vec![4, 10],
        certify_up_to: 10,
        ..experiment::ScalingOptions::default()
    };
    let s = experiment::scaling(&base, &opts, None, &()).unwrap();
    let row = |preset: Preset, n: usize, gain: &str, dos: &str| {
        s.rows
            .iter()
            .find(|r| r.preset == preset && r.followers == n && r.gain == gain && r.dos == dos)
            .unwrap_or_else(|| panic!("no {} {n} {gain} {dos}", preset.name()))
    };
    let presets = [
        (Preset::Pf, "PF"),
        (Preset::Tpsf, "TPSF"),
        (Preset::Plf, "PLF"),
        (Preset::Bpf, "BPF"),
    ];
    let gains = [
        ("paper-constant", "paper K, constant", "paper K"),
        (
            "designed-time-headway",
            "designed K, h_t = 1 s",
            "designed, h_t = 1 s",
        ),
    ];
    let (mut errors, mut certificates) = (String::new(), String::new());
    for (preset, name) in presets {
        for (gain, label, short) in gains {
            // Largest gap error without DoS, and with the base's DoS where it differs by more
            // than 5 %.
            let mut line = format!("| {name} | {label} |");
            for n in [4, 10] {
                let (none, dos) = (row(preset, n, gain, "none"), row(preset, n, gain, "base"));
                let (a, b) = (none.max_gap_error_m, dos.max_gap_error_m);
                let mut cell = format!("{a:.2}");
                if (b - a).abs() > 0.05 * a {
                    cell += &format!(" ({b:.2} DoS)");
                }
                if none.collided || dos.collided {
                    cell += ", collides";
                }
                line += &format!(" {cell} |");
            }
            errors += &line;
            errors += "\n";
            // Theorem 1's smallest ratios: common P / one P per follower (transient growth).
            let mut line = format!("| {name} | {short} |");
            for n in [4, 10] {
                let r = row(preset, n, gain, "none");
                let ratio = |x: Option<f64>| match x {
                    Some(x) if x.is_finite() => format!("{x:.0}"),
                    _ => "-".to_string(),
                };
                let block = match r.block_diagonal_ratio {
                    Some(x) if x.is_finite() => {
                        format!("{x:.0} ({:.0}x)", r.block_diagonal_growth.unwrap())
                    }
                    _ => "-".to_string(),
                };
                line += &format!(" {} / {block} |", ratio(r.certified_ratio));
            }
            certificates += &line;
            certificates += "\n";
        }
    }
    // Each table whole, so that a failure shows every row.
    published(DOC, &errors, &[]);
    // SDP results: their fifth digit moves with the BLAS build (12345 or 12346 for BPF).
    published_close(DOC, &certificates, 2e-3);
    // The string instability of constant spacing on PF, predicted and measured, and the
    // headway's string stability, measured.
    let pf10 = row(Preset::Pf, 10, "paper-constant", "none");
    assert!(!pf10.string_stable);
    let headway = row(Preset::Pf, 10, "designed-time-headway", "none");
    assert!(headway.string_stable);
    published(
        DOC,
        "PF and TPSF are string unstable (predicted amplification {}x at N = 10 on PF)",
        &[format!("{:.1}", pf10.predicted_amplification)],
    );
    published(
        DOC,
        "and the last follower's is a fraction of the first's ({} on PF with 10 followers)",
        &[format!("{:.2}", headway.gap_error_growth.unwrap())],
    );
    for (preset, _) in [(Preset::Pf, "PF"), (Preset::Tpsf, "TPSF")] {
        for n in [4, 10] {
            let r = row(preset, n, "designed-time-headway", "none");
            assert_eq!(format!("{:.0}", r.min_gap_m), "25", "{} {n}", preset.name());
        }
    }
    let plf = |n| {
        row(Preset::Plf, n, "designed-time-headway", "none")
            .certified_ratio
            .unwrap()
    };
    published_close(
        DOC,
        &format!(
            "Theorem 1 for PLF with h_t = 1 s needs a ratio that grows with N ({:.0} at 4, {:.0} \
             at 10).",
            plf(4),
            plf(10)
        ),
        2e-3,
    );
    // The designed gain for PF (the one configs/time-headway.toml's design also finds).
    let pf = s.designs.iter().find(|d| d.preset == Preset::Pf).unwrap();
    let k = pf.design.k;
    published(
        DOC,
        "K = [{}, {}, {}]",
        &[
            format!("{:.2}", k[0]),
            format!("{:.2}", k[1]),
            format!("{:.2}", k[2]),
        ],
    );
    // docs/design.md: the block-diagonal certificate holds where the common one does not.
    for preset in [Preset::Pf, Preset::Tpsf] {
        let r = row(preset, 10, "paper-constant", "none");
        assert!(
            r.certified_ratio.unwrap().is_infinite(),
            "{}",
            preset.name()
        );
        assert!(
            r.block_diagonal_ratio.unwrap().is_finite(),
            "{}",
            preset.name()
        );
    }
    published(
        "docs/design.md",
        "certifies stability for that N where `I_N kron P` is infeasible (the paper's K on PF and \
         TPSF with {} followers)",
        &["10".to_string()],
    );
}

/// Onsets as docs/campaigns.md writes them: each run of consecutive onsets (1 s apart) as
/// `35 s` or `33-38 s`, runs joined by "and".
fn onsets(v: &[f64]) -> String {
    let mut runs: Vec<(f64, f64)> = Vec::new();
    for &x in v {
        match runs.last_mut() {
            Some((_, last)) if (x - *last - 1.0).abs() < 1e-9 => *last = x,
            _ => runs.push((x, x)),
        }
    }
    let runs: Vec<String> = runs
        .iter()
        .map(|&(a, b)| {
            if a == b {
                format!("{a} s")
            } else {
                format!("{a}-{b} s")
            }
        })
        .collect();
    if runs.is_empty() {
        "none".to_string()
    } else {
        runs.join(" and ")
    }
}

/// `campaigns/dos-timing.toml` on durations 1, 3 and 5 s (153 of its 510 cells): where one jam
/// is `severe`, and the cruise where none is.
#[test]
fn dos_timing_on_three_durations() {
    let s = Study::reduced("dos-timing", None, |t| {
        t.get_mut("dos_window").unwrap()["duration_s"] =
            toml::Value::try_from([1.0, 3.0, 5.0]).unwrap();
    });
    assert_eq!(s.cells.len(), 153);
    let onset = |i| s.axis_num(i, "dos.onset_s");
    let duration = |i| s.axis_num(i, "dos.duration_s");
    let severe = |d: f64| {
        let v: Vec<f64> = s
            .select(|i| duration(i) == d && s.text(i, "safety_class") == "severe")
            .into_iter()
            .map(onset)
            .collect();
        onsets(&v)
    };
    let cruise = s.select(|i| (16.0..=30.0).contains(&onset(i)));
    assert_eq!(cruise.len(), 45);
    for &i in &cruise {
        assert_eq!(s.text(i, "safety_class"), "negligible", "{}", onset(i));
    }
    let worst = cruise
        .iter()
        .map(|&i| s.num(i, "max_spacing_error_m"))
        .fold(0.0, f64::max);
    published(
        "docs/campaigns.md",
        "On durations 1, 3 and 5 s (153 cells; tested) a jam that overlaps the braking ramp is \
         `severe` (1 s from {}; 3 s from {}; 5 s from {}), while any of them starting in the \
         cruise between the ramps (16-30 s) stays `negligible`, within {} m",
        &[severe(1.0), severe(3.0), severe(5.0), format!("{worst:.1}")],
    );
}

/// `campaigns/scaling.toml` on 16, 32 and 100 followers (12 of its 24 cells): where constant
/// spacing with the paper's K collides.
#[test]
fn scaling_campaign_on_three_sizes() {
    let s = Study::reduced("scaling", None, |t| {
        t.get_mut("axes").unwrap()[1]["values"] = toml::Value::try_from([16, 32, 100]).unwrap();
    });
    assert_eq!(s.cells.len(), 12);
    let at = |preset: &str, n: i64| {
        s.one(|i| {
            s.axis(i, "topology.preset").as_str() == Some(preset)
                && s.axis(i, "platoon.followers").as_integer() == Some(n)
        })
    };
    let collided = |preset: &str, n: i64| s.num(at(preset, n), "collided") == 1.0;
    let error = |preset: &str, n: i64| s.num(at(preset, n), "max_spacing_error_m");
    assert!(!collided("pf", 16) && collided("pf", 32) && collided("pf", 100));
    assert!(!collided("tpsf", 32) && collided("tpsf", 100));
    assert!(!collided("bpf", 100));
    let plf = [16, 32, 100].map(|n| error("plf", n));
    assert!(plf.iter().all(|&e| e < 0.4), "{plf:?}");
    assert!([16, 32, 100].iter().all(|&n| !collided("plf", n)));
    published(
        "docs/campaigns.md",
        "On 16, 32 and 100 followers (12 cells; tested), with the paper's K and constant spacing PF \
         collides from N = 32 (an error of {} m at N = 100), TPSF at N = 100, BPF ends {} m off \
         without colliding, PLF stays within 0.4 m",
        &[
            format!("{:.0}", error("pf", 100)),
            format!("{:.0}", error("bpf", 100)),
        ],
    );
}
