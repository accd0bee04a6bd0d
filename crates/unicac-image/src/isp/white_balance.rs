//! White balance: per-channel gains on camera-raw RGB (or on an RGGB mosaic, site by site), their inverse
//! for "unprocessing" a ground-truth image into camera raw (Brooks et al., "Unprocessing Images for Learned
//! Raw Denoising", CVPR 2019, section 3.1), and the seeded random perturbation of the gains that UniCAC /
//! DeepLens use as ISP domain randomisation (DeepLens `sample_augmentation`: gains + N(0, 0.1²)).

use super::bayer::rggb_channel;
use crate::error::{check_layout, ImageError, Result};
use crate::Planar;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use rayon::prelude::*;

/// Smallest gain a perturbation may produce (keeps gains positive and invertible).
pub const MIN_GAIN: f32 = 0.05;

/// Camera white-balance gains: raw R, G, B are multiplied by them to render a neutral grey (green = 1 by
/// convention).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhiteBalanceGains {
    pub red: f32,
    pub green: f32,
    pub blue: f32,
}

impl WhiteBalanceGains {
    /// DeepLens' default sensor gains (`deeplens/sensor/rgb_sensor.py`): R 2.0, G 1.0, B 1.8.
    pub const DEEPLENS: WhiteBalanceGains = WhiteBalanceGains {
        red: 2.0,
        green: 1.0,
        blue: 1.8,
    };
    /// No colour correction.
    pub const IDENTITY: WhiteBalanceGains = WhiteBalanceGains {
        red: 1.0,
        green: 1.0,
        blue: 1.0,
    };

    /// Gains in channel order R, G, B.
    pub fn to_array(self) -> [f32; 3] {
        [self.red, self.green, self.blue]
    }

    /// The gains if each is finite and > 0, else an error naming them.
    pub fn validate(self) -> Result<Self> {
        if self.to_array().iter().all(|g| g.is_finite() && *g > 0.0) {
            Ok(self)
        } else {
            Err(ImageError::invalid(
                "white_balance",
                format!("{self:?}: gains must be finite and > 0"),
            ))
        }
    }
}

/// White-balanced copy of a 3-channel camera-raw RGB image: channel c times gain c.
pub fn apply_white_balance(rgb: &Planar, gains: WhiteBalanceGains) -> Result<Planar> {
    super::edited_copy(rgb, |image| apply_white_balance_in_place(image, gains))
}

/// [`apply_white_balance`] where the samples are.
pub(crate) fn apply_white_balance_in_place(rgb: &mut Planar, gains: WhiteBalanceGains) -> Result<()> {
    scale_rgb(rgb, gains.validate()?.to_array())
}

/// Inverse white balance (camera-raw RGB from a white-balanced image): channel c divided by gain c.
pub fn invert_white_balance(rgb: &Planar, gains: WhiteBalanceGains) -> Result<Planar> {
    super::edited_copy(rgb, |image| invert_white_balance_in_place(image, gains))
}

/// [`invert_white_balance`] where the samples are (the pipeline's own images: no copy).
pub(crate) fn invert_white_balance_in_place(rgb: &mut Planar, gains: WhiteBalanceGains) -> Result<()> {
    scale_rgb(rgb, gains.validate()?.to_array().map(|g| 1.0 / g))
}

/// White balance applied on a 1-channel RGGB mosaic, each photosite scaled by the gain of its filter colour
/// (the order of a camera ISP: white balance before demosaicing, so that demosaicing sees neutral edges).
pub fn apply_white_balance_mosaic(mosaic: &Planar, gains: WhiteBalanceGains) -> Result<Planar> {
    super::edited_copy(mosaic, |image| apply_white_balance_mosaic_in_place(image, gains))
}

/// [`apply_white_balance_mosaic`] where the samples are.
pub(crate) fn apply_white_balance_mosaic_in_place(
    mosaic: &mut Planar,
    gains: WhiteBalanceGains,
) -> Result<()> {
    let gains = gains.validate()?.to_array();
    check_layout(mosaic, "mosaic", &[1])?;
    if mosaic.width > 0 {
        let width = mosaic.width;
        mosaic
            .data
            .par_chunks_mut(width)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    *v *= gains[rggb_channel(x, y)];
                }
            });
    }
    Ok(())
}

/// Randomly perturbed gains, `nominal + N(0, std_dev²)` independently per channel, floored at [`MIN_GAIN`];
/// deterministic for a given `seed`. The caller applies the returned gains to both the ground truth
/// (inverse, before the optics) and the degraded image (forward, in the ISP), so the pair stays consistent.
pub fn perturb_white_balance(
    nominal: WhiteBalanceGains,
    std_dev: f32,
    seed: u64,
) -> Result<WhiteBalanceGains> {
    let nominal = nominal.validate()?;
    if !(std_dev.is_finite() && std_dev >= 0.0) {
        return Err(ImageError::invalid(
            "white_balance_std_dev",
            format!("{std_dev}, expected >= 0"),
        ));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut jitter = |g: f32| (g + std_dev * rng.sample::<f32, _>(StandardNormal)).max(MIN_GAIN);
    Ok(WhiteBalanceGains {
        red: jitter(nominal.red),
        green: jitter(nominal.green),
        blue: jitter(nominal.blue),
    })
}

/// Channel c of `rgb` times `factors[c]`, in place and in parallel.
fn scale_rgb(rgb: &mut Planar, factors: [f32; 3]) -> Result<()> {
    check_layout(rgb, "rgb", &[3])?;
    for (channel, factor) in factors.into_iter().enumerate() {
        crate::color::map_in_parallel(rgb.plane_mut(channel), |v| v * factor);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_then_forward_white_balance_is_identity() {
        let image = Planar::from_fn(5, 4, 3, |c, x, y| 0.1 + 0.05 * (c + x + y) as f32);
        let gains = WhiteBalanceGains {
            red: 2.1,
            green: 0.97,
            blue: 1.73,
        };
        let back = apply_white_balance(&invert_white_balance(&image, gains).unwrap(), gains).unwrap();
        for (a, b) in image.data.iter().zip(&back.data) {
            assert!((a - b).abs() < 1e-6);
        }
        assert!(apply_white_balance(&image, WhiteBalanceGains { red: 0.0, ..gains }).is_err());
        assert!(apply_white_balance(&Planar::new(2, 2, 1), gains).is_err());
    }

    #[test]
    fn perturbation_is_seeded_and_has_the_requested_spread() {
        let nominal = WhiteBalanceGains::DEEPLENS;
        assert_eq!(
            perturb_white_balance(nominal, 0.1, 5).unwrap(),
            perturb_white_balance(nominal, 0.1, 5).unwrap()
        );
        assert_ne!(
            perturb_white_balance(nominal, 0.1, 5).unwrap(),
            perturb_white_balance(nominal, 0.1, 6).unwrap()
        );
        assert_eq!(perturb_white_balance(nominal, 0.0, 5).unwrap(), nominal);
        let draws: Vec<f64> = (0..4000)
            .map(|seed| perturb_white_balance(nominal, 0.1, seed).unwrap().red as f64)
            .collect();
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        let std = (draws.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / (draws.len() - 1) as f64).sqrt();
        // Standard errors: 0.1 / sqrt(4000) = 0.0016 for the mean, about 1.1 % for the std.
        assert!((mean - 2.0).abs() < 0.0065, "mean {mean}");
        assert!((std / 0.1 - 1.0).abs() < 0.045, "std {std}");
    }
}
