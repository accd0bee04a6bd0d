//! What `unicac bench` is asked to do (`BenchSettings`), with the limits its checks hold it to.

use std::path::PathBuf;

use crate::choices::{Benchmark, ClassicalMethod, Metric, Split};
use crate::tiling::Tiling;
use unicac_onnx::ort_library::Search;

/// Largest `threads`.
pub const MAX_THREADS: usize = 256;
/// Largest `wiener_nsr`: far past any useful noise-to-signal ratio (the restoration tends to zero).
pub const MAX_WIENER_NSR: f64 = 100.0;

/// What `unicac bench` was asked to do.
#[derive(Debug, Clone)]
pub struct BenchSettings {
    pub dataset: PathBuf,
    /// `NAME=MODEL.onnx` models.
    pub models: Vec<(String, PathBuf)>,
    /// Classical methods besides the always-present `identity`.
    pub methods: Vec<ClassicalMethod>,
    pub out: PathBuf,
    pub split: Split,
    pub benchmarks: Vec<Benchmark>,
    /// Metrics asked for explicitly (`None`: all, unavailable ones reported as null).
    pub metrics: Option<Vec<Metric>>,
    pub weights_dir: Option<PathBuf>,
    /// The cache holding `weights/lpips` (None: no LPIPS).
    pub cache_root: Option<PathBuf>,
    pub tiling: Tiling,
    pub threads: usize,
    pub save_images: bool,
    pub wiener_nsr: f64,
    /// Refuse a run whose estimated peak memory exceeds this (`None`: the memory available now).
    pub memory_limit_bytes: Option<u64>,
    /// Where onnxruntime is looked for.
    pub onnxruntime: Search,
}
