//! `Lens`, `load_lens`, `builtin_lenses`: lens files in, first-order data out.

use crate::errors::OrRaise;
use crate::json;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use unicac_optics::{builtin, Lens, LensSpec};
use unicac_trace::LensSummary;

/// A validated lens (from a `.json` or `.zmx` file or `builtin:NAME`). Immutable.
#[pyclass(module = "unicac", name = "Lens", frozen)]
pub struct PyLens {
    pub lens: Lens,
    pub spec: LensSpec,
    pub source: String,
    warnings: Vec<String>,
}

/// What `unicac lens info --json` prints (the same struct, so the keys cannot drift apart).
fn lens_info(lens: &Lens) -> PyResult<LensSummary> {
    LensSummary::of(lens).or_raise()
}

impl PyLens {
    /// The validated lens with another object distance (mm; None = infinity).
    pub fn with_object_distance_inner(&self, object_distance_mm: Option<f64>) -> PyResult<Lens> {
        let mut spec = self.spec.clone();
        spec.object_distance_mm = object_distance_mm;
        Lens::from_spec(&spec).map_err(|e| crate::errors::LensError::new_err(format!("{}: {e}", self.source)))
    }

    fn from_spec(spec: LensSpec, source: String, warnings: Vec<String>) -> PyResult<PyLens> {
        let lens = Lens::from_spec(&spec)
            .map_err(|e| crate::errors::LensError::new_err(format!("{source}: {e}")))?;
        Ok(PyLens {
            lens,
            spec,
            source,
            warnings,
        })
    }
}

#[pymethods]
impl PyLens {
    /// The lens's name from its file ("" when it has none).
    #[getter]
    fn name(&self) -> &str {
        &self.lens.name
    }

    /// Where the lens came from: the path or `builtin:NAME` given to `load_lens`.
    #[getter]
    fn source(&self) -> &str {
        &self.source
    }

    /// Reader warnings (e.g. Zemax settings that were read approximately).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// Number of surfaces, the image surface included.
    #[getter]
    fn num_surfaces(&self) -> usize {
        self.lens.surfaces.len()
    }

    /// The lens's wavelengths (um).
    #[getter]
    fn wavelengths_um(&self) -> Vec<f64> {
        self.lens.wavelengths_um()
    }

    /// The primary wavelength (um): pupils and paraxial data are computed there.
    #[getter]
    fn primary_wavelength_um(&self) -> f64 {
        self.lens.primary_wavelength_um()
    }

    /// The lens's field angles (deg).
    #[getter]
    fn field_angles_deg(&self) -> PyResult<Vec<f64>> {
        Ok(self.lens.first_order().or_raise()?.field_angles_deg)
    }

    /// Object distance (mm) from surface 1; None for an object at infinity.
    #[getter]
    fn object_distance_mm(&self) -> Option<f64> {
        self.lens.object_distance_mm
    }

    /// First-order data, real working F/#, clear semi-diameters and distortion: a dict with the same
    /// keys and values as `unicac lens info LENS --json`.
    fn first_order<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let info = crate::pool::detach(py, || lens_info(&self.lens))?;
        json::serialize_dict(py, &info)
    }

    /// A copy of this lens with another object distance (mm; None = infinity), for finite conjugates.
    #[pyo3(signature = (object_distance_mm))]
    fn with_object_distance(&self, object_distance_mm: Option<f64>) -> PyResult<PyLens> {
        if let Some(d) = object_distance_mm {
            if !d.is_finite() {
                return Err(PyValueError::new_err(format!(
                    "object_distance_mm: {d} must be finite (None means infinity)"
                )));
            }
        }
        let mut spec = self.spec.clone();
        spec.object_distance_mm = object_distance_mm;
        PyLens::from_spec(spec, self.source.clone(), self.warnings.clone())
    }

    /// Writes the lens as unicac JSON or Zemax `.zmx` (chosen by the extension).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        unicac_optics::write_spec(&self.spec, &path).or_raise()
    }

    fn __repr__(&self) -> String {
        format!(
            "Lens(source={:?}, name={:?}, surfaces={})",
            self.source,
            self.lens.name,
            self.lens.surfaces.len()
        )
    }
}

/// Reads a lens: a `.json` (unicac) or `.zmx` (Zemax) file, or `builtin:NAME` (see
/// `builtin_lenses()`). Raises `LensError` when the file cannot be read or is not a valid lens.
#[pyfunction]
#[pyo3(signature = (path))]
pub fn load_lens(path: PathBuf) -> PyResult<PyLens> {
    let text = path.to_string_lossy().into_owned();
    let loaded = builtin::resolve_spec(&path).or_raise()?;
    PyLens::from_spec(loaded.spec, text, loaded.warnings)
}

/// Names of the lenses bundled with unicac (load them as `load_lens("builtin:NAME")`).
#[pyfunction]
pub fn builtin_lenses() -> Vec<String> {
    builtin::names().map(str::to_string).collect()
}
