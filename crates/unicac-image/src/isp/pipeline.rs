//! The UniCAC / DeepLens image-simulation chain composed from the steps of this module, seeded and
//! reproducible (prior-art.md section 3, after DeepLens `Renderer.render` and Brooks et al. 2019):
//!
//! 1. draw this sample's random ISP parameters ([`Pipeline::draw`]): perturbed white-balance gains and a
//!    noise seed;
//! 2. ground truth (linear RGB) -> inverse white balance -> camera raw ([`Pipeline::unprocess`]);
//! 3. optics (PSF convolution; another crate) on camera raw;
//! 4. sensor + ISP ([`Pipeline::process`]): RGGB mosaic -> read-out with noise in DN -> black level ->
//!    white balance -> demosaic -> clip -> output encoding (sRGB gamma or linear) -> optional quantisation;
//! 5. the training target is the ground truth in the same output encoding ([`Pipeline::finish_reference`]).
//!
//! The same gains invert (step 2) and re-apply (step 4) the white balance, so target and degraded image
//! agree in colour while the per-channel raw levels, hence the noise, vary from sample to sample.

use super::bayer::{demosaic, mosaic_rggb, Demosaic};
use super::device::{HostIsp, IspDevice};
use super::noise::{read_out_in_place, subtract_black_level_in_place, SensorNoise};
use super::white_balance::{
    apply_white_balance_in_place, apply_white_balance_mosaic_in_place, invert_white_balance_in_place,
    perturb_white_balance, WhiteBalanceGains,
};
use crate::error::{check_layout, ImageError, Result};
use crate::io::Encoding;
use crate::quantise::quantise;
use crate::Planar;
use rayon::prelude::*;
use std::borrow::Cow;
use unicac_io::counter_random::derive_seed;

/// Sensor/ISP configuration. `Default` is DeepLens' sensor with its augmentation spread.
#[derive(Debug, Clone, PartialEq)]
pub struct Pipeline {
    /// Nominal camera white-balance gains. Default [`WhiteBalanceGains::DEEPLENS`] (2.0, 1.0, 1.8).
    pub white_balance: WhiteBalanceGains,
    /// Standard deviation of the Gaussian perturbation added to each gain per sample (ISP domain
    /// randomisation); 0 disables it. Default 0.1 (DeepLens `sample_augmentation`).
    pub white_balance_jitter: f32,
    pub sensor: SensorNoise,
    /// Default Malvar-He-Cutler.
    pub demosaic: Demosaic,
    /// Transfer curve of the output images. Default sRGB (the paper's gamma step).
    pub output_encoding: Encoding,
    /// Quantise outputs to this many bits (e.g. 8 or 16) while keeping f32 storage; `None` keeps full
    /// precision. Default `None`.
    pub output_bits: Option<u8>,
    /// Noiseless sensor: no shot or read noise; with the ISP on, black level, bit depth, rounding and
    /// clipping still apply.
    pub no_noise: bool,
    /// No colour filter array and no ISP randomisation: the sensor records R, G and B at every pixel (noise,
    /// if on, in each), gains stay nominal, nothing is demosaiced. With `no_noise` as well there is no
    /// read-out at all: the optics' output goes through unquantised (clipped to [0, 1]).
    pub no_isp: bool,
}

impl Default for Pipeline {
    fn default() -> Self {
        Pipeline {
            white_balance: WhiteBalanceGains::DEEPLENS,
            white_balance_jitter: 0.1,
            sensor: SensorNoise::default(),
            demosaic: Demosaic::MalvarHeCutler,
            output_encoding: Encoding::Srgb,
            output_bits: None,
            no_noise: false,
            no_isp: false,
        }
    }
}

/// The random parameters of one simulated sample, drawn from one seed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IspDraw {
    /// White-balance gains used to invert (before the optics) and re-apply (in the ISP) the white balance.
    pub gains: WhiteBalanceGains,
    /// Seed of the sensor noise, `None` when the pipeline is noiseless.
    pub noise_seed: Option<u64>,
}

/// A degraded image and its target, in the same output encoding.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedPair {
    pub degraded: Planar,
    pub target: Planar,
    pub draw: IspDraw,
}

impl Pipeline {
    /// The random parameters for `seed`: the gains perturbed by [`perturb_white_balance`] (nominal when
    /// `no_isp`) and the noise seed (absent when `no_noise`), each from its own stream derived from `seed`.
    pub fn draw(&self, seed: u64) -> Result<IspDraw> {
        let jitter = if self.no_isp {
            0.0
        } else {
            self.white_balance_jitter
        };
        let gains = perturb_white_balance(self.white_balance, jitter, derive_seed(seed, 1))?;
        let noise_seed = (!self.no_noise).then(|| derive_seed(seed, 2));
        Ok(IspDraw { gains, noise_seed })
    }

    /// Camera-raw RGB of a linear-light ground truth: inverse white balance with the drawn gains, in
    /// place (the image is consumed: a 12 MP frame is 144 MB).
    pub fn unprocess(&self, mut ground_truth: Planar, draw: &IspDraw) -> Result<Planar> {
        invert_white_balance_in_place(&mut ground_truth, draw.gains)?;
        Ok(ground_truth)
    }

    /// Sensor and ISP on camera-raw RGB (after the optics), returning the degraded image in the output
    /// encoding. See the module docs for the order of the steps.
    pub fn process(&self, raw_rgb: &Planar, draw: &IspDraw) -> Result<Planar> {
        self.process_on(raw_rgb, draw, &HostIsp)
    }

    /// `process` with the steps `device` takes (the noisy read-out, the development of the mosaic) run
    /// there, the rest on the CPU.
    pub fn process_on(&self, raw_rgb: &Planar, draw: &IspDraw, device: &dyn IspDevice) -> Result<Planar> {
        check_layout(raw_rgb, "raw_rgb", &[3])?;
        let sensor = &self.sensor;
        // Reads `exposure` out, on the device when it takes the step, else on the CPU where the
        // samples are (copied first only if they are the caller's).
        let read = |exposure: Cow<Planar>| -> Result<Planar> {
            if let Some(seed) = draw.noise_seed {
                if let Some(dn) = device.read_out(&exposure, sensor, seed) {
                    return Ok(dn);
                }
            }
            let mut dn = exposure.into_owned();
            read_out_in_place(&mut dn, sensor, draw.noise_seed)?;
            Ok(dn)
        };
        let rgb = if self.no_isp && draw.noise_seed.is_none() {
            // Optics only: with no ISP and no noise there is nothing for the sensor to add but its
            // digitisation, and a user who switched both off asks for the optics at full precision.
            let mut exposure = raw_rgb.clone();
            exposure.data.par_iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0)); // saturates before the gains
            apply_white_balance_in_place(&mut exposure, draw.gains)?;
            exposure
        } else if self.no_isp {
            let mut exposure = read(Cow::Borrowed(raw_rgb))?;
            subtract_black_level_in_place(&mut exposure, sensor)?;
            apply_white_balance_in_place(&mut exposure, draw.gains)?;
            exposure
        } else {
            let mut dn = read(Cow::Owned(mosaic_rggb(raw_rgb)?))?;
            match device.develop(&dn, sensor, draw.gains, self.demosaic) {
                Some(rgb) => rgb,
                None => {
                    subtract_black_level_in_place(&mut dn, sensor)?;
                    apply_white_balance_mosaic_in_place(&mut dn, draw.gains)?;
                    demosaic(&dn, self.demosaic)?
                }
            }
        };
        self.finish(rgb)
    }

    /// The training target: the linear ground truth clipped to [0, 1], encoded and quantised like the
    /// degraded output.
    pub fn finish_reference(&self, ground_truth: &Planar) -> Result<Planar> {
        check_layout(ground_truth, "ground_truth", &[3])?;
        self.finish(ground_truth.clone())
    }

    /// The whole chain for one sample: draw, unprocess, `optics` (camera raw in, camera raw out, e.g. a PSF
    /// convolution), process, and the matching target.
    pub fn render_pair(
        &self,
        ground_truth: &Planar,
        seed: u64,
        optics: impl FnOnce(&Planar) -> Result<Planar>,
    ) -> Result<RenderedPair> {
        let draw = self.draw(seed)?;
        let raw = self.unprocess(ground_truth.clone(), &draw)?;
        let degraded = self.process(&optics(&raw)?, &draw)?;
        Ok(RenderedPair {
            degraded,
            target: self.finish_reference(ground_truth)?,
            draw,
        })
    }

    fn finish(&self, mut rgb: Planar) -> Result<Planar> {
        // One parallel pass: NaN is refused, everything else clipped to [0, 1] (and encoded).
        let encode = self.output_encoding == Encoding::Srgb;
        if !crate::color::clip_and_encode_in_place(&mut rgb.data, encode) {
            return Err(ImageError::invalid("image", "NaN sample reached the ISP output"));
        }
        match self.output_bits {
            Some(bits) => quantise(&rgb, bits),
            None => Ok(rgb),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::psnr;

    fn smooth_gradient() -> Planar {
        Planar::from_fn(96, 64, 3, |c, x, y| {
            let (u, v) = (x as f32 / 96.0, y as f32 / 64.0);
            0.15 + 0.6 * (0.3 * u + 0.5 * v + 0.2 * c as f32 * u * v).min(1.0)
        })
    }

    #[test]
    fn noiseless_isp_round_trip_is_close_to_identity_above_55_db() {
        let truth = smooth_gradient();
        let pipeline = Pipeline {
            no_noise: true,
            output_encoding: Encoding::Linear,
            ..Pipeline::default()
        };
        let pair = pipeline.render_pair(&truth, 3, |raw| Ok(raw.clone())).unwrap();
        assert_ne!(
            pair.draw.gains,
            WhiteBalanceGains::DEEPLENS,
            "gains were perturbed"
        );
        let db = psnr(&pair.degraded, &pair.target);
        eprintln!("noiseless ISP round trip: {db:.1} dB");
        assert!(db > 55.0, "mosaic -> 10-bit read-out -> WB -> Malvar: {db:.1} dB");
    }

    #[test]
    fn the_output_is_clipped_and_a_nan_sample_is_refused() {
        let pipeline = Pipeline {
            no_noise: true,
            no_isp: true,
            output_encoding: Encoding::Linear,
            ..Pipeline::default()
        };
        let draw = pipeline.draw(3).unwrap();
        let bright = Planar::from_fn(300, 300, 3, |_, x, _| if x % 2 == 0 { 4.0 } else { -1.0 });
        let out = pipeline.process(&bright, &draw).unwrap();
        assert!(out.data.iter().all(|v| (0.0..=1.0).contains(v)));
        let mut poisoned = bright.clone();
        poisoned.set(2, 299, 299, f32::NAN);
        let error = pipeline.process(&poisoned, &draw).unwrap_err().to_string();
        assert!(error.contains("NaN sample reached the ISP output"), "{error}");
    }

    #[test]
    fn no_isp_and_no_noise_leaves_only_10_bit_digitisation() {
        let truth = smooth_gradient();
        let pipeline = Pipeline {
            no_noise: true,
            no_isp: true,
            output_encoding: Encoding::Linear,
            ..Pipeline::default()
        };
        let pair = pipeline.render_pair(&truth, 3, |raw| Ok(raw.clone())).unwrap();
        assert_eq!(pair.draw.gains, WhiteBalanceGains::DEEPLENS);
        // Half a DN of the 959-DN range, times the largest gain (2.0).
        let bound = 0.5 / 959.0 * 2.0 + 1e-6;
        let worst = pair
            .degraded
            .data
            .iter()
            .zip(&pair.target.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(worst <= bound, "worst {worst} > {bound}");
    }

    #[test]
    fn no_isp_and_no_noise_is_exact_linear_light() {
        // A ramp finer than any sensor step: it must come back unquantised (f32 rounding of the
        // inverse and re-applied white balance only), whatever the sensor's bit depth.
        let truth = Planar::from_fn(512, 2, 3, |_, x, _| 0.1 + 0.7 * x as f32 / 511.0);
        for bit_depth in [8, 10, 16] {
            let pipeline = Pipeline {
                no_noise: true,
                no_isp: true,
                output_encoding: Encoding::Linear,
                sensor: SensorNoise {
                    bit_depth,
                    ..SensorNoise::default()
                },
                ..Pipeline::default()
            };
            let pair = pipeline.render_pair(&truth, 3, |raw| Ok(raw.clone())).unwrap();
            let worst = pair
                .degraded
                .data
                .iter()
                .zip(&truth.data)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f32::max);
            assert!(worst <= 2e-7, "{bit_depth} bits: worst {worst}");
            let mut levels: Vec<u32> = pair.degraded.data.iter().map(|v| v.to_bits()).collect();
            levels.sort_unstable();
            levels.dedup();
            assert!(
                levels.len() >= 512,
                "{bit_depth} bits: only {} levels",
                levels.len()
            );
        }
    }

    #[test]
    fn same_seed_gives_identical_pairs_and_different_seeds_differ() {
        let truth = smooth_gradient();
        let pipeline = Pipeline {
            output_bits: Some(8),
            ..Pipeline::default()
        };
        let a = pipeline.render_pair(&truth, 42, |raw| Ok(raw.clone())).unwrap();
        let b = pipeline.render_pair(&truth, 42, |raw| Ok(raw.clone())).unwrap();
        let c = pipeline.render_pair(&truth, 43, |raw| Ok(raw.clone())).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.draw, c.draw);
        let differing = a
            .degraded
            .data
            .iter()
            .zip(&c.degraded.data)
            .filter(|(x, y)| x != y)
            .count();
        assert!(differing > a.degraded.data.len() / 2);
        assert_eq!(a.target, c.target, "the target does not depend on the seed");
        // 8-bit output levels.
        assert!(a
            .degraded
            .data
            .iter()
            .all(|v| ((v * 255.0).round() - v * 255.0).abs() < 1e-3));
        // Noise costs fidelity but the image stays recognisable (DeepLens' ISO 100 defaults).
        let db = psnr(&a.degraded, &a.target);
        eprintln!("default pipeline (ISO 100, 8-bit sRGB out): {db:.1} dB");
        assert!((25.0..50.0).contains(&db), "{db:.1} dB");
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let pipeline = Pipeline::default();
        let draw = pipeline.draw(0).unwrap();
        assert!(pipeline.process(&Planar::new(4, 4, 1), &draw).is_err());
        let nan = Planar::from_fn(4, 4, 3, |_, _, _| f32::NAN);
        assert!(pipeline.process(&nan, &draw).is_err());
        let bad = Pipeline {
            output_bits: Some(0),
            ..Pipeline::default()
        };
        assert!(bad.finish_reference(&smooth_gradient()).is_err());
        assert_ne!(derive_seed(1, 1), derive_seed(1, 2));
    }
}
