//! Slanted-edge MTF against analytic results.
//!
//! The test edges are rendered analytically: a straight edge slanted by `angle` from the pixel columns
//! (or rows), blurred by a Gaussian PSF of standard deviation sigma (the edge profile is the normal CDF,
//! i.e. an erf), integrated exactly over each pixel's width and by a 64-point midpoint rule over its height
//! (100% fill-factor square pixels). The expected MTF along the edge normal is then
//! exp(-2 pi^2 sigma^2 f^2) * sinc(f cos angle) * sinc(f sin angle) (Gaussian times the projected pixel
//! aperture; for 5 deg the second sinc differs from 1 by at most 0.3% up to Nyquist).

use std::f64::consts::PI;

use unicac_image::Planar;
use unicac_metrics::mtf::slanted_edge::{EdgeOrientation, EdgePolarity};
use unicac_metrics::mtf::{pixel_aperture_mtf, Mtf50Kind};
use unicac_metrics::{
    oiqe, psf_mtf, slanted_edge_mtf, EdgeMtf, OiqeWeights, PsfSamples, Roi, SlantedEdgeOptions,
};

const LOW: f64 = 0.1;
const HIGH: f64 = 0.9;

#[derive(Clone, Copy)]
struct Edge {
    sigma_px: f64,
    angle_deg: f64,
    orientation: EdgeOrientation,
    polarity: EdgePolarity,
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

/// A `size` x `size` single-channel image of `edge` through the image centre (plus a sub-pixel offset).
fn render(edge: Edge, size: usize) -> Planar {
    const SUB_ROWS: usize = 64;
    let (tan, cos) = (
        edge.angle_deg.to_radians().tan(),
        edge.angle_deg.to_radians().cos(),
    );
    let centre = size as f64 / 2.0 + 0.3;
    // Render a near-vertical edge as (across, along); transpose for near-horizontal edges.
    let value = |across: usize, along: usize| -> f32 {
        let fraction: f64 = (0..SUB_ROWS)
            .map(|k| {
                let y = along as f64 + (k as f64 + 0.5) / SUB_ROWS as f64;
                bright_fraction(across as f64, centre + tan * (y - centre), cos, edge.sigma_px)
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

fn analytic_mtf(sigma: f64, angle_deg: f64, f: f64) -> f64 {
    (-2.0 * PI * PI * sigma * sigma * f * f).exp() * pixel_aperture_mtf(f, angle_deg.to_radians())
}

/// First 0.5 crossing of the analytic MTF, by bisection on [0, 1] cy/px.
fn analytic_mtf50(sigma: f64, angle_deg: f64) -> f64 {
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

fn measure(edge: Edge, size: usize) -> EdgeMtf {
    let image = render(edge, size);
    let roi = Roi {
        x: 0,
        y: 0,
        width: size,
        height: size,
    };
    slanted_edge_mtf(&image, 0, roi, &SlantedEdgeOptions::default()).unwrap()
}

/// Largest |measured - analytic| up to Nyquist.
fn max_error_to_nyquist(measured: &EdgeMtf, sigma: f64, angle_deg: f64) -> f64 {
    measured
        .frequency_cy_per_px
        .iter()
        .zip(&measured.mtf)
        .filter(|(f, _)| **f <= 0.5)
        .map(|(&f, &m)| (m - analytic_mtf(sigma, angle_deg, f)).abs())
        .fold(0.0, f64::max)
}

fn all_edges(sigma_px: f64) -> Vec<Edge> {
    let mut edges = Vec::new();
    for orientation in [EdgeOrientation::NearVertical, EdgeOrientation::NearHorizontal] {
        for polarity in [EdgePolarity::Rising, EdgePolarity::Falling] {
            edges.push(Edge {
                sigma_px,
                angle_deg: 5.0,
                orientation,
                polarity,
            });
        }
    }
    edges
}

/// Maximum |measured - analytic| MTF up to Nyquist that the tests accept (the brief asks for 0.02).
const MAX_MTF_ERROR: f64 = 0.01;
/// Maximum relative MTF50 error accepted (the brief asks for 2%).
const MAX_MTF50_ERROR: f64 = 0.01;
/// Region side: large enough that the Hamming window's bias stays below 0.3% at sigma = 2 px.
const SIZE: usize = 128;

/// Checks one edge against the analytic MTF; returns (max MTF error, relative MTF50 error).
fn check(edge: Edge, options: &SlantedEdgeOptions) -> (f64, f64) {
    let image = render(edge, SIZE);
    let roi = Roi {
        x: 0,
        y: 0,
        width: SIZE,
        height: SIZE,
    };
    let m = slanted_edge_mtf(&image, 0, roi, options).unwrap();
    assert_eq!(m.edge.orientation, edge.orientation);
    assert_eq!(m.edge.polarity, edge.polarity);
    // Transposing mirrors the slant, so compare magnitudes.
    assert!(
        (m.edge.angle_deg.abs() - edge.angle_deg.abs()).abs() < 0.02,
        "angle {}",
        m.edge.angle_deg
    );
    assert!((m.frequency_cy_per_px.last().unwrap() - 1.0).abs() < 0.01);
    let error = max_error_to_nyquist(&m, edge.sigma_px, edge.angle_deg);
    let mtf50 = m.mtf50_cy_per_px / analytic_mtf50(edge.sigma_px, edge.angle_deg) - 1.0;
    (error, mtf50)
}

fn check_all(edges: &[Edge], options: &SlantedEdgeOptions, max_error: f64, max_mtf50: f64) {
    for &edge in edges {
        let (error, mtf50) = check(edge, options);
        println!(
            "sigma {:.1} angle {:+.0} {:?} {:?}: max MTF error {error:.4}, MTF50 error {:+.3}%",
            edge.sigma_px,
            edge.angle_deg,
            edge.orientation,
            edge.polarity,
            100.0 * mtf50
        );
        assert!(error < max_error, "MTF error {error}");
        assert!(mtf50.abs() < max_mtf50, "MTF50 error {mtf50}");
    }
}

#[test]
fn blurred_edges_match_gaussian_times_pixel_aperture() {
    let edges: Vec<Edge> = [0.8, 1.2, 2.0].into_iter().flat_map(all_edges).collect();
    check_all(
        &edges,
        &SlantedEdgeOptions::default(),
        MAX_MTF_ERROR,
        MAX_MTF50_ERROR,
    );
}

#[test]
fn perfect_edge_gives_the_pixel_sinc() {
    // No blur: MTF = pixel aperture only; MTF50 (0.604 cy/px) lies above Nyquist and is flagged.
    check_all(
        &all_edges(0.0),
        &SlantedEdgeOptions::default(),
        MAX_MTF_ERROR,
        MAX_MTF50_ERROR,
    );
    let m = measure(all_edges(0.0)[0], SIZE);
    assert_eq!(m.mtf50_kind, Mtf50Kind::AboveNyquist);
}

#[test]
fn other_slant_angles_work() {
    let edges: Vec<Edge> = [-4.0, 8.0]
        .into_iter()
        .map(|angle_deg| Edge {
            angle_deg,
            ..all_edges(1.2)[3]
        })
        .chain([Edge {
            angle_deg: -3.0,
            ..all_edges(0.8)[0]
        }])
        .collect();
    check_all(
        &edges,
        &SlantedEdgeOptions::default(),
        MAX_MTF_ERROR,
        MAX_MTF50_ERROR,
    );
}

#[test]
fn plain_iso_processing_is_within_the_brief() {
    // Without the bin-averaging correction (strict ISO 12233) the MTF is low by up to sinc(f / 4):
    // about 0.02 at Nyquist for an unblurred edge, much less once the edge is blurred.
    let iso = SlantedEdgeOptions {
        correct_bin_averaging: false,
        ..SlantedEdgeOptions::default()
    };
    let edges: Vec<Edge> = [0.8, 1.2, 2.0].into_iter().flat_map(all_edges).collect();
    check_all(&edges, &iso, 0.02, 0.02);
}

#[test]
fn edge_measurement_matches_the_exact_psf_route() {
    // The same Gaussian as a sampled PSF (0.05 px pitch) through `psf_mtf`, times the pixel aperture.
    let (sigma, angle_deg) = (1.2, 5.0);
    let m = measure(
        Edge {
            sigma_px: sigma,
            angle_deg,
            ..all_edges(0.0)[0]
        },
        SIZE,
    );
    let (n, pitch) = (241, 0.05);
    let c = (n as f64 - 1.0) / 2.0;
    let data: Vec<f64> = (0..n * n)
        .map(|i| {
            let (x, y) = (((i % n) as f64 - c) * pitch, ((i / n) as f64 - c) * pitch);
            (-(x * x + y * y) / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let psf = PsfSamples {
        data: &data,
        width: n,
        height: n,
        sample_pitch: pitch,
    };
    let normal = -angle_deg.to_radians(); // any direction: the Gaussian is isotropic
    let exact = psf_mtf(psf, normal, &m.frequency_cy_per_px).unwrap();
    let error = m
        .frequency_cy_per_px
        .iter()
        .zip(m.mtf.iter().zip(&exact))
        .filter(|(f, _)| **f <= 0.5)
        .map(|(f, (measured, optics))| {
            (measured - optics * pixel_aperture_mtf(*f, angle_deg.to_radians())).abs()
        })
        .fold(0.0, f64::max);
    println!("edge vs exact PSF route: max error {error:.4}");
    assert!(error < MAX_MTF_ERROR);
}

#[test]
fn oiqe_rises_as_blur_falls_and_stays_in_unit_range() {
    let weights = OiqeWeights::default();
    let scores: Vec<f64> = [2.0, 1.2, 0.8, 0.4, 0.0]
        .into_iter()
        .map(|sigma| {
            let edges = all_edges(sigma);
            let tangential = measure(edges[0], SIZE).summary();
            let sagittal = measure(edges[2], SIZE).summary();
            oiqe(&tangential, &sagittal, &weights).unwrap()
        })
        .collect();
    println!("OIQE for sigma 2.0, 1.2, 0.8, 0.4, 0.0: {scores:.4?}");
    assert!(scores.iter().all(|q| (0.0..=1.0).contains(q)));
    assert!(scores.windows(2).all(|p| p[1] > p[0]), "{scores:?}");
}
