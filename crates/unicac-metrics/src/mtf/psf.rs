//! The exact MTF of a sampled PSF along a direction, for comparison with slanted-edge measurements.
//!
//! Projecting the PSF onto an axis u gives the line spread function LSF(s) = sum of the PSF samples whose
//! centres project to s = r.u; its Fourier transform is the OTF on the line through the origin along u
//! (projection-slice theorem). The transform is evaluated directly at the requested frequencies, so
//! nothing is binned or interpolated:
//! MTF(f) = |sum_r psf(r) exp(-2 pi i f r.u)| / |sum_r psf(r)|.
//!
//! This is the optics-only MTF; multiply by [`super::pixel_aperture_mtf`] to compare with an edge
//! measured on a sensor with square pixels.

use crate::error::{MetricsError, Result};

/// A sampled PSF: `width` x `height` samples, row-major, spaced `sample_pitch` apart (in pixels when the
/// frequencies are wanted in cy/px, or in any other length unit with frequencies in cycles per unit).
#[derive(Debug, Clone, Copy)]
pub struct PsfSamples<'a> {
    pub data: &'a [f64],
    pub width: usize,
    pub height: usize,
    pub sample_pitch: f64,
}

/// MTF of `psf` along the direction at `direction_rad` from the +x axis (towards +y), at `frequencies`
/// (cycles per unit of `sample_pitch`).
pub fn psf_mtf(psf: PsfSamples<'_>, direction_rad: f64, frequencies: &[f64]) -> Result<Vec<f64>> {
    if psf.data.len() != psf.width * psf.height || psf.data.is_empty() {
        return Err(MetricsError::InvalidInput(format!(
            "PSF has {} samples, expected {} x {}",
            psf.data.len(),
            psf.width,
            psf.height
        )));
    }
    if !(psf.sample_pitch > 0.0) {
        return Err(MetricsError::InvalidInput(
            "PSF sample pitch must be positive".into(),
        ));
    }
    let total: f64 = psf.data.iter().sum();
    if !(total.abs() > 0.0) {
        return Err(MetricsError::InvalidInput("PSF sums to zero".into()));
    }
    let (ux, uy) = (direction_rad.cos(), direction_rad.sin());
    // Project once: sample positions relative to the grid centre (only phases depend on the origin).
    let (cx, cy) = ((psf.width as f64 - 1.0) / 2.0, (psf.height as f64 - 1.0) / 2.0);
    let projected: Vec<(f64, f64)> = psf
        .data
        .iter()
        .enumerate()
        .filter(|(_, &v)| v != 0.0)
        .map(|(i, &v)| {
            let (x, y) = ((i % psf.width) as f64 - cx, (i / psf.width) as f64 - cy);
            ((x * ux + y * uy) * psf.sample_pitch, v)
        })
        .collect();
    Ok(frequencies
        .iter()
        .map(|&f| {
            let (re, im) = projected.iter().fold((0.0, 0.0), |(re, im), &(s, v)| {
                let phase = -2.0 * std::f64::consts::PI * f * s;
                (re + v * phase.cos(), im + v * phase.sin())
            });
            re.hypot(im) / total.abs()
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gaussian_psf(sigma_px: f64, pitch: f64, n: usize) -> Vec<f64> {
        let c = (n as f64 - 1.0) / 2.0;
        (0..n * n)
            .map(|i| {
                let (x, y) = (((i % n) as f64 - c) * pitch, ((i / n) as f64 - c) * pitch);
                (-(x * x + y * y) / (2.0 * sigma_px * sigma_px)).exp()
            })
            .collect()
    }

    #[test]
    fn finely_sampled_gaussian_matches_the_analytic_mtf() {
        // sigma = 1.2 px sampled every 0.1 px over +-10 px: aliasing and truncation are below 1e-9.
        let (sigma, pitch, n) = (1.2, 0.1, 201);
        let data = gaussian_psf(sigma, pitch, n);
        let psf = PsfSamples {
            data: &data,
            width: n,
            height: n,
            sample_pitch: pitch,
        };
        let frequencies: Vec<f64> = (0..=20).map(|i| i as f64 * 0.05).collect();
        for direction in [0.0, 0.3, std::f64::consts::FRAC_PI_2] {
            let mtf = psf_mtf(psf, direction, &frequencies).unwrap();
            for (f, m) in frequencies.iter().zip(&mtf) {
                let expected = (-2.0 * std::f64::consts::PI.powi(2) * sigma * sigma * f * f).exp();
                assert!((m - expected).abs() < 1e-9, "f {f}: {m} vs {expected}");
            }
        }
    }

    #[test]
    fn anisotropic_psf_depends_on_direction() {
        // A 1 x 3 horizontal line of samples: flat MTF along y, cos-shaped along x.
        let data = [1.0, 1.0, 1.0];
        let psf = PsfSamples {
            data: &data,
            width: 3,
            height: 1,
            sample_pitch: 1.0,
        };
        let along_x = psf_mtf(psf, 0.0, &[0.25]).unwrap()[0];
        let along_y = psf_mtf(psf, std::f64::consts::FRAC_PI_2, &[0.25]).unwrap()[0];
        assert!((along_x - 1.0 / 3.0).abs() < 1e-12);
        assert!((along_y - 1.0).abs() < 1e-12);
    }
}
