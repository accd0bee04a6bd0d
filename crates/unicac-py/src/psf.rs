//! PSFs of one field (`psf`), as `unicac psf` computes them, returned as float32 kernels with metadata.

use crate::arrays::f32_array;
use crate::errors::{OrRaise, PsfError};
use crate::json;
use crate::lens::PyLens;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use unicac_psf::{FieldPsf, FieldPsfRequest, PsfMetadata, PsfMode, SpectralWeights};

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
    fn mode(&self) -> &'static str {
        self.meta.mode.name()
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

/// The PSF at field angle `field_deg`, as `unicac psf` computes it.
///
/// `wavelengths_um`: None gives R, G, B kernels over 400-700 nm (31 wavelengths, the default camera's
/// sensitivities); one wavelength gives a monochromatic kernel; several are weighted by the camera into
/// R, G, B. `mode`: "geometric" (ray density) or "wave" (diffraction). `pixel_um`: default the lens's
/// sensor pitch, else 2 um. `object_distance_mm` replaces the lens's object distance. `max_kernel_px`
/// (geometric mode; odd, at most 4095): the kernel holds every ray up to this size instead of 99.5% of
/// the energy within 127 px. `field_x_deg` (geometric mode): the field's x angle, for a lens with
/// decentred or tilted surfaces, whose PSF at (x, y) is not the one at the same radius rotated. GIL
/// released.
#[pyfunction]
#[pyo3(signature = (lens, field_deg, wavelengths_um=None, mode="geometric", pixel_um=None, object_distance_mm=None, max_kernel_px=None, device="cpu", field_x_deg=0.0))]
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
    device: &str,
    field_x_deg: f64,
) -> PyResult<PyPsf> {
    let mode: PsfMode = mode.parse().or_raise()?;
    let request = FieldPsfRequest::new(mode, vec![field_deg], wavelengths_um.unwrap_or_default())
        .and_then(|r| r.with_kernel_cap(max_kernel_px))
        .and_then(|r| r.with_field_x_deg(field_x_deg))
        .and_then(|r| r.with_pixel_um(pixel_um))
        .or_raise()?
        .with_backend(crate::device::backend(device)?);
    let owned;
    let lens_ref = match object_distance_mm {
        Some(_) => {
            owned = lens.with_object_distance_inner(object_distance_mm)?;
            &owned
        }
        None => &lens.lens,
    };
    let pixel_um = request.pixel_um_for(lens_ref).or_raise()?;
    let traced = crate::pool::detach(py, || request.run(lens_ref).or_raise());
    crate::device::warn_notes(py, request.backend())?;
    let mut traced = traced?;
    let field_psf = traced
        .psfs
        .pop()
        .ok_or_else(|| PsfError::new_err("no PSF was traced"))?;
    from_field_psf(
        py,
        &field_psf,
        mode,
        pixel_um,
        &traced.weights,
        traced.undersampled,
    )
}

/// Wraps a computed `FieldPsf`.
pub fn from_field_psf(
    py: Python<'_>,
    field_psf: &FieldPsf,
    mode: PsfMode,
    pixel_um: f64,
    weights: &SpectralWeights,
    undersampled: bool,
) -> PyResult<PyPsf> {
    let size = field_psf
        .kernels
        .first()
        .map(|k| k.size)
        .ok_or_else(|| PsfError::new_err("the PSF has no kernel"))?;
    let data: Vec<f32> = field_psf
        .kernels
        .iter()
        .flat_map(|k| k.data.iter().copied())
        .collect();
    let kernels = f32_array(py, data, &[field_psf.kernels.len(), size, size])?.unbind();
    Ok(PyPsf {
        kernels,
        meta: PsfMetadata::new(mode, field_psf, pixel_um, weights),
        undersampled,
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyPsf>()?;
    m.add_function(wrap_pyfunction!(psf, m)?)?;
    Ok(())
}
