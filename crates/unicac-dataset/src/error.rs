//! Errors of the dataset format and builder; each names the file, flag or field at fault.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error(
        "{path}: not a unicac dataset (no dataset.json with \"format\": \"unicac-dataset\"; `unicac dataset build` makes one)"
    )]
    NotADataset { path: PathBuf },
    #[error(
        "{path}: dataset format version {found} is newer than this unicac reads ({supported}); update unicac"
    )]
    NewerFormat {
        path: PathBuf,
        found: u32,
        supported: u32,
    },
    /// Something wrong with what was given that no lower error describes (the message names it).
    #[error("{0}")]
    Invalid(String),
    /// A lens that cannot be read or modelled; `context` names it ("lens LOCATION").
    #[error("{context}: {source}")]
    Optics {
        context: String,
        #[source]
        source: unicac_optics::OpticsError,
    },
    /// A simulation that cannot be prepared or run ("lens SOURCE", "pair ID").
    #[error("{context}: {source}")]
    Simulation {
        context: String,
        #[source]
        source: unicac_sim::SimError,
    },
    /// A lens's ODE or its edge patches ("lens SOURCE: the ODE failed", "lens SOURCE: edge patches").
    #[error("{context}: {source}")]
    Ode {
        context: String,
        #[source]
        source: unicac_ode::OdeError,
    },
    /// An image read, made, written or put through an ISP step ("image PATH", "pair ID"; none when
    /// the image error names its file itself).
    #[error("{}{source}", context_prefix(context))]
    Image {
        context: Option<String>,
        #[source]
        source: unicac_image::ImageError,
    },
    /// A picture that cannot be drawn (`context`: the output file).
    #[error("{context}: {source}")]
    Plot {
        context: String,
        #[source]
        source: unicac_plot::PlotError,
    },
    /// A build setting out of its range; `field` names the `BuildSettings` field (a face maps it to
    /// its own option name).
    #[error("{field}: {message}")]
    Setting { field: String, message: String },
}

pub type Result<T> = std::result::Result<T, DatasetError>;

fn context_prefix(context: &Option<String>) -> String {
    context.as_ref().map_or_else(String::new, |c| format!("{c}: "))
}

impl DatasetError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> DatasetError {
        DatasetError::Io {
            path: path.into(),
            source,
        }
    }

    pub fn setting(field: impl Into<String>, message: impl Into<String>) -> DatasetError {
        DatasetError::Setting {
            field: field.into(),
            message: message.into(),
        }
    }

    pub fn optics(context: impl Into<String>) -> impl FnOnce(unicac_optics::OpticsError) -> DatasetError {
        let context = context.into();
        move |source| DatasetError::Optics { context, source }
    }

    pub fn simulation(context: impl Into<String>) -> impl FnOnce(unicac_sim::SimError) -> DatasetError {
        let context = context.into();
        move |source| DatasetError::Simulation { context, source }
    }

    pub fn ode(context: impl Into<String>) -> impl FnOnce(unicac_ode::OdeError) -> DatasetError {
        let context = context.into();
        move |source| DatasetError::Ode { context, source }
    }

    pub fn image(context: impl Into<String>) -> impl FnOnce(unicac_image::ImageError) -> DatasetError {
        let context = Some(context.into());
        move |source| DatasetError::Image { context, source }
    }

    pub fn format(path: impl Into<PathBuf>, message: impl Into<String>) -> DatasetError {
        DatasetError::Format {
            path: path.into(),
            message: message.into(),
        }
    }
}
