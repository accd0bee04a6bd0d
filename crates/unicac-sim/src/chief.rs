//! The real chief ray as a function of field angle: image height h(F) on the image surface (primary
//! wavelength, aimed at the stop centre), its inverse, the ideal (paraxial) height, and what follows
//! from them: distortion and relative illumination.

use crate::error::{SimError, SimResult};
use unicac_optics::Lens;
use unicac_trace::{Aimer, Aiming, Clipping, TraceSystem};

/// Samples of h(F) from the axis to the lens's largest field, dense enough for linear interpolation
/// (distortion curves are smooth; 64 samples keep interpolation error below 1e-5 of the height on the
/// bundled lenses, see tests).
pub const CHIEF_SAMPLES: usize = 65;

/// Built only by [`ChiefRayMap::new`], which guarantees its invariants: `CHIEF_SAMPLES` samples,
/// angles increasing from 0 and heights strictly increasing (so lookups need no checks).
#[derive(Debug, Clone)]
pub struct ChiefRayMap {
    /// Field angles (deg), increasing from 0.
    angles_deg: Vec<f64>,
    /// Real chief-ray heights (mm), increasing.
    heights_mm: Vec<f64>,
    /// Paraxial height per unit tan F on the image surface.
    paraxial_height_per_tan_mm: f64,
}

impl ChiefRayMap {
    pub fn new(lens: &Lens) -> SimResult<ChiefRayMap> {
        // The map, and the radial PSF maps built on it, assume one field azimuth stands for all: refused
        // rather than answered wrongly for an as-built lens (the simulator and the ODE take a unit
        // through its centred twin's map, `Lens::nominal`).
        if let Some(i) = lens.surfaces.iter().position(|s| !s.placement.is_centred()) {
            return Err(SimError::Unsupported(format!(
                "surface {} is decentred or tilted: the chief-ray map samples one field radius, which needs \
                 a rotationally symmetric lens",
                i + 1
            )));
        }
        let first = lens.first_order()?;
        let max_field = first.max_field_deg();
        if max_field <= 0.0 {
            return Err(SimError::Unsupported(
                "the lens has no off-axis field to simulate".into(),
            ));
        }
        let wavelength = lens.primary_wavelength_um();
        let system = TraceSystem::new(lens, wavelength, Clipping::None)?;
        let aimer = Aimer::new(lens, wavelength, Aiming::Real)?;
        let mut angles_deg = Vec::with_capacity(CHIEF_SAMPLES);
        let mut heights_mm = Vec::with_capacity(CHIEF_SAMPLES);
        for i in 0..CHIEF_SAMPLES {
            let angle = max_field * i as f64 / (CHIEF_SAMPLES - 1) as f64;
            let mut ray = aimer.ray(angle, 0.0, 0.0)?;
            if !system.trace(&mut ray).is_ok() {
                return Err(SimError::Unsupported(format!(
                    "the chief ray of {angle:.3} deg does not reach the image"
                )));
            }
            let height = ray.position_mm[1];
            if heights_mm.last().is_some_and(|&last| height <= last) {
                return Err(SimError::Unsupported(format!(
                    "the chief-ray height stops increasing at {angle:.3} deg; the field cannot be mapped"
                )));
            }
            angles_deg.push(angle);
            heights_mm.push(height);
        }
        let per_tan = {
            let heights = &first.paraxial_chief_heights_at_image_surface_mm;
            first
                .field_angles_deg
                .iter()
                .zip(heights)
                .find(|(f, _)| **f != 0.0)
                .map(|(f, h)| h / f.to_radians().tan())
        }
        .unwrap_or(0.0);
        Ok(ChiefRayMap {
            angles_deg,
            heights_mm,
            paraxial_height_per_tan_mm: per_tan,
        })
    }

    pub fn max_height_mm(&self) -> f64 {
        self.heights_mm[CHIEF_SAMPLES - 1]
    }

    pub fn max_angle_deg(&self) -> f64 {
        self.angles_deg[CHIEF_SAMPLES - 1]
    }

    /// Paraxial height per unit tan F on the image surface (0 when no off-axis sample is paraxial).
    pub fn paraxial_height_per_tan_mm(&self) -> f64 {
        self.paraxial_height_per_tan_mm
    }

    /// Field angle whose real chief ray lands at `height_mm` (linear interpolation; clamped).
    pub fn angle_for_height(&self, height_mm: f64) -> f64 {
        interpolate(&self.heights_mm, &self.angles_deg, height_mm)
    }

    pub fn height_for_angle(&self, angle_deg: f64) -> f64 {
        interpolate(&self.angles_deg, &self.heights_mm, angle_deg)
    }

    /// Ideal (paraxial, distortion-free) height of the field that really lands at `height_mm`.
    pub fn ideal_height(&self, height_mm: f64) -> f64 {
        self.paraxial_height_per_tan_mm * self.angle_for_height(height_mm).to_radians().tan()
    }

    /// Relative illumination from the chief-ray mapping alone (no vignetting): for a uniform object
    /// at infinity, E(F) / E(0) = cos F sin F h'(0)^2 / (h h'), which is cos^4 F for h = f tan F.
    pub fn illumination_factor(&self, height_mm: f64) -> f64 {
        let angle = self.angle_for_height(height_mm).to_radians();
        if angle <= 1e-9 {
            return 1.0;
        }
        // dh/dF by a central difference, one-sided at the ends of the sampled range.
        let max_angle = self.max_angle_deg().to_radians();
        let slope_at = |a: f64| {
            let step = 1e-4;
            let (lo, hi) = ((a - step).max(0.0), (a + step).min(max_angle));
            (self.height_for_angle(hi.to_degrees()) - self.height_for_angle(lo.to_degrees())) / (hi - lo)
        };
        let h0 = slope_at(0.0);
        let h = self.height_for_angle(angle.to_degrees());
        angle.cos() * angle.sin() * h0 * h0 / (h * slope_at(angle))
    }
}

/// Piecewise-linear y(x) through increasing samples, clamped at the ends.
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    if x <= xs[0] {
        return ys[0];
    }
    let i = xs.partition_point(|&v| v < x);
    if i >= xs.len() {
        return ys[ys.len() - 1];
    }
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] + t * (ys[i] - ys[i - 1])
}
