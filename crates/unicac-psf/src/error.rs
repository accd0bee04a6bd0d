//! Typed errors of the PSF crate.

use std::path::PathBuf;
use unicac_optics::OpticsError;
use unicac_trace::TraceError;

#[derive(Debug, thiserror::Error)]
pub enum PsfError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// No ray of the field reaches the image (a field vignetted away).
    #[error("no ray of field {field_deg} deg reaches the image surface ({rays_traced} traced)")]
    FieldVignetted { field_deg: f64, rays_traced: usize },
    #[error("invalid PSF request: {0}")]
    InvalidRequest(String),
}

pub type PsfResult<T> = std::result::Result<T, PsfError>;
