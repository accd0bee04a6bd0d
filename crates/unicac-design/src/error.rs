//! Typed errors of the design crate. A design that fails a check is not an error (it is rejected and its
//! violations are reported); these are failures of a whole request.

use std::path::PathBuf;
use unicac_optics::OpticsError;
use unicac_trace::TraceError;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DesignError {
    /// The specification cannot be designed for; `field` names the offending option.
    #[error("invalid design specification: {field}: {message}")]
    InvalidSpec { field: String, message: String },
    #[error(transparent)]
    Optics(#[from] OpticsError),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error("plot: {0}")]
    Plot(#[from] unicac_plot::PlotError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A library directory holds files this run cannot resume from.
    #[error("{path}: cannot resume: {message}")]
    Resume { path: PathBuf, message: String },
}

impl DesignError {
    pub fn spec(field: impl Into<String>, message: impl Into<String>) -> Self {
        DesignError::InvalidSpec {
            field: field.into(),
            message: message.into(),
        }
    }
}

pub type Result<T> = std::result::Result<T, DesignError>;
