//! The lens model builder: arbitrary specs (any numbers, any surface count up to 24) give an error or
//! a lens whose first-order data and traced rays are finite wherever they are reported valid.
#![no_main]

mod common;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use unicac_optics::spec::{ApertureSpec, FieldSpec, MaterialSpec, SurfaceSpec, SurfaceType, WavelengthSpec};
use unicac_optics::LensSpec;

#[derive(Debug, Arbitrary)]
struct Surface {
    curvature_per_mm: f64,
    thickness_mm: f64,
    conic: f64,
    aspheric: Vec<f64>,
    glass: Option<(f64, f64)>,
    semi_diameter_mm: Option<f64>,
    stop: bool,
}

#[derive(Debug, Arbitrary)]
struct Spec {
    object_distance_mm: Option<f64>,
    aperture: (u8, f64),
    image_heights: bool,
    fields: Vec<f64>,
    wavelengths_um: Vec<f64>,
    surfaces: Vec<Surface>,
}

fuzz_target!(|input: Spec| {
    if input.surfaces.len() > 24 || input.fields.len() > 8 || input.wavelengths_um.len() > 8 {
        return;
    }
    let Some(mut spec) = unicac_optics::builtin::spec("singlet").ok() else { return };
    spec.object_distance_mm = input.object_distance_mm;
    spec.aperture = match input.aperture.0 % 3 {
        0 => ApertureSpec::EntrancePupilDiameterMm(input.aperture.1),
        1 => ApertureSpec::FNumber(input.aperture.1),
        _ => ApertureSpec::FloatByStopSize,
    };
    spec.fields = if input.image_heights {
        FieldSpec::ImageHeightsMm(input.fields.clone())
    } else {
        FieldSpec::AnglesDeg(input.fields.clone())
    };
    spec.field_weights = None;
    spec.wavelengths = input
        .wavelengths_um
        .iter()
        .map(|&w| WavelengthSpec { wavelength_um: w, weight: 1.0 })
        .collect();
    spec.primary_wavelength_index = None;
    spec.surfaces = input
        .surfaces
        .iter()
        .map(|s| SurfaceSpec {
            surface_type: if s.aspheric.is_empty() { SurfaceType::Standard } else { SurfaceType::EvenAsphere },
            curvature_per_mm: Some(s.curvature_per_mm),
            thickness_mm: s.thickness_mm,
            conic: s.conic,
            aspheric_coefficients: s.aspheric.iter().take(12).copied().collect(),
            material: s.glass.map(|(nd, vd)| MaterialSpec::Model { nd, vd }),
            semi_diameter_mm: s.semi_diameter_mm,
            stop: s.stop,
            ..SurfaceSpec::default()
        })
        .collect();
    let spec: LensSpec = spec;
    common::check_spec(&spec);
});
