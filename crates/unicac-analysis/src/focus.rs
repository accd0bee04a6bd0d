//! Through-focus: the MTF at one frequency and the RMS spot radius as the image surface moves along
//! the axis by each focus shift (positive: away from the lens), the lens otherwise unchanged (as
//! optiland's through-focus analyses move the image surface).

use crate::error::AnalysisResult;
use crate::mtf::{MtfSettings, MtfTracer};
use crate::pupil::Channel;
use crate::setup::{check_fields, check_samples, vignetted, Spectrum};
use serde::Serialize;
use unicac_optics::Lens;

/// The lens with its image surface `shift_mm` further from the lens.
pub fn refocused(lens: &Lens, shift_mm: f64) -> Lens {
    let mut moved = lens.clone();
    let image = moved.surfaces.len() - 1;
    moved.surfaces[image].z_mm += shift_mm;
    if image > 0 {
        moved.surfaces[image - 1].thickness_mm += shift_mm;
    }
    moved
}

/// Polychromatic RMS spot radius (um) about the weighted centroid of the rays of all wavelengths on
/// the N x N pupil grid (each wavelength's rays carry its weight, shared equally), with the centroid.
pub fn polychromatic_rms_um(
    lens: &Lens,
    spectrum: &Spectrum,
    field_deg: f64,
    pupil_grid: usize,
) -> AnalysisResult<(f64, [f64; 2])> {
    let mut groups = Vec::new();
    for (&wavelength, &weight) in spectrum.wavelengths_um.iter().zip(&spectrum.weights) {
        let (points, _) = Channel::new(lens, wavelength)?.grid_rays(field_deg, pupil_grid);
        if !points.is_empty() && weight > 0.0 {
            groups.push((weight / points.len() as f64, points));
        }
    }
    let total: f64 = groups.iter().map(|(w, p)| w * p.len() as f64).sum();
    if groups.is_empty() || total <= 0.0 {
        return Err(vignetted(field_deg));
    }
    let mut centroid = [0.0; 2];
    for (w, points) in &groups {
        for p in points {
            centroid[0] += w * p[0] / total;
            centroid[1] += w * p[1] / total;
        }
    }
    let mut sum = 0.0;
    for (w, points) in &groups {
        for p in points {
            sum += w * ((p[0] - centroid[0]).powi(2) + (p[1] - centroid[1]).powi(2));
        }
    }
    Ok(((sum / total).sqrt() * 1e3, centroid))
}

/// One field's through-focus curves (`unicac analysis through-focus --json`, one entry of `fields`).
#[derive(Debug, Clone, Serialize)]
pub struct FieldThroughFocus {
    pub field_deg: f64,
    pub focus_shifts_mm: Vec<f64>,
    pub tangential: Vec<f64>,
    pub sagittal: Vec<f64>,
    pub rms_spot_um: Vec<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ThroughFocusReport {
    pub frequency_cy_mm: f64,
    pub settings: MtfSettings,
    pub spectrum: Spectrum,
    pub fields: Vec<FieldThroughFocus>,
}

/// MTF at `frequency_cy_mm` and RMS spot radius at each focus shift, per field.
pub fn through_focus(
    lens: &Lens,
    spectrum: &Spectrum,
    fields_deg: &[f64],
    frequency_cy_mm: f64,
    focus_shifts_mm: &[f64],
    settings: MtfSettings,
) -> AnalysisResult<ThroughFocusReport> {
    check_fields(lens, fields_deg)?;
    check_samples("frequency_cy_mm", &[frequency_cy_mm], true)?;
    check_samples("focus_shifts_mm", focus_shifts_mm, false)?;
    let mut fields: Vec<FieldThroughFocus> = fields_deg
        .iter()
        .map(|&field_deg| FieldThroughFocus {
            field_deg,
            focus_shifts_mm: focus_shifts_mm.to_vec(),
            tangential: Vec::new(),
            sagittal: Vec::new(),
            rms_spot_um: Vec::new(),
        })
        .collect();
    for &shift in focus_shifts_mm {
        let moved = refocused(lens, shift);
        let tracer = MtfTracer::new(&moved, spectrum, settings)?;
        for field in &mut fields {
            let [t, s] = tracer.at_frequency(field.field_deg, frequency_cy_mm)?;
            field.tangential.push(t);
            field.sagittal.push(s);
            let (rms, _) = polychromatic_rms_um(&moved, spectrum, field.field_deg, settings.pupil_grid)?;
            field.rms_spot_um.push(rms);
        }
    }
    Ok(ThroughFocusReport {
        frequency_cy_mm,
        settings,
        spectrum: spectrum.clone(),
        fields,
    })
}
