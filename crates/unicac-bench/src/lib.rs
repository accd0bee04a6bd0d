//! # unicac-bench
//!
//! `unicac bench` and `unicac metrics`: restoration models (ONNX files following docs/models.md) run
//! through onnxruntime on a unicac dataset's test split, scored with the paper's metrics, and reported
//! per benchmark level, per model and per lens (docs/bench.md).
//!
//! The model runtime and the ONNX contract are `unicac-onnx`'s, the learned metrics (LPIPS, FID,
//! ClipIQA) `unicac-learned-metrics`', PSNR/SSIM/OIQE `unicac-metrics`'; this crate plans a run, restores,
//! scores and aggregates:
//! - [`tiling`]: overlapping tiles with seamless blending;
//! - [`wiener`]: the classical PSF-prior baseline (field-varying Wiener deconvolution);
//! - [`op`]: the paper's O.P. score; [`analysis`]: least-squares fits and R^2;
//! - [`report`]: aggregation into `results.json`, CSV, tables and pictures; the report folder's policy;
//! - [`memory`]: the peak memory of a run, estimated and checked before any work;
//! - [`choices`]: the benchmarks, metrics, classical methods and splits a run can be asked for;
//! - [`run`]: `unicac bench` from checks to report ([`edges`]: its slanted-edge patches, batched per
//!   lens; [`inputs`]: the images and maps a model is given); [`compare`]: `unicac metrics`.

pub mod analysis;
pub mod choices;
pub mod compare;
pub mod edges;
pub mod error;
pub mod inputs;
pub mod memory;
mod model_run;
pub mod op;
mod plan;
pub mod report;
pub mod run;
mod scoring;
mod settings;
pub mod tiling;
pub mod wiener;

pub use choices::{Benchmark, ClassicalMethod, Metric, Split};
pub use error::{BenchError, Result};
