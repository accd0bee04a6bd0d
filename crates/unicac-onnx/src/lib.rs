//! # unicac-onnx
//!
//! Restoration models and metric networks as ONNX files, run through onnxruntime: what `unicac bench`
//! and the learned metrics share.
//!
//! - [`contract`]: the restoration-model contract of docs/models.md, checked on the ONNX graph before
//!   any work;
//! - [`runtime`]: onnxruntime loaded from the PyPI wheel's library, sessions and tensors;
//!   [`ort_library`]: where that library is (`ORT_DYLIB_PATH`, else a Python's `onnxruntime` package);
//! - [`cost`]: parameters, FLOPs and latency from the graph;
//! - [`proto`], [`builder`]: the ONNX messages and a small graph builder.
//!
//! ONNX files are read and written with the crate's own `prost` declarations of the ONNX messages
//! ([`proto`]): one small, well-kept dependency gives exact control over the graphs we build (the LPIPS
//! network from its converted weights, the tiny models of the tests) and lets the contract check and the
//! cost analysis read any model without a second ML runtime.

pub mod builder;
pub mod contract;
pub mod cost;
pub mod error;
pub mod ort_library;
pub mod proto;
pub mod runtime;

pub use error::{OnnxError, Result};
