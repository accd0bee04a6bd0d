//! The tolerance file (TOL.json): the +- limit of each kind of manufacturing error, how errors are
//! drawn within their limits, and the compensator. Conventions in docs/tolerancing.md.

use crate::error::{ToleranceError, ToleranceResult};
use serde::{Deserialize, Serialize};

/// How one error is drawn within its +- limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Distribution {
    /// Gaussian with sigma = limit / 2, truncated at the limit (+-2 sigma): Zemax's default Monte
    /// Carlo statistics.
    #[default]
    Normal,
    /// Uniform over [-limit, limit].
    Uniform,
}

/// What is adjusted on each built unit before it is graded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Compensator {
    /// The image surface moves along the axis to the focus of least RMS spot radius (the sensor is
    /// shimmed at assembly).
    #[default]
    BackFocus,
    /// The sensor stays where the nominal design put it.
    None,
}

/// +- limits of every error kind (0: not toleranced). Each drawn independently per surface, element
/// or glass.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToleranceSpec {
    #[serde(default)]
    pub distribution: Distribution,
    #[serde(default)]
    pub compensator: Compensator,
    /// Relative error of every curved surface's radius (R -> R (1 + e)); plane surfaces keep theirs.
    #[serde(default)]
    pub radius_fraction: f64,
    /// Error of every axial thickness and air gap but the last (the back focus); later surfaces
    /// move with it, the sensor stays.
    #[serde(default)]
    pub thickness_mm: f64,
    /// Decentre of each surface alone, in x and in y.
    #[serde(default)]
    pub surface_decentre_mm: f64,
    /// Tilt of each surface alone about its vertex, about x and about y.
    #[serde(default)]
    pub surface_tilt_deg: f64,
    /// Decentre of each element (a cemented group counts as one) as a rigid body, in x and in y.
    #[serde(default)]
    pub element_decentre_mm: f64,
    /// Tilt of each element as a rigid body about its front vertex, about x and about y.
    #[serde(default)]
    pub element_tilt_deg: f64,
    /// Refractive index error of each glass (the same at every wavelength).
    #[serde(default)]
    pub index: f64,
}

/// The largest limit accepted per kind: beyond them a "tolerance" is a different lens.
pub const MAX_RADIUS_FRACTION: f64 = 0.05;
pub const MAX_THICKNESS_MM: f64 = 0.5;
pub const MAX_DECENTRE_MM: f64 = 0.5;
pub const MAX_TILT_DEG: f64 = 1.0;
pub const MAX_INDEX: f64 = 0.01;

impl ToleranceSpec {
    /// Reads and checks a tolerance file; every error names the file and the field.
    pub fn from_json(text: &str) -> ToleranceResult<ToleranceSpec> {
        let spec: ToleranceSpec = serde_json::from_str(text).map_err(|e| ToleranceError::InvalidSpec {
            field: None,
            reason: e.to_string(),
        })?;
        spec.check()?;
        Ok(spec)
    }

    /// Every limit finite, non-negative and within its maximum; at least one non-zero.
    pub fn check(&self) -> ToleranceResult<()> {
        for (field, value, max) in self.limits() {
            if !(value.is_finite() && (0.0..=max).contains(&value)) {
                return Err(ToleranceError::InvalidSpec {
                    field: Some(field.into()),
                    reason: format!("{value}: must lie between 0 and {max}"),
                });
            }
        }
        if self.limits().iter().all(|(_, value, _)| *value == 0.0) {
            return Err(ToleranceError::InvalidSpec {
                field: None,
                reason: "every limit is 0: give at least one of radius_fraction, thickness_mm, \
                         surface_decentre_mm, surface_tilt_deg, element_decentre_mm, element_tilt_deg, index"
                    .into(),
            });
        }
        Ok(())
    }

    fn limits(&self) -> [(&'static str, f64, f64); 7] {
        [
            ("radius_fraction", self.radius_fraction, MAX_RADIUS_FRACTION),
            ("thickness_mm", self.thickness_mm, MAX_THICKNESS_MM),
            ("surface_decentre_mm", self.surface_decentre_mm, MAX_DECENTRE_MM),
            ("surface_tilt_deg", self.surface_tilt_deg, MAX_TILT_DEG),
            ("element_decentre_mm", self.element_decentre_mm, MAX_DECENTRE_MM),
            ("element_tilt_deg", self.element_tilt_deg, MAX_TILT_DEG),
            ("index", self.index, MAX_INDEX),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_checked_field_by_field() {
        let spec =
            ToleranceSpec::from_json(r#"{"element_decentre_mm": 0.02, "distribution": "uniform"}"#).unwrap();
        assert_eq!(spec.distribution, Distribution::Uniform);
        assert_eq!(spec.compensator, Compensator::BackFocus);
        let message = |text: &str| ToleranceSpec::from_json(text).unwrap_err().to_string();
        assert!(message(r#"{"index": -0.001}"#).contains("index"));
        assert!(message(r#"{"element_tilt_deg": 5}"#).contains("element_tilt_deg"));
        assert!(message(r#"{"decenter_mm": 0.1}"#).contains("decenter_mm"));
        assert!(message("{}").contains("every limit is 0"));
        assert!(message(r#"{"index": 0.001, "distribution": "gauss"}"#).contains("gauss"));
    }
}
