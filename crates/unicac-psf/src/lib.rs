//! # unicac-psf
//!
//! Point spread functions of a lens at the sensor: geometric PSFs from traced rays (`geometric`),
//! rasterised into kernels at the pixel pitch (`kernel`), weighted over the spectrum by a camera's
//! sensitivities into R, G, B (`spectrum`).
//!
//! Hand-written: the rasteriser and the spectral weighting are the product's own optics.

pub mod cache;
pub mod error;
pub mod fields;
pub mod geometric;
pub mod hit_tracer;
pub mod kernel;
pub mod spectrum;
pub mod wave;

pub use cache::{cache_root, lens_fingerprint, PsfCache};
pub use error::{PsfError, PsfResult};
pub use fields::{
    weights_for, CachedRun, CommonSizePsfs, DarkFields, FieldPsfRequest, FieldPsfResponse, PsfMetadata,
    PsfMode, PsfReport, Served, TracedField, DEFAULT_PIXEL_UM, DEFAULT_WAVELENGTHS, MIN_WAVE_KERNEL_PX,
};
pub use geometric::{
    check_kernel_cap, check_pixel_um, ChiefReference, FieldHits, FieldPsf, PsfSettings, PsfTracer,
    KERNEL_PX_LIMIT, MAX_PIXEL_UM, MIN_PIXEL_UM,
};
pub use hit_tracer::{CpuHitTracer, HitTracer, RayBackend};
pub use kernel::Kernel;
pub use spectrum::{visible_wavelengths_um, SpectralResponse, SpectralWeights};
pub use wave::{Transform, WaveFieldPsf, WavePsfSettings, WavePsfTracer, WaveSampling, Wavefront};
