//! PSFs of one field (`psf`), as `unicac psf` computes them, returned as float32 kernels with metadata.

use crate::arrays::f32_array;
use crate::errors::{OrRaise, PsfError};
use crate::json;
use crate::lens::PyLens;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;
use unicac_optics::Lens;
use unicac_psf::{
    visible_wavelengths_um, FieldPsf, PsfSettings, PsfTracer, SpectralResponse, SpectralWeights,
    WavePsfSettings, WavePsfTracer,
};

/// Pixel pitch when neither `pixel_um` nor the lens's sensor gives one (as `unicac psf`).
const DEFAULT_PIXEL_UM: f64 = 2.0;
/// Smallest wave-optics kernel (room for the diffraction rings), as `unicac psf`.
const MIN_WAVE_KERNEL_PX: usize = 31;

/// The metadata `unicac psf --json` reports (without `lens` and `out`).
#[derive(Serialize, Clone)]
struct PsfMetadata {
    mode: String,
    field_deg: f64,
    pixel_um: f64,
    kernel_px: usize,
    wavelengths_um: Vec<f64>,
    skipped_wavelengths_um: Vec<f64>,
    channels: Vec<&'static str>,
    reference_mm: [f64; 2],
    transmission: f64,
    energy_cut: Vec<f64>,
    rays_traced: usize,
}

/// The PSF of one field: `kernels` is float32 of shape (C, K, K) (C = 3 for R, G, B, or 1 for a
/// monochromatic PSF), each kernel summing to 1, rows running down the image (towards sensor -y) and
/// columns along sensor +x, centred on the primary-wavelength real chief ray (`reference_mm`).
#[pyclass(module = "unicac", name = "Psf", frozen)]
pub struct PyPsf {
    kernels: Py<PyAny>,
    meta: PsfMetadata,
    /// True when the wave-optics pupil grid undersamples the wavefront (the PSF is approximate).
    undersampled: bool,
}

#[pymethods]
impl PyPsf {
    /// float32 array (C, K, K).
    #[getter]
    fn kernels(&self, py: Python<'_>) -> Py<PyAny> {
        self.kernels.clone_ref(py)
    }
    /// "geometric" or "wave".
    #[getter]
    fn mode(&self) -> &str {
        &self.meta.mode
    }
    #[getter]
    fn field_deg(&self) -> f64 {
        self.meta.field_deg
    }
    #[getter]
    fn pixel_um(&self) -> f64 {
        self.meta.pixel_um
    }
    #[getter]
    fn kernel_px(&self) -> usize {
        self.meta.kernel_px
    }
    /// "R", "G", "B" or "Y" (monochromatic), one per kernel.
    #[getter]
    fn channels(&self) -> Vec<&'static str> {
        self.meta.channels.clone()
    }
    #[getter]
    fn wavelengths_um(&self) -> Vec<f64> {
        self.meta.wavelengths_um.clone()
    }
    /// Primary-wavelength real chief ray on the image surface (mm): the kernels' centre.
    #[getter]
    fn reference_mm(&self) -> (f64, f64) {
        (self.meta.reference_mm[0], self.meta.reference_mm[1])
    }
    /// Fraction of the traced light that reached the image (vignetting), spectrally weighted.
    #[getter]
    fn transmission(&self) -> f64 {
        self.meta.transmission
    }
    /// Energy outside the kernel per channel, before normalisation (non-zero when the size was capped).
    #[getter]
    fn energy_cut(&self) -> Vec<f64> {
        self.meta.energy_cut.clone()
    }
    #[getter]
    fn undersampled(&self) -> bool {
        self.undersampled
    }
    /// The metadata as a dict with the keys of `unicac psf --json` (without `lens` and `out`).
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        json::serialize_dict(py, &self.meta)
    }
    fn __repr__(&self) -> String {
        format!(
            "Psf(mode={:?}, field_deg={}, kernel_px={}, channels={:?}, pixel_um={})",
            self.meta.mode, self.meta.field_deg, self.meta.kernel_px, self.meta.channels, self.meta.pixel_um
        )
    }
}

/// Geometric PSF sized from the spot (as `unicac psf --mode geometric`).
fn geometric(
    lens: &Lens,
    weights: SpectralWeights,
    pixel_um: f64,
    field_deg: f64,
    mono: bool,
    max_kernel_px: Option<usize>,
) -> PyResult<FieldPsf> {
    let settings = PsfSettings::new(pixel_um).with_kernel_cap(max_kernel_px);
    let tracer = PsfTracer::new(lens, weights, settings).or_raise()?;
    let reference = tracer.reference_point_mm(field_deg).or_raise()?;
    let hits = tracer.hits(field_deg, reference);
    let size = tracer.kernel_size_for(&hits);
    Ok(tracer.kernels_from_hits(field_deg, reference, &hits, size, mono))
}

/// Wave-optics PSF sized like the geometric one of the same field, at least 31 px (as `unicac psf
/// --mode wave`). Returns the PSF and whether the pupil grid undersampled the wavefront.
fn wave(
    lens: &Lens,
    weights: SpectralWeights,
    pixel_um: f64,
    field_deg: f64,
    mono: bool,
) -> PyResult<(FieldPsf, bool)> {
    let sizing = PsfTracer::new(lens, weights.clone(), PsfSettings::new(pixel_um)).or_raise()?;
    let reference = sizing.reference_point_mm(field_deg).or_raise()?;
    let size = sizing
        .kernel_size_for(&sizing.hits(field_deg, reference))
        .max(MIN_WAVE_KERNEL_PX);
    let tracer = WavePsfTracer::new(lens, weights, WavePsfSettings::new(pixel_um)).or_raise()?;
    let detailed = tracer
        .field_psf_detailed(field_deg, reference, size, mono)
        .or_raise()?;
    Ok((detailed.psf, detailed.undersampled))
}

/// The PSF at field angle `field_deg`, as `unicac psf` computes it.
///
/// `wavelengths_um`: None gives R, G, B kernels over 400-700 nm (31 wavelengths, the default camera's
/// sensitivities); one wavelength gives a monochromatic kernel; several are weighted by the camera into
/// R, G, B. `mode`: "geometric" (ray density) or "wave" (diffraction). `pixel_um`: default the lens's
/// sensor pitch, else 2 um. `object_distance_mm` replaces the lens's object distance. `max_kernel_px`
/// (geometric mode; odd, at most 4095): the kernel holds every ray up to this size instead of 99.5% of
/// the energy within 127 px. GIL released.
#[pyfunction]
#[pyo3(signature = (lens, field_deg, wavelengths_um=None, mode="geometric", pixel_um=None, object_distance_mm=None, max_kernel_px=None))]
#[allow(clippy::too_many_arguments)]
pub fn psf(
    py: Python<'_>,
    lens: &PyLens,
    field_deg: f64,
    wavelengths_um: Option<Vec<f64>>,
    mode: &str,
    pixel_um: Option<f64>,
    object_distance_mm: Option<f64>,
    max_kernel_px: Option<usize>,
) -> PyResult<PyPsf> {
    if let Some(n) = max_kernel_px {
        unicac_psf::check_kernel_cap(n).map_err(|e| PyValueError::new_err(format!("max_kernel_px: {e}")))?;
    }
    if mode != "geometric" && mode != "wave" {
        return Err(PyValueError::new_err(format!(
            "mode: '{mode}': expected \"geometric\" or \"wave\""
        )));
    }
    if !(field_deg.is_finite() && field_deg.abs() < 90.0) {
        return Err(PyValueError::new_err(format!(
            "field_deg: {field_deg} must lie strictly between -90 and 90"
        )));
    }
    let wavelengths = wavelengths_um.unwrap_or_default();
    if let Some(bad) = wavelengths.iter().find(|w| !(w.is_finite() && **w > 0.0)) {
        return Err(PyValueError::new_err(format!(
            "wavelengths_um: {bad} must be positive"
        )));
    }
    let owned;
    let lens_ref = match object_distance_mm {
        Some(_) => {
            owned = lens.with_object_distance_inner(object_distance_mm)?;
            &owned
        }
        None => &lens.lens,
    };
    let pixel_um = pixel_um
        .or(lens_ref.sensor.map(|s| s.pixel_pitch_um))
        .unwrap_or(DEFAULT_PIXEL_UM);
    if !(pixel_um.is_finite() && pixel_um > 0.0) {
        return Err(PyValueError::new_err(format!(
            "pixel_um: {pixel_um} must be positive"
        )));
    }
    let mono = wavelengths.len() == 1;
    let weights = match wavelengths.as_slice() {
        [] => SpectralWeights::new(&SpectralResponse::default_camera(), &visible_wavelengths_um(31)),
        [w] => SpectralWeights::monochromatic(*w),
        many => SpectralWeights::new(&SpectralResponse::default_camera(), many),
    };
    let (field_psf, undersampled) = crate::pool::detach(py, || match mode {
        "wave" => wave(lens_ref, weights.clone(), pixel_um, field_deg, mono),
        _ => geometric(lens_ref, weights.clone(), pixel_um, field_deg, mono, max_kernel_px).map(|p| (p, false)),
    })?;
    from_field_psf(py, &field_psf, mode, pixel_um, &weights, undersampled)
}

/// Wraps a computed `FieldPsf`.
pub fn from_field_psf(
    py: Python<'_>,
    field_psf: &FieldPsf,
    mode: &str,
    pixel_um: f64,
    weights: &SpectralWeights,
    undersampled: bool,
) -> PyResult<PyPsf> {
    let size = field_psf
        .kernels
        .first()
        .map(|k| k.size)
        .ok_or_else(|| PsfError::new_err("the PSF has no kernel"))?;
    let channels: Vec<&'static str> = if field_psf.kernels.len() == 1 {
        vec!["Y"]
    } else {
        vec!["R", "G", "B"]
    };
    let data: Vec<f32> = field_psf
        .kernels
        .iter()
        .flat_map(|k| k.data.iter().copied())
        .collect();
    let kernels = f32_array(py, data, &[field_psf.kernels.len(), size, size])?.unbind();
    Ok(PyPsf {
        kernels,
        meta: PsfMetadata {
            mode: mode.to_string(),
            field_deg: field_psf.field_deg,
            pixel_um,
            kernel_px: size,
            wavelengths_um: weights.wavelengths_um.clone(),
            skipped_wavelengths_um: weights.skipped_um.clone(),
            channels,
            reference_mm: field_psf.reference_mm,
            transmission: field_psf.transmission,
            energy_cut: field_psf.energy_cut.clone(),
            rays_traced: field_psf.rays_traced,
        },
        undersampled,
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyPsf>()?;
    m.add_function(wrap_pyfunction!(psf, m)?)?;
    Ok(())
}
