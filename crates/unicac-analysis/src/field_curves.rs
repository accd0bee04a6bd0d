//! Field curvature and distortion against field angle.
//!
//! - **Field curvature**: per wavelength and field, the tangential (sagittal) focus is where two
//!   parabasal rays at pupil py = +-delta (px = +-delta) cross, found from their image-surface
//!   intercepts and directions as the intersection of the two lines in the y-z (x-z) plane; reported as
//!   its axial distance from the image surface (positive: behind it), as Zemax and optiland do.
//!   delta = 1e-5 of the pupil radius, as optiland: small enough that the crossing is the Coddington
//!   focus to ~1e-10 of the pupil (the error is quadratic in delta), large enough that the crossing
//!   angle (~1e-5 of the marginal angle) keeps round-off below 1e-8 mm.
//! - **Distortion**: 100 (h - h0) / h0 with h the real chief ray's height on the image surface (primary
//!   wavelength, the analyses' aiming, no clipping) and h0 = k tan F the ideal height, k the paraxial
//!   chief ray's height per unit tan F *on the image surface* (the near-axis limit of the real chief
//!   ray: Zemax's and optiland's reference). `lens info` instead refers to the paraxial image plane,
//!   which differs when the image surface is not at the paraxial focus (docs/analysis.md).

use crate::error::AnalysisResult;
use crate::pupil::Channel;
use crate::setup::{check_fields, Spectrum};
use serde::Serialize;
use unicac_optics::Lens;
use unicac_trace::spot::DistortionPoint;
use unicac_trace::Ray;

/// Pupil offset of the parabasal ray pairs (normalised pupil units).
pub const PARABASAL_DELTA: f64 = 1e-5;

/// One wavelength's focus curves.
#[derive(Debug, Clone, Serialize)]
pub struct FocusCurves {
    pub wavelength_um: f64,
    /// Axial distance from the image surface to the tangential focus, per field (None: a ray failed).
    pub tangential_mm: Vec<Option<f64>>,
    pub sagittal_mm: Vec<Option<f64>>,
}

#[derive(Debug, Clone, Serialize)]
pub struct FieldCurves {
    pub fields_deg: Vec<f64>,
    pub field_curvature: Vec<FocusCurves>,
    pub distortion: Vec<DistortionPoint>,
}

/// Axial distance from the image surface to the crossing of two rays, in the plane of `axis` and z.
fn crossing(a: &Ray, b: &Ray, axis: usize) -> Option<f64> {
    let (u1, w1, u2, w2) = (
        a.direction[axis],
        a.direction[2],
        b.direction[axis],
        b.direction[2],
    );
    let (p1, z1, p2, z2) = (
        a.position_mm[axis],
        a.position_mm[2],
        b.position_mm[axis],
        b.position_mm[2],
    );
    let det = u1 * w2 - u2 * w1;
    if det == 0.0 {
        return None;
    }
    // a + t d_a crosses b's line: solve p1 + t u1 - p2 = s u2, z1 + t w1 - z2 = s w2 for t.
    let t = (u2 * (z1 - z2) - w2 * (p1 - p2)) / det;
    let shift = t * w1;
    shift.is_finite().then_some(shift)
}

/// Field curvature (per wavelength of `spectrum`) and distortion at `fields_deg`.
pub fn field_curves(lens: &Lens, spectrum: &Spectrum, fields_deg: &[f64]) -> AnalysisResult<FieldCurves> {
    check_fields(lens, fields_deg)?;
    spectrum.check()?;
    let mut field_curvature = Vec::new();
    for &wavelength in &spectrum.wavelengths_um {
        let channel = Channel::new(lens, wavelength)?;
        let pair = |field: f64, offset: [f64; 2]| -> Option<(Ray, Ray)> {
            let trace = |sign: f64| -> Option<Ray> {
                let mut ray = channel
                    .aimer
                    .ray(field, sign * offset[0], sign * offset[1])
                    .ok()?;
                channel.unclipped.trace(&mut ray).is_ok().then_some(ray)
            };
            Some((trace(-1.0)?, trace(1.0)?))
        };
        let focus = |offset: [f64; 2], axis: usize| -> Vec<Option<f64>> {
            fields_deg
                .iter()
                .map(|&f| pair(f, offset).and_then(|(a, b)| crossing(&a, &b, axis)))
                .collect()
        };
        field_curvature.push(FocusCurves {
            wavelength_um: wavelength,
            tangential_mm: focus([0.0, PARABASAL_DELTA], 1),
            sagittal_mm: focus([PARABASAL_DELTA, 0.0], 0),
        });
    }
    Ok(FieldCurves {
        fields_deg: fields_deg.to_vec(),
        field_curvature,
        distortion: distortion(lens, fields_deg)?,
    })
}

/// Distortion at each field whose chief ray arrives (module docs).
pub fn distortion(lens: &Lens, fields_deg: &[f64]) -> AnalysisResult<Vec<DistortionPoint>> {
    let first = lens.first_order()?;
    let per_tan = first
        .field_angles_deg
        .iter()
        .zip(&first.paraxial_chief_heights_at_image_surface_mm)
        .find(|(f, _)| **f != 0.0)
        .map_or(0.0, |(f, h)| h / f.to_radians().tan());
    let channel = Channel::new(lens, lens.primary_wavelength_um())?;
    Ok(fields_deg
        .iter()
        .filter_map(|&field_deg| {
            let mut ray = channel.aimer.ray(field_deg, 0.0, 0.0).ok()?;
            channel.unclipped.trace(&mut ray).is_ok().then_some(())?;
            let paraxial = per_tan * field_deg.to_radians().tan();
            let real = ray.position_mm[1];
            Some(DistortionPoint {
                field_deg,
                real_image_height_mm: real,
                paraxial_image_height_mm: paraxial,
                distortion_percent: if paraxial == 0.0 {
                    0.0
                } else {
                    100.0 * (real - paraxial) / paraxial
                },
            })
        })
        .collect())
}
