//! `unicac._native.main(argv)`: the `unicac` command of the Python package, the same CLI as the Rust
//! binary (`unicac_cli::run`), behaving as that binary does.

use pyo3::prelude::*;
use std::path::PathBuf;

/// Runs `unicac ARGS...` (`argv[0]` is the program name) and returns the exit code (0, 1 on an
/// error, 2 on a usage error, 101 on a panic), stdout flushed. For a process that exits with it
/// (`unicac.cli.main`): Ctrl-C and a closed stdout end the process as they end the binary.
#[pyfunction]
pub fn main(py: Python<'_>, argv: Vec<std::ffi::OsString>) -> PyResult<u8> {
    let sys = py.import("sys")?;
    let python: Option<PathBuf> = sys
        .getattr("executable")?
        .extract::<Option<String>>()?
        .filter(|p| !p.is_empty())
        .map(PathBuf::from);
    let host = unicac_cli::Host { python };
    // Python turns SIGINT into KeyboardInterrupt, which it only raises between bytecodes: during a long
    // native command Ctrl-C would do nothing. The default ends the process, as it ends the binary.
    // `run` gives SIGPIPE its default too; both of Python's dispositions are put back afterwards, for a
    // caller that goes on running Python.
    // SAFETY: changing signal dispositions has no preconditions; the saved values came from `signal`.
    let saved = unsafe {
        [
            (libc::SIGINT, libc::signal(libc::SIGINT, libc::SIG_DFL)),
            (libc::SIGPIPE, libc::signal(libc::SIGPIPE, libc::SIG_DFL)),
        ]
    };
    let code = py.detach(|| std::panic::catch_unwind(|| unicac_cli::run(argv, &host)).unwrap_or(101));
    for (signal, disposition) in saved {
        if disposition != libc::SIG_ERR {
            // SAFETY: as above.
            unsafe { libc::signal(signal, disposition) };
        }
    }
    Ok(code)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(main, m)?)
}
