//! The bench's results: per-pair scores in, per-level rows, per-model overall ranks and the per-lens
//! analysis out (`results.json`), with the CSV, tables and pictures of [`write`].
//!
//! Aggregation rules (docs/bench.md):
//! - a row is one (model, benchmark, level): the test pairs whose lens is at that level of the
//!   benchmark (`ode`: `level`, `us`: `us_level`, `uc`: `uc_level` in lenses.jsonl);
//! - PSNR (dB), SSIM, LPIPS and ClipIQA are means over the row's pairs; OIQE is the mean, over the row's
//!   lenses, of each lens's restored-edge OIQE; FID is computed over the row's pairs as one set;
//! - O.P. combines the row's metrics ([`crate::op`]);
//! - `overall` is the same over all test pairs of the `ode` benchmark, ranked by O.P. (1 = best);
//! - the analysis uses, per lens, the mean over the restoration models (every method except
//!   `identity`; `identity` alone when nothing else ran) of the lens's O.P. from its pairs' means and its
//!   edge OIQE (FID is a set statistic and has no per-lens value, so it is not among those terms).

pub mod html;
pub mod tables;
pub mod write;

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use crate::analysis::{bootstrap_ci95, fit_line, spearman, LineFit, BOOTSTRAP_RESAMPLES};
use crate::fid::{frechet_distance, Gaussian};
use crate::op::{overall_performance, OpInputs};

/// The benchmarks: the main ODE levels and the two uniformity sub-benchmarks.
pub const BENCHMARKS: [&str; 3] = ["ode", "us", "uc"];
/// The levels of every benchmark.
pub const LEVELS: u8 = 5;

/// One restored test pair's scores.
#[derive(Debug, Clone, Serialize)]
pub struct PairScore {
    pub model: String,
    pub pair_id: String,
    pub lens_id: String,
    /// The lens's main (ODE) level.
    pub level: u8,
    pub psnr_db: f64,
    pub ssim: f64,
    pub lpips: Option<f64>,
    pub clipiqa: Option<f64>,
    #[serde(skip)]
    pub features: Option<Vec<f32>>,
}

/// What the analysis needs of a lens.
#[derive(Debug, Clone, Serialize)]
pub struct LensInfo {
    pub lens_id: String,
    /// Levels by benchmark: `ode`, `us`, `uc`.
    pub levels: BTreeMap<String, u8>,
    pub ode: f64,
    pub rms_radius_um: f64,
}

/// One (model, benchmark, level) row of `results.json`.
#[derive(Debug, Clone, Serialize)]
pub struct ResultRow {
    pub model: String,
    pub benchmark: String,
    pub level: u8,
    pub pairs: usize,
    pub psnr_db: Option<f64>,
    pub ssim: Option<f64>,
    pub lpips: Option<f64>,
    pub oiqe: Option<f64>,
    pub fid: Option<f64>,
    pub clipiqa: Option<f64>,
    pub op: Option<f64>,
    pub op_terms: Vec<&'static str>,
    pub op_complete: bool,
}

/// A model's figures over all test pairs, with its rank by O.P.
#[derive(Debug, Clone, Serialize)]
pub struct OverallRow {
    #[serde(flatten)]
    pub row: ResultRow,
    pub rank: usize,
}

/// One lens of the analysis.
#[derive(Debug, Clone, Serialize)]
pub struct LensPoint {
    pub lens_id: String,
    pub ode: f64,
    pub rms_radius_um: f64,
    pub op: f64,
}

/// The per-lens fits (`r2_ode`, `r2_rms`, `lenses` are the keys checks read).
#[derive(Debug, Clone, Serialize)]
pub struct Analysis {
    pub r2_ode: Option<f64>,
    pub r2_rms: Option<f64>,
    pub lenses: usize,
    pub fit_ode: Option<LineFit>,
    pub fit_rms: Option<LineFit>,
    /// Spearman's rank correlation of the per-lens mean O.P. with ODE and with the RMS radius.
    pub spearman_ode: Option<f64>,
    pub spearman_rms: Option<f64>,
    /// 95% percentile bootstrap intervals over lenses (`bootstrap_resamples` resamples, seeded).
    pub r2_ode_ci95: Option<[f64; 2]>,
    pub r2_rms_ci95: Option<[f64; 2]>,
    pub spearman_ode_ci95: Option<[f64; 2]>,
    pub spearman_rms_ci95: Option<[f64; 2]>,
    pub bootstrap_resamples: usize,
    /// The models whose mean O.P. the points are.
    pub models: Vec<String>,
    pub op_terms: Vec<&'static str>,
    pub points: Vec<LensPoint>,
}

/// Everything the per-pair stage produced.
#[derive(Debug, Default)]
pub struct Scores {
    pub pairs: Vec<PairScore>,
    /// Ground-truth FID features by pair id.
    pub gt_features: BTreeMap<String, Vec<f32>>,
    /// Restored-edge OIQE by (model, lens id).
    pub oiqe: BTreeMap<(String, String), f64>,
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// Mean of an optional metric: `None` when any pair lacks it (a metric is available for all or none).
fn mean_opt(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let values: Option<Vec<f64>> = values.collect();
    values.and_then(|v| mean(v.into_iter()))
}

impl Scores {
    /// The row of `model` over `pairs`.
    fn row(&self, model: &str, benchmark: &str, level: u8, pairs: &[&PairScore]) -> ResultRow {
        let lenses: BTreeSet<&str> = pairs.iter().map(|p| p.lens_id.as_str()).collect();
        let oiqe = mean_opt(
            lenses
                .iter()
                .map(|l| self.oiqe.get(&(model.to_string(), l.to_string())).copied()),
        );
        let fid = self.fid(pairs);
        let metrics = OpInputs {
            psnr_db: mean(pairs.iter().map(|p| p.psnr_db)),
            ssim: mean(pairs.iter().map(|p| p.ssim)),
            lpips: mean_opt(pairs.iter().map(|p| p.lpips)),
            oiqe,
            fid,
            clipiqa: mean_opt(pairs.iter().map(|p| p.clipiqa)),
        };
        let op = overall_performance(&metrics);
        ResultRow {
            model: model.to_string(),
            benchmark: benchmark.to_string(),
            level,
            pairs: pairs.len(),
            psnr_db: metrics.psnr_db,
            ssim: metrics.ssim,
            lpips: metrics.lpips,
            oiqe: metrics.oiqe,
            fid: metrics.fid,
            clipiqa: metrics.clipiqa,
            op: op.as_ref().map(|o| o.value),
            op_terms: op.as_ref().map(|o| o.terms.clone()).unwrap_or_default(),
            op_complete: op.is_some_and(|o| o.complete),
        }
    }

    fn fid(&self, pairs: &[&PairScore]) -> Option<f64> {
        if pairs.len() < 2 {
            return None;
        }
        let restored: Option<Vec<Vec<f32>>> = pairs.iter().map(|p| p.features.clone()).collect();
        let reference: Option<Vec<Vec<f32>>> = pairs
            .iter()
            .map(|p| self.gt_features.get(&p.pair_id).cloned())
            .collect();
        let (a, b) = (Gaussian::fit(&restored?).ok()?, Gaussian::fit(&reference?).ok()?);
        Some(frechet_distance(&a, &b))
    }
}

/// `results.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Results {
    pub rows: Vec<ResultRow>,
    pub overall: Vec<OverallRow>,
    pub analysis: Analysis,
}

/// Aggregates the scores of `models` (in report order) into rows, overall ranks and the analysis.
pub fn summarise(
    scores: &Scores,
    models: &[String],
    lenses: &BTreeMap<String, LensInfo>,
    benchmarks: &[String],
) -> Results {
    let mut rows = Vec::new();
    for model in models {
        let of_model: Vec<&PairScore> = scores.pairs.iter().filter(|p| &p.model == model).collect();
        for benchmark in benchmarks {
            for level in 1..=LEVELS {
                let pairs: Vec<&PairScore> = of_model
                    .iter()
                    .copied()
                    .filter(|p| lenses.get(&p.lens_id).and_then(|l| l.levels.get(benchmark)) == Some(&level))
                    .collect();
                if !pairs.is_empty() {
                    rows.push(scores.row(model, benchmark, level, &pairs));
                }
            }
        }
    }
    let mut overall: Vec<OverallRow> = models
        .iter()
        .map(|model| {
            let pairs: Vec<&PairScore> = scores.pairs.iter().filter(|p| &p.model == model).collect();
            OverallRow {
                row: scores.row(model, "ode", 0, &pairs),
                rank: 0,
            }
        })
        .collect();
    let mut order: Vec<usize> = (0..overall.len()).collect();
    order.sort_by(|&a, &b| {
        let key = |i: usize| overall[i].row.op.unwrap_or(f64::NEG_INFINITY);
        key(b).total_cmp(&key(a))
    });
    for (rank, &i) in order.iter().enumerate() {
        overall[i].rank = rank + 1;
    }
    let analysis = analyse(scores, models, lenses);
    Results {
        rows,
        overall,
        analysis,
    }
}

fn analyse(scores: &Scores, models: &[String], lenses: &BTreeMap<String, LensInfo>) -> Analysis {
    let restorers: Vec<String> = {
        let others: Vec<String> = models
            .iter()
            .filter(|m| m.as_str() != "identity")
            .cloned()
            .collect();
        if others.is_empty() {
            models.to_vec()
        } else {
            others
        }
    };
    let mut points = Vec::new();
    let mut terms = Vec::new();
    for (lens_id, lens) in lenses {
        let ops: Vec<f64> = restorers
            .iter()
            .filter_map(|model| {
                let pairs: Vec<&PairScore> = scores
                    .pairs
                    .iter()
                    .filter(|p| &p.model == model && &p.lens_id == lens_id)
                    .collect();
                if pairs.is_empty() {
                    return None;
                }
                let op = overall_performance(&OpInputs {
                    psnr_db: mean(pairs.iter().map(|p| p.psnr_db)),
                    ssim: mean(pairs.iter().map(|p| p.ssim)),
                    lpips: mean_opt(pairs.iter().map(|p| p.lpips)),
                    oiqe: scores.oiqe.get(&(model.clone(), lens_id.clone())).copied(),
                    fid: None,
                    clipiqa: mean_opt(pairs.iter().map(|p| p.clipiqa)),
                })?;
                terms = op.terms.clone();
                Some(op.value)
            })
            .collect();
        if let Some(op) = mean(ops.into_iter()) {
            points.push(LensPoint {
                lens_id: lens_id.clone(),
                ode: lens.ode,
                rms_radius_um: lens.rms_radius_um,
                op,
            });
        }
    }
    let by_ode: Vec<(f64, f64)> = points.iter().map(|p| (p.ode, p.op)).collect();
    let by_rms: Vec<(f64, f64)> = points.iter().map(|p| (p.rms_radius_um, p.op)).collect();
    let (fit_ode, fit_rms) = (fit_line(&by_ode), fit_line(&by_rms));
    let r2 = |p: &[(f64, f64)]| fit_line(p).map(|f| f.r2);
    Analysis {
        r2_ode: fit_ode.map(|f| f.r2),
        r2_rms: fit_rms.map(|f| f.r2),
        lenses: points.len(),
        fit_ode,
        fit_rms,
        spearman_ode: spearman(&by_ode),
        spearman_rms: spearman(&by_rms),
        r2_ode_ci95: bootstrap_ci95(&by_ode, r2),
        r2_rms_ci95: bootstrap_ci95(&by_rms, r2),
        spearman_ode_ci95: bootstrap_ci95(&by_ode, spearman),
        spearman_rms_ci95: bootstrap_ci95(&by_rms, spearman),
        bootstrap_resamples: BOOTSTRAP_RESAMPLES,
        models: restorers,
        op_terms: terms,
        points,
    }
}
