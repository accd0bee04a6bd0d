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
    #[error(
        "the lens vignettes the whole field: none of the {rays_traced} rays traced from 0 to {max_field_deg:.2} deg \
         reached the sensor (check the clear semi-diameters)"
    )]
    FullyVignetted { max_field_deg: f64, rays_traced: usize },
    #[error("invalid simulation request: {0}")]
    InvalidRequest(String),
}

pub type SimResult<T> = std::result::Result<T, SimError>;
