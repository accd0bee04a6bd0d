//! `Lens`: a validated, ready-to-trace sequential system built from a `LensSpec`.

use crate::error::{OpticsError, Result};
use crate::material::{find_glass, Medium, LINE_D_UM};
use crate::placement::{Placement, MAX_TILT_DEG};
use crate::profile::{Profile, MAX_ASPHERE_TERMS};
use crate::spec::{
    ApertureSpec, FieldSpec, LensSpec, MaterialSpec, SensorSpec, SurfaceSpec, SurfaceType, WavelengthSpec,
    FORMAT_VERSION,
};
use serde::Serialize;

/// One surface of the model, with its vertex placed in global coordinates. Serialised for keys only
/// (`unicac_psf::lens_fingerprint`); lens files are `LensSpec`s.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Surface {
    pub profile: Profile,
    /// Global z of the vertex (surface 1 at 0).
    pub z_mm: f64,
    pub thickness_mm: f64,
    /// Clear semi-diameter; `None` means unlimited (its value is computed from the beams on request).
    pub semi_diameter_mm: Option<f64>,
    pub medium_after: Medium,
    pub label: String,
    /// Decentre and tilt of this surface (`crate::placement`); centred by default.
    pub placement: Placement,
}

/// A validated lens. Index 0 of `surfaces` is surface 1; the last entry is the image surface. Its
/// serialised form (every number the tracer reads, glass data included) is its identity in cache keys.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Lens {
    pub name: String,
    pub surfaces: Vec<Surface>,
    pub stop_index: usize,
    pub object_distance_mm: Option<f64>,
    pub aperture: ApertureSpec,
    pub fields: FieldSpec,
    pub field_weights: Vec<f64>,
    pub wavelengths: Vec<WavelengthSpec>,
    pub primary_wavelength_index: usize,
    pub sensor: Option<SensorSpec>,
}

impl Lens {
    /// Validates `spec`; every error names the offending field.
    pub fn from_spec(spec: &LensSpec) -> Result<Lens> {
        if spec.format_version != FORMAT_VERSION {
            return Err(OpticsError::invalid(
                "format_version",
                format!(
                    "version {} is not supported (this reader knows {FORMAT_VERSION})",
                    spec.format_version
                ),
            ));
        }
        if spec.surfaces.len() < 2 {
            return Err(OpticsError::invalid(
                "surfaces",
                "need at least one surface and the image surface",
            ));
        }
        let surfaces = build_surfaces(spec)?;
        let stops: Vec<usize> = spec
            .surfaces
            .iter()
            .enumerate()
            .filter(|(_, s)| s.stop)
            .map(|(i, _)| i)
            .collect();
        let stop_index = match stops.as_slice() {
            [] => 0,
            [one] => *one,
            _ => {
                return Err(OpticsError::invalid(
                    "surfaces[].stop",
                    format!("{} surfaces are marked as stop", stops.len()),
                ))
            }
        };
        if stop_index == spec.surfaces.len() - 1 {
            return Err(OpticsError::invalid(
                "surfaces[].stop",
                "the image surface cannot be the stop",
            ));
        }
        check_object_distance(spec.object_distance_mm)?;
        if spec.aperture == ApertureSpec::FloatByStopSize
            && spec.surfaces[stop_index].semi_diameter_mm.is_none()
        {
            return Err(OpticsError::invalid(
                format!("surfaces[{stop_index}].semi_diameter_mm"),
                "aperture float_by_stop_size needs the stop's semi-diameter",
            ));
        }
        check_aperture(&spec.aperture)?;
        check_fields(&spec.fields)?;
        let field_weights = spec
            .field_weights
            .clone()
            .unwrap_or_else(|| vec![1.0; spec.fields.values().len()]);
        if field_weights.len() != spec.fields.values().len() || field_weights.iter().any(|w| !(*w >= 0.0)) {
            return Err(OpticsError::invalid(
                "field_weights",
                "need one non-negative weight per field",
            ));
        }
        check_wavelengths(&spec.wavelengths)?;
        let primary_wavelength_index = match spec.primary_wavelength_index {
            Some(i) if i < spec.wavelengths.len() => i,
            Some(i) => {
                return Err(OpticsError::invalid(
                    "primary_wavelength_index",
                    format!("{i} is out of range for {} wavelengths", spec.wavelengths.len()),
                ))
            }
            None => closest_to_d_line(&spec.wavelengths),
        };
        if let Some(sensor) = &spec.sensor {
            if [sensor.width_mm, sensor.height_mm, sensor.pixel_um]
                .iter()
                .any(|v| !(v.is_finite() && *v > 0.0))
            {
                return Err(OpticsError::invalid(
                    "sensor",
                    "width_mm, height_mm and pixel_pitch_um must be positive",
                ));
            }
        }
        let lens = Lens {
            name: spec.name.clone(),
            surfaces,
            stop_index,
            object_distance_mm: spec.object_distance_mm,
            aperture: spec.aperture,
            fields: spec.fields.clone(),
            field_weights,
            wavelengths: spec.wavelengths.clone(),
            primary_wavelength_index,
            sensor: spec.sensor,
        };
        // Every medium must have an index at every wavelength of the file.
        for w in &lens.wavelengths {
            lens.media_indices(w.wavelength_um)?;
        }
        Ok(lens)
    }

    pub fn image_index(&self) -> usize {
        self.surfaces.len() - 1
    }

    pub fn primary_wavelength_um(&self) -> f64 {
        self.wavelengths[self.primary_wavelength_index].wavelength_um
    }

    pub fn wavelengths_um(&self) -> Vec<f64> {
        self.wavelengths.iter().map(|w| w.wavelength_um).collect()
    }

    /// Refractive indices of every medium at `wavelength_um`: entry 0 is object space (air), entry i + 1
    /// the medium after surface index i.
    pub fn media_indices(&self, wavelength_um: f64) -> Result<Vec<f64>> {
        std::iter::once(Ok(1.0))
            .chain(self.surfaces.iter().map(|s| s.medium_after.index(wavelength_um)))
            .collect()
    }

    /// Surface 1 vertex to the image surface.
    pub fn total_track_mm(&self) -> f64 {
        self.surfaces[self.image_index()].z_mm
    }

    /// True when every surface is centred on the axis and untilted: the model is then rotationally
    /// symmetric about z (fields need only one azimuth, the meridional plane is a plane of symmetry).
    pub fn is_rotationally_symmetric(&self) -> bool {
        self.surfaces.iter().all(|s| s.placement.is_centred())
    }

    /// The same lens with every surface centred (what the paraxial quantities describe).
    pub fn nominal(&self) -> Lens {
        let mut lens = self.clone();
        lens.surfaces
            .iter_mut()
            .for_each(|s| s.placement = Placement::default());
        lens
    }

    /// The lens as a lens file says it (`LensSpec`): `Lens::from_spec` of it gives this lens back,
    /// each vertex where the thicknesses put it (an offset glass as its material plus `index_offset`;
    /// catalogue glasses by qualified name, so no catalogue list is needed).
    pub fn to_spec(&self) -> LensSpec {
        let surfaces = self
            .surfaces
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let terms = s.profile.aspheric_terms;
                let (material, index_offset) = material_spec(&s.medium_after);
                let mut spec = SurfaceSpec {
                    surface_type: if terms > 0 {
                        SurfaceType::EvenAsphere
                    } else {
                        SurfaceType::Standard
                    },
                    curvature_per_mm: Some(s.profile.curvature_per_mm),
                    conic: s.profile.conic,
                    aspheric_coefficients: s.profile.aspheric_coefficients[..terms].to_vec(),
                    thickness_mm: s.thickness_mm,
                    material,
                    index_offset,
                    semi_diameter_mm: s.semi_diameter_mm,
                    stop: i == self.stop_index,
                    label: s.label.clone(),
                    ..SurfaceSpec::default()
                };
                spec.set_placement(s.placement);
                spec
            })
            .collect();
        LensSpec {
            format_version: FORMAT_VERSION,
            name: self.name.clone(),
            provenance: String::new(),
            object_distance_mm: self.object_distance_mm,
            aperture: self.aperture,
            fields: self.fields.clone(),
            field_weights: Some(self.field_weights.clone()),
            wavelengths: self.wavelengths.clone(),
            primary_wavelength_index: Some(self.primary_wavelength_index),
            glass_catalogs: Vec::new(),
            surfaces,
            sensor: self.sensor,
        }
    }

    /// The semi-diameters the file gave (None where the file left them to be computed).
    pub fn given_semi_diameters(&self) -> Vec<Option<f64>> {
        self.surfaces.iter().map(|s| s.semi_diameter_mm).collect()
    }
}

/// Largest index offset a lens file may give a glass (`SurfaceSpec::index_offset`): far beyond any
/// melt tolerance (1e-3 is a loose one), small enough that no glass turns into air.
pub const MAX_INDEX_OFFSET: f64 = 0.1;

fn build_surfaces(spec: &LensSpec) -> Result<Vec<Surface>> {
    let mut z_mm = 0.0;
    let mut surfaces = Vec::with_capacity(spec.surfaces.len());
    for (i, s) in spec.surfaces.iter().enumerate() {
        let field = |name: &str| format!("surfaces[{i}].{name}");
        if s.curvature_per_mm.is_some() && s.radius_mm.is_some() {
            return Err(OpticsError::invalid(
                field("radius_mm"),
                "give curvature_per_mm or radius_mm, not both",
            ));
        }
        let curvature = s.curvature();
        for (name, value) in [
            ("curvature_per_mm", curvature),
            ("conic", s.conic),
            ("thickness_mm", s.thickness_mm),
            ("decentre_x_mm", s.decentre_x_mm),
            ("decentre_y_mm", s.decentre_y_mm),
            ("tilt_x_deg", s.tilt_x_deg),
            ("tilt_y_deg", s.tilt_y_deg),
        ] {
            if !value.is_finite() {
                return Err(OpticsError::invalid(field(name), "must be a finite number"));
            }
        }
        let profile = match s.surface_type {
            SurfaceType::Standard if !s.aspheric_coefficients.is_empty() => {
                return Err(OpticsError::invalid(
                    field("aspheric_coefficients"),
                    "only an even_asphere surface has aspheric coefficients",
                ))
            }
            SurfaceType::Standard => Profile::conic(curvature, s.conic),
            SurfaceType::EvenAsphere => {
                if s.aspheric_coefficients.len() > MAX_ASPHERE_TERMS {
                    return Err(OpticsError::invalid(
                        field("aspheric_coefficients"),
                        format!("at most {MAX_ASPHERE_TERMS} coefficients (r^2 .. r^20)"),
                    ));
                }
                if s.aspheric_coefficients.iter().any(|a| !a.is_finite()) {
                    return Err(OpticsError::invalid(
                        field("aspheric_coefficients"),
                        "must be finite numbers",
                    ));
                }
                Profile::even_asphere(curvature, s.conic, &s.aspheric_coefficients)
            }
        };
        for (name, tilt) in [("tilt_x_deg", s.tilt_x_deg), ("tilt_y_deg", s.tilt_y_deg)] {
            if !(tilt.abs() <= MAX_TILT_DEG) {
                return Err(OpticsError::invalid(
                    field(name),
                    format!("{tilt} deg: tilts must lie within +-{MAX_TILT_DEG} deg"),
                ));
            }
        }
        if let Some(sd) = s.semi_diameter_mm {
            if !(sd.is_finite() && sd > 0.0) {
                return Err(OpticsError::invalid(
                    field("semi_diameter_mm"),
                    "must be positive",
                ));
            }
        }
        let medium_after = match &s.material {
            None => Medium::Air,
            Some(m) if m.is_air() => Medium::Air,
            Some(MaterialSpec::Named(name)) => Medium::Catalog(find_glass(name, &spec.glass_catalogs)?),
            Some(MaterialSpec::Model { nd, vd }) => {
                if !(nd.is_finite() && *nd >= 1.0 && vd.is_finite() && *vd > 0.0) {
                    return Err(OpticsError::invalid(
                        field("material"),
                        "model glass needs nd >= 1 and vd > 0",
                    ));
                }
                Medium::Model { nd: *nd, vd: *vd }
            }
        };
        let medium_after = match s.index_offset {
            0.0 => medium_after,
            delta_n if !(delta_n.abs() <= MAX_INDEX_OFFSET) => {
                return Err(OpticsError::invalid(
                    field("index_offset"),
                    format!("{delta_n}: must lie within +-{MAX_INDEX_OFFSET}"),
                ))
            }
            _ if medium_after.is_air() => {
                return Err(OpticsError::invalid(
                    field("index_offset"),
                    "air has no index error: an index offset needs a glass (material)",
                ))
            }
            delta_n => Medium::Offset {
                base: Box::new(medium_after),
                delta_n,
            },
        };
        surfaces.push(Surface {
            profile,
            z_mm,
            thickness_mm: s.thickness_mm,
            semi_diameter_mm: s.semi_diameter_mm,
            medium_after,
            label: s.label.clone(),
            placement: s.placement(),
        });
        z_mm += s.thickness_mm;
    }
    Ok(surfaces)
}

/// A medium as a lens file names it: the material, and the index offset of an offset glass.
fn material_spec(medium: &Medium) -> (Option<MaterialSpec>, f64) {
    match medium {
        Medium::Air => (None, 0.0),
        Medium::Catalog(glass) => (Some(MaterialSpec::Named(glass.qualified_name())), 0.0),
        Medium::Model { nd, vd } => (Some(MaterialSpec::Model { nd: *nd, vd: *vd }), 0.0),
        Medium::Offset { base, delta_n } => {
            let (material, inner) = material_spec(base);
            (material, inner + delta_n)
        }
    }
}

fn check_object_distance(distance: Option<f64>) -> Result<()> {
    match distance {
        Some(d) if !(d.is_finite() && d > 0.0) => Err(OpticsError::invalid(
            "object_distance_mm",
            "must be positive (null for an object at infinity)",
        )),
        _ => Ok(()),
    }
}

fn check_aperture(aperture: &ApertureSpec) -> Result<()> {
    let (name, value) = match aperture {
        ApertureSpec::EntrancePupilDiameterMm(v) => ("aperture.entrance_pupil_diameter_mm", *v),
        ApertureSpec::FNumber(v) => ("aperture.f_number", *v),
        ApertureSpec::FloatByStopSize => return Ok(()),
    };
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(OpticsError::invalid(name, "must be positive"))
    }
}

fn check_fields(fields: &FieldSpec) -> Result<()> {
    let values = fields.values();
    if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
        return Err(OpticsError::invalid(
            "fields",
            "need at least one finite field value",
        ));
    }
    if let FieldSpec::AnglesDeg(angles) = fields {
        if angles.iter().any(|a| a.abs() >= 90.0) {
            return Err(OpticsError::invalid(
                "fields.angles_deg",
                "angles must lie strictly between -90 and 90",
            ));
        }
    }
    Ok(())
}

fn check_wavelengths(wavelengths: &[WavelengthSpec]) -> Result<()> {
    if wavelengths.is_empty() {
        return Err(OpticsError::invalid(
            "wavelengths",
            "need at least one wavelength",
        ));
    }
    for (i, w) in wavelengths.iter().enumerate() {
        if !(w.wavelength_um.is_finite() && w.wavelength_um > 0.0) {
            return Err(OpticsError::invalid(
                format!("wavelengths[{i}].wavelength_um"),
                "must be positive",
            ));
        }
        if !(w.weight.is_finite() && w.weight >= 0.0) {
            return Err(OpticsError::invalid(
                format!("wavelengths[{i}].weight"),
                "must be non-negative",
            ));
        }
    }
    Ok(())
}

fn closest_to_d_line(wavelengths: &[WavelengthSpec]) -> usize {
    let distance = |w: &WavelengthSpec| (w.wavelength_um - LINE_D_UM).abs();
    (0..wavelengths.len())
        .min_by(|&a, &b| distance(&wavelengths[a]).total_cmp(&distance(&wavelengths[b])))
        .unwrap_or(0)
}
