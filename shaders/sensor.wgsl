// The sensor read-out of `unicac_image::isp::read_out` on the device, f32, one invocation per sample:
// sample i draws from its own counter stream derive_seed(noise_seed, i) (unicac_io::counter_draws),
// first its photo-electrons (Poisson: inversion below a mean of 10, Hörmann's PTRS above), then its
// read noise (an inverse normal distribution function), and reads out
// clamp(round(black + K n + sigma z), 0, white). Joined after counter.wgsl.
//
// Logarithm and exponential are evaluated here (range reduction by the exponent bits, short series),
// not by WGSL's built-ins, whose accuracy the standard leaves to the driver: with the same arithmetic
// the Rust twin (crates/unicac-gpu/src/sensor_twin.rs) gives the same bits. Named constants are written
// as plain literals, never as constant expressions (those are evaluated in abstract precision).

struct SensorParams {
    seed_lo: u32,
    seed_hi: u32,
    // This dispatch's band: `rows` rows of `width` samples, whose first sample has index `first` in the
    // image (planes stacked; the stream of sample i is first + row * width + column).
    width: u32,
    rows: u32,
    first: u32,
    // White minus black level (DN), as the CPU's (W - B).
    range_dn: f32,
    black_dn: f32,
    white_dn: f32,
    dn_per_electron: f32,
    read_noise_dn: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> sensor: SensorParams;
@group(0) @binding(1) var<storage, read> exposure: array<f32>;
@group(0) @binding(2) var<storage, read_write> raw_dn: array<f32>;

// Attempts (PTRS) or terms (inversion) a draw may take (MAX_STEPS of counter_draws).
const MAX_STEPS: u32 = 128u;
// ln 2 split so that e * LN2_HI is exact for |e| < 512 (its low 9 mantissa bits are zero).
const LN2_HI: f32 = 0.693145751953125;
const LN2_LO: f32 = 1.428606765330187e-6;
const INV_LN2: f32 = 1.4426950408889634;
const SQRT_2: f32 = 1.4142135623730951;
const SQRT_HALF: f32 = 0.7071067811865476;
// Stands for ln 0 = -infinity (WGSL need not keep infinities): below every log-probability.
const LN_ZERO: f32 = -1e30;
const HALF_LN_2PI: f32 = 0.9189385332046727;
const F32_EPSILON: f32 = 1.1920928955078125e-7;

// ln((1 + s) / (1 - s)) = 2 atanh(s) for |s| <= 0.1716 (truncation below 5e-11).
fn ln_series(s: f32) -> f32 {
    let s2 = s * s;
    return 2.0 * s * (1.0 + s2 * (0.3333333333333333 + s2 * (0.2 + s2 * (0.14285714285714285
        + s2 * (0.1111111111111111 + s2 * (0.09090909090909091 + s2 * 0.07692307692307693))))));
}

// ln x for x >= 0: x = 2^e m with m in [sqrt(1/2), sqrt(2)), ln m = ln_series((m - 1) / (m + 1)).
fn ln_f32(x: f32) -> f32 {
    if (x <= 0.0) {
        return LN_ZERO;
    }
    var bits = bitcast<u32>(x);
    var e = i32(bits >> 23u) - 127;
    if ((bits >> 23u) == 0u) {
        // Subnormal: scale by 2^24 first.
        bits = bitcast<u32>(x * 16777216.0);
        e = i32(bits >> 23u) - 151;
    }
    var m = bitcast<f32>((bits & 0x007fffffu) | 0x3f800000u);
    if (m > SQRT_2) {
        m = m * 0.5;
        e = e + 1;
    }
    let ef = f32(e);
    return ef * LN2_HI + (ef * LN2_LO + ln_series((m - 1.0) / (m + 1.0)));
}

// ln(1 + d) - d for d > -1, without cancellation near d = 0: with s = d / (2 + d),
// ln(1 + d) = 2 atanh(s), and 2 s - d = -d^2 / (2 + d) exactly, so the series keeps only small terms.
fn ln1p_minus_f32(d: f32) -> f32 {
    let u = 1.0 + d;
    if (u >= SQRT_HALF && u <= SQRT_2) {
        let s = d / (2.0 + d);
        let s2 = s * s;
        return -d * d / (2.0 + d) + 2.0 * s * s2 * (0.3333333333333333 + s2 * (0.2 + s2 * (0.14285714285714285
            + s2 * (0.1111111111111111 + s2 * (0.09090909090909091 + s2 * 0.07692307692307693)))));
    }
    return ln_f32(u) - d;
}

// e^x for -87 <= x <= 0 (smaller x are taken as -87): x = n ln 2 + r, |r| <= ln(2)/2, Taylor to r^8.
fn exp_f32(x: f32) -> f32 {
    let y = max(x, -87.0);
    let n = round(y * INV_LN2);
    let r = (y - n * LN2_HI) - n * LN2_LO;
    let p = 1.0 + r * (1.0 + r * (0.5 + r * (0.16666666666666666 + r * (0.041666666666666664
        + r * (0.008333333333333333 + r * (0.001388888888888889 + r * (0.0001984126984126984
        + r * 2.48015873015873e-5)))))));
    return p * bitcast<f32>(u32(i32(n) + 127) << 23u);
}

// Rounding half away from zero, as the CPU's f64::round.
fn round_half_away(x: f32) -> f32 {
    let t = trunc(x);
    return select(t, t + sign(x), abs(x - t) >= 0.5);
}

struct Stream {
    seed: vec2<u32>,
    next: u32,
}

fn next_bits(stream: ptr<function, Stream>) -> vec2<u32> {
    let bits = counter_hash((*stream).seed, vec2<u32>((*stream).next, 0u));
    (*stream).next = (*stream).next + 1u;
    return bits;
}

// The top 24 bits as a uniform value in [0, 1) (the CPU's top 53, truncated).
fn uniform_draw(stream: ptr<function, Stream>) -> f32 {
    return f32(next_bits(stream).y >> 8u) * 5.9604644775390625e-8;
}

// The top 23 bits n as (2n + 1) / 2^24: strictly inside (0, 1), exact in f32.
fn open_uniform(stream: ptr<function, Stream>) -> f32 {
    return f32(((next_bits(stream).y >> 9u) << 1u) | 1u) * 5.9604644775390625e-8;
}

// The standard normal quantile at p in [2^-24, 1 - 2^-24] (the range open_uniform draws): Wichura's
// PPND7 (Applied Statistics algorithm AS 241, 1988), the single-precision member of his family, whose
// rational functions stay well conditioned in f32 (Acklam's, the CPU's in f64, cancel to 4e-5 near
// its region boundary in f32). Relative error below 4e-7 in f32; the branch for p < e^-25 is left
// out (no draw reaches it).
fn normal_quantile(p: f32) -> f32 {
    let q = p - 0.5;
    if (abs(q) <= 0.425) {
        let r = 0.180625 - q * q;
        return q * (((59.10937472 * r + 159.29113202) * r + 50.434271938) * r + 3.3871327179)
            / (((67.1875636 * r + 78.757757664) * r + 17.895169469) * r + 1.0);
    }
    let r = sqrt(-ln_f32(select(1.0 - p, p, q < 0.0))) - 1.6;
    let z = (((0.17023821103 * r + 1.3067284816) * r + 2.75681539) * r + 1.4234372777)
        / ((0.1202113297 * r + 0.7370016425) * r + 1.0);
    return select(z, -z, q < 0.0);
}

fn standard_normal(stream: ptr<function, Stream>) -> f32 {
    return normal_quantile(open_uniform(stream));
}

// ln k! for k = 0..9 (counter_draws sums logarithms there).
fn ln_small_factorial(k: u32) -> f32 {
    switch k {
        case 2u: { return 0.6931471805599453; }
        case 3u: { return 1.791759469228055; }
        case 4u: { return 3.1780538303479458; }
        case 5u: { return 4.787491742782046; }
        case 6u: { return 6.579251212010101; }
        case 7u: { return 8.525161361065415; }
        case 8u: { return 10.60460290274525; }
        case 9u: { return 12.801827480081469; }
        default: { return 0.0; }
    }
}

// ln P(K = k) of a Poisson law (counter_draws::ln_poisson_probability): with x = k + 1 and
// d = (mean - x) / x, its k ln(1 + d) + (x - mean) is k (ln(1 + d) - d) - d, so no two large terms
// cancel in f32 even at a mean of 4e5 (where k ln(1 + d) alone reaches thousands).
fn ln_poisson_probability(k: f32, mean: f32) -> f32 {
    if (k < 10.0) {
        return k * ln_f32(mean) - mean - ln_small_factorial(u32(k));
    }
    let x = k + 1.0;
    let inverse = 1.0 / x;
    let inverse_squared = inverse * inverse;
    let stirling = inverse * (0.08333333333333333 - inverse_squared * (0.002777777777777778
        - inverse_squared * (0.0007936507936507937 - inverse_squared * 0.0005952380952380953)));
    let d = (mean - x) / x;
    return k * ln1p_minus_f32(d) - d - 0.5 * ln_f32(x) - HALF_LN_2PI - stirling;
}

fn poisson_by_inversion(stream: ptr<function, Stream>, mean: f32) -> f32 {
    let u = uniform_draw(stream);
    var term = exp_f32(-mean);
    var cumulative = term;
    var k = 0u;
    loop {
        if (!(u > cumulative) || k >= MAX_STEPS) {
            break;
        }
        k = k + 1u;
        term = term * (mean / f32(k));
        if (term <= cumulative * F32_EPSILON) {
            break;
        }
        cumulative = cumulative + term;
    }
    return f32(k);
}

// Hörmann's PTRS. k is formed as floor(mean) + floor(fraction of the mean + 0.43 + ...): the same
// whole number, but without rounding the mean's large integer part into the sum.
fn poisson_ptrs(stream: ptr<function, Stream>, mean: f32) -> f32 {
    let b = 0.931 + 2.53 * sqrt(mean);
    let a = -0.059 + 0.02483 * b;
    let v_r = 0.9277 - 3.6224 / (b - 2.0);
    let inverse_alpha = 1.1239 + 1.1328 / (b - 3.4);
    let whole = floor(mean);
    let rest = (mean - whole) + 0.43;
    for (var attempt = 0u; attempt < MAX_STEPS; attempt = attempt + 1u) {
        let u = uniform_draw(stream) - 0.5;
        let v = uniform_draw(stream);
        let us = 0.5 - abs(u);
        // us = 0 (u = -1/2) makes k = -infinity on the CPU: rejected there too.
        if (us <= 0.0) {
            continue;
        }
        let k = whole + floor((2.0 * a / us + b) * u + rest);
        if (us >= 0.07 && v <= v_r) {
            return k;
        }
        if (k < 0.0 || (us < 0.013 && v > us)) {
            continue;
        }
        let log_accept = ln_f32(v * inverse_alpha / (a / (us * us) + b));
        if (log_accept <= ln_poisson_probability(k, mean)) {
            return k;
        }
    }
    return round_half_away(mean);
}

fn poisson(stream: ptr<function, Stream>, mean: f32) -> f32 {
    if (!(mean > 0.0)) {
        return 0.0;
    }
    if (mean < 10.0) {
        return poisson_by_inversion(stream, mean);
    }
    return poisson_ptrs(stream, mean);
}

// One invocation per sample of the band.
@compute @workgroup_size(8, 8)
fn read_out(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= sensor.width || id.y >= sensor.rows) {
        return;
    }
    let i = id.y * sensor.width + id.x;
    let above_black = max(exposure[i], 0.0) * sensor.range_dn;
    let seed = derive_seed(vec2<u32>(sensor.seed_lo, sensor.seed_hi), vec2<u32>(sensor.first + i, 0u));
    var stream = Stream(seed, 0u);
    // A quotient, as the CPU's: a product here could be fused by the driver into its next use
    // (floor(mean) - mean became fma(above_black, 1/K, -floor) on lavapipe, moving k by one).
    let electrons = poisson(&stream, above_black / sensor.dn_per_electron);
    let signal = sensor.dn_per_electron * electrons + sensor.read_noise_dn * standard_normal(&stream);
    raw_dn[i] = clamp(round_half_away(sensor.black_dn + signal), 0.0, sensor.white_dn);
}
