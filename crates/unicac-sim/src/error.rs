//! Typed errors of the simulator.

use unicac_image::ImageError;
use unicac_optics::OpticsError;
use unicac_psf::PsfError;
use unicac_trace::TraceError;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    Psf(#[from] PsfError),
    #[error(transparent)]
    Image(#[from] ImageError),
    /// A request parameter out of its range (`image_px`, `pixel_um`, `window`, `image`).
    #[error(transparent)]
    InvalidParameter(#[from] unicac_trace::InvalidParameter),
    /// The lens cannot be simulated (no off-axis field, a chief ray that cannot be mapped).
    #[error("unsupported lens: {0}")]
    Unsupported(String),
}

pub type SimResult<T> = std::result::Result<T, SimError>;
