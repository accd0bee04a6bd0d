//! PSNR with the BasicSR conventions (`basicsr/metrics/psnr_ssim.py: calculate_psnr`, the code the UniCAC
//! authors' group uses in OmniLens): samples on the [0, 255] scale, the MSE taken over every pixel of every
//! channel of the (optionally border-cropped) image, PSNR = 10 log10(255^2 / MSE) = 20 log10(255 / sqrt(MSE)).
//!
//! Identical images have MSE = 0 and an infinite PSNR (BasicSR returns `float('inf')`). JSON cannot hold
//! infinity, so [`psnr`] returns [`PSNR_CAP_DB`] (100 dB) with [`Psnr::capped`] set instead. The cap also
//! applies when the true PSNR is above 100 dB (MSE below 6.5e-6, far below 8-bit quantisation).

use serde::{Deserialize, Serialize};
use unicac_image::Planar;

use crate::error::{MetricsError, Result};
use crate::input::{check_same_shape, plane_255, ValueRange};

/// The PSNR reported for identical (or nearly identical) images, in dB.
pub const PSNR_CAP_DB: f64 = 100.0;

/// Options shared by [`psnr`] and [`crate::ssim::ssim`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct FullReferenceOptions {
    /// Pixels removed from each side before the metric (BasicSR `crop_border`; 0 in the OmniLens configs).
    pub crop_border: usize,
    /// The range of the input samples.
    pub range: ValueRange,
}

/// A PSNR value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Psnr {
    /// PSNR in dB, at most [`PSNR_CAP_DB`].
    pub db: f64,
    /// Mean squared error on the [0, 255] scale.
    pub mse: f64,
    /// True when the PSNR was limited to [`PSNR_CAP_DB`] (MSE = 0 means infinite PSNR).
    pub capped: bool,
}

/// PSNR of `image` against `reference` (BasicSR `calculate_psnr`, `test_y_channel = false`).
pub fn psnr(image: &Planar, reference: &Planar, options: &FullReferenceOptions) -> Result<Psnr> {
    check_same_shape(image, reference)?;
    let border = options.crop_border;
    if image.width <= 2 * border || image.height <= 2 * border {
        return Err(MetricsError::TooSmall {
            width: image.width,
            height: image.height,
            what: format!("nothing left after cropping {border} px per side"),
        });
    }
    let mut sum = 0.0;
    let mut count = 0usize;
    for c in 0..image.channels {
        let (a, _, _) = plane_255(image, c, border, options.range);
        let (b, _, _) = plane_255(reference, c, border, options.range);
        sum += a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
        count += a.len();
    }
    let mse = sum / count as f64;
    Ok(psnr_from_mse(mse))
}

/// PSNR for a mean squared error on the [0, 255] scale, capped at [`PSNR_CAP_DB`].
pub fn psnr_from_mse(mse: f64) -> Psnr {
    let db = 10.0 * (255.0 * 255.0 / mse).log10();
    if db >= PSNR_CAP_DB || mse <= 0.0 {
        Psnr {
            db: PSNR_CAP_DB,
            mse,
            capped: true,
        }
    } else {
        Psnr {
            db,
            mse,
            capped: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_are_capped() {
        let a = Planar::from_fn(8, 8, 3, |c, x, y| (c + x + y) as f32 / 20.0);
        let p = psnr(&a, &a, &FullReferenceOptions::default()).unwrap();
        assert!(p.capped);
        assert_eq!(p.db, PSNR_CAP_DB);
        assert_eq!(p.mse, 0.0);
    }

    #[test]
    fn constant_offset_gives_the_textbook_value() {
        // Every sample off by 1/255 in [0, 1] units: MSE = 1 on the 255 scale, PSNR = 20 log10(255).
        let a = Planar::from_fn(6, 5, 2, |_, _, _| 0.5);
        let b = Planar::from_fn(6, 5, 2, |_, _, _| 0.5 + 1.0 / 255.0);
        let p = psnr(&a, &b, &FullReferenceOptions::default()).unwrap();
        assert!((p.db - 20.0 * 255f64.log10()).abs() < 1e-4, "{}", p.db);
    }

    #[test]
    fn crop_border_ignores_the_border() {
        let a = Planar::from_fn(10, 10, 1, |_, _, _| 100.0);
        let b = Planar::from_fn(10, 10, 1, |_, x, y| {
            if x < 2 || y < 2 || x > 7 || y > 7 {
                0.0
            } else {
                110.0
            }
        });
        let options = FullReferenceOptions {
            crop_border: 2,
            range: ValueRange::Byte,
        };
        let p = psnr(&a, &b, &options).unwrap();
        assert!((p.db - 10.0 * (255.0f64 * 255.0 / 100.0).log10()).abs() < 1e-12);
        assert!(psnr(
            &a,
            &b,
            &FullReferenceOptions {
                crop_border: 5,
                ..options
            }
        )
        .is_err());
    }

    #[test]
    fn shape_mismatch_is_an_error() {
        let a = Planar::new(4, 4, 3);
        let b = Planar::new(4, 4, 1);
        assert!(matches!(
            psnr(&a, &b, &FullReferenceOptions::default()),
            Err(MetricsError::ShapeMismatch { .. })
        ));
    }
}
