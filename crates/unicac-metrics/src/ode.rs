//! The UniCAC Optical Degradation Evaluator formulas (paper Sec. 3.3, Eqs. 3-5; weights from
//! Sec. 4.4 "Coefficient Selection Rationale"):
//!
//! - OIQ = alpha * PSNR / 50 + beta * (SSIM - 0.5) / 0.5 + gamma * OIQE (Eq. 4),
//! - U_{s,c} = exp(-sigma * CV_{s,c}) (Eq. 5), CV = coefficient of variation of the OIQ values across
//!   the 5 fields (U_s) or the 3 colour channels (U_c),
//! - ODE = lambda_oiq * OIQ + lambda_s * U_s + lambda_c * U_c (Eq. 3),
//!
//! with alpha = 0.4, beta = 0.3, gamma = 0.3, sigma = 5, lambda_oiq = 0.7, lambda_s = 0.3,
//! lambda_c = 0.01. The paper does not say whether CV uses the population or the sample standard
//! deviation; unicac uses the population one (divide by n), the natural choice for a fixed, complete set of
//! fields or channels. Note that the weights sum to 1.01, so ODE can slightly exceed 1; kept as published.
//! Which OIQ enters ODE and how the grid is averaged is unicac's reading (see [`ode_from_oiq_grid`]).

use serde::{Deserialize, Serialize};

use crate::error::{MetricsError, Result};

/// The ODE weights; `Default` gives the published values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OdeWeights {
    /// PSNR weight in OIQ (0.4).
    pub alpha: f64,
    /// SSIM weight in OIQ (0.3).
    pub beta: f64,
    /// OIQE weight in OIQ (0.3).
    pub gamma: f64,
    /// Scale of the CV in the uniformity exponent (5).
    pub sigma: f64,
    /// OIQ weight in ODE (0.7).
    pub lambda_oiq: f64,
    /// Spatial-uniformity weight in ODE (0.3).
    pub lambda_s: f64,
    /// Channel-uniformity weight in ODE (0.01).
    pub lambda_c: f64,
}

impl Default for OdeWeights {
    fn default() -> Self {
        OdeWeights {
            alpha: 0.4,
            beta: 0.3,
            gamma: 0.3,
            sigma: 5.0,
            lambda_oiq: 0.7,
            lambda_s: 0.3,
            lambda_c: 0.01,
        }
    }
}

/// PSNR at which the PSNR term of OIQ saturates: the paper normalises by 50 dB, and an ideal lens
/// (identical 8-bit images, infinite PSNR) must not score above a lens that is merely perfect to the eye.
pub const OIQ_PSNR_CEILING_DB: f64 = 50.0;

/// OIQ = alpha min(PSNR, 50)/50 + beta (SSIM - 0.5)/0.5 + gamma OIQE (PSNR in dB; see
/// `OIQ_PSNR_CEILING_DB` and docs/ode.md for the clamp).
pub fn oiq(psnr_db: f64, ssim: f64, oiqe: f64, weights: &OdeWeights) -> f64 {
    weights.alpha * psnr_db.min(OIQ_PSNR_CEILING_DB) / 50.0
        + weights.beta * (ssim - 0.5) / 0.5
        + weights.gamma * oiqe
}

/// Coefficient of variation: population standard deviation / mean.
pub fn coefficient_of_variation(values: &[f64]) -> Result<f64> {
    if values.is_empty() {
        return Err(MetricsError::InvalidInput(
            "the coefficient of variation needs at least one value".into(),
        ));
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    if !(mean.abs() > 0.0) {
        return Err(MetricsError::InvalidInput(
            "the coefficient of variation needs a non-zero mean".into(),
        ));
    }
    let variance = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    Ok(variance.sqrt() / mean)
}

/// U = exp(-sigma CV(values)).
pub fn uniformity(values: &[f64], weights: &OdeWeights) -> Result<f64> {
    Ok((-weights.sigma * coefficient_of_variation(values)?).exp())
}

/// ODE = lambda_oiq OIQ + lambda_s U_s + lambda_c U_c.
pub fn ode(oiq: f64, u_s: f64, u_c: f64, weights: &OdeWeights) -> f64 {
    weights.lambda_oiq * oiq + weights.lambda_s * u_s + weights.lambda_c * u_c
}

/// The ODE terms of one lens.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OdeBreakdown {
    pub oiq: f64,
    pub u_s: f64,
    pub u_c: f64,
    pub ode: f64,
}

/// ODE from OIQ values per field and channel (`oiq_by_field[field][channel]`, e.g. 5 x 3): OIQ is the mean
/// of all values; U_s uses the per-field means (over channels), U_c the per-channel means (over fields).
/// The paper says only "CV of OIQ values across 5 FoVs / 3 channels"; averaging the other axis first is
/// unicac's reading.
pub fn ode_from_oiq_grid(oiq_by_field: &[Vec<f64>], weights: &OdeWeights) -> Result<OdeBreakdown> {
    let channels = oiq_by_field.first().map_or(0, Vec::len);
    if channels == 0 || oiq_by_field.iter().any(|row| row.len() != channels) {
        return Err(MetricsError::InvalidInput(
            "the OIQ grid must be a non-empty fields x channels table".into(),
        ));
    }
    let fields = oiq_by_field.len();
    let field_means: Vec<f64> = oiq_by_field
        .iter()
        .map(|row| row.iter().sum::<f64>() / channels as f64)
        .collect();
    let channel_means: Vec<f64> = (0..channels)
        .map(|c| oiq_by_field.iter().map(|row| row[c]).sum::<f64>() / fields as f64)
        .collect();
    let oiq = field_means.iter().sum::<f64>() / fields as f64;
    let u_s = uniformity(&field_means, weights)?;
    let u_c = uniformity(&channel_means, weights)?;
    Ok(OdeBreakdown {
        oiq,
        u_s,
        u_c,
        ode: ode(oiq, u_s, u_c, weights),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_defaults() {
        let w = OdeWeights::default();
        assert_eq!((w.alpha, w.beta, w.gamma, w.sigma), (0.4, 0.3, 0.3, 5.0));
        assert_eq!((w.lambda_oiq, w.lambda_s, w.lambda_c), (0.7, 0.3, 0.01));
    }

    #[test]
    fn hand_computed_example() {
        let w = OdeWeights::default();
        // OIQ = 0.4 * 30/50 + 0.3 * (0.9 - 0.5)/0.5 + 0.3 * 0.6 = 0.24 + 0.24 + 0.18 = 0.66.
        assert!((oiq(30.0, 0.9, 0.6, &w) - 0.66).abs() < 1e-15);
        // Values 0.6 and 0.8: mean 0.7, population std 0.1, CV = 1/7, U = exp(-5/7) = 0.48954165955695...
        let cv = coefficient_of_variation(&[0.6, 0.8]).unwrap();
        assert!((cv - 1.0 / 7.0).abs() < 1e-15);
        let u = uniformity(&[0.6, 0.8], &w).unwrap();
        assert!((u - 0.489_541_659_556_952_6).abs() < 1e-15, "{u}");
        // ODE = 0.7 * 0.66 + 0.3 * 0.5 + 0.01 * 1.0 = 0.462 + 0.15 + 0.01 = 0.622.
        assert!((ode(0.66, 0.5, 1.0, &w) - 0.622).abs() < 1e-15);
    }

    #[test]
    fn grid_example() {
        // 2 fields x 2 channels: field means 0.6 and 0.8 (U_s = exp(-5/7)); channel means equal (U_c = 1).
        let grid = vec![vec![0.5, 0.7], vec![0.9, 0.7]];
        let b = ode_from_oiq_grid(&grid, &OdeWeights::default()).unwrap();
        assert!((b.oiq - 0.7).abs() < 1e-15);
        assert!((b.u_s - (-5.0f64 / 7.0).exp()).abs() < 1e-15);
        assert!((b.u_c - 1.0).abs() < 1e-15);
        assert!((b.ode - (0.7 * 0.7 + 0.3 * (-5.0f64 / 7.0).exp() + 0.01)).abs() < 1e-15);
        assert!(ode_from_oiq_grid(&[vec![0.5], vec![0.5, 0.6]], &OdeWeights::default()).is_err());
    }

    #[test]
    fn uniform_values_give_full_uniformity() {
        assert!((uniformity(&[0.4, 0.4, 0.4], &OdeWeights::default()).unwrap() - 1.0).abs() < 1e-14);
        assert!(coefficient_of_variation(&[0.0, 0.0]).is_err());
    }
}
