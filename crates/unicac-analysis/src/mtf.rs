//! Polychromatic MTF against spatial frequency, tangential and sagittal, per field: from the wave
//! optics (the OTF as the autocorrelation of the pupil function, i.e. the Fourier transform of the
//! wave PSF) or from the rays (the Fourier transform of the spot), with the diffraction limit.
//!
//! - **Directions.** The field lies along +y, so the meridional (tangential) plane is y-z: the
//!   tangential MTF is the modulation of a pattern varying along image y (pupil shift along y), the
//!   sagittal one along image x.
//! - **Frequencies** are cycles/mm on the image surface. A pupil shift of k grid steps is the frequency
//!   k times `Channel::step_cy_mm` (real marginal rays, per field, direction and wavelength); the OTF
//!   at any other frequency is interpolated linearly between lags (N = 128 gives 128 lags up to the
//!   cutoff).
//! - **Polychromatic weighting.** OTF = sum_l a_l OTF_l / sum_l a_l with a_l = weight_l x
//!   transmission_l (the lens file's wavelength weights times the fraction of the pupil that arrives):
//!   the OTF of the energy-weighted sum of the per-wavelength PSFs. The OTFs are complex and share one
//!   reference point, so lateral colour lowers the polychromatic MTF; MTF = |OTF|.
//! - **Diffraction limit** of a field: the same calculation with the wavefront error set to zero, on
//!   the same pupil (its vignetting included), per direction.
//! - **Geometric MTF**: |sum of exp(-2 pi i nu u)| over the grid's rays (u = image y or x), weighted as
//!   above, times the diffraction limit when `scale_by_diffraction_limit` (Zemax's and optiland's
//!   default), so that it never exceeds what the aperture can pass.

use crate::error::{AnalysisError, AnalysisResult};
use crate::pupil::{at_lag, autocorrelation, clear_pupil, disc_cells, pupil_function, ray_otf, Channel};
use crate::setup::{check_fields, check_pupil_grid, check_samples, vignetted, Spectrum, DEFAULT_PUPIL_GRID};
use rustfft::num_complex::Complex64;
use serde::Serialize;
use unicac_optics::Lens;
use unicac_psf::{SpectralWeights, WavePsfSettings, WavePsfTracer};

/// How the OTF is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MtfMethod {
    /// Pupil-function autocorrelation (the Fourier transform of the wave PSF).
    #[default]
    Diffraction,
    /// Fourier transform of the traced spot.
    Geometric,
}

impl std::str::FromStr for MtfMethod {
    type Err = unicac_trace::InvalidParameter;
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        match text {
            "diffraction" => Ok(MtfMethod::Diffraction),
            "geometric" => Ok(MtfMethod::Geometric),
            _ => Err(unicac_trace::InvalidParameter::new(
                "method",
                format!("'{text}': expected diffraction or geometric"),
            )),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MtfSettings {
    pub method: MtfMethod,
    /// Pupil samples per axis.
    pub pupil_grid: usize,
    /// Geometric method only: multiply by the diffraction limit.
    pub scale_by_diffraction_limit: bool,
}

impl Default for MtfSettings {
    fn default() -> Self {
        MtfSettings {
            method: MtfMethod::Diffraction,
            pupil_grid: DEFAULT_PUPIL_GRID,
            scale_by_diffraction_limit: true,
        }
    }
}

/// Tangential and sagittal values at the same frequencies.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Directions {
    pub tangential: Vec<f64>,
    pub sagittal: Vec<f64>,
}

/// Tangential and sagittal cutoff frequencies (cycles/mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Cutoff {
    pub tangential: f64,
    pub sagittal: f64,
}

/// The MTF of one field (`unicac analysis mtf --json`, one entry of `fields`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldMtf {
    pub field_deg: f64,
    pub frequencies_cy_mm: Vec<f64>,
    pub tangential: Vec<f64>,
    pub sagittal: Vec<f64>,
    /// The aberration-free MTF of the same pupil, per direction.
    pub diffraction_limit: Directions,
    /// Weighted fraction of the pupil that reaches the image.
    pub transmission: f64,
    /// Frequency of a shift across the whole pupil (the cutoff) at the primary wavelength (or the
    /// first of the spectrum), per direction.
    pub cutoff_cy_mm: Cutoff,
    /// A wavefront step between neighbouring pupil samples exceeds half a wave (raise `pupil_grid`).
    pub undersampled: bool,
}

/// One wavelength's OTF data of one field.
struct Monochromatic {
    /// Polychromatic weight a_l (weight x transmission).
    weight: f64,
    transmission: f64,
    /// Frequency per grid lag, [tangential, sagittal].
    step_cy_mm: [f64; 2],
    /// Aberrated OTF at lags (diffraction method), [tangential, sagittal].
    lags: Option<[Vec<Complex64>; 2]>,
    /// Aberration-free OTF at lags, [tangential, sagittal].
    limit: [Vec<Complex64>; 2],
    /// Image points relative to the field's common origin (geometric method).
    points: Vec<[f64; 2]>,
    undersampled: bool,
}

/// Traces one lens's fields for MTFs: one prepared channel per wavelength, built once.
pub struct MtfTracer {
    lens: Lens,
    spectrum: Spectrum,
    settings: MtfSettings,
    channels: Vec<Channel>,
    wave: WavePsfTracer,
}

impl MtfTracer {
    pub fn new(lens: &Lens, spectrum: &Spectrum, settings: MtfSettings) -> AnalysisResult<MtfTracer> {
        spectrum.check()?;
        check_pupil_grid(settings.pupil_grid)?;
        let weights = SpectralWeights {
            wavelengths_um: spectrum.wavelengths_um.clone(),
            weights: spectrum.weights.iter().map(|&w| [w; 3]).collect(),
            skipped_um: Vec::new(),
        };
        let wave = WavePsfTracer::new(
            lens,
            weights,
            WavePsfSettings {
                pupil_grid: settings.pupil_grid,
                ..WavePsfSettings::new(1.0)
            },
        )?;
        let channels = spectrum
            .wavelengths_um
            .iter()
            .map(|&w| Channel::new(lens, w))
            .collect::<AnalysisResult<_>>()?;
        Ok(MtfTracer {
            lens: lens.clone(),
            spectrum: spectrum.clone(),
            settings,
            channels,
            wave,
        })
    }

    pub fn lens(&self) -> &Lens {
        &self.lens
    }

    /// The MTF of one field at `frequencies_cy_mm`.
    pub fn field(&self, field_deg: f64, frequencies_cy_mm: &[f64]) -> AnalysisResult<FieldMtf> {
        check_fields(&self.lens, &[field_deg])?;
        check_samples("frequencies_cy_mm", frequencies_cy_mm, true)?;
        let monochromatic = self.trace_field(field_deg)?;
        Ok(self.evaluate(field_deg, &monochromatic, frequencies_cy_mm))
    }

    /// Tangential and sagittal MTF of one field at one frequency (the through-focus and vs-field
    /// analyses' unit of work).
    pub fn at_frequency(&self, field_deg: f64, frequency_cy_mm: f64) -> AnalysisResult<[f64; 2]> {
        let mtf = self.field(field_deg, &[frequency_cy_mm])?;
        Ok([mtf.tangential[0], mtf.sagittal[0]])
    }

    fn trace_field(&self, field_deg: f64) -> AnalysisResult<Vec<Monochromatic>> {
        let n = self.settings.pupil_grid;
        let geometric = self.settings.method == MtfMethod::Geometric;
        let reference = match self.wave.reference_point_mm(field_deg) {
            Ok(point) => point,
            Err(unicac_psf::PsfError::FieldVignetted { .. }) => return Err(vignetted(field_deg)),
            Err(other) => return Err(other.into()),
        };
        let mut out = Vec::with_capacity(self.channels.len());
        for (channel, &weight) in self.channels.iter().zip(&self.spectrum.weights) {
            let step = channel.step_cy_mm(&self.lens, field_deg, n).ok_or_else(|| {
                AnalysisError::Unsupported(format!(
                    "a marginal ray of field {field_deg} deg at {} um does not reach the image \
                         surface, so its frequency scale is unknown",
                    channel.wavelength_um
                ))
            })?;
            let (points, amplitude, lags, undersampled) = if geometric {
                let (points, amplitude) = channel.grid_rays(field_deg, n);
                let points = points
                    .iter()
                    .map(|p| [p[0] - reference[0], p[1] - reference[1]])
                    .collect();
                (points, amplitude, None, false)
            } else {
                let wavefront = self.wave.wavefront(field_deg, channel.wavelength_um, reference)?;
                let pupil = pupil_function(&wavefront);
                let lags = [
                    autocorrelation(&pupil, n, true),
                    autocorrelation(&pupil, n, false),
                ];
                (
                    Vec::new(),
                    wavefront.amplitude,
                    Some(lags),
                    wavefront.undersampled,
                )
            };
            let transmission = amplitude.iter().filter(|&&a| a > 0.0).count() as f64 / disc_cells(n) as f64;
            let clear = clear_pupil(&amplitude);
            out.push(Monochromatic {
                weight: weight * transmission,
                transmission,
                step_cy_mm: step,
                lags,
                limit: [
                    autocorrelation(&clear, n, true),
                    autocorrelation(&clear, n, false),
                ],
                points,
                undersampled,
            });
        }
        if out.iter().all(|m| m.weight == 0.0) {
            return Err(vignetted(field_deg));
        }
        Ok(out)
    }

    fn evaluate(&self, field_deg: f64, monochromatic: &[Monochromatic], frequencies: &[f64]) -> FieldMtf {
        let total: f64 = monochromatic.iter().map(|m| m.weight).sum();
        let weight_sum: f64 = self.spectrum.weights.iter().sum();
        let curve = |direction: usize, limit: bool| -> Vec<f64> {
            frequencies
                .iter()
                .map(|&nu| {
                    let sum = monochromatic.iter().filter(|m| m.weight > 0.0).fold(
                        Complex64::new(0.0, 0.0),
                        |acc, m| {
                            let t = nu / m.step_cy_mm[direction];
                            let value = match (&m.lags, limit) {
                                (_, true) => at_lag(&m.limit[direction], t),
                                (Some(lags), false) => at_lag(&lags[direction], t),
                                // Geometric: the ray OTF is the product's own frequency scale;
                                // the axis is image y for tangential, x for sagittal.
                                (None, false) => ray_otf(&m.points, 1 - direction, 0.0, nu),
                            };
                            acc + value * m.weight
                        },
                    );
                    (sum / total).norm()
                })
                .collect()
        };
        let limit = [curve(0, true), curve(1, true)];
        let mut mtf = [curve(0, false), curve(1, false)];
        if self.settings.method == MtfMethod::Geometric && self.settings.scale_by_diffraction_limit {
            for d in 0..2 {
                for (m, l) in mtf[d].iter_mut().zip(&limit[d]) {
                    *m *= l;
                }
            }
        }
        let primary = self
            .spectrum
            .wavelengths_um
            .iter()
            .position(|&w| w == self.lens.primary_wavelength_um())
            .unwrap_or(0);
        let n = self.settings.pupil_grid as f64;
        let [tangential, sagittal] = mtf;
        let [limit_t, limit_s] = limit;
        FieldMtf {
            field_deg,
            frequencies_cy_mm: frequencies.to_vec(),
            tangential,
            sagittal,
            diffraction_limit: Directions {
                tangential: limit_t,
                sagittal: limit_s,
            },
            transmission: monochromatic
                .iter()
                .zip(&self.spectrum.weights)
                .map(|(m, w)| m.transmission * w)
                .sum::<f64>()
                / weight_sum,
            cutoff_cy_mm: Cutoff {
                tangential: monochromatic[primary].step_cy_mm[0] * n,
                sagittal: monochromatic[primary].step_cy_mm[1] * n,
            },
            undersampled: monochromatic.iter().any(|m| m.undersampled),
        }
    }
}

/// `unicac analysis mtf --json`: the MTF of every requested field.
#[derive(Debug, Clone, Serialize)]
pub struct MtfReport {
    pub method: MtfMethod,
    pub pupil_grid: usize,
    pub spectrum: Spectrum,
    pub fields: Vec<FieldMtf>,
}

/// The MTF at `frequencies_cy_mm` of each field.
pub fn mtf(
    lens: &Lens,
    spectrum: &Spectrum,
    fields_deg: &[f64],
    frequencies_cy_mm: &[f64],
    settings: MtfSettings,
) -> AnalysisResult<MtfReport> {
    check_fields(lens, fields_deg)?;
    check_samples("frequencies_cy_mm", frequencies_cy_mm, true)?;
    let tracer = MtfTracer::new(lens, spectrum, settings)?;
    let fields = fields_deg
        .iter()
        .map(|&f| tracer.field(f, frequencies_cy_mm))
        .collect::<AnalysisResult<_>>()?;
    Ok(MtfReport {
        method: settings.method,
        pupil_grid: settings.pupil_grid,
        spectrum: spectrum.clone(),
        fields,
    })
}

/// The MTF at a few frequencies across the field (`unicac analysis mtf --vs-field --json`).
#[derive(Debug, Clone, Serialize)]
pub struct MtfVsField {
    pub method: MtfMethod,
    pub pupil_grid: usize,
    pub spectrum: Spectrum,
    pub fields_deg: Vec<f64>,
    /// One entry per frequency.
    pub curves: Vec<MtfAtFrequency>,
}

#[derive(Debug, Clone, Serialize)]
pub struct MtfAtFrequency {
    pub frequency_cy_mm: f64,
    /// One value per field of `fields_deg`.
    pub tangential: Vec<f64>,
    pub sagittal: Vec<f64>,
}

/// Tangential and sagittal MTF at each of `frequencies_cy_mm`, at each of `fields_deg`.
pub fn mtf_vs_field(
    lens: &Lens,
    spectrum: &Spectrum,
    fields_deg: &[f64],
    frequencies_cy_mm: &[f64],
    settings: MtfSettings,
) -> AnalysisResult<MtfVsField> {
    let report = mtf(lens, spectrum, fields_deg, frequencies_cy_mm, settings)?;
    let curves = frequencies_cy_mm
        .iter()
        .enumerate()
        .map(|(k, &frequency_cy_mm)| MtfAtFrequency {
            frequency_cy_mm,
            tangential: report.fields.iter().map(|f| f.tangential[k]).collect(),
            sagittal: report.fields.iter().map(|f| f.sagittal[k]).collect(),
        })
        .collect();
    Ok(MtfVsField {
        method: settings.method,
        pupil_grid: settings.pupil_grid,
        spectrum: spectrum.clone(),
        fields_deg: fields_deg.to_vec(),
        curves,
    })
}
