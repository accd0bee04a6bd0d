//! The one error type of the crate: every variant names the file, flag or field at fault.

use std::path::PathBuf;

use thiserror::Error;

#[derive(Debug, Error)]
#[non_exhaustive]
pub enum BenchError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not an ONNX model: {why}")]
    NotOnnx { path: PathBuf, why: String },
    #[error("{path}: does not follow the model contract (docs/models.md): {why}")]
    Contract { path: PathBuf, why: String },
    #[error("{0}")]
    RuntimeMissing(String),
    #[error("onnxruntime: {context}: {message}")]
    Ort { context: String, message: String },
    #[error("{path}: {why}")]
    Weights { path: PathBuf, why: String },
    #[error("pickle {what}: {why}")]
    Pickle { what: String, why: String },
    #[error("{0}")]
    InvalidInput(String),
    /// The run's estimated peak memory exceeds its limit (refused before any work).
    #[error("{0}")]
    MemoryExceeded(crate::memory::MemoryExceeded),
    /// A setting out of its range, named by its library field (`threads`, `wiener_nsr`).
    #[error(transparent)]
    InvalidParameter(#[from] unicac_trace::InvalidParameter),
    #[error("{what}: {source}")]
    Metrics {
        what: String,
        #[source]
        source: unicac_metrics::MetricsError,
    },
    #[error(transparent)]
    Image(#[from] unicac_image::ImageError),
    #[error(transparent)]
    Plot(#[from] unicac_plot::PlotError),
}

pub type Result<T> = std::result::Result<T, BenchError>;

impl BenchError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> BenchError {
        BenchError::Io {
            path: path.into(),
            source,
        }
    }

    pub fn ort(context: impl Into<String>, error: impl std::fmt::Display) -> BenchError {
        BenchError::Ort {
            context: context.into(),
            message: error.to_string(),
        }
    }

    pub fn metrics(what: impl Into<String>, source: unicac_metrics::MetricsError) -> BenchError {
        BenchError::Metrics {
            what: what.into(),
            source,
        }
    }
}
