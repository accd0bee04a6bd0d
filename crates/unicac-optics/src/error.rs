//! Typed errors of the optics crate. Each variant says who is at fault and where.

use std::path::PathBuf;

/// Everything that can go wrong while reading, validating or analysing a lens.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OpticsError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file could not be parsed; `location` names the line (and column where known).
    #[error("{path}:{location}: {message}")]
    Parse {
        path: PathBuf,
        location: String,
        message: String,
    },
    /// A lens description is well formed but not a valid lens; `field` names the offending key.
    #[error("invalid lens: {field}: {message}")]
    InvalidLens { field: String, message: String },
    #[error("unknown glass '{name}'{}", nearest_names_hint(.nearest))]
    UnknownGlass { name: String, nearest: Vec<String> },
    #[error("glass '{name}': wavelength {wavelength_um} um is outside its data range {min_um}-{max_um} um")]
    WavelengthOutOfRange {
        name: String,
        wavelength_um: f64,
        min_um: f64,
        max_um: f64,
    },
    /// A Zemax feature this reader does not support; never silently dropped.
    #[error("{path}: unsupported Zemax feature(s): {features}")]
    UnsupportedZemax { path: PathBuf, features: String },
    #[error("unsupported lens file extension for {path} (expected .json or .zmx)")]
    UnknownFormat { path: PathBuf },
    /// The paraxial system is degenerate (afocal, stop imaged to infinity, ...).
    #[error("paraxial analysis failed: {0}")]
    Paraxial(String),
}

fn nearest_names_hint(nearest: &[String]) -> String {
    if nearest.is_empty() {
        String::new()
    } else {
        format!("; nearest catalogue names: {}", nearest.join(", "))
    }
}

pub type Result<T, E = OpticsError> = std::result::Result<T, E>;

impl OpticsError {
    pub(crate) fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        OpticsError::InvalidLens {
            field: field.into(),
            message: message.into(),
        }
    }
}
