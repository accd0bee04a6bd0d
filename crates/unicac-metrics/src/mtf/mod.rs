//! Modulation transfer functions: measured from a slanted edge ([`slanted_edge`], ISO 12233) or computed
//! exactly from a sampled PSF ([`psf`]), and the summary numbers of an MTF curve used by OIQE: MTF50 and the
//! normalised MTF area (Imatest's "MTF area normalized": the area under the DC-normalised MTF from 0 to
//! Nyquist divided by Nyquist, so a perfect system scores 1).
//!
//! Frequencies are in cycles per pixel; Nyquist is 0.5 cy/px.

pub mod psf;
pub mod slanted_edge;

use serde::{Deserialize, Serialize};

use crate::error::{MetricsError, Result};

/// The sampling (Nyquist) frequency of a pixel grid, in cycles per pixel.
pub const NYQUIST_CY_PER_PX: f64 = 0.5;

/// Where the MTF50 value came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mtf50Kind {
    /// The MTF first falls below 0.5 at or below Nyquist; the value is interpolated linearly there.
    BelowNyquist,
    /// The first crossing of 0.5 lies above Nyquist (within the measured range); interpolated there.
    AboveNyquist,
    /// The MTF stays at or above 0.5 over the whole curve; the value is clamped to the curve's last frequency.
    NotReached,
}

/// MTF50 and the normalised area of one MTF curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MtfSummary {
    /// Frequency of the first 0.5 crossing, cy/px (see `mtf50_kind`).
    pub mtf50_cy_per_px: f64,
    pub mtf50_kind: Mtf50Kind,
    /// Area under the MTF from 0 to Nyquist, divided by Nyquist (1 for a perfect system).
    pub mtf_area: f64,
}

/// MTF50 and area of a curve sampled at increasing `frequency` (cy/px, starting at 0) with values `mtf`
/// (normalised to 1 at DC). The curve must reach Nyquist.
pub fn summarize(frequency: &[f64], mtf: &[f64]) -> Result<MtfSummary> {
    check_curve(frequency, mtf)?;
    let (mtf50_cy_per_px, mtf50_kind) = mtf50(frequency, mtf);
    Ok(MtfSummary {
        mtf50_cy_per_px,
        mtf50_kind,
        mtf_area: mtf_area(frequency, mtf),
    })
}

fn check_curve(frequency: &[f64], mtf: &[f64]) -> Result<()> {
    if frequency.len() != mtf.len() || frequency.len() < 2 {
        return Err(MetricsError::InvalidInput(
            "an MTF curve needs matching arrays of at least 2 samples".into(),
        ));
    }
    if frequency.windows(2).any(|p| p[1] <= p[0]) {
        return Err(MetricsError::InvalidInput("MTF frequencies must increase".into()));
    }
    if frequency[frequency.len() - 1] < NYQUIST_CY_PER_PX - 1e-12 {
        return Err(MetricsError::InvalidInput(
            "the MTF curve does not reach Nyquist (0.5 cy/px)".into(),
        ));
    }
    Ok(())
}

/// First frequency where the curve falls below 0.5, by linear interpolation between the bracketing samples.
fn mtf50(frequency: &[f64], mtf: &[f64]) -> (f64, Mtf50Kind) {
    for i in 1..mtf.len() {
        if mtf[i] < 0.5 && mtf[i - 1] >= 0.5 {
            let t = (mtf[i - 1] - 0.5) / (mtf[i - 1] - mtf[i]);
            let f = frequency[i - 1] + t * (frequency[i] - frequency[i - 1]);
            let kind = if f <= NYQUIST_CY_PER_PX {
                Mtf50Kind::BelowNyquist
            } else {
                Mtf50Kind::AboveNyquist
            };
            return (f, kind);
        }
    }
    (frequency[frequency.len() - 1], Mtf50Kind::NotReached)
}

/// Trapezoidal area under the curve from 0 to Nyquist (the last segment interpolated), divided by Nyquist.
fn mtf_area(frequency: &[f64], mtf: &[f64]) -> f64 {
    let mut area = 0.0;
    for i in 1..frequency.len() {
        let (f0, f1) = (frequency[i - 1], frequency[i]);
        if f0 >= NYQUIST_CY_PER_PX {
            break;
        }
        let (m0, mut m1, mut f1c) = (mtf[i - 1], mtf[i], f1);
        if f1 > NYQUIST_CY_PER_PX {
            f1c = NYQUIST_CY_PER_PX;
            m1 = m0 + (mtf[i] - m0) * (f1c - f0) / (f1 - f0);
        }
        area += 0.5 * (m0 + m1) * (f1c - f0);
    }
    area / NYQUIST_CY_PER_PX
}

/// The normalised sinc, sin(pi x) / (pi x).
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-8 {
        1.0
    } else {
        let px = std::f64::consts::PI * x;
        px.sin() / px
    }
}

/// MTF of a square pixel aperture (100% fill factor, side 1 px) along a direction at `angle_rad` from the
/// x axis: sinc(f cos a) sinc(f sin a). Along an axis this is sinc(f).
pub fn pixel_aperture_mtf(frequency_cy_per_px: f64, angle_rad: f64) -> f64 {
    (sinc(frequency_cy_per_px * angle_rad.cos()) * sinc(frequency_cy_per_px * angle_rad.sin())).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_line_mtf_has_known_summary() {
        // MTF = 1 - f: MTF50 = 0.5 exactly, area = (0.5 - 0.125) / 0.5 = 0.75.
        let f: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
        let m: Vec<f64> = f.iter().map(|f| 1.0 - f).collect();
        let s = summarize(&f, &m).unwrap();
        assert!((s.mtf50_cy_per_px - 0.5).abs() < 1e-12);
        assert_eq!(s.mtf50_kind, Mtf50Kind::BelowNyquist);
        assert!((s.mtf_area - 0.75).abs() < 1e-12);
    }

    #[test]
    fn flat_mtf_is_not_reached_and_area_one() {
        let f = [0.0, 0.3, 0.7];
        let m = [1.0, 1.0, 1.0];
        let s = summarize(&f, &m).unwrap();
        assert_eq!(s.mtf50_kind, Mtf50Kind::NotReached);
        assert_eq!(s.mtf50_cy_per_px, 0.7);
        assert!((s.mtf_area - 1.0).abs() < 1e-12);
    }

    #[test]
    fn crossing_above_nyquist_is_flagged() {
        let f = [0.0, 0.5, 1.0];
        let m = [1.0, 0.6, 0.2];
        let s = summarize(&f, &m).unwrap();
        assert_eq!(s.mtf50_kind, Mtf50Kind::AboveNyquist);
        assert!((s.mtf50_cy_per_px - 0.625).abs() < 1e-12);
    }

    #[test]
    fn short_curve_is_rejected() {
        assert!(summarize(&[0.0, 0.4], &[1.0, 0.5]).is_err());
    }

    #[test]
    fn pixel_aperture_on_axis_is_sinc() {
        assert!((pixel_aperture_mtf(0.5, 0.0) - 2.0 / std::f64::consts::PI).abs() < 1e-15);
    }
}
