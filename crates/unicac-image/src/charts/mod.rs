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

use crate::Planar;

/// Grey chart from an analytic reflectance `shade(x, y)` in continuous pixel coordinates, averaged over
/// `n x n` sub-samples per pixel and copied to three identical channels.
fn render_grey(width: usize, height: usize, n: usize, shade: impl Fn(f64, f64) -> f64) -> Planar {
    let mut grey = vec![0.0f32; width * height];
    let inverse_n = 1.0 / n as f64;
    for y in 0..height {
        for x in 0..width {
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    sum += shade(
                        x as f64 + (i as f64 + 0.5) * inverse_n,
                        y as f64 + (j as f64 + 0.5) * inverse_n,
                    );
                }
            }
            grey[y * width + x] = (sum * inverse_n * inverse_n) as f32;
        }
    }
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
