//! Typed errors of tolerancing; the lower crates' errors pass through whole.

use std::path::PathBuf;
use unicac_analysis::AnalysisError;
use unicac_optics::OpticsError;
use unicac_trace::{InvalidParameter, TraceError};

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ToleranceError {
    /// The tolerance file, or one of its fields (by its name in the file), is wrong.
    #[error("tolerance file: {}{reason}", field.as_ref().map(|f| format!("field {f}: ")).unwrap_or_default())]
    InvalidSpec { field: Option<String>, reason: String },
    /// A setting of the run out of its range, by its library name (`trials`, `pupil_grid`, ...).
    #[error(transparent)]
    InvalidParameter(#[from] InvalidParameter),
    /// The lens cannot be toleranced this way.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// A run folder written for another lens, tolerance file or settings.
    #[error("{folder}: {reason}")]
    Folder { folder: PathBuf, reason: String },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Optics(#[from] OpticsError),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    Analysis(#[from] AnalysisError),
    #[error(transparent)]
    Ode(#[from] unicac_ode::OdeError),
}

pub type ToleranceResult<T> = std::result::Result<T, ToleranceError>;

impl ToleranceError {
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> ToleranceError {
        let path = path.into();
        move |source| ToleranceError::Io { path, source }
    }
}
