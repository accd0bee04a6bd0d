//! # unicac-metrics
//!
//! The metrics behind unicac's Optical Degradation Evaluator (UniCAC paper, Sec. 3.3):
//!
//! - [`mod@psnr`] and [`mod@ssim`]: full-reference fidelity with the BasicSR conventions ([0, 255] scale,
//!   Gaussian 11x11 / 1.5 SSIM window, 'valid' filtering, per-channel mean);
//! - [`mtf`]: ISO 12233 slanted-edge MTF, the exact MTF of a sampled PSF, MTF50 and the normalised MTF area;
//! - [`mod@oiqe`]: the MTF-based OIQE score in [0, 1] (unicac's definition; the paper publishes none);
//! - [`mod@ode`]: the paper's OIQ, uniformity and ODE formulas with the published weights;
//! - [`mod@pyiqa`]: PSNR and SSIM with pyiqa's defaults (the paper's evaluation of restored images;
//!   `unicac bench` and `unicac metrics` report these).
//!
//! Images are `unicac_image::Planar`; the full-reference metrics take samples in [0, 1] (or in [0, 255]
//! with [`ValueRange::Byte`]). Everything is computed in f64. The definitions and their sources are
//! collected in `docs/ode.md`.

// `!(x > 0.0)` and friends are deliberate: they reject NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod error;
mod input;
pub mod mtf;
pub mod ode;
pub mod oiqe;
pub mod psnr;
pub mod pyiqa;
pub mod ssim;

pub use error::{MetricsError, Result};
pub use input::ValueRange;
pub use mtf::psf::{psf_mtf, PsfSamples};
pub use mtf::slanted_edge::{slanted_edge_mtf, EdgeMtf, Roi, SlantedEdgeOptions};
pub use mtf::{summarize, MtfSummary};
pub use ode::{ode, ode_from_oiq_grid, oiq, uniformity, OdeBreakdown, OdeWeights};
pub use oiqe::{oiqe, OiqeWeights};
pub use psnr::{psnr, FullReferenceOptions, Psnr, PSNR_CAP_DB};
pub use pyiqa::{psnr_pyiqa, ssim_pyiqa, PYIQA_PSNR_CAP_DB};
pub use ssim::{ssim, Ssim};
