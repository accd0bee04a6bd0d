//! Pupil sampling patterns over the unit disc (normalised pupil coordinates), and the counter-based
//! random generator behind `random:N`.

use rayon::prelude::*;
use serde::Serialize;
use std::ops::{Add, Mul, Neg, Sub};

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
    /// N points on a Fibonacci (sunflower) spiral: r = sqrt((i + 0.5) / N), angle = i * golden angle
    /// (formed in 64-bit fixed-point turns, so exact for every i).
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
        let number = |part: Option<&str>, what: &str| -> Result<u64, String> {
            part.ok_or_else(|| format!("'{text}': missing {what}"))?
                .parse::<u64>()
                .map_err(|_| format!("'{text}': the {what} must be a non-negative integer"))
        };
        let n = number(parts.next(), "count")?;
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
                    Some(seed) => number(Some(seed), "seed")?,
                    None => DEFAULT_SEED,
                },
            },
            _ => {
                return Err(format!(
                    "'{text}': expected hexapolar:R, grid:N, fibonacci:N or random:N[:SEED]"
                ))
            }
        };
        if parts.next().is_some() {
            return Err(format!(
                "'{text}': too many ':' parts; expected hexapolar:R, grid:N, fibonacci:N or random:N[:SEED]"
            ));
        }
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
            PupilSampling::Fibonacci { n } => Some(fibonacci_point(n, i)),
            PupilSampling::Random { seed, .. } => Some(random_point(seed, i)),
            PupilSampling::Hexapolar { .. } | PupilSampling::Grid { .. } => None,
        }
    }

    /// Points `indices` of a pattern that makes points by index (`indexed_point` of each, bit for bit),
    /// appended to `out`; false (and nothing appended) for the others. The loop is compiled for the
    /// CPU's widest vectors (runtime dispatch): the same IEEE operations lane by lane, so the same bits,
    /// several times faster than point by point (a million random points cost about what their trace does).
    pub fn indexed_points_into(&self, indices: std::ops::Range<usize>, out: &mut Vec<[f64; 2]>) -> bool {
        if !matches!(
            self,
            PupilSampling::Fibonacci { .. } | PupilSampling::Random { .. }
        ) {
            return false;
        }
        let start = out.len();
        out.resize(start + indices.len(), [0.0; 2]);
        self.fill_indexed(indices.start, &mut out[start..]);
        true
    }

    /// Points first, first + 1, ... of an indexed pattern into `out`, in a `pulp` dispatch (see
    /// `indexed_points_into`).
    fn fill_indexed(&self, first: usize, out: &mut [[f64; 2]]) {
        pulp::Arch::new().dispatch(IndexedPoints {
            sampling: *self,
            first,
            out,
        });
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
                        let [c, s] = cos_sin_turns(k as f64 / count as f64);
                        [r * c, r * s]
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
                const CHUNK: usize = 1 << 14;
                let mut points = vec![[0.0; 2]; count];
                points
                    .par_chunks_mut(CHUNK)
                    .enumerate()
                    .for_each(|(c, chunk)| self.fill_indexed(c * CHUNK, chunk));
                points
            }
        }
    }
}

/// Point i of `fibonacci:N`.
#[inline(always)]
fn fibonacci_point(n: usize, i: usize) -> [f64; 2] {
    let r = ((i as f64 + 0.5) / n as f64).sqrt();
    let [c, s] = cos_sin_turns(unit_interval((i as u64).wrapping_mul(GOLDEN_TURNS)));
    [r * c, r * s]
}

/// Point i of `random:N:SEED`: r = sqrt(u), angle 2 pi v, u and v from the counter-based hash.
#[inline(always)]
fn random_point(seed: u64, i: usize) -> [f64; 2] {
    let i = i as u64;
    let r = unit_interval(counter_hash(seed, 2 * i)).sqrt();
    let [c, s] = cos_sin_turns(unit_interval(counter_hash(seed, 2 * i + 1)));
    [r * c, r * s]
}

/// `indexed_points_into`'s loop, compiled by `pulp` once per instruction set.
struct IndexedPoints<'a> {
    sampling: PupilSampling,
    first: usize,
    out: &'a mut [[f64; 2]],
}

impl pulp::WithSimd for IndexedPoints<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let IndexedPoints { sampling, first, out } = self;
        match sampling {
            PupilSampling::Fibonacci { n } => {
                for (j, point) in out.iter_mut().enumerate() {
                    *point = fibonacci_point(n, first + j);
                }
            }
            PupilSampling::Random { seed, .. } => {
                for (j, point) in out.iter_mut().enumerate() {
                    *point = random_point(seed, first + j);
                }
            }
            PupilSampling::Hexapolar { .. } | PupilSampling::Grid { .. } => {
                unreachable!("indexed_points_into checks the pattern")
            }
        }
    }
}

/// Counter-based randomness (one home: unicac-io), re-exported for the tracer's users.
pub use unicac_io::counter_random::{counter_hash, unit_interval};

/// The golden angle in turns, (3 - sqrt 5) / 2, as a 64-bit fraction: the Fibonacci pattern's angle of
/// point i is i times it modulo one turn, exact in wrapping integer arithmetic.
pub const GOLDEN_TURNS: u64 = 0x61c8_8646_80b5_83ea;

/// What `cos_sin_turns` needs of its working type: f64 for the CPU's pupils, f32 as well for the GPU
/// kernels' twins (unicac-gpu), which share this one implementation with the CPU.
pub trait TurnsFloat:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn constant(v: f64) -> Self;
    /// Round half to even, as WGSL `round`.
    fn round_even(self) -> Self;
    /// Truncating conversion (the WGSL `u32(x)` for 0 <= x < 2^32).
    fn to_u32(self) -> u32;
}

macro_rules! impl_turns_float {
    ($t:ty) => {
        impl TurnsFloat for $t {
            #[inline]
            fn constant(v: f64) -> $t {
                v as $t
            }
            #[inline]
            fn round_even(self) -> $t {
                self.round_ties_even()
            }
            #[inline]
            fn to_u32(self) -> u32 {
                self as u32
            }
        }
    };
}

impl_turns_float!(f64);
impl_turns_float!(f32);

/// cos and sin of 2 pi t for t in [0, 1]: reduction to the nearest quarter turn (exact in turns), then
/// Taylor series to x^17 / x^16 on |x| <= pi/4 (truncation below 1e-17). Branch-free apart from the
/// quadrant, a few times faster than libm's `sincos` of 2 pi t (which reduces a rounded angle), within
/// an ulp or two of it, and exact at every quarter turn. The GPU kernels (shaders/common.wgsl) run the
/// same polynomial, so the device's pupil points are the CPU's.
#[inline(always)]
pub fn cos_sin_turns<T: TurnsFloat>(t: T) -> [T; 2] {
    let k = T::constant;
    let q = (t * k(4.0)).round_even();
    let x = (t - q * k(0.25)) * k(std::f64::consts::TAU);
    let x2 = x * x;
    let s = x
        * (k(1.0)
            + x2 * (k(-1.0 / 6.0)
                + x2 * (k(1.0 / 120.0)
                    + x2 * (k(-1.0 / 5040.0)
                        + x2 * (k(1.0 / 362880.0)
                            + x2 * (k(-1.0 / 39916800.0)
                                + x2 * (k(1.0 / 6227020800.0)
                                    + x2 * (k(-1.0 / 1307674368000.0)
                                        + x2 * k(1.0 / 355687428096000.0)))))))));
    let c = k(1.0)
        + x2 * (k(-0.5)
            + x2 * (k(1.0 / 24.0)
                + x2 * (k(-1.0 / 720.0)
                    + x2 * (k(1.0 / 40320.0)
                        + x2 * (k(-1.0 / 3628800.0)
                            + x2 * (k(1.0 / 479001600.0)
                                + x2 * (k(-1.0 / 87178291200.0) + x2 * k(1.0 / 20922789888000.0))))))));
    // Quadrant q (mod 4) of [c, s]: [c, s], [-s, c], [-c, -s], [s, -c]; as selects, so that loops of
    // points vectorise.
    let quadrant = q.to_u32();
    let [cos, sin] = if quadrant & 1 == 0 { [c, s] } else { [-s, c] };
    if quadrant & 2 == 0 {
        [cos, sin]
    } else {
        [-cos, -sin]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Within 4 ulps of libm's sin and cos of 2 pi t (whose own argument is rounded), in both
    /// precisions; exact at every quarter turn, where libm's cos(pi / 2) is 6e-17, not 0.
    #[test]
    fn cos_sin_by_turns_is_accurate_in_both_precisions() {
        let mut worst64 = 0.0f64;
        let mut worst32 = 0.0f64;
        let grid = (0..=4096).map(|i| i as f64 / 4096.0);
        let random = (0..100_000).map(|i| unit_interval(counter_hash(7, i)));
        for t in grid.chain(random) {
            let (sin, cos) = (std::f64::consts::TAU * t).sin_cos();
            let [c, s] = cos_sin_turns(t);
            worst64 = worst64.max((c - cos).abs().max((s - sin).abs()));
            let [c, s] = cos_sin_turns(t as f32);
            worst32 = worst32.max((c as f64 - cos).abs().max((s as f64 - sin).abs()));
        }
        println!("cos/sin by turns: worst error f64 {worst64:.2e}, f32 {worst32:.2e}");
        assert!(worst64 < 4.0 * f64::EPSILON && worst32 < 4.0 * f32::EPSILON as f64);
        for (t, expected) in [
            (0.0, [1.0, 0.0]),
            (0.25, [0.0, 1.0]),
            (0.5, [-1.0, 0.0]),
            (0.75, [0.0, -1.0]),
            (1.0, [1.0, 0.0]),
        ] {
            let [c, s] = cos_sin_turns(t);
            assert!(c == expected[0] && s == expected[1], "{t}: {c} {s}");
        }
    }

    /// The vectorised batch (`indexed_points_into`) gives `indexed_point`'s bits, from any first index.
    #[test]
    fn batched_indexed_points_are_the_single_points() {
        for sampling in [
            PupilSampling::Random { n: 5000, seed: 3 },
            PupilSampling::Fibonacci { n: 5000 },
        ] {
            let mut batch = vec![[9.0, 9.0]];
            assert!(sampling.indexed_points_into(17..4999, &mut batch));
            assert_eq!(batch[0], [9.0, 9.0]);
            for (j, point) in batch[1..].iter().enumerate() {
                assert_eq!(Some(*point), sampling.indexed_point(17 + j), "{sampling:?} {j}");
            }
        }
        let mut none = Vec::new();
        assert!(!PupilSampling::Grid { n: 4 }.indexed_points_into(0..3, &mut none) && none.is_empty());
    }

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
        for bad in [
            "hexapolar",
            "grid:0",
            "spiral:4",
            "random:x",
            "grid:5:3",
            "random:5:6:7",
        ] {
            assert!(bad.parse::<PupilSampling>().is_err(), "{bad}");
        }
        let message = "random:5:abc".parse::<PupilSampling>().unwrap_err();
        assert!(message.contains("the seed must be"), "{message}");
        assert_eq!(
            "random:10:3".parse::<PupilSampling>().unwrap(),
            PupilSampling::Random { n: 10, seed: 3 }
        );
    }
}
