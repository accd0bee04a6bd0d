//! Shared input handling for the full-reference metrics (PSNR, SSIM): shape checks and the value range.

use serde::{Deserialize, Serialize};
use unicac_image::Planar;

use crate::error::{MetricsError, Result};

/// The range the samples of a `Planar` are in. BasicSR computes PSNR/SSIM on [0, 255] values, so samples
/// in [0, 1] are multiplied by 255 (in f64) before any arithmetic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ValueRange {
    /// Samples in [0, 1] (the pipeline's convention); scaled by 255.
    #[default]
    Unit,
    /// Samples already in [0, 255] (e.g. 8-bit values stored as f32); used as they are.
    Byte,
}

impl ValueRange {
    /// The factor that brings a sample to the [0, 255] scale.
    pub fn to_255(self) -> f64 {
        match self {
            ValueRange::Unit => 255.0,
            ValueRange::Byte => 1.0,
        }
    }
}

pub(crate) fn shape(image: &Planar) -> (usize, usize, usize) {
    (image.width, image.height, image.channels)
}

pub(crate) fn check_same_shape(a: &Planar, b: &Planar) -> Result<()> {
    if shape(a) != shape(b) {
        return Err(MetricsError::ShapeMismatch {
            a: shape(a),
            b: shape(b),
        });
    }
    if a.channels == 0 {
        return Err(MetricsError::InvalidInput("image has no channels".into()));
    }
    Ok(())
}

/// Plane `channel` of `image`, cropped by `border` pixels on every side, on the [0, 255] scale, in f64;
/// returned with its width and height.
pub(crate) fn plane_255(
    image: &Planar,
    channel: usize,
    border: usize,
    range: ValueRange,
) -> (Vec<f64>, usize, usize) {
    let (w, h) = (image.width - 2 * border, image.height - 2 * border);
    let scale = range.to_255();
    let plane = image.plane(channel);
    let mut out = Vec::with_capacity(w * h);
    for y in border..border + h {
        let row = &plane[y * image.width + border..y * image.width + border + w];
        out.extend(row.iter().map(|&v| v as f64 * scale));
    }
    (out, w, h)
}

/// The first NaN or infinite sample of `channel` inside the rectangle (x, y, width, height), as an
/// error naming its position (callers add the file name).
pub(crate) fn check_finite_region(
    image: &Planar,
    channel: usize,
    [x0, y0, width, height]: [usize; 4],
) -> Result<()> {
    if channel >= image.channels {
        return Ok(()); // the caller's own checks name a missing channel
    }
    for y in y0..(y0 + height).min(image.height) {
        for x in x0..(x0 + width).min(image.width) {
            let value = image.get(channel, x, y);
            if !value.is_finite() {
                return Err(MetricsError::NonFinitePixel { x, y, channel, value });
            }
        }
    }
    Ok(())
}
