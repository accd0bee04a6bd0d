//! A search for a fast aperture that starts from a slower one's solutions (a curriculum, as designers
//! open the aperture of a working lens step by step rather than start an F/2 design from nothing).
//!
//! The global search runs on the same specification at F/[`CURRICULUM_START_F_NUMBER`], where random
//! starts find well-corrected forms far more often; each archived design is then refined at every rung
//! of a ladder of apertures, each at most [`MAX_RUNG_RATIO`] faster than the last, ending at the
//! target F/#. The design variables do not depend on the F/# (curvature bounds follow the focal
//! length, gaps the constraints, the glass genes the catalogue), so a design carries across rungs as
//! its normalised vector.

use crate::global::{search, Candidate, GlobalProgress, GlobalSettings, Search};
use crate::local::{refine, LocalSettings};
use crate::merit::{Merit, Sampling};
use crate::params::Parameterization;
use crate::spec::DesignSpec;
use rayon::prelude::*;

/// The aperture a curriculum starts from: the slowest of the specification grid (F/2, 3, 4).
pub const CURRICULUM_START_F_NUMBER: f64 = 4.0;

/// Largest ratio of F/#s between two rungs of the ladder: half a stop (sqrt 2), so that each rung's
/// refinement starts inside the basin of the last.
pub const MAX_RUNG_RATIO: f64 = std::f64::consts::SQRT_2;

/// Whether `spec` is faster than the curriculum's start.
pub fn applies_to(spec: &DesignSpec) -> bool {
    spec.f_number < CURRICULUM_START_F_NUMBER
}

/// The F/#s from [`CURRICULUM_START_F_NUMBER`] to `target` (both included), equal steps in log F/#,
/// none larger than [`MAX_RUNG_RATIO`]. Only `target` when it is already at least the start.
pub fn aperture_ladder(target: f64) -> Vec<f64> {
    let start = CURRICULUM_START_F_NUMBER;
    if target >= start {
        return vec![target];
    }
    let steps = ((start / target).ln() / MAX_RUNG_RATIO.ln()).ceil().max(1.0) as usize;
    (0..=steps)
        .map(|k| {
            if k == steps {
                target
            } else {
                start * (target / start).powf(k as f64 / steps as f64)
            }
        })
        .collect()
}

/// `spec` at another F/#, everything else equal.
fn at_f_number(spec: &DesignSpec, f_number: f64) -> DesignSpec {
    DesignSpec {
        f_number,
        ..spec.clone()
    }
}

/// The global search's archive for `spec`, found by the curriculum: searched at the ladder's first
/// F/#, each design refined at every later rung (`local` iterations per rung, coarse merit), then
/// evaluated with `spec`'s coarse merit, best first, with the evaluations spent (the walk's included).
/// `None` when the slower spec's variables differ from `spec`'s (no curriculum applies).
pub fn search_from_slower_aperture(
    spec: &DesignSpec,
    global: &GlobalSettings,
    local: &LocalSettings,
    progress: &(dyn Fn(GlobalProgress) + Sync),
) -> Option<Search> {
    // The ladder ends at `spec`'s own F/#: its last rung is `spec`.
    let specs: Vec<DesignSpec> = aperture_ladder(spec.f_number)
        .into_iter()
        .map(|f| at_f_number(spec, f))
        .collect();
    let params: Vec<Parameterization> = specs.iter().map(Parameterization::spherical).collect();
    let merits: Vec<Merit> = specs.iter().map(|s| Merit::new(s, Sampling::COARSE)).collect();
    let (target_params, target_merit) = (params.last()?, merits.last()?);
    if params.iter().any(|p| p.len() != target_params.len()) {
        return None;
    }
    let slower = search(&merits[0], &params[0], global, progress);
    let walks: Vec<(Option<Candidate>, u64)> = slower
        .archive
        .into_par_iter()
        .map(|candidate| {
            let mut x = candidate.x;
            let mut evaluations = 1;
            for (merit, params) in merits.iter().zip(&params).skip(1) {
                let refined = refine(merit, params, &x, local, |_| {});
                evaluations += refined.evaluations as u64;
                x = refined.x;
            }
            let merit = target_merit.value(target_params, &x).filter(|v| v.is_finite());
            (merit.map(|merit| Candidate { x, merit }), evaluations)
        })
        .collect();
    let evaluations = slower.evaluations + walks.iter().map(|(_, n)| n).sum::<u64>();
    let mut archive: Vec<Candidate> = walks.into_iter().filter_map(|(c, _)| c).collect();
    archive.sort_by(|a, b| a.merit.total_cmp(&b.merit));
    Some(Search { archive, evaluations })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ladder_opens_the_aperture_in_steps_of_at_most_half_a_stop() {
        assert_eq!(aperture_ladder(4.0), vec![4.0]);
        assert_eq!(aperture_ladder(5.6), vec![5.6]);
        for target in [2.0, 2.8, 3.0, 1.4] {
            let ladder = aperture_ladder(target);
            assert_eq!(ladder[0], CURRICULUM_START_F_NUMBER);
            assert_eq!(*ladder.last().unwrap(), target);
            for pair in ladder.windows(2) {
                assert!(pair[1] < pair[0], "{ladder:?}");
                assert!(pair[0] / pair[1] <= MAX_RUNG_RATIO * (1.0 + 1e-12), "{ladder:?}");
            }
        }
        assert_eq!(aperture_ladder(2.0).len(), 3, "F/4, F/2.83, F/2");
    }
}
