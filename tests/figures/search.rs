//! `platoon search` (docs/search.md, README): the shipped search files run in process by the
//! library call the command makes, at the reduced number of runs the docs publish
//! (`--evaluations`), and every figure the text states compared at the digits it prints.
use crate::common::{json, published, repo};
use platoon_app::campaign::LocalPool;
use platoon_app::search::{
    self, Found, MethodOutcome, Problem, ProblemOutcome, Search, SearchOptions,
};
use platoon_app::Stop;
use platoon_sim::Safety;

const DOC: &str = "docs/search.md";
const README: &str = "README.md";

/// A shipped search file run as `platoon search FILE --evaluations N --no-plots` runs it.
struct Ran {
    search: Search,
    problems: Vec<ProblemOutcome>,
    dir: std::path::PathBuf,
    _tmp: tempfile::TempDir,
}

fn run(file: &str, evaluations: Option<usize>) -> Ran {
    let search = search::load(&repo().join(file), evaluations).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let opts = SearchOptions {
        force: false,
        plots: false,
    };
    let outcome = search::run(
        &search,
        &tmp.path().join("out"),
        &opts,
        &LocalPool::new(None),
        &Stop::default(),
        &(),
    )
    .unwrap();
    assert!(outcome.committed && outcome.stopped.is_none());
    Ran {
        search,
        problems: outcome.problems,
        dir: outcome.dir,
        _tmp: tmp,
    }
}

fn method<'a>(p: &'a ProblemOutcome, name: &str) -> &'a MethodOutcome {
    p.method(name)
        .unwrap_or_else(|| panic!("{}: no {name}", p.label))
}

fn best<'a>(p: &'a ProblemOutcome, name: &str) -> &'a Found {
    method(p, name).best.as_ref().unwrap()
}

fn harm(f: &Found) -> f64 {
    f.harm.unwrap()
}

fn two(x: f64) -> String {
    format!("{x:.2}")
}

/// The run of `schedule` on `problem`, in process: its safety (was there a collision?).
fn safety(problem: &Problem, found: &Found) -> Safety {
    let mut c = problem.config_of(&found.schedule);
    let scenario = platoon_config::to_scenario(&mut c).unwrap();
    platoon_sim::run(scenario, |_| {}).unwrap().safety
}

/// The longest single jam Assumption 2 admits, `D1 / (1 - 1/D2)`, and the most jamming it
/// admits over the whole run, `D1 + horizon / D2` (s).
fn allowance(problem: &Problem) -> (f64, f64) {
    let a = problem.budget.limits.assumption2.unwrap();
    (
        a.D1 / (1.0 - 1.0 / a.D2),
        a.D1 + problem.grid.horizon() / a.D2,
    )
}

/// One jam as the docs print it: `35.1 s for 6.58 s`.
fn one_jam(f: &Found) -> (f64, f64) {
    assert_eq!(f.schedule.jams.len(), 1, "{}", f.text);
    let j = &f.schedule.jams[0];
    assert_eq!(j.target.to_string(), "channel");
    (j.start_s, j.duration_s)
}

/// campaigns/worst-dos.toml with `--evaluations 100`: the search, random sampling and the grid
/// at 100 runs each on the paper scenario, the table and findings of docs/search.md and the
/// README's summary. The search beats the best of its own seeds (its first generation).
#[test]
fn worst_dos_on_the_paper_scenario() {
    let evaluations = 100;
    let r = run("campaigns/worst-dos.toml", Some(evaluations));
    let (problem, p) = (&r.search.problems[0], &r.problems[0]);
    let names: Vec<&str> = p.methods.iter().map(|m| m.method).collect();
    assert_eq!(names, ["search", "random", "grid"]);
    assert!(p.methods.iter().all(|m| m.evaluations == evaluations));
    assert_eq!(p.worst_by, Some("search"));
    assert_eq!(p.reproduced, Some(true));
    let (search, random, grid) = (best(p, "search"), best(p, "random"), best(p, "grid"));
    let reference = p.reference.as_ref().unwrap();
    let (longest, total) = allowance(problem);

    // The table.
    let (onset, length) = one_jam(search);
    assert_eq!(two(length), two(longest), "the longest jam admitted");
    let worst = json(&r.dir.join("worst/summary.json"));
    assert_eq!(worst["safety"]["collided"], true);
    assert_eq!(search.class.unwrap().name(), "severe");
    published(
        DOC,
        "| search | **{}** | one jam, {} s for {} s | severe (collision) | {} |",
        &[
            two(harm(search)),
            format!("{onset:.1}"),
            two(length),
            evaluations.to_string(),
        ],
    );
    let (ref_onset, ref_length) = one_jam(reference);
    assert!(safety(problem, reference).collided);
    published(
        DOC,
        "| by hand (the issue's) | {} | one jam, {} s for {} s | severe (collision) | 1 |",
        &[
            two(harm(reference)),
            format!("{ref_onset:.1}"),
            format!("{ref_length:.1}"),
        ],
    );
    let (grid_onset, grid_length) = one_jam(grid);
    assert!(safety(problem, grid).collided);
    assert_eq!(grid.class.unwrap().name(), "severe");
    published(
        DOC,
        "| DoS-timing grid | {} | one jam, {} s for {} s | severe (collision) | {} of its {} cells |",
        &[
            two(harm(grid)),
            format!("{grid_onset}"),
            format!("{grid_length}"),
            evaluations.to_string(),
            (r.search.grid_values.0.len() * r.search.grid_values.1.len()).to_string(),
        ],
    );
    assert!(!safety(problem, random).collided);
    published(
        DOC,
        "| random admissible | {} | {} jams, {} s jammed in all | {} | {} |",
        &[
            two(harm(random)),
            random.schedule.jams.len().to_string(),
            two(random.certificate.jammed_s),
            random.class.unwrap().name().to_string(),
            evaluations.to_string(),
        ],
    );

    // How it got there: two of its seeds, then the pattern search.
    let history = &method(p, "search").history;
    let at = |n: usize| &history[n - 1];
    let first_generation = r.search.spec.search.population;
    let seeds_best = history[..first_generation]
        .iter()
        .filter_map(|e| e.harm)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(harm(search) > seeds_best, "the search beats its own seeds");
    assert_eq!(at(10).harm, Some(seeds_best));
    let beaten = history
        .iter()
        .find(|e| e.harm.is_some_and(|h| h > seeds_best))
        .unwrap()
        .evaluation;
    assert_eq!(
        beaten, search.evaluation,
        "nothing between the seed and the best"
    );
    assert!(at(2).harm.unwrap() > harm(reference));
    let second = Found {
        evaluation: 2,
        harm: at(2).harm,
        text: at(2).schedule.to_string(),
        schedule: at(2).schedule.clone(),
        class: at(2).class,
        certificate: search.certificate.clone(),
    };
    let (second_onset, second_length) = one_jam(&second);
    assert_eq!(two(second_length), two(longest));
    assert!(!safety(problem, &second).collided);
    let (tenth_onset, tenth_length) = one_jam(&Found {
        schedule: at(10).schedule.clone(),
        ..second.clone()
    });
    assert_eq!(two(tenth_length), two(longest));
    published(
        DOC,
        "**The search beats the hand-made schedule by {} m ({} %).** Its second run already \
         beats it ({} m, no collision): one of its seeds is the longest jam the assumption \
         allows, {} s + {} s, over the leader's acceleration ramp. Another seed, the same jam from \
         {} s at the start of the braking, gives {} m at run 10, and no run beats it until the \
         pattern search refines the onset to {} s ({} m, run {}).",
        &[
            format!("{:.1}", harm(search) - harm(reference)),
            format!("{:.1}", 100.0 * (harm(search) / harm(reference) - 1.0)),
            format!("{:.1}", at(2).harm.unwrap()),
            format!("{second_onset}"),
            two(second_length),
            format!("{tenth_onset}"),
            two(seeds_best),
            format!("{onset:.1}"),
            two(harm(search)),
            search.evaluation.to_string(),
        ],
    );
    published(
        DOC,
        "the longest jam over the *acceleration* ramp ({} s + {} s) gives {} m without a \
         collision.",
        &[
            format!("{second_onset}"),
            two(second_length),
            format!("{:.1}", at(2).harm.unwrap()),
        ],
    );

    // The budget it spends.
    let a2 = search.certificate.assumption2.as_ref().unwrap();
    let window = a2.worst_duration.unwrap();
    published(
        DOC,
        "One jam of {} s is the longest a single attack may last, D1 / (1 - 1/D2). The \
         certificate in `search.json` shows the duration bound's margin on the window [{}, {}) \
         is {} s.",
        &[
            two(longest),
            format!("{:.1}", window.t1),
            two(window.t2),
            format!("{:.4}", window.margin()),
        ],
    );
    published(
        DOC,
        "**Random sampling misses it by a factor of {}.** {} m is the worst of its {} schedules. \
         They spread the jamming the assumption allows ({} s over the 55 s run, D1 + 55 / D2) \
         over many short jams, and short jams do little. The grid stops at {} s jams, so it \
         cannot reach the worst one either.",
        &[
            format!("{:.0}", harm(search) / harm(random)),
            two(harm(random)),
            evaluations.to_string(),
            two(total),
            format!(
                "{}",
                r.search.grid_values.1.iter().fold(0.0f64, |a, &b| a.max(b))
            ),
        ],
    );
    assert!(r.search.grid_values.1.iter().all(|&d| d < longest));

    // The README's summary.
    published(
        README,
        "Its best is one {} s jam from {} s, over the leader's braking ramp: a spacing error of \
         {} m and a collision. The best hand-made schedule ({} s from {} s) gives {} m. The worst \
         of {} random admissible schedules gives {} m, and the best of {} cells of the \
         DoS-timing grid {} m.",
        &[
            two(length),
            format!("{onset:.1}"),
            format!("{:.1}", harm(search)),
            format!("{ref_length:.1}"),
            format!("{ref_onset:.1}"),
            format!("{:.1}", harm(reference)),
            evaluations.to_string(),
            format!("{:.1}", harm(random)),
            evaluations.to_string(),
            format!("{:.1}", harm(grid)),
        ],
    );
}

/// campaigns/worst-dos-budget-2.9.toml and -2.7.toml: the search with a total jammed time on
/// top of Assumption 2, harm the smallest gap. 2.9 s in all is enough for a collision; the
/// search finds none with 2.7 s.
#[test]
fn a_fraction_of_the_budget_is_enough_for_a_collision() {
    let mut found = Vec::new();
    for budget in ["2.9", "2.7"] {
        let r = run(&format!("campaigns/worst-dos-budget-{budget}.toml"), None);
        let (problem, p) = (&r.search.problems[0], &r.problems[0]);
        assert_eq!(
            problem.budget.limits.max_jammed_s,
            Some(budget.parse().unwrap())
        );
        assert_eq!(r.search.harm.name(), "min_gap_m");
        assert_eq!(p.reproduced, Some(true));
        let b = best(p, "search").clone();
        let (onset, length) = one_jam(&b);
        assert_eq!(
            format!("{length:.1}"),
            budget,
            "the whole budget in one jam"
        );
        found.push((
            r.search.spec.evaluations,
            onset,
            length,
            harm(&b),
            allowance(problem),
        ));
    }
    let (evaluations, onset, length, gap, (longest, total)) = found[0];
    let (evaluations_27, onset_27, length_27, gap_27, _) = found[1];
    assert_eq!(evaluations, evaluations_27);
    assert_eq!(onset, onset_27);
    assert!(gap < 0.0 && gap_27 > 0.0);
    published(
        DOC,
        "a budget of {} s of jamming in all is enough for a collision ({} s + {} s, a gap of {} \
         m; searched with `max_jammed_s` on top of Assumption 2, {} runs each: \
         `campaigns/worst-dos-budget-2.9.toml`). With {} s (`campaigns/worst-dos-budget-2.7.toml`) \
         the smallest gap the search finds is still {} m. That is {} % of the longest jam the \
         assumption allows ({} s), and {} % of the {} s it allows over the 55 s run.",
        &[
            format!("{length:.1}"),
            format!("{onset}"),
            format!("{length:.1}"),
            two(gap),
            evaluations.to_string(),
            format!("{length_27:.1}"),
            two(gap_27),
            format!("{:.0}", 100.0 * length / longest),
            two(longest),
            format!("{:.0}", 100.0 * length / total),
            two(total),
        ],
    );
    published(
        README,
        "{} s of jamming in all is already enough for a collision: {} % of what the assumption \
         allows.",
        &[
            format!("{length:.1}"),
            format!("{:.0}", 100.0 * length / total),
        ],
    );
}

/// campaigns/worst-dos-study.toml with `--evaluations 24`: every law on pf and plf, the
/// search's first generation beside 24 runs of random sampling and 24 cells of the grid; the
/// table of docs/search.md row by row, its findings and the README's summary.
#[test]
fn the_study_of_every_law() {
    let evaluations = 24;
    let r = run("campaigns/worst-dos-study.toml", Some(evaluations));
    let outcome = |label: &str| -> &ProblemOutcome {
        r.problems
            .iter()
            .find(|p| p.label == label)
            .unwrap_or_else(|| panic!("no {label}"))
    };
    let figures = |p: &ProblemOutcome| -> [f64; 4] {
        [
            harm(best(p, "search")),
            harm(p.reference.as_ref().unwrap()),
            harm(best(p, "grid")),
            harm(best(p, "random")),
        ]
    };
    let laws = ["paper", "acc", "path_cacc", "ploeg", "consensus", "flatbed"];
    let names = [
        "paper",
        "ACC (radar only)",
        "PATH CACC",
        "Ploeg",
        "consensus",
        "flatbed",
    ];
    for p in &r.problems {
        let reads_the_leader = ["path_cacc", "consensus", "flatbed"]
            .iter()
            .any(|l| p.label.starts_with(&format!("{l}-")));
        assert_eq!(
            p.not_run.is_some(),
            reads_the_leader && p.label.ends_with("-pf"),
            "{}",
            p.label
        );
        if p.not_run.is_none() {
            assert_eq!(p.reproduced, Some(true), "{}", p.label);
            assert!(p.methods.iter().all(|m| m.evaluations == evaluations));
        }
    }
    // The laws that read only their predecessor (and the leader's law on follower 1) give the
    // same on pf and plf.
    for law in ["paper", "acc", "ploeg"] {
        let (pf, plf) = (
            outcome(&format!("{law}-pf")),
            outcome(&format!("{law}-plf")),
        );
        assert_eq!(figures(pf), figures(plf), "{law}");
        assert_eq!(best(pf, "search").text, best(plf, "search").text, "{law}");
    }
    let mut searched = Vec::new();
    for (law, name) in laws.iter().zip(names) {
        let p = outcome(&format!("{law}-plf"));
        let f = figures(p);
        let (worst_by, worst) = p.worst().unwrap();
        let topologies = if ["paper", "acc", "ploeg"].contains(law) {
            "pf, plf"
        } else {
            "plf"
        };
        if *law == "acc" {
            assert!(f.iter().all(|&x| x == f[0] && x > 0.0), "{f:?}");
            published(
                DOC,
                "| {} | {} | {} | {} | {} | {} | any: jamming does nothing |",
                &[
                    name.to_string(),
                    topologies.to_string(),
                    two(f[0]),
                    two(f[1]),
                    two(f[2]),
                    two(f[3]),
                ],
            );
            continue;
        }
        assert_eq!(worst_by, "search", "{law}");
        assert!(f[0] < f[1] && f[0] < f[2] && f[0] < f[3], "{law}: {f:?}");
        let (onset, length) = one_jam(worst);
        let margin = worst
            .certificate
            .assumption2
            .as_ref()
            .unwrap()
            .worst_duration
            .unwrap()
            .margin();
        published(
            DOC,
            "| {} | {} | **{}** | {} | {} | {} | {} s + {} s |",
            &[
                name.to_string(),
                topologies.to_string(),
                two(f[0]),
                two(f[1]),
                two(f[2]),
                two(f[3]),
                format!("{onset}"),
                two(length),
            ],
        );
        searched.push((*law, name, f, onset, length, margin));
    }

    // Every law that uses V2V collides; the order from least to most harmed.
    assert!(searched.iter().all(|s| s.2[0] < 0.0));
    let mut order = searched.clone();
    order.sort_by(|a, b| b.2[0].total_cmp(&a.2[0]));
    let named = |i: usize| (order[i].1.to_string(), format!("{:.1}", order[i].2[0]));
    assert_eq!(order[0].0, "consensus");
    assert_eq!(order[1].0, "paper");
    assert_eq!(order[4].0, "path_cacc");
    published(
        DOC,
        "The least harmed cooperative law is consensus, at {} m, then the paper's resilient law, \
         at {} m, the {} controller ({} m) and {}'s ({} m). PATH CACC does worst, at {} m.",
        &[
            named(0).1,
            named(1).1,
            named(2).0,
            named(2).1,
            named(3).0,
            named(3).1,
            named(4).1,
        ],
    );
    published(
        README,
        "Consensus fares best, at {} m of smallest gap, then the paper's law ({} m). The {} \
         controller reaches {} m, {}'s law {} m and PATH CACC {} m.",
        &[
            named(0).1,
            named(1).1,
            named(2).0,
            named(2).1,
            named(3).0,
            named(3).1,
            named(4).1,
        ],
    );

    // Sampling: the laws random sampling and the grid leave without a collision.
    let safe = |column: usize| -> Vec<&str> {
        searched
            .iter()
            .filter(|s| s.2[column] >= 0.0)
            .map(|s| s.0)
            .collect()
    };
    assert_eq!(safe(3), ["paper", "consensus"]);
    assert_eq!(safe(2), ["paper", "ploeg", "consensus", "flatbed"]);
    let of = |law: &str| searched.iter().find(|s| s.0 == law).unwrap().2;
    published(
        DOC,
        "The worst of {} random admissible schedules leaves the paper's law a {} m gap and \
         consensus {} m, and the grid's {} cells leave them {} m and {} m, Ploeg's law {} m and \
         the flatbed controller {} m.",
        &[
            evaluations.to_string(),
            two(of("paper")[3]),
            two(of("consensus")[3]),
            evaluations.to_string(),
            two(of("paper")[2]),
            two(of("consensus")[2]),
            two(of("ploeg")[2]),
            two(of("flatbed")[2]),
        ],
    );
    let gains: Vec<(f64, &str)> = searched.iter().map(|s| (s.2[1] - s.2[0], s.1)).collect();
    let least = gains
        .iter()
        .copied()
        .fold((f64::INFINITY, ""), |a, b| if b.0 < a.0 { b } else { a });
    let most = gains
        .iter()
        .copied()
        .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a });
    published(
        DOC,
        "For every law, the search also beats the hand-made jam, by {} m ({}) to {} m ({}).",
        &[
            format!("{:.1}", least.0),
            least.1.to_string(),
            format!("{:.1}", most.0),
            most.1.to_string(),
        ],
    );

    // The worst attacks: one jam, the longest the assumption allows, from the braking's start.
    let (longest, _) = allowance(&r.search.problems[0]);
    assert!(searched
        .iter()
        .all(|s| s.3 == searched[0].3 && two(s.4) == two(longest)));
    let tightest = searched.iter().map(|s| s.5).fold(f64::INFINITY, f64::min);
    assert!(tightest >= 0.0);
    published(
        DOC,
        "Every worst schedule is one jam of {} s from {} s, and its tightest window meets the \
         duration bound to within {} s.",
        &[
            two(longest),
            format!("{}", searched[0].3),
            format!("{tightest:.4}"),
        ],
    );
}
