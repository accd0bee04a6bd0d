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
//!   edge OIQE (FID is a set statistic and has no per-lens value, so it is not among those terms); the
//!   same over the learned models alone (`learned_only`) and over each model alone (`per_model`), so
//!   that no single method decides the result ([`predictors`]);
//! - `rank_stability`: each level's ranks with bootstrap intervals over lenses and scenes ([`ranks`]).

pub mod analysis_md;
pub mod as_built;
pub mod folder;
pub mod html;
pub mod predictors;
pub mod ranks;
pub mod tables;
pub mod write;

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use crate::analysis::BOOTSTRAP_RESAMPLES;
use crate::choices::Benchmark;
use crate::op::{overall_performance, OpInputs};
use unicac_learned_metrics::fid::{frechet_distance, Gaussian};

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
    /// The lens's level in each benchmark that grades it.
    pub levels: BTreeMap<Benchmark, u8>,
    pub ode: f64,
    pub rms_radius_um: f64,
}

/// One (model, benchmark, level) row of `results.json`.
#[derive(Debug, Clone, Serialize)]
pub struct ResultRow {
    pub model: String,
    pub benchmark: Benchmark,
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

/// A model's figures over all test pairs, with its rank by O.P. (`None`: no pair was scored, e.g. the
/// model failed on every image, so there is nothing to rank).
#[derive(Debug, Clone, Serialize)]
pub struct OverallRow {
    #[serde(flatten)]
    pub row: ResultRow,
    pub rank: Option<usize>,
}

/// One lens of the analysis.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct LensPoint {
    pub lens_id: String,
    pub ode: f64,
    pub rms_radius_um: f64,
    pub op: f64,
}

/// The per-lens analysis over one set of models: the points and every lens metric's fits
/// ([`predictors::Predictors`], flattened: `r2_ode`, `r2_rms`, `r2_log_rms`, `lenses`, ...).
#[derive(Debug, Clone, Serialize)]
pub struct LensAnalysis {
    /// The models whose mean O.P. the points are.
    pub models: Vec<String>,
    #[serde(flatten)]
    pub predictors: predictors::Predictors,
    pub op_terms: Vec<&'static str>,
    pub points: Vec<LensPoint>,
}

/// `results.json`'s `analysis`: the restoration models together (flattened), the learned models alone,
/// each model alone, and the rank stability per level.
#[derive(Debug, Clone, Serialize)]
pub struct Analysis {
    #[serde(flatten)]
    pub all: LensAnalysis,
    /// 95% percentile bootstrap intervals over lenses (`bootstrap_resamples` resamples, seeded).
    pub bootstrap_resamples: usize,
    /// The same over the learned (ONNX) models only; `None` when none ran.
    pub learned_only: Option<LensAnalysis>,
    /// The same over each restoration model alone.
    pub per_model: BTreeMap<String, LensAnalysis>,
    pub rank_stability: Vec<ranks::LevelRanks>,
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
    fn row(&self, model: &str, benchmark: Benchmark, level: u8, pairs: &[&PairScore]) -> ResultRow {
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
            benchmark,
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
    learned: &[String],
    lenses: &BTreeMap<String, LensInfo>,
    benchmarks: &[Benchmark],
) -> Results {
    let mut rows = Vec::new();
    for model in models {
        let of_model: Vec<&PairScore> = scores.pairs.iter().filter(|p| &p.model == model).collect();
        for &benchmark in benchmarks {
            for level in 1..=LEVELS {
                let pairs: Vec<&PairScore> = of_model
                    .iter()
                    .copied()
                    .filter(|p| lenses.get(&p.lens_id).and_then(|l| l.levels.get(&benchmark)) == Some(&level))
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
                row: scores.row(model, Benchmark::Ode, 0, &pairs),
                rank: None,
            }
        })
        .collect();
    let mut order: Vec<usize> = (0..overall.len()).filter(|&i| overall[i].row.pairs > 0).collect();
    order.sort_by(|&a, &b| {
        let key = |i: usize| overall[i].row.op.unwrap_or(f64::NEG_INFINITY);
        key(b).total_cmp(&key(a))
    });
    for (rank, &i) in order.iter().enumerate() {
        overall[i].rank = Some(rank + 1);
    }
    let analysis = analyse(scores, models, learned, lenses);
    Results {
        rows,
        overall,
        analysis,
    }
}

fn analyse(
    scores: &Scores,
    models: &[String],
    learned: &[String],
    lenses: &BTreeMap<String, LensInfo>,
) -> Analysis {
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
    let learned: Vec<String> = restorers
        .iter()
        .filter(|m| learned.contains(m))
        .cloned()
        .collect();
    Analysis {
        all: lens_analysis(scores, &restorers, lenses),
        bootstrap_resamples: BOOTSTRAP_RESAMPLES,
        learned_only: (!learned.is_empty()).then(|| lens_analysis(scores, &learned, lenses)),
        per_model: restorers
            .iter()
            .map(|m| (m.clone(), lens_analysis(scores, std::slice::from_ref(m), lenses)))
            .collect(),
        rank_stability: ranks::rank_stability(scores, models, lenses),
    }
}

/// Per lens, the mean O.P. of `models`, and every lens metric's fits to it.
fn lens_analysis(scores: &Scores, models: &[String], lenses: &BTreeMap<String, LensInfo>) -> LensAnalysis {
    let mut points = Vec::new();
    let mut terms = Vec::new();
    for (lens_id, lens) in lenses {
        let ops: Vec<f64> = models
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
    LensAnalysis {
        models: models.to_vec(),
        predictors: predictors::Predictors::of(&points),
        op_terms: terms,
        points,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 28 case 10: a method that scored no pair (`--wiener-nsr NaN` made every Wiener image fail)
    /// was ranked 2nd with an empty row. It is not ranked; the others are ranked among themselves.
    #[test]
    fn a_method_without_a_scored_pair_is_not_ranked() {
        let lens = LensInfo {
            lens_id: "l".into(),
            levels: BTreeMap::from([(Benchmark::Ode, 1)]),
            ode: 0.5,
            rms_radius_um: 3.0,
        };
        let score = |model: &str, psnr_db: f64| PairScore {
            model: model.into(),
            pair_id: "p".into(),
            lens_id: "l".into(),
            level: 1,
            psnr_db,
            ssim: 0.9,
            lpips: None,
            clipiqa: None,
            features: None,
        };
        let scores = Scores {
            pairs: vec![score("identity", 30.0), score("model", 32.0)],
            ..Scores::default()
        };
        let models: Vec<String> = ["identity", "wiener", "model"].map(String::from).to_vec();
        let lenses = BTreeMap::from([("l".to_string(), lens)]);
        let results = summarise(
            &scores,
            &models,
            &["model".to_string()],
            &lenses,
            &[Benchmark::Ode],
        );
        let ranks: Vec<(&str, Option<usize>)> = results
            .overall
            .iter()
            .map(|r| (r.row.model.as_str(), r.rank))
            .collect();
        assert_eq!(
            ranks,
            [("identity", Some(2)), ("wiener", None), ("model", Some(1))]
        );
    }
}
