//! What the attacker may do ([`Budget`]), the repair of any proposal into it, and the
//! certificate every schedule must earn before it is run.
use crate::{Grid, Jamming, Schedule, SearchError, Target};
use platoon_attacks::{Assumption2, Assumption2Report};
use serde::{Deserialize, Serialize};

/// One jam on the step grid: steps `[start, start + len)` on the budget's target `target`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Jam {
    /// First jammed step.
    pub start: u64,
    /// Jammed steps, >= 1.
    pub len: u64,
    /// Index into [`Budget::targets`].
    pub target: usize,
}

impl Jam {
    /// The first step after it.
    pub fn end(&self) -> u64 {
        self.start + self.len
    }
}

/// A repaired proposal: jams sorted, at least one step apart, within the budget.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct Plan(pub Vec<Jam>);

/// How far the repair lets a sum's rounding pass a bound (s): a tenth of the exact checker's
/// tolerance, so that a bound met exactly on the grid (a 2 s jam under a 2 s cap) is kept.
const ROUNDING: f64 = 1e-10;

/// What the attacker may do, as a search file's `[budget]` table gives it. Every bound given
/// applies.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Assumption 2 (frequency and duration of DoS), certified on every window by the exact
    /// checker [in a search file: the base's `attack.assumption2`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assumption2: Option<Assumption2>,
    /// Total jammed time over the run (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_jammed_s: Option<f64>,
    /// Number of jams.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_intervals: Option<usize>,
    /// Shortest jam (s) \[one step\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_interval_s: Option<f64>,
    /// Longest jam (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_interval_s: Option<f64>,
    /// `channel` (the paper's DoS: every vehicle senses it) or `links` (one V2V link at a
    /// time, the receivers not told) \[channel\].
    #[serde(default)]
    pub jam: JamKind,
    /// With `jam = "links"`: the links, `[sender, receiver]` \[every link of the topology\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub links: Option<Vec<[u16; 2]>>,
}

/// What a jam hits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum JamKind {
    /// The whole channel.
    #[default]
    Channel,
    /// One link at a time.
    Links,
}

/// The attacker's budget: its [`Limits`] on the jamming activity (the union of the jams,
/// whatever they hit: one jammer) and the targets they resolve to.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Budget {
    /// The bounds, every one given applying at once.
    #[serde(flatten)]
    pub limits: Limits,
    /// What a jam may hit: the whole channel, or links.
    pub targets: Vec<Target>,
}

/// Whether a schedule is within a [`Budget`], and why not.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Certificate {
    /// Every bound holds.
    pub holds: bool,
    /// The exact checker's verdict on Assumption 2, with its tightest windows (a budget with
    /// Assumption 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assumption2: Option<Assumption2Report>,
    /// Jammed time within the run (s).
    pub jammed_s: f64,
    /// Jams.
    pub intervals: usize,
    /// The first bound that fails.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub violation: Option<String>,
}

impl Budget {
    /// Whole-channel jamming under the paper's Assumption 2 and nothing else.
    pub fn assumption2(bounds: Assumption2) -> Self {
        Self {
            limits: Limits {
                assumption2: Some(bounds),
                ..Limits::default()
            },
            targets: vec![Target::Channel],
        }
    }

    /// Checks the values; errors name the key (`budget.max_jammed_s`).
    pub fn validate(&self) -> Result<(), SearchError> {
        if let Some(b) = &self.limits.assumption2 {
            b.validate()
                .map_err(|e| SearchError::new("budget.assumption2", e.to_string()))?;
        }
        let positive = |key: &str, x: Option<f64>| match x {
            Some(x) if !(x.is_finite() && x > 0.0) => Err(SearchError::new(
                format!("budget.{key}"),
                format!("must be a number of seconds > 0 (got {x})"),
            )),
            _ => Ok(()),
        };
        positive("max_jammed_s", self.limits.max_jammed_s)?;
        positive("min_interval_s", self.limits.min_interval_s)?;
        positive("max_interval_s", self.limits.max_interval_s)?;
        if let (Some(lo), Some(hi)) = (self.limits.min_interval_s, self.limits.max_interval_s) {
            if lo > hi {
                return Err(SearchError::new(
                    "budget.min_interval_s",
                    format!("is above budget.max_interval_s ({lo} > {hi})"),
                ));
            }
        }
        if self.limits.max_intervals == Some(0) {
            return Err(SearchError::new(
                "budget.max_intervals",
                "must be at least 1 (no jam at all is no attack to search)",
            ));
        }
        if self.targets.is_empty() {
            return Err(SearchError::new(
                "budget.jam",
                "no target: the topology has no link to jam",
            ));
        }
        Ok(())
    }

    /// The longest single jam on a run of `horizon` s (s).
    pub fn longest(&self, horizon: f64) -> f64 {
        let mut l = horizon;
        if let Some(b) = &self.limits.assumption2 {
            l = l.min(b.D1 / (1.0 - 1.0 / b.D2));
        }
        for x in [self.limits.max_jammed_s, self.limits.max_interval_s]
            .into_iter()
            .flatten()
        {
            l = l.min(x);
        }
        l
    }

    /// The most jams a schedule on a run of `horizon` s may have (0: the budget admits no
    /// jam at all, e.g. T1 < 1).
    pub fn most_intervals(&self, grid: &Grid) -> usize {
        let horizon = grid.horizon();
        let mut n = (grid.steps() as usize).div_ceil(2);
        if let Some(b) = &self.limits.assumption2 {
            if b.T1 < 1.0 {
                return 0;
            }
            n = n.min((b.T1 + horizon / b.T2).floor() as usize);
        }
        if let Some(m) = self.limits.max_intervals {
            n = n.min(m);
        }
        if let (Some(total), Some(shortest)) =
            (self.limits.max_jammed_s, self.limits.min_interval_s)
        {
            n = n.min((total / shortest).floor() as usize);
        }
        n
    }

    /// The shortest jam in steps (at least one).
    fn min_len(&self, grid: &Grid) -> u64 {
        self.limits
            .min_interval_s
            .map_or(1, |m| grid.ceil(m - ROUNDING).max(1))
    }

    /// Checks `schedule` against every bound on a run of `horizon` s: its jams in order,
    /// disjoint, within the run and on allowed targets; their lengths, number and total; and
    /// Assumption 2 by the exact checker on the jamming activity.
    pub fn certify(&self, schedule: &Schedule, horizon: f64) -> Certificate {
        let mut cert = Certificate {
            holds: false,
            assumption2: None,
            jammed_s: 0.0,
            intervals: schedule.jams.len(),
            violation: None,
        };
        let fail = |mut c: Certificate, why: String| {
            c.violation = Some(why);
            c
        };
        let activity = match schedule.activity() {
            Ok(a) => a,
            Err(e) => return fail(cert, e),
        };
        cert.jammed_s = activity.active_time(0.0, horizon);
        if let Some(b) = &self.limits.assumption2 {
            cert.assumption2 = Some(b.check(&activity, horizon));
        }
        for (i, j) in schedule.jams.iter().enumerate() {
            if !self.targets.contains(&j.target) {
                return fail(cert, format!("jam {i} hits {}, not a target", j.target));
            }
            let end = j.start_s + j.duration_s;
            if end > horizon + 1e-9 {
                return fail(cert, format!("jam {i} ends at {end} s, after the run"));
            }
            if let Some(next) = schedule.jams.get(i + 1) {
                if next.start_s < end {
                    return fail(cert, format!("jams {i} and {} overlap", i + 1));
                }
            }
            if let Some(m) = self.limits.min_interval_s {
                if j.duration_s < m - 1e-9 {
                    return fail(cert, format!("jam {i} is shorter than {m} s"));
                }
            }
            if let Some(m) = self.limits.max_interval_s {
                if j.duration_s > m + 1e-9 {
                    return fail(cert, format!("jam {i} is longer than {m} s"));
                }
            }
        }
        if let Some(m) = self.limits.max_intervals {
            if schedule.jams.len() > m {
                return fail(cert, format!("{} jams, more than {m}", schedule.jams.len()));
            }
        }
        if let Some(m) = self.limits.max_jammed_s {
            if cert.jammed_s > m + 1e-9 {
                let why = format!("{} s jammed, more than {m} s", cert.jammed_s);
                return fail(cert, why);
            }
        }
        if let Some(r) = &cert.assumption2 {
            if !r.holds {
                return fail(cert, "Assumption 2 is violated".into());
            }
        }
        cert.holds = true;
        cert
    }

    /// The schedule of `plan` on `grid`, in seconds: each jam's start and length on the grid
    /// (certified as they are, by [`Budget::certify`]).
    pub fn schedule(&self, grid: &Grid, plan: &Plan) -> Schedule {
        Schedule {
            jams: plan
                .0
                .iter()
                .map(|j| Jamming {
                    start_s: grid.time(j.start),
                    // The length of `len` steps (6.58, not 41.58 - 35 = 6.579999999999998).
                    duration_s: grid.time(j.len),
                    target: self.targets[j.target.min(self.targets.len() - 1)],
                })
                .collect(),
        }
    }

    /// Maps any proposal into the budget, jamming only where the proposal did: jams are
    /// clipped to the run; jams on one target that overlap or touch merge; a jam that overlaps
    /// one on another target loses its front (they stay a step apart). Then, in time order, a
    /// jam's front is trimmed until Assumption 2's frequency bound holds on every window ending
    /// at it, and its end until the duration bound, the longest jam and the total hold (the
    /// incremental form of the exact checker's O(n) pass); a jam left shorter than the
    /// shortest allowed, or beyond the number allowed, is dropped. The result is certified by
    /// [`Budget::certify`] (tested on random proposals).
    pub fn repair(&self, grid: &Grid, proposal: &[Jam]) -> Plan {
        let h = grid.steps();
        let targets = self.targets.len();
        let mut jams: Vec<Jam> = proposal
            .iter()
            .filter(|j| j.start < h && j.len > 0 && j.target < targets)
            .map(|j| Jam {
                len: j.len.min(h - j.start),
                ..*j
            })
            .collect();
        jams.sort();
        let mut disjoint: Vec<Jam> = Vec::with_capacity(jams.len());
        for mut j in jams {
            if let Some(last) = disjoint.last_mut() {
                let end = last.end();
                if j.target == last.target && j.start <= end {
                    last.len = end.max(j.end()) - last.start;
                    continue;
                }
                let free = end + u64::from(j.target != last.target);
                if j.start < free {
                    if j.end() <= free {
                        continue;
                    }
                    j.len = j.end() - free;
                    j.start = free;
                }
            }
            disjoint.push(j);
        }
        let most = self.most_intervals(grid);
        let min_len = self.min_len(grid);
        let longest = self.longest(grid.horizon());
        let mut out: Vec<Jam> = Vec::with_capacity(disjoint.len());
        let (mut best_f, mut best_d) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        let mut cumulative = 0.0; // jammed time of the jams kept (s)
        for j in disjoint {
            if out.len() >= most {
                break;
            }
            let (mut a, mut e) = (j.start, j.end());
            let mut ta = grid.time(a);
            let mut d_max = longest + ROUNDING;
            if let Some(b) = &self.limits.assumption2 {
                let k = out.len() as f64;
                // Frequency on windows [a_i, a_j]: (k + 1) - (a_j - a_i)/T2 <= T1.
                let earliest = b.T2 * (k + 1.0 - b.T1 + best_f) - ROUNDING;
                if ta < earliest {
                    a = grid.ceil(earliest);
                    ta = grid.time(a);
                }
                // Duration on windows [a_i, a_j + d_j].
                if best_d.is_finite() {
                    let cap = (b.D1 - cumulative + ta / b.D2 - best_d) / (1.0 - 1.0 / b.D2);
                    d_max = d_max.min(cap + ROUNDING);
                }
            }
            if let Some(total) = self.limits.max_jammed_s {
                d_max = d_max.min(total - cumulative + ROUNDING);
            }
            if a >= e || d_max <= 0.0 {
                continue;
            }
            e = e.min(grid.floor(ta + d_max));
            if e <= a || e - a < min_len {
                continue;
            }
            let d = grid.time(e) - ta;
            if let Some(b) = &self.limits.assumption2 {
                best_f = best_f.max(ta / b.T2 - out.len() as f64);
                best_d = best_d.max(ta / b.D2 - cumulative);
            }
            cumulative += d;
            out.push(Jam {
                start: a,
                len: e - a,
                target: j.target,
            });
        }
        // The rounding allowed is a tenth of the checker's: this loop is a formality; it keeps the promise if rounding ever wins.
        let mut plan = Plan(out);
        for _ in 0..4 {
            if self
                .certify(&self.schedule(grid, &plan), grid.horizon())
                .holds
            {
                return plan;
            }
            plan.0.retain_mut(|j| {
                j.len -= 1;
                j.len >= min_len
            });
        }
        Plan::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const PAPER: Assumption2 = Assumption2::PAPER;

    fn grid() -> Grid {
        Grid::new(0.01, 5500).unwrap()
    }

    fn jam(start: u64, len: u64) -> Jam {
        Jam {
            start,
            len,
            target: 0,
        }
    }

    #[test]
    fn an_admissible_proposal_is_kept() {
        let b = Budget::assumption2(PAPER);
        let p = [jam(3490, 650)];
        assert_eq!(b.repair(&grid(), &p).0, p);
        let s = b.schedule(&grid(), &Plan(p.to_vec()));
        assert_eq!(s.to_string(), "34.9+6.5 s");
        assert!(b.certify(&s, 55.0).holds);
    }

    #[test]
    fn a_jam_too_long_loses_its_end() {
        let b = Budget::assumption2(PAPER);
        let p = b.repair(&grid(), &[jam(3000, 1000)]);
        // The longest single attack: D1 / (1 - 1/D2) = 6.58 s.
        assert_eq!(p.0, [jam(3000, 658)]);
        let bad = b.schedule(&grid(), &Plan(vec![jam(3000, 659)]));
        let c = b.certify(&bad, 55.0);
        assert!(!c.holds && c.violation.unwrap().contains("Assumption 2"));
    }

    #[test]
    fn a_third_jam_within_t2_loses_its_front() {
        let b = Budget::assumption2(PAPER);
        let p = b.repair(&grid(), &[jam(0, 50), jam(400, 50), jam(900, 100)]);
        // N = 3 needs the third start 9.46 s after the first.
        assert_eq!(p.0[..2], [jam(0, 50), jam(400, 50)]);
        assert_eq!(p.0[2].end(), 1000);
        assert!(p.0[2].start >= 946);
        assert!(b.certify(&b.schedule(&grid(), &p), 55.0).holds);
    }

    #[test]
    fn jams_on_one_target_merge_and_on_two_stay_apart() {
        let mut b = Budget::assumption2(PAPER);
        b.targets = vec![
            Target::Link {
                sender: 0,
                receiver: 1,
            },
            Target::Link {
                sender: 1,
                receiver: 2,
            },
        ];
        let p = b.repair(
            &grid(),
            &[
                jam(100, 100),
                jam(200, 50),
                Jam {
                    start: 240,
                    len: 30,
                    target: 1,
                },
            ],
        );
        assert_eq!(
            p.0,
            [
                jam(100, 150),
                Jam {
                    start: 251,
                    len: 19,
                    target: 1
                }
            ]
        );
    }

    #[test]
    fn totals_counts_and_lengths_bound_the_repair() {
        let b = Budget {
            limits: Limits {
                max_jammed_s: Some(3.0),
                max_intervals: Some(2),
                min_interval_s: Some(0.5),
                max_interval_s: Some(2.0),
                ..Limits::default()
            },
            targets: vec![Target::Channel],
        };
        let p = b.repair(
            &grid(),
            &[jam(100, 300), jam(1000, 40), jam(2000, 300), jam(3000, 100)],
        );
        // 2 s (capped), the 0.4 s jam dropped, then the 1 s left of the total, exactly.
        assert_eq!(p.0, [jam(100, 200), jam(2000, 100)]);
        assert!(b.certify(&b.schedule(&grid(), &p), 55.0).holds);
        assert_eq!(b.most_intervals(&grid()), 2);
    }

    #[test]
    fn no_jam_is_admissible_below_one_attack() {
        let b = Budget::assumption2(Assumption2 { T1: 0.5, ..PAPER });
        assert_eq!(b.most_intervals(&grid()), 0);
        assert!(b.repair(&grid(), &[jam(10, 10)]).0.is_empty());
    }

    #[test]
    fn bad_budgets_name_their_key() {
        let mut b = Budget::assumption2(PAPER);
        b.limits.max_jammed_s = Some(-1.0);
        assert_eq!(b.validate().unwrap_err().key, "budget.max_jammed_s");
        let mut b = Budget::assumption2(Assumption2 { D2: 0.5, ..PAPER });
        assert_eq!(b.validate().unwrap_err().key, "budget.assumption2");
        b.limits.assumption2 = None;
        b.targets.clear();
        assert_eq!(b.validate().unwrap_err().key, "budget.jam");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        /// Whatever is proposed, the repair is certified by the exact checker, jams only where
        /// the proposal jammed, and keeps an admissible plan as it is.
        #[test]
        fn repairs_are_certified_subsets(
            proposal in prop::collection::vec((0u64..6000, 1u64..900, 0usize..3), 0..10),
            t1 in 1.0f64..3.0, t2 in 2.0f64..15.0, d1 in 0.5f64..8.0, d2 in 1.5f64..20.0,
            total in prop::option::of(0.5f64..20.0),
            count in prop::option::of(1usize..6),
            min in prop::option::of(0.01f64..1.0),
            dt in prop_oneof![Just(0.01), Just(0.05), Just(0.03)],
        ) {
            let grid = Grid::new(dt, (55.0 / dt).round() as u64).unwrap();
            let b = Budget {
                limits: Limits {
                    assumption2: Some(Assumption2 { T1: t1, T2: t2, D1: d1, D2: d2 }),
                    max_jammed_s: total,
                    max_intervals: count,
                    min_interval_s: min,
                    ..Limits::default()
                },
                targets: vec![
                    Target::Channel,
                    Target::Link { sender: 0, receiver: 1 },
                    Target::Link { sender: 1, receiver: 2 },
                ],
            };
            let jams: Vec<Jam> = proposal
                .iter()
                .map(|&(start, len, target)| Jam { start, len, target })
                .collect();
            let plan = b.repair(&grid, &jams);
            let s = b.schedule(&grid, &plan);
            let c = b.certify(&s, grid.horizon());
            prop_assert!(c.holds, "{:?} -> {} : {:?}", jams, s, c);
            for j in &plan.0 {
                prop_assert!((j.start..j.end()).all(|k| jams
                    .iter()
                    .any(|p| p.target == j.target && p.start <= k && k < p.end())));
            }
            prop_assert_eq!(&b.repair(&grid, &plan.0), &plan);
        }
    }
}
