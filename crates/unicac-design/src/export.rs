//! Between the design's prescription and unicac's lens model: `to_lens_spec` writes a design as a
//! `LensSpec` (then JSON or .zmx); `from_lens` reads a lens into a prescription (for comparisons with
//! classic designs and for tests).

use crate::error::{DesignError, Result};
use crate::spec::DesignSpec;
use crate::system::{Material, Prescription, Surf, ASPHERE_TERMS};
use unicac_optics::spec::{
    ApertureSpec, FieldSpec, LensSpec, MaterialSpec, SurfaceSpec, SurfaceType, WavelengthSpec, FORMAT_VERSION,
};
use unicac_optics::{Lens, Medium};

/// The design as a lens file. `semi_diameters_mm` (one per surface) become the clear semi-diameters;
/// the aperture is the entrance-pupil diameter f / F#, as the merit traced it.
pub fn to_lens_spec(
    p: &Prescription<f64>,
    spec: &DesignSpec,
    semi_diameters_mm: &[f64],
    name: &str,
    provenance: &str,
) -> LensSpec {
    let mut surfaces: Vec<SurfaceSpec> = p
        .surfaces
        .iter()
        .enumerate()
        .map(|(i, s)| SurfaceSpec {
            surface_type: if s.is_asphere {
                SurfaceType::EvenAsphere
            } else {
                SurfaceType::Standard
            },
            curvature_per_mm: Some(s.curvature),
            radius_mm: None,
            conic: s.conic,
            aspheric_coefficients: if s.is_asphere {
                std::iter::once(0.0).chain(s.asphere).collect()
            } else {
                Vec::new()
            },
            thickness_mm: s.thickness,
            material: match &s.after {
                Material::Air => None,
                Material::Model { nd, vd } => Some(MaterialSpec::Model { nd: *nd, vd: *vd }),
                Material::Catalog(g) => Some(MaterialSpec::Named(g.qualified_name())),
            },
            semi_diameter_mm: semi_diameters_mm.get(i).copied().filter(|v| *v > 0.0),
            stop: s.is_stop,
            ..SurfaceSpec::default()
        })
        .collect();
    surfaces.push(SurfaceSpec {
        curvature_per_mm: Some(0.0),
        label: "image".into(),
        ..SurfaceSpec::default()
    });
    LensSpec {
        format_version: FORMAT_VERSION,
        name: name.to_string(),
        provenance: provenance.to_string(),
        object_distance_mm: None,
        aperture: ApertureSpec::EntrancePupilDiameterMm(spec.focal_length_mm / spec.f_number),
        fields: FieldSpec::AnglesDeg(spec.field_angles_deg()),
        field_weights: None,
        wavelengths: spec
            .wavelengths_um
            .iter()
            .zip(&spec.wavelength_weights)
            .map(|(&wavelength_um, &weight)| WavelengthSpec {
                wavelength_um,
                weight,
            })
            .collect(),
        primary_wavelength_index: Some(spec.primary_wavelength_index),
        glass_catalogs: Vec::new(),
        surfaces,
        sensor: None,
    }
}

/// A lens as a prescription: spheres, conics and even aspheres whose polynomial is r^4..r^10 (no r^2
/// term), object at infinity, plane image surface.
pub fn from_lens(lens: &Lens) -> Result<Prescription<f64>> {
    let unsupported = |what: &str| DesignError::spec("lens", what.to_string());
    if lens.object_distance_mm.is_some() {
        return Err(unsupported("only objects at infinity"));
    }
    let image = lens.image_index();
    if !lens.surfaces[image].profile.is_plane() {
        return Err(unsupported("the image surface must be a plane"));
    }
    let surfaces = lens.surfaces[..image]
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let profile = &s.profile;
            let a = &profile.aspheric_coefficients;
            if a[0] != 0.0 || a[ASPHERE_TERMS + 1..].iter().any(|v| *v != 0.0) {
                return Err(unsupported("aspheric terms beyond r^4..r^10 (or an r^2 term)"));
            }
            let mut asphere = [0.0; ASPHERE_TERMS];
            asphere.copy_from_slice(&a[1..=ASPHERE_TERMS]);
            Ok(Surf {
                curvature: profile.curvature_per_mm,
                conic: profile.conic,
                asphere,
                is_asphere: profile.has_polynomial(),
                thickness: s.thickness_mm,
                after: match &s.medium_after {
                    Medium::Air => Material::Air,
                    Medium::Model { nd, vd } => Material::Model { nd: *nd, vd: *vd },
                    Medium::Catalog(g) => Material::Catalog(g.clone()),
                    Medium::Offset { .. } => {
                        return Err(unsupported("a glass with an index offset (a toleranced lens)"))
                    }
                },
                is_stop: i == lens.stop_index,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Prescription { surfaces })
}
