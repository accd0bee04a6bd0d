//! # unicac-analysis
//!
//! The standard lens analyses of an optical-design program, from the tracer and the wave PSF's
//! wavefront: polychromatic MTF against frequency (`mtf`: diffraction from the pupil function's
//! autocorrelation, or geometric from the spot) with the diffraction limit, and against field;
//! through-focus MTF and RMS spot (`focus`); field curvature and distortion (`field_curves`);
//! relative illumination (`illumination`); geometric encircled energy (`encircled`). Conventions in
//! docs/analysis.md; every analysis is checked against optiland in `tests/references.rs`.
//!
//! Every analysis takes the lens, a `Spectrum` (wavelengths and weights) and the field angles, checks
//! them (`setup`: fields within the lens's largest field, counts within stated limits) before any work,
//! and returns a serialisable report that both faces print as is.

pub mod encircled;
pub mod error;
pub mod field_curves;
pub mod focus;
pub mod illumination;
pub mod mtf;
mod pupil;
pub mod setup;

pub use encircled::{encircled_energy, EncircledEnergy, FieldEncircledEnergy};
pub use error::{AnalysisError, AnalysisResult};
pub use field_curves::{distortion, field_curves, FieldCurves, FocusCurves};
pub use focus::{polychromatic_rms_um, refocused, through_focus, FieldThroughFocus, ThroughFocusReport};
pub use illumination::{relative_illumination, RelativeIllumination};
pub use mtf::{
    mtf, mtf_vs_field, Cutoff, Directions, FieldMtf, MtfAtFrequency, MtfMethod, MtfReport, MtfSettings,
    MtfTracer, MtfVsField,
};
pub use setup::{check_fields, linspace, Spectrum, DEFAULT_PUPIL_GRID, MAX_PUPIL_GRID};
