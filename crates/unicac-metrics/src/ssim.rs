//! SSIM with the BasicSR conventions (`basicsr/metrics/psnr_ssim.py: calculate_ssim` and `_ssim`, MATLAB
//! compatible, after Wang et al. 2004): samples on the [0, 255] scale; an 11x11 Gaussian window with
//! sigma = 1.5 (OpenCV `getGaussianKernel(11, 1.5)`, normalised to sum 1); C1 = (0.01*255)^2 and
//! C2 = (0.03*255)^2; local statistics by 'valid' filtering, so the SSIM map covers the image minus 5 px
//! on each side; population (not sample) covariances; the map mean per channel, then the mean over channels.
//!
//! scikit-image's `structural_similarity(gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
//! data_range=255)` filters the whole image with reflected borders but then also drops 5 px per side
//! before averaging, so it gives the same number (checked in `tests/reference/metrics`).

use serde::{Deserialize, Serialize};
use unicac_image::Planar;

use crate::error::{MetricsError, Result};
use crate::input::{check_same_shape, plane_255};
use crate::psnr::FullReferenceOptions;

/// Half width of the Gaussian window (the window is 11x11).
pub const SSIM_RADIUS: usize = 5;
/// Standard deviation of the Gaussian window, in pixels.
pub const SSIM_SIGMA: f64 = 1.5;
const C1: f64 = (0.01 * 255.0) * (0.01 * 255.0);
const C2: f64 = (0.03 * 255.0) * (0.03 * 255.0);

/// An SSIM value with its per-channel parts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ssim {
    /// Mean of `per_channel` (BasicSR's `calculate_ssim` result).
    pub mean: f64,
    /// Mean of the SSIM map of each channel.
    pub per_channel: Vec<f64>,
}

/// SSIM of `image` against `reference` (BasicSR `calculate_ssim`, `test_y_channel = false`).
pub fn ssim(image: &Planar, reference: &Planar, options: &FullReferenceOptions) -> Result<Ssim> {
    check_same_shape(image, reference)?;
    let border = options.crop_border;
    let window = 2 * SSIM_RADIUS + 1;
    if image.width < 2 * border + window || image.height < 2 * border + window {
        return Err(MetricsError::TooSmall {
            width: image.width,
            height: image.height,
            what: format!("SSIM needs at least {window}x{window} px after cropping {border} px per side"),
        });
    }
    let kernel = gaussian_kernel(SSIM_RADIUS, SSIM_SIGMA);
    let per_channel: Vec<f64> = (0..image.channels)
        .map(|c| {
            let (a, w, h) = plane_255(image, c, border, options.range);
            let (b, _, _) = plane_255(reference, c, border, options.range);
            channel_ssim(&a, &b, w, h, &kernel)
        })
        .collect();
    let mean = per_channel.iter().sum::<f64>() / per_channel.len() as f64;
    Ok(Ssim { mean, per_channel })
}

/// The normalised 1-D Gaussian exp(-i^2 / (2 sigma^2)), i = -radius..=radius (OpenCV `getGaussianKernel`).
pub fn gaussian_kernel(radius: usize, sigma: f64) -> Vec<f64> {
    let r = radius as f64;
    let raw: Vec<f64> = (0..=2 * radius)
        .map(|i| (-(i as f64 - r).powi(2) / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.into_iter().map(|v| v / sum).collect()
}

/// Mean SSIM map of one channel (samples on the 255 scale, `w` x `h`, row-major).
fn channel_ssim(a: &[f64], b: &[f64], w: usize, h: usize, kernel: &[f64]) -> f64 {
    let product =
        |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> { a.iter().zip(b).map(|(&x, &y)| f(x, y)).collect() };
    let mu_a = filter_valid(a, w, h, kernel);
    let mu_b = filter_valid(b, w, h, kernel);
    let aa = filter_valid(&product(&|x, _| x * x), w, h, kernel);
    let bb = filter_valid(&product(&|_, y| y * y), w, h, kernel);
    let ab = filter_valid(&product(&|x, y| x * y), w, h, kernel);
    let n = mu_a.len();
    let total: f64 = (0..n)
        .map(|i| {
            let (ma, mb) = (mu_a[i], mu_b[i]);
            let var_a = aa[i] - ma * ma;
            let var_b = bb[i] - mb * mb;
            let cov = ab[i] - ma * mb;
            ((2.0 * ma * mb + C1) * (2.0 * cov + C2)) / ((ma * ma + mb * mb + C1) * (var_a + var_b + C2))
        })
        .sum();
    total / n as f64
}

/// Separable 'valid' correlation of a `w` x `h` plane with `kernel` along both axes; the result is
/// `(w - k + 1) x (h - k + 1)`.
pub(crate) fn filter_valid(plane: &[f64], w: usize, h: usize, kernel: &[f64]) -> Vec<f64> {
    let k = kernel.len();
    let (ow, oh) = (w + 1 - k, h + 1 - k);
    // Each output accumulates its taps in kernel order (0 + g0 v0 + g1 v1 + ...), tap by tap over a
    // whole row: the same sums as one dot product per pixel, but contiguous, so they vectorise. The
    // first tap writes (0 + g0 v0) rather than adding into zeroed memory: pages read while still the
    // kernel's shared zero page fault a second time on the write, with a TLB flush on the other threads.
    let (first, rest) = kernel.split_first().expect("a non-empty kernel");
    let mut rows = Vec::with_capacity(ow * h);
    for src in plane.chunks_exact(w) {
        let start = rows.len();
        rows.extend(src[..ow].iter().map(|v| 0.0 + first * v));
        let row = &mut rows[start..];
        for (i, g) in rest.iter().enumerate() {
            row.iter_mut()
                .zip(&src[i + 1..i + 1 + ow])
                .for_each(|(r, v)| *r += g * v);
        }
    }
    let mut out = Vec::with_capacity(ow * oh);
    for y in 0..oh {
        let start = out.len();
        out.extend(rows[y * ow..(y + 1) * ow].iter().map(|v| 0.0 + first * v));
        let row = &mut out[start..];
        for (j, g) in rest.iter().enumerate() {
            let src = &rows[(y + j + 1) * ow..(y + j + 2) * ow];
            row.iter_mut().zip(src).for_each(|(r, v)| *r += g * v);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::ValueRange;

    #[test]
    fn kernel_is_normalised_and_symmetric() {
        let k = gaussian_kernel(5, 1.5);
        assert_eq!(k.len(), 11);
        assert!((k.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert_eq!(k[0], k[10]);
        assert!(k[5] > k[4]);
    }

    #[test]
    fn identical_images_give_one() {
        let a = Planar::from_fn(16, 14, 3, |c, x, y| ((c * 7 + x * 3 + y * 5) % 11) as f32 / 10.0);
        let s = ssim(&a, &a, &FullReferenceOptions::default()).unwrap();
        assert!((s.mean - 1.0).abs() < 1e-12);
        assert_eq!(s.per_channel.len(), 3);
    }

    #[test]
    fn constant_images_follow_the_luminance_term() {
        // Flat images: variances are 0, so SSIM = (2 a b + C1) / (a^2 + b^2 + C1).
        let a = Planar::from_fn(12, 12, 1, |_, _, _| 100.0);
        let b = Planar::from_fn(12, 12, 1, |_, _, _| 120.0);
        let options = FullReferenceOptions {
            crop_border: 0,
            range: ValueRange::Byte,
        };
        let s = ssim(&a, &b, &options).unwrap();
        let expected = (2.0 * 100.0 * 120.0 + C1) / (100.0f64 * 100.0 + 120.0 * 120.0 + C1);
        assert!((s.mean - expected).abs() < 1e-12);
    }

    #[test]
    fn too_small_is_an_error() {
        let a = Planar::new(10, 20, 1);
        assert!(ssim(&a, &a, &FullReferenceOptions::default()).is_err());
    }
}
