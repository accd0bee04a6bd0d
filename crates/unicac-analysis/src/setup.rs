//! What every analysis shares: the lens, its spectrum (polychromatic weights), the pupil grid, the
//! checked field angles, and the limits on every count.

use crate::error::{AnalysisError, AnalysisResult};
use serde::Serialize;
use unicac_optics::Lens;
use unicac_trace::{check_field_deg, check_wavelength_um, InvalidParameter};

/// Default pupil samples per axis: 128, as optiland's FFT MTF and unicac's wave PSF (12,900 rays
/// per field and wavelength; resolves 32 waves of aberration across the pupil radius).
pub const DEFAULT_PUPIL_GRID: usize = 128;
/// Fewest pupil samples per axis (a coarser grid cannot resolve even defocus).
pub const MIN_PUPIL_GRID: usize = 16;
/// Most pupil samples per axis: 512^2 rays per field and wavelength, and an autocorrelation of
/// 512^3 complex products per direction (about a second each).
pub const MAX_PUPIL_GRID: usize = 512;
/// Most field angles in one request.
pub const MAX_FIELDS: usize = 256;
/// Most wavelengths in one request.
pub const MAX_WAVELENGTHS: usize = 64;
/// Most spatial frequencies (or radii, or focus positions) in one request.
pub const MAX_SAMPLES: usize = 4096;

/// Wavelengths and their weights: the polychromatic weighting of every analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spectrum {
    pub wavelengths_um: Vec<f64>,
    /// Relative weights (the lens file's `weight`, else 1), not normalised.
    pub weights: Vec<f64>,
}

impl Spectrum {
    /// The lens file's wavelengths with their weights.
    pub fn of_lens(lens: &Lens) -> Spectrum {
        Spectrum {
            wavelengths_um: lens.wavelengths.iter().map(|w| w.wavelength_um).collect(),
            weights: lens.wavelengths.iter().map(|w| w.weight).collect(),
        }
    }

    /// The given wavelengths, equally weighted (one wavelength: a monochromatic analysis).
    pub fn equal(wavelengths_um: &[f64]) -> AnalysisResult<Spectrum> {
        let spectrum = Spectrum {
            wavelengths_um: wavelengths_um.to_vec(),
            weights: vec![1.0; wavelengths_um.len()],
        };
        spectrum.check()?;
        Ok(spectrum)
    }

    /// Non-empty, at most [`MAX_WAVELENGTHS`], positive wavelengths, non-negative weights that do not
    /// all vanish.
    pub fn check(&self) -> Result<(), InvalidParameter> {
        if self.wavelengths_um.is_empty() || self.wavelengths_um.len() > MAX_WAVELENGTHS {
            return Err(InvalidParameter::new(
                "wavelength_um",
                format!(
                    "{} wavelengths: need 1 to {MAX_WAVELENGTHS} (MAX_WAVELENGTHS)",
                    self.wavelengths_um.len()
                ),
            ));
        }
        for &w in &self.wavelengths_um {
            check_wavelength_um(w)?;
        }
        let valid = |w: &f64| w.is_finite() && *w >= 0.0;
        if self.weights.len() != self.wavelengths_um.len()
            || !self.weights.iter().all(valid)
            || self.weights.iter().sum::<f64>() <= 0.0
        {
            return Err(InvalidParameter::new(
                "wavelength_weights",
                "one finite, non-negative weight per wavelength, not all zero",
            ));
        }
        Ok(())
    }
}

/// The field angles of a request, each finite and within the lens's largest field (the lens file's
/// field of view: beyond it the semi-diameters and the design say nothing), at most [`MAX_FIELDS`].
pub fn check_fields(lens: &Lens, fields_deg: &[f64]) -> AnalysisResult<()> {
    if fields_deg.is_empty() || fields_deg.len() > MAX_FIELDS {
        return Err(InvalidParameter::new(
            "field_deg",
            format!("{} fields: need 1 to {MAX_FIELDS} (MAX_FIELDS)", fields_deg.len()),
        )
        .into());
    }
    let max_field = lens.first_order()?.max_field_deg();
    for &field in fields_deg {
        check_field_deg(field)?;
        if field.abs() > max_field * (1.0 + 1e-9) + 1e-12 {
            return Err(InvalidParameter::new(
                "field_deg",
                format!("{field}: beyond the lens's largest field, {max_field} deg"),
            )
            .into());
        }
    }
    Ok(())
}

/// `count` values from `start` to `end` inclusive (`count` >= 2), or `[start]`.
pub fn linspace(start: f64, end: f64, count: usize) -> Vec<f64> {
    match count {
        0 => Vec::new(),
        1 => vec![start],
        n => (0..n)
            .map(|i| start + (end - start) * i as f64 / (n - 1) as f64)
            .collect(),
    }
}

/// A pupil grid size within [`MIN_PUPIL_GRID`, `MAX_PUPIL_GRID`].
pub fn check_pupil_grid(pupil_grid: usize) -> Result<(), InvalidParameter> {
    if !(MIN_PUPIL_GRID..=MAX_PUPIL_GRID).contains(&pupil_grid) {
        return Err(InvalidParameter::new(
            "pupil_grid",
            format!("{pupil_grid}: must lie between {MIN_PUPIL_GRID} and {MAX_PUPIL_GRID}"),
        ));
    }
    Ok(())
}

/// A list of samples (frequencies, radii, focus shifts): 1 to [`MAX_SAMPLES`] finite values, each
/// non-negative when `non_negative`.
pub fn check_samples(
    field: &'static str,
    values: &[f64],
    non_negative: bool,
) -> Result<(), InvalidParameter> {
    if values.is_empty() || values.len() > MAX_SAMPLES {
        return Err(InvalidParameter::new(
            field,
            format!("{} values: need 1 to {MAX_SAMPLES} (MAX_SAMPLES)", values.len()),
        ));
    }
    if let Some(bad) = values
        .iter()
        .find(|v| !v.is_finite() || (non_negative && **v < 0.0))
    {
        let what = if non_negative {
            "finite and non-negative"
        } else {
            "finite"
        };
        return Err(InvalidParameter::new(field, format!("{bad}: must be {what}")));
    }
    Ok(())
}

/// A field that no ray reaches is an error rather than an empty curve.
pub(crate) fn vignetted(field_deg: f64) -> AnalysisError {
    AnalysisError::FieldVignetted { field_deg }
}
