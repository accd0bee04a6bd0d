//! # unicac-py
//!
//! The native module `unicac._native`: PyO3 bindings over the unicac crates, re-exported by the Python
//! package in `python/unicac`. PyO3 stays here; the core crates know nothing about Python.
//!
//! - `errors`: Rust errors -> named Python exceptions (one place);
//! - `arrays`: numpy in and out, with dtype/shape checks that name the argument;
//! - `json`: the CLI's JSON structs as Python dicts;
//! - `device`: the `device=` keyword (the ray backend of PSF tracing);
//! - `lens`, `trace`, `psf`, `simulate`, `isp`, `ode`, `dataset`: the API, one module per stage;
//! - `outputs`: the output-file policy of `unicac_io` (checks, atomic writes) for the Python tools.
//! - `cli`: `main(argv)`, the `unicac` command itself (crates/unicac-cli as a library).
//!
//! Every call that traces or renders releases the GIL before the parallel (rayon) work, on a thread
//! pool of its own process (`pool`), so forked workers (PyTorch data loaders) work too.

mod arrays;
mod cli;
mod dataset;
mod device;
mod errors;
mod images;
mod isp;
mod json;
mod lens;
mod ode;
mod outputs;
mod pool;
mod psf;
mod simulate;
mod trace;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    m.add_class::<lens::PyLens>()?;
    m.add_function(wrap_pyfunction!(lens::load_lens, m)?)?;
    m.add_function(wrap_pyfunction!(lens::builtin_lenses, m)?)?;
    trace::register(m)?;
    psf::register(m)?;
    simulate::register(m)?;
    images::register(m)?;
    isp::register(m)?;
    ode::register(m)?;
    dataset::register(m)?;
    outputs::register(m)?;
    cli::register(m)?;
    Ok(())
}
