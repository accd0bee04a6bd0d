//! A Monte Carlo run in a folder, resumable and shardable:
//! - `run.json`: what the run is (lens identity, tolerance file, grading, seed, field points); a
//!   folder made for anything else is refused, so a resumed run continues the same trials;
//! - `trials/NNNNNN.jsonl`: chunk c holds trials 64 c .. 64 c + 63 (fewer in the last), one JSON line
//!   each, written atomically when the chunk is done. Trial t depends only on (seed, t), so a killed
//!   run redoes only missing chunks and ends with the bytes of an uninterrupted one, and shard I of N
//!   (chunks c with c mod N = I - 1) can run anywhere that sees the folder;
//! - `summary.json`: the nominal lens's score, the statistics and yields of every metric, written by
//!   the unsharded run once every chunk is there.

use crate::error::{ToleranceError, ToleranceResult};
use crate::evaluate::{field_points, score, FieldPoint, Grading, Score};
use crate::perturb::{apply, draw, Change};
use crate::spec::ToleranceSpec;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use unicac_io::Shard;
use unicac_optics::Lens;
use unicac_trace::InvalidParameter;

/// Most trials in one run.
pub const MAX_TRIALS: usize = 100_000;
/// Version of the folder's files.
const FORMAT: u32 = 1;
pub const RUN_FILE: &str = "run.json";
pub const TRIALS_DIR: &str = "trials";
pub const SUMMARY_FILE: &str = "summary.json";
/// Trials per chunk file: the unit of resumption and of sharding (part of the folder format).
pub const CHUNK_TRIALS: usize = 64;

/// What a run is: the same record means the same trials.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub format: u32,
    /// The caller's identity of the lens (the hash of its file, or its builtin name).
    pub lens: String,
    pub spec: ToleranceSpec,
    pub grading: Grading,
    pub seed: u64,
    pub field_points: Vec<FieldPoint>,
}

/// One built unit: its errors and its score, or why it could not be graded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trial {
    pub trial: u64,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub score: Option<Score>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub failure: Option<String>,
    pub changes: Vec<Change>,
}

/// Trial `trial` of the run: drawn, built and graded.
pub fn run_trial(nominal: &Lens, record: &RunRecord, trial: u64) -> Trial {
    let changes = draw(nominal, &record.spec, record.seed, trial);
    let built = apply(nominal, &changes);
    let graded = score(
        &built,
        &record.field_points,
        &record.grading,
        record.spec.compensator,
    );
    Trial {
        trial,
        failure: graded.as_ref().err().map(ToString::to_string),
        score: graded.ok(),
        changes,
    }
}

/// The lens of built unit `trial` as it was graded: its drawn errors applied and the compensator's
/// image shift in place (what `--write-units` writes as a lens file).
pub fn unit_lens(nominal: &Lens, request: &MonteCarlo, trial: u64) -> ToleranceResult<Lens> {
    Ok(built_unit(nominal, request, trial)?.lens)
}

/// One built unit: its drawn errors, the lens as graded and its score.
pub struct BuiltUnit {
    pub changes: Vec<Change>,
    /// The errors applied and the compensator's image shift in place.
    pub lens: Lens,
    pub score: Score,
}

/// Unit `trial` of `request`, drawn, built, graded and refocused.
pub fn built_unit(nominal: &Lens, request: &MonteCarlo, trial: u64) -> ToleranceResult<BuiltUnit> {
    let changes = draw(nominal, &request.spec, request.seed, trial);
    let built = apply(nominal, &changes);
    let score = score(
        &built,
        &field_points(nominal)?,
        &request.grading,
        request.spec.compensator,
    )?;
    let lens = unicac_analysis::refocused(&built, score.focus_shift_mm);
    Ok(BuiltUnit { changes, lens, score })
}

/// `built_unit` focused as its design is: the compensator moves the image by the unit's best-focus
/// shift minus the design's own (`focus_shift_mm` is that difference), so a unit sits where its design
/// sits relative to best focus and differs from it by its errors alone, not by a refocus the design
/// never had (a lens file is not always at the compensator's best focus).
pub fn built_unit_at_design_focus(
    nominal: &Lens,
    request: &MonteCarlo,
    trial: u64,
) -> ToleranceResult<BuiltUnit> {
    let design = score(
        nominal,
        &field_points(nominal)?,
        &request.grading,
        request.spec.compensator,
    )?;
    let mut unit = built_unit(nominal, request, trial)?;
    unit.lens = unicac_analysis::refocused(&unit.lens, -design.focus_shift_mm);
    unit.score.focus_shift_mm -= design.focus_shift_mm;
    Ok(unit)
}

/// What to run: the same request on the same folder continues the same trials.
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarlo {
    /// The caller's identity of the lens (the hash of its file, or its builtin name).
    pub lens_identity: String,
    pub spec: ToleranceSpec,
    pub grading: Grading,
    pub seed: u64,
    /// Trials wanted (at most [`MAX_TRIALS`]); more than a finished folder holds adds trials.
    pub trials: usize,
}

/// Runs (or resumes) `shard`'s part of a Monte Carlo run in `folder`, reporting the shard's trials
/// done after each chunk (one stage, "trials"). The unsharded run (`Shard::ALL`) returns the summary, also written
/// to `summary.json`; a shard returns None (the summary needs every shard's chunks).
pub fn run_folder(
    nominal: &Lens,
    request: &MonteCarlo,
    folder: &Path,
    shard: Shard,
    progress: &dyn unicac_io::progress::Progress,
) -> ToleranceResult<Option<Summary>> {
    let MonteCarlo {
        lens_identity,
        spec,
        grading,
        seed,
        trials,
    } = request;
    let (seed, trials) = (*seed, *trials);
    spec.check()?;
    grading.check()?;
    if !(1..=MAX_TRIALS).contains(&trials) {
        return Err(InvalidParameter::new(
            "trials",
            format!("{trials}: need 1 to {MAX_TRIALS} (MAX_TRIALS)"),
        )
        .into());
    }
    let record = RunRecord {
        format: FORMAT,
        lens: lens_identity.clone(),
        spec: spec.clone(),
        grading: grading.clone(),
        seed,
        field_points: field_points(nominal)?,
    };
    // The nominal lens first: a lens that cannot be graded stops the run before any trial.
    let nominal_score = score(nominal, &record.field_points, grading, spec.compensator)?;
    if folder.exists() && !folder.is_dir() {
        return Err(ToleranceError::Folder {
            folder: folder.to_path_buf(),
            reason: "is a file; the run needs a folder".into(),
        });
    }
    std::fs::create_dir_all(folder).map_err(ToleranceError::io(folder))?;
    adopt_record(folder, &record)?;
    let chunks_dir = folder.join(TRIALS_DIR);
    std::fs::create_dir_all(&chunks_dir).map_err(ToleranceError::io(&chunks_dir))?;
    // A killed writer's half-written chunk (its temporary) goes; a live shard's stays.
    unicac_io::clean_stale_temporaries(&chunks_dir).map_err(ToleranceError::io(&chunks_dir))?;
    let mine: Vec<usize> = (0..trials.div_ceil(CHUNK_TRIALS))
        .filter(|&c| shard.owns(c))
        .collect();
    let total: usize = mine.iter().map(|&c| chunk_range(c, trials).count()).sum();
    progress.stage("trials", total);
    // The unsharded run owns every chunk, in order: it keeps them for the summary as it goes.
    let mut all = Vec::with_capacity(if shard.is_all() { trials } else { 0 });
    for &c in &mine {
        let range = chunk_range(c, trials);
        let chunk = match read_chunk(folder, c, trials)? {
            Some(found) => found,
            None => {
                let fresh: Vec<Trial> = range
                    .clone()
                    .into_par_iter()
                    .map(|t| run_trial(nominal, &record, t as u64))
                    .collect();
                let mut lines = String::new();
                for trial in &fresh {
                    lines.push_str(&serde_json::to_string(trial).expect("a trial serialises"));
                    lines.push('\n');
                }
                let path = chunk_path(folder, c);
                unicac_io::write_atomically(&path, lines.as_bytes()).map_err(ToleranceError::io(&path))?;
                fresh
            }
        };
        if shard.is_all() {
            all.extend(chunk);
        }
        progress.advance(range.len());
    }
    if !shard.is_all() {
        return Ok(None);
    }
    let summary = Summary::of(&record, nominal_score, &all);
    let text = serde_json::to_string_pretty(&summary).expect("a summary serialises") + "\n";
    let summary_path = folder.join(SUMMARY_FILE);
    unicac_io::write_atomically(&summary_path, text.as_bytes()).map_err(ToleranceError::io(&summary_path))?;
    Ok(Some(summary))
}

/// The trials of chunk `chunk` of a run of `trials` trials.
fn chunk_range(chunk: usize, trials: usize) -> std::ops::Range<usize> {
    chunk * CHUNK_TRIALS..((chunk + 1) * CHUNK_TRIALS).min(trials)
}

fn chunk_path(folder: &Path, chunk: usize) -> PathBuf {
    folder.join(TRIALS_DIR).join(format!("{chunk:06}.jsonl"))
}

/// Chunk `chunk`'s trials when its file holds exactly them (a chunk written for a smaller run, or
/// damaged, is None: made again).
fn read_chunk(folder: &Path, chunk: usize, trials: usize) -> ToleranceResult<Option<Vec<Trial>>> {
    let path = chunk_path(folder, chunk);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(ToleranceError::io(&path)(e)),
    };
    let expected = chunk_range(chunk, trials);
    let parsed: Option<Vec<Trial>> = text
        .split_terminator('\n')
        .map(|line| serde_json::from_str::<Trial>(line).ok())
        .collect();
    Ok(parsed.filter(|found| {
        text.ends_with('\n')
            && found.len() == expected.len()
            && found
                .iter()
                .zip(expected.clone())
                .all(|(t, k)| t.trial == k as u64)
    }))
}

/// Writes `run.json`, or checks that the folder's is this run's.
fn adopt_record(folder: &Path, record: &RunRecord) -> ToleranceResult<()> {
    let path = folder.join(RUN_FILE);
    let refuse = |reason: String| ToleranceError::Folder {
        folder: folder.to_path_buf(),
        reason,
    };
    match std::fs::read_to_string(&path) {
        Ok(text) => {
            let existing: RunRecord = serde_json::from_str(&text).map_err(|e| {
                refuse(format!(
                    "{RUN_FILE} is not a tolerancing run's ({e}); choose another folder"
                ))
            })?;
            let differs = [
                ("lens", existing.lens != record.lens),
                ("tolerance file", existing.spec != record.spec),
                (
                    "grading (pupil grid, MTF frequencies, ODE)",
                    existing.grading != record.grading,
                ),
                ("seed", existing.seed != record.seed),
                ("field points", existing.field_points != record.field_points),
                ("format", existing.format != record.format),
            ];
            match differs.iter().find(|(_, d)| *d) {
                Some((what, _)) => Err(refuse(format!(
                    "holds a run with a different {what}; resume it with the same inputs or choose another folder"
                ))),
                None => Ok(()),
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if std::fs::read_dir(folder)
                .map_err(ToleranceError::io(folder))?
                .next()
                .is_some()
            {
                return Err(refuse(
                    "is not empty and holds no tolerancing run; choose an empty or new folder".into(),
                ));
            }
            let text = serde_json::to_string_pretty(record).expect("a record serialises") + "\n";
            unicac_io::write_atomically(&path, text.as_bytes()).map_err(ToleranceError::io(&path))
        }
        Err(e) => Err(ToleranceError::io(&path)(e)),
    }
}

/// Whether a metric is better low (spot radii) or high (MTF).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Better {
    Lower,
    Higher,
}

/// One metric over the graded trials.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Statistic {
    pub metric: String,
    pub better: Better,
    pub nominal: f64,
    pub mean: f64,
    pub std: f64,
    /// The value met by 50, 80, 90 and 98% of units (the worse tail: for a lower-is-better metric the
    /// 50th, 80th, 90th and 98th percentiles).
    pub met_by_50: f64,
    pub met_by_80: f64,
    pub met_by_90: f64,
    pub met_by_98: f64,
    /// Every graded trial's value, best first: the yield curve (the k-th value is met by (k + 1) / n
    /// of the units).
    pub yield_curve: Vec<f64>,
}

impl Statistic {
    fn of(metric: String, better: Better, nominal: f64, values: &[f64]) -> Statistic {
        let mut sorted: Vec<f64> = values.to_vec();
        sorted.sort_by(|a, b| a.total_cmp(b));
        if better == Better::Higher {
            sorted.reverse();
        }
        let n = sorted.len().max(1) as f64;
        let mean = values.iter().sum::<f64>() / n;
        let std = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
        // The value met by fraction q: the ceil(q n)-th best (nearest rank).
        let met_by = |q: f64| {
            let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len().max(1));
            sorted.get(rank - 1).copied().unwrap_or(f64::NAN)
        };
        Statistic {
            metric,
            better,
            nominal,
            mean,
            std,
            met_by_50: met_by(0.5),
            met_by_80: met_by(0.8),
            met_by_90: met_by(0.9),
            met_by_98: met_by(0.98),
            yield_curve: sorted,
        }
    }
}

/// The run's outcome (`summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub record: RunRecord,
    pub trials: usize,
    /// Trials that could not be graded (no ray of a field arrived, ...): counted as failing every
    /// yield.
    pub failed: usize,
    pub nominal: Score,
    pub statistics: Vec<Statistic>,
}

impl Summary {
    fn of(record: &RunRecord, nominal: Score, trials: &[Trial]) -> Summary {
        let scores: Vec<&Score> = trials.iter().filter_map(|t| t.score.as_ref()).collect();
        let column = |f: &dyn Fn(&Score) -> f64| scores.iter().map(|s| f(s)).collect::<Vec<f64>>();
        let mut statistics = vec![
            Statistic::of(
                "rms_mean_um".into(),
                Better::Lower,
                nominal.rms_mean_um,
                &column(&|s| s.rms_mean_um),
            ),
            Statistic::of(
                "rms_max_um".into(),
                Better::Lower,
                nominal.rms_max_um,
                &column(&|s| s.rms_max_um),
            ),
            Statistic::of(
                "boresight_um".into(),
                Better::Lower,
                nominal.boresight_um,
                &column(&|s| s.boresight_um),
            ),
            Statistic::of(
                "focus_shift_abs_mm".into(),
                Better::Lower,
                nominal.focus_shift_mm.abs(),
                &column(&|s| s.focus_shift_mm.abs()),
            ),
        ];
        for (k, f) in record.grading.mtf_frequencies_cy_mm.iter().enumerate() {
            statistics.push(Statistic::of(
                format!("mtf_min_at_{f}_cy_mm"),
                Better::Higher,
                nominal.mtf_min[k],
                &column(&|s| s.mtf_min[k]),
            ));
        }
        if let Some(nominal_ode) = nominal.ode {
            statistics.push(Statistic::of(
                "ode".into(),
                Better::Higher,
                nominal_ode,
                &column(&|s| s.ode.unwrap_or(f64::NAN)),
            ));
        }
        Summary {
            record: record.clone(),
            trials: trials.len(),
            failed: trials.len() - scores.len(),
            nominal,
            statistics,
        }
    }
}

/// The files and folder a run writes into its folder (for the faces' output checks).
pub fn outputs(folder: &Path) -> [PathBuf; 3] {
    [RUN_FILE, TRIALS_DIR, SUMMARY_FILE].map(|name| folder.join(name))
}
