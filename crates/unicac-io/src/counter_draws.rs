//! Random draws from the counter-based source ([`crate::counter_random`]): uniform, standard normal and
//! Poisson variates of one sample's own stream, so that every sample of an image is drawn independently
//! of the others (in parallel on the CPU, one invocation per sample on a GPU) and the same seed gives
//! the same draws on any thread count. Hand-written because the GPU must repeat them with the same
//! arithmetic; `rand_distr`'s samplers pull from a sequential stream.
//!
//! - Standard normal: the inverse distribution function at one uniform (Acklam's approximation).
//! - Poisson, mean < [`POISSON_INVERSION_BELOW`]: inversion by sequential search (one uniform).
//! - Poisson, larger means: Hörmann's transformed rejection with squeeze, PTRS (W. Hörmann, "The
//!   transformed rejection method for generating Poisson random variables", Insurance: Mathematics and
//!   Economics 12, 1993), two uniforms per attempt, 1.1-1.3 attempts on average.

use crate::counter_random::{counter_hash, unit_interval};

/// Means below this are drawn by inversion; PTRS is valid from 10 on (Hörmann 1993).
pub const POISSON_INVERSION_BELOW: f64 = 10.0;

/// Attempts (PTRS) or terms (inversion) a draw may take: bounds the work per sample. PTRS accepts
/// 75% of its attempts at a mean of 10 and ~88% at large means, and inversion below 10 needs more than
/// 60 terms with a chance below 1e-40, so the bound is never met in practice; PTRS then returns its
/// mean rounded.
const MAX_STEPS: u32 = 128;

/// One sample's stream: its uniforms are counter_hash(seed, 0), counter_hash(seed, 1), ...
#[derive(Debug, Clone, Copy)]
pub struct CounterStream {
    seed: u64,
    next: u64,
}

impl CounterStream {
    pub fn new(seed: u64) -> Self {
        CounterStream { seed, next: 0 }
    }

    /// The stream's next 64 random bits.
    #[inline]
    fn next_bits(&mut self) -> u64 {
        let bits = counter_hash(self.seed, self.next);
        self.next += 1;
        bits
    }

    /// A uniform value in [0, 1).
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        unit_interval(self.next_bits())
    }

    /// A standard normal value: the inverse of the normal distribution function at one uniform
    /// (P. J. Acklam's rational approximation, relative error below 1.2e-9: far below what sensor
    /// noise needs, and without Box-Muller's logarithm and cosine in the central 95%).
    #[inline]
    pub fn standard_normal(&mut self) -> f64 {
        inverse_normal_cdf(open_unit_interval(self.next_bits()))
    }

    /// A Poisson variate of mean `mean`: 0 for a mean that is not > 0 (NaN included), the mean itself
    /// when it is infinite (a saturated sensor stays saturated).
    #[inline]
    pub fn poisson(&mut self, mean: f64) -> f64 {
        if mean.is_nan() || mean <= 0.0 {
            return 0.0;
        }
        if mean == f64::INFINITY {
            return mean;
        }
        if mean < POISSON_INVERSION_BELOW {
            self.poisson_by_inversion(mean)
        } else {
            self.poisson_ptrs(mean)
        }
    }

    fn poisson_by_inversion(&mut self, mean: f64) -> f64 {
        let u = self.uniform();
        let mut term = (-mean).exp();
        let mut cumulative = term;
        let mut k = 0u32;
        while u > cumulative && k < MAX_STEPS {
            k += 1;
            term *= mean / f64::from(k);
            // The terms no longer move the sum: u sits in the rounding gap just below 1.
            if term <= cumulative * f64::EPSILON {
                break;
            }
            cumulative += term;
        }
        f64::from(k)
    }

    // Inlined into callers compiled for a wider instruction set (the read-out's `pulp` dispatch), where
    // `floor` is one instruction rather than a libm call.
    #[inline(always)]
    fn poisson_ptrs(&mut self, mean: f64) -> f64 {
        let ptrs = Ptrs::new(mean);
        for _ in 0..MAX_STEPS {
            let (first, v) = (self.uniform(), self.uniform());
            let attempt = ptrs.attempt(mean, first, v);
            if attempt.squeezed {
                return attempt.k;
            }
            let (k, us) = (attempt.k, attempt.us);
            if k < 0.0 || (us < 0.013 && v > us) {
                continue;
            }
            // The exact test (~0.8 per draw at a mean of 10, ~0.2 at large means), whose logarithms
            // the squeeze above spares.
            let inverse_alpha = 1.1239 + 1.1328 / (ptrs.b - 3.4);
            let log_accept = (v * inverse_alpha / (ptrs.a / (us * us) + ptrs.b)).ln();
            if log_accept <= ln_poisson_probability(k, mean) {
                return k;
            }
        }
        mean.round()
    }
}

/// A Poisson draw of `mean` then a standard normal draw from the fresh stream `seed`, in their common
/// case only and without a branch, so that a loop over samples vectorises: the first PTRS attempt
/// accepted by its squeeze (~35% of draws at a mean of 10, ~80% at large means) and a normal quantile
/// from Acklam's central branch (95%): 68% of pairs at a mean of 250, 74% at 6,000.
///
/// Returns (Poisson, normal, taken): when `taken`, the pair is what `CounterStream::new(seed)` gives by
/// `poisson(mean)` then `standard_normal()`, bit for bit (the same functions compute it); otherwise the
/// values mean nothing and the caller draws the sequential way.
#[inline(always)]
pub fn common_poisson_then_normal(seed: u64, mean: f64) -> (f64, f64, bool) {
    let uniform = |counter| unit_interval(counter_hash(seed, counter));
    let attempt = Ptrs::new(mean).attempt(mean, uniform(0), uniform(1));
    let p = open_unit_interval(counter_hash(seed, 2));
    let taken = (POISSON_INVERSION_BELOW..f64::INFINITY).contains(&mean)
        & attempt.squeezed
        & (P_LOW..=1.0 - P_LOW).contains(&p);
    (attempt.k, central_normal_quantile(p), taken)
}

/// Hörmann's PTRS constants for one mean.
#[derive(Clone, Copy)]
struct Ptrs {
    b: f64,
    a: f64,
    v_r: f64,
}

/// One PTRS attempt: the candidate `k`, the distance `us` of the first uniform from the ends, and
/// whether the squeeze accepts `k` without the exact test.
struct PtrsAttempt {
    k: f64,
    us: f64,
    squeezed: bool,
}

impl Ptrs {
    #[inline(always)]
    fn new(mean: f64) -> Self {
        let b = 0.931 + 2.53 * mean.sqrt();
        Ptrs {
            b,
            a: -0.059 + 0.02483 * b,
            v_r: 0.9277 - 3.6224 / (b - 2.0),
        }
    }

    /// The attempt whose uniforms (in [0, 1)) are `first` and `v`; branch-free.
    #[inline(always)]
    fn attempt(&self, mean: f64, first: f64, v: f64) -> PtrsAttempt {
        let u = first - 0.5;
        let us = 0.5 - u.abs();
        let k = ((2.0 * self.a / us + self.b) * u + mean + 0.43).floor();
        PtrsAttempt {
            k,
            us,
            squeezed: (us >= 0.07) & (v <= self.v_r),
        }
    }
}

/// The top 52 bits as a value strictly inside (0, 1): (n + 1/2) / 2^52, from 2^-53 to 1 - 2^-53, both
/// exact in f64 (with 53 bits the largest value would round to 1, whose quantile is infinite).
pub fn open_unit_interval(bits: u64) -> f64 {
    ((bits >> 12) as f64 + 0.5) * (1.0 / (1u64 << 52) as f64)
}

/// Below this p (and above 1 - P_LOW) Acklam's quantile takes its tail branch.
const P_LOW: f64 = 0.02425;

/// The standard normal quantile at p in (0, 1) (Acklam's algorithm: a rational function of p in the
/// centre, of sqrt(-2 ln q) in the tails below 0.02425 and above 0.97575).
pub fn inverse_normal_cdf(p: f64) -> f64 {
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        let t = (-2.0 * q.ln()).sqrt();
        (((((C[0] * t + C[1]) * t + C[2]) * t + C[3]) * t + C[4]) * t + C[5])
            / ((((D[0] * t + D[1]) * t + D[2]) * t + D[3]) * t + 1.0)
    };
    if p < P_LOW {
        tail(p)
    } else if p <= 1.0 - P_LOW {
        central_normal_quantile(p)
    } else {
        -tail(1.0 - p)
    }
}

/// Acklam's central branch, for P_LOW <= p <= 1 - P_LOW.
#[inline(always)]
fn central_normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    let q = p - 0.5;
    let r = q * q;
    (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
        / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
}

/// ln(k!) for a whole number k >= 0: sums of logarithms below 10, Stirling's series of ln Γ(k + 1)
/// (to 1/x^7) above, whose truncation error there is below 1e-12.
pub fn ln_factorial(k: f64) -> f64 {
    if k < 10.0 {
        return (2..=k as u32).map(|i| f64::from(i).ln()).sum();
    }
    let x = k + 1.0;
    (x - 0.5) * x.ln() - x + 0.5 * std::f64::consts::TAU.ln() + stirling_series(x)
}

/// ln P(K = k) = k ln(mean) - mean - ln k! of a Poisson law, for a whole number k >= 0, written so that
/// its large terms do not cancel where k is near a large mean (the PTRS exact test's case): with
/// x = k + 1 and Stirling's series for ln k!, the difference k ln(mean) - (x - 1/2) ln x is written as
/// k ln(1 + (mean - x) / x) minus half of ln x, so no term grows like mean ln(mean). (The f32 kernel
/// of shaders/sensor.wgsl goes one step further, k (ln(1 + d) - d) - d, where f64 does not need to.)
pub fn ln_poisson_probability(k: f64, mean: f64) -> f64 {
    if k < 10.0 {
        return k * mean.ln() - mean - ln_factorial(k);
    }
    let x = k + 1.0;
    k * ((mean - x) / x).ln_1p() - 0.5 * x.ln() + (x - mean)
        - 0.5 * std::f64::consts::TAU.ln()
        - stirling_series(x)
}

/// 1/(12x) - 1/(360x^3) + 1/(1260x^5) - 1/(1680x^7): Stirling's series of ln Γ(x) past its leading
/// terms.
fn stirling_series(x: f64) -> f64 {
    let inverse = 1.0 / x;
    let inverse_squared = inverse * inverse;
    inverse
        * (1.0 / 12.0
            - inverse_squared * (1.0 / 360.0 - inverse_squared * (1.0 / 1260.0 - inverse_squared / 1680.0)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::counter_random::derive_seed;

    /// ln k! by summing logarithms, k = 0..=n.
    fn summed_ln_factorials(n: usize) -> Vec<f64> {
        let mut table = vec![0.0; n + 1];
        for k in 1..=n {
            table[k] = table[k - 1] + (k as f64).ln();
        }
        table
    }

    #[test]
    fn ln_factorial_matches_summed_logarithms() {
        let table = summed_ln_factorials(20_000);
        for (k, &exact) in table.iter().enumerate() {
            let error = (ln_factorial(k as f64) - exact).abs();
            assert!(
                error <= 1e-12 * exact.max(1.0),
                "ln {k}! = {} vs {exact}",
                ln_factorial(k as f64)
            );
        }
    }

    #[test]
    fn the_poisson_log_probability_matches_summed_logarithms_near_and_far_from_the_mean() {
        let table = summed_ln_factorials(20_000);
        for mean in [10.0f64, 37.5, 1000.0, 6000.0] {
            let spread = 12.0 * mean.sqrt();
            let low = (mean - spread).max(0.0) as usize;
            let high = (mean + spread) as usize;
            for (k, ln_k_factorial) in table.iter().enumerate().take(high + 1).skip(low) {
                let reference = k as f64 * mean.ln() - mean - ln_k_factorial;
                // The reference's own rounding: its terms reach k ln(mean).
                let tolerance = 1e-12 * (k as f64 * mean.ln()).max(1.0);
                let value = ln_poisson_probability(k as f64, mean);
                assert!(
                    (value - reference).abs() <= tolerance,
                    "mean {mean}, k {k}: {value} vs {reference}"
                );
            }
        }
    }

    /// Pearson's chi-square of `counts` against `probabilities`, with every bin of fewer than 5
    /// expected draws merged into its neighbour; returns (statistic, degrees of freedom).
    fn chi_square(counts: &[f64], probabilities: &[f64], draws: f64) -> (f64, usize) {
        let (mut statistic, mut bins) = (0.0, 0usize);
        let (mut observed, mut expected) = (0.0, 0.0);
        for (&c, &p) in counts.iter().zip(probabilities) {
            observed += c;
            expected += p * draws;
            if expected >= 5.0 {
                statistic += (observed - expected).powi(2) / expected;
                bins += 1;
                (observed, expected) = (0.0, 0.0);
            }
        }
        if expected > 0.0 {
            statistic += (observed - expected).powi(2) / expected.max(1e-300);
            bins += 1;
        }
        (statistic, bins - 1)
    }

    /// The chi-square value a correct sampler exceeds with chance ~3e-5 (Wilson-Hilferty, z = 4).
    fn chi_square_bound(freedom: usize) -> f64 {
        let d = freedom as f64;
        d * (1.0 - 2.0 / (9.0 * d) + 4.0 * (2.0 / (9.0 * d)).sqrt()).powi(3)
    }

    #[test]
    fn poisson_draws_follow_the_poisson_law_on_both_sides_of_the_method_switch() {
        let draws = 200_000usize;
        for (m, mean) in [0.05f64, 0.7, 3.0, 9.99, 10.0, 17.3, 250.0, 6000.0, 400_000.0]
            .into_iter()
            .enumerate()
        {
            let high = (mean + 12.0 * mean.sqrt() + 30.0) as usize;
            let table = summed_ln_factorials(high);
            let probabilities: Vec<f64> = (0..=high)
                .map(|k| (k as f64 * f64::ln(mean) - mean - table[k]).exp())
                .collect();
            let mut counts = vec![0.0; high + 1];
            let seed = derive_seed(77, m as u64);
            for i in 0..draws {
                let k = CounterStream::new(derive_seed(seed, i as u64)).poisson(mean);
                assert!(k >= 0.0 && k.fract() == 0.0, "mean {mean}: draw {k}");
                counts[(k as usize).min(high)] += 1.0;
            }
            let (statistic, freedom) = chi_square(&counts, &probabilities, draws as f64);
            eprintln!("mean {mean}: chi-square {statistic:.1} on {freedom} degrees of freedom");
            assert!(
                statistic < chi_square_bound(freedom),
                "mean {mean}: chi-square {statistic} on {freedom} degrees of freedom"
            );
        }
    }

    #[test]
    fn the_normal_quantile_matches_published_values_within_its_stated_error() {
        // (p, Φ⁻¹(p)) from the normal distribution function's published values.
        let known = [
            (0.5, 0.0),
            (0.841_344_746_068_542_9, 1.0),
            (0.9, 1.281_551_565_544_600_4),
            (0.975, 1.959_963_984_540_054),
            (0.977_249_868_051_820_8, 2.0),
            (0.99, 2.326_347_874_040_841),
            (0.998_650_101_968_369_9, 3.0),
            (0.999, 3.090_232_306_167_813),
            (1e-6, -4.753_424_308_822_899),
            (1e-12, -7.034_483_825_994_47),
        ];
        for (p, z) in known {
            // 1 - p is exact enough to mirror except for the smallest p.
            let mirrored = if p > 1e-9 { vec![(1.0 - p, -z)] } else { vec![] };
            for (p, z) in [(p, z)].into_iter().chain(mirrored) {
                let error = (inverse_normal_cdf(p) - z).abs();
                assert!(
                    error <= 1.2e-9 * z.abs().max(1.0),
                    "Φ⁻¹({p}) = {} vs {z}",
                    inverse_normal_cdf(p)
                );
            }
        }
    }

    #[test]
    fn the_normal_draw_stays_finite_at_both_ends_of_the_hash() {
        for bits in [0, 1, u64::MAX - 1, u64::MAX] {
            let p = open_unit_interval(bits);
            assert!(p > 0.0 && p < 1.0, "{bits:#x}: p {p}");
            let z = inverse_normal_cdf(p);
            assert!(z.is_finite() && z.abs() < 8.3, "{bits:#x}: z {z}");
        }
    }

    #[test]
    fn standard_normal_draws_fill_equal_probability_bins_evenly() {
        // The standard normal's deciles.
        let deciles = [
            -1.2816, -0.8416, -0.5244, -0.2533, 0.0, 0.2533, 0.5244, 0.8416, 1.2816,
        ];
        let draws = 200_000usize;
        let mut counts = [0.0; 10];
        let (mut sum, mut squares) = (0.0, 0.0);
        for i in 0..draws {
            let z = CounterStream::new(derive_seed(5, i as u64)).standard_normal();
            sum += z;
            squares += z * z;
            counts[deciles.iter().filter(|&&d| z > d).count()] += 1.0;
        }
        let (statistic, freedom) = chi_square(&counts, &[0.1; 10], draws as f64);
        let n = draws as f64;
        assert!(statistic < chi_square_bound(freedom), "chi-square {statistic}");
        assert!((sum / n).abs() < 4.0 / n.sqrt(), "mean {}", sum / n);
        assert!(
            (squares / n - 1.0).abs() < 4.0 * (2.0 / n).sqrt(),
            "variance {}",
            squares / n
        );
    }

    #[test]
    fn the_common_case_gives_the_sequential_draws_bit_for_bit() {
        for mean in [
            9.99f64,
            10.0,
            17.3,
            250.0,
            6000.0,
            400_000.0,
            f64::INFINITY,
            0.0,
            f64::NAN,
        ] {
            let draws = 20_000u64;
            let mut taken_count = 0u64;
            for i in 0..draws {
                let seed = derive_seed(31, i);
                let (poisson, normal, taken) = common_poisson_then_normal(seed, mean);
                if taken {
                    taken_count += 1;
                    let mut stream = CounterStream::new(seed);
                    let sequential = (stream.poisson(mean), stream.standard_normal());
                    assert_eq!(
                        (poisson.to_bits(), normal.to_bits()),
                        (sequential.0.to_bits(), sequential.1.to_bits()),
                        "mean {mean}, draw {i}"
                    );
                }
            }
            let share = taken_count as f64 / draws as f64;
            eprintln!("mean {mean}: common case {share:.3}");
            // Inversion's means, the infinite and the empty mean are never taken; PTRS's squeeze accepts
            // ~35% of first attempts at a mean of 10 and ~80% at large means, the normal's centre holds
            // 95% (this seed: 33% of pairs at 10, 68% at 250, 74% at 6000).
            if (10.0..f64::INFINITY).contains(&mean) {
                assert!(share > 0.3, "mean {mean}: common case {share}");
            } else {
                assert_eq!(taken_count, 0, "mean {mean}");
            }
        }
    }

    #[test]
    fn a_stream_is_a_pure_function_of_its_seed() {
        let draw = |seed| {
            let mut s = CounterStream::new(seed);
            [s.poisson(3.0), s.poisson(500.0), s.standard_normal(), s.uniform()]
        };
        assert_eq!(draw(11), draw(11));
        assert_ne!(draw(11), draw(12));
        for mean in [0.0, -1.0, f64::NAN, f64::NEG_INFINITY] {
            assert_eq!(CounterStream::new(1).poisson(mean), 0.0, "mean {mean}");
        }
        assert_eq!(CounterStream::new(1).poisson(f64::INFINITY), f64::INFINITY);
    }
}
