//! Ray aiming: which object-space ray belongs to a field angle and a normalised pupil point.
//!
//! - `Paraxial` (Zemax "ray aiming off"): the ray has direction (0, sin F, cos F) and passes through
//!   (px, py) * EPD/2 on the paraxial entrance-pupil plane (object at infinity); for a finite object it
//!   leaves the object point of field F towards that pupil point.
//! - `Real`: the ray of the same field crosses the stop surface at (px, py) * R_stop, R_stop being the
//!   paraxial marginal-ray height at the stop. Solved by Newton's method on the entrance-pupil-plane
//!   point with a finite-difference Jacobian, from the paraxial guess; where that fails (wide fields),
//!   by continuation from the axis in growing field steps. Whole pupils (`rays_at`, `for_field`) start
//!   from a fitted aiming map instead and are held to the same stop tolerance (`aim_map`).
//!
//! - `Auto` (the default): `Real` for lenses whose paraxial chief ray misses the stop centre by more than
//!   `AUTO_REAL_AIMING_STOP_MISS` of R_stop at the largest field, else `Paraxial` (`AutoAiming`).
//!
//! Pupils come from the primary wavelength, as in Zemax; each ray is aimed at its own wavelength.

use crate::error::{TraceError, TraceResult};
use crate::ray::Ray;
use crate::system::{Clipping, TraceSystem};
use serde::Serialize;
use unicac_optics::{FirstOrder, Lens};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Aiming {
    Paraxial,
    Real,
    /// `Real` when the lens's pupil is aberrated enough for paraxial aiming to be wrong, else `Paraxial`
    /// (see `AutoAiming`). Resolved once per lens by `Aimer::new`.
    #[default]
    Auto,
}

impl std::str::FromStr for Aiming {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "paraxial" => Ok(Aiming::Paraxial),
            "real" => Ok(Aiming::Real),
            "auto" => Ok(Aiming::Auto),
            _ => Err(format!("'{text}': expected auto, paraxial or real")),
        }
    }
}

/// `Aiming::Auto` switches to real aiming when the paraxially aimed chief ray of the lens's largest field
/// (primary wavelength, no clipping) crosses the stop farther than this fraction of R_stop from its
/// centre, or does not reach it. At 25% the bundled classic lenses (largest miss 5.9%, the Cooke triplet
/// at 20 deg) stay paraxial, bit for bit as before, while the 100-degree retrofocus
/// `lenses/wide_angle_100.json` (miss 346% of R_stop at 50 deg) switches.
pub const AUTO_REAL_AIMING_STOP_MISS: f64 = 0.25;

/// What `Aiming::Auto` decided for a lens, and why (reported in the JSON of the commands).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AutoAiming {
    /// The aiming in use: `paraxial` or `real`.
    pub aiming: Aiming,
    /// Field at which the pupil was checked: the lens's largest (deg).
    pub checked_field_deg: f64,
    /// Distance of the paraxially aimed chief ray from the stop centre, as a fraction of R_stop; None
    /// when that ray does not reach the stop.
    pub chief_ray_stop_miss: Option<f64>,
    /// The switching threshold, `AUTO_REAL_AIMING_STOP_MISS`.
    pub threshold: f64,
}

impl AutoAiming {
    /// The decision for `lens` (pupils from the primary wavelength, as every aiming).
    pub fn decide(lens: &Lens) -> TraceResult<AutoAiming> {
        let probe = Aimer::resolved(lens, lens.primary_wavelength_um(), Aiming::Paraxial)?;
        let field = probe.first_order.max_field_deg();
        let r_stop = probe.first_order.stop_radius_mm;
        let miss = probe
            .stop_intercept([0.0, field], [0.0, 0.0])
            .map(|hit| hit[0].hypot(hit[1]) / r_stop.abs().max(f64::MIN_POSITIVE));
        // The paraxial pupil is the nominal system's: a decentred or tilted lens is always aimed for real.
        let real =
            !lens.is_rotationally_symmetric() || miss.is_none_or(|m| !(m <= AUTO_REAL_AIMING_STOP_MISS));
        Ok(AutoAiming {
            aiming: if real { Aiming::Real } else { Aiming::Paraxial },
            checked_field_deg: field,
            chief_ray_stop_miss: miss,
            threshold: AUTO_REAL_AIMING_STOP_MISS,
        })
    }
}

impl Aiming {
    /// `Paraxial` or `Real`: this aiming, with `Auto` decided for `lens`.
    pub fn resolve(self, lens: &Lens) -> TraceResult<Aiming> {
        match self {
            Aiming::Auto => Ok(AutoAiming::decide(lens)?.aiming),
            fixed => Ok(fixed),
        }
    }
}

/// What all rays of one field share (`Aimer::field_start`).
#[derive(Debug, Clone, Copy)]
pub(crate) enum FieldStart {
    /// Object at infinity: every ray has this unit direction (normalised once, as `Ray::new` would).
    Parallel { unit_direction: [f64; 3] },
    /// Object at a finite distance: every ray leaves this object point.
    Point { start_mm: [f64; 3] },
}

const MAX_AIM_ITERATIONS: usize = 30;
const CONTINUATION_STEPS: usize = 16;

/// Aims rays of one wavelength.
pub struct Aimer {
    unclipped: TraceSystem,
    /// The unclipped system cut after the stop: what the batch aiming traces with the lane tracer.
    pub(crate) to_stop: TraceSystem,
    pub first_order: FirstOrder,
    object_distance_mm: Option<f64>,
    stop_index: usize,
    pub aiming: Aiming,
}

impl Aimer {
    /// An aimer; `Aiming::Auto` is decided here for the lens (so `aimer.aiming` is never `Auto`).
    pub fn new(lens: &Lens, wavelength_um: f64, aiming: Aiming) -> TraceResult<Aimer> {
        let aiming = aiming.resolve(lens)?;
        Aimer::resolved(lens, wavelength_um, aiming)
    }

    fn resolved(lens: &Lens, wavelength_um: f64, aiming: Aiming) -> TraceResult<Aimer> {
        let unclipped = TraceSystem::new(lens, wavelength_um, Clipping::None)?;
        let mut to_stop = unclipped.clone();
        to_stop.surfaces.truncate(lens.stop_index + 1);
        Ok(Aimer {
            unclipped,
            to_stop,
            first_order: lens.first_order()?,
            object_distance_mm: lens.object_distance_mm,
            stop_index: lens.stop_index,
            aiming,
        })
    }

    /// The ray of field angle `field_deg` (y-z plane) through normalised pupil point (px, py).
    pub fn ray(&self, field_deg: f64, px: f64, py: f64) -> TraceResult<Ray> {
        self.ray_at([0.0, field_deg], px, py)
    }

    /// The ray of the 2D field `field_deg` = (x, y) object-space angles through normalised pupil
    /// point (px, py): direction (tan x, tan y, 1) normalised (optiland's and Zemax's angle fields; for
    /// x = 0 the direction (0, sin y, cos y) of `ray`). For lenses that are not rotationally symmetric,
    /// where one azimuth does not stand for the others.
    pub fn ray_at(&self, field_deg: [f64; 2], px: f64, py: f64) -> TraceResult<Ray> {
        self.for_field(field_deg, 1).ray(px, py)
    }

    /// `ray_at` for many pupil points of one field, in order: what every many-ray caller should use.
    /// Real aiming solves a few points exactly, fits an aiming map and corrects each ray from it in
    /// lane batches (`aim_map`), holding every ray to the per-ray solve's stop tolerance; the rays agree
    /// with `ray_at`'s to that tolerance (paraxial rays are the same, bit for bit).
    pub fn rays_at(&self, field_deg: [f64; 2], pupil: &[[f64; 2]]) -> Vec<TraceResult<Ray>> {
        self.for_field(field_deg, pupil.len()).rays(pupil)
    }

    /// `rays_at` of a field in the y-z plane.
    pub fn rays(&self, field_deg: f64, pupil: &[[f64; 2]]) -> Vec<TraceResult<Ray>> {
        self.rays_at([0.0, field_deg], pupil)
    }

    /// The ray of field (x, y) through the point (sx, sy) of the paraxial entrance-pupil plane.
    pub(crate) fn ray_through_pupil_plane(&self, field_deg: [f64; 2], sx: f64, sy: f64) -> Ray {
        self.ray_from(self.field_start(field_deg), sx, sy)
    }

    /// What every ray of field (x, y) shares, worked out once for the field.
    pub(crate) fn field_start(&self, field_deg: [f64; 2]) -> FieldStart {
        let z_ep = self.first_order.entrance_pupil_z_mm;
        let [x_deg, y_deg] = field_deg;
        // Slopes dx/dz, dy/dz and the direction; an x of 0 keeps the y-z plane's own expressions.
        let (slopes, direction) = if x_deg == 0.0 {
            let (sin_f, cos_f) = y_deg.to_radians().sin_cos();
            ([0.0, sin_f / cos_f], [0.0, sin_f, cos_f])
        } else {
            let (tan_x, tan_y) = (x_deg.to_radians().tan(), y_deg.to_radians().tan());
            ([tan_x, tan_y], [tan_x, tan_y, 1.0])
        };
        match self.object_distance_mm {
            None => FieldStart::Parallel {
                unit_direction: Ray::new([0.0; 3], direction).direction,
            },
            Some(distance) => {
                let object_x = if x_deg == 0.0 {
                    0.0
                } else {
                    -slopes[0] * (z_ep + distance)
                };
                let object_y = -slopes[1] * (z_ep + distance);
                FieldStart::Point {
                    start_mm: [object_x, object_y, -distance],
                }
            }
        }
    }

    /// The ray of a field (its `field_start`) through the point (sx, sy) of the paraxial
    /// entrance-pupil plane.
    #[inline]
    pub(crate) fn ray_from(&self, field: FieldStart, sx: f64, sy: f64) -> Ray {
        let z_ep = self.first_order.entrance_pupil_z_mm;
        match field {
            FieldStart::Parallel { unit_direction } => Ray {
                position_mm: [sx, sy, z_ep],
                direction: unit_direction,
            },
            FieldStart::Point { start_mm: start } => {
                Ray::new(start, [sx - start[0], sy - start[1], z_ep - start[2]])
            }
        }
    }

    /// Where the ray through pupil-plane point s meets the stop surface, in the stop's own frame (None
    /// if it fails on the way).
    fn stop_intercept(&self, field_deg: [f64; 2], s: [f64; 2]) -> Option<[f64; 2]> {
        let mut ray = self.ray_through_pupil_plane(field_deg, s[0], s[1]);
        let status = self.unclipped.trace_through(&mut ray, self.stop_index, false);
        if !status.is_ok() {
            return None;
        }
        Some(self.in_stop_frame(ray.position_mm))
    }

    /// A point on the stop surface, in the stop's own frame (x, y).
    pub(crate) fn in_stop_frame(&self, point_mm: [f64; 3]) -> [f64; 2] {
        if self.unclipped.surfaces[self.stop_index].frame.is_none() {
            return [point_mm[0], point_mm[1]];
        }
        let local = self.unclipped.to_surface_frame(self.stop_index, point_mm);
        [local[0], local[1]]
    }

    /// The largest stop-intercept error (mm, per axis) at which a ray counts as aimed: the same for the
    /// per-ray solve and the batch aiming (`aim_map`).
    pub(crate) fn stop_tolerance_mm(&self) -> f64 {
        1e-13 * self.first_order.stop_radius_mm.max(1e-6)
    }

    pub(crate) fn real_ray(&self, field_deg: [f64; 2], px: f64, py: f64) -> TraceResult<Ray> {
        match self.real_pupil_point(field_deg, px, py) {
            Ok(s) => Ok(self.ray_through_pupil_plane(field_deg, s[0], s[1])),
            Err(reason) => Err(aim_failed(field_deg, px, py, reason)),
        }
    }

    /// The pupil-plane point of the real-aimed ray: Newton from the paraxial guess, else continuation.
    pub(crate) fn real_pupil_point(&self, field_deg: [f64; 2], px: f64, py: f64) -> Result<[f64; 2], String> {
        let radius = self.first_order.epd_mm / 2.0;
        let guess = [px * radius, py * radius];
        self.solve_stop_point(field_deg, px, py, guess)
            .or_else(|first_failure| {
                // Continuation: walk the field up from the axis, each solve starting at the previous one.
                let mut s = guess;
                for step in 1..=CONTINUATION_STEPS {
                    let field = field_deg.map(|f| f * step as f64 / CONTINUATION_STEPS as f64);
                    s = self
                        .solve_stop_point(field, px, py, s)
                        .map_err(|_| first_failure.clone())?;
                }
                Ok::<_, String>(s)
            })
    }

    /// Newton's method for the pupil-plane point whose ray crosses the stop at (px, py) * R_stop.
    pub(crate) fn solve_stop_point(
        &self,
        field_deg: [f64; 2],
        px: f64,
        py: f64,
        start: [f64; 2],
    ) -> Result<[f64; 2], String> {
        let r_stop = self.first_order.stop_radius_mm;
        let target = [px * r_stop, py * r_stop];
        let scale = self.first_order.epd_mm.max(1e-9);
        let tolerance = self.stop_tolerance_mm();
        let h = 1e-7 * scale;
        let residual = |s: [f64; 2]| {
            self.stop_intercept(field_deg, s)
                .map(|hit| [hit[0] - target[0], hit[1] - target[1]])
        };
        let mut s = start;
        let mut r = residual(s).ok_or("the starting ray does not reach the stop")?;
        for _ in 0..MAX_AIM_ITERATIONS {
            if r[0].abs().max(r[1].abs()) <= tolerance {
                return Ok(s);
            }
            let rx = residual([s[0] + h, s[1]]).ok_or("a ray near the solution does not reach the stop")?;
            let ry = residual([s[0], s[1] + h]).ok_or("a ray near the solution does not reach the stop")?;
            let j = [
                [(rx[0] - r[0]) / h, (ry[0] - r[0]) / h],
                [(rx[1] - r[1]) / h, (ry[1] - r[1]) / h],
            ];
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if det == 0.0 || !det.is_finite() {
                return Err("singular aiming Jacobian".into());
            }
            let delta = [
                (j[1][1] * r[0] - j[0][1] * r[1]) / det,
                (j[0][0] * r[1] - j[1][0] * r[0]) / det,
            ];
            // Damped step: halve until the new ray still reaches the stop and the residual shrinks.
            let mut factor = 1.0;
            loop {
                let candidate = [s[0] - factor * delta[0], s[1] - factor * delta[1]];
                if let Some(rc) = residual(candidate) {
                    if rc[0].hypot(rc[1]) < r[0].hypot(r[1]) || factor < 1e-3 {
                        s = candidate;
                        r = rc;
                        break;
                    }
                }
                factor *= 0.5;
                if factor < 1e-6 {
                    return Err("no step towards the stop point reaches the stop".into());
                }
            }
        }
        if r[0].abs().max(r[1].abs()) <= 1e3 * tolerance {
            Ok(s)
        } else {
            Err(format!("no convergence (residual {:.3e} mm)", r[0].hypot(r[1])))
        }
    }
}

/// `TraceError::AimFailed` for a 2D field: `field_deg` carries the y angle, the reason names an x angle.
pub(crate) fn aim_failed(field_deg: [f64; 2], px: f64, py: f64, reason: String) -> TraceError {
    let reason = if field_deg[0] == 0.0 {
        reason
    } else {
        format!("(x field {} deg) {reason}", field_deg[0])
    };
    TraceError::AimFailed {
        field_deg: field_deg[1],
        px,
        py,
        reason,
    }
}
