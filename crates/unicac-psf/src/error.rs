//! Typed errors of the PSF crate.

use std::path::PathBuf;
use unicac_optics::OpticsError;
use unicac_trace::TraceError;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
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
    /// No ray of any field of a map reaches the image.
    #[error(
        "the lens vignettes the whole field: none of the {rays_traced} rays traced from 0 to {max_field_deg:.2} deg \
         reached the sensor (check the clear semi-diameters)"
    )]
    AllFieldsVignetted { max_field_deg: f64, rays_traced: usize },
    /// A request parameter out of its range, named by its library name (`field_deg`, `wavelength_um`,
    /// `pixel_um`, `max_kernel_px`, `mode`), which each face translates to its own spelling.
    #[error(transparent)]
    InvalidParameter(#[from] unicac_trace::InvalidParameter),
    /// The ray backend (a GPU) failed; the message is the device's.
    #[error("ray backend {backend}: {message}")]
    Backend { backend: String, message: String },
    /// The lens cannot be handled by the requested method (e.g. a wave PSF of an image-space
    /// telecentric lens).
    #[error("unsupported: {0}")]
    Unsupported(String),
}

pub type PsfResult<T> = std::result::Result<T, PsfError>;
