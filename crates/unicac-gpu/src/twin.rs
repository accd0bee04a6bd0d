//! Plain-Rust twins of the WGSL kernels: the same functions, the same arithmetic in the same order and
//! the same loop shape (one "invocation" per ray index), in the same working type. The GPU-vs-CPU tests
//! compare each kernel with its twin (agreement to rounding: the GPU may fuse multiply-adds) and the
//! twins with the f64 reference tracer of unicac-trace (the parity figures of docs/gpu.md).
//!
//! Function names follow shaders/common.wgsl, trace.wgsl and psf.wgsl.

use crate::layout::{kind, pattern, GpuRay, Params, Surface};
use crate::real::Real;

// The shaders spell these out (WGSL has no imports from Rust); the parity tests hold them to the tracer's.
const MAX_NEWTON_ITERATIONS: u32 = unicac_trace::surface::MAX_NEWTON_ITERATIONS as u32;
use unicac_trace::surface::GRAZING_N;
/// 2^44 fixed-point units per unit weight (FIXED_SCALE in psf.wgsl).
pub const FIXED_SCALE: f64 = 17_592_186_044_416.0;

fn r<R: Real>(v: f64) -> R {
    R::from_f64(v)
}

fn status_word(kind: u32, surface: u32) -> u32 {
    kind | (surface << 8)
}

/// `guard`: whether `value` lies within GUARD * scale of `threshold`.
fn guard<R: Real>(undecided: &mut bool, value: R, threshold: R, scale: R) {
    if (value - threshold).abs() <= R::guard() * scale {
        *undecided = true;
    }
}

fn is_finite<R: Real>(v: R) -> bool {
    v.abs() <= R::MAX
}

/// `counter_hash` of common.wgsl (u32 pairs there, native u64 here).
pub use unicac_trace::pupil::counter_hash;

/// `unit_fraction`: the top 53 bits of a 64-bit fraction, as two exact partial products.
pub fn unit_fraction<R: Real>(bits: u64) -> R {
    let hi = (bits >> 32) as u32;
    let lo = bits as u32;
    let top = R::from_u32(hi >> 11) * r(4.76837158203125e-7);
    let rest = R::from_u32(((hi & 0x7ff) << 21) | (lo >> 11)) * r(1.1102230246251565e-16);
    top + rest
}

/// `cos_sin_turns` of common.wgsl: the CPU pupil patterns' own function (one polynomial in both
/// precisions).
pub use unicac_trace::pupil::cos_sin_turns;

// 2^64 (3 - sqrt 5) / 2, the golden angle in 64-bit fixed-point turns (the CPU pattern's own).
use unicac_trace::pupil::GOLDEN_TURNS;

/// `pupil_point`: (px, py, w) of pattern slot `index`; w = 0 for grid slots outside the disc.
pub fn pupil_point<R: Real>(params: &Params<R>, index: u32) -> [R; 3] {
    let n = params.pattern_n;
    let one = r::<R>(1.0);
    match params.pattern {
        pattern::HEXAPOLAR => {
            if index == 0 {
                return [r(0.0), r(0.0), one];
            }
            let mut ring = (((3.0 + (12.0 * index as f32 - 3.0).sqrt()) / 6.0) as u32).max(1);
            while 1 + 3 * ring * (ring - 1) > index {
                ring -= 1;
            }
            // (same comparison as the kernel: the first slot of ring + 1 is 1 + 3 (ring + 1) ring)
            #[allow(clippy::int_plus_one)]
            while 1 + 3 * (ring + 1) * ring <= index {
                ring += 1;
            }
            let k = index - (1 + 3 * ring * (ring - 1));
            let radius = R::from_u32(ring) / R::from_u32(n);
            let [c, s] = cos_sin_turns(R::from_u32(k) / R::from_u32(6 * ring));
            [radius * c, radius * s, one]
        }
        pattern::GRID => {
            let (i, j) = (index % n, index / n);
            let a = (2 * i + 1) as i64 - n as i64;
            let b = (2 * j + 1) as i64 - n as i64;
            let inside = a * a + b * b <= (n as i64) * (n as i64);
            let x = r::<R>(-1.0) + R::from_u32(2 * i + 1) / R::from_u32(n);
            let y = r::<R>(-1.0) + R::from_u32(2 * j + 1) / R::from_u32(n);
            [x, y, if inside { one } else { r(0.0) }]
        }
        pattern::FIBONACCI => {
            let radius = ((R::from_u32(index) + r(0.5)) / R::from_u32(n)).sqrt();
            let [c, s] = cos_sin_turns(unit_fraction::<R>((index as u64).wrapping_mul(GOLDEN_TURNS)));
            [radius * c, radius * s, one]
        }
        _ => {
            let seed = params.seed_lo as u64 | ((params.seed_hi as u64) << 32);
            let counter = 2 * index as u64;
            let u = unit_fraction::<R>(counter_hash(seed, counter));
            let v = unit_fraction::<R>(counter_hash(seed, counter | 1));
            let radius = u.sqrt();
            let [c, s] = cos_sin_turns(v);
            [radius * c, radius * s, one]
        }
    }
}

/// `aimed_ray`: paraxial aiming through (px, py) on the entrance-pupil plane.
pub fn aimed_ray<R: Real>(params: &Params<R>, px: R, py: R) -> GpuRay<R> {
    let sx = px * params.pupil_radius_mm;
    let sy = py * params.pupil_radius_mm;
    let d = if params.finite_object != 0 {
        [sx, sy - params.object_y_mm, params.object_to_pupil_mm]
    } else {
        [r(0.0), params.sin_field, params.cos_field]
    };
    let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    GpuRay {
        x: sx,
        y: sy,
        z: params.pupil_z_mm,
        l: d[0] / norm,
        m: d[1] / norm,
        n: d[2] / norm,
    }
}

/// `sag_and_slope`: sag and d(sag)/d(rho) of surface `s`.
pub fn sag_and_slope<R: Real>(s: &Surface<R>, rho: R) -> [R; 2] {
    let mut value = r::<R>(0.0);
    let mut slope = r::<R>(0.0);
    for i in (1..=s.terms).rev() {
        let a = s.coefficients[i as usize - 1];
        slope = slope * rho + R::from_u32(i) * a;
        value = value * rho + a;
    }
    let c = s.curvature_per_mm;
    let root = (r::<R>(1.0) - (r::<R>(1.0) + s.conic) * c * c * rho).sqrt();
    [
        c * rho / (r::<R>(1.0) + root) + value * rho,
        c / (r::<R>(2.0) * root) + slope,
    ]
}

/// `trace_step`: one surface; on failure the ray is left as it was. Sets `undecided` as the kernel's
/// private flag.
pub fn trace_step<R: Real>(
    surface: &Surface<R>,
    index: u32,
    ray: &mut GpuRay<R>,
    undecided: &mut bool,
) -> u32 {
    let zero = r::<R>(0.0);
    let one = r::<R>(1.0);
    let (l, m, n) = (ray.l, ray.m, ray.n);
    let (mut x, mut y, mut z) = (ray.x, ray.y, ray.z - surface.gap_mm);
    if n.abs() > r(GRAZING_N) {
        let t0 = -z / n;
        x = x + t0 * l;
        y = y + t0 * m;
        z = zero;
    }
    let c = surface.curvature_per_mm;
    let conic = surface.conic;
    let k1 = one + conic;
    let limit = surface.conic_rho_limit;
    let a = c * (one + conic * n * n);
    let b = n - c * (x * l + y * m + k1 * z * n);
    let f = c * (x * x + y * y + k1 * z * z) - r::<R>(2.0) * z;
    let discriminant = b * b - a * f;
    guard(undecided, discriminant, zero, b * b + (a * f).abs());
    if !(discriminant >= zero) {
        return status_word(kind::MISSED, index);
    }
    let root = discriminant.sqrt();
    let denominator = b + if b >= zero { root } else { -root };
    if denominator == zero && f != zero {
        return status_word(kind::MISSED, index);
    }
    let mut t = if f == zero { zero } else { f / denominator };
    {
        let (hx, hy, hz) = (x + t * l, y + t * m, z + t * n);
        guard(undecided, hx * hx + hy * hy, limit, limit);
        guard(undecided, c * k1 * hz, one, one);
        if hx * hx + hy * hy > limit || one - c * k1 * hz <= zero {
            return status_word(kind::MISSED, index);
        }
    }
    if surface.terms > 0 {
        let mut converged = false;
        for _ in 0..MAX_NEWTON_ITERATIONS {
            let (px, py, pz) = (x + t * l, y + t * m, z + t * n);
            let rho = px * px + py * py;
            if !(rho <= limit) {
                return status_word(kind::MISSED, index);
            }
            let [sag, slope] = sag_and_slope(surface, rho);
            let derivative = n - r::<R>(2.0) * slope * (px * l + py * m);
            if derivative == zero || !is_finite(derivative) {
                return status_word(kind::MISSED, index);
            }
            let dt = (pz - sag) / derivative;
            t = t - dt;
            if !is_finite(t) {
                return status_word(kind::MISSED, index);
            }
            if dt.abs()
                <= R::newton_tolerance() * (t.abs() + px.abs() + py.abs() + pz.abs()) + R::MIN_POSITIVE
            {
                converged = true;
                break;
            }
        }
        if !converged {
            return status_word(kind::NO_CONVERGENCE, index);
        }
    }
    let (px, py, pz) = (x + t * l, y + t * m, z + t * n);
    let rho = px * px + py * py;
    guard(undecided, rho, surface.clip_rho, surface.clip_rho);
    if !(rho <= surface.clip_rho) {
        return status_word(kind::CLIPPED, index);
    }
    if !(is_finite(px) && is_finite(py) && is_finite(pz)) {
        return status_word(kind::MISSED, index);
    }
    let mut d = [l, m, n];
    if surface.refract != 0 {
        let normal = if surface.terms > 0 {
            let slope = sag_and_slope(surface, rho)[1];
            [r::<R>(-2.0) * px * slope, r::<R>(-2.0) * py * slope, one]
        } else {
            [-c * px, -c * py, one - c * k1 * pz]
        };
        let mu = surface.mu;
        let q = normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2];
        let mut p = d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2];
        let mut sign = one;
        if p < zero {
            p = -p;
            sign = -one;
        }
        let radicand = q * (one - mu * mu) + mu * mu * p * p;
        guard(undecided, radicand, zero, q);
        if radicand < zero {
            return status_word(kind::TIR, index);
        }
        let g = sign * (radicand.sqrt() - mu * p) / q;
        d = [
            mu * d[0] + g * normal[0],
            mu * d[1] + g * normal[1],
            mu * d[2] + g * normal[2],
        ];
    }
    *ray = GpuRay {
        x: px,
        y: py,
        z: pz,
        l: d[0],
        m: d[1],
        n: d[2],
    };
    kind::OK
}

/// `trace_ray`: the status word, with UNDECIDED set when a decision was too close to call.
pub fn trace_ray<R: Real>(surfaces: &[Surface<R>], ray: &mut GpuRay<R>) -> u32 {
    let mut undecided = false;
    let status = trace_surfaces(surfaces, ray, &mut undecided);
    if undecided {
        status | kind::UNDECIDED
    } else {
        status
    }
}

/// `trace_surfaces`: every surface in turn.
fn trace_surfaces<R: Real>(surfaces: &[Surface<R>], ray: &mut GpuRay<R>, undecided: &mut bool) -> u32 {
    let finite = [ray.x, ray.y, ray.z, ray.l, ray.m, ray.n]
        .iter()
        .all(|v| is_finite(*v));
    if !finite {
        return status_word(kind::INVALID_INPUT, 0);
    }
    for (s, surface) in surfaces.iter().enumerate() {
        let status = trace_step(surface, s as u32, ray, undecided);
        if status != kind::OK {
            return status;
        }
    }
    kind::OK
}

/// `source_ray`: the host's ray, or the sampled and aimed one (and whether the slot is a ray at all).
fn source_ray<R: Real>(params: &Params<R>, host: &[GpuRay<R>], i: u32) -> (GpuRay<R>, bool) {
    if params.pattern == pattern::HOST_RAYS {
        return (host[i as usize], true);
    }
    let [px, py, w] = pupil_point(params, params.first_index + i);
    (aimed_ray(params, px, py), w != r(0.0))
}

/// `trace_rays` of trace.wgsl: returns rays, status words and the status histogram.
pub fn trace_kernel<R: Real>(
    params: &Params<R>,
    surfaces: &[Surface<R>],
    host: &[GpuRay<R>],
) -> (Vec<GpuRay<R>>, Vec<u32>, [u32; kind::COUNTERS]) {
    let mut counters = [0u32; kind::COUNTERS];
    let mut rays = Vec::with_capacity(params.ray_count as usize);
    let mut statuses = Vec::with_capacity(params.ray_count as usize);
    for i in 0..params.ray_count {
        let (mut ray, sampled) = source_ray(params, host, i);
        let status = if sampled {
            trace_ray(surfaces, &mut ray)
        } else {
            status_word(kind::NOT_SAMPLED, 0)
        };
        counters[(status & 0x7f) as usize] += 1;
        rays.push(ray);
        statuses.push(status);
    }
    (rays, statuses, counters)
}

/// `to_fixed` of psf.wgsl: a non-negative weight as 64-bit fixed point, rounded to nearest.
pub fn to_fixed<R: Real>(weight: R) -> u64 {
    let scaled = (weight * r(FIXED_SCALE) + r(0.5)).floor();
    let high = (scaled * r(2.3283064365386963e-10)).floor();
    let low = (scaled - high * r(4294967296.0)).to_u32();
    low as u64 | ((high.to_u32() as u64) << 32)
}

/// `splat` of psf.wgsl into a grid of 3 x fine^2 fixed-point cells (channel-major).
pub fn splat<R: Real>(params: &Params<R>, grid: &mut [u64], x_mm: R, y_mm: R) {
    let fine = params.fine_size;
    let centre = R::from_u32(fine) * r(0.5);
    let ox_um = (x_mm - params.chief_x_mm) * r(1000.0);
    let oy_um = -((y_mm - params.chief_y_mm) * r(1000.0));
    let fx = ox_um / params.sub_pitch_um + centre - r(0.5);
    let fy = oy_um / params.sub_pitch_um + centre - r(0.5);
    if !((fx - centre).abs() < centre + r(2.0) && (fy - centre).abs() < centre + r(2.0)) {
        return;
    }
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let weights = [params.weight_r, params.weight_g, params.weight_b];
    let (x0, y0) = (x0.to_f64() as i64, y0.to_f64() as i64);
    for dy in 0..2 {
        let y = y0 + dy;
        let wy = if dy == 1 { ty } else { r::<R>(1.0) - ty };
        for dx in 0..2 {
            let x = x0 + dx;
            let wx = if dx == 1 { tx } else { r::<R>(1.0) - tx };
            if x >= 0 && y >= 0 && (x as u32) < fine && (y as u32) < fine {
                let cell = y as usize * fine as usize + x as usize;
                for (c, w) in weights.iter().enumerate() {
                    let word = c * (fine * fine) as usize + cell;
                    grid[word] = grid[word].wrapping_add(to_fixed(*w * wx * wy));
                }
            }
        }
    }
}

/// `accumulate_psf` of psf.wgsl: traces and splats into `grid`, returns the status histogram.
pub fn accumulate_kernel<R: Real>(
    params: &Params<R>,
    surfaces: &[Surface<R>],
    host: &[GpuRay<R>],
    grid: &mut [u64],
) -> [u32; kind::COUNTERS] {
    let mut counters = [0u32; kind::COUNTERS];
    for i in 0..params.ray_count {
        let (mut ray, sampled) = source_ray(params, host, i);
        let status = if sampled {
            trace_ray(surfaces, &mut ray)
        } else {
            status_word(kind::NOT_SAMPLED, 0)
        };
        if status & 0x7f == kind::OK {
            splat(params, grid, ray.x, ray.y);
        }
        counters[(status & 0x7f) as usize] += 1;
    }
    counters
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::{ParaxialAim, PupilSource};
    use unicac_trace::PupilSampling;

    fn params_for(sampling: PupilSampling) -> Params<f64> {
        let mut params = Params::<f64>::default();
        PupilSource {
            sampling,
            aim: ParaxialAim {
                pupil_radius_mm: 1.0,
                pupil_z_mm: 0.0,
                field_deg: 0.0,
                object: None,
            },
        }
        .fill(&mut params);
        params
    }

    /// The device's pupil patterns (in their f64 twin) are the CPU's, bit for bit.
    #[test]
    fn device_pupil_sampling_reproduces_the_cpu_patterns() {
        for pattern in ["hexapolar:9", "grid:24", "fibonacci:3001", "random:3001:42"] {
            let sampling: PupilSampling = pattern.parse().unwrap();
            let params = params_for(sampling);
            let slots = match sampling {
                PupilSampling::Grid { n } => n * n,
                _ => sampling.points().len(),
            };
            let device: Vec<[f64; 2]> = (0..slots as u32)
                .map(|i| pupil_point(&params, i))
                .filter(|p| p[2] != 0.0)
                .map(|p| [p[0], p[1]])
                .collect();
            let cpu = sampling.points();
            assert_eq!(device.len(), cpu.len(), "{pattern}");
            let worst = device
                .iter()
                .zip(&cpu)
                .map(|(d, c)| (d[0] - c[0]).abs().max((d[1] - c[1]).abs()))
                .fold(0.0, f64::max);
            println!("{pattern}: {} points, worst difference {worst:.2e}", cpu.len());
            // One `cos_sin_turns` and one fixed-point golden angle serve both: the same bits in f64.
            assert_eq!(worst, 0.0, "{pattern}");
        }
    }

    #[test]
    fn fixed_point_rounds_to_nearest_in_both_precisions() {
        for w in [0.0, 1e-9, 0.25, 0.999_999, 1.0] {
            let exact = (w * FIXED_SCALE).round() as u64;
            assert_eq!(to_fixed(w), exact, "{w}");
            let w32 = w as f32;
            assert_eq!(to_fixed(w32), (w32 as f64 * FIXED_SCALE).round() as u64, "{w}");
        }
    }
}
