//! The design tracer: a compact real-ray tracer and paraxial tracer generic over `Scalar`, so the merit
//! and its exact gradient come from one code path. Object at infinity; paraxial ray aiming (rays of
//! field F pass through the paraxial entrance pupil, Zemax "ray aiming off"), as unicac-trace's
//! `Aiming::Paraxial`.
//!
//! The per-surface arithmetic mirrors `unicac_trace::system` step for step (tangent-plane transfer,
//! cancellation-free conic root, Newton for the polynomial, vector Snell), so in f64 both agree to
//! rounding (tests: 1e-12 mm). For even aspheres Newton runs to convergence on the value and then takes
//! one more step: by the implicit function theorem that step makes the derivative part exact.
//! unicac-trace stays the reference and the f64 hot path; this one exists for gradients.

use crate::scalar::Scalar;
use crate::system::Prescription;

use unicac_trace::surface::{GRAZING_N, MAX_NEWTON_ITERATIONS, NEWTON_STEP_TOLERANCE};

#[derive(Debug, Clone, Copy)]
pub struct Ray<S> {
    pub position: [S; 3],
    pub direction: [S; 3],
}

/// Why a ray stopped (0-based surface index).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RayFailure {
    Missed(usize),
    Tir(usize),
    NoConvergence(usize),
}

/// A prescription prepared at one wavelength.
pub struct Tracer<'a, S> {
    pub prescription: &'a Prescription<S>,
    pub z: Vec<S>,
    pub indices: Vec<S>,
}

impl<'a, S: Scalar> Tracer<'a, S> {
    pub fn new(prescription: &'a Prescription<S>, wavelength_um: f64) -> Self {
        Tracer {
            prescription,
            z: prescription.vertex_z(),
            indices: prescription.indices(wavelength_um),
        }
    }

    /// Traces `ray` to the image plane; `visit(surface, local hit point)` is called at each surface.
    pub fn trace(&self, ray: &mut Ray<S>, mut visit: impl FnMut(usize, &[S; 3])) -> Result<(), RayFailure> {
        let surfaces = &self.prescription.surfaces;
        for (i, surface) in surfaces.iter().enumerate() {
            let hit = self.intersect(i, ray)?;
            visit(i, &hit);
            ray.position = [hit[0], hit[1], hit[2] + self.z[i]];
            let (n_before, n_after) = (self.indices[i], self.indices[i + 1]);
            if n_before.re() != n_after.re() {
                let normal = if surface.is_asphere {
                    let rho = hit[0] * hit[0] + hit[1] * hit[1];
                    let slope = surface.sag_and_slope(rho).ok_or(RayFailure::Missed(i))?.1;
                    [hit[0] * slope * -2.0, hit[1] * slope * -2.0, S::cst(1.0)]
                } else {
                    let c = surface.curvature;
                    [
                        -(c * hit[0]),
                        -(c * hit[1]),
                        S::cst(1.0) - c * (surface.conic + 1.0) * hit[2],
                    ]
                };
                ray.direction =
                    refract(ray.direction, normal, n_before / n_after).ok_or(RayFailure::Tir(i))?;
            }
        }
        // The image plane.
        let image = surfaces.len();
        let [l, m, n] = ray.direction;
        if n.re().abs() <= GRAZING_N {
            return Err(RayFailure::Missed(image));
        }
        let t = (self.z[image] - ray.position[2]) / n;
        ray.position = [ray.position[0] + t * l, ray.position[1] + t * m, self.z[image]];
        Ok(())
    }

    /// The hit point of `ray` on surface `i`, in the surface's local frame.
    fn intersect(&self, i: usize, ray: &Ray<S>) -> Result<[S; 3], RayFailure> {
        let surface = &self.prescription.surfaces[i];
        let [l, m, n] = ray.direction;
        let mut x = ray.position[0];
        let mut y = ray.position[1];
        let mut z = ray.position[2] - self.z[i];
        if n.re().abs() > GRAZING_N {
            let t0 = -z / n;
            x = x + t0 * l;
            y = y + t0 * m;
            z = S::cst(0.0);
        }
        let c = surface.curvature;
        let k1 = surface.conic + 1.0;
        let a = c * (surface.conic * n * n + 1.0);
        let b = n - c * (x * l + y * m + k1 * z * n);
        let f = c * (x * x + y * y + k1 * z * z) - z * 2.0;
        let discriminant = b * b - a * f;
        if !(discriminant.re() >= 0.0) {
            return Err(RayFailure::Missed(i));
        }
        let root = discriminant.sqrt();
        let denominator = if b.re() < 0.0 { b - root } else { b + root };
        if denominator.re() == 0.0 && f.re() != 0.0 {
            return Err(RayFailure::Missed(i));
        }
        let mut t = if f.re() == 0.0 { f } else { f / denominator };
        let point = |t: S| [x + t * l, y + t * m, z + t * n];
        let [hx, hy, hz] = point(t);
        let rho = hx * hx + hy * hy;
        let conic_limit = k1.re() * c.re() * c.re();
        if (conic_limit > 0.0 && rho.re() > 1.0 / conic_limit) || 1.0 - c.re() * k1.re() * hz.re() <= 0.0 {
            return Err(RayFailure::Missed(i));
        }
        if surface.is_asphere {
            let mut converged = false;
            for _ in 0..MAX_NEWTON_ITERATIONS {
                let [px, py, pz] = point(t);
                let rho = px * px + py * py;
                let (sag, slope) = surface.sag_and_slope(rho).ok_or(RayFailure::Missed(i))?;
                let derivative = n - slope * (px * l + py * m) * 2.0;
                if derivative.re() == 0.0 || !derivative.re().is_finite() {
                    return Err(RayFailure::Missed(i));
                }
                let dt = (pz - sag) / derivative;
                t = t - dt;
                if !t.re().is_finite() {
                    return Err(RayFailure::Missed(i));
                }
                if converged {
                    break;
                }
                let scale = t.re().abs() + px.re().abs() + py.re().abs() + pz.re().abs();
                // One more step after the value converged carries the derivative to convergence too.
                converged = dt.re().abs() <= NEWTON_STEP_TOLERANCE * scale + 1e-300;
            }
            if !converged {
                return Err(RayFailure::NoConvergence(i));
            }
        }
        let hit = point(t);
        if !(hit.iter().all(|v| v.re().is_finite())) {
            return Err(RayFailure::Missed(i));
        }
        Ok(hit)
    }
}

/// Vector Snell's law, as `unicac_trace::system::refract_direction`.
#[inline]
pub fn refract<S: Scalar>(d: [S; 3], normal: [S; 3], mu: S) -> Option<[S; 3]> {
    let q = normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2];
    let p = d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2];
    let (p, sign) = if p.re() < 0.0 { (-p, -1.0) } else { (p, 1.0) };
    let radicand = q * (S::cst(1.0) - mu * mu) + mu * mu * p * p;
    if radicand.re() < 0.0 {
        return None;
    }
    let g = (radicand.sqrt() - mu * p) / q * sign;
    Some([
        mu * d[0] + g * normal[0],
        mu * d[1] + g * normal[1],
        mu * d[2] + g * normal[2],
    ])
}

/// First-order data of a prescription at one wavelength (object at infinity).
#[derive(Debug, Clone, Copy)]
pub struct Paraxial<S> {
    pub efl: S,
    /// Last surface to the paraxial focus.
    pub bfd: S,
    /// Global z of the paraxial entrance pupil.
    pub entrance_pupil_z: S,
}

/// (y, nu) traces: y-nu refraction nu' = nu - y c (n' - n), transfer y' = y + t nu' / n'.
/// `upto`: refract at surfaces 0..upto (exclusive), transferring to surface `upto`'s vertex plane.
pub fn paraxial_ray<S: Scalar>(p: &Prescription<S>, indices: &[S], y0: S, nu0: S, upto: usize) -> (S, S) {
    let (mut y, mut nu) = (y0, nu0);
    for i in 0..upto {
        let s = &p.surfaces[i];
        nu = nu - y * s.curvature * (indices[i + 1] - indices[i]);
        y = y + s.thickness * nu / indices[i + 1];
    }
    (y, nu)
}

/// EFL, BFD and entrance pupil; `None` for an afocal system or a stop imaged to infinity.
pub fn paraxial<S: Scalar>(p: &Prescription<S>, wavelength_um: f64) -> Option<Paraxial<S>> {
    let indices = p.indices(wavelength_um);
    let last = p.surfaces.len() - 1;
    let (y, nu) = paraxial_ray(p, &indices, S::cst(1.0), S::cst(0.0), last);
    let s = &p.surfaces[last];
    let nu_out = nu - y * s.curvature * (indices[last + 1] - indices[last]);
    if nu_out.re() == 0.0 {
        return None;
    }
    let stop = p.stop_index();
    let (stop_a, _) = paraxial_ray(p, &indices, S::cst(1.0), S::cst(0.0), stop);
    let (stop_b, _) = paraxial_ray(p, &indices, S::cst(0.0), S::cst(1.0), stop);
    if stop_a.re() == 0.0 {
        return None;
    }
    Some(Paraxial {
        efl: -(S::cst(1.0) / nu_out),
        bfd: -(y * indices[last + 1] / nu_out),
        entrance_pupil_z: stop_b / stop_a,
    })
}

/// The ray of field `field_deg` through normalised pupil point (px, py) of a paraxial entrance pupil of
/// radius `pupil_radius` at global z `pupil_z` (unicac-trace's paraxial aiming, object at infinity).
pub fn aimed_ray<S: Scalar>(field_deg: f64, px: f64, py: f64, pupil_radius: S, pupil_z: S) -> Ray<S> {
    let (sin_f, cos_f) = field_deg.to_radians().sin_cos();
    // Normalised as `unicac_trace::Ray::new` does, so both start from the same bits.
    let norm = (sin_f * sin_f + cos_f * cos_f).sqrt();
    Ray {
        position: [pupil_radius * px, pupil_radius * py, pupil_z],
        direction: [S::cst(0.0), S::cst(sin_f / norm), S::cst(cos_f / norm)],
    }
}
