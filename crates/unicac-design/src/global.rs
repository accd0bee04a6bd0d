//! The global stage: a population search in the normalised variables, after OptiFusion (GA + simulated
//! annealing + gradient refinement), with exact-gradient damped least squares in place of its
//! finite-difference Adam. Each generation:
//! 1. simulated annealing: every individual takes a few Metropolis steps (temperature relative to its
//!    merit, cooling within the generation) and keeps its best point;
//! 2. selection with diversity: the best individuals, each at least `diversity` away (normalised
//!    distance) from those already chosen, become parents;
//! 3. local refinement of the parents (a few damped-least-squares iterations);
//! 4. the archive keeps the best distinct designs seen (this is what one run returns: many, not one);
//! 5. the next population: the parents, plus children by uniform crossover of two parents and mutation
//!    (genes resampled; glass genes jump to a random catalogue glass).
//!
//! Random numbers come from a counter-based generator keyed by (seed, generation, individual), so a
//! run's result does not depend on thread scheduling: same seed, same designs.

use crate::budget::Budget;
use crate::local::{refine, Gradient, LocalSettings};
use crate::merit::{design_glasses, Merit};
use crate::params::{distance, Parameterization, Target};
use rayon::prelude::*;
use unicac_trace::pupil::{counter_hash, unit_interval};

/// A counter-based random stream.
#[derive(Debug, Clone)]
pub struct Rng {
    key: u64,
    counter: u64,
}

impl Rng {
    pub fn new(seed: u64, stream: u64) -> Rng {
        Rng {
            key: counter_hash(seed, stream),
            counter: 0,
        }
    }

    pub fn uniform(&mut self) -> f64 {
        self.counter += 1;
        unit_interval(counter_hash(self.key, self.counter))
    }

    pub fn below(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }
}

#[derive(Debug, Clone)]
pub struct GlobalSettings {
    pub population: usize,
    pub generations: usize,
    pub annealing_steps: usize,
    pub parents: usize,
    /// Smallest normalised distance between parents (and between archived designs, halved).
    pub diversity: f64,
    pub local_iterations: usize,
    pub gradient: Gradient,
    pub archive: usize,
    pub seed: u64,
    /// Checked before each generation; the evaluations counted are this search's own.
    pub budget: Budget,
}

impl GlobalSettings {
    pub fn new(seed: u64) -> Self {
        GlobalSettings {
            population: 48,
            generations: 12,
            annealing_steps: 12,
            parents: 8,
            diversity: 0.12,
            local_iterations: 8,
            gradient: Gradient::Exact,
            archive: 32,
            seed,
            budget: Budget::UNLIMITED,
        }
    }
}

#[derive(Debug, Clone)]
pub struct Candidate {
    pub x: Vec<f64>,
    pub merit: f64,
}

/// What a search found and spent.
#[derive(Debug, Clone)]
pub struct Search {
    /// The best distinct designs seen, best first.
    pub archive: Vec<Candidate>,
    /// Merit evaluations spent (the unit of `crate::budget`).
    pub evaluations: u64,
}

/// What the search reports after each generation.
#[derive(Debug, Clone, Copy)]
pub struct GlobalProgress {
    pub generation: usize,
    pub best_merit: f64,
    pub archived: usize,
}

/// Normalised (nd, Vd) genes of the catalogue glasses, for initialisation and glass mutation.
fn glass_genes(params: &Parameterization) -> Vec<[f64; 2]> {
    let nd = params
        .variables
        .iter()
        .find(|v| matches!(v.target, Target::Nd(_)));
    let vd = params
        .variables
        .iter()
        .find(|v| matches!(v.target, Target::Vd(_)));
    match (nd, vd) {
        (Some(nd), Some(vd)) => design_glasses()
            .iter()
            .filter_map(|g| Some([nd.normalise(g.nd?), vd.normalise(g.vd?)]))
            .collect(),
        _ => Vec::new(),
    }
}

/// A gene's fresh random value: curvatures near the middle, gaps in the thinner part of their range,
/// defocus at zero.
fn random_gene(target: Target, rng: &mut Rng) -> f64 {
    match target {
        Target::Curvature(_) => 0.2 + 0.6 * rng.uniform(),
        Target::Thickness(_) => 0.3 * rng.uniform(),
        Target::Defocus => 0.5,
        _ => rng.uniform(),
    }
}

fn set_glass(x: &mut [f64], params: &Parameterization, surface: usize, glass: [f64; 2]) {
    for (xi, v) in x.iter_mut().zip(&params.variables) {
        match v.target {
            Target::Nd(i) if i == surface => *xi = glass[0],
            Target::Vd(i) if i == surface => *xi = glass[1],
            _ => {}
        }
    }
}

fn random_design(params: &Parameterization, glasses: &[[f64; 2]], rng: &mut Rng) -> Vec<f64> {
    let mut x: Vec<f64> = params
        .variables
        .iter()
        .map(|v| random_gene(v.target, rng))
        .collect();
    for v in &params.variables {
        if let Target::Nd(i) = v.target {
            if !glasses.is_empty() {
                set_glass(&mut x, params, i, glasses[rng.below(glasses.len())]);
            }
        }
    }
    x
}

fn evaluate(merit: &Merit, params: &Parameterization, x: Vec<f64>) -> Candidate {
    let value = merit.value(params, &x).unwrap_or(f64::INFINITY);
    Candidate {
        x,
        merit: if value.is_finite() { value } else { f64::INFINITY },
    }
}

/// Metropolis steps from `start`; returns the best point visited.
fn anneal(
    merit: &Merit,
    params: &Parameterization,
    start: Candidate,
    steps: usize,
    rng: &mut Rng,
) -> Candidate {
    let mut current = start;
    let mut best = current.clone();
    let n = params.len();
    for k in 0..steps {
        let mut x = current.x.clone();
        let genes = 1 + rng.below(3);
        for _ in 0..genes {
            let j = rng.below(n);
            x[j] = (x[j] + 0.1 * (rng.uniform() - 0.5)).clamp(0.0, 1.0);
        }
        let candidate = evaluate(merit, params, x);
        let temperature = 0.05 * current.merit.min(1e9) * (1.0 - k as f64 / steps as f64) + 1e-12;
        let accept = candidate.merit < current.merit
            || (candidate.merit.is_finite()
                && rng.uniform() < (-(candidate.merit - current.merit) / temperature).exp());
        if accept {
            current = candidate;
            if current.merit < best.merit {
                best = current.clone();
            }
        }
    }
    best
}

/// Greedy diverse selection of up to `count` of `sorted` (ascending merit).
fn select_diverse(sorted: &[Candidate], count: usize, diversity: f64) -> Vec<Candidate> {
    let mut chosen: Vec<Candidate> = Vec::new();
    for c in sorted.iter().filter(|c| c.merit.is_finite()) {
        if chosen.len() == count {
            break;
        }
        if chosen.iter().all(|p| distance(&p.x, &c.x) >= diversity) {
            chosen.push(c.clone());
        }
    }
    chosen
}

/// Inserts into the archive, keeping it sorted, distinct (a better near-duplicate replaces the worse)
/// and at most `size` long.
fn archive_insert(archive: &mut Vec<Candidate>, c: Candidate, diversity: f64, size: usize) {
    if !c.merit.is_finite() {
        return;
    }
    if let Some(k) = archive.iter().position(|a| distance(&a.x, &c.x) < diversity) {
        if c.merit < archive[k].merit {
            archive[k] = c;
        }
    } else {
        archive.push(c);
    }
    archive.sort_by(|a, b| a.merit.total_cmp(&b.merit));
    archive.truncate(size);
}

/// Runs the search until its generations are done or its budget is spent (checked between
/// generations, so an evaluation budget stops it at the same point on any machine).
pub fn search(
    merit: &Merit,
    params: &Parameterization,
    settings: &GlobalSettings,
    progress: &(dyn Fn(GlobalProgress) + Sync),
) -> Search {
    let glasses = glass_genes(params);
    let mut evaluations = settings.population as u64;
    let mut population: Vec<Candidate> = (0..settings.population)
        .into_par_iter()
        .map(|i| {
            let mut rng = Rng::new(settings.seed, i as u64);
            evaluate(merit, params, random_design(params, &glasses, &mut rng))
        })
        .collect();
    let mut archive: Vec<Candidate> = Vec::new();
    let local = LocalSettings {
        deadline: settings.budget.deadline,
        ..LocalSettings::new(settings.local_iterations, settings.gradient)
    };
    for generation in 0..settings.generations {
        if settings.budget.spent(evaluations) {
            break;
        }
        let stream = |i: usize| ((generation as u64 + 1) << 32) + i as u64;
        population = population
            .into_par_iter()
            .enumerate()
            .map(|(i, c)| {
                let mut rng = Rng::new(settings.seed, stream(i));
                anneal(merit, params, c, settings.annealing_steps, &mut rng)
            })
            .collect();
        evaluations += (population.len() * settings.annealing_steps) as u64;
        population.sort_by(|a, b| a.merit.total_cmp(&b.merit));
        let refined: Vec<(Candidate, usize)> =
            select_diverse(&population, settings.parents, settings.diversity)
                .into_par_iter()
                .map(|c| {
                    let refined = refine(merit, params, &c.x, &local, |_| {});
                    let candidate = Candidate {
                        x: refined.x,
                        merit: refined.merit,
                    };
                    (candidate, refined.evaluations)
                })
                .collect();
        evaluations += refined.iter().map(|(_, n)| *n as u64).sum::<u64>();
        let parents: Vec<Candidate> = refined.into_iter().map(|(c, _)| c).collect();
        for p in &parents {
            archive_insert(
                &mut archive,
                p.clone(),
                settings.diversity / 2.0,
                settings.archive,
            );
        }
        progress(GlobalProgress {
            generation,
            best_merit: archive.first().map_or(f64::INFINITY, |c| c.merit),
            archived: archive.len(),
        });
        if parents.is_empty() {
            // Nothing traced: start again from fresh random designs.
            population = (0..settings.population)
                .into_par_iter()
                .map(|i| {
                    let mut rng = Rng::new(settings.seed, stream(i) + (1 << 31));
                    evaluate(merit, params, random_design(params, &glasses, &mut rng))
                })
                .collect();
            evaluations += settings.population as u64;
            continue;
        }
        let children = settings.population.saturating_sub(parents.len());
        let mut next: Vec<Candidate> = (0..children)
            .into_par_iter()
            .map(|i| {
                let mut rng = Rng::new(settings.seed, stream(i) + (1 << 30));
                let a = &parents[rng.below(parents.len())];
                let b = &parents[rng.below(parents.len())];
                let mut x: Vec<f64> =
                    a.x.iter()
                        .zip(&b.x)
                        .map(|(u, v)| if rng.uniform() < 0.5 { *u } else { *v })
                        .collect();
                // Crossover keeps an element's (nd, Vd) pair together.
                for (j, v) in params.variables.iter().enumerate() {
                    if let Target::Vd(i) = v.target {
                        let nd_index = params.variables.iter().position(|w| w.target == Target::Nd(i));
                        if let Some(k) = nd_index {
                            let from_a = (x[k] - a.x[k]).abs() < 1e-15;
                            x[j] = if from_a { a.x[j] } else { b.x[j] };
                        }
                    }
                }
                let mutations = 1 + rng.below(2);
                for _ in 0..mutations {
                    let j = rng.below(params.len());
                    match params.variables[j].target {
                        Target::Nd(s) | Target::Vd(s) if !glasses.is_empty() => {
                            set_glass(&mut x, params, s, glasses[rng.below(glasses.len())])
                        }
                        target => x[j] = random_gene(target, &mut rng),
                    }
                }
                evaluate(merit, params, x)
            })
            .collect();
        evaluations += next.len() as u64;
        next.extend(parents);
        population = next;
    }
    Search { archive, evaluations }
}
