//! What to design: the specification (elements, field, aperture, stop position, focal length,
//! wavelengths) and the constraints a lens designer would accept by default. Lengths scale with the
//! focal length: defaults are stated for f = 50 mm and multiplied by f / 50.

use crate::error::{DesignError, Result};
use serde::{Deserialize, Serialize};
use unicac_optics::material::{LINE_C_UM, LINE_D_UM, LINE_F_UM};

/// Where the aperture stop sits relative to the elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopPosition {
    Front,
    Middle,
    Back,
}

impl StopPosition {
    pub fn name(&self) -> &'static str {
        match self {
            StopPosition::Front => "front",
            StopPosition::Middle => "middle",
            StopPosition::Back => "back",
        }
    }
}

impl std::str::FromStr for StopPosition {
    type Err = String;
    fn from_str(text: &str) -> std::result::Result<Self, String> {
        match text {
            "front" => Ok(StopPosition::Front),
            "middle" => Ok(StopPosition::Middle),
            "back" => Ok(StopPosition::Back),
            _ => Err(format!("'{text}': expected front, middle or back")),
        }
    }
}

/// Shortest focal length designed for (mm): below phone-camera modules (about 4 mm), where lengths
/// are still far above the tracer's tolerances.
pub const MIN_FOCAL_LENGTH_MM: f64 = 1.0;
/// Longest focal length designed for (mm): beyond long telephoto lenses.
pub const MAX_FOCAL_LENGTH_MM: f64 = 10_000.0;

/// Limits on the design. Every one is checked on every accepted lens and reported by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Constraints {
    /// Glass centre thickness (mm).
    pub glass_center_mm: [f64; 2],
    /// Air gap on the axis (mm), including the gaps next to the stop.
    pub air_center_mm: [f64; 2],
    /// Smallest glass edge thickness (mm) at the element's semi-diameter.
    pub glass_edge_min_mm: f64,
    /// Smallest air gap between neighbouring surfaces at any height up to the smaller semi-diameter (mm).
    pub air_edge_min_mm: f64,
    /// Last surface to the image (mm).
    pub back_focal_min_mm: f64,
    /// Surface 1 to the image (mm).
    pub total_track_max_mm: f64,
    /// Largest |EFL / f - 1|.
    pub focal_tolerance: f64,
    /// Largest |distortion| (%) over the fields.
    pub distortion_max_percent: f64,
    /// Smallest relative illumination at the edge of the field.
    pub relative_illumination_min: f64,
    /// Curvature bound: |c| f <= this.
    pub curvature_max_times_f: f64,
    /// Steepest surface normal on any surface over its semi-diameter (deg).
    pub surface_slope_max_deg: f64,
    /// Largest departure of an asphere from its best-fit sphere (mm).
    pub asphere_departure_max_mm: f64,
    /// Largest distance of a model glass (nd, Vd) from the nearest catalogue glass in the normalised
    /// glass map (nd / 0.1, Vd / 10).
    pub glass_distance_max: f64,
}

impl Constraints {
    /// Every limit is a finite number >= 0 (NaN would accept every design or none); an edge thickness
    /// is at most the longest track allowed, which no lens could hold.
    pub fn validate(&self, focal_length_mm: f64) -> Result<()> {
        let named = [
            ("glass_center_mm", self.glass_center_mm[0]),
            ("glass_center_mm", self.glass_center_mm[1]),
            ("air_center_mm", self.air_center_mm[0]),
            ("air_center_mm", self.air_center_mm[1]),
            ("glass_edge_min_mm", self.glass_edge_min_mm),
            ("air_edge_min_mm", self.air_edge_min_mm),
            ("back_focal_min_mm", self.back_focal_min_mm),
            ("total_track_max_mm", self.total_track_max_mm),
            ("focal_tolerance", self.focal_tolerance),
            ("distortion_max_percent", self.distortion_max_percent),
            ("relative_illumination_min", self.relative_illumination_min),
            ("curvature_max_times_f", self.curvature_max_times_f),
            ("surface_slope_max_deg", self.surface_slope_max_deg),
            ("asphere_departure_max_mm", self.asphere_departure_max_mm),
            ("glass_distance_max", self.glass_distance_max),
        ];
        for (field, value) in named {
            if !(value.is_finite() && value >= 0.0) {
                return Err(DesignError::spec(
                    format!("constraints.{field}"),
                    format!("{value:?} must be a finite number >= 0"),
                ));
            }
        }
        for (field, value) in [
            ("glass_edge_min_mm", self.glass_edge_min_mm),
            ("air_edge_min_mm", self.air_edge_min_mm),
        ] {
            if value > self.total_track_max_mm {
                return Err(DesignError::spec(
                    format!("constraints.{field}"),
                    format!(
                        "{value:?} mm must be at most the longest track allowed, {} mm (focal length {focal_length_mm} mm)",
                        self.total_track_max_mm
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Defaults for focal length `f_mm`.
    pub fn for_focal_length(f_mm: f64, elements: usize) -> Constraints {
        let s = f_mm / 50.0;
        Constraints {
            glass_center_mm: [1.0 * s, 10.0 * s],
            air_center_mm: [0.1 * s, 20.0 * s],
            glass_edge_min_mm: 0.7 * s,
            air_edge_min_mm: 0.1 * s,
            back_focal_min_mm: 5.0 * s,
            // Room for the elements and the back focus: about f, plus about f/4 per element.
            total_track_max_mm: f_mm * (1.6 + 0.25 * elements as f64),
            focal_tolerance: 0.01,
            distortion_max_percent: 5.0,
            relative_illumination_min: 0.25,
            curvature_max_times_f: 4.0,
            surface_slope_max_deg: 55.0,
            asphere_departure_max_mm: 0.02 * f_mm,
            glass_distance_max: 0.25,
        }
    }
}

/// A lens to design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignSpec {
    pub elements: usize,
    pub half_fov_deg: f64,
    pub f_number: f64,
    pub stop: StopPosition,
    pub focal_length_mm: f64,
    /// Design wavelengths (um) and weights; the middle one is primary.
    pub wavelengths_um: Vec<f64>,
    pub wavelength_weights: Vec<f64>,
    pub primary_wavelength_index: usize,
    /// Fields as fractions of the image height (angle = atan(fraction tan(half_fov))).
    pub field_fractions: Vec<f64>,
    pub aspheric: bool,
    pub constraints: Constraints,
}

/// Focal length that puts the full field on the sensor's half diagonal.
pub fn focal_length_for_sensor(half_diagonal_mm: f64, half_fov_deg: f64) -> f64 {
    half_diagonal_mm / half_fov_deg.to_radians().tan()
}

impl DesignSpec {
    /// A spec with default wavelengths (F, d, C), fields (0, 0.7, 1 of the image height) and constraints.
    pub fn new(
        elements: usize,
        half_fov_deg: f64,
        f_number: f64,
        stop: StopPosition,
        focal_length_mm: f64,
    ) -> Result<DesignSpec> {
        let spec = DesignSpec {
            elements,
            half_fov_deg,
            f_number,
            stop,
            focal_length_mm,
            wavelengths_um: vec![LINE_F_UM, LINE_D_UM, LINE_C_UM],
            wavelength_weights: vec![1.0; 3],
            primary_wavelength_index: 1,
            field_fractions: vec![0.0, 0.7, 1.0],
            aspheric: false,
            constraints: Constraints::for_focal_length(focal_length_mm, elements),
        };
        spec.validate()?;
        Ok(spec)
    }

    pub fn validate(&self) -> Result<()> {
        if !(1..=6).contains(&self.elements) {
            return Err(DesignError::spec("elements", "must be 1 to 6"));
        }
        if self.elements == 1 && self.stop == StopPosition::Middle {
            return Err(DesignError::spec(
                "stop",
                "a single element has no middle: use front or back",
            ));
        }
        if !(self.half_fov_deg > 0.0 && self.half_fov_deg < 70.0) {
            return Err(DesignError::spec("half_fov_deg", "must lie in (0, 70)"));
        }
        if !(self.f_number >= 0.9 && self.f_number <= 32.0) {
            return Err(DesignError::spec("f_number", "must lie in [0.9, 32]"));
        }
        if !(MIN_FOCAL_LENGTH_MM..=MAX_FOCAL_LENGTH_MM).contains(&self.focal_length_mm) {
            return Err(DesignError::spec(
                "focal_length_mm",
                format!(
                    "{:?} must lie in [{MIN_FOCAL_LENGTH_MM}, {MAX_FOCAL_LENGTH_MM}] mm",
                    self.focal_length_mm
                ),
            ));
        }
        self.constraints.validate(self.focal_length_mm)?;
        let w = &self.wavelengths_um;
        if w.is_empty()
            || w.len() != self.wavelength_weights.len()
            || self.primary_wavelength_index >= w.len()
            || w.iter().any(|l| !(*l > 0.3 && *l < 2.0))
            || self.wavelength_weights.iter().any(|v| !(*v >= 0.0))
        {
            return Err(DesignError::spec(
                "wavelengths",
                "need 0.3-2 um wavelengths with one non-negative weight each and a valid primary",
            ));
        }
        // Relative illumination is normalised by the on-axis field, so the fields start there.
        if self.field_fractions.first() != Some(&0.0)
            || self.field_fractions.iter().any(|f| !(0.0..=1.0).contains(f))
        {
            return Err(DesignError::spec(
                "field_fractions",
                "must start at 0 and lie in [0, 1]",
            ));
        }
        Ok(())
    }

    /// Field angles (deg) of the design fields.
    pub fn field_angles_deg(&self) -> Vec<f64> {
        let t = self.half_fov_deg.to_radians().tan();
        self.field_fractions
            .iter()
            .map(|h| (h * t).atan().to_degrees())
            .collect()
    }

    pub fn primary_wavelength_um(&self) -> f64 {
        self.wavelengths_um[self.primary_wavelength_index]
    }

    /// A short unique name: e3_h20_f5_middle_f50 (+ _asph).
    pub fn slug(&self) -> String {
        format!(
            "e{}_h{}_f{}_{}_f{}{}",
            self.elements,
            trim(self.half_fov_deg),
            trim(self.f_number),
            self.stop.name(),
            trim(self.focal_length_mm),
            if self.aspheric { "_asph" } else { "" }
        )
    }
}

fn trim(v: f64) -> String {
    let text = format!("{v:.3}");
    text.trim_end_matches('0').trim_end_matches('.').replace('.', "p")
}

/// The paper's specification grid: elements 1-6, half field 20/30/40 deg, F/2, 3, 4, stop front,
/// middle, back (no middle for one element).
pub fn paper_grid(
    elements: &[usize],
    half_fovs_deg: &[f64],
    f_numbers: &[f64],
    stops: &[StopPosition],
    focal_length_mm: f64,
    aspheric: bool,
) -> Result<Vec<DesignSpec>> {
    let mut specs = Vec::new();
    for &e in elements {
        for &h in half_fovs_deg {
            for &f in f_numbers {
                for &stop in stops {
                    if e == 1 && stop == StopPosition::Middle {
                        continue;
                    }
                    let mut spec = DesignSpec::new(e, h, f, stop, focal_length_mm)?;
                    spec.aspheric = aspheric;
                    specs.push(spec);
                }
            }
        }
    }
    Ok(specs)
}

/// A sensor's size (mm), as the faces write it: `WIDTHxHEIGHT` (e.g. `36x24`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorSize {
    pub width_mm: f64,
    pub height_mm: f64,
}

impl std::str::FromStr for SensorSize {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<SensorSize, String> {
        let expected = || format!("{text:?}: expected WIDTHxHEIGHT in mm, e.g. 36x24");
        let (w, h) = text.split_once(['x', 'X']).ok_or_else(expected)?;
        let side = |v: &str| v.trim().parse::<f64>().map_err(|_| expected());
        let (width_mm, height_mm) = (side(w)?, side(h)?);
        if !(width_mm > 0.0 && height_mm > 0.0 && width_mm.is_finite() && height_mm.is_finite()) {
            return Err(format!(
                "{text:?}: width and height must be positive, finite millimetres"
            ));
        }
        Ok(SensorSize { width_mm, height_mm })
    }
}

/// How each specification's focal length is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FocalLength {
    /// The same for every specification.
    Fixed { focal_length_mm: f64 },
    /// So that the full field fills the sensor's half diagonal (it follows each half field).
    FillsSensor(SensorSize),
}

impl FocalLength {
    /// 50 mm, the paper's.
    pub const DEFAULT: FocalLength = FocalLength::Fixed {
        focal_length_mm: 50.0,
    };

    pub fn for_half_fov_deg(self, half_fov_deg: f64) -> f64 {
        match self {
            FocalLength::Fixed { focal_length_mm } => focal_length_mm,
            FocalLength::FillsSensor(sensor) => {
                focal_length_for_sensor(0.5 * sensor.width_mm.hypot(sensor.height_mm), half_fov_deg)
            }
        }
    }
}

/// A specification grid: the values of each axis (an empty axis takes the paper's, `GRID_*`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Grid {
    pub elements: Vec<usize>,
    pub half_fovs_deg: Vec<f64>,
    pub f_numbers: Vec<f64>,
    pub stops: Vec<StopPosition>,
}

impl Grid {
    /// Every specification of the grid, in the order a run designs them: by element count, then half
    /// field, f-number and stop.
    pub fn specs(&self, focal: FocalLength, aspheric: bool) -> Result<Vec<DesignSpec>> {
        fn or<T: Clone>(given: &[T], paper: &[T]) -> Vec<T> {
            if given.is_empty() { paper } else { given }.to_vec()
        }
        let (elements, f_numbers, stops) = (
            or(&self.elements, &GRID_ELEMENTS),
            or(&self.f_numbers, &GRID_F_NUMBERS),
            or(&self.stops, &GRID_STOPS),
        );
        let mut all = Vec::new();
        for h in or(&self.half_fovs_deg, &GRID_HALF_FOV_DEG) {
            let focal_length_mm = focal.for_half_fov_deg(h);
            all.extend(paper_grid(
                &elements,
                &[h],
                &f_numbers,
                &stops,
                focal_length_mm,
                aspheric,
            )?);
        }
        all.sort_by_key(|s| s.elements);
        Ok(all)
    }
}

pub const GRID_ELEMENTS: [usize; 6] = [1, 2, 3, 4, 5, 6];
pub const GRID_HALF_FOV_DEG: [f64; 3] = [20.0, 30.0, 40.0];
pub const GRID_F_NUMBERS: [f64; 3] = [2.0, 3.0, 4.0];
pub const GRID_STOPS: [StopPosition; 3] = [StopPosition::Front, StopPosition::Middle, StopPosition::Back];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_runs_by_elements_and_a_sensor_sets_each_focal_length() {
        let grid = Grid {
            elements: vec![2, 1],
            half_fovs_deg: vec![20.0, 40.0],
            f_numbers: vec![4.0],
            stops: vec![StopPosition::Front],
        };
        let sensor: SensorSize = "36x24".parse().unwrap();
        let specs = grid.specs(FocalLength::FillsSensor(sensor), false).unwrap();
        let order: Vec<(usize, f64)> = specs.iter().map(|s| (s.elements, s.half_fov_deg)).collect();
        assert_eq!(order, [(1, 20.0), (1, 40.0), (2, 20.0), (2, 40.0)]);
        let half_diagonal_mm = 0.5 * 36f64.hypot(24.0);
        for spec in &specs {
            let image_height_mm = spec.focal_length_mm * spec.half_fov_deg.to_radians().tan();
            assert!((image_height_mm - half_diagonal_mm).abs() < 1e-9);
        }
        assert_eq!(
            Grid::default().specs(FocalLength::DEFAULT, false).unwrap().len(),
            6 * 3 * 3 * 3 - 9
        );
        for bad in ["36", "0x24", "infx24", "ax24"] {
            assert!(
                bad.parse::<SensorSize>()
                    .unwrap_err()
                    .contains(&format!("{bad:?}")),
                "{bad}"
            );
        }
    }

    #[test]
    fn paper_grid_has_every_combination_but_a_singlet_middle_stop() {
        let grid = paper_grid(
            &GRID_ELEMENTS,
            &GRID_HALF_FOV_DEG,
            &GRID_F_NUMBERS,
            &GRID_STOPS,
            50.0,
            false,
        )
        .unwrap();
        assert_eq!(grid.len(), 6 * 3 * 3 * 3 - 3 * 3);
        assert_eq!(grid[0].slug(), "e1_h20_f2_front_f50");
    }

    #[test]
    fn bad_specs_name_the_field() {
        let err = DesignSpec::new(7, 20.0, 4.0, StopPosition::Front, 50.0).unwrap_err();
        assert!(err.to_string().contains("elements"), "{err}");
        let err = DesignSpec::new(1, 20.0, 4.0, StopPosition::Middle, 50.0).unwrap_err();
        assert!(err.to_string().contains("stop"), "{err}");
    }
}
