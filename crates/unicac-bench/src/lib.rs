//! # unicac-bench
//!
//! `unicac bench` and `unicac metrics`: restoration models (ONNX files following docs/models.md) run
//! through onnxruntime on a unicac dataset's test split, scored with the paper's metrics, and reported
//! per benchmark level, per model and per lens (docs/bench.md).
//!
//! - [`contract`]: the model contract, checked on the ONNX graph before any work;
//! - [`runtime`]: onnxruntime loaded from the PyPI wheel's library, sessions; [`ort_library`]: where
//!   that library is (`ORT_DYLIB_PATH`, else a Python's `onnxruntime` package);
//! - [`tiling`]: overlapping tiles with seamless blending;
//! - [`wiener`]: the classical PSF-prior baseline (field-varying Wiener deconvolution);
//! - [`lpips`], [`fid`], [`clipiqa`]: the learned metrics; PSNR/SSIM are `unicac_metrics::pyiqa`;
//! - [`op`]: the paper's O.P. score; [`analysis`]: least-squares fits and R^2;
//! - [`cost`]: parameters, FLOPs and latency from the graph;
//! - [`report`]: aggregation into `results.json`, CSV, tables and pictures; the report folder's policy;
//! - [`memory`]: the peak memory of a run, estimated and checked before any work;
//! - [`choices`]: the benchmarks, metrics, classical methods and splits a run can be asked for;
//! - [`run`]: `unicac bench` from checks to report ([`edges`]: its slanted-edge patches, batched per
//!   lens; [`inputs`]: the images and maps a model is given); [`compare`]: `unicac metrics`.
//!
//! ONNX files are read and written with the crate's own `prost` declarations of the ONNX messages
//! ([`onnx`]): one small, well-kept dependency gives exact control over the graphs we build (the LPIPS
//! network from its converted weights, the tiny models of the tests) and lets the contract check and the
//! cost analysis read any model without a second ML runtime.

pub mod analysis;
#[macro_use]
pub mod choices;
pub mod clipiqa;
pub mod compare;
pub mod contract;
pub mod cost;
pub mod edges;
pub mod error;
pub mod fid;
pub mod inputs;
pub mod lpips;
pub mod memory;
mod model_run;
pub mod npz;
pub mod onnx;
pub mod op;
pub mod ort_library;
pub mod report;
pub mod run;
pub mod runtime;
mod scoring;
pub mod tiling;
pub mod wiener;

pub use choices::{Benchmark, ClassicalMethod, Metric, Split};
pub use error::{BenchError, Result};
