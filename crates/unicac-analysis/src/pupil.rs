//! One field at one wavelength, sampled on the N x N pupil grid: which cells pass light, the
//! wavefront (diffraction) or the image points (geometric), and the frequency scale of a pupil shift.
//!
//! The grid is the wave PSF's: cell centres (px, py) = -1 + (i + 1/2) 2/N, kept inside the unit disc,
//! traced with `Aiming::Auto` (`unicac_psf::wave`, items 1-2), so the wavefront is the one the wave
//! PSF is made from.

use crate::error::AnalysisResult;
use rustfft::num_complex::Complex64;
use unicac_optics::Lens;
use unicac_psf::Wavefront;
use unicac_trace::{trace_rays, Aimer, Aiming, Clipping, Ray, TraceSystem};

/// Cell-centre coordinate of grid index `i` of `n` (as `unicac_psf::wave`).
pub(crate) fn coordinate(i: usize, n: usize) -> f64 {
    -1.0 + (i as f64 + 0.5) * 2.0 / n as f64
}

/// Cells of the n x n grid inside the unit disc.
pub(crate) fn disc_cells(n: usize) -> usize {
    (0..n * n)
        .filter(|k| {
            let (x, y) = (coordinate(k % n, n), coordinate(k / n, n));
            x * x + y * y <= 1.0
        })
        .count()
}

/// Prepared systems of one wavelength: clipped for the pupil rays, unclipped for the calibration rays.
pub(crate) struct Channel {
    pub wavelength_um: f64,
    pub clipped: TraceSystem,
    pub unclipped: TraceSystem,
    pub aimer: Aimer,
}

impl Channel {
    pub fn new(lens: &Lens, wavelength_um: f64) -> AnalysisResult<Channel> {
        Ok(Channel {
            wavelength_um,
            clipped: TraceSystem::new(lens, wavelength_um, Clipping::Apertures)?,
            unclipped: TraceSystem::new(lens, wavelength_um, Clipping::None)?,
            aimer: Aimer::new(lens, wavelength_um, Aiming::Auto)?,
        })
    }

    /// Refractive index of image space.
    pub fn image_index(&self) -> f64 {
        let last = self.clipped.image_index();
        match last {
            0 => self.clipped.object_index,
            _ => self.clipped.surfaces[last - 1].index_after,
        }
    }

    /// Spatial frequency (cycles/mm on the image surface) of one grid step of pupil shift,
    /// [tangential (pupil y), sagittal (pupil x)]. Calibrated on real rays, as optiland's FFT MTF
    /// does: the direction difference of the two marginal rays (pupil +-1) projected on the plane
    /// tangent to the image surface at the chief ray, times n' / lambda, is the frequency of a shift
    /// across the whole pupil (2 in normalised units, N grid steps). An oblique beam so gets its
    /// foreshortened tangential bandwidth. `None` when a calibration ray fails.
    pub fn step_cy_mm(&self, lens: &Lens, field_deg: f64, grid: usize) -> Option<[f64; 2]> {
        let trace = |px: f64, py: f64| -> Option<Ray> {
            let mut ray = self.aimer.ray(field_deg, px, py).ok()?;
            self.unclipped.trace(&mut ray).is_ok().then_some(ray)
        };
        let chief = trace(0.0, 0.0)?;
        let image = lens.surfaces.last()?.profile;
        let (x, y) = (chief.position_mm[0], chief.position_mm[1]);
        let (_, slope) = image.sag_and_slope(x * x + y * y);
        let normal = normalise([-2.0 * x * slope, -2.0 * y * slope, 1.0]);
        let lambda_mm = self.wavelength_um * 1e-3;
        let n_image = self.image_index().abs();
        let band = |a: Ray, b: Ray| {
            let d = [0, 1, 2].map(|k| a.direction[k] - b.direction[k]);
            let along = dot(d, normal);
            let projected = [0, 1, 2].map(|k| d[k] - along * normal[k]);
            n_image * dot(projected, projected).sqrt() / (grid as f64 * lambda_mm)
        };
        let tangential = band(trace(0.0, 1.0)?, trace(0.0, -1.0)?);
        let sagittal = band(trace(1.0, 0.0)?, trace(-1.0, 0.0)?);
        (tangential > 0.0 && sagittal > 0.0 && tangential.is_finite() && sagittal.is_finite())
            .then_some([tangential, sagittal])
    }

    /// Image points of the grid's rays that arrive, and the grid's amplitude (1 where a ray inside the
    /// disc arrived), row-major `[iy * n + ix]`.
    pub fn grid_rays(&self, field_deg: f64, n: usize) -> (Vec<[f64; 2]>, Vec<f64>) {
        let mut cells = Vec::new();
        let mut rays = Vec::new();
        for iy in 0..n {
            let py = coordinate(iy, n);
            for ix in 0..n {
                let px = coordinate(ix, n);
                if px * px + py * py > 1.0 {
                    continue;
                }
                if let Ok(ray) = self.aimer.ray(field_deg, px, py) {
                    cells.push(iy * n + ix);
                    rays.push(ray);
                }
            }
        }
        let statuses = trace_rays(&self.clipped, &mut rays);
        let mut amplitude = vec![0.0; n * n];
        let mut points = Vec::with_capacity(rays.len());
        for ((ray, status), cell) in rays.iter().zip(&statuses).zip(cells) {
            if status.is_ok() {
                amplitude[cell] = 1.0;
                points.push([ray.position_mm[0], ray.position_mm[1]]);
            }
        }
        (points, amplitude)
    }
}

/// The pupil function A exp(2 pi i W) of a wavefront, row-major.
pub(crate) fn pupil_function(wavefront: &Wavefront) -> Vec<Complex64> {
    wavefront
        .amplitude
        .iter()
        .zip(&wavefront.opd_waves)
        .map(|(&a, &w)| Complex64::from_polar(a, 2.0 * std::f64::consts::PI * w))
        .collect()
}

/// The aberration-free pupil function of an amplitude grid.
pub(crate) fn clear_pupil(amplitude: &[f64]) -> Vec<Complex64> {
    amplitude.iter().map(|&a| Complex64::new(a, 0.0)).collect()
}

/// Normalised complex autocorrelation of an n x n pupil function along pupil y (`along_y`) or x, at
/// lags 0..n-1: OTF(k) = sum P(p + k) conj(P(p)) / sum |P|^2, the OTF at k grid steps of shift.
pub(crate) fn autocorrelation(pupil: &[Complex64], n: usize, along_y: bool) -> Vec<Complex64> {
    use rayon::prelude::*;
    let zero = Complex64::new(0.0, 0.0);
    let norm: f64 = pupil.iter().map(|p| p.norm_sqr()).sum();
    if norm == 0.0 {
        return vec![zero; n];
    }
    (0..n)
        .into_par_iter()
        .map(|k| {
            let mut sum = zero;
            for j in 0..n {
                for i in 0..n {
                    let (jj, ii) = if along_y { (j + k, i) } else { (j, i + k) };
                    if jj >= n || ii >= n {
                        continue;
                    }
                    let a = pupil[j * n + i];
                    if a != zero {
                        sum += pupil[jj * n + ii] * a.conj();
                    }
                }
            }
            sum / norm
        })
        .collect()
}

/// Linear interpolation of lag samples at fractional lag `t` (0 beyond the last lag).
pub(crate) fn at_lag(lags: &[Complex64], t: f64) -> Complex64 {
    let zero = Complex64::new(0.0, 0.0);
    if t.is_nan() || t < 0.0 {
        return zero;
    }
    let k = t.floor() as usize;
    if k + 1 >= lags.len() {
        return if k + 1 == lags.len() && t == k as f64 {
            lags[k]
        } else {
            zero
        };
    }
    let f = t - k as f64;
    lags[k] * (1.0 - f) + lags[k + 1] * f
}

/// Geometric OTF of image points along one axis (1 = y, tangential; 0 = x, sagittal), relative to
/// `origin`: the mean of exp(-2 pi i nu u) over the rays (the Fourier transform of the ray density).
pub(crate) fn ray_otf(points: &[[f64; 2]], axis: usize, origin: f64, frequency_cy_mm: f64) -> Complex64 {
    if points.is_empty() {
        return Complex64::new(0.0, 0.0);
    }
    let omega = -2.0 * std::f64::consts::PI * frequency_cy_mm;
    let sum = points.iter().fold(Complex64::new(0.0, 0.0), |acc, p| {
        acc + Complex64::from_polar(1.0, omega * (p[axis] - origin))
    });
    sum / points.len() as f64
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let length = dot(v, v).sqrt();
    v.map(|c| c / length)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The autocorrelation of a clear circular pupil is the textbook diffraction-limited MTF,
    /// (2/pi)(phi - cos phi sin phi) with cos phi = nu / nu_c, to the grid's discretisation.
    #[test]
    fn clear_disc_autocorrelation_is_the_diffraction_limit() {
        let n = 256;
        let amplitude: Vec<f64> = (0..n * n)
            .map(|k| {
                let (x, y) = (coordinate(k % n, n), coordinate(k / n, n));
                if x * x + y * y <= 1.0 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let lags = autocorrelation(&clear_pupil(&amplitude), n, true);
        for k in [0, 16, 64, 128, 192, 240] {
            let ratio = k as f64 / n as f64;
            let phi = ratio.acos();
            let exact = 2.0 / std::f64::consts::PI * (phi - phi.cos() * phi.sin());
            assert!(
                (lags[k].re - exact).abs() < 4e-3,
                "lag {k}: {} vs {exact}",
                lags[k].re
            );
            assert!(lags[k].im.abs() < 1e-12);
        }
    }

    #[test]
    fn lag_interpolation_is_linear_and_ends_at_zero() {
        let lags = vec![
            Complex64::new(1.0, 0.0),
            Complex64::new(0.5, 0.0),
            Complex64::new(0.0, 0.0),
        ];
        assert_eq!(at_lag(&lags, 0.5).re, 0.75);
        assert_eq!(at_lag(&lags, 2.0).re, 0.0);
        assert_eq!(at_lag(&lags, 7.0).re, 0.0);
        assert_eq!(at_lag(&lags, f64::NAN).re, 0.0);
    }

    /// Two equal groups of rays a distance d apart: |OTF| = |cos(pi nu d)|.
    #[test]
    fn ray_otf_of_two_points_is_a_cosine() {
        let points = [[0.0, 0.0], [0.0, 0.01]];
        for nu in [0.0, 10.0, 25.0, 50.0] {
            let m = ray_otf(&points, 1, 0.0, nu).norm();
            assert!((m - (std::f64::consts::PI * nu * 0.01).cos().abs()).abs() < 1e-12);
        }
        assert!((ray_otf(&points, 0, 0.0, 50.0).norm() - 1.0).abs() < 1e-12);
    }
}
