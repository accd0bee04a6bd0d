//! Typed errors of the simulator.

use unicac_image::ImageError;
use unicac_optics::OpticsError;
use unicac_psf::PsfError;
use unicac_trace::TraceError;

#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    Psf(#[from] PsfError),
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error("invalid simulation request: {0}")]
    InvalidRequest(String),
}

pub type SimResult<T> = std::result::Result<T, SimError>;
