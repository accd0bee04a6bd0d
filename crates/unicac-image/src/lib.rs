//! # unicac-image
//!
//! Images for the unicac pipeline:
//! - [`buffer`]: the planar f32 buffer every stage shares ([`Planar`]);
//! - [`io`]: PNG / TIFF / OpenEXR files, atomic writes;
//! - [`color`]: the sRGB transfer curve;
//! - [`quantise`]: unit-range samples <-> integer codes;
//! - [`charts`]: generated, seeded test charts (dead leaves, checkerboard, slanted edge, Siemens star);
//! - [`isp`]: the sensor and ISP chain (white balance, Bayer mosaic, Poisson-Gaussian noise, demosaicing,
//!   gamma, quantisation) and a seeded [`isp::Pipeline`] composing it.
//!
//! All images are linear light unless a function says otherwise. Randomness is always an explicit `u64`
//! seed fed to generators specified bit for bit (ChaCha8 for charts and white-balance draws, the
//! counter-based SplitMix64 draws of `unicac_io` for sensor noise), so the same seed gives the same image
//! on every machine and thread count.
//!
//! ```
//! use unicac_image::{charts, io, isp::Pipeline};
//!
//! let truth = charts::dead_leaves(64, 48, 7)?; // linear RGB in [0, 1]
//! let pipeline = Pipeline::default(); // DeepLens-like 10-bit sensor, Malvar demosaic, sRGB output
//! // The closure is the optics (camera raw in and out); identity here, a PSF convolution in practice.
//! let pair = pipeline.render_pair(&truth, 7, |raw| Ok(raw.clone()))?;
//! let folder = tempfile::tempdir().unwrap();
//! io::write_png(folder.path().join("degraded.png"), &pair.degraded, io::SampleDepth::Eight)?;
//! io::write_png(folder.path().join("target.png"), &pair.target, io::SampleDepth::Eight)?;
//! # Ok::<(), unicac_image::ImageError>(())
//! ```

pub mod buffer;
pub mod charts;
pub mod color;
pub mod error;
pub mod io;
pub mod isp;
pub mod quantise;
pub mod size;

pub use buffer::Planar;
pub use error::{ImageError, Result};

#[cfg(test)]
mod test_support;
