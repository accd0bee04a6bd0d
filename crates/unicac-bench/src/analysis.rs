//! The paper's key analysis: does a lens metric predict how well lenses can be corrected? Per lens, the
//! mean O.P. of the restoration models is fitted by least squares against the lens's ODE, its RMS spot
//! radius and the logarithm of that radius (the fair baseline for a quantity spanning decades); R^2 of
//! each fit says how much of the spread in restorability each metric explains, Pearson's r and the slope
//! give its direction (an R^2 alone can present an inverse relation as support). Spearman's and Kendall's
//! rank correlations say whether the metric orders the lenses right (what a benchmark's levels need), and
//! percentile bootstrap intervals over lenses, paired where two metrics are compared on the same
//! resamples, say how far each figure can be trusted (issue 33, claim 1).

use serde::Serialize;

/// A least-squares line y = intercept + slope x and its coefficient of determination.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LineFit {
    pub intercept: f64,
    pub slope: f64,
    /// 1 - SS_res / SS_tot.
    pub r2: f64,
}

/// The ordinary least-squares line through `points`; `None` with fewer than 3 points or when x or y
/// does not vary (R^2 undefined).
pub fn fit_line(points: &[(f64, f64)]) -> Option<LineFit> {
    let points = finite_points(points)?;
    let m = Moments::of(&points)?;
    let slope = m.sxy / m.sxx;
    let intercept = m.mean_y - slope * m.mean_x;
    let residual: f64 = points
        .iter()
        .map(|p| (p.1 - intercept - slope * p.0).powi(2))
        .sum();
    Some(LineFit {
        intercept,
        slope,
        r2: 1.0 - residual / m.syy,
    })
}

/// Spearman's rank correlation: Pearson's correlation of the ranks (ties get their mean rank). `None`
/// with fewer than 3 finite points or when either variable is constant.
pub fn spearman(points: &[(f64, f64)]) -> Option<f64> {
    let points = finite_points(points)?;
    let xs = ranks(&points.iter().map(|p| p.0).collect::<Vec<_>>());
    let ys = ranks(&points.iter().map(|p| p.1).collect::<Vec<_>>());
    let ranked: Vec<(f64, f64)> = xs.into_iter().zip(ys).collect();
    let m = Moments::of(&ranked)?;
    Some(m.sxy / (m.sxx * m.syy).sqrt())
}

/// Pearson's correlation coefficient (signed). `None` with fewer than 3 finite points or when either
/// variable is constant.
pub fn pearson(points: &[(f64, f64)]) -> Option<f64> {
    let points = finite_points(points)?;
    let m = Moments::of(&points)?;
    Some(m.sxy / (m.sxx * m.syy).sqrt())
}

/// Kendall's tau-b: (concordant - discordant) pairs over the geometric mean of the pairs not tied in x
/// and not tied in y (ties in both count in neither). `None` with fewer than 3 finite points or when
/// either variable is constant. O(n^2): a bench has at most thousands of lenses.
pub fn kendall_tau_b(points: &[(f64, f64)]) -> Option<f64> {
    let points = finite_points(points)?;
    let (mut concordant, mut discordant, mut tied_x, mut tied_y) = (0i64, 0i64, 0i64, 0i64);
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            let dx = (a.0 - b.0).partial_cmp(&0.0).expect("finite");
            let dy = (a.1 - b.1).partial_cmp(&0.0).expect("finite");
            use std::cmp::Ordering::Equal;
            match (dx, dy) {
                (Equal, Equal) => {}
                (Equal, _) => tied_x += 1,
                (_, Equal) => tied_y += 1,
                _ if dx == dy => concordant += 1,
                _ => discordant += 1,
            }
        }
    }
    let untied_x = (concordant + discordant + tied_y) as f64;
    let untied_y = (concordant + discordant + tied_x) as f64;
    (untied_x > 0.0 && untied_y > 0.0)
        .then(|| (concordant - discordant) as f64 / (untied_x * untied_y).sqrt())
}

/// The points with both coordinates finite; `None` when fewer than 3 remain.
fn finite_points(points: &[(f64, f64)]) -> Option<Vec<(f64, f64)>> {
    let finite: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    (finite.len() >= 3).then_some(finite)
}

/// Means and centred sums of squares and products of a point set.
struct Moments {
    mean_x: f64,
    mean_y: f64,
    sxx: f64,
    sxy: f64,
    syy: f64,
}

impl Moments {
    /// `None` when x or y does not vary.
    fn of(points: &[(f64, f64)]) -> Option<Moments> {
        let n = points.len() as f64;
        let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
        let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
        let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
        let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
        let syy: f64 = points.iter().map(|p| (p.1 - mean_y).powi(2)).sum();
        (sxx > 0.0 && syy > 0.0).then_some(Moments {
            mean_x,
            mean_y,
            sxx,
            sxy,
            syy,
        })
    }
}

/// 1-based ranks of `values`, ties sharing their mean rank.
fn ranks(values: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut ranks = vec![0.0; values.len()];
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && values[order[end]] == values[order[start]] {
            end += 1;
        }
        // Positions start..end (0-based) share ranks start+1 ..= end: their mean.
        let mean_rank = (start + 1 + end) as f64 / 2.0;
        for &i in &order[start..end] {
            ranks[i] = mean_rank;
        }
        start = end;
    }
    ranks
}

/// Resamples of the percentile bootstrap (a stated count: the interval ends move by about 0.01 between
/// seeds at this count on 25 lenses).
pub const BOOTSTRAP_RESAMPLES: usize = 2000;

/// Seed of the bootstrap's resampling, fixed so that a report is reproducible byte for byte.
pub const BOOTSTRAP_SEED: u64 = 19;

/// The 95% percentile bootstrap interval of `statistic` over `points` (resampled with replacement,
/// `BOOTSTRAP_RESAMPLES` times, seeded). Resamples where the statistic is undefined (e.g. every drawn
/// lens the same) are dropped; `None` when more than half are, or with fewer than 3 points.
pub fn bootstrap_ci95(
    points: &[(f64, f64)],
    statistic: impl Fn(&[(f64, f64)]) -> Option<f64>,
) -> Option<[f64; 2]> {
    let mut sample = Vec::with_capacity(points.len());
    bootstrap_indices_ci95(points.len(), |drawn| {
        sample.clear();
        sample.extend(drawn.iter().map(|&i| points[i]));
        statistic(&sample)
    })
}

/// The percentile bootstrap over `n` items when the statistic needs more than one value per item (a
/// paired comparison of two metrics on the same lenses): `statistic` receives the drawn indices. Same
/// resamples, seed and rules as [`bootstrap_ci95`].
pub fn bootstrap_indices_ci95(
    n: usize,
    mut statistic: impl FnMut(&[usize]) -> Option<f64>,
) -> Option<[f64; 2]> {
    use rand::rngs::ChaCha8Rng;
    use rand::{RngExt, SeedableRng};
    if n < 3 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(BOOTSTRAP_SEED);
    let mut drawn = vec![0; n];
    let mut values: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
        .filter_map(|_| {
            for slot in drawn.iter_mut() {
                *slot = rng.random_range(0..n);
            }
            statistic(&drawn).filter(|v| v.is_finite())
        })
        .collect();
    percentile_interval(&mut values, BOOTSTRAP_RESAMPLES)
}

/// The 2.5% and 97.5% percentiles of `values` (sorted in place); `None` when fewer than half of the
/// `attempted` resamples gave a value.
pub fn percentile_interval(values: &mut [f64], attempted: usize) -> Option<[f64; 2]> {
    if values.is_empty() || values.len() * 2 < attempted {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
    Some([at(0.025), at(0.975)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spearman_of_a_monotonic_relation_is_one_and_ties_share_ranks() {
        let cubic: Vec<(f64, f64)> = (0..10).map(|i| (i as f64, (i as f64).powi(3))).collect();
        assert!((spearman(&cubic).unwrap() - 1.0).abs() < 1e-12);
        let reversed: Vec<(f64, f64)> = cubic.iter().map(|&(x, y)| (x, -y)).collect();
        assert!((spearman(&reversed).unwrap() + 1.0).abs() < 1e-12);
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
        // x = (1, 2, 3, 4, 5), y = (2, 1, 4, 3, 5): d^2 sums to 4, rho = 1 - 6 * 4 / (5 * 24) = 0.8.
        let swapped = [(1.0, 2.0), (2.0, 1.0), (3.0, 4.0), (4.0, 3.0), (5.0, 5.0)];
        assert!((spearman(&swapped).unwrap() - 0.8).abs() < 1e-12);
        assert!(spearman(&[(0.0, 1.0), (1.0, 1.0), (2.0, 1.0)]).is_none());
    }

    #[test]
    fn bootstrap_intervals_hold_the_estimate_and_shrink_with_more_lenses() {
        // y = x + a deterministic wobble: R^2 well below 1, known to lie inside its interval.
        let points = |n: usize| -> Vec<(f64, f64)> {
            (0..n)
                .map(|i| (i as f64, i as f64 + 3.0 * ((i * 7919) % 13) as f64 / 13.0))
                .collect()
        };
        let r2 = |p: &[(f64, f64)]| fit_line(p).map(|f| f.r2);
        let small = points(12);
        let [lo, hi] = bootstrap_ci95(&small, r2).unwrap();
        let estimate = r2(&small).unwrap();
        assert!(lo <= estimate && estimate <= hi, "{lo} {estimate} {hi}");
        let [big_lo, big_hi] = bootstrap_ci95(&points(200), r2).unwrap();
        assert!(big_hi - big_lo < hi - lo, "{big_lo}..{big_hi} against {lo}..{hi}");
        // Seeded: the same interval every time.
        assert_eq!(bootstrap_ci95(&small, r2), Some([lo, hi]));
        assert!(bootstrap_ci95(&small[..2], r2).is_none());
    }

    #[test]
    fn kendall_and_pearson_match_hand_counts() {
        // x = (1..5), y = (2, 1, 4, 3, 5): 10 pairs, 2 discordant -> tau = (8 - 2) / 10 = 0.6.
        let swapped = [(1.0, 2.0), (2.0, 1.0), (3.0, 4.0), (4.0, 3.0), (5.0, 5.0)];
        assert!((kendall_tau_b(&swapped).unwrap() - 0.6).abs() < 1e-12);
        // Ties: x = (1, 1, 2, 3), y = (1, 2, 2, 3): pairs (12) tied in x, (23) tied in y, 4 concordant,
        // 0 discordant: tau_b = 4 / sqrt(5 * 5) = 0.8 (scipy.stats.kendalltau gives 0.8).
        let tied = [(1.0, 1.0), (1.0, 2.0), (2.0, 2.0), (3.0, 3.0)];
        assert!((kendall_tau_b(&tied).unwrap() - 0.8).abs() < 1e-12);
        let reversed: Vec<(f64, f64)> = swapped.iter().map(|&(x, y)| (x, -y)).collect();
        assert!((kendall_tau_b(&reversed).unwrap() + 0.6).abs() < 1e-12);
        assert!(kendall_tau_b(&[(0.0, 1.0), (1.0, 1.0), (2.0, 1.0)]).is_none());
        // Pearson is signed and its square is the line's R^2.
        let points = [(0.0, 3.0), (1.0, 1.0), (2.0, 2.0), (3.0, 0.0)];
        let r = pearson(&points).unwrap();
        assert!(r < 0.0);
        assert!((r * r - fit_line(&points).unwrap().r2).abs() < 1e-12);
    }

    #[test]
    fn paired_bootstrap_of_a_difference_excludes_zero_only_when_one_metric_is_better() {
        // y follows a exactly and b loosely: R^2(a) - R^2(b) > 0 on every resample.
        let n = 40;
        let a: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let b: Vec<f64> = (0..n)
            .map(|i| i as f64 + 10.0 * ((i * 7919) % 11) as f64 / 11.0)
            .collect();
        let y: Vec<f64> = a.iter().map(|v| 2.0 * v + 1.0).collect();
        let r2_of = |x: &[f64], drawn: &[usize]| {
            let p: Vec<(f64, f64)> = drawn.iter().map(|&i| (x[i], y[i])).collect();
            fit_line(&p).map(|f| f.r2)
        };
        let [lo, hi] = bootstrap_indices_ci95(n, |d| Some(r2_of(&a, d)? - r2_of(&b, d)?)).unwrap();
        assert!(lo > 0.0 && hi > lo, "{lo} {hi}");
        // The same metric against itself: the difference is exactly 0.
        assert_eq!(
            bootstrap_indices_ci95(n, |d| Some(r2_of(&a, d)? - r2_of(&a, d)?)),
            Some([0.0, 0.0])
        );
    }

    #[test]
    fn exact_line_has_r2_one() {
        let fit = fit_line(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]).unwrap();
        assert!((fit.slope - 2.0).abs() < 1e-12 && (fit.intercept - 1.0).abs() < 1e-12);
        assert!((fit.r2 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn known_r2() {
        // y = (0, 2, 1, 3) at x = (0, 1, 2, 3): slope 0.8, intercept 0.3, SS_res 1.8, SS_tot 5.
        let fit = fit_line(&[(0.0, 0.0), (1.0, 2.0), (2.0, 1.0), (3.0, 3.0)]).unwrap();
        assert!((fit.slope - 0.8).abs() < 1e-12);
        assert!((fit.intercept - 0.3).abs() < 1e-12);
        assert!((fit.r2 - (1.0 - 1.8 / 5.0)).abs() < 1e-12);
        assert!(fit_line(&[(0.0, 1.0), (1.0, 2.0)]).is_none());
        assert!(fit_line(&[(0.0, 1.0), (1.0, 1.0), (2.0, 1.0)]).is_none());
    }
}
