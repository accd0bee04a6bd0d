//! `LensSpec`: what a lens file says, field for field (docs/lens-format.md). Nothing derived lives
//! here; `Lens::from_spec` validates a spec into the model that analyses use.

use crate::placement::Placement;
use serde::{Deserialize, Serialize};

pub const FORMAT_VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LensSpec {
    pub format_version: u32,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub provenance: String,
    /// Object plane to surface 1 vertex; `None` is an object at infinity.
    #[serde(default)]
    pub object_distance_mm: Option<f64>,
    pub aperture: ApertureSpec,
    pub fields: FieldSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_weights: Option<Vec<f64>>,
    pub wavelengths: Vec<WavelengthSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub primary_wavelength_index: Option<usize>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub glass_catalogs: Vec<String>,
    pub surfaces: Vec<SurfaceSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<SensorSpec>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ApertureSpec {
    EntrancePupilDiameterMm(f64),
    /// Image-space F/# at infinite conjugates: EFL / EPD (Zemax FNUM).
    FNumber(f64),
    /// The stop surface's `semi_diameter_mm` sets the aperture (Zemax FLOA, "float by stop size").
    FloatByStopSize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum FieldSpec {
    /// Object-space chief-ray angles in the y-z plane.
    AnglesDeg(Vec<f64>),
    /// Paraxial image heights.
    ImageHeightsMm(Vec<f64>),
}

impl FieldSpec {
    pub fn values(&self) -> &[f64] {
        match self {
            FieldSpec::AnglesDeg(v) | FieldSpec::ImageHeightsMm(v) => v,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WavelengthSpec {
    pub wavelength_um: f64,
    #[serde(default = "one")]
    pub weight: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceType {
    #[default]
    Standard,
    EvenAsphere,
}

impl SurfaceType {
    fn is_standard(&self) -> bool {
        *self == SurfaceType::Standard
    }
}

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceSpec {
    #[serde(default, rename = "type", skip_serializing_if = "SurfaceType::is_standard")]
    pub surface_type: SurfaceType,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub curvature_per_mm: Option<f64>,
    /// Alternative to `curvature_per_mm`; 0 or null is a plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub conic: f64,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub aspheric_coefficients: Vec<f64>,
    #[serde(default)]
    pub thickness_mm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<MaterialSpec>,
    /// The glass after this surface departs from its material's index by this at every wavelength
    /// (dispersion kept): a melt's index error, as `unicac tolerance` writes built units; absent: 0.
    #[serde(default, skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub index_offset: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub semi_diameter_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub stop: bool,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub label: String,
    /// Decentre and tilt of this surface alone (docs/lens-format.md "Decentres and tilts"); absent: 0.
    #[serde(default, skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub decentre_x_mm: f64,
    #[serde(default, skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub decentre_y_mm: f64,
    #[serde(default, skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub tilt_x_deg: f64,
    #[serde(default, skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub tilt_y_deg: f64,
}

impl SurfaceSpec {
    /// Curvature from whichever of `curvature_per_mm` / `radius_mm` was given (a plane when neither).
    pub fn curvature(&self) -> f64 {
        match (self.curvature_per_mm, self.radius_mm) {
            (Some(c), _) => c,
            (None, Some(r)) if r != 0.0 && r.is_finite() => 1.0 / r,
            _ => 0.0,
        }
    }

    /// The surface's decentre and tilt as written (validated by `Lens::from_spec`).
    pub fn placement(&self) -> Placement {
        Placement {
            decentre_x_mm: self.decentre_x_mm,
            decentre_y_mm: self.decentre_y_mm,
            tilt_x_deg: self.tilt_x_deg,
            tilt_y_deg: self.tilt_y_deg,
        }
    }

    /// Sets the four placement fields from `placement`.
    pub fn set_placement(&mut self, placement: Placement) {
        self.decentre_x_mm = placement.decentre_x_mm;
        self.decentre_y_mm = placement.decentre_y_mm;
        self.tilt_x_deg = placement.tilt_x_deg;
        self.tilt_y_deg = placement.tilt_y_deg;
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MaterialSpec {
    /// A catalogue glass name (optionally `CATALOG:NAME`) or `AIR`.
    Named(String),
    /// A model glass.
    Model { nd: f64, vd: f64 },
}

impl MaterialSpec {
    pub fn is_air(&self) -> bool {
        matches!(self, MaterialSpec::Named(n) if n.eq_ignore_ascii_case("AIR"))
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    pub width_mm: f64,
    pub height_mm: f64,
    #[serde(rename = "pixel_pitch_um")]
    pub pixel_um: f64,
}

impl SensorSpec {
    pub fn half_diagonal_mm(&self) -> f64 {
        0.5 * self.width_mm.hypot(self.height_mm)
    }
}
