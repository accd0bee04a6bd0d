//! Tracing and paraxial analysis against closed-form optics. Tolerances are stated per test.

use unicac_optics::{Lens, LensSpec};
use unicac_trace::{Aimer, Aiming, Clipping, Ray, RayStatus, TraceSystem};

const D_LINE: f64 = 0.5875618;

fn lens(json: &str) -> Lens {
    let spec: LensSpec = serde_json::from_str(json).expect("test lens JSON");
    Lens::from_spec(&spec).expect("valid test lens")
}

/// A singlet of model glass (index exactly nd at the d line) with radii r1, r2 and thickness t.
fn singlet(r1: f64, r2: f64, thickness: f64, nd: f64, back_mm: f64) -> Lens {
    lens(&format!(
        r#"{{"format_version": 1, "aperture": {{"entrance_pupil_diameter_mm": 4.0}},
        "fields": {{"angles_deg": [0.0, 5.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}],
        "surfaces": [
          {{"radius_mm": {r1}, "thickness_mm": {thickness}, "material": {{"nd": {nd}, "vd": 60.0}}, "stop": true}},
          {{"radius_mm": {r2}, "thickness_mm": {back_mm}}},
          {{"thickness_mm": 0.0}}]}}"#
    ))
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn thick_lens_focal_lengths_match_the_lensmaker_formula() {
    // 1/f = (n-1) (1/R1 - 1/R2 + (n-1) d / (n R1 R2)); BFL = f (1 - (n-1) d / (n R1)); FFL = -f (1 + (n-1) d / (n R2)).
    for (r1, r2, d, n) in [
        (50.0, -50.0, 5.0, 1.5168),
        (30.0, 200.0, 8.0, 1.8),
        (-40.0, -25.0, 3.0, 1.6),
        (1e9, -20.0, 2.0, 1.5),
    ] {
        let lens = singlet(r1, r2, d, n, 40.0);
        let first = lens.first_order().unwrap();
        let f = 1.0 / ((n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * d / (n * r1 * r2)));
        assert!(relative(first.efl_mm, f) < 1e-12, "efl {} vs {f}", first.efl_mm);
        assert!(relative(first.bfl_mm, f * (1.0 - (n - 1.0) * d / (n * r1))) < 1e-12);
        assert!(relative(first.ffl_mm, -f * (1.0 + (n - 1.0) * d / (n * r2))) < 1e-12);
    }
}

#[test]
fn thin_lens_limit_matches_one_over_f() {
    let lens = singlet(100.0, -100.0, 1e-9, 1.5, 100.0);
    assert!(relative(lens.first_order().unwrap().efl_mm, 100.0) < 1e-9);
}

#[test]
fn ball_lens_focal_lengths() {
    // Ball of radius R, index n: EFL = n R / (2 (n - 1)), BFL = EFL - R (from the rear vertex).
    let (r, n) = (5.0, 1.5168);
    let lens = singlet(r, -r, 2.0 * r, n, 5.0);
    let first = lens.first_order().unwrap();
    let efl = n * r / (2.0 * (n - 1.0));
    assert!(relative(first.efl_mm, efl) < 1e-12);
    assert!(relative(first.bfl_mm, efl - r) < 1e-12);
}

#[test]
fn entrance_pupil_of_a_rear_stop_is_its_image_through_the_front_lens() {
    // Stop 10 mm behind a thin lens of f = 50: the entrance pupil is the stop's virtual image,
    // 1/s' = 1/f + 1/s with s = -10 (looking back) -> image 12.5 mm behind the lens.
    let lens = lens(&format!(
        r#"{{"format_version": 1, "aperture": {{"entrance_pupil_diameter_mm": 4.0}},
        "fields": {{"angles_deg": [0.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}],
        "surfaces": [
          {{"radius_mm": 51.68, "thickness_mm": 0.0, "material": {{"nd": 1.5168, "vd": 60.0}}}},
          {{"radius_mm": -51.68, "thickness_mm": 10.0}},
          {{"thickness_mm": 40.0, "stop": true}},
          {{"thickness_mm": 0.0}}]}}"#
    ));
    let first = lens.first_order().unwrap();
    assert!(relative(first.efl_mm, 50.0) < 1e-12);
    assert!(
        relative(first.entrance_pupil_z_mm, 12.5) < 1e-12,
        "{}",
        first.entrance_pupil_z_mm
    );
}

#[test]
fn snell_law_at_a_plane_surface() {
    let n = 1.7;
    let lens = singlet(0.0, 0.0, 10.0, n, 0.0);
    let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
    for angle_deg in [0.0f64, 10.0, 45.0, 80.0] {
        let (s, c) = angle_deg.to_radians().sin_cos();
        let mut ray = Ray::new([0.0, 0.0, -1.0], [0.0, s, c]);
        // Stop after surface 1: refract there only.
        assert_eq!(system.trace_through(&mut ray, 0, true), RayStatus::Ok);
        assert!((ray.direction[1] - s / n).abs() < 1e-15, "angle {angle_deg}");
        assert!((ray.direction.iter().map(|d| d * d).sum::<f64>() - 1.0).abs() < 1e-15);
    }
}

#[test]
fn total_internal_reflection_is_reported_at_its_surface() {
    // A plano-convex lens (R2 = -10) hit parallel to the axis at height 7: incidence asin(0.7) = 44 deg
    // on the glass-air surface, beyond the critical angle asin(1/1.8) = 33.7 deg.
    let lens = singlet(0.0, -10.0, 12.0, 1.8, 5.0);
    let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
    let mut ray = Ray::new([0.0, 7.0, -1.0], [0.0, 0.0, 1.0]);
    let status = system.trace(&mut ray);
    assert_eq!(status, RayStatus::Tir { surface: 1 });
    assert!(ray.is_finite());
}

/// Air into glass of index n through an ellipsoid (k = -1/n^2) of vertex radius R: a perfect focus
/// for collimated light at n R / (n - 1), where the image surface sits (inside the glass).
fn ellipsoidal_refractor(n: f64, radius: f64) -> Lens {
    let focus = n * radius / (n - 1.0);
    lens(&format!(
        r#"{{"format_version": 1, "aperture": {{"entrance_pupil_diameter_mm": 12.0}},
        "fields": {{"angles_deg": [0.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}],
        "surfaces": [
          {{"radius_mm": {radius}, "conic": {k}, "thickness_mm": {focus}, "material": {{"nd": {n}, "vd": 50.0}}}},
          {{"thickness_mm": 0.0, "material": {{"nd": {n}, "vd": 50.0}}}}]}}"#,
        k = -1.0 / (n * n)
    ))
}

#[test]
fn perfect_conic_refractors_focus_collimated_light_to_a_point() {
    // Air -> glass: an ellipsoid with k = -1/n^2 focuses a collimated beam at n R / (n - 1) inside the glass.
    // Glass -> air: a plano-hyperbolic lens (k = -n^2 on the exit face) focuses at the far focus.
    let (n, radius) = (1.5, 10.0);
    let ellipsoid = ellipsoidal_refractor(n, radius);
    let hyperbola = lens(&format!(
        r#"{{"format_version": 1, "aperture": {{"entrance_pupil_diameter_mm": 12.0}},
        "fields": {{"angles_deg": [0.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}],
        "surfaces": [
          {{"thickness_mm": 5.0, "material": {{"nd": {n}, "vd": 50.0}}}},
          {{"radius_mm": {r}, "conic": {k}, "thickness_mm": {f}}},
          {{"thickness_mm": 0.0}}]}}"#,
        r = -radius * (n - 1.0),
        k = -n * n,
        f = radius
    ));
    for lens in [ellipsoid, hyperbola] {
        let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
        for h in [0.5, 2.0, 4.0, 5.9] {
            let mut ray = Ray::new([0.0, h, -1.0], [0.0, 0.0, 1.0]);
            assert_eq!(system.trace(&mut ray), RayStatus::Ok);
            assert!(
                ray.position_mm[1].abs() < 1e-12,
                "height {h}: {}",
                ray.position_mm[1]
            );
        }
    }
}

#[test]
fn paraboloid_as_conic_and_as_polynomial_trace_identically() {
    // z = c r^2 / 2 written twice: conic k = -1 (closed-form root) and a plane plus a_2 = c / 2 (Newton).
    let c = 0.02;
    let make = |surface: String| {
        lens(&format!(
            r#"{{"format_version": 1, "aperture": {{"entrance_pupil_diameter_mm": 10.0}},
            "fields": {{"angles_deg": [0.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}],
            "surfaces": [{surface}, {{"radius_mm": -60.0, "thickness_mm": 50.0}}, {{"thickness_mm": 0.0}}]}}"#
        ))
    };
    let conic = make(format!(
        r#"{{"curvature_per_mm": {c}, "conic": -1.0, "thickness_mm": 4.0, "material": {{"nd": 1.6, "vd": 40.0}}}}"#
    ));
    let poly = make(format!(
        r#"{{"type": "even_asphere", "aspheric_coefficients": [{a2}], "thickness_mm": 4.0, "material": {{"nd": 1.6, "vd": 40.0}}}}"#,
        a2 = c / 2.0
    ));
    let trace = |lens: &Lens, y: f64, m: f64| {
        let system = TraceSystem::new(lens, D_LINE, Clipping::None).unwrap();
        let mut ray = Ray::new([0.3, y, -2.0], [0.01, m, 1.0]);
        assert_eq!(system.trace(&mut ray), RayStatus::Ok);
        ray.position_mm
    };
    for (y, m) in [(0.0, 0.0), (3.0, 0.05), (-4.5, 0.1)] {
        let (a, b) = (trace(&conic, y, m), trace(&poly, y, m));
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-11, "y {y}: {a:?} vs {b:?}");
        }
    }
}

#[test]
fn real_aiming_hits_the_stop_where_asked() {
    let lens = lens(&format!(
        r#"{{"format_version": 1, "aperture": {{"entrance_pupil_diameter_mm": 8.0}},
        "fields": {{"angles_deg": [0.0, 30.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}],
        "surfaces": [
          {{"radius_mm": 20.0, "thickness_mm": 4.0, "material": {{"nd": 1.6, "vd": 50.0}}}},
          {{"radius_mm": 60.0, "thickness_mm": 5.0}},
          {{"thickness_mm": 20.0, "stop": true}},
          {{"thickness_mm": 0.0}}]}}"#
    ));
    let aimer = Aimer::new(&lens, D_LINE, Aiming::Real).unwrap();
    let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
    let r_stop = aimer.first_order.stop_radius_mm;
    for field in [0.0, 15.0, 30.0, 40.0] {
        for (px, py) in [(0.0, 0.0), (0.0, 1.0), (0.0, -1.0), (1.0, 0.0), (0.6, -0.6)] {
            let mut ray = aimer.ray(field, px, py).unwrap();
            assert_eq!(system.trace_through(&mut ray, 2, false), RayStatus::Ok);
            assert!(
                (ray.position_mm[0] - px * r_stop).abs() < 1e-10,
                "field {field} ({px},{py})"
            );
            assert!(
                (ray.position_mm[1] - py * r_stop).abs() < 1e-10,
                "field {field} ({px},{py})"
            );
        }
    }
}

#[test]
fn failing_rays_are_flagged_and_never_nan() {
    let lens = singlet(10.0, -10.0, 4.0, 1.5, 10.0);
    let clipped = {
        let mut spec: LensSpec =
            serde_json::from_str(&unicac_optics::format::json::to_string(&to_spec(&lens))).unwrap();
        spec.surfaces[0].semi_diameter_mm = Some(2.0);
        Lens::from_spec(&spec).unwrap()
    };
    let system = TraceSystem::new(&clipped, D_LINE, Clipping::Apertures).unwrap();
    let cases = [
        (Ray::new([0.0, 3.0, -1.0], [0.0, 0.0, 1.0]), "clipped"),
        (Ray::new([0.0, 50.0, -1.0], [0.0, 0.0, 1.0]), "missed"),
        (
            Ray {
                position_mm: [f64::NAN, 0.0, 0.0],
                direction: [0.0, 0.0, 1.0],
            },
            "invalid_input",
        ),
        (Ray::new([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]), "missed"),
    ];
    for (mut ray, kind) in cases {
        let status = system.trace(&mut ray);
        assert_eq!(status.kind(), kind, "{ray:?}");
        if kind != "invalid_input" {
            assert!(ray.is_finite());
        }
    }
}

/// Rebuilds a spec from a lens for tests that tweak one field (surfaces only; enough here).
fn to_spec(lens: &Lens) -> LensSpec {
    let mut spec: LensSpec = serde_json::from_str(&format!(
        r#"{{"format_version": 1, "aperture": {{"entrance_pupil_diameter_mm": 4.0}},
        "fields": {{"angles_deg": [0.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}], "surfaces": []}}"#
    ))
    .unwrap();
    spec.surfaces = lens
        .surfaces
        .iter()
        .map(|s| unicac_optics::spec::SurfaceSpec {
            curvature_per_mm: Some(s.profile.curvature_per_mm),
            thickness_mm: s.thickness_mm,
            material: match &s.medium_after {
                unicac_optics::Medium::Model { nd, vd } => {
                    Some(unicac_optics::spec::MaterialSpec::Model { nd: *nd, vd: *vd })
                }
                _ => None,
            },
            ..Default::default()
        })
        .collect();
    spec
}

#[test]
fn finite_object_images_by_the_gaussian_lens_formula() {
    // Near-thin lens f = 100 mm, object 150 mm in front: image 300 mm behind, magnification -2.
    let (n, f) = (1.5, 100.0);
    let r = 2.0 * f * (n - 1.0);
    let lens = lens(&format!(
        r#"{{"format_version": 1, "object_distance_mm": 150.0, "aperture": {{"entrance_pupil_diameter_mm": 2.0}},
        "fields": {{"angles_deg": [0.0]}}, "wavelengths": [{{"wavelength_um": {D_LINE}}}],
        "surfaces": [
          {{"radius_mm": {r}, "thickness_mm": 1e-9, "material": {{"nd": {n}, "vd": 60.0}}, "stop": true}},
          {{"radius_mm": {}, "thickness_mm": 300.0}},
          {{"thickness_mm": 0.0}}]}}"#,
        -r
    ));
    let first = lens.first_order().unwrap();
    assert!(
        (first.paraxial_image_z_mm - 300.0).abs() < 1e-6,
        "{}",
        first.paraxial_image_z_mm
    );
    assert!(
        (first.magnification + 2.0).abs() < 1e-8,
        "{}",
        first.magnification
    );
    // A paraxially small real ray from the axial object point lands on the axis at the image.
    let aimer = Aimer::new(&lens, D_LINE, Aiming::Paraxial).unwrap();
    let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
    let mut ray = aimer.ray(0.0, 0.0, 0.01).unwrap();
    assert_eq!(ray.position_mm[2], -150.0);
    assert_eq!(system.trace(&mut ray), RayStatus::Ok);
    assert!(ray.position_mm[1].abs() < 1e-6, "{}", ray.position_mm[1]);
}

#[test]
fn f_number_and_floating_stop_apertures_give_the_same_pupil() {
    use unicac_optics::spec::ApertureSpec;
    let base = unicac_optics::builtin::spec("cooke_triplet").unwrap();
    let reference = Lens::from_spec(&base).unwrap().first_order().unwrap();
    let mut by_f_number = base.clone();
    by_f_number.aperture = ApertureSpec::FNumber(reference.f_number);
    let first = Lens::from_spec(&by_f_number).unwrap().first_order().unwrap();
    assert!(relative(first.epd_mm, reference.epd_mm) < 1e-12);
    let mut floating = base.clone();
    floating.aperture = ApertureSpec::FloatByStopSize;
    let stop = Lens::from_spec(&base).unwrap().stop_index;
    floating.surfaces[stop].semi_diameter_mm = Some(reference.stop_radius_mm);
    let first = Lens::from_spec(&floating).unwrap().first_order().unwrap();
    assert!(
        relative(first.epd_mm, reference.epd_mm) < 1e-12,
        "{}",
        first.epd_mm
    );
}

#[test]
fn real_aiming_reaches_wide_fields_where_paraxial_aiming_fails() {
    // Beyond the wide-angle lens's 30 deg design field, paraxially aimed rays miss the stop badly;
    // real aiming still puts them exactly on the requested stop points.
    let lens = unicac_optics::builtin::lens("wide_angle").unwrap();
    let stop = lens.stop_index;
    let paraxial = Aimer::new(&lens, D_LINE, Aiming::Paraxial).unwrap();
    let real = Aimer::new(&lens, D_LINE, Aiming::Real).unwrap();
    let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
    let r_stop = real.first_order.stop_radius_mm;
    for field in [30.0, 40.0, 45.0] {
        for (px, py) in [(0.0, 0.0), (0.0, 1.0), (0.0, -1.0), (1.0, 0.0)] {
            let mut ray = paraxial.ray(field, px, py).unwrap();
            let status = system.trace_through(&mut ray, stop, false);
            let paraxial_error = if status.is_ok() {
                (ray.position_mm[0] - px * r_stop).hypot(ray.position_mm[1] - py * r_stop)
            } else {
                f64::INFINITY
            };
            let mut ray = real.ray(field, px, py).unwrap();
            assert!(system.trace_through(&mut ray, stop, false).is_ok());
            let real_error = (ray.position_mm[0] - px * r_stop).hypot(ray.position_mm[1] - py * r_stop);
            assert!(real_error < 1e-10, "field {field} ({px},{py}): {real_error}");
            if field >= 40.0 && (px, py) == (0.0, 0.0) {
                assert!(
                    paraxial_error > 0.1 * r_stop,
                    "paraxial chief ray error {paraxial_error}"
                );
            }
        }
    }
}

#[test]
fn optical_path_lengths_of_a_perfect_focus_are_equal() {
    // Fermat: every ray of the ellipsoidal refractor (k = -1/n^2) reaches its focus with the same OPL.
    let (n, radius) = (1.5, 10.0);
    let focus = n * radius / (n - 1.0);
    let lens = ellipsoidal_refractor(n, radius);
    let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
    let opl = |h: f64| {
        let mut ray = Ray::new([0.0, h, -5.0], [0.0, 0.0, 1.0]);
        let (status, opl) = system.trace_with_opl(&mut ray);
        assert_eq!(status, RayStatus::Ok);
        opl
    };
    let axial = opl(0.0);
    assert!((axial - (5.0 + n * focus)).abs() < 1e-12);
    for h in [1.0, 3.0, 5.5] {
        assert!((opl(h) - axial).abs() < 1e-11, "h {h}: {}", opl(h) - axial);
    }
}
