//! OIQE, the MTF-based optical image quality score on a [0, 1] scale that enters the UniCAC OIQ term
//! (paper Eq. 4, citing Jiang et al. 2024, "minimalist" optical design). The paper gives no formula and no
//! code for OIQE, only that it is MTF-based and "quantifies optical image quality on a [0, 1] scale". This
//! module's definition is therefore unicac's own, documented in `docs/ode.md` (section "OIQE"):
//!
//! per direction d (tangential, sagittal):
//!   q_d = (w50 * min(MTF50_d / 0.5, 1) + wA * clamp(A_d, 0, 1)) / (w50 + wA),
//!   A_d = (1 / 0.5) * integral of MTF_d from 0 to 0.5 cy/px (Imatest "MTF area normalized"),
//! OIQE = mean of q_d over the directions (over fields and channels too, when several are given),
//! with w50 = wA = 0.5 by default.
//!
//! Why this combination: MTF50 is the standard single-number sharpness measure (Imatest, ISO 12233
//! practice) and dividing by Nyquist maps it to [0, 1] with 1 for a system that keeps half contrast up to
//! the sampling limit; the normalised area adds the contrast at all frequencies up to Nyquist (MTF50 is
//! blind to the shape of the curve, e.g. a low-contrast halo from flare or spherical aberration). Both are
//! 0 for a useless lens and 1 for a perfect one, both are monotonic in blur, and equal weights avoid
//! inventing a preference. Clamping the area removes the reward for oversharpening (MTF > 1).

use serde::{Deserialize, Serialize};

use crate::error::{MetricsError, Result};
use crate::mtf::{MtfSummary, NYQUIST_CY_PER_PX};

/// Weights of the two MTF summary numbers in OIQE (normalised by their sum).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OiqeWeights {
    pub mtf50: f64,
    pub area: f64,
}

impl Default for OiqeWeights {
    fn default() -> Self {
        OiqeWeights {
            mtf50: 0.5,
            area: 0.5,
        }
    }
}

/// The OIQE score of one MTF curve (one direction), in [0, 1].
pub fn oiqe_direction(summary: &MtfSummary, weights: &OiqeWeights) -> Result<f64> {
    let total = weights.mtf50 + weights.area;
    if !(weights.mtf50 >= 0.0 && weights.area >= 0.0 && total > 0.0) {
        return Err(MetricsError::InvalidInput(
            "OIQE weights must be non-negative with a positive sum".into(),
        ));
    }
    let mtf50 = (summary.mtf50_cy_per_px / NYQUIST_CY_PER_PX).clamp(0.0, 1.0);
    let area = summary.mtf_area.clamp(0.0, 1.0);
    Ok((weights.mtf50 * mtf50 + weights.area * area) / total)
}

/// OIQE from the tangential and sagittal MTF of one field and channel.
pub fn oiqe(tangential: &MtfSummary, sagittal: &MtfSummary, weights: &OiqeWeights) -> Result<f64> {
    oiqe_mean(&[*tangential, *sagittal], weights)
}

/// OIQE as the mean over any set of MTF curves (e.g. both directions at every field and channel).
pub fn oiqe_mean(summaries: &[MtfSummary], weights: &OiqeWeights) -> Result<f64> {
    if summaries.is_empty() {
        return Err(MetricsError::InvalidInput(
            "OIQE needs at least one MTF curve".into(),
        ));
    }
    let mut total = 0.0;
    for summary in summaries {
        total += oiqe_direction(summary, weights)?;
    }
    Ok(total / summaries.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mtf::Mtf50Kind;

    fn summary(mtf50: f64, area: f64) -> MtfSummary {
        MtfSummary {
            mtf50_cy_per_px: mtf50,
            mtf50_kind: Mtf50Kind::BelowNyquist,
            mtf_area: area,
        }
    }

    #[test]
    fn hand_computed_value() {
        // Tangential: 0.5 * 0.25/0.5 + 0.5 * 0.6 = 0.55; sagittal: 0.5 * 1 (clamped) + 0.5 * 1 (clamped) = 1.
        let w = OiqeWeights::default();
        let q = oiqe(&summary(0.25, 0.6), &summary(0.7, 1.2), &w).unwrap();
        assert!((q - 0.775).abs() < 1e-15);
    }

    #[test]
    fn bad_weights_and_empty_input_are_errors() {
        let s = summary(0.2, 0.5);
        assert!(oiqe_direction(
            &s,
            &OiqeWeights {
                mtf50: -1.0,
                area: 2.0
            }
        )
        .is_err());
        assert!(oiqe_direction(
            &s,
            &OiqeWeights {
                mtf50: 0.0,
                area: 0.0
            }
        )
        .is_err());
        assert!(oiqe_mean(&[], &OiqeWeights::default()).is_err());
    }
}
