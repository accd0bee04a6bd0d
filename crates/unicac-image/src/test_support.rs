//! Helpers shared by the crate's unit tests.

use crate::Planar;

/// Peak signal-to-noise ratio in dB for peak 1 over all samples, computed in f64.
pub(crate) fn psnr(a: &Planar, b: &Planar) -> f64 {
    assert_eq!((a.width, a.height, a.channels), (b.width, b.height, b.channels));
    let mse = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
        .sum::<f64>()
        / a.data.len() as f64;
    -10.0 * mse.log10()
}
