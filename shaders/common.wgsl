// common.wgsl: buffer layouts, integer helpers, pupil sampling, paraxial aiming and the per-surface
// ray-tracing step shared by trace.wgsl and psf.wgsl.
//
// Not a complete module: crates/unicac-gpu/src/shader.rs prepends the precision prelude
//   alias Real = f32;  (or f64)   const EPSILON: Real = ...;  const REAL_MAX: Real = ...;
//   const REAL_MIN_POSITIVE: Real = ...;  const NEWTON_TOLERANCE: Real = ...;  const GUARD: Real = ...;
// and concatenates common + trace + psf into one module. Literals are abstract (`1.0`, `Real(0.5)`), so
// the same text compiles as f32 and as f64. Every struct below is mirrored, field for field, by
// crates/unicac-gpu/src/layout.rs (no vec3 members: their 16-byte alignment differs between WGSL and
// Rust); every function has a plain-Rust twin in crates/unicac-gpu/src/twin.rs.

// Status kinds (low byte of a status word; the failing surface, 0-based, sits above it).
const OK: u32 = 0u;
const MISSED: u32 = 1u;
const TIR: u32 = 2u;
const CLIPPED: u32 = 3u;
const NO_CONVERGENCE: u32 = 4u;
const INVALID_INPUT: u32 = 5u;
// A grid cell outside the unit disc: not a ray, counted nowhere.
const NOT_SAMPLED: u32 = 6u;
// Set on a status word when one of the ray's decisions (aperture, TIR, missing a surface) fell within
// GUARD (1024 ulps of the working type, relative) of its threshold: the working precision cannot tell,
// so the host re-traces that ray in f64. Keeps f32 status counts equal to the CPU's.
const UNDECIDED: u32 = 0x80u;

const MAX_NEWTON_ITERATIONS: u32 = 40u;
// Below this |N| a ray counts as parallel to a tangent plane (a geometric angle, as on the CPU).
const GRAZING_N: Real = Real(1e-6);
const WORKGROUP: u32 = 64u;

// Pupil patterns.
const PATTERN_HOST_RAYS: u32 = 0u;
const PATTERN_HEXAPOLAR: u32 = 1u;
const PATTERN_GRID: u32 = 2u;
const PATTERN_FIBONACCI: u32 = 3u;
const PATTERN_RANDOM: u32 = 4u;

// Mirror: layout.rs `Surface<R>`. Coordinates are local to each surface's vertex.
struct Surface {
    gap_mm: Real,            // this vertex's z minus the previous vertex's z (0 for surface 1)
    curvature_per_mm: Real,
    conic: Real,
    conic_rho_limit: Real,   // r^2 limit of the conic base; REAL_MAX when unbounded
    clip_rho: Real,          // squared clear semi-diameter; REAL_MAX when not clipping
    mu: Real,                // n_before / n_after, divided in f64 on the host
    coefficients: array<Real, 10>,
    terms: u32,
    refract: u32,
}

// Mirror: layout.rs `GpuRay<R>`. Position local to the vertex of the last surface reached.
struct Ray {
    x: Real,
    y: Real,
    z: Real,
    l: Real,
    m: Real,
    n: Real,
}

// Mirror: layout.rs `Params<R>`.
struct Params {
    pupil_radius_mm: Real,     // paraxial entrance pupil radius
    pupil_z_mm: Real,          // its plane, relative to surface 1's vertex
    sin_field: Real,
    cos_field: Real,
    object_y_mm: Real,         // finite object: the object point's y
    object_to_pupil_mm: Real,  // finite object: z from the object point to the pupil plane
    chief_x_mm: Real,          // PSF reference point (image-surface frame)
    chief_y_mm: Real,
    sub_pitch_um: Real,        // PSF fine-grid pitch
    weight_r: Real,            // per-ray weight of each channel (spectral weight / rays traced)
    weight_g: Real,
    weight_b: Real,
    surface_count: u32,
    ray_count: u32,            // rays (or pattern slots) in this dispatch
    first_index: u32,          // pattern index of this dispatch's first ray (chunking)
    pattern: u32,
    pattern_n: u32,            // rings, grid side or point count
    seed_lo: u32,
    seed_hi: u32,
    finite_object: u32,
    fine_size: u32,            // PSF fine-grid side
    pad: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> surfaces: array<Surface>;
@group(0) @binding(2) var<storage, read_write> rays: array<Ray>;
@group(0) @binding(3) var<storage, read_write> statuses: array<u32>;
// PSF grid: per channel and fine cell, a 64-bit fixed-point sum as (low word, high word).
@group(0) @binding(4) var<storage, read_write> grid: array<atomic<u32>>;
// Rays per status kind, summed over dispatches.
@group(0) @binding(5) var<storage, read_write> counters: array<atomic<u32>>;

var<workgroup> local_counts: array<atomic<u32>, 8>;
var<private> undecided: bool;

// Whether `value` lies within GUARD * scale of `threshold` (flags the ray as undecided).
fn guard(value: Real, threshold: Real, scale: Real) {
    if (abs(value - threshold) <= GUARD * scale) {
        undecided = true;
    }
}

fn status_word(kind: u32, surface: u32) -> u32 {
    return kind | (surface << 8u);
}

fn is_finite(v: Real) -> bool {
    return abs(v) <= REAL_MAX;
}

// 64-bit integer helpers and counter_hash: counter.wgsl (joined before this file).

// A 64-bit fraction (of 2^64) as a Real in [0, 1]: its top 53 bits, as unicac_trace's unit_interval.
fn unit_fraction(bits: vec2<u32>) -> Real {
    let top = Real(bits.y >> 11u) * Real(4.76837158203125e-7);                      // 2^-21
    let rest = Real(((bits.y & 0x7ffu) << 21u) | (bits.x >> 11u)) * Real(1.1102230246251565e-16); // 2^-53
    return top + rest;
}

// cos and sin of 2 pi t for t in [0, 1]: quadrant reduction in turns (exact), then Taylor series to
// x^17 on |x| <= pi/4 (truncation below 1e-17). Vulkan offers no f64 sin/cos, and one polynomial in both
// precisions keeps the twin and the kernel identical; the CPU's pupils use it too
// (unicac_trace::pupil::cos_sin_turns), so the f64 kernel's points are the CPU's.
fn cos_sin_turns(t: Real) -> vec2<Real> {
    let q = round(t * Real(4.0));
    let x = (t - q * Real(0.25)) * Real(6.283185307179586);
    let x2 = x * x;
    let s = x * (Real(1.0) + x2 * (Real(-1.0 / 6.0) + x2 * (Real(1.0 / 120.0) + x2 * (Real(-1.0 / 5040.0)
        + x2 * (Real(1.0 / 362880.0) + x2 * (Real(-1.0 / 39916800.0) + x2 * (Real(1.0 / 6227020800.0)
        + x2 * (Real(-1.0 / 1307674368000.0) + x2 * Real(1.0 / 355687428096000.0)))))))));
    let c = Real(1.0) + x2 * (Real(-0.5) + x2 * (Real(1.0 / 24.0) + x2 * (Real(-1.0 / 720.0)
        + x2 * (Real(1.0 / 40320.0) + x2 * (Real(-1.0 / 3628800.0) + x2 * (Real(1.0 / 479001600.0)
        + x2 * (Real(-1.0 / 87178291200.0) + x2 * Real(1.0 / 20922789888000.0))))))));
    switch (u32(q) & 3u) {
        case 0u: { return vec2<Real>(c, s); }
        case 1u: { return vec2<Real>(-s, c); }
        case 2u: { return vec2<Real>(-c, -s); }
        default: { return vec2<Real>(s, -c); }
    }
}

// Pupil point of pattern slot `index` (twin: twin::pupil_point). w = 0 marks a slot that is not a ray
// (grid cells outside the disc).
fn pupil_point(index: u32) -> vec3<Real> {
    let n = params.pattern_n;
    switch (params.pattern) {
        case 1u: {  // hexapolar: centre, then ring i (of n) holds 6 i points
            if (index == 0u) {
                return vec3<Real>(Real(0.0), Real(0.0), Real(1.0));
            }
            var ring = u32((3.0 + sqrt(12.0 * f32(index) - 3.0)) / 6.0);
            ring = max(ring, 1u);
            loop {
                if (1u + 3u * ring * (ring - 1u) <= index) { break; }
                ring -= 1u;
            }
            loop {
                if (1u + 3u * (ring + 1u) * ring > index) { break; }
                ring += 1u;
            }
            let k = index - (1u + 3u * ring * (ring - 1u));
            let r = Real(ring) / Real(n);
            let cs = cos_sin_turns(Real(k) / Real(6u * ring));
            return vec3<Real>(r * cs.x, r * cs.y, Real(1.0));
        }
        case 2u: {  // grid: cell centres of n x n over [-1, 1]^2, kept inside the disc (exact integer test)
            let i = index % n;
            let j = index / n;
            let a = i32(2u * i + 1u) - i32(n);
            let b = i32(2u * j + 1u) - i32(n);
            let inside = u32(a * a + b * b) <= n * n;
            let x = Real(-1.0) + Real(2u * i + 1u) / Real(n);
            let y = Real(-1.0) + Real(2u * j + 1u) / Real(n);
            return vec3<Real>(x, y, select(Real(0.0), Real(1.0), inside));
        }
        case 3u: {  // Fibonacci: r = sqrt((i + 1/2) / n), angle i * golden angle, in 64-bit fixed-point turns
            let r = sqrt((Real(index) + Real(0.5)) / Real(n));
            let turns = unit_fraction(mul64(vec2<u32>(index, 0u), vec2<u32>(0x80b583eau, 0x61c88646u)));
            let cs = cos_sin_turns(turns);
            return vec3<Real>(r * cs.x, r * cs.y, Real(1.0));
        }
        default: {  // random: r = sqrt(u), angle 2 pi v, from the counter-based hash
            let seed = vec2<u32>(params.seed_lo, params.seed_hi);
            let counter = vec2<u32>(index << 1u, index >> 31u);
            let u = unit_fraction(counter_hash(seed, counter));
            let v = unit_fraction(counter_hash(seed, vec2<u32>(counter.x | 1u, counter.y)));
            let r = sqrt(u);
            let cs = cos_sin_turns(v);
            return vec3<Real>(r * cs.x, r * cs.y, Real(1.0));
        }
    }
}

// Paraxial aiming (as unicac_trace::Aimer): the ray through (px, py) * EPD/2 on the entrance-pupil
// plane. A finite object's ray starts on that plane too (same line, far smaller coordinates).
fn aimed_ray(px: Real, py: Real) -> Ray {
    let sx = px * params.pupil_radius_mm;
    let sy = py * params.pupil_radius_mm;
    var d = vec3<Real>(Real(0.0), params.sin_field, params.cos_field);
    if (params.finite_object != 0u) {
        d = vec3<Real>(sx, sy - params.object_y_mm, params.object_to_pupil_mm);
    }
    let norm = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    return Ray(sx, sy, params.pupil_z_mm, d.x / norm, d.y / norm, d.z / norm);
}

fn sag_and_slope(s: u32, rho: Real) -> vec2<Real> {
    var value = Real(0.0);
    var slope = Real(0.0);
    for (var i = surfaces[s].terms; i > 0u; i -= 1u) {
        let a = surfaces[s].coefficients[i - 1u];
        slope = slope * rho + Real(i) * a;
        value = value * rho + a;
    }
    let c = surfaces[s].curvature_per_mm;
    let root = sqrt(Real(1.0) - (Real(1.0) + surfaces[s].conic) * c * c * rho);
    return vec2<Real>(c * rho / (Real(1.0) + root) + value * rho, c / (Real(2.0) * root) + slope);
}

// One surface: transfer to the tangent plane, closed-form conic hit, Newton on the residual for even
// aspheres, aperture test, refraction (see unicac_trace::system for the maths). On failure `ray` is
// left as it was (in the previous surface's frame).
fn trace_step(s: u32, ray: ptr<function, Ray>) -> u32 {
    let l = (*ray).l;
    let m = (*ray).m;
    let n = (*ray).n;
    var x = (*ray).x;
    var y = (*ray).y;
    var z = (*ray).z - surfaces[s].gap_mm;
    if (abs(n) > GRAZING_N) {
        let t0 = -z / n;
        x += t0 * l;
        y += t0 * m;
        z = Real(0.0);
    }
    let c = surfaces[s].curvature_per_mm;
    let conic = surfaces[s].conic;
    let k1 = Real(1.0) + conic;
    let limit = surfaces[s].conic_rho_limit;
    let a = c * (Real(1.0) + conic * n * n);
    let b = n - c * (x * l + y * m + k1 * z * n);
    let f = c * (x * x + y * y + k1 * z * z) - Real(2.0) * z;
    let discriminant = b * b - a * f;
    guard(discriminant, Real(0.0), b * b + abs(a * f));
    if (!(discriminant >= Real(0.0))) {
        return status_word(MISSED, s);
    }
    let root = sqrt(discriminant);
    let denominator = b + select(-root, root, b >= Real(0.0));
    if (denominator == Real(0.0) && f != Real(0.0)) {
        return status_word(MISSED, s);
    }
    var t = select(f / denominator, Real(0.0), f == Real(0.0));
    {
        let hx = x + t * l;
        let hy = y + t * m;
        let hz = z + t * n;
        guard(hx * hx + hy * hy, limit, limit);
        guard(c * k1 * hz, Real(1.0), Real(1.0));
        if (hx * hx + hy * hy > limit || Real(1.0) - c * k1 * hz <= Real(0.0)) {
            return status_word(MISSED, s);
        }
    }
    if (surfaces[s].terms > 0u) {
        var converged = false;
        for (var iteration = 0u; iteration < MAX_NEWTON_ITERATIONS; iteration += 1u) {
            let px = x + t * l;
            let py = y + t * m;
            let pz = z + t * n;
            let rho = px * px + py * py;
            if (!(rho <= limit)) {
                return status_word(MISSED, s);
            }
            let ss = sag_and_slope(s, rho);
            let derivative = n - Real(2.0) * ss.y * (px * l + py * m);
            if (derivative == Real(0.0) || !is_finite(derivative)) {
                return status_word(MISSED, s);
            }
            let dt = (pz - ss.x) / derivative;
            t -= dt;
            if (!is_finite(t)) {
                return status_word(MISSED, s);
            }
            if (abs(dt) <= NEWTON_TOLERANCE * (abs(t) + abs(px) + abs(py) + abs(pz)) + REAL_MIN_POSITIVE) {
                converged = true;
                break;
            }
        }
        if (!converged) {
            return status_word(NO_CONVERGENCE, s);
        }
    }
    let px = x + t * l;
    let py = y + t * m;
    let pz = z + t * n;
    let rho = px * px + py * py;
    guard(rho, surfaces[s].clip_rho, surfaces[s].clip_rho);
    if (!(rho <= surfaces[s].clip_rho)) {
        return status_word(CLIPPED, s);
    }
    if (!(is_finite(px) && is_finite(py) && is_finite(pz))) {
        return status_word(MISSED, s);
    }
    var d = vec3<Real>(l, m, n);
    if (surfaces[s].refract != 0u) {
        var normal: vec3<Real>;
        if (surfaces[s].terms > 0u) {
            let slope = sag_and_slope(s, rho).y;
            normal = vec3<Real>(Real(-2.0) * px * slope, Real(-2.0) * py * slope, Real(1.0));
        } else {
            normal = vec3<Real>(-c * px, -c * py, Real(1.0) - c * k1 * pz);
        }
        // Vector Snell's law with the normalisation folded in (unicac_trace::system::refract_direction).
        let mu = surfaces[s].mu;
        let q = normal.x * normal.x + normal.y * normal.y + normal.z * normal.z;
        var p = d.x * normal.x + d.y * normal.y + d.z * normal.z;
        var sign = Real(1.0);
        if (p < Real(0.0)) {
            p = -p;
            sign = Real(-1.0);
        }
        let radicand = q * (Real(1.0) - mu * mu) + mu * mu * p * p;
        guard(radicand, Real(0.0), q);
        if (radicand < Real(0.0)) {
            return status_word(TIR, s);
        }
        let g = sign * (sqrt(radicand) - mu * p) / q;
        d = vec3<Real>(mu * d.x + g * normal.x, mu * d.y + g * normal.y, mu * d.z + g * normal.z);
    }
    *ray = Ray(px, py, pz, d.x, d.y, d.z);
    return OK;
}

// Status word of the trace, with UNDECIDED set when a decision was too close to call.
fn trace_ray(ray: ptr<function, Ray>) -> u32 {
    undecided = false;
    let status = trace_surfaces(ray);
    return select(status, status | UNDECIDED, undecided);
}

fn trace_surfaces(ray: ptr<function, Ray>) -> u32 {
    let r = *ray;
    if (!(is_finite(r.x) && is_finite(r.y) && is_finite(r.z) && is_finite(r.l) && is_finite(r.m)
        && is_finite(r.n))) {
        return status_word(INVALID_INPUT, 0u);
    }
    for (var s = 0u; s < params.surface_count; s += 1u) {
        let status = trace_step(s, ray);
        if (status != OK) {
            return status;
        }
    }
    return OK;
}

// The ray of this invocation: from the host, or sampled and aimed on the device. `kind` is set to
// NOT_SAMPLED for grid slots outside the disc.
fn source_ray(i: u32, kind: ptr<function, u32>) -> Ray {
    if (params.pattern == PATTERN_HOST_RAYS) {
        return rays[i];
    }
    let p = pupil_point(params.first_index + i);
    if (p.z == Real(0.0)) {
        *kind = NOT_SAMPLED;
    }
    return aimed_ray(p.x, p.y);
}

// Per-workgroup status histogram, then one global add per kind: keeps atomics off one hot word.
// Must be reached by every invocation of the workgroup (uniform control flow).
fn count_status(local_index: u32, kind: u32) {
    if (local_index < 8u) {
        atomicStore(&local_counts[local_index], 0u);
    }
    workgroupBarrier();
    if (kind < 8u) {
        atomicAdd(&local_counts[kind], 1u);
    }
    workgroupBarrier();
    if (local_index < 8u) {
        let count = atomicLoad(&local_counts[local_index]);
        if (count > 0u) {
            atomicAdd(&counters[local_index], count);
        }
    }
}
