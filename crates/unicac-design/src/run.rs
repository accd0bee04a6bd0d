//! One specification (or a grid of them) from search to library, within a budget (`crate::budget`).
//!
//! Per spec: the global stage (a share of the budget) fills an archive of distinct candidates, saved as a
//! checkpoint; each candidate is then finished in merit order (full refinement with the fine merit,
//! glass snapping and re-optimisation, then the aspheric stage if asked), verified, and written as soon
//! as it is accepted. With budget left and too few lenses, another search round runs with a new seed
//! stream. At the budget, work stops between steps and everything accepted so far is on disk. An
//! evaluation budget stops only between global generations and between finished candidates (in merit
//! order, as if finished one at a time), so its library does not depend on the machine or the threads.
//!
//! Rounds alternate their starting forms: even rounds search the spec itself, odd rounds of a spec
//! faster than F/4 start from F/4 solutions and open the aperture (`curriculum`). With a budget, a
//! search whose best design is still poor (mean RMS spot radius above [`GOOD_RMS_AIRY_RADII`] Airy
//! radii) never counts as converged: it restarts until the budget ends. A good one converges after
//! [`IDLE_ROUNDS_TO_CONVERGE`] rounds without a better design.

use crate::asphere::asphericize;
use crate::budget::Budget;
use crate::curriculum;
use crate::error::{DesignError, Result};
use crate::export::to_lens_spec;
use crate::glass_snap::snap;
use crate::global::{search, GlobalProgress, GlobalSettings, Search};
use crate::library::{Checkpoint, Entry, Library, RoundRecord};
use crate::local::{refine, Gradient, LocalSettings};
use crate::merit::{Merit, Sampling, Terms};
use crate::params::Parameterization;
use crate::spec::DesignSpec;
use crate::system::Prescription;
use crate::verify::{verify, Verification};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// An aspheric child is written only if its merit is at least this fraction below its parent's (and
/// its RMS spot smaller): an asphere that buys nothing is not a new lens.
pub const MIN_ASPHERE_GAIN: f64 = 0.005;

/// Search rounds in a row that must bring no better design before a full set of `count` counts as
/// converged (each round is a new global search with its own seed stream).
pub const IDLE_ROUNDS_TO_CONVERGE: usize = 2;

/// A design is good when its mean RMS spot radius is at most this many Airy radii (1.22 lambda N at the
/// primary wavelength: 14 um at F/2, 29 um at F/4): a budgeted search converges only once its best
/// design is good, and otherwise keeps restarting until the budget ends.
pub const GOOD_RMS_AIRY_RADII: f64 = 10.0;

/// The mean RMS spot radius (um) below which a design of `spec` is good ([`GOOD_RMS_AIRY_RADII`]).
pub fn good_rms_um(spec: &DesignSpec) -> f64 {
    let wavelength_um = spec.wavelengths_um[spec.primary_wavelength_index];
    GOOD_RMS_AIRY_RADII * 1.22 * wavelength_um * spec.f_number
}

#[derive(Debug, Clone)]
pub struct RunSettings {
    /// Lenses kept per spec (spherical ones; with `aspheric`, each also gets its asphere): the `count`
    /// best distinct designs found (smallest mean RMS spot radius), or with `first_acceptable` the first
    /// `count` acceptable ones.
    pub count: usize,
    /// Stop at the first `count` acceptable designs (fast) instead of keeping the best within the budget.
    pub first_acceptable: bool,
    pub seed: u64,
    /// Wall-clock budget for the whole run (all specs), seconds.
    pub time_budget_s: Option<f64>,
    /// Merit evaluations each spec may spend (`crate::budget`: reproducible where time is not).
    pub evaluations_per_spec: Option<u64>,
    pub gradient: Gradient,
    /// Accept only lenses with a mean RMS spot radius at most this (um).
    pub max_rms_um: Option<f64>,
    /// Share of a spec's budget given to the global stage of a round.
    pub global_share: f64,
    pub refine_iterations: usize,
    /// Search rounds per spec at most (each with a fresh seed stream).
    pub rounds: usize,
    /// Odd rounds of a spec faster than F/4 start from F/4 solutions (`curriculum`); off, every round
    /// searches the spec itself (the ablation).
    pub curriculum: bool,
    pub global: GlobalSettings,
}

/// Most lenses kept per spec (`count`): every kept design is compared with each new one.
pub const MAX_COUNT: usize = 1000;
/// Longest time budget (s): one year. Beyond it a deadline is not representable on every platform
/// (`Instant` plus a huge `Duration` overflows), and no run is meant to last longer.
pub const MAX_TIME_BUDGET_S: f64 = 365.0 * 86_400.0;
/// Most merit evaluations per spec: 10^12, months of a core (a 6-element merit value takes ~0.3 ms).
pub const MAX_EVALUATIONS_PER_SPEC: u64 = 1_000_000_000_000;
/// Largest `max_rms_um` (um): 10 mm, larger than any image it could bound.
pub const MAX_RMS_LIMIT_UM: f64 = 10_000.0;

impl RunSettings {
    /// Checks every setting a caller gives; errors name the field.
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_COUNT).contains(&self.count) {
            return Err(DesignError::spec(
                "count",
                format!("{} must lie in [1, {MAX_COUNT}]", self.count),
            ));
        }
        if let Some(t) = self.time_budget_s {
            if !(t > 0.0 && t <= MAX_TIME_BUDGET_S) {
                return Err(DesignError::spec(
                    "time_budget_s",
                    format!("{t:?} must lie in (0, {MAX_TIME_BUDGET_S}] s (one year, MAX_TIME_BUDGET_S)"),
                ));
            }
        }
        if let Some(n) = self.evaluations_per_spec {
            if !(1..=MAX_EVALUATIONS_PER_SPEC).contains(&n) {
                return Err(DesignError::spec(
                    "evaluations_per_spec",
                    format!("{n} must lie in [1, {MAX_EVALUATIONS_PER_SPEC}] (MAX_EVALUATIONS_PER_SPEC)"),
                ));
            }
        }
        if let Some(m) = self.max_rms_um {
            if !(m > 0.0 && m <= MAX_RMS_LIMIT_UM) {
                return Err(DesignError::spec(
                    "max_rms_um",
                    format!("{m:?} must lie in (0, {MAX_RMS_LIMIT_UM}] um"),
                ));
            }
        }
        if !(self.global_share > 0.0 && self.global_share < 1.0) {
            return Err(DesignError::spec(
                "global_share",
                format!("{} must lie in (0, 1)", self.global_share),
            ));
        }
        Ok(())
    }

    pub fn new(count: usize, seed: u64) -> Self {
        RunSettings {
            count,
            first_acceptable: false,
            seed,
            time_budget_s: None,
            evaluations_per_spec: None,
            gradient: Gradient::Exact,
            max_rms_um: None,
            global_share: 0.6,
            refine_iterations: 60,
            rounds: 3,
            curriculum: true,
            global: GlobalSettings::new(seed),
        }
    }
}

/// What a run reports as it goes.
#[derive(Debug, Clone)]
pub enum Event {
    SpecStarted {
        slug: String,
        index: usize,
        total: usize,
    },
    Generation {
        slug: String,
        progress: GlobalProgress,
    },
    Accepted {
        slug: String,
        id: String,
        aspheric: bool,
        rms_mean_um: f64,
    },
    Rejected {
        slug: String,
        reasons: Vec<String>,
    },
    /// A kept design dropped for a better one (`count` best are kept).
    Replaced {
        slug: String,
        id: String,
        rms_mean_um: f64,
    },
    SpecDone {
        slug: String,
        accepted: usize,
    },
    /// Something the user should know that lost nothing (a layout plot not drawn).
    Note {
        slug: String,
        message: String,
    },
}

/// One finished design (before acceptance).
#[derive(Debug, Clone)]
pub struct Finished {
    pub prescription: Prescription<f64>,
    pub terms: Terms,
    pub verification: Verification,
    pub lens: unicac_optics::LensSpec,
    pub aspheric: bool,
}

impl Finished {
    pub fn acceptable(&self, max_rms_um: Option<f64>) -> bool {
        self.terms.feasible()
            && self.verification.passed
            && max_rms_um.is_none_or(|m| self.verification.rms_mean_um <= m)
    }

    /// Every reason this design is not acceptable, by name.
    pub fn rejection_reasons(&self, max_rms_um: Option<f64>) -> Vec<String> {
        let mut reasons: Vec<String> = self
            .terms
            .violations()
            .map(|c| format!("{}: {:.4} (limit {})", c.name, c.value, c.limit))
            .collect();
        reasons.extend(self.verification.failures.iter().cloned());
        if let Some(m) = max_rms_um {
            if self.verification.rms_mean_um > m {
                reasons.push(format!("rms_mean_um: {:.2} > {m}", self.verification.rms_mean_um));
            }
        }
        reasons
    }
}

fn finished(
    merit: &Merit,
    params: &Parameterization,
    x: &[f64],
    aspheric: bool,
    name: &str,
) -> Option<Finished> {
    let prescription = crate::system::values(&params.decode(x)?);
    let terms = merit.evaluate(&prescription).terms;
    let lens = to_lens_spec(
        &prescription,
        &merit.spec,
        &terms.semi_diameters_mm,
        name,
        "unicac design (crates/unicac-design)",
    );
    let verification = verify(
        &lens,
        merit.spec.focal_length_mm,
        merit.spec.constraints.focal_tolerance,
    );
    Some(Finished {
        prescription,
        terms,
        verification,
        lens,
        aspheric,
    })
}

/// A spherical design and, when made, its aspheric child.
pub type FinishedPair = (Finished, Option<Finished>);

/// A finished candidate: its designs (none when a stage failed) and the merit evaluations spent.
#[derive(Debug, Clone)]
pub struct FinishOutcome {
    pub designs: Option<FinishedPair>,
    pub evaluations: u64,
}

/// Finishes one candidate of the spherical stage: refinement with the fine merit, glass snapping and
/// re-optimisation, and (if the spec asks) the aspheric stage. Returns the spherical design and, if
/// made, its aspheric child, with the evaluations spent.
pub fn finish_candidate(
    spec: &DesignSpec,
    x: &[f64],
    settings: &RunSettings,
    deadline: Option<Instant>,
) -> FinishOutcome {
    let mut evaluations = 0;
    let designs = finish_counted(spec, x, settings, deadline, &mut evaluations);
    FinishOutcome { designs, evaluations }
}

fn finish_counted(
    spec: &DesignSpec,
    x: &[f64],
    settings: &RunSettings,
    deadline: Option<Instant>,
    evaluations: &mut u64,
) -> Option<FinishedPair> {
    let mut merit = Merit::new(spec, Sampling::FINE);
    let params = Parameterization::spherical(spec);
    let local = LocalSettings {
        deadline,
        ..LocalSettings::new(settings.refine_iterations, settings.gradient)
    };
    let refined = refine(&merit, &params, x, &local, |_| {});
    *evaluations += refined.evaluations as u64;
    let (snapped, x) = snap(&params, &refined.x)?;
    let x = refine_within_limits(&mut merit, &snapped, &x, &local, evaluations);
    *evaluations += 1;
    let spherical = finished(&merit, &snapped, &x, false, &spec.slug())?;
    if !spec.aspheric {
        return Some((spherical, None));
    }
    let (aspheric_params, x) = asphericize(
        &snapped,
        &x,
        &spherical.terms.semi_diameters_mm,
        spec.constraints.asphere_departure_max_mm,
    )?;
    let x = refine_within_limits(&mut merit, &aspheric_params, &x, &local, evaluations);
    *evaluations += 1;
    let aspheric = finished(&merit, &aspheric_params, &x, true, &spec.slug())?;
    Some((spherical, Some(aspheric)))
}

/// Refines, and while limits are still violated (beyond their tolerances) raises the penalty weights
/// tenfold and refines again, at most twice. The merit keeps the raised weights, so a parent and its
/// aspheric child are compared on the same merit. Adds the merit evaluations spent to `evaluations`.
fn refine_within_limits(
    merit: &mut Merit,
    params: &Parameterization,
    x: &[f64],
    local: &LocalSettings,
    evaluations: &mut u64,
) -> Vec<f64> {
    let refined = refine(merit, params, x, local, |_| {});
    *evaluations += refined.evaluations as u64;
    let mut x = refined.x;
    for _ in 0..2 {
        *evaluations += 1;
        let feasible = params
            .decode(&x)
            .is_some_and(|p| merit.evaluate(&p).terms.checks.iter().all(|c| c.met));
        if feasible {
            break;
        }
        merit.penalty_scale *= 10.0;
        let refined = refine(merit, params, &x, local, |_| {});
        *evaluations += refined.evaluations as u64;
        x = refined.x;
    }
    x
}

/// Why the work on a spec stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// `first_acceptable`: the first `count` acceptable designs were found.
    CountReached,
    /// The best `count` designs did not change for `IDLE_ROUNDS_TO_CONVERGE` search rounds (with a
    /// budget: and the best of them is good, [`good_rms_um`]).
    Converged,
    /// The time budget ran out.
    Budget,
    /// The spec's evaluation budget (`RunSettings::evaluations_per_spec`) was spent.
    EvaluationBudget,
    /// The search rounds (`RunSettings::rounds`, without a budget) were used up.
    RoundsDone,
    /// An earlier run of this spec with this seed into the same library had finished: nothing was redone.
    AlreadyDone,
}

/// Summary of one spec.
#[derive(Debug, Clone)]
pub struct SpecSummary {
    pub slug: String,
    pub accepted: usize,
    pub first_accepted_s: Option<f64>,
    pub elapsed_s: f64,
    pub stop_reason: StopReason,
    /// Search rounds run (global search and finishing of its candidates).
    pub rounds: usize,
    /// The best kept spherical design's mean RMS spot radius (um), and the bar of a good one
    /// ([`good_rms_um`]).
    pub best_rms_mean_um: Option<f64>,
    pub good_rms_um: f64,
    /// Merit evaluations this run spent on the spec (a resumed run's count includes the killed one's).
    pub evaluations: u64,
}

/// Designs `spec` into `library`: keeps the `settings.count` best distinct acceptable designs until the
/// search converges, the rounds are used up, `deadline` passes or the spec's evaluations are spent
/// (with `first_acceptable`: stops at the first `count` acceptable ones).
pub fn run_spec(
    spec: &DesignSpec,
    settings: &RunSettings,
    library: &mut Library,
    deadline: Option<Instant>,
    events: &(dyn Fn(Event) + Sync),
) -> Result<SpecSummary> {
    spec.validate()?;
    settings.validate()?;
    let start = Instant::now();
    let slug = spec.slug();
    let accepted_now = |library: &Library| library.rows_for(&slug).filter(|r| !r.aspheric).count();
    // The best kept spherical design's (mean RMS spot radius, merit).
    let best_design = |library: &Library| {
        library
            .rows_for(&slug)
            .filter(|r| !r.aspheric)
            .map(|r| (r.rms_mean_um, r.merit))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let mut first_accepted_s = None;
    let checkpoint_path = library.checkpoint_path(&slug);
    let mut checkpoint = Checkpoint::load(&checkpoint_path)?.filter(|c| c.seed == settings.seed);
    let done_before = checkpoint
        .as_ref()
        .and_then(|c| c.done_count)
        .is_some_and(|done| settings.count <= done);
    // A killed run resumes where it was (evaluations spent, rounds without a better design, whether
    // the unfinished round had improved), so it ends as the uninterrupted run would; a run after a
    // finished one starts these anew.
    let resumed = checkpoint.as_ref().filter(|c| c.done_count.is_none());
    let mut used = resumed.map_or(0, |c| c.evaluations_used);
    let mut idle_rounds = resumed.map_or(0, |c| c.idle_rounds);
    let mut improved_before_kill = resumed.is_some_and(|c| c.improved);
    if let Some(c) = checkpoint.as_mut() {
        c.done_count = None;
    }
    let mut round = checkpoint.as_ref().map_or(0, |c| c.round);
    let budget = Budget {
        deadline,
        evaluations: settings.evaluations_per_spec,
    };
    let out_of_time = || budget.out_of_time();
    let enough = |library: &Library| settings.first_acceptable && accepted_now(library) >= settings.count;
    let mut converged = false;
    let first_round = round;
    // Keeping the best, each run gets its own rounds (a resumed run with a larger count searches anew);
    // first-acceptable runs count rounds from the start, as they always did.
    let round_limit = if settings.first_acceptable {
        settings.rounds
    } else {
        first_round.saturating_add(settings.rounds)
    };
    while !done_before && !enough(library) && round < round_limit && !budget.spent(used) && !converged {
        let mut improved = std::mem::take(&mut improved_before_kill);
        // The global stage of this round, unless a checkpoint of it exists.
        let state = match checkpoint.take().filter(|c| c.round == round) {
            Some(state) => state,
            None => {
                let coarse = Merit::new(spec, Sampling::COARSE);
                let params = Parameterization::spherical(spec);
                let global = GlobalSettings {
                    seed: settings.seed.wrapping_add(round as u64 * 0x9E37_79B9),
                    budget: budget.share_of_rest(used, settings.global_share),
                    gradient: settings.gradient,
                    ..settings.global.clone()
                };
                let report = |progress: GlobalProgress| {
                    events(Event::Generation {
                        slug: slug.clone(),
                        progress,
                    })
                };
                let found = round_archive(spec, settings, round, &coarse, &params, &global, &report);
                used += found.evaluations;
                let state = Checkpoint {
                    slug: slug.clone(),
                    seed: settings.seed,
                    round,
                    merits: found.archive.iter().map(|c| c.merit).collect(),
                    candidates: found.archive.into_iter().map(|c| c.x).collect(),
                    finished: Vec::new(),
                    done_count: None,
                    evaluations_used: used,
                    idle_rounds,
                    improved: false,
                };
                state.save(&checkpoint_path)?;
                state
            }
        };
        let mut state = state;
        // Finish candidates two at a time (one per core), best first, writing each accepted lens at once.
        let pending: Vec<usize> = (0..state.candidates.len())
            .filter(|i| !state.finished.contains(i))
            .collect();
        for batch in pending.chunks(rayon::current_num_threads().max(1)) {
            if enough(library) || budget.spent(used) {
                break;
            }
            let results: Vec<(usize, FinishOutcome)> = batch
                .par_iter()
                .map(|&i| {
                    (
                        i,
                        finish_candidate(spec, &state.candidates[i], settings, deadline),
                    )
                })
                .collect();
            for (i, outcome) in results {
                // As if finished one at a time: a candidate after the evaluations ran out never
                // started (its work is dropped, and a resumed run does not redo it).
                if budget.evaluations_spent(used) {
                    break;
                }
                used += outcome.evaluations;
                let result = outcome.designs;
                if out_of_time() && result.is_none() {
                    continue;
                }
                if let Some((spherical, aspheric)) = result {
                    if !enough(library) {
                        let written = accept(
                            spec,
                            settings,
                            library,
                            &spherical,
                            aspheric.as_ref(),
                            start,
                            events,
                        )?;
                        improved |= written;
                        if written && first_accepted_s.is_none() {
                            first_accepted_s = Some(start.elapsed().as_secs_f64());
                        }
                    }
                }
                state.finished.push(i);
            }
            state.evaluations_used = used;
            state.improved = improved;
            state.save(&checkpoint_path)?;
        }
        if state.finished.len() == state.candidates.len() {
            let (kept, best) = (accepted_now(library), best_design(library));
            library.log_round(
                &slug,
                &RoundRecord {
                    seed: settings.seed,
                    round,
                    elapsed_s: start.elapsed().as_secs_f64(),
                    curriculum: uses_curriculum(spec, settings, round),
                    kept,
                    best_rms_mean_um: best.map(|(rms, _)| rms),
                    best_merit: best.map(|(_, merit)| merit),
                    evaluations: used,
                },
            )?;
            round += 1;
            checkpoint = None;
            // A full round that changed nothing in a full set of the best designs: one step towards
            // convergence.
            let full = kept >= settings.count;
            idle_rounds = if full && !improved { idle_rounds + 1 } else { 0 };
            // With a budget, a poor best design is not a converged search: restart until time is up.
            let good = best.is_some_and(|(rms, _)| rms <= good_rms_um(spec));
            converged = idle_rounds >= IDLE_ROUNDS_TO_CONVERGE && (!budget.is_limited() || good);
        } else {
            checkpoint = Some(state);
        }
    }
    let stop_reason = if done_before {
        StopReason::AlreadyDone
    } else if enough(library) {
        StopReason::CountReached
    } else if converged {
        StopReason::Converged
    } else if out_of_time() {
        StopReason::Budget
    } else if budget.spent(used) {
        StopReason::EvaluationBudget
    } else {
        StopReason::RoundsDone
    };
    if !done_before {
        // Mark the last saved search state (the unfinished round, else the last finished one) as done
        // for this count, so that a rerun of the same job is a no-op and a larger count resumes from it.
        let last = match checkpoint {
            Some(state) => Some(state),
            None => Checkpoint::load(&checkpoint_path)?.filter(|c| c.seed == settings.seed),
        };
        if let Some(mut finished) = last {
            finished.done_count = Some(settings.count);
            finished.save(&checkpoint_path)?;
        }
    }
    let accepted = accepted_now(library);
    events(Event::SpecDone {
        slug: slug.clone(),
        accepted,
    });
    let best_rms_mean_um = best_design(library).map(|(rms, _)| rms);
    Ok(SpecSummary {
        slug,
        accepted,
        first_accepted_s,
        elapsed_s: start.elapsed().as_secs_f64(),
        stop_reason,
        rounds: round - first_round,
        best_rms_mean_um,
        good_rms_um: good_rms_um(spec),
        evaluations: used,
    })
}

/// Whether `round` starts from slower-aperture designs: odd rounds of a spec faster than F/4, with
/// `settings.curriculum`.
fn uses_curriculum(spec: &DesignSpec, settings: &RunSettings, round: usize) -> bool {
    settings.curriculum && round % 2 == 1 && curriculum::applies_to(spec)
}

/// The global stage's archive for `round`: the spec searched itself, or, in odd rounds of a spec
/// faster than F/4 (with `settings.curriculum`), designs found at F/4 and walked to the spec's aperture.
fn round_archive(
    spec: &DesignSpec,
    settings: &RunSettings,
    round: usize,
    coarse: &Merit,
    params: &Parameterization,
    global: &GlobalSettings,
    report: &(dyn Fn(GlobalProgress) + Sync),
) -> Search {
    let from_slower = uses_curriculum(spec, settings, round)
        .then(|| {
            let local = LocalSettings {
                deadline: global.budget.deadline,
                ..LocalSettings::new(settings.refine_iterations / 2, settings.gradient)
            };
            curriculum::search_from_slower_aperture(spec, global, &local, report)
        })
        .flatten();
    from_slower.unwrap_or_else(|| search(coarse, params, global, report))
}

/// Writes the spherical design (and its aspheric child, if it improves on it and passes) when acceptable,
/// new and, once `count` designs are kept, better (smaller mean RMS spot radius) than the worst kept one,
/// which it then replaces. Returns whether the spherical design was written.
fn accept(
    spec: &DesignSpec,
    settings: &RunSettings,
    library: &mut Library,
    spherical: &Finished,
    aspheric: Option<&Finished>,
    start: Instant,
    events: &(dyn Fn(Event) + Sync),
) -> Result<bool> {
    let slug = spec.slug();
    if !spherical.acceptable(settings.max_rms_um) {
        events(Event::Rejected {
            slug,
            reasons: spherical.rejection_reasons(settings.max_rms_um),
        });
        return Ok(false);
    }
    let rms = spherical.verification.rms_mean_um;
    if library.is_duplicate(&slug, false, rms, spherical.terms.total_track_mm) {
        return Ok(false);
    }
    let kept: Vec<(f64, String)> = library
        .rows_for(&slug)
        .filter(|r| !r.aspheric)
        .map(|r| (r.rms_mean_um, r.id.clone()))
        .collect();
    let worst = kept
        .iter()
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .filter(|_| kept.len() >= settings.count)
        .cloned();
    if let Some((worst_rms, _)) = &worst {
        if rms >= *worst_rms {
            events(Event::Rejected {
                slug,
                reasons: vec![format!(
                    "rms_mean_um: {rms:.3} is no better than the {} kept designs (worst {worst_rms:.3})",
                    settings.count
                )],
            });
            return Ok(false);
        }
    }
    let elapsed_s = start.elapsed().as_secs_f64();
    let id = library.add(&entry(spec, settings.seed, elapsed_s, spherical, None, None))?;
    forward_notes(library, &slug, events);
    events(Event::Accepted {
        slug: slug.clone(),
        id: id.clone(),
        aspheric: false,
        rms_mean_um: rms,
    });
    if let Some((worst_rms, worst_id)) = worst {
        library.remove(&worst_id)?;
        events(Event::Replaced {
            slug: slug.clone(),
            id: worst_id,
            rms_mean_um: worst_rms,
        });
    }
    if let Some(a) = aspheric {
        let improves = a.terms.merit < spherical.terms.merit * (1.0 - MIN_ASPHERE_GAIN)
            && a.verification.rms_mean_um < rms;
        if a.acceptable(settings.max_rms_um) && improves {
            let child = library.add(&entry(spec, settings.seed, elapsed_s, a, Some(id), Some(rms)))?;
            forward_notes(library, &slug, events);
            events(Event::Accepted {
                slug,
                id: child,
                aspheric: true,
                rms_mean_um: a.verification.rms_mean_um,
            });
        } else {
            let mut reasons = a.rejection_reasons(settings.max_rms_um);
            if !improves {
                reasons.push("aspheric: no gain over the spherical parent".into());
            }
            events(Event::Rejected { slug, reasons });
        }
    }
    Ok(true)
}

fn entry<'a>(
    spec: &'a DesignSpec,
    seed: u64,
    elapsed_s: f64,
    f: &'a Finished,
    parent: Option<String>,
    parent_rms_mean_um: Option<f64>,
) -> Entry<'a> {
    Entry {
        spec,
        aspheric: f.aspheric,
        parent,
        parent_rms_mean_um,
        lens: &f.lens,
        terms: &f.terms,
        verification: &f.verification,
        seed,
        elapsed_s,
    }
}

/// Hands the library's notes to the caller as events (libraries do not print).
fn forward_notes(library: &mut Library, slug: &str, events: &(dyn Fn(Event) + Sync)) {
    for message in library.take_notes() {
        events(Event::Note {
            slug: slug.to_string(),
            message,
        });
    }
}

/// Runs several specs, splitting the remaining budget evenly over the specs still to do.
pub fn run_specs(
    specs: &[DesignSpec],
    settings: &RunSettings,
    library: &mut Library,
    events: &(dyn Fn(Event) + Sync),
) -> Result<Vec<SpecSummary>> {
    settings.validate()?;
    for spec in specs {
        spec.validate()?;
    }
    let start = Instant::now();
    let end = settings.time_budget_s.map(|s| start + Duration::from_secs_f64(s));
    let mut summaries = Vec::new();
    for (index, spec) in specs.iter().enumerate() {
        if end.is_some_and(|e| Instant::now() >= e) {
            break;
        }
        events(Event::SpecStarted {
            slug: spec.slug(),
            index,
            total: specs.len(),
        });
        let deadline = end.map(|e| {
            let left = e.saturating_duration_since(Instant::now());
            Instant::now() + left.div_f64((specs.len() - index) as f64)
        });
        summaries.push(run_spec(spec, settings, library, deadline, events)?);
    }
    Ok(summaries)
}
