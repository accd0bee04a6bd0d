//! A Monte Carlo run in a folder, resumable:
//! - `run.json`: what the run is (lens identity, tolerance file, grading, seed, field points); a
//!   folder made for anything else is refused, so a resumed run continues the same trials;
//! - `trials.jsonl`: one line per finished trial, in trial order, appended and synced batch by batch.
//!   A line cut short by a kill is dropped on resume, and the trial redone: trial t depends only on
//!   (seed, t), so the resumed file is byte for byte the uninterrupted one;
//! - `summary.json`: the nominal lens's score, the statistics and yields of every metric.

use crate::error::{ToleranceError, ToleranceResult};
use crate::evaluate::{field_points, score, FieldPoint, Grading, Score};
use crate::perturb::{apply, draw, Change};
use crate::spec::ToleranceSpec;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use unicac_optics::Lens;
use unicac_trace::InvalidParameter;

/// Most trials in one run.
pub const MAX_TRIALS: usize = 100_000;
/// Version of the folder's files.
const FORMAT: u32 = 1;
pub const RUN_FILE: &str = "run.json";
pub const TRIALS_FILE: &str = "trials.jsonl";
pub const SUMMARY_FILE: &str = "summary.json";

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

/// Runs (or resumes) a Monte Carlo run into `folder`, reporting (done, total) after each batch;
/// returns the summary, also written to `summary.json`.
pub fn run_folder(
    nominal: &Lens,
    request: &MonteCarlo,
    folder: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> ToleranceResult<Summary> {
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
    let trials_path = folder.join(TRIALS_FILE);
    let mut done = read_trials(&trials_path)?;
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&trials_path)
        .map_err(ToleranceError::io(&trials_path))?;
    let batch = (2 * rayon::current_num_threads()).max(4);
    progress(done.len().min(trials), trials);
    while done.len() < trials {
        let next = done.len() as u64;
        let end = (done.len() + batch).min(trials) as u64;
        let fresh: Vec<Trial> = (next..end)
            .into_par_iter()
            .map(|t| run_trial(nominal, &record, t))
            .collect();
        let mut lines = String::new();
        for trial in &fresh {
            lines.push_str(&serde_json::to_string(trial).expect("a trial serialises"));
            lines.push('\n');
        }
        file.write_all(lines.as_bytes())
            .and_then(|_| file.sync_data())
            .map_err(ToleranceError::io(&trials_path))?;
        done.extend(fresh);
        progress(done.len(), trials);
    }
    done.truncate(trials);
    let summary = Summary::of(&record, nominal_score, &done);
    let text = serde_json::to_string_pretty(&summary).expect("a summary serialises") + "\n";
    let summary_path = folder.join(SUMMARY_FILE);
    unicac_io::write_atomically(&summary_path, text.as_bytes()).map_err(ToleranceError::io(&summary_path))?;
    Ok(summary)
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
                ("grading settings", existing.grading != record.grading),
                ("seed", existing.seed != record.seed),
                ("field points", existing.field_points != record.field_points),
                ("format", existing.format != record.format),
            ];
            match differs.iter().find(|(_, d)| *d) {
                Some((what, _)) => Err(refuse(format!(
                    "holds a run with another {what}; resume it with the same inputs or choose another folder"
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

/// The finished trials of a folder, in order; a last line cut short is cut off the file.
fn read_trials(path: &Path) -> ToleranceResult<Vec<Trial>> {
    let text = match std::fs::read_to_string(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(ToleranceError::io(path)(e)),
    };
    let mut trials = Vec::new();
    let mut good_bytes = 0;
    for line in text.split_inclusive('\n') {
        let parsed = line
            .strip_suffix('\n')
            .and_then(|l| serde_json::from_str::<Trial>(l).ok())
            .filter(|t| t.trial == trials.len() as u64);
        match parsed {
            Some(trial) => {
                trials.push(trial);
                good_bytes += line.len();
            }
            None => break,
        }
    }
    if good_bytes < text.len() {
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(ToleranceError::io(path))?;
        file.set_len(good_bytes as u64)
            .and_then(|_| file.sync_data())
            .map_err(ToleranceError::io(path))?;
    }
    Ok(trials)
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
        Summary {
            record: record.clone(),
            trials: trials.len(),
            failed: trials.len() - scores.len(),
            nominal,
            statistics,
        }
    }
}

/// The files a run writes into its folder (for the faces' output checks).
pub fn outputs(folder: &Path) -> [PathBuf; 3] {
    [RUN_FILE, TRIALS_FILE, SUMMARY_FILE].map(|name| folder.join(name))
}
