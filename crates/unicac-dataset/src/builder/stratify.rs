//! Splits and levels from the lens grades (docs/dataset.md, "Levels"). Pure functions of the grades
//! and the counts: no randomness, so every shard computes the same assignment.
//!
//! ODE levels: the lenses are ranked by ODE (highest = mildest first; ties by lens id) and the ranks
//! cut into `levels` contiguous groups of equal size (+-1): quantiles, so an uneven library cannot
//! leave a level empty. Each group gives `per_level` test lenses at evenly spaced ranks inside it,
//! which spreads them over the group's ODE range. Validation lenses are taken at evenly spaced ranks
//! of the remaining lenses (so they span the whole range too); the rest train.
//!
//! Sub-benchmarks: the test lenses are ranked by U_s (resp. U_c), highest first, and cut into
//! `levels` groups of `per_level`. Because the test lenses were drawn evenly across the ODE ranks, OIQ
//! and the other uniformity stay spread in every sub-level; their [min, mean, max] per level is
//! recorded in `dataset.json` and printed by `unicac dataset info` so the balance can be checked.

use crate::builder::grading::Grade;
use crate::builder::sources::MAX_ITEMS;
use crate::error::{DatasetError, Result};
use crate::manifest::{LevelSummary, Stratification};

/// The role of each lens (same order as the input).
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    pub split: Vec<&'static str>,
    pub level: Vec<Option<u32>>,
    pub us_level: Vec<Option<u32>>,
    pub uc_level: Vec<Option<u32>>,
    pub stratifications: Vec<Stratification>,
}

/// Counts the assignment needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelCounts {
    pub levels: usize,
    pub per_level: usize,
    pub val: usize,
    pub sub_benchmarks: bool,
}

pub const MAX_LEVELS: usize = 100;

impl LevelCounts {
    /// Lenses the split needs (`levels` x `per_level` test, `val` validation, one training), with
    /// checked arithmetic: at most `MAX_ITEMS`, the most lenses a build takes.
    pub fn lenses_needed(&self) -> Result<usize> {
        let needed = self
            .levels
            .checked_mul(self.per_level)
            .and_then(|n| n.checked_add(self.val))
            .and_then(|n| n.checked_add(1))
            .filter(|&n| n <= MAX_ITEMS);
        needed.ok_or_else(|| {
            DatasetError::setting(
                "test_lenses_per_level",
                format!(
                    "{}: {} levels x {} test lenses + {} validation + 1 training lens need more than the {MAX_ITEMS} lenses a build takes (MAX_ITEMS)",
                    self.per_level, self.levels, self.per_level, self.val
                ),
            )
        })
    }

    /// The counts are in range and a library of `lenses` lenses is large enough.
    pub fn check(&self, lenses: usize) -> Result<()> {
        if !(1..=MAX_LEVELS).contains(&self.levels) {
            return Err(DatasetError::setting(
                "levels",
                format!("{}: must lie in [1, {MAX_LEVELS}] (MAX_LEVELS)", self.levels),
            ));
        }
        if self.per_level == 0 {
            return Err(DatasetError::setting(
                "test_lenses_per_level",
                "0: must be at least 1",
            ));
        }
        let needed = self.lenses_needed()?;
        if lenses < needed {
            return Err(DatasetError::Invalid(format!(
                "the library holds {lenses} lenses; {} levels x {} test lenses + {} validation + 1 training lens need {needed}",
                self.levels, self.per_level, self.val
            )));
        }
        Ok(())
    }
}

pub fn assign(ids: &[String], grades: &[Grade], counts: LevelCounts) -> Result<Assignment> {
    let n = grades.len();
    counts.check(n)?;
    let LevelCounts {
        levels,
        per_level,
        val,
        sub_benchmarks,
    } = counts;
    let by_metric = |metric: fn(&Grade) -> f64, subset: &[usize]| {
        let mut order = subset.to_vec();
        order.sort_by(|&a, &b| {
            metric(&grades[b])
                .total_cmp(&metric(&grades[a]))
                .then_with(|| ids[a].cmp(&ids[b]))
        });
        order
    };
    let everyone: Vec<usize> = (0..n).collect();
    let ranked = by_metric(|g| g.scores.ode, &everyone);
    let mut split = vec!["train"; n];
    let mut level = vec![None; n];
    let groups = rank_groups(n, levels);
    for (k, &(start, end)) in groups.iter().enumerate() {
        for pick in evenly_spaced(end - start, per_level) {
            let lens = ranked[start + pick];
            split[lens] = "test";
            level[lens] = Some(k as u32 + 1);
        }
    }
    let rest: Vec<usize> = ranked.iter().copied().filter(|&i| split[i] != "test").collect();
    for pick in evenly_spaced(rest.len(), val) {
        split[rest[pick]] = "val";
    }
    let group_members: Vec<Vec<usize>> = groups.iter().map(|&(s, e)| ranked[s..e].to_vec()).collect();
    let test_of = |k: usize| -> Vec<usize> {
        ranked
            .iter()
            .copied()
            .filter(|&i| level[i] == Some(k as u32 + 1))
            .collect()
    };
    let mut stratifications = vec![stratification(
        "ode",
        "quantile groups of the ODE ranking of every lens; per_level test lenses at evenly spaced ranks in each group",
        |g| g.scores.ode,
        grades,
        &group_members,
        &(0..levels).map(test_of).collect::<Vec<_>>(),
    )];
    let (mut us_level, mut uc_level) = (vec![None; n], vec![None; n]);
    if sub_benchmarks {
        let test: Vec<usize> = (0..n).filter(|&i| split[i] == "test").collect();
        for (metric_name, metric, target) in [
            (
                "u_s",
                (|g: &Grade| g.scores.u_s) as fn(&Grade) -> f64,
                &mut us_level,
            ),
            ("u_c", |g: &Grade| g.scores.u_c, &mut uc_level),
        ] {
            let ranked_test = by_metric(metric, &test);
            let groups: Vec<Vec<usize>> = rank_groups(test.len(), levels)
                .iter()
                .map(|&(s, e)| ranked_test[s..e].to_vec())
                .collect();
            for (k, members) in groups.iter().enumerate() {
                for &i in members {
                    target[i] = Some(k as u32 + 1);
                }
            }
            stratifications.push(stratification(
                metric_name,
                "the test lenses ranked by this uniformity (highest first) in groups of per_level",
                metric,
                grades,
                &groups,
                &groups,
            ));
        }
    }
    Ok(Assignment {
        split,
        level,
        us_level,
        uc_level,
        stratifications,
    })
}

/// [start, end) of `groups` contiguous rank groups covering 0..n, sizes equal to within one.
pub fn rank_groups(n: usize, groups: usize) -> Vec<(usize, usize)> {
    (0..groups)
        .map(|k| (k * n / groups, (k + 1) * n / groups))
        .collect()
}

/// `count` distinct positions in 0..n (count <= n), evenly spaced: the centres of `count` equal bins.
pub fn evenly_spaced(n: usize, count: usize) -> Vec<usize> {
    (0..count).map(|j| ((2 * j + 1) * n) / (2 * count)).collect()
}

/// Thresholds from the rank groups (midpoints between neighbouring groups, the outer values at the
/// ends) and the score distribution of each level's members.
fn stratification(
    metric_name: &str,
    rule: &str,
    metric: fn(&Grade) -> f64,
    grades: &[Grade],
    groups: &[Vec<usize>],
    members: &[Vec<usize>],
) -> Stratification {
    let value = |i: usize| metric(&grades[i]);
    let first = |g: &Vec<usize>| g.iter().map(|&i| value(i)).fold(f64::NEG_INFINITY, f64::max);
    let last = |g: &Vec<usize>| g.iter().map(|&i| value(i)).fold(f64::INFINITY, f64::min);
    let mut thresholds = vec![first(&groups[0])];
    for pair in groups.windows(2) {
        thresholds.push(0.5 * (last(&pair[0]) + first(&pair[1])));
    }
    thresholds.push(last(&groups[groups.len() - 1]));
    let spread = |of: &Vec<usize>, f: fn(&Grade) -> f64| {
        let values: Vec<f64> = of.iter().map(|&i| f(&grades[i])).collect();
        let (lo, hi) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        [lo, values.iter().sum::<f64>() / values.len().max(1) as f64, hi]
    };
    Stratification {
        metric: metric_name.into(),
        rule: rule.into(),
        levels: members
            .iter()
            .enumerate()
            .map(|(k, of)| LevelSummary {
                level: k as u32 + 1,
                lenses: of.len(),
                lower: thresholds[k + 1],
                upper: thresholds[k],
                ode: spread(of, |g| g.scores.ode),
                oiq: spread(of, |g| g.scores.oiq),
                u_s: spread(of, |g| g.scores.u_s),
                u_c: spread(of, |g| g.scores.u_c),
            })
            .collect(),
        thresholds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grade(ode: f64, u_s: f64, u_c: f64) -> Grade {
        Grade {
            scores: unicac_ode::OdeScores {
                ode,
                oiq: ode,
                u_s,
                u_c,
                oiqe: 0.5,
                psnr_db: 30.0,
                ssim: 0.9,
                rms_radius_um: 2.0,
            },
            pixel_um: 1.0,
            half_diagonal_mm: 1.0,
            kernel_px: 5,
        }
    }

    fn counts(levels: usize, per_level: usize, val: usize) -> LevelCounts {
        LevelCounts {
            levels,
            per_level,
            val,
            sub_benchmarks: true,
        }
    }

    #[test]
    fn an_uneven_library_fills_every_level_exactly_and_in_order() {
        // 7 lenses bunched at both ends: equal-width ODE bins would leave the middle levels empty.
        let odes = [0.95, 0.94, 0.93, 0.92, 0.10, 0.09, 0.5];
        let grades: Vec<Grade> = odes
            .iter()
            .enumerate()
            .map(|(i, &o)| grade(o, 1.0 - 0.1 * i as f64, 0.05 * i as f64))
            .collect();
        let ids: Vec<String> = (0..7).map(|i| format!("lens{i}")).collect();
        let a = assign(&ids, &grades, counts(5, 1, 1)).unwrap();
        let ode = &a.stratifications[0];
        for k in 1..=5u32 {
            let members: Vec<usize> = (0..7).filter(|&i| a.level[i] == Some(k)).collect();
            assert_eq!(members.len(), 1, "level {k}");
            let level = &ode.levels[k as usize - 1];
            for &i in &members {
                assert!(grades[i].scores.ode <= level.upper && grades[i].scores.ode >= level.lower);
            }
        }
        assert!(
            ode.thresholds.windows(2).all(|w| w[0] >= w[1]),
            "{:?}",
            ode.thresholds
        );
        assert_eq!(a.split.iter().filter(|s| **s == "val").count(), 1);
        assert_eq!(a.split.iter().filter(|s| **s == "train").count(), 1);
        // Sub-benchmark levels hold the test lenses, one each, ordered by U_s.
        assert_eq!(a.us_level.iter().flatten().count(), 5);
        let us = &a.stratifications[1];
        assert!(us.levels.windows(2).all(|w| w[0].u_s[0] >= w[1].u_s[2]));
    }

    #[test]
    fn a_library_too_small_is_refused_with_the_numbers() {
        let grades: Vec<Grade> = (0..10).map(|i| grade(i as f64 / 10.0, 0.5, 0.5)).collect();
        let ids: Vec<String> = (0..10).map(|i| format!("l{i}")).collect();
        let error = assign(&ids, &grades, counts(5, 2, 1)).unwrap_err().to_string();
        assert!(
            error.contains("holds 10 lenses") && error.contains("need 12"),
            "{error}"
        );
        assert!(assign(&ids, &grades, counts(3, 2, 2)).is_ok());
    }

    #[test]
    fn evenly_spaced_positions_are_distinct_and_centred() {
        assert_eq!(evenly_spaced(10, 2), vec![2, 7]);
        assert_eq!(evenly_spaced(3, 3), vec![0, 1, 2]);
        assert_eq!(rank_groups(7, 5), vec![(0, 1), (1, 2), (2, 4), (4, 5), (5, 7)]);
    }
}
