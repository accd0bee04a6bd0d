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
//!    Convergence rule: |dt| <= 4 eps (|t| + |z| + r) + 1e-300 within `MAX_NEWTON_ITERATIONS` steps,
//!    else `NoConvergence`.
//!
//! Refraction is vector Snell's law; a negative radicand is total internal reflection.

use crate::ray::{Ray, RayStatus};
use unicac_optics::{Lens, Profile, Result};

pub const MAX_NEWTON_ITERATIONS: usize = 40;

/// Below this |N| a ray counts as parallel to a surface's tangent plane (angle > 89.99994 deg).
const GRAZING_N: f64 = 1e-6;

/// Whether clear semi-diameters clip rays (aiming and aperture sizing trace without clipping).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clipping {
    Apertures,
    None,
}

/// One surface with everything the inner loop needs, precomputed.
#[derive(Debug, Clone, Copy)]
pub struct TraceSurface {
    pub z_mm: f64,
    pub profile: Profile,
    /// r^2 limit of the conic base (infinite if unbounded).
    pub conic_rho_limit: f64,
    /// Squared clear semi-diameter (infinite when not clipping).
    pub clip_rho: f64,
    /// Index of the medium after the surface.
    pub index_after: f64,
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
        let surfaces = lens
            .surfaces
            .iter()
            .enumerate()
            .map(|(i, s)| TraceSurface {
                z_mm: s.z_mm,
                profile: s.profile,
                conic_rho_limit: s.profile.conic_rho_limit(),
                clip_rho: match (clipping, s.semi_diameter_mm) {
                    (Clipping::Apertures, Some(sd)) => sd * sd,
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

    /// Traces `ray` in place through surfaces 0..=last. Surfaces before `last` refract; `last` itself
    /// refracts only if `refract_last`. On failure the ray keeps its last valid state.
    #[inline]
    pub fn trace_through(&self, ray: &mut Ray, last: usize, refract_last: bool) -> RayStatus {
        if !ray.is_finite() {
            return RayStatus::InvalidInput;
        }
        let mut n_before = self.object_index;
        for (i, surface) in self.surfaces[..=last].iter().enumerate() {
            let status = step(surface, i as u32, ray, n_before, i < last || refract_last);
            if !status.is_ok() {
                return status;
            }
            n_before = surface.index_after;
        }
        RayStatus::Ok
    }

    /// Traces a chunk of rays to the image surface, surface by surface: the rays of one surface are
    /// independent, so the CPU overlaps their long division/square-root chains, where ray-by-ray
    /// order would serialise them. Rays that failed are skipped from then on. Same results, bit for bit,
    /// as `trace` on each ray.
    pub fn trace_chunk(&self, rays: &mut [Ray], statuses: &mut [RayStatus]) {
        for (ray, status) in rays.iter().zip(statuses.iter_mut()) {
            *status = if ray.is_finite() {
                RayStatus::Ok
            } else {
                RayStatus::InvalidInput
            };
        }
        let last = self.image_index();
        let mut n_before = self.object_index;
        for (i, surface) in self.surfaces.iter().enumerate() {
            for (ray, status) in rays.iter_mut().zip(statuses.iter_mut()) {
                if status.is_ok() {
                    *status = step(surface, i as u32, ray, n_before, i < last);
                }
            }
            n_before = surface.index_after;
        }
    }

    /// Traces to the image surface (the last surface).
    #[inline]
    pub fn trace(&self, ray: &mut Ray) -> RayStatus {
        self.trace_through(ray, self.image_index(), false)
    }

    /// Traces to the image surface and records the point on every surface it reaches (for layouts and
    /// aperture sizing). The first entry is the starting point.
    pub fn trace_path(&self, ray: Ray) -> (Vec<[f64; 3]>, RayStatus) {
        let mut ray = ray;
        let mut points = vec![ray.position_mm];
        if !ray.is_finite() {
            return (points, RayStatus::InvalidInput);
        }
        let mut n_before = self.object_index;
        let last = self.image_index();
        for (i, surface) in self.surfaces.iter().enumerate() {
            let status = step(surface, i as u32, &mut ray, n_before, i < last);
            if !status.is_ok() {
                return (points, status);
            }
            points.push(ray.position_mm);
            n_before = surface.index_after;
        }
        (points, RayStatus::Ok)
    }
}

/// Intersects, clips and (optionally) refracts at one surface.
#[inline]
fn step(surface: &TraceSurface, index: u32, ray: &mut Ray, n_before: f64, refract: bool) -> RayStatus {
    let [l, m, n] = ray.direction;
    // Local coordinates, transferred to the vertex tangent plane when the ray is not parallel to it.
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
        return RayStatus::Missed { surface: index };
    }
    let denominator = b + discriminant.sqrt().copysign(b);
    if denominator == 0.0 {
        // Both roots at infinity (a ray along a plane, or tangent to a paraboloid's axis direction).
        if f != 0.0 {
            return RayStatus::Missed { surface: index };
        }
    }
    let mut t = if f == 0.0 { 0.0 } else { f / denominator };
    let mut hit = [x + t * l, y + t * m, z + t * n];
    let mut rho = hit[0] * hit[0] + hit[1] * hit[1];
    if rho > surface.conic_rho_limit || 1.0 - c * k1 * hit[2] <= 0.0 {
        return RayStatus::Missed { surface: index };
    }
    if p.has_polynomial() {
        match newton_asphere(p, surface.conic_rho_limit, [x, y, z], [l, m, n], t) {
            Ok(solved) => t = solved,
            Err(status) => return status.at(index),
        }
        hit = [x + t * l, y + t * m, z + t * n];
        rho = hit[0] * hit[0] + hit[1] * hit[1];
    }
    if !(rho <= surface.clip_rho) {
        return RayStatus::Clipped { surface: index };
    }
    if !(hit[0].is_finite() && hit[1].is_finite() && hit[2].is_finite()) {
        return RayStatus::Missed { surface: index };
    }
    ray.position_mm = [hit[0], hit[1], hit[2] + surface.z_mm];
    if refract && n_before != surface.index_after {
        let normal = if p.has_polynomial() {
            let slope = p.sag_and_slope(rho).1;
            [-2.0 * hit[0] * slope, -2.0 * hit[1] * slope, 1.0]
        } else {
            [-c * hit[0], -c * hit[1], 1.0 - c * k1 * hit[2]]
        };
        match refract_direction(ray.direction, normal, n_before / surface.index_after) {
            Some(direction) => ray.direction = direction,
            None => return RayStatus::Tir { surface: index },
        }
    }
    RayStatus::Ok
}

/// Failure of the asphere solve, placed at a surface by `at`.
enum NewtonFailure {
    Missed,
    NoConvergence,
}

impl NewtonFailure {
    fn at(self, surface: u32) -> RayStatus {
        match self {
            NewtonFailure::Missed => RayStatus::Missed { surface },
            NewtonFailure::NoConvergence => RayStatus::NoConvergence { surface },
        }
    }
}

#[inline]
fn newton_asphere(
    p: &Profile,
    rho_limit: f64,
    start: [f64; 3],
    d: [f64; 3],
    t0: f64,
) -> Result<f64, NewtonFailure> {
    let mut t = t0;
    for _ in 0..MAX_NEWTON_ITERATIONS {
        let x = start[0] + t * d[0];
        let y = start[1] + t * d[1];
        let z = start[2] + t * d[2];
        let rho = x * x + y * y;
        if !(rho <= rho_limit) {
            return Err(NewtonFailure::Missed);
        }
        let (sag, slope) = p.sag_and_slope(rho);
        let residual = z - sag;
        let derivative = d[2] - 2.0 * slope * (x * d[0] + y * d[1]);
        if derivative == 0.0 || !derivative.is_finite() {
            return Err(NewtonFailure::Missed);
        }
        let dt = residual / derivative;
        t -= dt;
        if dt.abs() <= 4.0 * f64::EPSILON * (t.abs() + z.abs() + rho.sqrt()) + 1e-300 {
            return if t.is_finite() {
                Ok(t)
            } else {
                Err(NewtonFailure::Missed)
            };
        }
    }
    Err(NewtonFailure::NoConvergence)
}

/// Vector Snell's law. `normal` need not be unit length or face the ray; `mu` = n_before / n_after.
/// Returns `None` on total internal reflection.
#[inline]
pub fn refract_direction(d: [f64; 3], normal: [f64; 3], mu: f64) -> Option<[f64; 3]> {
    let inv = 1.0 / (normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]).sqrt();
    let mut nrm = normal.map(|v| v * inv);
    let mut cos_i = d[0] * nrm[0] + d[1] * nrm[1] + d[2] * nrm[2];
    if cos_i < 0.0 {
        nrm = nrm.map(|v| -v);
        cos_i = -cos_i;
    }
    let cos_t_squared = 1.0 - mu * mu * (1.0 - cos_i * cos_i);
    if cos_t_squared < 0.0 {
        return None;
    }
    let g = cos_t_squared.sqrt() - mu * cos_i;
    Some([
        mu * d[0] + g * nrm[0],
        mu * d[1] + g * nrm[1],
        mu * d[2] + g * nrm[2],
    ])
}
