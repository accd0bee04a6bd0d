//! Grading one unit: the polychromatic RMS spot radius over the whole field (the criterion the
//! compensator minimises), the shift of the on-axis image (boresight), the MTF at chosen frequencies.
//!
//! A built unit is not rotationally symmetric, so one azimuth does not stand for the others: every
//! non-zero field of the lens file is graded at four azimuths (+y, -y, +x, -x), each with a quarter of
//! its weight, and the axis once. Rays are aimed for real; the stop radius they aim at is the unit's own
//! paraxial one (its centred system: radius, thickness and index errors move it), as the entrance pupil
//! diameter of the lens file holds for every unit.
//!
//! The back-focus compensator is solved, not searched: on a plane image surface every ray's intercept
//! moves linearly with the image's axial shift s (x + s dx/dz), so each field's squared RMS radius
//! about its centroid is a quadratic in s; the weighted sum's minimum is exact from one trace.

use crate::error::{ToleranceError, ToleranceResult};
use crate::spec::Compensator;
use serde::{Deserialize, Serialize};
use unicac_analysis::{refocused, MtfSettings, MtfTracer, Spectrum};
use unicac_optics::Lens;
use unicac_trace::{trace_rays, Aimer, Aiming, Clipping, InvalidParameter, PupilSampling, TraceSystem};

/// Pupil grid of the RMS criterion (cells per axis): 32 x 32 = 812 rays per field point and
/// wavelength; on the Cooke triplet's textbook run each unit's mean RMS lies within 0.6% of a 256
/// grid's (0.4% on average) at 1/50 of its time: the knee of docs/tolerancing.md's sweep.
pub const DEFAULT_PUPIL_GRID: usize = 32;
pub const MIN_PUPIL_GRID: usize = 8;
pub const MAX_PUPIL_GRID: usize = 256;
/// Most MTF frequencies per run.
pub const MAX_MTF_FREQUENCIES: usize = 16;

/// How each unit is graded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Grading {
    /// Pupil grid of the RMS criterion.
    pub pupil_grid: usize,
    /// Frequencies (cycles/mm) of the MTF (diffraction, tangential and sagittal) at the y-axis field
    /// points; empty: no MTF.
    pub mtf_frequencies_cy_mm: Vec<f64>,
    /// Also the ODE of each refocused unit (docs/ode.md: every off-axis field at four azimuths; about a
    /// second per unit). Absent from run files when off, so runs without it keep their bytes.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub ode: bool,
}

impl Default for Grading {
    fn default() -> Self {
        Grading {
            pupil_grid: DEFAULT_PUPIL_GRID,
            mtf_frequencies_cy_mm: Vec::new(),
            ode: false,
        }
    }
}

impl Grading {
    pub fn check(&self) -> ToleranceResult<()> {
        if !(MIN_PUPIL_GRID..=MAX_PUPIL_GRID).contains(&self.pupil_grid) {
            return Err(InvalidParameter::new(
                "pupil_grid",
                format!(
                    "{}: must lie between {MIN_PUPIL_GRID} and {MAX_PUPIL_GRID}",
                    self.pupil_grid
                ),
            )
            .into());
        }
        let f = &self.mtf_frequencies_cy_mm;
        if f.len() > MAX_MTF_FREQUENCIES || f.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(InvalidParameter::new(
                "mtf_frequencies_cy_mm",
                format!("at most {MAX_MTF_FREQUENCIES} positive, finite frequencies"),
            )
            .into());
        }
        Ok(())
    }
}

/// One point of the field: (x, y) object-space angles (deg) and its weight in the criterion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FieldPoint {
    pub field_deg: [f64; 2],
    pub weight: f64,
}

/// The axis first (weight: that of the lens's zero field, else 0: graded for the boresight only),
/// then each non-zero field at +y, -y, +x, -x.
pub fn field_points(lens: &Lens) -> ToleranceResult<Vec<FieldPoint>> {
    let angles = lens.first_order()?.field_angles_deg;
    let on_axis: f64 = angles
        .iter()
        .zip(&lens.field_weights)
        .filter(|(a, _)| **a == 0.0)
        .map(|(_, w)| w)
        .sum();
    let mut points = vec![FieldPoint {
        field_deg: [0.0, 0.0],
        weight: on_axis,
    }];
    for (&angle, &weight) in angles.iter().zip(&lens.field_weights) {
        if angle != 0.0 {
            let f = angle.abs();
            for field_deg in [[0.0, f], [0.0, -f], [f, 0.0], [-f, 0.0]] {
                points.push(FieldPoint {
                    field_deg,
                    weight: weight / 4.0,
                });
            }
        }
    }
    if !(points.iter().map(|p| p.weight).sum::<f64>() > 0.0) {
        return Err(ToleranceError::Unsupported(
            "the lens's field weights are all 0: no field to grade units on".into(),
        ));
    }
    Ok(points)
}

/// What one unit scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// The compensator's image shift (mm, positive away from the lens; 0 without compensator).
    pub focus_shift_mm: f64,
    /// Polychromatic RMS spot radius (um) per field point, in `field_points` order.
    pub rms_um: Vec<f64>,
    /// Weighted mean of `rms_um`.
    pub rms_mean_um: f64,
    /// Largest of `rms_um` over the weighted points.
    pub rms_max_um: f64,
    /// Distance of the on-axis image's centroid from the axis (um).
    pub boresight_um: f64,
    /// Lowest MTF (tangential or sagittal, over the y-axis field points) per frequency.
    pub mtf_min: Vec<f64>,
    /// The refocused unit's ODE (`Grading::ode`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ode: Option<f64>,
}

/// Intercepts and slopes of one field point's rays, per wavelength, with each ray's weight.
struct Bundle {
    weight: f64,
    points_mm: Vec<[f64; 2]>,
    slopes: Vec<[f64; 2]>,
}

/// The weighted squared RMS radius about the centroid as a + 2 b s + c s^2 of the image shift s,
/// with the centroid at s = 0 and its rate.
struct Quadratic {
    a: f64,
    b: f64,
    c: f64,
    centroid_mm: [f64; 2],
    centroid_rate: [f64; 2],
}

impl Quadratic {
    fn of(bundles: &[Bundle]) -> Option<Quadratic> {
        let total: f64 = bundles.iter().map(|b| b.weight * b.points_mm.len() as f64).sum();
        if !(total > 0.0) {
            return None;
        }
        let mut centroid = [0.0; 2];
        let mut rate = [0.0; 2];
        for b in bundles {
            for (p, m) in b.points_mm.iter().zip(&b.slopes) {
                for k in 0..2 {
                    centroid[k] += b.weight * p[k] / total;
                    rate[k] += b.weight * m[k] / total;
                }
            }
        }
        let (mut a, mut bb, mut c) = (0.0, 0.0, 0.0);
        for b in bundles {
            for (p, m) in b.points_mm.iter().zip(&b.slopes) {
                for k in 0..2 {
                    let d = p[k] - centroid[k];
                    let e = m[k] - rate[k];
                    a += b.weight * d * d;
                    bb += b.weight * d * e;
                    c += b.weight * e * e;
                }
            }
        }
        Some(Quadratic {
            a: a / total,
            b: bb / total,
            c: c / total,
            centroid_mm: centroid,
            centroid_rate: rate,
        })
    }

    fn rms_um(&self, shift_mm: f64) -> f64 {
        (self.a + 2.0 * self.b * shift_mm + self.c * shift_mm * shift_mm)
            .max(0.0)
            .sqrt()
            * 1e3
    }
}

/// Grades `lens` (a built unit, or the nominal lens) at `points`, after `compensator`.
pub fn score(
    lens: &Lens,
    points: &[FieldPoint],
    grading: &Grading,
    compensator: Compensator,
) -> ToleranceResult<Score> {
    let image = &lens.surfaces[lens.image_index()];
    if compensator == Compensator::BackFocus && !(image.profile.is_plane() && image.placement.is_centred()) {
        return Err(ToleranceError::Unsupported(
            "the back-focus compensator needs a plane image surface square to the axis".into(),
        ));
    }
    let spectrum = Spectrum::of_lens(lens);
    let pupil = PupilSampling::Grid {
        n: grading.pupil_grid,
    }
    .points();
    let mut tracers = Vec::new();
    for (&wavelength_um, &weight) in spectrum.wavelengths_um.iter().zip(&spectrum.weights) {
        if weight > 0.0 {
            let system = TraceSystem::new(lens, wavelength_um, Clipping::Apertures)?;
            let aimer = Aimer::new(lens, wavelength_um, Aiming::Real)?;
            tracers.push((weight, system, aimer));
        }
    }
    let mut quadratics = Vec::with_capacity(points.len());
    for point in points {
        let bundles: Vec<Bundle> = tracers
            .iter()
            .map(|(weight, system, aimer)| {
                let mut rays: Vec<_> = aimer
                    .rays_at(point.field_deg, &pupil)
                    .into_iter()
                    .filter_map(Result::ok)
                    .collect();
                let statuses = trace_rays(system, &mut rays);
                let arrived: Vec<_> = rays
                    .iter()
                    .zip(&statuses)
                    .filter(|(_, s)| s.is_ok())
                    .map(|(r, _)| r)
                    .collect();
                Bundle {
                    // Each wavelength's weight shared by its arriving rays, as `polychromatic_rms_um`.
                    weight: weight / arrived.len().max(1) as f64,
                    points_mm: arrived
                        .iter()
                        .map(|r| [r.position_mm[0], r.position_mm[1]])
                        .collect(),
                    slopes: arrived
                        .iter()
                        .map(|r| [r.direction[0] / r.direction[2], r.direction[1] / r.direction[2]])
                        .collect(),
                }
            })
            .collect();
        let quadratic = Quadratic::of(&bundles).ok_or_else(|| {
            ToleranceError::Unsupported(format!(
                "no ray of field ({}, {}) deg reaches the image surface",
                point.field_deg[0], point.field_deg[1]
            ))
        })?;
        quadratics.push(quadratic);
    }
    let focus_shift_mm = match compensator {
        Compensator::None => 0.0,
        Compensator::BackFocus => {
            let (b, c) = points.iter().zip(&quadratics).fold((0.0, 0.0), |(b, c), (p, q)| {
                (b + p.weight * q.b, c + p.weight * q.c)
            });
            if c > 0.0 {
                -b / c
            } else {
                0.0
            }
        }
    };
    let rms_um: Vec<f64> = quadratics.iter().map(|q| q.rms_um(focus_shift_mm)).collect();
    let total_weight: f64 = points.iter().map(|p| p.weight).sum();
    let weighted = || points.iter().zip(&rms_um).filter(|(p, _)| p.weight > 0.0);
    let rms_mean_um = weighted().map(|(p, r)| p.weight * r).sum::<f64>() / total_weight;
    let rms_max_um = weighted().map(|(_, r)| *r).fold(0.0, f64::max);
    let axis = &quadratics[0];
    let boresight_um = (0..2)
        .map(|k| axis.centroid_mm[k] + focus_shift_mm * axis.centroid_rate[k])
        .map(|v| v * v)
        .sum::<f64>()
        .sqrt()
        * 1e3;
    let unit = refocused(lens, focus_shift_mm);
    let mtf_min = if grading.mtf_frequencies_cy_mm.is_empty() {
        Vec::new()
    } else {
        lowest_mtf(&unit, &spectrum, points, &grading.mtf_frequencies_cy_mm)?
    };
    let ode = match grading.ode {
        true => Some(
            unicac_ode::evaluate(&unit, &unicac_ode::OdeSettings::default())?
                .scores
                .ode,
        ),
        false => None,
    };
    Ok(Score {
        focus_shift_mm,
        rms_um,
        rms_mean_um,
        rms_max_um,
        boresight_um,
        mtf_min,
        ode,
    })
}

/// The diffraction MTF's lowest value per frequency over the y-axis field points, both directions
/// (the MTF analyses take a field in the y-z plane; x-axis points are left to the RMS criterion).
fn lowest_mtf(
    lens: &Lens,
    spectrum: &Spectrum,
    points: &[FieldPoint],
    frequencies: &[f64],
) -> ToleranceResult<Vec<f64>> {
    let settings = MtfSettings {
        pupil_grid: 64,
        ..MtfSettings::default()
    };
    let tracer = MtfTracer::new(lens, spectrum, settings)?;
    let mut lowest = vec![f64::INFINITY; frequencies.len()];
    for point in points.iter().filter(|p| p.field_deg[0] == 0.0) {
        let mtf = tracer.field(point.field_deg[1], frequencies)?;
        for (k, low) in lowest.iter_mut().enumerate() {
            *low = low.min(mtf.tangential[k]).min(mtf.sagittal[k]);
        }
    }
    Ok(lowest)
}
