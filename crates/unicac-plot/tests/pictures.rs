//! Every picture renders as PNG and SVG for a small Cooke triplet built here: the files are complete
//! (SVG closed, with the expected titles; PNG with a valid header of the SVG's size), no temporary file is
//! left behind, and bad requests fail with typed errors and no file.

mod common;

use common::{check_both_formats, TempDir};
use unicac_optics::{Lens, LensSpec};
use unicac_plot::{layout, ray_fan_plot, spot_diagram, PlotError};
use unicac_trace::apertures::clear_semi_diameters;
use unicac_trace::meridional::layout_bundles;
use unicac_trace::spot::ray_fan;
use unicac_trace::{spots, Aiming, PupilSampling, Spot, SpotTracer};

/// A 50 mm F/5 Cooke triplet of model glasses; `image_semi_diameter` is a field stop 1 mm before the
/// image (the image surface itself never vignettes).
fn triplet(image_semi_diameter: f64) -> Lens {
    let json = format!(
        r#"{{"format_version": 1, "name": "test triplet", "aperture": {{"entrance_pupil_diameter_mm": 10.0}},
        "fields": {{"angles_deg": [0.0, 10.0, 15.0]}},
        "wavelengths": [{{"wavelength_um": 0.4861327}}, {{"wavelength_um": 0.5875618}}, {{"wavelength_um": 0.6562725}}],
        "surfaces": [
          {{"radius_mm": 22.014, "thickness_mm": 3.259, "material": {{"nd": 1.6204, "vd": 60.3}}, "semi_diameter_mm": 8.8}},
          {{"radius_mm": -435.76, "thickness_mm": 6.008, "semi_diameter_mm": 8.2}},
          {{"radius_mm": -22.213, "thickness_mm": 1.0, "material": {{"nd": 1.6200, "vd": 36.4}}, "semi_diameter_mm": 4.1}},
          {{"radius_mm": 20.292, "thickness_mm": 4.750, "stop": true, "semi_diameter_mm": 4.0}},
          {{"radius_mm": 79.684, "thickness_mm": 2.952, "material": {{"nd": 1.6204, "vd": 60.3}}, "semi_diameter_mm": 7.1}},
          {{"radius_mm": -18.395, "thickness_mm": 41.208, "semi_diameter_mm": 7.5}},
          {{"thickness_mm": 1.0, "semi_diameter_mm": {image_semi_diameter}, "label": "field stop"}},
          {{"thickness_mm": 0.0}}]}}"#
    );
    let spec: LensSpec = serde_json::from_str(&json).expect("test lens JSON");
    Lens::from_spec(&spec).expect("valid test lens")
}

fn lens_spots(lens: &Lens) -> Vec<Spot> {
    let fields = lens.first_order().unwrap().field_angles_deg;
    spots(
        lens,
        &fields,
        &lens.wavelengths_um(),
        Aiming::Paraxial,
        &PupilSampling::Hexapolar { rings: 5 },
    )
    .unwrap()
}

#[test]
fn spot_diagram_renders_every_field_and_wavelength() {
    let spots = lens_spots(&triplet(20.0));
    assert!(spots.iter().all(|s| s.rays_ok > 0));
    let texts = [
        "Spot diagram",
        "common scale",
        "15°   0.5876 µm   RMS",
        "0°   0.4861 µm",
        "Δx (µm)",
    ];
    check_both_formats("spot", &texts, |path| spot_diagram(&spots, path));
}

#[test]
fn spot_diagram_notes_a_spot_without_rays() {
    // A 1 mm field stop just before the image clips every off-axis ray: those spots are empty.
    let spots = lens_spots(&triplet(1.0));
    assert!(spots.iter().any(|s| s.field_deg == 10.0 && s.rays_ok == 0));
    assert!(spots.iter().any(|s| s.field_deg == 0.0 && s.rays_ok > 0));
    check_both_formats(
        "empty-spot",
        &["10°   0.5876 µm   no rays", "none of 91 rays reached the image"],
        |path| spot_diagram(&spots, path),
    );
}

#[test]
fn layout_renders_elements_stop_and_rays() {
    let lens = triplet(20.0);
    let bundles = layout_bundles(&lens, 9).unwrap();
    let semi_diameters = clear_semi_diameters(&lens, Aiming::Paraxial).unwrap();
    let texts = ["Layout: test triplet", "STOP", "field 0°", "field 15°", "z (mm)"];
    check_both_formats("layout", &texts, |path| {
        layout(&lens, &bundles, &semi_diameters, path)
    });
}

#[test]
fn layout_bundles_start_before_the_lens_and_stop_where_rays_fail() {
    let mut lens = triplet(20.0);
    // A 6 mm front aperture passes the axial beam (5 mm) but vignettes the lower edge of the 15 deg beam.
    lens.surfaces[0].semi_diameter_mm = Some(6.0);
    let first = lens.first_order().unwrap();
    let start_z = first.entrance_pupil_z_mm.min(0.0) - 0.2 * lens.total_track_mm();
    let bundles = layout_bundles(&lens, 9).unwrap();
    assert_eq!(
        bundles.iter().map(|b| b.field_deg).collect::<Vec<_>>(),
        [0.0, 10.0, 15.0]
    );
    for bundle in &bundles {
        assert_eq!(bundle.paths.len(), 9);
        for path in &bundle.paths {
            assert!(
                (path[0][2] - start_z).abs() < 1e-9,
                "starts at z = {}",
                path[0][2]
            );
        }
    }
    // On axis every ray reaches the image: start plus one point per surface.
    assert!(bundles[0]
        .paths
        .iter()
        .all(|p| p.len() == lens.surfaces.len() + 1));
    assert!(bundles[0]
        .paths
        .iter()
        .all(|p| (p.last().unwrap()[2] - lens.total_track_mm()).abs() < 1e-9));
    // At 15 deg the lowest rays are clipped by the front surface: their paths end on it, outside 6 mm.
    let edge = &bundles[2].paths;
    let clipped: Vec<_> = edge
        .iter()
        .filter(|p| p.len() < lens.surfaces.len() + 1)
        .collect();
    assert!(
        !clipped.is_empty() && clipped.len() < edge.len(),
        "{} of {} clipped",
        clipped.len(),
        edge.len()
    );
    for path in clipped {
        let end = path.last().unwrap();
        assert_eq!(path.len(), 2, "start and the stopping point");
        let sag = lens.surfaces[0].profile.sag(end[1] * end[1]);
        assert!(
            end[1] < -6.0 && (end[2] - sag).abs() < 0.2,
            "ends at the front surface: {end:?}"
        );
    }
}

#[test]
fn ray_fan_plot_renders_both_fans_per_field() {
    let lens = triplet(20.0);
    let mut fans = Vec::new();
    for wavelength in lens.wavelengths_um() {
        let tracer = SpotTracer::new(&lens, wavelength, Aiming::Paraxial).unwrap();
        fans.extend([0.0, 10.0, 15.0].iter().filter_map(|&f| ray_fan(&tracer, f, 31)));
    }
    assert_eq!(fans.len(), 9);
    let texts = [
        "Ray fans",
        "15°   tangential",
        "15°   sagittal",
        "ey (µm)",
        "ex (µm)",
        "0.6563 µm",
    ];
    check_both_formats("fan", &texts, |path| ray_fan_plot(&fans, path));
}

#[test]
fn unknown_extension_is_a_typed_error_and_writes_nothing() {
    let spots = lens_spots(&triplet(20.0));
    let dir = TempDir::new("bad-extension");
    for name in ["spots.jpg", "spots"] {
        let path = dir.0.join(name);
        match spot_diagram(&spots, &path) {
            Err(PlotError::UnknownExtension { path: named }) => assert_eq!(named, path),
            other => panic!("expected UnknownExtension, got {other:?}"),
        }
        let message = spot_diagram(&spots, &path).unwrap_err().to_string();
        assert!(
            message.contains(name) && message.contains(".png or .svg"),
            "{message}"
        );
    }
    assert!(dir.files().is_empty(), "left {:?}", dir.files());
}

#[test]
fn bad_inputs_are_typed_errors_and_write_nothing() {
    let lens = triplet(20.0);
    let dir = TempDir::new("bad-input");
    let wrong_count = layout(&lens, &[], &[1.0, 2.0], &dir.0.join("layout.png"));
    assert!(
        matches!(wrong_count, Err(PlotError::InvalidInput(m)) if m.contains("2 semi-diameters for 8 surfaces"))
    );
    assert!(matches!(
        spot_diagram(&[], &dir.0.join("spots.svg")),
        Err(PlotError::InvalidInput(_))
    ));
    assert!(matches!(
        ray_fan_plot(&[], &dir.0.join("fans.png")),
        Err(PlotError::InvalidInput(_))
    ));
    assert!(dir.files().is_empty(), "left {:?}", dir.files());
}
