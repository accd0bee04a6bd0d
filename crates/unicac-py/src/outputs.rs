//! The output-file policy (`unicac_io`) for the Python tools: `unicac-train` and `unicac-ray` check
//! their outputs and write their files through the same code as every Rust command, so the two
//! languages cannot drift apart.

use crate::errors::OrRaise;
use pyo3::exceptions::PyOSError;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use unicac_io::OutputPlan;

/// An I/O failure as Python's `OSError(errno, strerror, filename)` (the subclass follows the errno:
/// `FileNotFoundError`, `PermissionError`, ...), so the caller can name the path once.
fn os_error(path: &Path, error: &std::io::Error) -> PyErr {
    let text = error.to_string();
    let strerror = match error.raw_os_error() {
        Some(code) => text
            .strip_suffix(&format!(" (os error {code})"))
            .unwrap_or(&text)
            .to_string(),
        None => text,
    };
    PyOSError::new_err((error.raw_os_error(), strerror, path.display().to_string()))
}

/// Checks a run's outputs against its inputs before any work (`unicac_io::OutputPlan`): an output is
/// never an input (compared by file identity), never inside an input folder, and two outputs never
/// share a path. `outputs` are (flag, path) pairs; the flag names the output in the message.
#[pyfunction]
#[pyo3(signature = (outputs, inputs=None, input_folders=None))]
pub fn check_outputs(
    outputs: Vec<(String, PathBuf)>,
    inputs: Option<Vec<PathBuf>>,
    input_folders: Option<Vec<PathBuf>>,
) -> PyResult<()> {
    let mut plan = OutputPlan::new();
    for input in inputs.unwrap_or_default() {
        plan.input(input);
    }
    for folder in input_folders.unwrap_or_default() {
        plan.input_folder(folder);
    }
    for (flag, output) in outputs {
        plan.output(flag, output);
    }
    plan.check().or_raise()
}

/// The lower-case extension of `path` if it is one of `allowed` (lower case, no dots), else
/// `OutputError` naming `flag` and the extensions expected.
#[pyfunction]
pub fn require_extension(flag: &str, path: PathBuf, allowed: Vec<String>) -> PyResult<String> {
    let allowed: Vec<&str> = allowed.iter().map(String::as_str).collect();
    unicac_io::require_extension(flag, &path, &allowed).or_raise()
}

/// Writes `data` to `path` atomically: a dot-named temporary sibling, synced, renamed over `path`
/// (removed on error, the target left as it was). The folder must exist.
#[pyfunction]
pub fn write_atomically(py: Python<'_>, path: PathBuf, data: &[u8]) -> PyResult<()> {
    py.detach(|| unicac_io::write_atomically(&path, data))
        .map_err(|e| os_error(&path, &e))
}

/// Removes the temporaries in `folder` whose writer is gone (killed runs); a live writer's are kept.
/// Returns the files removed; a missing folder is not an error.
#[pyfunction]
pub fn clean_stale_temporaries(py: Python<'_>, folder: PathBuf) -> PyResult<Vec<PathBuf>> {
    py.detach(|| unicac_io::clean_stale_temporaries(&folder))
        .map_err(|e| os_error(&folder, &e))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(check_outputs, m)?)?;
    m.add_function(wrap_pyfunction!(require_extension, m)?)?;
    m.add_function(wrap_pyfunction!(write_atomically, m)?)?;
    m.add_function(wrap_pyfunction!(clean_stale_temporaries, m)?)?;
    Ok(())
}
