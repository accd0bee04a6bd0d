//! Typed errors of the image crate. Each variant says who is at fault and where: a file (`path`) or a
//! parameter (`field`).

use std::path::PathBuf;

/// Everything that can go wrong while reading, writing, generating or processing an image.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// The operating system refused a read, write or rename.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file exists but holds no bytes.
    #[error("{path}: file is empty")]
    EmptyFile { path: PathBuf },
    /// The file's first bytes match none of the supported formats (PNG, TIFF, OpenEXR).
    #[error("{path}: not a PNG, TIFF or OpenEXR file")]
    UnknownFormat { path: PathBuf },
    /// The file claims a supported format but its content is broken or uses an unsupported variant.
    #[error("{path}: cannot decode {format}: {message}")]
    Decode {
        path: PathBuf,
        format: &'static str,
        message: String,
    },
    /// The image cannot be stored in the requested format (channel count, non-finite values, codec error).
    #[error("{path}: cannot write {format}: {message}")]
    Encode {
        path: PathBuf,
        format: &'static str,
        message: String,
    },
    /// A function argument is outside its documented range; `field` names it.
    #[error("invalid {field}: {message}")]
    InvalidParameter { field: &'static str, message: String },
}

pub type Result<T, E = ImageError> = std::result::Result<T, E>;

impl ImageError {
    pub(crate) fn invalid(field: &'static str, message: impl Into<String>) -> Self {
        ImageError::InvalidParameter {
            field,
            message: message.into(),
        }
    }
}

/// Checks that `image.data` holds exactly `channels * height * width` samples (the fields are public, so a
/// caller can break the invariant) and that it has one of the `allowed` channel counts (empty: any).
pub(crate) fn check_layout(
    image: &crate::Planar,
    field: &'static str,
    allowed_channels: &[usize],
) -> Result<()> {
    let expected = image.width * image.height * image.channels;
    if image.data.len() != expected {
        return Err(ImageError::invalid(
            field,
            format!(
                "{} samples for {}x{}x{} (width x height x channels)",
                image.data.len(),
                image.width,
                image.height,
                image.channels
            ),
        ));
    }
    if !allowed_channels.is_empty() && !allowed_channels.contains(&image.channels) {
        return Err(ImageError::invalid(
            field,
            format!(
                "{} channels, expected one of {allowed_channels:?}",
                image.channels
            ),
        ));
    }
    Ok(())
}
