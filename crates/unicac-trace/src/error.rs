//! Typed errors of the trace crate. Per-ray failures are not errors (see `RayStatus`); these are
//! failures of a whole request.

use unicac_optics::OpticsError;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TraceError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    /// Real aiming found no ray through the requested stop point.
    #[error("real ray aiming failed for field {field_deg} deg, pupil ({px}, {py}): {reason}")]
    AimFailed {
        field_deg: f64,
        px: f64,
        py: f64,
        reason: String,
    },
    /// A request parameter out of its range (named in the library's words).
    #[error(transparent)]
    InvalidParameter(#[from] crate::InvalidParameter),
}

pub type TraceResult<T> = std::result::Result<T, TraceError>;
