//! Errors of the dataset format and builder; each names the file, flag or field at fault.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error(
        "{path}: not a unicac dataset (no dataset.json with \"format\": \"unicac-dataset\"; `unicac dataset build` makes one)"
    )]
    NotADataset { path: PathBuf },
    #[error(
        "{path}: dataset format version {found} is newer than this unicac reads ({supported}); update unicac"
    )]
    NewerFormat {
        path: PathBuf,
        found: u32,
        supported: u32,
    },
    #[error("{0}")]
    Invalid(String),
    /// A build setting out of its range; `field` names the `BuildSettings` field (a face maps it to
    /// its own option name).
    #[error("{field}: {message}")]
    Setting { field: String, message: String },
}

pub type Result<T> = std::result::Result<T, DatasetError>;

impl DatasetError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> DatasetError {
        DatasetError::Io {
            path: path.into(),
            source,
        }
    }

    pub fn setting(field: impl Into<String>, message: impl Into<String>) -> DatasetError {
        DatasetError::Setting {
            field: field.into(),
            message: message.into(),
        }
    }

    pub fn format(path: impl Into<PathBuf>, message: impl Into<String>) -> DatasetError {
        DatasetError::Format {
            path: path.into(),
            message: message.into(),
        }
    }
}
