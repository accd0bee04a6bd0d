//! The one error type of the crate.

use thiserror::Error;

/// Why a metric could not be computed.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MetricsError {
    #[error("image shapes differ: {a:?} vs {b:?} (width, height, channels)")]
    ShapeMismatch {
        a: (usize, usize, usize),
        b: (usize, usize, usize),
    },
    #[error("image of {width}x{height} is too small: {what}")]
    TooSmall {
        width: usize,
        height: usize,
        what: String,
    },
    #[error("channel {channel} does not exist (image has {channels})")]
    NoSuchChannel { channel: usize, channels: usize },
    #[error("region {x},{y} {width}x{height} does not fit in the {image_width}x{image_height} image")]
    RegionOutside {
        x: usize,
        y: usize,
        width: usize,
        height: usize,
        image_width: usize,
        image_height: usize,
    },
    /// A pixel is NaN or infinite: no measurement can be trusted; names the first such pixel.
    #[error("pixel (x {x}, y {y}) of channel {channel} is {value}: the image holds non-finite values")]
    NonFinitePixel {
        x: usize,
        y: usize,
        channel: usize,
        value: f32,
    },
    #[error("no usable edge: {0}")]
    NoEdge(String),
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

pub type Result<T> = std::result::Result<T, MetricsError>;
