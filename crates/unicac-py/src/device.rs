//! `device=`: which ray backend traces the PSFs of a call ("cpu", "gpu" or "auto"), as the CLI's
//! `--device` chooses it; what the device noted (a fallback to the CPU) becomes a Python warning.

use pyo3::exceptions::{PyRuntimeWarning, PyValueError};
use pyo3::prelude::*;
use unicac_gpu::{DeviceChoice, DeviceSelection, Precision};
use unicac_psf::RayBackend;

/// The backend a `device=` keyword names (GPU kernels in f32, the CLI's default precision).
pub fn backend(device: &str) -> PyResult<RayBackend> {
    let choice: DeviceChoice = device
        .parse()
        .map_err(|e| PyValueError::new_err(format!("device: {e}")))?;
    Ok(DeviceSelection::backend(choice, Precision::F32))
}

/// Issues the backend's notes as `RuntimeWarning`s.
pub fn warn_notes(py: Python<'_>, backend: &RayBackend) -> PyResult<()> {
    for note in backend.take_notes() {
        let message = std::ffi::CString::new(note.replace('\0', " "))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        PyErr::warn(py, &py.get_type::<PyRuntimeWarning>(), &message, 1)?;
    }
    Ok(())
}
