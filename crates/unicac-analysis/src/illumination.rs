//! Relative illumination: image irradiance of a uniform (Lambertian) object at infinity against field
//! angle, relative to the axis.
//!
//! Flux from the solid angle dOmega around field F enters through the entrance pupil's area A(F) seen
//! at the angle F (projected: A cos F) and lands on the image area h h' dOmega / sin F (h(F) the real
//! chief-ray height on the image surface, h' = dh/dF), so
//!
//!   E(F) / E(0) = [T(F) A(F) / (T(0) A(0))] cos F sin F h'(0)^2 / (h h'),
//!
//! cos^4 F for a distortion-free lens with a constant pupil. T is the fraction of the N x N pupil grid's
//! rays that arrive (vignetting; weighted over the spectrum as the MTF), A the pupil area on the
//! entrance-pupil plane: constant with paraxial aiming (ray aiming off), the area enclosed by the
//! aimed pupil-edge rays with real aiming (pupil growth of wide-angle lenses). h' by central
//! differences of the chief ray at F +- 1e-4 rad (the chief ray of the analyses' aiming, primary
//! wavelength, no clipping). The sim crate's illumination (`ChiefRayMap::illumination_factor`) is the
//! same formula on an interpolated chief-ray table.

use crate::error::{AnalysisError, AnalysisResult};
use crate::pupil::{disc_cells, Channel};
use crate::setup::{check_fields, check_pupil_grid, Spectrum};
use serde::Serialize;
use unicac_optics::Lens;
use unicac_trace::Aiming;

/// Angle step of the chief-ray height derivative (rad): central differences are exact to ~1e-8
/// relative at this step on smooth mappings, far above round-off.
const SLOPE_STEP_RAD: f64 = 1e-4;
/// Pupil-edge rays outlining the entrance pupil with real aiming.
const EDGE_RAYS: usize = 64;

#[derive(Debug, Clone, Serialize)]
pub struct RelativeIllumination {
    pub fields_deg: Vec<f64>,
    /// E(F) / E(0).
    pub relative_illumination: Vec<f64>,
    /// The vignetting factor T(F) / T(0) alone.
    pub vignetting: Vec<f64>,
    /// Real chief-ray height on the image surface (mm).
    pub image_height_mm: Vec<f64>,
    pub aiming: Aiming,
}

pub fn relative_illumination(
    lens: &Lens,
    spectrum: &Spectrum,
    fields_deg: &[f64],
    pupil_grid: usize,
) -> AnalysisResult<RelativeIllumination> {
    check_fields(lens, fields_deg)?;
    spectrum.check()?;
    check_pupil_grid(pupil_grid)?;
    if lens.object_distance_mm.is_some() {
        return Err(AnalysisError::Unsupported(
            "relative illumination is defined here for an object at infinity".into(),
        ));
    }
    let primary = Channel::new(lens, lens.primary_wavelength_um())?;
    let channels: Vec<Channel> = spectrum
        .wavelengths_um
        .iter()
        .map(|&w| Channel::new(lens, w))
        .collect::<AnalysisResult<_>>()?;
    let weight_sum: f64 = spectrum.weights.iter().sum();
    let height = |field_deg: f64| -> AnalysisResult<f64> {
        let mut ray = primary.aimer.ray(field_deg, 0.0, 0.0)?;
        if !primary.unclipped.trace(&mut ray).is_ok() {
            return Err(AnalysisError::Unsupported(format!(
                "the chief ray of {field_deg} deg does not reach the image surface"
            )));
        }
        Ok(ray.position_mm[1])
    };
    let slope = |field_rad: f64| -> AnalysisResult<f64> {
        let (lo, hi) = (field_rad - SLOPE_STEP_RAD, field_rad + SLOPE_STEP_RAD);
        Ok((height(hi.to_degrees())? - height(lo.to_degrees())?) / (hi - lo))
    };
    let transmission = |field_deg: f64| -> f64 {
        channels
            .iter()
            .zip(&spectrum.weights)
            .map(|(c, w)| {
                let (points, _) = c.grid_rays(field_deg, pupil_grid);
                w * points.len() as f64 / disc_cells(pupil_grid) as f64
            })
            .sum::<f64>()
            / weight_sum
    };
    let pupil_area = |field_deg: f64| -> AnalysisResult<f64> {
        if primary.aimer.aiming != Aiming::Real {
            return Ok(1.0);
        }
        let mut corners = Vec::with_capacity(EDGE_RAYS);
        for k in 0..EDGE_RAYS {
            let angle = 2.0 * std::f64::consts::PI * k as f64 / EDGE_RAYS as f64;
            let ray = primary.aimer.ray(field_deg, angle.cos(), angle.sin())?;
            corners.push([ray.position_mm[0], ray.position_mm[1]]);
        }
        let twice: f64 = (0..EDGE_RAYS)
            .map(|k| {
                let (a, b) = (corners[k], corners[(k + 1) % EDGE_RAYS]);
                a[0] * b[1] - b[0] * a[1]
            })
            .sum();
        Ok(twice.abs() / 2.0)
    };
    let axis_slope = slope(0.0)?;
    let axis_transmission = transmission(0.0);
    let axis_area = pupil_area(0.0)?;
    if axis_transmission == 0.0 {
        return Err(AnalysisError::FieldVignetted { field_deg: 0.0 });
    }
    let mut out = RelativeIllumination {
        fields_deg: fields_deg.to_vec(),
        relative_illumination: Vec::new(),
        vignetting: Vec::new(),
        image_height_mm: Vec::new(),
        aiming: primary.aimer.aiming,
    };
    for &field_deg in fields_deg {
        let f = field_deg.to_radians();
        let h = height(field_deg)?;
        let vignetting = transmission(field_deg) / axis_transmission;
        let mapping = if f.abs() < 1e-9 {
            1.0
        } else {
            f.cos() * f.sin() * axis_slope * axis_slope / (h * slope(f)?)
        };
        out.relative_illumination
            .push(vignetting * pupil_area(field_deg)? / axis_area * mapping);
        out.vignetting.push(vignetting);
        out.image_height_mm.push(h);
    }
    Ok(out)
}
