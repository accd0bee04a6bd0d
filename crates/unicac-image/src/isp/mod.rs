//! The sensor and ISP chain of UniCAC's image simulation (after DeepLens' `RGBSensor` and ISP modules;
//! prior-art.md sections 1.4 and 3), one small function per step, each citing its source:
//!
//! | step | function |
//! |---|---|
//! | inverse white balance ("unprocessing") | [`invert_white_balance`] |
//! | Bayer RGGB mosaic | [`mosaic_rggb`] |
//! | read-out: Poisson-Gaussian noise, black level, bit depth, clipping | [`read_out`] with [`SensorNoise`] |
//! | black-level subtraction | [`subtract_black_level`] |
//! | white balance (on the mosaic, or on RGB) | [`apply_white_balance_mosaic`], [`apply_white_balance`] |
//! | demosaicing, bilinear or Malvar-He-Cutler | [`demosaic`] |
//! | gamma (sRGB encoding) | [`crate::color::linear_to_srgb`] |
//! | quantisation to 8/16 bits | [`crate::quantise::quantise`] |
//! | ISP domain randomisation | [`perturb_white_balance`] |
//!
//! [`Pipeline`] composes them with `no_noise` / `no_isp` switches; every random step takes a seed. An
//! [`IspDevice`] (a GPU) may take over the read-out and the development (black level, white balance,
//! demosaicing) with the same contract. The
//! colour-correction matrix of DeepLens' ISP is not modelled (identity): UniCAC's degradations are optical.
//! The algorithms are hand-written because they *are* the product (the simulator must match the paper's
//! chain exactly); the white-balance perturbation draws from `rand`/`rand_distr` (three values per
//! sample), the sensor noise from `unicac_io::counter_draws` (a stream per sample, so the read-out runs
//! in parallel and a GPU can repeat it).

mod bayer;
mod device;
mod noise;
mod pipeline;
mod white_balance;

pub use bayer::{demosaic, demosaic_taps, mosaic_rggb, rggb_channel, Demosaic, Taps};
pub use device::{HostIsp, IspDevice};
pub use noise::{
    read_out, subtract_black_level, SensorNoise, DEFAULT_BIT_DEPTH, MIN_DEFAULT_SENSOR_BITS, NOISE_DRAWS,
};
pub use pipeline::{IspDraw, Pipeline, RenderedPair};
pub use white_balance::{
    apply_white_balance, apply_white_balance_mosaic, invert_white_balance, perturb_white_balance,
    WhiteBalanceGains, MIN_GAIN,
};

use crate::{Planar, Result};

/// A copy of `image` with `edit` applied: the public, copying form of a step whose pipeline form works in
/// place (the pipeline edits its own images; callers that keep theirs get a new one).
fn edited_copy(image: &Planar, edit: impl FnOnce(&mut Planar) -> Result<()>) -> Result<Planar> {
    let mut copy = image.clone();
    edit(&mut copy)?;
    Ok(copy)
}
