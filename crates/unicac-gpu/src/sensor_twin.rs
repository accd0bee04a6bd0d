//! The plain-Rust twin of shaders/sensor.wgsl: the same functions in f32 with the same arithmetic in
//! the same order, one call of [`read_out_sample`] per kernel invocation. Its job is to say what the
//! kernel computes without a device: the kernel equals it but for draws within an ulp of a rounding
//! boundary (1.3e-5 of samples on lavapipe, one electron each; `--test sensor`), and it is held against the f64 CPU read-out (`unicac_image::isp::read_out`, the reference) and
//! against the Poisson and normal laws. Function names follow the shader.

// The literals are the shader's text, digit for digit, so that both read the same decimal.
#![allow(clippy::excessive_precision, clippy::approx_constant)]

use unicac_io::counter_random::{counter_hash, derive_seed};

/// The shader's `SensorParams` as values (the device's uniform block is `crate::sensor`'s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorConstants {
    pub noise_seed: u64,
    pub range_dn: f32,
    pub black_dn: f32,
    pub white_dn: f32,
    pub dn_per_electron: f32,
    pub read_noise_dn: f32,
}

/// WGSL reads an abstract literal as f64 and converts it to f32: the twin does the same.
#[inline]
fn c(v: f64) -> f32 {
    v as f32
}

const MAX_STEPS: u32 = 128;
const LN2_HI: f64 = 0.693145751953125;
const LN2_LO: f64 = 1.428606765330187e-6;
const INV_LN2: f64 = 1.4426950408889634;
const SQRT_2: f64 = 1.4142135623730951;
const SQRT_HALF: f64 = 0.7071067811865476;
const LN_ZERO: f64 = -1e30;
const HALF_LN_2PI: f64 = 0.9189385332046727;
const F32_EPSILON: f64 = 1.1920928955078125e-7;
const TWO_TO_MINUS_24: f64 = 5.9604644775390625e-8;

/// `ln_series`: 2 atanh(s).
pub fn ln_series(s: f32) -> f32 {
    let s2 = s * s;
    c(2.0)
        * s
        * (c(1.0)
            + s2 * (c(0.3333333333333333)
                + s2 * (c(0.2)
                    + s2 * (c(0.14285714285714285)
                        + s2 * (c(0.1111111111111111)
                            + s2 * (c(0.09090909090909091) + s2 * c(0.07692307692307693)))))))
}

/// `ln_f32`: ln x for x >= 0 (`LN_ZERO` at 0).
pub fn ln_f32(x: f32) -> f32 {
    if x <= 0.0 {
        return c(LN_ZERO);
    }
    let mut bits = x.to_bits();
    let mut e = (bits >> 23) as i32 - 127;
    if bits >> 23 == 0 {
        bits = (x * c(16777216.0)).to_bits();
        e = (bits >> 23) as i32 - 151;
    }
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    if m > c(SQRT_2) {
        m *= c(0.5);
        e += 1;
    }
    let ef = e as f32;
    ef * c(LN2_HI) + (ef * c(LN2_LO) + ln_series((m - c(1.0)) / (m + c(1.0))))
}

/// `ln1p_minus_f32`: ln(1 + d) - d for d > -1.
pub fn ln1p_minus_f32(d: f32) -> f32 {
    let u = c(1.0) + d;
    if u >= c(SQRT_HALF) && u <= c(SQRT_2) {
        let s = d / (c(2.0) + d);
        let s2 = s * s;
        return -d * d / (c(2.0) + d)
            + c(2.0)
                * s
                * s2
                * (c(0.3333333333333333)
                    + s2 * (c(0.2)
                        + s2 * (c(0.14285714285714285)
                            + s2 * (c(0.1111111111111111)
                                + s2 * (c(0.09090909090909091) + s2 * c(0.07692307692307693))))));
    }
    ln_f32(u) - d
}

/// `exp_f32`: e^x for -87 <= x <= 0.
pub fn exp_f32(x: f32) -> f32 {
    let y = x.max(c(-87.0));
    let n = (y * c(INV_LN2)).round_ties_even();
    let r = (y - n * c(LN2_HI)) - n * c(LN2_LO);
    let p = c(1.0)
        + r * (c(1.0)
            + r * (c(0.5)
                + r * (c(0.16666666666666666)
                    + r * (c(0.041666666666666664)
                        + r * (c(0.008333333333333333)
                            + r * (c(0.001388888888888889)
                                + r * (c(0.0001984126984126984) + r * c(2.48015873015873e-5))))))));
    p * f32::from_bits(((n as i32 + 127) as u32) << 23)
}

/// `round_half_away` (WGSL's `sign` is f32::signum here: x is not 0 on that branch).
pub fn round_half_away(x: f32) -> f32 {
    let t = x.trunc();
    if (x - t).abs() >= c(0.5) {
        t + x.signum()
    } else {
        t
    }
}

/// `Stream`: one sample's counter stream.
struct Stream {
    seed: u64,
    next: u32,
}

impl Stream {
    fn next_bits(&mut self) -> u64 {
        let bits = counter_hash(self.seed, u64::from(self.next));
        self.next += 1;
        bits
    }

    /// `uniform`: the top 24 bits in [0, 1).
    fn uniform(&mut self) -> f32 {
        ((self.next_bits() >> 40) as u32) as f32 * c(TWO_TO_MINUS_24)
    }

    /// `open_uniform`: (2n + 1) / 2^24 from the top 23 bits.
    fn open_uniform(&mut self) -> f32 {
        ((((self.next_bits() >> 41) as u32) << 1) | 1) as f32 * c(TWO_TO_MINUS_24)
    }
}

/// `normal_quantile`: Wichura's PPND7 (AS 241) in f32, for p in [2^-24, 1 - 2^-24].
pub fn normal_quantile(p: f32) -> f32 {
    let q = p - c(0.5);
    if q.abs() <= c(0.425) {
        let r = c(0.180625) - q * q;
        return q * (((c(59.10937472) * r + c(159.29113202)) * r + c(50.434271938)) * r + c(3.3871327179))
            / (((c(67.1875636) * r + c(78.757757664)) * r + c(17.895169469)) * r + c(1.0));
    }
    let r = (-ln_f32(if q < 0.0 { p } else { c(1.0) - p })).sqrt() - c(1.6);
    let z = (((c(0.17023821103) * r + c(1.3067284816)) * r + c(2.75681539)) * r + c(1.4234372777))
        / ((c(0.1202113297) * r + c(0.7370016425)) * r + c(1.0));
    if q < 0.0 {
        -z
    } else {
        z
    }
}

fn ln_small_factorial(k: u32) -> f32 {
    c(match k {
        2 => 0.6931471805599453,
        3 => 1.791759469228055,
        4 => 3.1780538303479458,
        5 => 4.787491742782046,
        6 => 6.579251212010101,
        7 => 8.525161361065415,
        8 => 10.60460290274525,
        9 => 12.801827480081469,
        _ => 0.0,
    })
}

/// `ln_poisson_probability` in f32.
pub fn ln_poisson_probability(k: f32, mean: f32) -> f32 {
    if k < c(10.0) {
        return k * ln_f32(mean) - mean - ln_small_factorial(k as u32);
    }
    let x = k + c(1.0);
    let inverse = c(1.0) / x;
    let inverse_squared = inverse * inverse;
    let stirling = inverse
        * (c(0.08333333333333333)
            - inverse_squared
                * (c(0.002777777777777778)
                    - inverse_squared
                        * (c(0.0007936507936507937) - inverse_squared * c(0.0005952380952380953))));
    let d = (mean - x) / x;
    k * ln1p_minus_f32(d) - d - c(0.5) * ln_f32(x) - c(HALF_LN_2PI) - stirling
}

fn poisson_by_inversion(stream: &mut Stream, mean: f32) -> f32 {
    let u = stream.uniform();
    let mut term = exp_f32(-mean);
    let mut cumulative = term;
    let mut k = 0u32;
    loop {
        if !(u > cumulative) || k >= MAX_STEPS {
            break;
        }
        k += 1;
        term *= mean / k as f32;
        if term <= cumulative * c(F32_EPSILON) {
            break;
        }
        cumulative += term;
    }
    k as f32
}

fn poisson_ptrs(stream: &mut Stream, mean: f32) -> f32 {
    let b = c(0.931) + c(2.53) * mean.sqrt();
    let a = c(-0.059) + c(0.02483) * b;
    let v_r = c(0.9277) - c(3.6224) / (b - c(2.0));
    let inverse_alpha = c(1.1239) + c(1.1328) / (b - c(3.4));
    let whole = mean.floor();
    let rest = (mean - whole) + c(0.43);
    for _ in 0..MAX_STEPS {
        let u = stream.uniform() - c(0.5);
        let v = stream.uniform();
        let us = c(0.5) - u.abs();
        if us <= 0.0 {
            continue;
        }
        let k = whole + ((c(2.0) * a / us + b) * u + rest).floor();
        if us >= c(0.07) && v <= v_r {
            return k;
        }
        if k < 0.0 || (us < c(0.013) && v > us) {
            continue;
        }
        let log_accept = ln_f32(v * inverse_alpha / (a / (us * us) + b));
        if log_accept <= ln_poisson_probability(k, mean) {
            return k;
        }
    }
    round_half_away(mean)
}

fn poisson(stream: &mut Stream, mean: f32) -> f32 {
    if !(mean > 0.0) {
        return 0.0;
    }
    if mean < c(10.0) {
        return poisson_by_inversion(stream, mean);
    }
    poisson_ptrs(stream, mean)
}

/// A Poisson draw of stream `seed` as the kernel makes it (for the law tests).
pub fn poisson_draw(seed: u64, mean: f32) -> f32 {
    poisson(&mut Stream { seed, next: 0 }, mean)
}

/// A standard normal draw of stream `seed`'s first number, as the kernel makes it.
pub fn normal_draw(seed: u64) -> f32 {
    let mut stream = Stream { seed, next: 0 };
    normal_quantile(stream.open_uniform())
}

/// The kernel's `read_out` for the sample at `index` of the image whose exposure is `exposure`.
pub fn read_out_sample(constants: &SensorConstants, index: u32, exposure: f32) -> f32 {
    let (electrons, z) = sample_draws(constants, index, exposure);
    let signal = constants.dn_per_electron * electrons + constants.read_noise_dn * z;
    round_half_away(constants.black_dn + signal).clamp(0.0, constants.white_dn)
}

/// The photo-electrons and the standard normal value the sample at `index` draws.
pub fn sample_draws(constants: &SensorConstants, index: u32, exposure: f32) -> (f32, f32) {
    let above_black = exposure.max(0.0) * constants.range_dn;
    let mut stream = Stream {
        seed: derive_seed(constants.noise_seed, u64::from(index)),
        next: 0,
    };
    let electrons = poisson(&mut stream, above_black / constants.dn_per_electron);
    (electrons, normal_quantile(stream.open_uniform()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logarithm_and_exponential_are_within_a_few_ulps_of_the_library() {
        let mut worst_ln = 0.0f64;
        for i in 0..200_000u32 {
            // Every binade from 1e-40 (subnormal) to 1e30, and the neighbourhood of 1.
            let x = 10f64.powf(-40.0 + 70.0 * f64::from(i) / 200_000.0) as f32;
            for x in [x, 1.0 + (x - 0.5).clamp(-0.4, 0.4) * 1e-3] {
                let exact = f64::from(x).ln();
                let error = (f64::from(ln_f32(x)) - exact).abs() / exact.abs().max(1e-3);
                worst_ln = worst_ln.max(error);
            }
        }
        let mut worst_exp = 0.0f64;
        for i in 0..100_000u32 {
            let x = (-87.0 * f64::from(i) / 100_000.0) as f32;
            let exact = f64::from(x).exp();
            worst_exp = worst_exp.max((f64::from(exp_f32(x)) - exact).abs() / exact);
        }
        let mut worst_ln1p = 0.0f64;
        let small = (0..2000).map(|i| 10f64.powf(-8.0 + 7.0 * f64::from(i) / 2000.0));
        for d in (1..100_000u32)
            .map(|i| -0.99 + 2.0 * f64::from(i) / 100_000.0)
            .chain(small.flat_map(|d| [d, -d]))
        {
            let d = d as f32;
            let exact = f64::from(d).ln_1p() - f64::from(d);
            if exact != 0.0 {
                worst_ln1p = worst_ln1p.max((f64::from(ln1p_minus_f32(d)) - exact).abs() / exact.abs());
            }
        }
        eprintln!("relative error: ln {worst_ln:.2e}, exp {worst_exp:.2e}, ln(1 + d) - d {worst_ln1p:.2e}");
        // f32's epsilon is 1.2e-7; x = 1 + tiny rounds its argument, hence the relative floor of 1e-3.
        assert!(worst_ln < 5e-7, "ln: {worst_ln}");
        assert!(worst_exp < 1e-6, "exp: {worst_exp}");
        // Outside the series' range ln(1 + d) - d cancels by up to ~7x (d = -0.29): a few ulps more.
        assert!(worst_ln1p < 3e-6, "ln(1 + d) - d: {worst_ln1p}");
        assert_eq!(ln_f32(0.0), c(LN_ZERO));
        assert_eq!(exp_f32(0.0), 1.0);
    }

    #[test]
    fn the_f32_quantile_and_log_probability_follow_the_f64_ones() {
        use unicac_io::counter_draws::{inverse_normal_cdf, ln_poisson_probability as reference};
        let tails = (0..2000).map(|i| 10f64.powf(-7.2 + 5.0 * f64::from(i) / 2000.0));
        for p in (1..10_000u32).map(|i| f64::from(i) / 10_000.0).chain(tails) {
            let (z, exact) = (normal_quantile(p as f32), inverse_normal_cdf(f64::from(p as f32)));
            assert!(
                (f64::from(z) - exact).abs() < 2e-6 * exact.abs().max(1.0),
                "p {p}: {z} vs {exact}"
            );
        }
        for mean in [10.0f32, 37.5, 1000.0, 6000.0, 400_000.0] {
            let spread = 12.0 * mean.sqrt();
            for step in 0..=200 {
                let k = (mean - spread + spread * step as f32 / 100.0).max(0.0).floor();
                let exact = reference(f64::from(k), f64::from(mean));
                let value = f64::from(ln_poisson_probability(k, mean));
                // f32 holds ln P to a few ulps of its size (no term cancels).
                let tolerance = 2e-6 * exact.abs().max(1.0);
                assert!(
                    (value - exact).abs() <= tolerance,
                    "mean {mean}, k {k}: {value} vs {exact}"
                );
            }
        }
    }
}
