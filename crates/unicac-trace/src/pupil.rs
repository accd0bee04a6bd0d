//! Pupil sampling patterns over the unit disc (normalised pupil coordinates), and the counter-based
//! random generator behind `random:N`.

use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::PI;

/// Fixed default seed of `random:N`, so two runs sample the same rays.
pub const DEFAULT_SEED: u64 = 0x5EED_0FC0_FFEE;

/// Most pupil points one sampling may produce (2^24). A spot holds, per point, the pupil point (16 B),
/// the ray (48 B), its status (8 B) and its image point (16 B): about 1.5 GB at this limit, traced in a
/// few seconds. Checked before anything is allocated.
pub const MAX_PUPIL_SAMPLES: u64 = 1 << 24;

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PupilSampling {
    /// Centre plus rings i = 1..R at radius i/R holding 6 i points at angles 2 pi k / (6 i).
    Hexapolar { rings: usize },
    /// The cell centres of an N x N grid over [-1, 1]^2 that fall inside the unit disc.
    Grid { n: usize },
    /// N points on a Fibonacci (sunflower) spiral: r = sqrt((i + 0.5) / N), angle = i * golden angle.
    Fibonacci { n: usize },
    /// N points uniform over the disc (r = sqrt(u), angle = 2 pi v) from a seeded counter-based generator.
    Random { n: usize, seed: u64 },
}

impl std::str::FromStr for PupilSampling {
    type Err = String;

    /// Parses `hexapolar:R`, `grid:N`, `fibonacci:N`, `random:N` or `random:N:SEED`.
    fn from_str(text: &str) -> Result<Self, String> {
        let mut parts = text.split(':');
        let kind = parts.next().unwrap_or_default();
        let number = |part: Option<&str>| -> Result<u64, String> {
            part.ok_or_else(|| format!("'{text}': missing count"))?
                .parse::<u64>()
                .map_err(|_| format!("'{text}': the count must be a non-negative integer"))
        };
        let n = number(parts.next())?;
        if n == 0 {
            return Err(format!("'{text}': the count must be at least 1"));
        }
        // Counts beyond the limit are refused below; clamping here keeps 32-bit targets from wrapping.
        let n_usize = usize::try_from(n).unwrap_or(usize::MAX);
        let sampling = match kind {
            "hexapolar" => PupilSampling::Hexapolar { rings: n_usize },
            "grid" => PupilSampling::Grid { n: n_usize },
            "fibonacci" => PupilSampling::Fibonacci { n: n_usize },
            "random" => PupilSampling::Random {
                n: n_usize,
                seed: match parts.next() {
                    Some(_) => number(text.rsplit(':').next())?,
                    None => DEFAULT_SEED,
                },
            },
            _ => {
                return Err(format!(
                    "'{text}': expected hexapolar:R, grid:N, fibonacci:N or random:N[:SEED]"
                ))
            }
        };
        sampling.check().map_err(|e| format!("'{text}': {e}"))?;
        Ok(sampling)
    }
}

impl PupilSampling {
    /// How many points the sampling visits before the disc test (grid: N^2 cells), without allocating;
    /// saturates instead of overflowing.
    pub fn candidate_count(&self) -> u64 {
        match *self {
            PupilSampling::Hexapolar { rings } => {
                let r = rings as u64;
                r.saturating_mul(r.saturating_add(1))
                    .saturating_mul(3)
                    .saturating_add(1)
            }
            PupilSampling::Grid { n } => (n as u64).saturating_mul(n as u64),
            PupilSampling::Fibonacci { n } | PupilSampling::Random { n, .. } => n as u64,
        }
    }

    /// An error naming the limit when the sampling is empty or would exceed [`MAX_PUPIL_SAMPLES`].
    pub fn check(&self) -> Result<(), String> {
        let count = self.candidate_count();
        let n = match *self {
            PupilSampling::Hexapolar { rings: n }
            | PupilSampling::Grid { n }
            | PupilSampling::Fibonacci { n }
            | PupilSampling::Random { n, .. } => n,
        };
        if n == 0 {
            return Err("the count must be at least 1".into());
        }
        if count > MAX_PUPIL_SAMPLES {
            return Err(format!(
                "{count} pupil samples exceed the limit of {MAX_PUPIL_SAMPLES} (MAX_PUPIL_SAMPLES)"
            ));
        }
        Ok(())
    }

    /// How many points `points` gives, without making them.
    pub fn point_count(&self) -> usize {
        match *self {
            PupilSampling::Grid { n } => {
                let coordinate = |i: usize| -1.0 + (2 * i + 1) as f64 / n as f64;
                (0..n)
                    .map(|j| {
                        (0..n)
                            .filter(|&i| {
                                let (x, y) = (coordinate(i), coordinate(j));
                                x * x + y * y <= 1.0
                            })
                            .count()
                    })
                    .sum()
            }
            _ => self.candidate_count() as usize,
        }
    }

    /// Point i of `points()` for the patterns whose i-th point depends on i alone (Fibonacci, random),
    /// so that parts of a pupil can be made where they are used; None for the others.
    #[inline]
    pub fn indexed_point(&self, i: usize) -> Option<[f64; 2]> {
        match *self {
            PupilSampling::Fibonacci { n } => {
                let golden_angle = PI * (3.0 - 5f64.sqrt());
                let r = ((i as f64 + 0.5) / n as f64).sqrt();
                let angle = i as f64 * golden_angle;
                Some([r * angle.cos(), r * angle.sin()])
            }
            PupilSampling::Random { seed, .. } => {
                let i = i as u64;
                let r = unit_interval(counter_hash(seed, 2 * i)).sqrt();
                let angle = 2.0 * PI * unit_interval(counter_hash(seed, 2 * i + 1));
                Some([r * angle.cos(), r * angle.sin()])
            }
            PupilSampling::Hexapolar { .. } | PupilSampling::Grid { .. } => None,
        }
    }

    /// The sample points (px, py) in the unit disc.
    pub fn points(&self) -> Vec<[f64; 2]> {
        match *self {
            PupilSampling::Hexapolar { rings } => {
                let mut points = vec![[0.0, 0.0]];
                for i in 1..=rings {
                    let r = i as f64 / rings as f64;
                    let count = 6 * i;
                    points.extend((0..count).map(|k| {
                        let angle = 2.0 * PI * k as f64 / count as f64;
                        [r * angle.cos(), r * angle.sin()]
                    }));
                }
                points
            }
            PupilSampling::Grid { n } => {
                let coordinate = |i: usize| -1.0 + (2 * i + 1) as f64 / n as f64;
                (0..n)
                    .flat_map(|j| (0..n).map(move |i| [coordinate(i), coordinate(j)]))
                    .filter(|[x, y]| x * x + y * y <= 1.0)
                    .collect()
            }
            // Point i depends on i alone: generated in parallel (a million points are most of a
            // spot's work outside the trace).
            PupilSampling::Fibonacci { .. } | PupilSampling::Random { .. } => {
                let count = self.point_count();
                (0..count)
                    .into_par_iter()
                    .map(|i| self.indexed_point(i).expect("an indexed pattern"))
                    .collect()
            }
        }
    }
}

/// Counter-based randomness (one home: unicac-io), re-exported for the tracer's users.
pub use unicac_io::counter_random::{counter_hash, unit_interval};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hexapolar_counts_and_radii() {
        let points = PupilSampling::Hexapolar { rings: 6 }.points();
        assert_eq!(points.len(), 1 + 3 * 6 * 7);
        let outer = points.iter().map(|[x, y]| x.hypot(*y)).fold(0.0, f64::max);
        assert!((outer - 1.0).abs() < 1e-15);
    }

    #[test]
    fn point_count_is_the_number_of_points() {
        for pattern in [
            "hexapolar:5",
            "grid:1",
            "grid:16",
            "grid:17",
            "fibonacci:500",
            "random:500",
        ] {
            let sampling = pattern.parse::<PupilSampling>().unwrap();
            assert_eq!(sampling.point_count(), sampling.points().len(), "{pattern}");
        }
    }

    #[test]
    fn all_patterns_stay_inside_the_unit_disc() {
        for pattern in ["hexapolar:5", "grid:16", "fibonacci:500", "random:500"] {
            let points = pattern.parse::<PupilSampling>().unwrap().points();
            assert!(!points.is_empty());
            assert!(
                points.iter().all(|[x, y]| x * x + y * y <= 1.0 + 1e-15),
                "{pattern}"
            );
        }
    }

    #[test]
    fn random_sampling_is_reproducible_and_uniform() {
        let a = PupilSampling::Random { n: 20000, seed: 7 }.points();
        assert_eq!(a, PupilSampling::Random { n: 20000, seed: 7 }.points());
        assert_ne!(a, PupilSampling::Random { n: 20000, seed: 8 }.points());
        // Uniform over the disc: E[r^2] = 1/2, E[x] = 0; 20000 samples give ~0.002 standard error.
        let mean_r2: f64 = a.iter().map(|[x, y]| x * x + y * y).sum::<f64>() / a.len() as f64;
        let mean_x: f64 = a.iter().map(|[x, _]| x).sum::<f64>() / a.len() as f64;
        assert!((mean_r2 - 0.5).abs() < 0.01, "{mean_r2}");
        assert!(mean_x.abs() < 0.015, "{mean_x}");
    }

    #[test]
    fn counts_beyond_the_limit_are_refused_before_allocating() {
        // Unchecked, each of these would abort on allocation, overflow a capacity or run for minutes.
        for bad in [
            "fibonacci:18446744073709551615",
            "random:18446744073709551615",
            "random:4294967296",
            "hexapolar:100000",
            "grid:100000",
            "grid:4294967295",
        ] {
            let message = bad.parse::<PupilSampling>().unwrap_err();
            assert!(message.contains("MAX_PUPIL_SAMPLES"), "{bad}: {message}");
        }
        assert!("hexapolar:2000".parse::<PupilSampling>().is_ok());
        assert!("grid:4096".parse::<PupilSampling>().is_ok());
        assert!("random:16777216".parse::<PupilSampling>().is_ok());
        assert!("random:16777217".parse::<PupilSampling>().is_err());
    }

    #[test]
    fn parsing_rejects_bad_patterns() {
        for bad in ["hexapolar", "grid:0", "spiral:4", "random:x"] {
            assert!(bad.parse::<PupilSampling>().is_err(), "{bad}");
        }
        assert_eq!(
            "random:10:3".parse::<PupilSampling>().unwrap(),
            PupilSampling::Random { n: 10, seed: 3 }
        );
    }
}
