//! # unicac-ode
//!
//! The Optical Degradation Evaluator of the UniCAC paper for one lens: a checkerboard is imaged through
//! the lens at 5 field positions and in 3 colour channels; each (field, channel) gets an OIQ from
//! PSNR, SSIM and the MTF-based OIQE; ODE combines the mean OIQ with the spatial and channel
//! uniformity. The RMS spot radius is reported beside it. Every choice the paper leaves open is
//! written down in docs/ode.md.
//!
//! Only what the scores need is computed: PSFs at the 5 fields (not a PSF map), and a small patch of
//! checkerboard around each field (the PSF is constant across a patch), not a full frame.

pub mod evaluate;
pub mod frame;

pub use evaluate::{
    edge_patches, evaluate, lens_mtf, score_fields, EdgePatch, EvaluationSetup, FieldChannelScore,
    FieldKernels, LensMtf, LensOde, OdeError, OdeReport, OdeScores, OdeSettings, UNIT_AZIMUTHS_DEG,
};
pub use frame::FrameSensor;
