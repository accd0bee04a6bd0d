//! Shared by the slanted-edge tests: an analytic renderer of a Gaussian-blurred slanted edge and the
//! analytic MTF it must give.
//!
//! The test edges are rendered analytically: a straight edge slanted by `angle` from the pixel columns
//! (or rows), blurred by a Gaussian PSF of standard deviation sigma (the edge profile is the normal CDF,
//! i.e. an erf), integrated exactly over each pixel's width and by a 64-point midpoint rule over its height
//! (100% fill-factor square pixels). The expected MTF along the edge normal is then
//! exp(-2 pi^2 sigma^2 f^2) * sinc(f cos angle) * sinc(f sin angle) (Gaussian times the projected pixel
//! aperture; for 5 deg the second sinc differs from 1 by at most 0.3% up to Nyquist).

// Each test binary compiles this module on its own and uses only part of it.
#![allow(dead_code)]

use std::f64::consts::PI;

use unicac_image::Planar;
use unicac_metrics::mtf::pixel_aperture_mtf;
use unicac_metrics::mtf::slanted_edge::{EdgeOrientation, EdgePolarity};
use unicac_metrics::{slanted_edge_mtf, EdgeMtf, Roi, SlantedEdgeOptions};

/// Grey levels on the dark and the bright side of the edge.
pub const LOW: f64 = 0.1;
pub const HIGH: f64 = 0.9;

#[derive(Clone, Copy, Debug)]
pub struct Edge {
    pub sigma_px: f64,
    pub angle_deg: f64,
    pub orientation: EdgeOrientation,
    pub polarity: EdgePolarity,
    /// Where the edge crosses the centre row (near-vertical; centre column when near-horizontal),
    /// across the edge, relative to the region centre, px.
    pub offset_px: f64,
}

impl Edge {
    /// The same edge moved so that it passes through (`size / 2 + d`, `size / 2 + d`) in (across, along)
    /// pixel-edge coordinates, i.e. across by d (1 - tan angle) at the centre row.
    pub fn through_diagonal_point(self, d: f64) -> Edge {
        Edge {
            offset_px: d * (1.0 - self.angle_deg.to_radians().tan()),
            ..self
        }
    }
}

fn normal_cdf(u: f64) -> f64 {
    0.5 * libm::erfc(-u / std::f64::consts::SQRT_2)
}

/// Antiderivative of the normal CDF: u Phi(u) + phi(u).
fn cdf_integral(u: f64) -> f64 {
    u * normal_cdf(u) + (-0.5 * u * u).exp() / (2.0 * PI).sqrt()
}

/// Fraction of bright side in the pixel row segment [x0, x0 + 1] for an edge crossing the row at `e`.
fn bright_fraction(x0: f64, e: f64, cos: f64, sigma: f64) -> f64 {
    if sigma == 0.0 {
        (x0 + 1.0 - e).clamp(0.0, 1.0)
    } else {
        let s = sigma / cos;
        s * (cdf_integral((x0 + 1.0 - e) / s) - cdf_integral((x0 - e) / s))
    }
}

/// A `size` x `size` single-channel image of `edge`: the edge crosses the centre line along it at
/// `size / 2 + edge.offset_px` (in pixel-edge coordinates, pixel i covers [i, i + 1]).
pub fn render(edge: Edge, size: usize) -> Planar {
    const SUB_ROWS: usize = 64;
    let (tan, cos) = (
        edge.angle_deg.to_radians().tan(),
        edge.angle_deg.to_radians().cos(),
    );
    let centre = size as f64 / 2.0;
    // Render a near-vertical edge as (across, along); transpose for near-horizontal edges.
    let value = |across: usize, along: usize| -> f32 {
        let fraction: f64 = (0..SUB_ROWS)
            .map(|k| {
                let y = along as f64 + (k as f64 + 0.5) / SUB_ROWS as f64;
                let e = centre + edge.offset_px + tan * (y - centre);
                bright_fraction(across as f64, e, cos, edge.sigma_px)
            })
            .sum::<f64>()
            / SUB_ROWS as f64;
        let (from, to) = match edge.polarity {
            EdgePolarity::Rising => (LOW, HIGH),
            EdgePolarity::Falling => (HIGH, LOW),
        };
        (from + (to - from) * fraction) as f32
    };
    Planar::from_fn(size, size, 1, |_, x, y| match edge.orientation {
        EdgeOrientation::NearVertical => value(x, y),
        EdgeOrientation::NearHorizontal => value(y, x),
    })
}

/// Gaussian MTF times the pixel aperture projected on the edge normal.
pub fn analytic_mtf(sigma: f64, angle_deg: f64, f: f64) -> f64 {
    (-2.0 * PI * PI * sigma * sigma * f * f).exp() * pixel_aperture_mtf(f, angle_deg.to_radians())
}

/// First 0.5 crossing of the analytic MTF, by bisection on [0, 1] cy/px.
pub fn analytic_mtf50(sigma: f64, angle_deg: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if analytic_mtf(sigma, angle_deg, mid) > 0.5 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The whole of a `size` x `size` image.
pub fn full_roi(size: usize) -> Roi {
    Roi {
        x: 0,
        y: 0,
        width: size,
        height: size,
    }
}

/// Renders `edge` on a `size` x `size` image and measures it over the whole image.
pub fn measure_with(edge: Edge, size: usize, options: &SlantedEdgeOptions) -> EdgeMtf {
    slanted_edge_mtf(&render(edge, size), 0, full_roi(size), options).unwrap()
}

/// Largest |measured - analytic| up to Nyquist.
pub fn max_error_to_nyquist(measured: &EdgeMtf, sigma: f64, angle_deg: f64) -> f64 {
    measured
        .frequency_cy_per_px
        .iter()
        .zip(&measured.mtf)
        .filter(|(f, _)| **f <= 0.5)
        .map(|(&f, &m)| (m - analytic_mtf(sigma, angle_deg, f)).abs())
        .fold(0.0, f64::max)
}

/// Relative error of the measured MTF50 against the analytic one.
pub fn mtf50_error(measured: &EdgeMtf, sigma: f64, angle_deg: f64) -> f64 {
    measured.mtf50_cy_per_px / analytic_mtf50(sigma, angle_deg) - 1.0
}
