//! The one error type of the crate: every variant names the file, flag or field at fault. It holds the
//! memory refusal too (`MemoryExceeded`, re-exported by `memory`), so that no module it wraps imports it back.

use std::path::PathBuf;

use thiserror::Error;

#[derive(Debug, Error)]
#[non_exhaustive]
pub enum BenchError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A model file, its contract or onnxruntime (`unicac-onnx`), kind kept.
    #[error(transparent)]
    Onnx(#[from] unicac_onnx::OnnxError),
    /// LPIPS, FID or ClipIQA (`unicac-learned-metrics`), kind kept.
    #[error(transparent)]
    LearnedMetric(#[from] unicac_learned_metrics::LearnedMetricError),
    /// A dataset folder, manifest or PSF table (`unicac-dataset`), kind kept; its message names the file.
    #[error(transparent)]
    Dataset(#[from] unicac_dataset::DatasetError),
    /// An output path the output policy refuses (the report folder is an input or inside one).
    #[error(transparent)]
    Output(#[from] unicac_io::OutputError),
    /// Something wrong with what was given that no lower error describes (the message names it).
    #[error("{0}")]
    InvalidInput(String),
    /// The run's estimated peak memory exceeds its limit (refused before any work).
    #[error("{0}")]
    MemoryExceeded(MemoryExceeded),
    /// A setting out of its range, named by its library field (`threads`, `wiener_nsr`).
    #[error(transparent)]
    InvalidParameter(#[from] unicac_trace::InvalidParameter),
    #[error("{what}: {source}")]
    Metrics {
        what: String,
        #[source]
        source: unicac_metrics::MetricsError,
    },
    #[error(transparent)]
    Image(#[from] unicac_image::ImageError),
    #[error(transparent)]
    Plot(#[from] unicac_plot::PlotError),
}

pub type Result<T> = std::result::Result<T, BenchError>;

/// Where a run's memory limit came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MemoryLimit {
    /// The `memory_limit_bytes` setting.
    Setting,
    /// What the machine has available now (no setting).
    Available,
}

/// What lowers a run's peak memory, in the order worth trying.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MemoryRemedy {
    /// Run the models on tiles of this side (the `tiling.tile_px` setting).
    TileModels { tile_px: usize },
    /// Leave LPIPS out of the metrics.
    LeaveOutLpips,
    /// Build the dataset with a smaller frame.
    SmallerFrame,
}

/// A run refused before any work because its estimated peak exceeds the limit. Faces say the limit and
/// the remedies in their own words (`describe`); `Display` uses the library's field names.
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryExceeded {
    /// The largest test pair (W, H).
    pub pair_size_px: [usize; 2],
    pub peak_bytes: u64,
    pub limit_bytes: u64,
    pub limit: MemoryLimit,
    pub remedies: Vec<MemoryRemedy>,
}

impl MemoryExceeded {
    /// The refusal as one sentence, the limit's source and each remedy put in the caller's words.
    pub fn describe(
        &self,
        limit: impl Fn(MemoryLimit) -> String,
        remedy: impl Fn(MemoryRemedy) -> String,
    ) -> String {
        let remedies: Vec<String> = self.remedies.iter().map(|&r| remedy(r)).collect();
        format!(
            "the largest test pair ({} x {} px) needs about {:.1} GB to benchmark, more than the {:.1} GB {}: {}",
            self.pair_size_px[0],
            self.pair_size_px[1],
            self.peak_bytes as f64 / 1e9,
            self.limit_bytes as f64 / 1e9,
            limit(self.limit),
            remedies.join(", or ")
        )
    }
}

impl std::fmt::Display for MemoryExceeded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let text = self.describe(
            |limit| match limit {
                MemoryLimit::Setting => "memory_limit_bytes allows".into(),
                MemoryLimit::Available => "available on this machine now".into(),
            },
            |remedy| match remedy {
                MemoryRemedy::TileModels { tile_px } => {
                    format!("run the models on tiles (tile_px {tile_px})")
                }
                MemoryRemedy::LeaveOutLpips => "leave LPIPS out of the metrics".into(),
                MemoryRemedy::SmallerFrame => "build the dataset with a smaller frame".into(),
            },
        );
        f.write_str(&text)
    }
}

impl BenchError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> BenchError {
        BenchError::Io {
            path: path.into(),
            source,
        }
    }

    pub fn metrics(what: impl Into<String>, source: unicac_metrics::MetricsError) -> BenchError {
        BenchError::Metrics {
            what: what.into(),
            source,
        }
    }
}
