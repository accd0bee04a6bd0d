//! `TraceSystem`: a lens prepared for tracing at one wavelength, and the per-surface step
//! (intersection, aperture test, refraction) that every trace in unicac uses.
//!
//! Intersection, in the surface's local frame (vertex at the origin):
//! 1. Transfer the ray to the vertex tangent plane (keeps the quadratic's constant term small), unless it
//!    runs (nearly) parallel to that plane.
//! 2. Conic: F = c (x^2 + y^2 + (1+k) z^2) - 2 z = 0 along p + t d gives a t^2 - 2 b t + f = 0 with
//!    a = c (1 + k N^2), b = N - c (x L + y M + (1+k) z N), f = c (x^2 + y^2 + (1+k) z^2) - 2 z.
//!    The root nearest the tangent plane is t = f / (b + sign(b) sqrt(b^2 - a f)): no cancellation, exact
//!    for planes (c = 0) and paraboloids (a = 0). The hit must lie on the vertex sheet
//!    (1 - c (1+k) z > 0) and inside the conic's domain ((1+k) c^2 r^2 <= 1).
//! 3. Even asphere: Newton's method on g(t) = z(t) - sag(r(t)^2), started from the conic hit.
//!    Convergence rule: the step just taken satisfies |dt| <= 1e-9 (|t| + |x| + |y| + |z|) within
//!    `MAX_NEWTON_ITERATIONS` steps, else `NoConvergence`. Newton converges quadratically, so the error
//!    left after that step is about C dt^2 (C = |g''/2g'|, of the order of the curvature): below f64
//!    rounding for any surface whose curvature is not many orders above 1/scale. This saves the extra
//!    step a "|dt| at rounding level" rule needs (tests check 1e-11 mm agreement with closed forms).
//!
//! Refraction is vector Snell's law; a negative radicand is total internal reflection.

use crate::lanes::{trace_lanes, LaneSurface, SimdLevel};
use crate::ray::{Ray, RayStatus};
pub use crate::surface::{Frame, TraceSurface, LANE_BLOCK, MAX_NEWTON_ITERATIONS};
use crate::surface::{GRAZING_N, NEWTON_STEP_TOLERANCE, UNIT_DIRECTION_TOLERANCE};
use unicac_optics::{Lens, Result};

/// Relative distance a ray may "travel backwards" to a surface before `trace_path_from_start` calls it
/// missed (rounding of a ray that starts on the surface).
const BACKWARDS_TOLERANCE: f64 = 1e-12;

/// Whether clear semi-diameters clip rays (aiming and aperture sizing trace without clipping).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clipping {
    Apertures,
    None,
}

/// A lens at one wavelength.
#[derive(Debug, Clone)]
pub struct TraceSystem {
    pub surfaces: Vec<TraceSurface>,
    pub object_index: f64,
    pub wavelength_um: f64,
}

impl TraceSystem {
    pub fn new(lens: &Lens, wavelength_um: f64, clipping: Clipping) -> Result<TraceSystem> {
        let n = lens.media_indices(wavelength_um)?;
        let image = lens.image_index();
        let surfaces = lens
            .surfaces
            .iter()
            .enumerate()
            .map(|(i, s)| TraceSurface {
                z_mm: s.z_mm,
                frame: (!s.placement.is_centred()).then(|| Frame {
                    origin: [s.placement.decentre_x_mm, s.placement.decentre_y_mm, s.z_mm],
                    rotation: s.placement.rotation(),
                }),
                profile: s.profile,
                conic_rho_limit: s.profile.conic_rho_limit(),
                // The image surface is the detector: its semi-diameter describes it, it never vignettes.
                clip_rho: match (clipping, s.semi_diameter_mm) {
                    (Clipping::Apertures, Some(sd)) if i != image => sd * sd,
                    _ => f64::INFINITY,
                },
                index_after: n[i + 1],
            })
            .collect();
        Ok(TraceSystem {
            surfaces,
            object_index: n[0],
            wavelength_um,
        })
    }

    pub fn image_index(&self) -> usize {
        self.surfaces.len() - 1
    }

    /// True when no surface is decentred or tilted.
    pub fn is_rotationally_symmetric(&self) -> bool {
        self.surfaces.iter().all(|s| s.frame.is_none())
    }

    /// A global point in the frame of surface `index` (its vertex at the origin, its axis along z).
    pub fn to_surface_frame(&self, index: usize, point: [f64; 3]) -> [f64; 3] {
        let surface = &self.surfaces[index];
        match &surface.frame {
            None => [point[0], point[1], point[2] - surface.z_mm],
            Some(frame) => frame.point_to_local(point),
        }
    }

    /// Traces `ray` in place through surfaces 0..=last. Surfaces before `last` refract; `last` itself
    /// refracts only if `refract_last`. On failure the ray keeps its last valid state.
    #[inline]
    pub fn trace_through(&self, ray: &mut Ray, last: usize, refract_last: bool) -> RayStatus {
        self.walk(ray, last, refract_last, |_, _, _| {})
    }

    /// The one surface-by-surface loop behind the single-ray traces: steps `ray` through surfaces
    /// 0..=last and calls `visit(ray before the surface, ray after it, index before)` after each
    /// successful step.
    #[inline]
    fn walk(
        &self,
        ray: &mut Ray,
        last: usize,
        refract_last: bool,
        mut visit: impl FnMut(&Ray, &Ray, f64),
    ) -> RayStatus {
        if !ray.is_finite() {
            return RayStatus::InvalidInput;
        }
        let mut n_before = self.object_index;
        for (i, surface) in self.surfaces[..=last].iter().enumerate() {
            let before = *ray;
            let refract = i < last || refract_last;
            let status = match &surface.frame {
                None => step(surface, i as u32, ray, n_before, refract),
                Some(frame) => placed_step(surface, frame, i as u32, ray, n_before, refract),
            };
            if !status.is_ok() {
                return status;
            }
            visit(&before, ray, n_before);
            n_before = surface.index_after;
        }
        RayStatus::Ok
    }

    /// Traces a chunk of rays to the image surface with the lane tracer (`lanes.rs`: SIMD over rays at
    /// the widest instruction set the CPU has, surface by surface over blocks of `LANE_BLOCK` rays).
    /// Same results, bit for bit, as `trace` on each ray.
    pub fn trace_chunk(&self, rays: &mut [Ray], statuses: &mut [RayStatus]) {
        self.trace_chunk_at(SimdLevel::detected(), rays, statuses);
    }

    /// `trace_chunk` at a chosen instruction-set level (clamped to what the CPU supports): for the
    /// tests that hold every level to the scalar path, and for the benches.
    pub fn trace_chunk_at(&self, level: SimdLevel, rays: &mut [Ray], statuses: &mut [RayStatus]) {
        debug_assert_eq!(rays.len(), statuses.len(), "one status per ray");
        let last = self.image_index();
        let mut n_before = self.object_index;
        let surfaces: Vec<LaneSurface> = self
            .surfaces
            .iter()
            .enumerate()
            .map(|(i, surface)| {
                let lane = match &surface.frame {
                    None => LaneSurface::new(surface, n_before, i < last),
                    Some(frame) => LaneSurface::placed(&surface.local(), *frame, n_before, i < last),
                };
                n_before = surface.index_after;
                lane
            })
            .collect();
        trace_lanes(level, &surfaces, rays, statuses);
    }

    /// Traces to the image surface (the last surface).
    #[inline]
    pub fn trace(&self, ray: &mut Ray) -> RayStatus {
        self.trace_through(ray, self.image_index(), false)
    }

    /// Traces to the image surface and returns the optical path length (sum of index x signed
    /// distance, mm) from the ray's start point to its image-surface intercept. Used by wave-optics PSFs;
    /// the hot paths do not pay for it.
    pub fn trace_with_opl(&self, ray: &mut Ray) -> (RayStatus, f64) {
        let mut opl = 0.0;
        let status = self.walk(ray, self.image_index(), false, |before, after, n_before| {
            let delta = [0, 1, 2].map(|k| after.position_mm[k] - before.position_mm[k]);
            let d = before.direction;
            let along = delta[0] * d[0] + delta[1] * d[1] + delta[2] * d[2];
            // |delta| with the sign of travel along the ray (virtual segments count negative).
            opl += n_before
                * (delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2])
                    .sqrt()
                    .copysign(along);
        });
        (status, opl)
    }

    /// Like `trace_path`, for a ray that physically starts where it is (a ray given by a user): every
    /// surface must lie ahead of it. A ray pointing away from the lens, or starting past the image
    /// surface, is `Missed` at the first surface it would have to travel backwards to, instead of being
    /// traced as if it had come from the other side. A gap of negative thickness is traversed
    /// backwards by design and is exempt. (Aimed rays start on the entrance-pupil plane, which may
    /// be virtual, and use `trace`.)
    pub fn trace_path_from_start(&self, ray: Ray) -> (Vec<[f64; 3]>, RayStatus) {
        let mut ray = ray;
        let mut points = vec![ray.position_mm];
        let status = self.walk_from_start(&mut ray, |point| points.push(point));
        (points, status)
    }

    /// `trace` for a ray that physically starts where it is (the rule of `trace_path_from_start`,
    /// without recording the path): what the Python binding's `trace` of user rays runs.
    pub fn trace_from_start(&self, ray: &mut Ray) -> RayStatus {
        self.walk_from_start(ray, |_| {})
    }

    /// The walk of `trace_path_from_start`: `on_point` gets every surface point reached before the ray
    /// would have to travel backwards.
    fn walk_from_start(&self, ray: &mut Ray, mut on_point: impl FnMut([f64; 3])) -> RayStatus {
        let mut surface = 0usize;
        let mut backwards_at: Option<u32> = None;
        let status = self.walk(ray, self.image_index(), false, |before, after, _| {
            let delta = [0, 1, 2].map(|k| after.position_mm[k] - before.position_mm[k]);
            let d = before.direction;
            let along = delta[0] * d[0] + delta[1] * d[1] + delta[2] * d[2];
            let scale = 1.0
                + before
                    .position_mm
                    .iter()
                    .chain(&after.position_mm)
                    .fold(0.0f64, |m, v| m.max(v.abs()));
            let negative_gap = surface > 0 && self.surfaces[surface].z_mm < self.surfaces[surface - 1].z_mm;
            if backwards_at.is_none() && !negative_gap && along < -BACKWARDS_TOLERANCE * scale {
                backwards_at = Some(surface as u32);
            }
            if backwards_at.is_none() {
                on_point(after.position_mm);
            }
            surface += 1;
        });
        match backwards_at {
            Some(surface) => RayStatus::Missed { surface },
            None => status,
        }
    }

    /// Traces to the image surface and records the point on every surface it reaches (for layouts and
    /// aperture sizing). The first entry is the starting point.
    pub fn trace_path(&self, ray: Ray) -> (Vec<[f64; 3]>, RayStatus) {
        let mut ray = ray;
        let mut points = vec![ray.position_mm];
        let status = self.walk(&mut ray, self.image_index(), false, |_, after, _| {
            points.push(after.position_mm)
        });
        (points, status)
    }
}

/// A ray in a surface's local frame (vertex at the origin): where it starts, its direction, and the
/// intersection parameter found so far.
#[derive(Debug, Clone, Copy, Default)]
struct LocalHit {
    start: [f64; 3],
    direction: [f64; 3],
    t: f64,
}

impl LocalHit {
    #[inline]
    fn point(&self) -> [f64; 3] {
        let [x, y, z] = self.start;
        let [l, m, n] = self.direction;
        [x + self.t * l, y + self.t * m, z + self.t * n]
    }
}

/// Outcome of one Newton step on an even asphere.
enum NewtonStep {
    Converged,
    Continue,
    Failed(RayStatus),
}

/// `step` at a decentred or tilted surface: the ray is taken into the surface's frame, stepped there,
/// and taken back if it arrived (a ray stopped before the surface keeps its global state untouched).
fn placed_step(
    surface: &TraceSurface,
    frame: &Frame,
    index: u32,
    ray: &mut Ray,
    n_before: f64,
    refract: bool,
) -> RayStatus {
    let local_surface = surface.local();
    let mut local = Ray {
        position_mm: frame.point_to_local(ray.position_mm),
        direction: frame.vector_to_local(ray.direction),
    };
    let hit = match intersect(&local_surface, index, &local) {
        Ok(hit) => hit,
        Err(status) => return status,
    };
    let status = finish(&local_surface, index, &mut local, &hit, n_before, refract);
    if arrives(&local_surface, &hit) {
        ray.position_mm = frame.point_to_global(local.position_mm);
        ray.direction = frame.vector_to_global(local.direction);
    }
    status
}

/// Whether `finish` moves the ray to `hit` (inside the clear aperture, finite): the tests of `finish`,
/// in the same form.
#[inline]
fn arrives(surface: &TraceSurface, hit: &LocalHit) -> bool {
    let point = hit.point();
    let rho = point[0] * point[0] + point[1] * point[1];
    rho <= surface.clip_rho && point[0].is_finite() && point[1].is_finite() && point[2].is_finite()
}

/// Intersects, clips and (optionally) refracts at one surface.
#[inline]
fn step(surface: &TraceSurface, index: u32, ray: &mut Ray, n_before: f64, refract: bool) -> RayStatus {
    match intersect(surface, index, ray) {
        Ok(hit) => finish(surface, index, ray, &hit, n_before, refract),
        Err(status) => status,
    }
}

/// The intersection of `ray` with the surface (steps 1-3 of the module docs), in the surface's frame.
#[inline]
fn intersect(surface: &TraceSurface, index: u32, ray: &Ray) -> Result<LocalHit, RayStatus> {
    let mut hit = conic_hit(surface, index, ray)?;
    if surface.profile.has_polynomial() {
        let mut converged = false;
        for _ in 0..MAX_NEWTON_ITERATIONS {
            match newton_step(surface, index, &mut hit) {
                NewtonStep::Converged => {
                    converged = true;
                    break;
                }
                NewtonStep::Continue => {}
                NewtonStep::Failed(status) => return Err(status),
            }
        }
        if !converged {
            return Err(RayStatus::NoConvergence { surface: index });
        }
    }
    Ok(hit)
}

/// Transfer to the tangent plane and the closed-form conic intersection (steps 1 and 2 of the module
/// docs). For an even asphere this is Newton's starting point.
#[inline]
fn conic_hit(surface: &TraceSurface, index: u32, ray: &Ray) -> Result<LocalHit, RayStatus> {
    let [l, m, n] = ray.direction;
    let mut x = ray.position_mm[0];
    let mut y = ray.position_mm[1];
    let mut z = ray.position_mm[2] - surface.z_mm;
    // Rays (nearly) parallel to the tangent plane are solved from where they are: the transfer would
    // throw them astronomically far and the quadratic would cancel catastrophically.
    if n.abs() > GRAZING_N {
        let t0 = -z / n;
        x += t0 * l;
        y += t0 * m;
        z = 0.0;
    }
    let p = &surface.profile;
    let c = p.curvature_per_mm;
    let k1 = 1.0 + p.conic;
    let a = c * (1.0 + p.conic * n * n);
    let b = n - c * (x * l + y * m + k1 * z * n);
    let f = c * (x * x + y * y + k1 * z * z) - 2.0 * z;
    let discriminant = b * b - a * f;
    if !(discriminant >= 0.0) {
        return Err(RayStatus::Missed { surface: index });
    }
    let denominator = b + discriminant.sqrt().copysign(b);
    // Both roots at infinity (a ray along a plane, or tangent to a paraboloid's axis direction).
    if denominator == 0.0 && f != 0.0 {
        return Err(RayStatus::Missed { surface: index });
    }
    let hit = LocalHit {
        start: [x, y, z],
        direction: [l, m, n],
        t: if f == 0.0 { 0.0 } else { f / denominator },
    };
    let [hx, hy, hz] = hit.point();
    if hx * hx + hy * hy > surface.conic_rho_limit || 1.0 - c * k1 * hz <= 0.0 {
        return Err(RayStatus::Missed { surface: index });
    }
    Ok(hit)
}

/// One Newton step on g(t) = z(t) - sag(r(t)^2) (step 3 of the module docs).
#[inline]
fn newton_step(surface: &TraceSurface, index: u32, hit: &mut LocalHit) -> NewtonStep {
    let [x, y, z] = hit.point();
    let d = hit.direction;
    let rho = x * x + y * y;
    if !(rho <= surface.conic_rho_limit) {
        return NewtonStep::Failed(RayStatus::Missed { surface: index });
    }
    let (sag, slope) = surface.profile.sag_and_slope(rho);
    let derivative = d[2] - 2.0 * slope * (x * d[0] + y * d[1]);
    if derivative == 0.0 || !derivative.is_finite() {
        return NewtonStep::Failed(RayStatus::Missed { surface: index });
    }
    let dt = (z - sag) / derivative;
    hit.t -= dt;
    if !hit.t.is_finite() {
        NewtonStep::Failed(RayStatus::Missed { surface: index })
    } else if dt.abs() <= NEWTON_STEP_TOLERANCE * (hit.t.abs() + x.abs() + y.abs() + z.abs()) + 1e-300 {
        NewtonStep::Converged
    } else {
        NewtonStep::Continue
    }
}

/// Aperture test, the new position in global coordinates, and refraction.
#[inline]
fn finish(
    surface: &TraceSurface,
    index: u32,
    ray: &mut Ray,
    hit: &LocalHit,
    n_before: f64,
    refract: bool,
) -> RayStatus {
    let point = hit.point();
    let rho = point[0] * point[0] + point[1] * point[1];
    if !(rho <= surface.clip_rho) {
        return RayStatus::Clipped { surface: index };
    }
    if !(point[0].is_finite() && point[1].is_finite() && point[2].is_finite()) {
        return RayStatus::Missed { surface: index };
    }
    ray.position_mm = [point[0], point[1], point[2] + surface.z_mm];
    if refract && n_before != surface.index_after {
        let p = &surface.profile;
        let normal = if p.has_polynomial() {
            let slope = p.sag_and_slope(rho).1;
            [-2.0 * point[0] * slope, -2.0 * point[1] * slope, 1.0]
        } else {
            let c = p.curvature_per_mm;
            [-c * point[0], -c * point[1], 1.0 - c * (1.0 + p.conic) * point[2]]
        };
        match refract_direction(ray.direction, normal, n_before / surface.index_after) {
            Some(direction) if is_unit(direction) => ray.direction = direction,
            // Found by fuzzing: a normal that overflows (an r^2 coefficient of 6e306) gives a NaN
            // direction, and an index ratio of 1e36 cancels the refracted direction to zero. No valid
            // direction: the ray is lost at this surface and keeps its last valid one.
            Some(_) => return RayStatus::Missed { surface: index },
            None => return RayStatus::Tir { surface: index },
        }
    }
    RayStatus::Ok
}

#[inline]
fn is_unit(d: [f64; 3]) -> bool {
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - 1.0).abs() <= UNIT_DIRECTION_TOLERANCE
}

/// Vector Snell's law. `normal` need not be unit length or face the ray; `mu` = n_before / n_after.
/// Returns `None` on total internal reflection.
///
/// With the raw normal N, q = N.N and p = d.N (p >= 0 after orienting N along d):
/// d' = mu d + g N, g = (sqrt(q (1 - mu^2) + mu^2 p^2) - mu p) / q, which is the textbook
/// mu d + (cos T - mu cos I) N/|N| with the normalisation folded in: one square root and one division.
#[inline]
pub fn refract_direction(d: [f64; 3], normal: [f64; 3], mu: f64) -> Option<[f64; 3]> {
    let q = normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2];
    let p = d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2];
    let (p, sign) = if p < 0.0 { (-p, -1.0) } else { (p, 1.0) };
    let radicand = q * (1.0 - mu * mu) + mu * mu * p * p;
    if radicand < 0.0 {
        return None;
    }
    let g = sign * (radicand.sqrt() - mu * p) / q;
    Some([
        mu * d[0] + g * normal[0],
        mu * d[1] + g * normal[1],
        mu * d[2] + g * normal[2],
    ])
}
