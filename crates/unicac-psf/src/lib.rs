//! # unicac-psf
//!
//! Point spread functions of a lens at the sensor: geometric PSFs from traced rays (`geometric`),
//! rasterised into kernels at the pixel pitch (`kernel`), weighted over the spectrum by a camera's
//! sensitivities into R, G, B (`spectrum`).
//!
//! Hand-written: the rasteriser and the spectral weighting are the product's own optics.

pub mod error;
pub mod geometric;
pub mod hit_tracer;
pub mod kernel;
pub mod spectrum;
pub mod wave;

pub use error::{PsfError, PsfResult};
pub use geometric::{
    check_kernel_cap, ChiefReference, FieldHits, FieldPsf, PsfSettings, PsfTracer, KERNEL_PX_LIMIT,
};
pub use hit_tracer::{default_hit_tracer, set_default_hit_tracer, CpuHitTracer, HitTracer};
pub use kernel::Kernel;
pub use spectrum::{visible_wavelengths_um, SpectralResponse, SpectralWeights};
pub use wave::{Transform, WaveFieldPsf, WavePsfSettings, WavePsfTracer, WaveSampling, Wavefront};
