//! Generated test charts in linear light, RGB, values in [0, 1], deterministic (seeded where random) and
//! anti-aliased by supersampling: each pixel is the box-filtered mean of `n x n` sub-samples at sub-pixel
//! centres (a pixel-aperture integral, as a sensor pixel with 100 % fill factor would see it).
//!
//! Coordinates are in pixels: pixel (x, y) covers [x, x + 1) x [y, y + 1), origin at the top-left corner,
//! y down. Angles are in degrees.
//!
//! The charts are hand-written: they are the product's own measurement targets, specified by the standards
//! cited on each function, and no maintained crate generates them.

mod dead_leaves;
mod patterns;

pub use dead_leaves::{dead_leaves, DeadLeaves, LeafColours};
pub use patterns::{
    checkerboard, siemens_star, slanted_edge, CHART_HIGH, CHART_LOW, CHART_MEAN, SUPERSAMPLING,
};

use crate::error::{ImageError, Result};
use crate::Planar;
use rayon::prelude::*;

/// Most pixels of a generated chart (2^25, e.g. 8192 x 4096). Peak memory of a chart is about
/// 4 n^2 + 16 bytes per pixel (dead leaves: one u32 label per sub-sample, n = 4 by default, then the
/// f32 RGB image): 2.7 GB at this limit.
pub const MAX_CHART_PIXELS: usize = 1 << 25;

/// An error naming the limit when a chart of `width` x `height` is empty or too large; checked before
/// anything is allocated.
pub fn check_chart_size(width: usize, height: usize) -> Result<()> {
    match width.checked_mul(height) {
        Some(pixels) if pixels > 0 && pixels <= MAX_CHART_PIXELS => Ok(()),
        _ => Err(ImageError::invalid(
            "size",
            format!(
                "{width} x {height} px: a chart needs at least one pixel and at most {MAX_CHART_PIXELS} \
                 (MAX_CHART_PIXELS)"
            ),
        )),
    }
}

/// Grey chart from an analytic reflectance `shade(x, y)` in continuous pixel coordinates, averaged over
/// `n x n` sub-samples per pixel and copied to three identical channels.
fn render_grey(width: usize, height: usize, n: usize, shade: impl Fn(f64, f64) -> f64 + Sync) -> Planar {
    debug_assert!(check_chart_size(width, height).is_ok());
    let mut grey = vec![0.0f32; width * height];
    let inverse_n = 1.0 / n as f64;
    // Rows in parallel: the ODE draws a fresh 508 px edge chart and checkerboard per kernel size.
    grey.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        for (x, value) in row.iter_mut().enumerate() {
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    sum += shade(
                        x as f64 + (i as f64 + 0.5) * inverse_n,
                        y as f64 + (j as f64 + 0.5) * inverse_n,
                    );
                }
            }
            *value = (sum * inverse_n * inverse_n) as f32;
        }
    });
    grey_to_rgb(width, height, grey)
}

fn grey_to_rgb(width: usize, height: usize, grey: Vec<f32>) -> Planar {
    let mut data = Vec::with_capacity(grey.len() * 3);
    for _ in 0..3 {
        data.extend_from_slice(&grey);
    }
    Planar {
        width,
        height,
        channels: 3,
        data,
    }
}
