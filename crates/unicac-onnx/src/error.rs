//! The one error type of the crate: every variant names the file or library at fault.

use std::path::PathBuf;

use thiserror::Error;

#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OnnxError {
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
    /// No onnxruntime library was found or it does not load (the message says where it looked).
    #[error("{0}")]
    RuntimeMissing(String),
    #[error("onnxruntime: {context}: {message}")]
    Ort { context: String, message: String },
}

pub type Result<T> = std::result::Result<T, OnnxError>;

impl OnnxError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> OnnxError {
        OnnxError::Io {
            path: path.into(),
            source,
        }
    }

    pub fn ort(context: impl Into<String>, error: impl std::fmt::Display) -> OnnxError {
        OnnxError::Ort {
            context: context.into(),
            message: error.to_string(),
        }
    }
}
