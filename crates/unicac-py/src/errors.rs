//! The one place where Rust errors become Python exceptions.
//!
//! Every failure of a whole request raises a subclass of `unicac.UnicacError` named after the stage
//! that failed: `LensError` (reading or analysing a lens), `TraceError` (ray aiming, trace requests),
//! `PsfError`, `ImageError` (files, ISP steps), `SimulationError`, `MetricsError`, `OdeError` and `DatasetError`; an output path the
//! output-file policy refuses raises `OutputError`.
//! A nested error keeps the most specific stage: a lens problem found while simulating is a
//! `LensError`, also when the ODE found it. A trace or PSF parameter out of range raises `ValueError`
//! naming it (a simulation's stays a `SimulationError`, naming it too). Wrong argument types, dtypes or shapes are caught before Rust sees them and raise
//! the standard `TypeError` / `ValueError` naming the argument (see `arrays.rs`). Per-ray failures are
//! not errors: they are status codes.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    unicac,
    UnicacError,
    PyException,
    "Base class of every error unicac raises for a failed request."
);
create_exception!(
    unicac,
    LensError,
    UnicacError,
    "A lens file or lens could not be read, validated or analysed."
);
create_exception!(
    unicac,
    TraceError,
    UnicacError,
    "A trace request failed as a whole (e.g. real ray aiming)."
);
create_exception!(
    unicac,
    PsfError,
    UnicacError,
    "A PSF could not be computed (e.g. a field vignetted away)."
);
create_exception!(
    unicac,
    ImageError,
    UnicacError,
    "An image could not be read, written or processed."
);
create_exception!(
    unicac,
    SimulationError,
    UnicacError,
    "An image simulation request was invalid."
);
create_exception!(
    unicac,
    MetricsError,
    UnicacError,
    "A metric could not be computed from its inputs."
);
create_exception!(
    unicac,
    DatasetError,
    UnicacError,
    "A dataset folder, manifest or PSF table could not be read or written."
);
create_exception!(
    unicac,
    OdeError,
    UnicacError,
    "The Optical Degradation Evaluator failed for a lens."
);
create_exception!(
    unicac,
    OutputError,
    UnicacError,
    "An output path was refused: it is an input, lies inside an input folder, is another output's path, or its extension does not name the format written."
);

/// A library parameter error as a `ValueError` naming the Python keyword (`fields_deg` for the
/// library's `field_deg` when the keyword takes a list).
pub fn keyword_error(keyword: &str, parameter: unicac_trace::InvalidParameter) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(format!("{keyword}: {}", parameter.message))
}

/// A library parameter error where the library's name is the Python keyword (`pixel_um`,
/// `max_kernel_px`, `field_deg`): a `ValueError` that names it.
pub fn parameter_error(parameter: unicac_trace::InvalidParameter) -> PyErr {
    keyword_error(parameter.field, parameter)
}

/// A Rust error that knows which Python exception it becomes.
pub trait ToPyErr {
    fn to_py_err(self) -> PyErr;
}

/// `result.or_raise()?` turns any unicac error into the matching Python exception.
pub trait OrRaise<T> {
    fn or_raise(self) -> PyResult<T>;
}

impl<T, E: ToPyErr> OrRaise<T> for Result<T, E> {
    fn or_raise(self) -> PyResult<T> {
        self.map_err(ToPyErr::to_py_err)
    }
}

impl ToPyErr for unicac_optics::OpticsError {
    fn to_py_err(self) -> PyErr {
        LensError::new_err(self.to_string())
    }
}

impl ToPyErr for unicac_trace::TraceError {
    fn to_py_err(self) -> PyErr {
        match self {
            unicac_trace::TraceError::Optics(e) => e.to_py_err(),
            unicac_trace::TraceError::InvalidParameter(parameter) => parameter_error(parameter),
            other => TraceError::new_err(other.to_string()),
        }
    }
}

impl ToPyErr for unicac_psf::PsfError {
    fn to_py_err(self) -> PyErr {
        match self {
            unicac_psf::PsfError::Optics(e) => e.to_py_err(),
            unicac_psf::PsfError::Trace(e) => e.to_py_err(),
            unicac_psf::PsfError::InvalidParameter(parameter) => parameter_error(parameter),
            other => PsfError::new_err(other.to_string()),
        }
    }
}

impl ToPyErr for unicac_image::ImageError {
    fn to_py_err(self) -> PyErr {
        ImageError::new_err(self.to_string())
    }
}

impl ToPyErr for unicac_metrics::MetricsError {
    fn to_py_err(self) -> PyErr {
        MetricsError::new_err(self.to_string())
    }
}

impl ToPyErr for unicac_sim::SimError {
    fn to_py_err(self) -> PyErr {
        match self {
            unicac_sim::SimError::Optics(e) => e.to_py_err(),
            unicac_sim::SimError::Trace(e) => e.to_py_err(),
            unicac_sim::SimError::Psf(e) => e.to_py_err(),
            unicac_sim::SimError::Image(e) => e.to_py_err(),
            other => SimulationError::new_err(other.to_string()),
        }
    }
}

impl ToPyErr for unicac_ode::OdeError {
    fn to_py_err(self) -> PyErr {
        // A lens, trace, PSF or image problem found while grading keeps its own exception class.
        match self {
            unicac_ode::OdeError::Sim(e) => e.to_py_err(),
            unicac_ode::OdeError::Psf(e) => e.to_py_err(),
            unicac_ode::OdeError::Trace(e) => e.to_py_err(),
            unicac_ode::OdeError::Metrics(e) => e.to_py_err(),
            unicac_ode::OdeError::Image(e) => e.to_py_err(),
            other => OdeError::new_err(other.to_string()),
        }
    }
}

impl ToPyErr for unicac_dataset::DatasetError {
    fn to_py_err(self) -> PyErr {
        use unicac_dataset::DatasetError as E;
        // A lens, simulation, ODE or image problem met while building keeps its own exception class,
        // with the dataset's context (the lens or pair) in its message.
        let message = self.to_string();
        let inner = match self {
            E::Invalid(message) => return pyo3::exceptions::PyValueError::new_err(message),
            E::Optics { source, .. } => source.to_py_err(),
            E::Simulation { source, .. } => source.to_py_err(),
            E::Ode { source, .. } => source.to_py_err(),
            E::Image { source, .. } => source.to_py_err(),
            _ => return DatasetError::new_err(message),
        };
        Python::attach(|py| PyErr::from_type(inner.get_type(py), message))
    }
}

impl ToPyErr for unicac_io::OutputError {
    fn to_py_err(self) -> PyErr {
        OutputError::new_err(self.to_string())
    }
}

/// Registers the exception classes on the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("UnicacError", py.get_type::<UnicacError>())?;
    m.add("LensError", py.get_type::<LensError>())?;
    m.add("TraceError", py.get_type::<TraceError>())?;
    m.add("PsfError", py.get_type::<PsfError>())?;
    m.add("ImageError", py.get_type::<ImageError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("MetricsError", py.get_type::<MetricsError>())?;
    m.add("OdeError", py.get_type::<OdeError>())?;
    m.add("DatasetError", py.get_type::<DatasetError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    Ok(())
}
