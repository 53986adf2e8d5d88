//! The strategies: each proposes batches of certified schedules and is told the harm of each.
use crate::{Budget, Grid, Jam, Jamming, Plan, Schedule, SearchError, Target};
use platoon_attacks::RandomDos;
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Proposes schedules in batches (a batch is what the caller runs in parallel: a generation)
/// and learns from their scores (higher is more harmful; `-inf` for a run that gave no harm).
/// Every schedule proposed has passed [`Budget::certify`].
pub trait Strategy {
    /// Its name in outputs (`search`, `random`, `grid`).
    fn name(&self) -> &'static str;
    /// At most `max` new schedules to run (empty: it has nothing more to propose).
    fn ask(&mut self, max: usize) -> Vec<Schedule>;
    /// The scores of the last batch, in its order.
    fn tell(&mut self, scores: &[f64]);
    /// Proposals the budget refused (never run).
    fn rejected(&self) -> usize;
}

/// The seed the Monte Carlo campaigns give the DoS generator of sample `sample` of a campaign
/// seeded `seed` (`platoon_campaign::sample_seed`, then the first draw of its stream, halved
/// as a config's integer): with the seed of `campaigns/monte-carlo.toml` the random baseline
/// meets the campaign's very schedules.
pub fn monte_carlo_seed(seed: u64, sample: usize) -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(sample as u64);
    let s = rng.next_u64();
    ChaCha8Rng::seed_from_u64(s).next_u64() >> 1
}

/// The random generator's settings ([`RandomDos`] without its seed), as a Monte Carlo
/// campaign's `dos` gives them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomSettings {
    /// Smallest quiet time between two jams (s).
    pub min_gap_s: f64,
    /// Largest proposed quiet time (s).
    pub max_gap_s: f64,
    /// Shortest proposed jam (s).
    pub min_duration_s: f64,
    /// Longest proposed jam (s).
    pub max_duration_s: f64,
}

impl Default for RandomSettings {
    /// `campaigns/monte-carlo.toml`'s.
    fn default() -> Self {
        Self {
            min_gap_s: 1.0,
            max_gap_s: 12.0,
            min_duration_s: 0.5,
            max_duration_s: 3.0,
        }
    }
}

/// Random admissible schedules. With Assumption 2 in the budget, sample `s` is the seeded
/// generator's ([`RandomDos`], seeded by [`monte_carlo_seed`]) as the Monte Carlo campaigns
/// draw it, cut to the budget's other bounds (jams beyond the number allowed dropped, the total
/// and the longest jam trimmed from the end); otherwise uniform jams on the grid, repaired.
/// Targets are drawn uniformly per jam from a stream of the same seed. A draw the budget
/// refuses is counted and not run.
#[derive(Debug, Clone)]
pub struct RandomSampler {
    grid: Grid,
    budget: Budget,
    settings: RandomSettings,
    seed: u64,
    next: usize,
    rejected: usize,
}

impl RandomSampler {
    /// Samples from `seed` within `budget` on `grid`.
    pub fn new(
        grid: Grid,
        budget: Budget,
        settings: RandomSettings,
        seed: u64,
    ) -> Result<Self, SearchError> {
        budget.validate()?;
        RandomDos {
            seed,
            min_gap: settings.min_gap_s,
            max_gap: settings.max_gap_s,
            min_duration: settings.min_duration_s,
            max_duration: settings.max_duration_s,
        }
        .validate()
        .map_err(|e| SearchError::new("random", e.to_string()))?;
        Ok(Self {
            grid,
            budget,
            settings,
            seed,
            next: 0,
            rejected: 0,
        })
    }

    fn draw(&self, sample: usize) -> Schedule {
        let seed = monte_carlo_seed(self.seed, sample);
        let mut targets = ChaCha8Rng::seed_from_u64(seed);
        targets.set_stream(1);
        let n = self.budget.targets.len();
        let horizon = self.grid.horizon();
        let Some(bounds) = &self.budget.limits.assumption2 else {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let most = self.budget.most_intervals(&self.grid).min(8);
            let longest = self.grid.floor(self.budget.longest(horizon)).max(1);
            let count = if most == 0 {
                0
            } else {
                rng.gen_range(1..=most)
            };
            let jams: Vec<Jam> = (0..count)
                .map(|_| Jam {
                    start: rng.gen_range(0..self.grid.steps()),
                    len: rng.gen_range(1..=longest),
                    target: targets.gen_range(0..n),
                })
                .collect();
            return self
                .budget
                .schedule(&self.grid, &self.budget.repair(&self.grid, &jams));
        };
        let s = &self.settings;
        let generated = RandomDos {
            seed,
            min_gap: s.min_gap_s,
            max_gap: s.max_gap_s,
            min_duration: s.min_duration_s,
            max_duration: s.max_duration_s,
        }
        .generate(bounds, horizon)
        .unwrap_or_default();
        let longest = self.budget.longest(horizon);
        let mut total = 0.0;
        let mut jams = Vec::new();
        for iv in generated.intervals() {
            if self
                .budget
                .limits
                .max_intervals
                .is_some_and(|m| jams.len() >= m)
            {
                break;
            }
            let mut d = iv.duration().min(longest);
            if let Some(m) = self.budget.limits.max_jammed_s {
                d = d.min(m - total);
            }
            if d <= 0.0 || self.budget.limits.min_interval_s.is_some_and(|m| d < m) {
                continue;
            }
            total += d;
            jams.push(Jamming {
                start_s: iv.start,
                duration_s: d,
                target: self.budget.targets[targets.gen_range(0..n)],
            });
        }
        Schedule { jams }
    }
}

impl Strategy for RandomSampler {
    fn name(&self) -> &'static str {
        "random"
    }

    fn ask(&mut self, max: usize) -> Vec<Schedule> {
        let mut out = Vec::with_capacity(max);
        // Refused draws are skipped, but not forever.
        let mut tries = 0;
        while out.len() < max && tries < 100 * max.max(1) {
            tries += 1;
            let s = self.draw(self.next);
            self.next += 1;
            if self.budget.certify(&s, self.grid.horizon()).holds {
                out.push(s);
            } else {
                self.rejected += 1;
            }
        }
        out
    }

    fn tell(&mut self, _scores: &[f64]) {}

    fn rejected(&self) -> usize {
        self.rejected
    }
}

/// One jam per schedule on an onset x duration grid (onsets slowest), as the DoS-timing
/// campaign (`[dos_window]`) maps it, on every target: the cells the budget refuses are
/// counted and dropped; of more cells than the evaluations, an evenly spaced subset.
#[derive(Debug, Clone)]
pub struct GridSampler {
    cells: Vec<Schedule>,
    next: usize,
    rejected: usize,
}

impl GridSampler {
    /// The grid of `onsets_s` x `durations_s` x the budget's targets, thinned to at most
    /// `evaluations` cells.
    pub fn new(
        grid: &Grid,
        budget: &Budget,
        onsets_s: &[f64],
        durations_s: &[f64],
        evaluations: usize,
    ) -> Result<Self, SearchError> {
        budget.validate()?;
        let mut cells = Vec::new();
        let mut rejected = 0;
        for &start_s in onsets_s {
            for &duration_s in durations_s {
                for &target in &budget.targets {
                    let s = Schedule {
                        jams: vec![Jamming {
                            start_s,
                            duration_s,
                            target,
                        }],
                    };
                    if budget.certify(&s, grid.horizon()).holds {
                        cells.push(s);
                    } else {
                        rejected += 1;
                    }
                }
            }
        }
        if cells.len() > evaluations {
            let n = cells.len();
            cells = (0..evaluations)
                .map(|i| cells[i * n / evaluations].clone())
                .collect();
        }
        Ok(Self {
            cells,
            next: 0,
            rejected,
        })
    }

    /// The cells it will run.
    pub fn cells(&self) -> usize {
        self.cells.len()
    }
}

impl Strategy for GridSampler {
    fn name(&self) -> &'static str {
        "grid"
    }

    fn ask(&mut self, max: usize) -> Vec<Schedule> {
        let end = (self.next + max).min(self.cells.len());
        let out = self.cells[self.next..end].to_vec();
        self.next = end;
        out
    }

    fn tell(&mut self, _scores: &[f64]) {}

    fn rejected(&self) -> usize {
        self.rejected
    }
}

/// How [`Evolution`] searches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct EvolutionSettings {
    /// Schedules per generation (a batch run in parallel) \[24\].
    #[serde(default = "default_population")]
    pub population: usize,
    /// Differential weight F \[0.6\].
    #[serde(default = "default_f")]
    pub f: f64,
    /// Crossover rate CR \[0.9\].
    #[serde(default = "default_cr")]
    pub cr: f64,
    /// Fraction of the evaluations left to the pattern search around the best \[0.3\].
    #[serde(default = "default_refine")]
    pub refine: f64,
    /// Jam slots per candidate \[the most the budget allows, at most 8\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slots: Option<usize>,
}

fn default_population() -> usize {
    24
}
fn default_f() -> f64 {
    0.6
}
fn default_cr() -> f64 {
    0.9
}
fn default_refine() -> f64 {
    0.3
}

impl Default for EvolutionSettings {
    fn default() -> Self {
        Self {
            population: default_population(),
            f: default_f(),
            cr: default_cr(),
            refine: default_refine(),
            slots: None,
        }
    }
}

impl EvolutionSettings {
    /// Checks the values; errors name the key (`search.population`).
    pub fn validate(&self) -> Result<(), SearchError> {
        if self.population < 4 {
            return Err(SearchError::new(
                "search.population",
                format!(
                    "differential evolution needs at least 4 members (got {})",
                    self.population
                ),
            ));
        }
        if !(self.f.is_finite() && self.f > 0.0 && self.f <= 2.0) {
            return Err(SearchError::new(
                "search.f",
                format!("must be in (0, 2] (got {})", self.f),
            ));
        }
        if !(0.0..=1.0).contains(&self.cr) {
            return Err(SearchError::new(
                "search.cr",
                format!("must be in [0, 1] (got {})", self.cr),
            ));
        }
        if !(0.0..=1.0).contains(&self.refine) {
            return Err(SearchError::new(
                "search.refine",
                format!("must be a fraction in [0, 1] (got {})", self.refine),
            ));
        }
        if self.slots == Some(0) {
            return Err(SearchError::new("search.slots", "must be at least 1"));
        }
        Ok(())
    }
}

/// A member of the population: genes in \[0, 1\], three per slot (onset, length, target).
#[derive(Debug, Clone)]
struct Member {
    genes: Vec<f64>,
    score: f64,
}

/// A proposal waiting for its score.
#[derive(Debug, Clone)]
struct Trial {
    /// The member it challenges (DE), none for the initial population and the pattern search.
    member: Option<usize>,
    genes: Vec<f64>,
    plan: Plan,
    key: Vec<(u64, u64, Target)>,
    score: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Initial,
    Evolve,
    /// Pattern search around the best with moves of `step` steps.
    Refine {
        step: u64,
    },
}

/// The search: differential evolution (DE/current-to-best/1/bin) over a fixed number of jam
/// slots, each three genes in \[0, 1\] (onset, length, target), decoded onto the step grid and
/// repaired into the budget ([`Budget::repair`]), the repaired plan written back into the
/// member (so the population stays admissible). The first generation holds, besides random
/// members, the longest jam the budget allows ending at and starting from each of the leader's
/// manoeuvres (`anchors`: the instants its acceleration changes), and the same jam half
/// shifted. The last `refine` of the evaluations go to a pattern search around the best
/// schedule: every jam's start, end and position moved by `step` steps each way, repaired; the
/// step halves when no move improves, and evolution resumes when it reaches zero. Schedules
/// already run are never run again (their score is remembered). Seeded: the same seed and
/// scores give the same proposals.
#[derive(Debug, Clone)]
pub struct Evolution {
    grid: Grid,
    budget: Budget,
    settings: EvolutionSettings,
    anchors: Vec<f64>,
    evaluations: usize,
    rng: ChaCha8Rng,
    slots: usize,
    /// The longest jam, in steps.
    longest: u64,
    population: Vec<Member>,
    phase: Phase,
    trials: Vec<Trial>,
    /// Indices into `trials` of the schedules asked.
    asked: Vec<usize>,
    cache: HashMap<Vec<(u64, u64, Target)>, f64>,
    best: Option<(Plan, f64)>,
    used: usize,
    rejected: usize,
}

impl Evolution {
    /// A search within `budget` on `grid`, of `evaluations` runs in all (it turns to the
    /// pattern search once `1 - refine` of them are used), from `seed`. `anchors`: the
    /// instants of the leader's manoeuvres (s).
    pub fn new(
        grid: Grid,
        budget: Budget,
        settings: EvolutionSettings,
        anchors: Vec<f64>,
        evaluations: usize,
        seed: u64,
    ) -> Result<Self, SearchError> {
        budget.validate()?;
        settings.validate()?;
        let most = budget.most_intervals(&grid);
        if most == 0 {
            return Err(SearchError::new(
                "budget",
                "admits no jam at all on this run (Assumption 2 with T1 < 1 admits none)",
            ));
        }
        let slots = settings.slots.unwrap_or(most.min(8)).min(most).max(1);
        let longest = grid.floor(budget.longest(grid.horizon())).max(1);
        Ok(Self {
            grid,
            budget,
            settings,
            anchors,
            evaluations,
            rng: ChaCha8Rng::seed_from_u64(seed),
            slots,
            longest,
            population: Vec::new(),
            phase: Phase::Initial,
            trials: Vec::new(),
            asked: Vec::new(),
            cache: HashMap::new(),
            best: None,
            used: 0,
            rejected: 0,
        })
    }

    /// The best plan so far and its score.
    pub fn best(&self) -> Option<(&Plan, f64)> {
        self.best.as_ref().map(|(p, s)| (p, *s))
    }

    fn decode(&self, genes: &[f64]) -> Plan {
        let n = self.budget.targets.len();
        let h = self.grid.steps();
        let jams: Vec<Jam> = genes
            .chunks(3)
            .filter_map(|g| {
                let len = (g[1] * self.longest as f64).round() as u64;
                (len > 0).then(|| Jam {
                    start: ((g[0] * h as f64).floor() as u64).min(h - 1),
                    len,
                    target: ((g[2] * n as f64) as usize).min(n - 1),
                })
            })
            .collect();
        self.budget.repair(&self.grid, &jams)
    }

    /// Genes of `plan` (slot i holds jam i; the slots left empty keep `old`'s onsets).
    fn encode(&self, plan: &Plan, old: &[f64]) -> Vec<f64> {
        let n = self.budget.targets.len() as f64;
        let h = self.grid.steps() as f64;
        let mut genes = old.to_vec();
        for s in 0..self.slots {
            match plan.0.get(s) {
                Some(j) => {
                    genes[3 * s] = (j.start as f64 + 0.5) / h;
                    genes[3 * s + 1] = (j.len as f64 / self.longest as f64).min(1.0);
                    genes[3 * s + 2] = (j.target as f64 + 0.5) / n;
                }
                None => genes[3 * s + 1] = 0.0,
            }
        }
        genes
    }

    fn random_genes(&mut self) -> Vec<f64> {
        let mut g: Vec<f64> = (0..3 * self.slots).map(|_| self.rng.gen()).collect();
        // Fewer jams than slots is as likely as more: each slot active with probability 1/2.
        for s in 0..self.slots {
            if self.rng.gen_bool(0.5) {
                g[3 * s + 1] = 0.0;
            }
        }
        g
    }

    fn trial(&mut self, member: Option<usize>, genes: Vec<f64>, plan: Plan) -> Trial {
        let schedule = self.budget.schedule(&self.grid, &plan);
        let key = schedule.key();
        let genes = self.encode(&plan, &genes);
        let score = self.cache.get(&key).copied();
        Trial {
            member,
            genes,
            plan,
            key,
            score,
        }
    }

    fn initial(&mut self) -> Vec<Trial> {
        let np = self.settings.population;
        let mut trials = Vec::with_capacity(np);
        let mut anchors = self.anchors.clone();
        anchors.sort_by(f64::total_cmp);
        anchors.dedup();
        let longest = self.longest;
        let mut seeded: Vec<Jam> = Vec::new();
        for &a in &anchors {
            let k = self.grid.ceil(a);
            for start in [
                k.saturating_sub(longest),
                k,
                k.saturating_sub(longest / 2),
                k.saturating_sub(longest / 4),
            ] {
                seeded.push(Jam {
                    start,
                    len: longest,
                    target: 0,
                });
            }
        }
        for jam in seeded.into_iter().take(np / 2) {
            let mut genes = self.random_genes();
            for s in 1..self.slots {
                genes[3 * s + 1] = 0.0;
            }
            let mut jam = jam;
            jam.target = ((genes[2] * self.budget.targets.len() as f64) as usize)
                .min(self.budget.targets.len() - 1);
            let plan = self.budget.repair(&self.grid, &[jam]);
            trials.push(self.trial(None, genes, plan));
        }
        while trials.len() < np {
            let genes = self.random_genes();
            let plan = self.decode(&genes);
            trials.push(self.trial(None, genes, plan));
        }
        trials
    }

    fn evolve(&mut self) -> Vec<Trial> {
        let np = self.population.len();
        let best = (0..np)
            .max_by(|&a, &b| {
                self.population[a]
                    .score
                    .total_cmp(&self.population[b].score)
            })
            .unwrap_or(0);
        let dims = 3 * self.slots;
        let (f, cr) = (self.settings.f, self.settings.cr);
        let mut trials = Vec::with_capacity(np);
        for i in 0..np {
            let pick = |rng: &mut ChaCha8Rng, not: &[usize]| loop {
                let r = rng.gen_range(0..np);
                if !not.contains(&r) {
                    break r;
                }
            };
            let r1 = pick(&mut self.rng, &[i]);
            let r2 = pick(&mut self.rng, &[i, r1]);
            let jrand = self.rng.gen_range(0..dims);
            let x = &self.population[i].genes;
            let (xb, x1, x2) = (
                &self.population[best].genes,
                &self.population[r1].genes,
                &self.population[r2].genes,
            );
            let mut genes = x.clone();
            for d in 0..dims {
                if d == jrand || self.rng.gen::<f64>() < cr {
                    let v = x[d] + f * (xb[d] - x[d]) + f * (x1[d] - x2[d]);
                    // Reflected back into [0, 1].
                    let v = if v < 0.0 { -v } else { v };
                    let v = if v > 1.0 { 2.0 - v } else { v };
                    genes[d] = v.clamp(0.0, 1.0);
                }
            }
            let plan = self.decode(&genes);
            trials.push(self.trial(Some(i), genes, plan));
        }
        trials
    }

    fn refine(&mut self, step: u64) -> Vec<Trial> {
        let Some((center, _)) = self.best.clone() else {
            return Vec::new();
        };
        let mut trials = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let s = step as i64;
        for j in 0..center.0.len() {
            for (ds, de) in [(-s, -s), (s, s), (-s, 0), (s, 0), (0, -s), (0, s)] {
                let mut jams = center.0.clone();
                let jam = jams[j];
                let start = (jam.start as i64 + ds).max(0);
                let end = (jam.end() as i64 + de).max(start + 1);
                jams[j] = Jam {
                    start: start as u64,
                    len: (end - start) as u64,
                    target: jam.target,
                };
                let plan = self.budget.repair(&self.grid, &jams);
                if plan != center && seen.insert(plan.clone()) {
                    let genes = self.encode(&plan, &vec![0.5; 3 * self.slots]);
                    trials.push(self.trial(None, genes, plan));
                }
            }
        }
        trials
    }

    /// Records a trial's score and lets it challenge its member.
    fn settle(&mut self, t: &Trial) {
        let score = t.score.unwrap_or(f64::NEG_INFINITY);
        if self.best.as_ref().is_none_or(|(_, b)| score > *b) {
            self.best = Some((t.plan.clone(), score));
        }
        match (self.phase, t.member) {
            (Phase::Initial, _) => self.population.push(Member {
                genes: t.genes.clone(),
                score,
            }),
            (Phase::Evolve, Some(i)) if score >= self.population[i].score => {
                self.population[i] = Member {
                    genes: t.genes.clone(),
                    score,
                };
            }
            _ => {}
        }
    }

    /// Ends the current batch: settles it and picks the next phase.
    fn close(&mut self) {
        let trials = std::mem::take(&mut self.trials);
        let before = self.best.as_ref().map(|(_, s)| *s);
        for t in &trials {
            self.settle(t);
        }
        let improved = self.best.as_ref().map(|(_, s)| *s) > before;
        let refine_from = ((1.0 - self.settings.refine) * self.evaluations as f64).ceil() as usize;
        self.phase = match self.phase {
            Phase::Initial => Phase::Evolve,
            Phase::Evolve if self.used >= refine_from && self.settings.refine > 0.0 => {
                Phase::Refine {
                    step: (self.longest / 8).max(1),
                }
            }
            Phase::Evolve => Phase::Evolve,
            Phase::Refine { step } if improved => Phase::Refine { step },
            Phase::Refine { step } if step > 1 => Phase::Refine { step: step / 2 },
            Phase::Refine { .. } => {
                // Converged around the best: the best joins the population and evolution
                // resumes with what is left.
                if let (Some((plan, score)), Some(worst)) = (
                    self.best.clone(),
                    (0..self.population.len()).min_by(|&a, &b| {
                        self.population[a]
                            .score
                            .total_cmp(&self.population[b].score)
                    }),
                ) {
                    let genes = self.encode(&plan, &self.population[worst].genes.clone());
                    self.population[worst] = Member { genes, score };
                }
                self.settings.refine = 0.0;
                Phase::Evolve
            }
        };
    }
}

impl Strategy for Evolution {
    fn name(&self) -> &'static str {
        "search"
    }

    fn ask(&mut self, max: usize) -> Vec<Schedule> {
        // Batches whose schedules were all run before settle at once; a search that finds
        // nothing new in many batches in a row is done.
        for _ in 0..200 {
            if max == 0 {
                return Vec::new();
            }
            let trials = match self.phase {
                Phase::Initial => self.initial(),
                Phase::Evolve => self.evolve(),
                Phase::Refine { step } => self.refine(step),
            };
            self.trials = trials;
            self.asked.clear();
            let mut out = Vec::new();
            let mut batch: HashMap<Vec<(u64, u64, Target)>, usize> = HashMap::new();
            for i in 0..self.trials.len() {
                if self.trials[i].score.is_some() || batch.contains_key(&self.trials[i].key) {
                    continue;
                }
                if out.len() >= max {
                    // Not run: it cannot win its challenge.
                    self.trials[i].score = Some(f64::NEG_INFINITY);
                    continue;
                }
                let schedule = self.budget.schedule(&self.grid, &self.trials[i].plan);
                if !self.budget.certify(&schedule, self.grid.horizon()).holds {
                    self.rejected += 1;
                    self.trials[i].score = Some(f64::NEG_INFINITY);
                    continue;
                }
                batch.insert(self.trials[i].key.clone(), i);
                self.asked.push(i);
                out.push(schedule);
            }
            if !out.is_empty() {
                return out;
            }
            self.close();
        }
        Vec::new()
    }

    fn tell(&mut self, scores: &[f64]) {
        let asked = std::mem::take(&mut self.asked);
        for (&i, &score) in asked.iter().zip(scores) {
            let score = if score.is_nan() {
                f64::NEG_INFINITY
            } else {
                score
            };
            self.cache.insert(self.trials[i].key.clone(), score);
            self.used += 1;
        }
        // Duplicates within the batch take the score of the one run.
        for t in &mut self.trials {
            if t.score.is_none() {
                t.score = self.cache.get(&t.key).copied();
            }
        }
        self.close();
    }

    fn rejected(&self) -> usize {
        self.rejected
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_attacks::Assumption2;

    const PAPER: Assumption2 = Assumption2::PAPER;

    fn grid() -> Grid {
        Grid::new(0.01, 5500).unwrap()
    }

    /// A stand-in for a run: jammed time on [34, 42) (the braking ramp), a little more
    /// for jamming that ends late in it.
    fn harm(s: &Schedule) -> f64 {
        s.jams
            .iter()
            .map(|j| {
                let (a, b) = (j.start_s.max(34.0), (j.start_s + j.duration_s).min(42.0));
                (b - a).max(0.0) * (1.0 + 0.01 * b)
            })
            .sum()
    }

    fn drive(st: &mut dyn Strategy, evaluations: usize) -> (f64, Vec<Schedule>) {
        let (mut best, mut all, mut used) = (f64::NEG_INFINITY, Vec::new(), 0);
        while used < evaluations {
            let batch = st.ask((evaluations - used).min(24));
            if batch.is_empty() {
                break;
            }
            let scores: Vec<f64> = batch.iter().map(harm).collect();
            used += batch.len();
            best = scores.iter().copied().fold(best, f64::max);
            st.tell(&scores);
            all.extend(batch);
        }
        (best, all)
    }

    #[test]
    fn the_search_finds_the_longest_jam_over_the_ramp_and_repeats_itself() {
        let budget = Budget::assumption2(PAPER);
        let run = |seed| {
            let mut e = Evolution::new(
                grid(),
                budget.clone(),
                EvolutionSettings::default(),
                vec![10.0, 15.0, 35.0, 40.0],
                400,
                seed,
            )
            .unwrap();
            drive(&mut e, 400)
        };
        let (best, all) = run(3);
        // Everything proposed is admissible and nothing is run twice.
        assert!(all.iter().all(|s| budget.certify(s, 55.0).holds));
        let keys: std::collections::HashSet<_> = all.iter().map(Schedule::key).collect();
        assert_eq!(keys.len(), all.len());
        // The most a schedule can score: the longest jam (6.58 s) ending at 42 s.
        let longest = 6.58;
        assert!(best > 0.999 * longest * (1.0 + 0.42), "{best}");
        let (again, all_again) = run(3);
        assert_eq!((best, all.len()), (again, all_again.len()));
        assert_eq!(all, all_again);
    }

    #[test]
    fn random_samples_are_the_campaigns_and_grid_cells_are_admissible() {
        let budget = Budget::assumption2(PAPER);
        let mut r =
            RandomSampler::new(grid(), budget.clone(), RandomSettings::default(), 2024).unwrap();
        let batch = r.ask(5);
        assert_eq!(batch.len(), 5);
        let first = RandomDos {
            seed: monte_carlo_seed(2024, 0),
            min_gap: 1.0,
            max_gap: 12.0,
            min_duration: 0.5,
            max_duration: 3.0,
        }
        .generate(&PAPER, 55.0)
        .unwrap();
        assert_eq!(batch[0].activity().unwrap(), first);
        let onsets: Vec<f64> = (0..=50).map(f64::from).collect();
        let durations: Vec<f64> = (1..=10).map(|k| f64::from(k) / 2.0).collect();
        let g = GridSampler::new(&grid(), &budget, &onsets, &durations, 1000).unwrap();
        assert_eq!(g.cells(), 510);
        let g = GridSampler::new(&grid(), &budget, &onsets, &durations, 100).unwrap();
        assert_eq!(g.cells(), 100);
        let mut tight = budget.clone();
        tight.limits.max_jammed_s = Some(2.0);
        let mut g = GridSampler::new(&grid(), &tight, &onsets, &durations, 1000).unwrap();
        assert_eq!((g.cells(), g.rejected()), (51 * 4, 51 * 6));
        assert!(g.ask(1000).iter().all(|s| tight.certify(s, 55.0).holds));
    }
}
