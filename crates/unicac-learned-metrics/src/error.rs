//! The one error type of the crate: every variant names the file or input at fault; the runtime's
//! errors keep their kind.

use std::path::PathBuf;

use thiserror::Error;

#[derive(Debug, Error)]
#[non_exhaustive]
pub enum LearnedMetricError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Weights that are missing, damaged or of the wrong shape.
    #[error("{path}: {why}")]
    Weights { path: PathBuf, why: String },
    /// A pickle in the weights' source that the restricted reader refuses.
    #[error("pickle {what}: {why}")]
    Pickle { what: String, why: String },
    /// Images or features a metric cannot score (sizes that differ, too few samples).
    #[error("{0}")]
    InvalidInput(String),
    #[error(transparent)]
    Onnx(#[from] unicac_onnx::OnnxError),
}

pub type Result<T> = std::result::Result<T, LearnedMetricError>;

impl LearnedMetricError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> LearnedMetricError {
        LearnedMetricError::Io {
            path: path.into(),
            source,
        }
    }
}
