//! PSNR and SSIM with the pyiqa conventions (chaofengc/IQA-PyTorch 0.1.16, the package the UniCAC paper
//! evaluated restored images with): the numbers `unicac bench` and `unicac metrics` report.
//!
//! - **`psnr`** (pyiqa `psnr`, `test_y_channel=False`): RGB samples in [0, 1] (8-bit files divided by 255),
//!   MSE over every sample, `10 log10(1 / (MSE + 1e-8))`. The `1e-8` caps identical images at
//!   [`PYIQA_PSNR_CAP_DB`] = 80 dB (pyiqa's value, kept so numbers compare with the paper's tables).
//! - **`ssim`** (pyiqa `ssim`: `test_y_channel=True`, `color_space='yiq'`, `downsample=False`): the Y of
//!   YIQ, `0.299 R + 0.587 G + 0.114 B` in float32, times 255 and rounded half-to-even (pyiqa's "use
//!   rounded uint8 value to make the input image same as MATLAB"), then in float64: 11x11 Gaussian
//!   window (sigma 1.5), 'valid' filtering, C1 = (0.01 * 255)^2, C2 = (0.03 * 255)^2, and the
//!   contrast-structure map clamped at 0 (`F.relu(cs_map)`) before it multiplies the luminance map; the
//!   score is the mean of the map. The clamp is why pyiqa's SSIM differs from the MATLAB original in
//!   the 4th decimal on its calibration pairs.
//!
//! Calibration: pyiqa's own outputs on its 5 reference/distorted pairs (`ResultsCalibra`), checked in
//! `crates/unicac-bench/tests/calibration.rs`. The BasicSR-convention metrics used by the ODE are in
//! [`crate::psnr`] and [`crate::ssim`].

use unicac_image::Planar;

use crate::error::{MetricsError, Result};
use crate::input::check_same_shape;
use crate::ssim::{filter_valid, gaussian_kernel, SSIM_RADIUS, SSIM_SIGMA};

/// pyiqa's PSNR of identical images: 10 log10(1 / 1e-8) dB.
pub const PYIQA_PSNR_CAP_DB: f64 = 80.0;
/// The term pyiqa adds to the MSE (data range 1).
const PSNR_EPS: f64 = 1e-8;
const C1: f64 = (0.01 * 255.0) * (0.01 * 255.0);
const C2: f64 = (0.03 * 255.0) * (0.03 * 255.0);

fn check_rgb(image: &Planar, reference: &Planar) -> Result<()> {
    check_same_shape(image, reference)?;
    if image.channels != 3 {
        return Err(MetricsError::InvalidInput(format!(
            "pyiqa metrics take RGB images, got {} channels",
            image.channels
        )));
    }
    Ok(())
}

/// pyiqa `psnr` of `image` against `reference`, both RGB in [0, 1], in dB (at most 80).
pub fn psnr_pyiqa(image: &Planar, reference: &Planar) -> Result<f64> {
    check_rgb(image, reference)?;
    let sum: f64 = image
        .data
        .iter()
        .zip(&reference.data)
        .map(|(&a, &b)| {
            let d = a as f64 - b as f64;
            d * d
        })
        .sum();
    let mse = sum / image.data.len() as f64;
    Ok(10.0 * (1.0 / (mse + PSNR_EPS)).log10())
}

/// The rounded Y of YIQ on the [0, 255] scale, as pyiqa's `to_y_channel(img, 255, 'yiq')` computes it.
pub fn y_channel_255(image: &Planar) -> Vec<f64> {
    let (r, g, b) = (image.plane(0), image.plane(1), image.plane(2));
    (0..image.pixels())
        .map(|i| {
            // float32 like the torch matmul, then rounding half to even like torch.round.
            let y = (r[i] * 0.299f32 + g[i] * 0.587f32 + b[i] * 0.114f32) * 255.0f32;
            y.round_ties_even() as f64
        })
        .collect()
}

/// pyiqa `ssim` (its default: Y of YIQ, clamped contrast-structure map) of `image` against `reference`,
/// both RGB in [0, 1].
pub fn ssim_pyiqa(image: &Planar, reference: &Planar) -> Result<f64> {
    check_rgb(image, reference)?;
    let window = 2 * SSIM_RADIUS + 1;
    let (w, h) = (image.width, image.height);
    if w < window || h < window {
        return Err(MetricsError::TooSmall {
            width: w,
            height: h,
            what: format!("SSIM needs at least {window}x{window} px"),
        });
    }
    let a = y_channel_255(image);
    let b = y_channel_255(reference);
    let kernel = gaussian_kernel(SSIM_RADIUS, SSIM_SIGMA);
    let product =
        |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> { a.iter().zip(&b).map(|(&x, &y)| f(x, y)).collect() };
    let mu_a = filter_valid(&a, w, h, &kernel);
    let mu_b = filter_valid(&b, w, h, &kernel);
    let aa = filter_valid(&product(&|x, _| x * x), w, h, &kernel);
    let bb = filter_valid(&product(&|_, y| y * y), w, h, &kernel);
    let ab = filter_valid(&product(&|x, y| x * y), w, h, &kernel);
    let n = mu_a.len();
    let total: f64 = (0..n)
        .map(|i| {
            let (ma, mb) = (mu_a[i], mu_b[i]);
            let var_a = aa[i] - ma * ma;
            let var_b = bb[i] - mb * mb;
            let cov = ab[i] - ma * mb;
            let cs = ((2.0 * cov + C2) / (var_a + var_b + C2)).max(0.0);
            (2.0 * ma * mb + C1) / (ma * ma + mb * mb + C1) * cs
        })
        .sum();
    Ok(total / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(offset: f32) -> Planar {
        Planar::from_fn(24, 20, 3, |c, x, y| {
            (((c * 5 + x * 3 + y * 7) % 13) as f32 / 12.0 * 0.8 + offset).clamp(0.0, 1.0)
        })
    }

    #[test]
    fn identical_images_give_pyiqas_cap_and_one() {
        let a = pattern(0.0);
        assert!((psnr_pyiqa(&a, &a).unwrap() - PYIQA_PSNR_CAP_DB).abs() < 1e-9);
        assert!((ssim_pyiqa(&a, &a).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn psnr_of_a_constant_offset() {
        // Every sample off by 0.1: MSE = 0.01, PSNR = 10 log10(1 / (0.01 + 1e-8)).
        let a = Planar::from_fn(8, 8, 3, |_, _, _| 0.5);
        let b = Planar::from_fn(8, 8, 3, |_, _, _| 0.6);
        let expected = 10.0 * (1.0 / (0.01f64 + 1e-8)).log10();
        assert!((psnr_pyiqa(&a, &b).unwrap() - expected).abs() < 1e-5);
    }

    #[test]
    fn y_is_rounded_on_the_255_scale() {
        // Grey 128/255 gives Y = 128 exactly; pure red 1.0 gives 0.299 * 255 = 76.245 -> 76.
        let grey = Planar::from_fn(1, 1, 3, |_, _, _| 128.0 / 255.0);
        assert_eq!(y_channel_255(&grey), vec![128.0]);
        let red = Planar::from_fn(1, 1, 3, |c, _, _| if c == 0 { 1.0 } else { 0.0 });
        assert_eq!(y_channel_255(&red), vec![76.0]);
    }

    #[test]
    fn anticorrelated_structure_is_clamped_at_zero() {
        // An image against its negative: the contrast-structure term is negative everywhere and clamps
        // to 0, so pyiqa's SSIM is 0 where the unclamped formula would be negative.
        let a = Planar::from_fn(16, 16, 3, |_, x, y| if (x + y) % 2 == 0 { 0.2 } else { 0.8 });
        let b = Planar::from_fn(16, 16, 3, |_, x, y| if (x + y) % 2 == 0 { 0.8 } else { 0.2 });
        assert_eq!(ssim_pyiqa(&a, &b).unwrap(), 0.0);
    }

    #[test]
    fn grey_images_are_refused() {
        let a = Planar::new(16, 16, 1);
        assert!(psnr_pyiqa(&a, &a).is_err());
    }
}
