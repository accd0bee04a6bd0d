//! The batch tracer with explicit SIMD over ray lanes: `TraceSystem::trace_chunk` runs here.
//!
//! Rays are traced in blocks of `LANE_BLOCK`, stored as structure of arrays (one array per coordinate),
//! surface by surface in three phases (closed-form conic hit, Newton on even aspheres, aperture test
//! and refraction), each a loop over SIMD vectors of 8 (AVX-512), 4 (AVX2) or 1 (portable) lanes.
//! Independent vectors in one phase let the core overlap their long division and square-root chains.
//!
//! Statuses are masked, never branched on: every lane carries a status code (0 while the ray is
//! alive); a lane that fails gets its code (kind and surface) and from then on every update of its
//! position and direction is a select that keeps the old value, so a failed ray keeps its last valid
//! state exactly as the scalar `step` leaves it, and whatever a dead lane computes (NaN included) is
//! never stored. Padding lanes of a short block carry their own code and are never written back.
//!
//! **Same results, bit for bit, as the scalar path** (`TraceSystem::trace` ray by ray): each lane
//! performs the scalar `step`'s operations in the same order, only IEEE-754 additions,
//! multiplications, divisions and square roots (all correctly rounded, in SIMD as in scalar code),
//! and no fused multiply-add (an FMA rounds once where the scalar code rounds twice, which would change
//! the last bit). Reassociated or FMA forms would buy some 10-20% more but lose the exact agreement
//! that makes this path checkable against the reference; `tests/lanes.rs` asserts bit equality on
//! random rays including missed, clipped, TIR, non-converging and invalid ones, at every level the CPU
//! supports.
//!
//! **Why `pulp`.** The vector types and the runtime dispatch come from the `pulp` crate (0.22, stable
//! Rust; maintained with the `faer` linear-algebra crates and already in this workspace's dependency
//! tree through the `exr` image decoder): one generic function over its `Simd` trait is compiled for
//! AVX-512 (`x86-v4`), AVX2+FMA (`x86-v3`) and a portable one-lane fallback, and `SimdLevel::detected`
//! picks the best the CPU has at run time. `std::simd` is nightly-only; `wide` fixes its width at
//! compile time (no runtime dispatch, so an AVX2 build would never use AVX-512 and a baseline build
//! never AVX2); `multiversion` only clones scalar code and leaves vectorisation of this branchy loop to
//! the compiler, which does not do it. Hand-written `core::arch` intrinsics would be three copies of
//! this file.

use crate::ray::{Ray, RayStatus};
use crate::surface::{
    Frame, TraceSurface, GRAZING_N, LANE_BLOCK, MAX_NEWTON_ITERATIONS, NEWTON_STEP_TOLERANCE,
};
use pulp::{Simd, WithSimd};
use unicac_optics::profile::MAX_ASPHERE_TERMS;

/// Instruction set of the lane tracer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLevel {
    /// One lane, plain f64 code: any CPU.
    Portable,
    /// 4 f64 lanes (x86-64-v3: AVX2 and FMA).
    Avx2,
    /// 8 f64 lanes (x86-64-v4: AVX-512 F/BW/CD/DQ/VL).
    Avx512,
}

impl SimdLevel {
    /// The widest level this CPU supports (detected at run time; cached by the standard library).
    pub fn detected() -> SimdLevel {
        #[cfg(target_arch = "x86_64")]
        {
            if pulp::x86::V4::try_new().is_some() {
                return SimdLevel::Avx512;
            }
            if pulp::x86::V3::try_new().is_some() {
                return SimdLevel::Avx2;
            }
        }
        SimdLevel::Portable
    }

    /// Every level this CPU can run, narrowest first.
    pub fn supported() -> Vec<SimdLevel> {
        let best = SimdLevel::detected();
        [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512]
            .into_iter()
            .filter(|&level| level <= best)
            .collect()
    }

    /// f64 lanes per vector.
    pub fn lanes(self) -> usize {
        match self {
            SimdLevel::Portable => 1,
            SimdLevel::Avx2 => 4,
            SimdLevel::Avx512 => 8,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Portable => "portable",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }
}

/// One surface with the constants of the scalar `step`, computed by the same expressions (so with the
/// same roundings), plus what depends on its neighbours (refraction index ratio).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneSurface {
    z_mm: f64,
    c: f64,
    conic: f64,
    /// 1 + k.
    k1: f64,
    /// c (1 + k): the vertex-sheet test and the conic normal.
    ck1: f64,
    /// (1 + k) c^2: the square root of the base sag.
    kcc: f64,
    conic_rho_limit: f64,
    clip_rho: f64,
    terms: usize,
    coefficients: [f64; MAX_ASPHERE_TERMS],
    /// (i + 1) a_i: the Horner coefficients of the slope.
    slope_coefficients: [f64; MAX_ASPHERE_TERMS],
    refract: bool,
    mu: f64,
    mu2: f64,
    one_minus_mu2: f64,
    /// A decentred or tilted surface's frame (the other constants are then in that frame, z_mm = 0).
    frame: Option<Frame>,
}

impl LaneSurface {
    pub(crate) fn new(surface: &TraceSurface, n_before: f64, refract: bool) -> LaneSurface {
        let p = &surface.profile;
        let c = p.curvature_per_mm;
        let mu = n_before / surface.index_after;
        let mut slope_coefficients = [0.0; MAX_ASPHERE_TERMS];
        for (i, (slope, a)) in slope_coefficients
            .iter_mut()
            .zip(&p.aspheric_coefficients)
            .enumerate()
        {
            *slope = (i as f64 + 1.0) * a;
        }
        LaneSurface {
            z_mm: surface.z_mm,
            c,
            conic: p.conic,
            k1: 1.0 + p.conic,
            ck1: c * (1.0 + p.conic),
            kcc: (1.0 + p.conic) * c * c,
            conic_rho_limit: surface.conic_rho_limit,
            clip_rho: surface.clip_rho,
            terms: p.aspheric_terms,
            coefficients: p.aspheric_coefficients,
            slope_coefficients,
            refract: refract && n_before != surface.index_after,
            mu,
            mu2: mu * mu,
            one_minus_mu2: 1.0 - mu * mu,
            frame: None,
        }
    }

    /// A decentred or tilted surface: `local` is the surface in its own frame (`TraceSurface::local`).
    pub(crate) fn placed(local: &TraceSurface, frame: Frame, n_before: f64, refract: bool) -> LaneSurface {
        LaneSurface {
            frame: Some(frame),
            ..LaneSurface::new(local, n_before, refract)
        }
    }
}

/// Lane status codes: 0 while alive, else kind << 32 | surface.
const ALIVE: u64 = 0;
const MISSED: u64 = 1 << 32;
const TIR: u64 = 2 << 32;
const CLIPPED: u64 = 3 << 32;
const NO_CONVERGENCE: u64 = 4 << 32;
const INVALID_INPUT: u64 = 5 << 32;
/// Lanes past the end of a short block: never traced, never written back.
const PADDING: u64 = 6 << 32;

fn decode(code: u64) -> RayStatus {
    let surface = code as u32;
    match code >> 32 {
        0 => RayStatus::Ok,
        1 => RayStatus::Missed { surface },
        2 => RayStatus::Tir { surface },
        3 => RayStatus::Clipped { surface },
        4 => RayStatus::NoConvergence { surface },
        _ => RayStatus::InvalidInput,
    }
}

/// Three coordinates of a block's rays, structure of arrays.
struct Points {
    x: [f64; LANE_BLOCK],
    y: [f64; LANE_BLOCK],
    z: [f64; LANE_BLOCK],
}

/// One block of rays as structure of arrays, plus the per-surface scratch of the phases.
///
/// The two point sets swap roles at every surface: one holds the rays' global positions, the other
/// receives their start points in the surface's frame (conic phase), and then their new global
/// positions (finish phase: the new point where the ray arrived, the old one from the other set where
/// it did not). Updating a position in place instead, `x = select(arrived, hit, x)`, is what LLVM turns
/// into a masked store (`vmaskmovpd`), which is microcoded and several times slower on AMD cores.
struct Block {
    points: [Points; 2],
    /// Which of `points` holds the global positions.
    global: usize,
    l: [f64; LANE_BLOCK],
    m: [f64; LANE_BLOCK],
    n: [f64; LANE_BLOCK],
    code: [u64; LANE_BLOCK],
    /// The intersection parameter along the ray from its start point in the surface's frame.
    t: [f64; LANE_BLOCK],
    /// Newton: !0 while a lane still iterates.
    pending: [u64; LANE_BLOCK],
    /// Placed surfaces only: the global state before the surface, and !0 where the ray arrived on it.
    saved: Points,
    saved_l: [f64; LANE_BLOCK],
    saved_m: [f64; LANE_BLOCK],
    saved_n: [f64; LANE_BLOCK],
    arrived: [u64; LANE_BLOCK],
}

impl Points {
    fn zero() -> Points {
        Points {
            x: [0.0; LANE_BLOCK],
            y: [0.0; LANE_BLOCK],
            z: [0.0; LANE_BLOCK],
        }
    }
}

impl Block {
    fn new() -> Box<Block> {
        Box::new(Block {
            points: [Points::zero(), Points::zero()],
            global: 0,
            l: [0.0; LANE_BLOCK],
            m: [0.0; LANE_BLOCK],
            n: [0.0; LANE_BLOCK],
            code: [PADDING; LANE_BLOCK],
            t: [0.0; LANE_BLOCK],
            pending: [0; LANE_BLOCK],
            saved: Points::zero(),
            saved_l: [0.0; LANE_BLOCK],
            saved_m: [0.0; LANE_BLOCK],
            saved_n: [0.0; LANE_BLOCK],
            arrived: [0; LANE_BLOCK],
        })
    }

    fn load(&mut self, rays: &[Ray]) {
        self.global = 0;
        let p = &mut self.points[0];
        for i in 0..LANE_BLOCK {
            match rays.get(i) {
                Some(ray) => {
                    [p.x[i], p.y[i], p.z[i]] = ray.position_mm;
                    [self.l[i], self.m[i], self.n[i]] = ray.direction;
                    self.code[i] = if ray.is_finite() { ALIVE } else { INVALID_INPUT };
                }
                None => {
                    // Harmless finite values: padding lanes compute alongside the others.
                    [p.x[i], p.y[i], p.z[i], self.l[i], self.m[i]] = [0.0; 5];
                    self.n[i] = 1.0;
                    self.code[i] = PADDING;
                }
            }
        }
    }

    fn store(&self, rays: &mut [Ray], statuses: &mut [RayStatus]) {
        let p = &self.points[self.global];
        for (i, (ray, status)) in rays.iter_mut().zip(statuses.iter_mut()).enumerate() {
            ray.position_mm = [p.x[i], p.y[i], p.z[i]];
            ray.direction = [self.l[i], self.m[i], self.n[i]];
            *status = decode(self.code[i]);
        }
    }
}

/// The point set holding the global positions (`global`) and the other one.
fn split_points(points: &mut [Points; 2], global: usize) -> (&mut Points, &mut Points) {
    let [p0, p1] = points;
    if global == 0 {
        (p0, p1)
    } else {
        (p1, p0)
    }
}

/// Traces `rays` to the last of `surfaces` at `level` (clamped to what the CPU supports).
pub(crate) fn trace_lanes(
    level: SimdLevel,
    surfaces: &[LaneSurface],
    rays: &mut [Ray],
    statuses: &mut [RayStatus],
) {
    if surfaces.iter().any(|s| s.frame.is_some()) {
        dispatch(
            level,
            TraceBlocks::<true> {
                surfaces,
                rays,
                statuses,
            },
        );
    } else {
        dispatch(
            level,
            TraceBlocks::<false> {
                surfaces,
                rays,
                statuses,
            },
        );
    }
}

/// Runs `op` at `level` (clamped to what the CPU supports).
fn dispatch<const PLACED: bool>(level: SimdLevel, op: TraceBlocks<'_, PLACED>) {
    match level.min(SimdLevel::detected()) {
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx512 => match pulp::x86::V4::try_new() {
            Some(simd) => Simd::vectorize(simd, op),
            None => Simd::vectorize(pulp::Scalar, op),
        },
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx2 => match pulp::x86::V3::try_new() {
            Some(simd) => Simd::vectorize(simd, op),
            None => Simd::vectorize(pulp::Scalar, op),
        },
        _ => Simd::vectorize(pulp::Scalar, op),
    }
}

/// `PLACED`: some surface is decentred or tilted (the general path); `false` compiles the rotationally
/// symmetric loop without any frame code.
struct TraceBlocks<'a, const PLACED: bool> {
    surfaces: &'a [LaneSurface],
    rays: &'a mut [Ray],
    statuses: &'a mut [RayStatus],
}

impl<const PLACED: bool> WithSimd for TraceBlocks<'_, PLACED> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let mut block = Block::new();
        for (rays, statuses) in self
            .rays
            .chunks_mut(LANE_BLOCK)
            .zip(self.statuses.chunks_mut(LANE_BLOCK))
        {
            block.load(rays);
            for (index, surface) in self.surfaces.iter().enumerate() {
                let index = index as u64;
                let frame = if PLACED { surface.frame } else { None };
                if let Some(frame) = &frame {
                    localize_phase(simd, frame, &mut block);
                }
                conic_phase(simd, surface, index, &mut block);
                if surface.terms > 0 {
                    newton_phase(simd, surface, index, &mut block);
                }
                finish_phase::<S, PLACED>(simd, surface, index, &mut block);
                block.global ^= 1;
                if let Some(frame) = &frame {
                    globalize_phase(simd, frame, &mut block);
                }
            }
            block.store(rays, statuses);
        }
    }
}

/// Lane arithmetic with the scalar code's operator order. The methods are thin names over `pulp`'s so
/// that the expressions below read like `system.rs`.
#[derive(Clone, Copy)]
struct Lanes<S: Simd>(S);

impl<S: Simd> Lanes<S> {
    #[inline(always)]
    fn splat(self, v: f64) -> S::f64s {
        self.0.splat_f64s(v)
    }
    #[inline(always)]
    fn add(self, a: S::f64s, b: S::f64s) -> S::f64s {
        self.0.add_f64s(a, b)
    }
    #[inline(always)]
    fn sub(self, a: S::f64s, b: S::f64s) -> S::f64s {
        self.0.sub_f64s(a, b)
    }
    #[inline(always)]
    fn mul(self, a: S::f64s, b: S::f64s) -> S::f64s {
        self.0.mul_f64s(a, b)
    }
    #[inline(always)]
    fn div(self, a: S::f64s, b: S::f64s) -> S::f64s {
        self.0.div_f64s(a, b)
    }
    #[inline(always)]
    fn sqrt(self, a: S::f64s) -> S::f64s {
        self.0.sqrt_f64s(a)
    }
    #[inline(always)]
    fn abs(self, a: S::f64s) -> S::f64s {
        self.0.abs_f64s(a)
    }
    #[inline(always)]
    fn neg(self, a: S::f64s) -> S::f64s {
        self.0.neg_f64s(a)
    }
    /// |a| with the sign of b (`f64::copysign`).
    #[inline(always)]
    fn copysign(self, a: S::f64s, b: S::f64s) -> S::f64s {
        let sign = self.splat(-0.0);
        self.0.or_f64s(self.abs(a), self.0.and_f64s(b, sign))
    }
    /// Finite (neither infinite nor NaN): |a| < inf is false for both.
    #[inline(always)]
    fn finite(self, a: S::f64s) -> S::m64s {
        self.0.less_than_f64s(self.abs(a), self.splat(f64::INFINITY))
    }
    #[inline(always)]
    fn lt(self, a: S::f64s, b: S::f64s) -> S::m64s {
        self.0.less_than_f64s(a, b)
    }
    #[inline(always)]
    fn le(self, a: S::f64s, b: S::f64s) -> S::m64s {
        self.0.less_than_or_equal_f64s(a, b)
    }
    #[inline(always)]
    fn gt(self, a: S::f64s, b: S::f64s) -> S::m64s {
        self.0.greater_than_f64s(a, b)
    }
    #[inline(always)]
    fn ge(self, a: S::f64s, b: S::f64s) -> S::m64s {
        self.0.greater_than_or_equal_f64s(a, b)
    }
    #[inline(always)]
    fn eq(self, a: S::f64s, b: S::f64s) -> S::m64s {
        self.0.equal_f64s(a, b)
    }
    #[inline(always)]
    fn and(self, a: S::m64s, b: S::m64s) -> S::m64s {
        self.0.and_m64s(a, b)
    }
    #[inline(always)]
    fn or(self, a: S::m64s, b: S::m64s) -> S::m64s {
        self.0.or_m64s(a, b)
    }
    #[inline(always)]
    fn not(self, a: S::m64s) -> S::m64s {
        self.0.not_m64s(a)
    }
    #[inline(always)]
    fn select(self, mask: S::m64s, if_true: S::f64s, if_false: S::f64s) -> S::f64s {
        self.0.select_f64s(mask, if_true, if_false)
    }
    #[inline(always)]
    fn any(self, mask: S::m64s) -> bool {
        self.0.first_true_m64s(mask) < S::F64_LANES
    }
    #[inline(always)]
    fn alive(self, code: S::u64s) -> S::m64s {
        self.0.equal_u64s(code, self.0.splat_u64s(ALIVE))
    }
    /// Sets the code of the lanes in `mask`.
    #[inline(always)]
    fn fail(self, mask: S::m64s, code: u64, at: u64, codes: S::u64s) -> S::u64s {
        self.0.select_u64s(mask, self.0.splat_u64s(code | at), codes)
    }

    /// `Profile::polynomial` and `sag_and_slope`: Horner's rule from the highest term.
    #[inline(always)]
    fn sag_and_slope(self, s: &LaneSurface, rho: S::f64s, with_sag: bool) -> (S::f64s, S::f64s) {
        let mut value = self.splat(0.0);
        let mut poly_slope = self.splat(0.0);
        for i in (0..s.terms).rev() {
            poly_slope = self.add(self.mul(poly_slope, rho), self.splat(s.slope_coefficients[i]));
            if with_sag {
                value = self.add(self.mul(value, rho), self.splat(s.coefficients[i]));
            }
        }
        let c = self.splat(s.c);
        let root = self.sqrt(self.sub(self.splat(1.0), self.mul(self.splat(s.kcc), rho)));
        let slope = self.add(self.div(c, self.mul(self.splat(2.0), root)), poly_slope);
        if !with_sag {
            return (value, slope);
        }
        let poly = self.mul(value, rho);
        let sag = self.add(self.div(self.mul(c, rho), self.add(self.splat(1.0), root)), poly);
        (sag, slope)
    }
}

/// Steps 1-2 of `system.rs` (`conic_hit`) for every live lane: transfer, closed-form conic root, the
/// sheet and domain tests. Stores the local start point and t.
#[inline(always)]
fn conic_phase<S: Simd>(simd: S, s: &LaneSurface, index: u64, b: &mut Block) {
    let v = Lanes(simd);
    let (global, start) = split_points(&mut b.points, b.global);
    let (xs, _) = S::as_simd_f64s(&global.x);
    let (ys, _) = S::as_simd_f64s(&global.y);
    let (zs, _) = S::as_simd_f64s(&global.z);
    let (sxs, _) = S::as_mut_simd_f64s(&mut start.x);
    let (sys, _) = S::as_mut_simd_f64s(&mut start.y);
    let (szs, _) = S::as_mut_simd_f64s(&mut start.z);
    let (ls, _) = S::as_simd_f64s(&b.l);
    let (ms, _) = S::as_simd_f64s(&b.m);
    let (ns, _) = S::as_simd_f64s(&b.n);
    let (codes, _) = S::as_mut_simd_u64s(&mut b.code);
    let (ts, _) = S::as_mut_simd_f64s(&mut b.t);
    let c = v.splat(s.c);
    let k1 = v.splat(s.k1);
    let zero = v.splat(0.0);
    let one = v.splat(1.0);
    for j in 0..codes.len() {
        let alive = v.alive(codes[j]);
        let (l, m, n) = (ls[j], ms[j], ns[j]);
        let mut x = xs[j];
        let mut y = ys[j];
        let mut z = v.sub(zs[j], v.splat(s.z_mm));
        let transfer = v.gt(v.abs(n), v.splat(GRAZING_N));
        let t0 = v.div(v.neg(z), n);
        x = v.select(transfer, v.add(x, v.mul(t0, l)), x);
        y = v.select(transfer, v.add(y, v.mul(t0, m)), y);
        z = v.select(transfer, zero, z);
        let a = v.mul(c, v.add(one, v.mul(v.mul(v.splat(s.conic), n), n)));
        let bb = v.sub(
            n,
            v.mul(c, v.add(v.add(v.mul(x, l), v.mul(y, m)), v.mul(v.mul(k1, z), n))),
        );
        let f = v.sub(
            v.mul(c, v.add(v.add(v.mul(x, x), v.mul(y, y)), v.mul(v.mul(k1, z), z))),
            v.mul(v.splat(2.0), z),
        );
        let discriminant = v.sub(v.mul(bb, bb), v.mul(a, f));
        let f_zero = v.eq(f, zero);
        // Every lane already on the surface's vertex (a plane after the transfer: the image plane, a
        // flat stop): t is 0 and the root is not needed, so its square root and division (the
        // slowest instructions here) are skipped; the selects below give the same values.
        let (t, denominator_fails) = if v.any(v.not(f_zero)) {
            let denominator = v.add(bb, v.copysign(v.sqrt(discriminant), bb));
            (
                v.select(f_zero, zero, v.div(f, denominator)),
                v.and(v.eq(denominator, zero), v.not(f_zero)),
            )
        } else {
            // No lane fails on the denominator: every f is 0, so !f_zero is the all-false mask.
            (zero, v.not(f_zero))
        };
        let hx = v.add(x, v.mul(t, l));
        let hy = v.add(y, v.mul(t, m));
        let hz = v.add(z, v.mul(t, n));
        let missed = v.or(
            v.or(v.not(v.ge(discriminant, zero)), denominator_fails),
            v.or(
                v.gt(v.add(v.mul(hx, hx), v.mul(hy, hy)), v.splat(s.conic_rho_limit)),
                v.le(v.sub(one, v.mul(v.splat(s.ck1), hz)), zero),
            ),
        );
        codes[j] = v.fail(v.and(alive, missed), MISSED, index, codes[j]);
        sxs[j] = x;
        sys[j] = y;
        szs[j] = z;
        ts[j] = t;
    }
}

/// Step 3 of `system.rs` (`newton_step`), in lock step over the block: each pass steps every vector
/// with a lane still iterating, so the passes' vectors are independent work.
#[inline(always)]
fn newton_phase<S: Simd>(simd: S, s: &LaneSurface, index: u64, b: &mut Block) {
    let v = Lanes(simd);
    let (_, start) = split_points(&mut b.points, b.global);
    let (sxs, _) = S::as_simd_f64s(&start.x);
    let (sys, _) = S::as_simd_f64s(&start.y);
    let (szs, _) = S::as_simd_f64s(&start.z);
    let (ls, _) = S::as_simd_f64s(&b.l);
    let (ms, _) = S::as_simd_f64s(&b.m);
    let (ns, _) = S::as_simd_f64s(&b.n);
    let (codes, _) = S::as_mut_simd_u64s(&mut b.code);
    let (ts, _) = S::as_mut_simd_f64s(&mut b.t);
    let (pendings, _) = S::as_mut_simd_u64s(&mut b.pending);
    let all = simd.splat_u64s(!0);
    let none = simd.splat_u64s(0);
    let mut any_pending = false;
    for j in 0..codes.len() {
        let alive = v.alive(codes[j]);
        pendings[j] = simd.select_u64s(alive, all, none);
        any_pending |= v.any(alive);
    }
    let zero = v.splat(0.0);
    let tolerance = v.splat(NEWTON_STEP_TOLERANCE);
    for _ in 0..MAX_NEWTON_ITERATIONS {
        if !any_pending {
            return;
        }
        any_pending = false;
        for j in 0..codes.len() {
            let active = simd.equal_u64s(pendings[j], all);
            if !v.any(active) {
                continue;
            }
            let (l, m, n, t) = (ls[j], ms[j], ns[j], ts[j]);
            let x = v.add(sxs[j], v.mul(t, l));
            let y = v.add(sys[j], v.mul(t, m));
            let z = v.add(szs[j], v.mul(t, n));
            let rho = v.add(v.mul(x, x), v.mul(y, y));
            let bad_rho = v.not(v.le(rho, v.splat(s.conic_rho_limit)));
            let (sag, slope) = v.sag_and_slope(s, rho, true);
            let derivative = v.sub(
                n,
                v.mul(v.mul(v.splat(2.0), slope), v.add(v.mul(x, l), v.mul(y, m))),
            );
            let bad_derivative = v.or(v.eq(derivative, zero), v.not(v.finite(derivative)));
            let dt = v.div(v.sub(z, sag), derivative);
            let t_next = v.sub(t, dt);
            let failed = v.and(
                active,
                v.or(v.or(bad_rho, bad_derivative), v.not(v.finite(t_next))),
            );
            let scale = v.add(v.add(v.add(v.abs(t_next), v.abs(x)), v.abs(y)), v.abs(z));
            let converged = v.le(v.abs(dt), v.add(v.mul(tolerance, scale), v.splat(1e-300)));
            let stepped = v.and(active, v.not(failed));
            ts[j] = v.select(stepped, t_next, t);
            // Failures are rare: a branch instead of a store of every code (see `Block`).
            if v.any(failed) {
                codes[j] = v.fail(failed, MISSED, index, codes[j]);
            }
            let still = v.and(stepped, v.not(converged));
            pendings[j] = simd.select_u64s(still, all, none);
            any_pending |= v.any(still);
        }
    }
    for j in 0..codes.len() {
        let still = simd.equal_u64s(pendings[j], all);
        if v.any(still) {
            codes[j] = v.fail(still, NO_CONVERGENCE, index, codes[j]);
        }
    }
}

/// `finish` of `system.rs`: aperture test, the new global position, the surface normal and vector
/// Snell refraction (`refract_direction`), with TIR as a status.
/// `RECORD`: also store which lanes arrived (for `globalize_phase`).
#[inline(always)]
fn finish_phase<S: Simd, const RECORD: bool>(simd: S, s: &LaneSurface, index: u64, b: &mut Block) {
    let v = Lanes(simd);
    // The start points are replaced by the new global positions (see `Block`).
    let (global, start) = split_points(&mut b.points, b.global);
    let (xs, _) = S::as_simd_f64s(&global.x);
    let (ys, _) = S::as_simd_f64s(&global.y);
    let (zs, _) = S::as_simd_f64s(&global.z);
    let (sxs, _) = S::as_mut_simd_f64s(&mut start.x);
    let (sys, _) = S::as_mut_simd_f64s(&mut start.y);
    let (szs, _) = S::as_mut_simd_f64s(&mut start.z);
    let (ls, _) = S::as_mut_simd_f64s(&mut b.l);
    let (ms, _) = S::as_mut_simd_f64s(&mut b.m);
    let (ns, _) = S::as_mut_simd_f64s(&mut b.n);
    let (codes, _) = S::as_mut_simd_u64s(&mut b.code);
    let (ts, _) = S::as_simd_f64s(&b.t);
    let (arriveds, _) = S::as_mut_simd_u64s(&mut b.arrived);
    let zero = v.splat(0.0);
    let one = v.splat(1.0);
    for j in 0..codes.len() {
        let alive = v.alive(codes[j]);
        let (l, m, n, t) = (ls[j], ms[j], ns[j], ts[j]);
        let hx = v.add(sxs[j], v.mul(t, l));
        let hy = v.add(sys[j], v.mul(t, m));
        let hz = v.add(szs[j], v.mul(t, n));
        let rho = v.add(v.mul(hx, hx), v.mul(hy, hy));
        let clipped = v.and(alive, v.not(v.le(rho, v.splat(s.clip_rho))));
        let finite = v.and(v.and(v.finite(hx), v.finite(hy)), v.finite(hz));
        let missed = v.and(v.and(alive, v.not(clipped)), v.not(finite));
        let mut code = v.fail(clipped, CLIPPED, index, codes[j]);
        code = v.fail(missed, MISSED, index, code);
        let arrived = v.and(alive, v.and(v.not(clipped), finite));
        sxs[j] = v.select(arrived, hx, xs[j]);
        sys[j] = v.select(arrived, hy, ys[j]);
        szs[j] = v.select(arrived, v.add(hz, v.splat(s.z_mm)), zs[j]);
        if RECORD {
            arriveds[j] = simd.select_u64s(arrived, simd.splat_u64s(!0), simd.splat_u64s(0));
        }
        if s.refract {
            let (nx, ny, nz) = if s.terms > 0 {
                let slope = v.sag_and_slope(s, rho, false).1;
                let minus_two = v.splat(-2.0);
                (
                    v.mul(v.mul(minus_two, hx), slope),
                    v.mul(v.mul(minus_two, hy), slope),
                    one,
                )
            } else {
                let minus_c = v.splat(-s.c);
                (
                    v.mul(minus_c, hx),
                    v.mul(minus_c, hy),
                    v.sub(one, v.mul(v.splat(s.ck1), hz)),
                )
            };
            let q = v.add(v.add(v.mul(nx, nx), v.mul(ny, ny)), v.mul(nz, nz));
            let p = v.add(v.add(v.mul(l, nx), v.mul(m, ny)), v.mul(n, nz));
            let facing = v.lt(p, zero);
            let p = v.select(facing, v.neg(p), p);
            let sign = v.select(facing, v.splat(-1.0), one);
            let mu = v.splat(s.mu);
            let radicand = v.add(
                v.mul(q, v.splat(s.one_minus_mu2)),
                v.mul(v.mul(v.splat(s.mu2), p), p),
            );
            let tir = v.and(arrived, v.lt(radicand, zero));
            let g = v.div(v.mul(sign, v.sub(v.sqrt(radicand), v.mul(mu, p))), q);
            let refracted = v.and(arrived, v.not(tir));
            let (new_l, new_m, new_n) = (
                v.add(v.mul(mu, l), v.mul(g, nx)),
                v.add(v.mul(mu, m), v.mul(g, ny)),
                v.add(v.mul(mu, n), v.mul(g, nz)),
            );
            // No valid direction (an overflowing normal, a cancelled one): missed here, as in the scalar
            // `finish`, by the same test in the same operation order.
            let length2 = v.add(
                v.add(v.mul(new_l, new_l), v.mul(new_m, new_m)),
                v.mul(new_n, new_n),
            );
            let valid_direction = v.le(
                v.abs(v.sub(length2, one)),
                v.splat(crate::surface::UNIT_DIRECTION_TOLERANCE),
            );
            let turned = v.and(refracted, valid_direction);
            ls[j] = v.select(turned, new_l, l);
            ms[j] = v.select(turned, new_m, m);
            ns[j] = v.select(turned, new_n, n);
            code = v.fail(tir, TIR, index, code);
            code = v.fail(v.and(refracted, v.not(valid_direction)), MISSED, index, code);
        }
        codes[j] = code;
    }
}

/// `Frame::point_to_local` / `vector_to_local` of every lane, in place on the global positions and the
/// directions, after saving them (a lane that does not arrive gets them back in `globalize_phase`).
#[inline(always)]
fn localize_phase<S: Simd>(simd: S, frame: &Frame, b: &mut Block) {
    let v = Lanes(simd);
    let global = &mut b.points[b.global];
    b.saved.x = global.x;
    b.saved.y = global.y;
    b.saved.z = global.z;
    b.saved_l = b.l;
    b.saved_m = b.m;
    b.saved_n = b.n;
    let (xs, _) = S::as_mut_simd_f64s(&mut global.x);
    let (ys, _) = S::as_mut_simd_f64s(&mut global.y);
    let (zs, _) = S::as_mut_simd_f64s(&mut global.z);
    let (ls, _) = S::as_mut_simd_f64s(&mut b.l);
    let (ms, _) = S::as_mut_simd_f64s(&mut b.m);
    let (ns, _) = S::as_mut_simd_f64s(&mut b.n);
    let r = splat_rotation(v, &frame.rotation);
    let o = [
        v.splat(frame.origin[0]),
        v.splat(frame.origin[1]),
        v.splat(frame.origin[2]),
    ];
    // R^T w: column k of R against w.
    let columns = [
        [r[0][0], r[1][0], r[2][0]],
        [r[0][1], r[1][1], r[2][1]],
        [r[0][2], r[1][2], r[2][2]],
    ];
    for j in 0..xs.len() {
        let d = [v.sub(xs[j], o[0]), v.sub(ys[j], o[1]), v.sub(zs[j], o[2])];
        let dir = [ls[j], ms[j], ns[j]];
        xs[j] = combine(v, columns[0], d);
        ys[j] = combine(v, columns[1], d);
        zs[j] = combine(v, columns[2], d);
        ls[j] = combine(v, columns[0], dir);
        ms[j] = combine(v, columns[1], dir);
        ns[j] = combine(v, columns[2], dir);
    }
}

/// (a0 w0 + a1 w1) + a2 w2, the scalar code's order (`Frame`'s rotations). A function rather than a
/// closure: closures do not inherit the SIMD context's target features, so their intrinsics would be
/// calls (they were, at 44% of a decentred lens's trace time).
#[inline(always)]
fn combine<S: Simd>(v: Lanes<S>, a: [S::f64s; 3], w: [S::f64s; 3]) -> S::f64s {
    v.add(v.add(v.mul(a[0], w[0]), v.mul(a[1], w[1])), v.mul(a[2], w[2]))
}

/// A rotation's entries as lanes.
#[inline(always)]
fn splat_rotation<S: Simd>(v: Lanes<S>, rotation: &[[f64; 3]; 3]) -> [[S::f64s; 3]; 3] {
    let row = |r: &[f64; 3]| [v.splat(r[0]), v.splat(r[1]), v.splat(r[2])];
    [row(&rotation[0]), row(&rotation[1]), row(&rotation[2])]
}

/// After `finish_phase` (and the swap of the point sets): lanes that arrived go back to global
/// coordinates (`Frame::point_to_global` / `vector_to_global`), the others get their saved state.
#[inline(always)]
fn globalize_phase<S: Simd>(simd: S, frame: &Frame, b: &mut Block) {
    let v = Lanes(simd);
    let global = &mut b.points[b.global];
    let (xs, _) = S::as_mut_simd_f64s(&mut global.x);
    let (ys, _) = S::as_mut_simd_f64s(&mut global.y);
    let (zs, _) = S::as_mut_simd_f64s(&mut global.z);
    let (ls, _) = S::as_mut_simd_f64s(&mut b.l);
    let (ms, _) = S::as_mut_simd_f64s(&mut b.m);
    let (ns, _) = S::as_mut_simd_f64s(&mut b.n);
    let (sxs, _) = S::as_simd_f64s(&b.saved.x);
    let (sys, _) = S::as_simd_f64s(&b.saved.y);
    let (szs, _) = S::as_simd_f64s(&b.saved.z);
    let (sls, _) = S::as_simd_f64s(&b.saved_l);
    let (sms, _) = S::as_simd_f64s(&b.saved_m);
    let (sns, _) = S::as_simd_f64s(&b.saved_n);
    let (arriveds, _) = S::as_simd_u64s(&b.arrived);
    let r = splat_rotation(v, &frame.rotation);
    let o = [
        v.splat(frame.origin[0]),
        v.splat(frame.origin[1]),
        v.splat(frame.origin[2]),
    ];
    // R w: row k of R against w.
    for j in 0..xs.len() {
        let arrived = simd.equal_u64s(arriveds[j], simd.splat_u64s(!0));
        let p = [xs[j], ys[j], zs[j]];
        let dir = [ls[j], ms[j], ns[j]];
        let moved = [
            v.add(o[0], combine(v, r[0], p)),
            v.add(o[1], combine(v, r[1], p)),
            v.add(o[2], combine(v, r[2], p)),
        ];
        let turned = [
            combine(v, r[0], dir),
            combine(v, r[1], dir),
            combine(v, r[2], dir),
        ];
        xs[j] = v.select(arrived, moved[0], sxs[j]);
        ys[j] = v.select(arrived, moved[1], sys[j]);
        zs[j] = v.select(arrived, moved[2], szs[j]);
        ls[j] = v.select(arrived, turned[0], sls[j]);
        ms[j] = v.select(arrived, turned[1], sms[j]);
        ns[j] = v.select(arrived, turned[2], sns[j]);
    }
}
