//! Which differences between models at a level are real: the models' O.P. ranks at each `ode` level
//! recomputed on bootstrap resamples of the level's lenses and, within each drawn lens, of its test
//! scenes (the same draws for every model, so the comparison is paired). A rank that holds in most
//! resamples is a finding; one that changes often is within the noise of the test set.
//!
//! The resampled O.P. combines the per-pair metrics (PSNR, SSIM, LPIPS, ClipIQA) and the per-lens
//! restored-edge OIQE; FID, a statistic of a whole set of images, is left out of every resample and so
//! also of the point ranks given here (they can differ from `overall`'s when FID is available).

use std::collections::BTreeMap;

use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use serde::Serialize;

use super::{LensInfo, PairScore, Scores};
use crate::analysis::BOOTSTRAP_SEED;
use crate::choices::Benchmark;
use crate::op::{overall_performance, OpInputs};

/// Resamples of the rank bootstrap (seeded): a share is known to about +-0.016 (one standard error at
/// share 0.5).
pub const RANK_RESAMPLES: usize = 1000;

/// One model's rank at a level and how stable it is.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RankStability {
    pub model: String,
    /// O.P. without FID over the level's pairs.
    pub op: f64,
    /// Rank by that O.P. (1 = best).
    pub rank: usize,
    /// The 2.5% and 97.5% percentiles of the rank over the resamples.
    pub rank_ci95: [usize; 2],
    /// The share of resamples in which the model takes `rank`.
    pub rank_share: f64,
    /// The share of resamples in which it ranks first.
    pub best_share: f64,
}

/// The ranks at one `ode` level.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct LevelRanks {
    pub level: u8,
    pub lenses: usize,
    pub pairs: usize,
    pub resamples: usize,
    pub models: Vec<RankStability>,
}

/// Running sums of one model's per-pair metrics over a resample.
#[derive(Default, Clone)]
struct Sums {
    n: usize,
    psnr_db: f64,
    ssim: f64,
    lpips: Option<f64>,
    clipiqa: Option<f64>,
    oiqe: Option<f64>,
    oiqe_n: usize,
}

fn add(total: Option<f64>, v: Option<f64>, first: bool) -> Option<f64> {
    // An optional metric counts only when every pair has it (as in the rows' means).
    match (total, v) {
        (Some(t), Some(v)) => Some(t + v),
        (None, Some(v)) if first => Some(v),
        _ => None,
    }
}

impl Sums {
    fn pair(&mut self, p: &PairScore) {
        let first = self.n == 0;
        self.psnr_db += p.psnr_db;
        self.ssim += p.ssim;
        self.lpips = add(self.lpips, p.lpips, first);
        self.clipiqa = add(self.clipiqa, p.clipiqa, first);
        self.n += 1;
    }

    fn lens_oiqe(&mut self, v: Option<f64>) {
        self.oiqe = add(self.oiqe, v, self.oiqe_n == 0);
        self.oiqe_n += 1;
    }

    fn op(&self) -> Option<f64> {
        if self.n == 0 {
            return None;
        }
        let n = self.n as f64;
        let per_pair = |v: Option<f64>| v.map(|s| s / n);
        overall_performance(&OpInputs {
            psnr_db: Some(self.psnr_db / n),
            ssim: Some(self.ssim / n),
            lpips: per_pair(self.lpips),
            oiqe: self.oiqe.map(|s| s / self.oiqe_n.max(1) as f64),
            fid: None,
            clipiqa: per_pair(self.clipiqa),
        })
        .map(|o| o.value)
    }
}

/// 1 + the number of strictly better values (ties share the better rank); `None` values rank last.
fn ranks_of(ops: &[Option<f64>]) -> Vec<usize> {
    ops.iter()
        .map(|v| {
            let v = v.unwrap_or(f64::NEG_INFINITY);
            1 + ops.iter().filter(|w| w.unwrap_or(f64::NEG_INFINITY) > v).count()
        })
        .collect()
}

/// The O.P. of each model over `draws` (lens index, pair ids drawn for it).
fn ops_over(
    models: &[String],
    by_model: &[BTreeMap<&str, &PairScore>],
    scores: &Scores,
    lens_ids: &[&str],
    draws: &[(usize, Vec<&str>)],
) -> Vec<Option<f64>> {
    models
        .iter()
        .zip(by_model)
        .map(|(model, pairs)| {
            let mut sums = Sums::default();
            for (lens, pair_ids) in draws {
                for id in pair_ids {
                    if let Some(p) = pairs.get(id) {
                        sums.pair(p);
                    }
                }
                let key = (model.clone(), lens_ids[*lens].to_string());
                sums.lens_oiqe(scores.oiqe.get(&key).copied());
            }
            sums.op()
        })
        .collect()
}

/// The rank stability of `models` at every `ode` level that has test pairs.
pub fn rank_stability(
    scores: &Scores,
    models: &[String],
    lenses: &BTreeMap<String, LensInfo>,
) -> Vec<LevelRanks> {
    let by_model: Vec<BTreeMap<&str, &PairScore>> = models
        .iter()
        .map(|m| {
            scores
                .pairs
                .iter()
                .filter(|p| &p.model == m)
                .map(|p| (p.pair_id.as_str(), p))
                .collect()
        })
        .collect();
    let mut out = Vec::new();
    for level in 1..=super::LEVELS {
        // The level's lenses and, per lens, its pairs (any model's: pairs are shared test images).
        let mut pairs_of: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
        for p in &scores.pairs {
            let at_level = lenses.get(&p.lens_id).and_then(|l| l.levels.get(&Benchmark::Ode)) == Some(&level);
            if at_level {
                let ids = pairs_of.entry(p.lens_id.as_str()).or_default();
                if !ids.contains(&p.pair_id.as_str()) {
                    ids.push(p.pair_id.as_str());
                }
            }
        }
        if pairs_of.is_empty() || models.is_empty() {
            continue;
        }
        let lens_ids: Vec<&str> = pairs_of.keys().copied().collect();
        let lens_pairs: Vec<&Vec<&str>> = pairs_of.values().collect();
        let all: Vec<(usize, Vec<&str>)> = lens_pairs
            .iter()
            .enumerate()
            .map(|(i, ids)| (i, (*ids).clone()))
            .collect();
        let point_ops = ops_over(models, &by_model, scores, &lens_ids, &all);
        let point_ranks = ranks_of(&point_ops);
        let mut rng = ChaCha8Rng::seed_from_u64(BOOTSTRAP_SEED + u64::from(level));
        let mut drawn_ranks: Vec<Vec<usize>> = vec![Vec::with_capacity(RANK_RESAMPLES); models.len()];
        for _ in 0..RANK_RESAMPLES {
            let draws: Vec<(usize, Vec<&str>)> = (0..lens_ids.len())
                .map(|_| {
                    let lens = rng.random_range(0..lens_ids.len());
                    let ids = lens_pairs[lens];
                    let pairs = (0..ids.len())
                        .map(|_| ids[rng.random_range(0..ids.len())])
                        .collect();
                    (lens, pairs)
                })
                .collect();
            let ranks = ranks_of(&ops_over(models, &by_model, scores, &lens_ids, &draws));
            for (m, r) in ranks.into_iter().enumerate() {
                drawn_ranks[m].push(r);
            }
        }
        let models_out = models
            .iter()
            .enumerate()
            .filter_map(|(m, model)| {
                let op = point_ops[m]?;
                let ranks = &mut drawn_ranks[m];
                ranks.sort_unstable();
                let at = |q: f64| ranks[((ranks.len() - 1) as f64 * q).round() as usize];
                let share = |r: usize| ranks.iter().filter(|&&x| x == r).count() as f64 / ranks.len() as f64;
                Some(RankStability {
                    model: model.clone(),
                    op,
                    rank: point_ranks[m],
                    rank_ci95: [at(0.025), at(0.975)],
                    rank_share: share(point_ranks[m]),
                    best_share: share(1),
                })
            })
            .collect();
        out.push(LevelRanks {
            level,
            lenses: lens_ids.len(),
            pairs: lens_pairs.iter().map(|p| p.len()).sum(),
            resamples: RANK_RESAMPLES,
            models: models_out,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(model: &str, lens: &str, scene: usize, psnr_db: f64) -> PairScore {
        PairScore {
            model: model.into(),
            pair_id: format!("{lens}__s{scene}"),
            lens_id: lens.into(),
            level: 1,
            psnr_db,
            ssim: 0.5,
            lpips: None,
            clipiqa: None,
            features: None,
        }
    }

    fn lens_at_level_1(id: &str) -> (String, LensInfo) {
        let levels = BTreeMap::from([(Benchmark::Ode, 1u8)]);
        (
            id.to_string(),
            LensInfo {
                lens_id: id.into(),
                levels,
                ode: 0.5,
                rms_radius_um: 10.0,
            },
        )
    }

    #[test]
    fn a_clear_winner_holds_its_rank_and_a_coin_flip_does_not() {
        let lenses: BTreeMap<String, LensInfo> = (0..8).map(|i| lens_at_level_1(&format!("l{i}"))).collect();
        let mut scores = Scores::default();
        for i in 0..8 {
            let lens = format!("l{i}");
            for s in 0..3 {
                // `a` beats everyone by 5 dB; `b` and `c` trade places lens by lens.
                let wobble = if (i + s) % 2 == 0 { 0.5 } else { -0.5 };
                scores.pairs.push(pair("a", &lens, s, 35.0));
                scores.pairs.push(pair("b", &lens, s, 30.0 + wobble));
                scores.pairs.push(pair("c", &lens, s, 30.0 - wobble + 0.01));
            }
        }
        let models: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let levels = rank_stability(&scores, &models, &lenses);
        assert_eq!(levels.len(), 1);
        let level = &levels[0];
        assert_eq!((level.lenses, level.pairs), (8, 24));
        let a = &level.models[0];
        assert_eq!(
            (a.rank, a.rank_ci95, a.rank_share, a.best_share),
            (1, [1, 1], 1.0, 1.0)
        );
        let (b, c) = (&level.models[1], &level.models[2]);
        assert_eq!(b.rank + c.rank, 5);
        assert!(b.rank_share < 0.9 && c.rank_share < 0.9, "{b:?} {c:?}");
        assert_eq!(b.rank_ci95, [2, 3]);
        // Seeded: the same shares every time.
        assert_eq!(rank_stability(&scores, &models, &lenses), levels);
    }
}
