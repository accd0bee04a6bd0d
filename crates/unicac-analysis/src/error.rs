//! Typed errors of the analyses; the lower crates' errors pass through whole.

use unicac_optics::OpticsError;
use unicac_psf::PsfError;
use unicac_trace::{InvalidParameter, TraceError};

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AnalysisError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    Psf(#[from] PsfError),
    /// A request parameter out of its range, by its library name (`field_deg`, `frequencies_cy_mm`,
    /// `focus_shifts_mm`, ...), which each face translates to its own spelling.
    #[error(transparent)]
    InvalidParameter(#[from] InvalidParameter),
    /// No ray of the field reaches the image surface.
    #[error("no ray of field {field_deg} deg reaches the image surface")]
    FieldVignetted { field_deg: f64 },
    /// The lens cannot be analysed this way (no finite exit pupil, a chief ray that does not arrive).
    #[error("unsupported: {0}")]
    Unsupported(String),
}

pub type AnalysisResult<T> = std::result::Result<T, AnalysisError>;
