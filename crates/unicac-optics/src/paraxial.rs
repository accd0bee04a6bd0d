//! First-order (paraxial) analysis by y-nu ray tracing.
//!
//! A paraxial ray is (y, nu) at a surface vertex plane, nu = n * u the reduced slope. Refraction:
//! nu' = nu - y * phi with phi = c_par (n' - n); transfer over t in index n': y' = y + t * nu' / n'.
//! The paraxial curvature of an even asphere includes its r^2 term: c_par = c + 2 a_2.
//! Conventions (docs/conventions.md): global z from surface 1's vertex, signed; field angle F > 0 means a
//! chief ray travelling towards +y (an object below the axis), so a positive lens images it at +y.

use crate::error::{OpticsError, Result};
use crate::lens::Lens;
use crate::spec::{ApertureSpec, FieldSpec};
use serde::Serialize;

/// First-order properties at one wavelength. Positions are global z (mm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FirstOrder {
    pub wavelength_um: f64,
    pub efl_mm: f64,
    /// Last optical surface vertex (the surface before the image surface) to the paraxial focus.
    pub bfl_mm: f64,
    /// Surface 1 vertex to the front focal point (negative: in front of the lens).
    pub ffl_mm: f64,
    pub epd_mm: f64,
    pub entrance_pupil_z_mm: f64,
    /// `None` when the exit pupil is at infinity (image-space telecentric).
    pub exit_pupil_z_mm: Option<f64>,
    pub exit_pupil_diameter_mm: Option<f64>,
    /// EFL / EPD (image-space F/# at infinite conjugates, Zemax "Image Space F/#").
    pub f_number: f64,
    /// 1 / (2 n' |u'|) of the paraxial marginal ray at the actual conjugates.
    pub paraxial_working_f_number: f64,
    /// Paraxial marginal-ray height at the stop: the stop radius that real aiming targets.
    pub stop_radius_mm: f64,
    pub stop_surface: usize,
    /// Global z of the paraxial image plane.
    pub paraxial_image_z_mm: f64,
    pub total_track_mm: f64,
    pub petzval_sum_per_mm: f64,
    /// Lateral magnification (finite conjugates only; 0 for an object at infinity).
    pub magnification: f64,
    pub field_angles_deg: Vec<f64>,
    /// Chief-ray heights at the paraxial image plane, signed (see module docs).
    pub paraxial_image_heights_mm: Vec<f64>,
    /// The same paraxial chief rays' heights on the lens's image surface (differs when the image
    /// surface is not at the paraxial focus; optiland and ray-optics report this one).
    pub paraxial_chief_heights_at_image_surface_mm: Vec<f64>,
}

impl FirstOrder {
    /// The largest field angle in magnitude (0 for an on-axis-only lens).
    pub fn max_field_deg(&self) -> f64 {
        self.field_angles_deg.iter().fold(0.0f64, |m, f| m.max(f.abs()))
    }
}

/// A paraxial ray state after each surface: height at the vertex plane and reduced slope after refraction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParaxialRay {
    pub y_mm: f64,
    pub nu: f64,
}

/// Paraxial surface data at one wavelength: powers and reduced thicknesses, so rays cost no lookups.
pub struct ParaxialSystem {
    /// Per surface up to (excluding) the image surface: (power, index after, thickness after, z vertex).
    powers: Vec<f64>,
    index_after: Vec<f64>,
    thickness_after: Vec<f64>,
    z_mm: Vec<f64>,
    index_before: Vec<f64>,
    object_index: f64,
}

impl ParaxialSystem {
    pub fn new(lens: &Lens, wavelength_um: f64) -> Result<Self> {
        let n = lens.media_indices(wavelength_um)?;
        let optical = lens.image_index();
        let surfaces = &lens.surfaces[..optical];
        let paraxial_curvature =
            |s: &crate::lens::Surface| s.profile.curvature_per_mm + 2.0 * s.profile.aspheric_coefficients[0];
        Ok(ParaxialSystem {
            powers: surfaces
                .iter()
                .enumerate()
                .map(|(i, s)| paraxial_curvature(s) * (n[i + 1] - n[i]))
                .collect(),
            index_after: n[1..=optical].to_vec(),
            index_before: n[..optical].to_vec(),
            thickness_after: surfaces.iter().map(|s| s.thickness_mm).collect(),
            z_mm: surfaces.iter().map(|s| s.z_mm).collect(),
            object_index: n[0],
        })
    }

    /// Traces (y, nu) given at surface 1's vertex plane (object space) through surfaces 0..=last
    /// (refracting at each) and returns the state at each of them.
    pub fn trace(&self, start: ParaxialRay, last: usize) -> Vec<ParaxialRay> {
        let mut states = Vec::with_capacity(last + 1);
        let (mut y, mut nu) = (start.y_mm, start.nu);
        for i in 0..=last {
            if i > 0 {
                y += self.thickness_after[i - 1] * nu / self.index_after[i - 1];
            }
            nu -= y * self.powers[i];
            states.push(ParaxialRay { y_mm: y, nu });
        }
        states
    }

    /// Height at the vertex of surface `at` before refracting there.
    fn height_at(&self, start: ParaxialRay, at: usize) -> f64 {
        if at == 0 {
            return start.y_mm;
        }
        let before = self.trace(start, at - 1)[at - 1];
        before.y_mm + self.thickness_after[at - 1] * before.nu / self.index_after[at - 1]
    }

    fn last(&self) -> usize {
        self.powers.len() - 1
    }

    fn image_index(&self) -> f64 {
        self.index_after[self.last()]
    }

    pub fn petzval_sum_per_mm(&self) -> f64 {
        (0..self.powers.len())
            .map(|i| self.powers[i] / (self.index_before[i] * self.index_after[i]))
            .sum()
    }
}

/// Full first-order analysis at `wavelength_um`.
pub fn first_order(lens: &Lens, wavelength_um: f64) -> Result<FirstOrder> {
    let sys = ParaxialSystem::new(lens, wavelength_um)?;
    let last = sys.last();
    let z_last = sys.z_mm[last];
    let n0 = sys.object_index;
    let n_image = sys.image_index();

    // Columns of the system matrix from the surface-1 vertex plane to after the last surface.
    let col_y = sys.trace(ParaxialRay { y_mm: 1.0, nu: 0.0 }, last)[last];
    let col_nu = sys.trace(ParaxialRay { y_mm: 0.0, nu: 1.0 }, last)[last];
    let (a, c) = (col_y.y_mm, col_y.nu);
    let d = col_nu.nu;
    if c == 0.0 {
        return Err(OpticsError::Paraxial("the system is afocal (zero power)".into()));
    }
    let efl_mm = -1.0 / c;
    let bfl_mm = -a * n_image / c;
    let ffl_mm = d * n0 / c;

    // Entrance pupil: where the object-space chief ray crosses the axis, y at the stop being zero.
    let stop = lens.stop_index;
    let stop_a = sys.height_at(ParaxialRay { y_mm: 1.0, nu: 0.0 }, stop);
    let stop_b = sys.height_at(ParaxialRay { y_mm: 0.0, nu: 1.0 }, stop);
    if stop_a == 0.0 {
        return Err(OpticsError::Paraxial(
            "the stop is imaged to infinity in object space".into(),
        ));
    }
    let entrance_pupil_z_mm = stop_b * n0 / stop_a;
    let epd_mm = match lens.aperture {
        ApertureSpec::EntrancePupilDiameterMm(epd) => epd,
        ApertureSpec::FNumber(f_number) => efl_mm.abs() / f_number,
        ApertureSpec::FloatByStopSize => {
            let stop_semi_diameter = lens.surfaces[stop].semi_diameter_mm.unwrap_or(0.0);
            epd_from_stop_radius(
                stop_semi_diameter,
                stop_a,
                stop_b,
                n0,
                entrance_pupil_z_mm,
                lens.object_distance_mm,
            )
        }
    };

    // Marginal ray through the entrance-pupil edge, from infinity or from the axial object point.
    let marginal_start = match lens.object_distance_mm {
        None => ParaxialRay {
            y_mm: epd_mm / 2.0,
            nu: 0.0,
        },
        Some(distance) => {
            let u = (epd_mm / 2.0) / (entrance_pupil_z_mm + distance);
            ParaxialRay {
                y_mm: u * distance,
                nu: n0 * u,
            }
        }
    };
    let stop_radius_mm = sys.height_at(marginal_start, stop).abs();
    let marginal = sys.trace(marginal_start, last)[last];
    let paraxial_image_z_mm = z_last - marginal.y_mm * n_image / marginal.nu;
    let paraxial_working_f_number = n_image / (2.0 * marginal.nu.abs());
    let magnification = match lens.object_distance_mm {
        None => 0.0,
        Some(_) => marginal_start.nu / marginal.nu,
    };

    // Chief ray of unit slope tan F = 1 through the entrance-pupil centre; heights scale with tan F.
    let unit_chief = ParaxialRay {
        y_mm: -entrance_pupil_z_mm,
        nu: n0,
    };
    let chief = sys.trace(unit_chief, last)[last];
    let chief_height_at = |z: f64| chief.y_mm + chief.nu / n_image * (z - z_last);
    let image_height_per_tan = chief_height_at(paraxial_image_z_mm);
    let surface_height_per_tan = chief_height_at(lens.total_track_mm());
    let (exit_pupil_z_mm, exit_pupil_diameter_mm) = if chief.nu == 0.0 {
        (None, None)
    } else {
        let z_xp = z_last - chief.y_mm * n_image / chief.nu;
        let marginal_at_xp = marginal.y_mm + marginal.nu / n_image * (z_xp - z_last);
        (Some(z_xp), Some(2.0 * marginal_at_xp.abs()))
    };
    let field_angles_deg = match &lens.fields {
        FieldSpec::AnglesDeg(angles) => angles.clone(),
        FieldSpec::ImageHeightsMm(heights) => heights
            .iter()
            .map(|h| (h / image_height_per_tan).atan().to_degrees())
            .collect(),
    };
    let heights = |per_tan: f64| {
        field_angles_deg
            .iter()
            .map(|f| f.to_radians().tan() * per_tan)
            .collect()
    };
    let paraxial_image_heights_mm = heights(image_height_per_tan);
    let paraxial_chief_heights_at_image_surface_mm = heights(surface_height_per_tan);

    let first_order = FirstOrder {
        wavelength_um,
        efl_mm,
        bfl_mm,
        ffl_mm,
        epd_mm,
        entrance_pupil_z_mm,
        exit_pupil_z_mm,
        exit_pupil_diameter_mm,
        f_number: efl_mm.abs() / epd_mm,
        paraxial_working_f_number,
        stop_radius_mm,
        stop_surface: stop,
        paraxial_image_z_mm,
        total_track_mm: lens.total_track_mm(),
        petzval_sum_per_mm: sys.petzval_sum_per_mm(),
        magnification,
        field_angles_deg,
        paraxial_image_heights_mm,
        paraxial_chief_heights_at_image_surface_mm,
    };
    check_finite(&first_order)?;
    Ok(first_order)
}

/// First-order data that overflowed (a curvature of 1e308, a thickness of 1e300, ...) is an error
/// naming the first quantity that is not finite, never NaN reported as a result.
fn check_finite(f: &FirstOrder) -> Result<()> {
    let scalars = [
        ("efl_mm", f.efl_mm),
        ("bfl_mm", f.bfl_mm),
        ("ffl_mm", f.ffl_mm),
        ("epd_mm", f.epd_mm),
        ("entrance_pupil_z_mm", f.entrance_pupil_z_mm),
        ("exit_pupil_z_mm", f.exit_pupil_z_mm.unwrap_or(0.0)),
        ("exit_pupil_diameter_mm", f.exit_pupil_diameter_mm.unwrap_or(0.0)),
        ("f_number", f.f_number),
        ("paraxial_working_f_number", f.paraxial_working_f_number),
        ("stop_radius_mm", f.stop_radius_mm),
        ("paraxial_image_z_mm", f.paraxial_image_z_mm),
        ("total_track_mm", f.total_track_mm),
        ("petzval_sum_per_mm", f.petzval_sum_per_mm),
        ("magnification", f.magnification),
    ];
    let vectors = [
        ("field_angles_deg", &f.field_angles_deg),
        ("paraxial_image_heights_mm", &f.paraxial_image_heights_mm),
        (
            "paraxial_chief_heights_at_image_surface_mm",
            &f.paraxial_chief_heights_at_image_surface_mm,
        ),
    ];
    let bad = scalars
        .iter()
        .find(|(_, v)| !v.is_finite())
        .map(|(name, v)| (*name, *v))
        .or_else(|| {
            vectors
                .iter()
                .find_map(|(name, values)| values.iter().find(|v| !v.is_finite()).map(|v| (*name, *v)))
        });
    match bad {
        Some((name, value)) => Err(OpticsError::Paraxial(format!(
            "{name} is {value}: the lens's numbers overflow or the system is degenerate"
        ))),
        None => Ok(()),
    }
}

/// The entrance-pupil diameter whose marginal ray just fills a stop of radius `stop_radius`.
/// `stop_a`, `stop_b`: stop heights of the unit rays (y=1, nu=0) and (y=0, nu=1).
fn epd_from_stop_radius(
    stop_radius: f64,
    stop_a: f64,
    stop_b: f64,
    n0: f64,
    z_ep: f64,
    object: Option<f64>,
) -> f64 {
    match object {
        None => 2.0 * stop_radius / stop_a.abs(),
        Some(distance) => {
            // Marginal slope u from the axial object point: stop height = u (a d + b n0).
            let u = stop_radius / (stop_a * distance + stop_b * n0).abs();
            2.0 * u * (z_ep + distance)
        }
    }
}

impl Lens {
    /// First-order data at the primary wavelength.
    pub fn first_order(&self) -> Result<FirstOrder> {
        first_order(self, self.primary_wavelength_um())
    }
}
