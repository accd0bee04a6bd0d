//! `device=`: which device traces the PSFs of a call and runs a simulator's image pass ("cpu", "gpu" or
//! "auto"), as the CLI's `--device` chooses it; what the device noted (a fallback to the CPU) becomes a
//! Python warning.

use pyo3::exceptions::{PyRuntimeWarning, PyValueError};
use pyo3::prelude::*;
use std::sync::Arc;
use unicac_gpu::{DeviceChoice, DeviceSelection, Precision};
use unicac_psf::RayBackend;
use unicac_sim::ImageBackend;

fn choice(device: &str) -> PyResult<DeviceChoice> {
    device
        .parse()
        .map_err(|e| PyValueError::new_err(format!("device: {e}")))
}

/// The backend a `device=` keyword names (GPU kernels in f32, the CLI's default precision).
pub fn backend(device: &str) -> PyResult<RayBackend> {
    Ok(DeviceSelection::backend(choice(device)?, Precision::F32))
}

/// A simulator's backends for a `device=` keyword: one device for its PSF rays and its image pass.
pub fn simulator_backends(device: &str) -> PyResult<(RayBackend, ImageBackend)> {
    let selection = Arc::new(DeviceSelection::new(choice(device)?, Precision::F32));
    Ok((
        DeviceSelection::ray_backend(&selection),
        DeviceSelection::image_backend(&selection),
    ))
}

/// Issues the backend's notes as `RuntimeWarning`s.
pub fn warn_notes(py: Python<'_>, backend: &RayBackend) -> PyResult<()> {
    warn(py, backend.take_notes())
}

/// Issues a simulator's image-pass notes (and its rays', which share the device) as `RuntimeWarning`s.
pub fn warn_image_notes(py: Python<'_>, backend: &ImageBackend) -> PyResult<()> {
    warn(py, backend.take_notes())
}

fn warn(py: Python<'_>, notes: Vec<String>) -> PyResult<()> {
    for note in notes {
        let message = std::ffi::CString::new(note.replace('\0', " "))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        PyErr::warn(py, &py.get_type::<PyRuntimeWarning>(), &message, 1)?;
    }
    Ok(())
}
