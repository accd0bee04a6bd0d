//! Numerical stress: near-flat and steep surfaces, high-order aspheres, grazing rays, rays outside a
//! conic's domain, zero gaps, extreme scales, random lenses (proptest), and reversibility.

use proptest::prelude::*;
use unicac_optics::spec::{
    ApertureSpec, FieldSpec, LensSpec, MaterialSpec, SurfaceSpec, SurfaceType, WavelengthSpec,
};
use unicac_optics::{builtin, Lens};
use unicac_trace::{spots, Aiming, Clipping, PupilSampling, Ray, RayStatus, TraceSystem};

const D_LINE: f64 = 0.5875618;

fn glass(nd: f64) -> Option<MaterialSpec> {
    Some(MaterialSpec::Model { nd, vd: 50.0 })
}

fn surface(curvature: f64, thickness: f64, material: Option<MaterialSpec>) -> SurfaceSpec {
    SurfaceSpec {
        curvature_per_mm: Some(curvature),
        thickness_mm: thickness,
        material,
        ..Default::default()
    }
}

fn lens_of(surfaces: Vec<SurfaceSpec>) -> Lens {
    let spec = LensSpec {
        format_version: 1,
        name: String::new(),
        provenance: String::new(),
        object_distance_mm: None,
        aperture: ApertureSpec::EntrancePupilDiameterMm(2.0),
        fields: FieldSpec::AnglesDeg(vec![0.0]),
        field_weights: None,
        wavelengths: vec![WavelengthSpec {
            wavelength_um: D_LINE,
            weight: 1.0,
        }],
        primary_wavelength_index: None,
        glass_catalogs: vec![],
        surfaces,
        sensor: None,
    };
    Lens::from_spec(&spec).unwrap()
}

fn trace(lens: &Lens, ray: Ray) -> (Ray, RayStatus) {
    let system = TraceSystem::new(lens, D_LINE, Clipping::Apertures).unwrap();
    let mut ray = ray;
    let status = system.trace(&mut ray);
    assert!(ray.is_finite(), "NaN left the tracer: {ray:?} {status:?}");
    (ray, status)
}

#[test]
fn near_flat_surfaces_converge_to_the_plane() {
    let plane = lens_of(vec![
        surface(0.0, 5.0, glass(1.5)),
        surface(0.0, 10.0, None),
        surface(0.0, 0.0, None),
    ]);
    let start = Ray::new([0.0, 3.0, -1.0], [0.0, 0.2, 1.0]);
    let (reference, _) = trace(&plane, start);
    for c in [1e-15, -1e-12, 1e-9] {
        let near = lens_of(vec![
            surface(c, 5.0, glass(1.5)),
            surface(0.0, 10.0, None),
            surface(0.0, 0.0, None),
        ]);
        let (ray, status) = trace(&near, start);
        assert!(status.is_ok());
        // The sag at r = 3 is c * 4.5 mm; the intercept may move by a few times that.
        let bound = 1e-6f64.max(100.0 * c.abs() * 10.0);
        assert!(
            (ray.position_mm[1] - reference.position_mm[1]).abs() < bound,
            "c = {c}"
        );
    }
}

#[test]
fn steep_surfaces_near_the_hemisphere() {
    // R = 5 hemisphere-ish front: rays up to 0.9999 R arrive or are cleanly flagged; none NaN.
    let lens = lens_of(vec![
        surface(0.2, 6.0, glass(1.5)),
        surface(-0.05, 20.0, None),
        surface(0.0, 0.0, None),
    ]);
    let mut arrived = 0;
    for h in [0.0, 2.0, 4.0, 4.9, 4.99, 4.9999, 5.0, 5.0001, 7.0] {
        let (_, status) = trace(&lens, Ray::new([0.0, h, -1.0], [0.0, 0.0, 1.0]));
        if status.is_ok() {
            arrived += 1;
        }
        if h > 5.0 {
            assert_eq!(status, RayStatus::Missed { surface: 0 }, "h = {h}");
        }
    }
    assert!(arrived >= 3);
}

#[test]
fn high_order_asphere_converges_and_flags_out_of_domain_rays() {
    let mut front = surface(0.1, 3.0, glass(1.55));
    front.surface_type = SurfaceType::EvenAsphere;
    front.conic = -0.5;
    front.aspheric_coefficients = vec![1e-3, -2e-4, 3e-5, -4e-6, 5e-7, -6e-8, 7e-9, -8e-10, 9e-11, -1e-11];
    let lens = lens_of(vec![front, surface(-0.05, 15.0, None), surface(0.0, 0.0, None)]);
    for h in [0.0, 1.0, 2.0, 3.0, 3.5] {
        let (_, status) = trace(&lens, Ray::new([0.0, h, -1.0], [0.0, 0.0, 1.0]));
        assert!(status.is_ok(), "h = {h}: {status}");
    }
    // Domain of the conic base: r^2 < 1 / ((1 + k) c^2) = 200 -> r < 14.1 mm.
    let (_, status) = trace(&lens, Ray::new([0.0, 14.5, -1.0], [0.0, 0.0, 1.0]));
    assert_eq!(status.kind(), "missed");
}

#[test]
fn grazing_rays_never_produce_nan() {
    let lens = lens_of(vec![
        surface(0.05, 4.0, glass(1.7)),
        surface(-0.02, 20.0, None),
        surface(0.0, 0.0, None),
    ]);
    for angle_deg in [80.0f64, 89.0, 89.9, 89.999, 90.0, 95.0] {
        let (s, c) = angle_deg.to_radians().sin_cos();
        let (_, status) = trace(&lens, Ray::new([0.0, -3.0, -0.5], [0.0, s, c]));
        // A ray parallel to the vertex plane in front of a convex surface cannot meet it.
        if angle_deg == 90.0 {
            assert_eq!(status, RayStatus::Missed { surface: 0 }, "{angle_deg}");
        }
    }
}

#[test]
fn zero_air_gaps_and_cemented_surfaces() {
    let lens = lens_of(vec![
        surface(0.05, 3.0, glass(1.5)),
        surface(-0.05, 0.0, None),
        surface(-0.05, 2.0, glass(1.7)),
        surface(0.0, 30.0, None),
        surface(0.0, 0.0, None),
    ]);
    let (_, status) = trace(&lens, Ray::new([0.0, 2.0, -1.0], [0.0, 0.0, 1.0]));
    assert!(status.is_ok(), "{status}");
}

#[test]
fn spot_sizes_scale_linearly_with_the_lens() {
    let base = builtin::spec("cooke_triplet").unwrap();
    let rms = |scale: f64| {
        let mut spec = base.clone();
        for s in &mut spec.surfaces {
            s.curvature_per_mm = Some(s.curvature() / scale);
            s.radius_mm = None;
            s.thickness_mm *= scale;
            s.semi_diameter_mm = s.semi_diameter_mm.map(|d| d * scale);
        }
        if let ApertureSpec::EntrancePupilDiameterMm(d) = spec.aperture {
            spec.aperture = ApertureSpec::EntrancePupilDiameterMm(d * scale);
        }
        let lens = Lens::from_spec(&spec).unwrap();
        let spot = &spots(
            &lens,
            &[14.0],
            &[D_LINE],
            Aiming::Paraxial,
            &PupilSampling::Hexapolar { rings: 6 },
        )
        .unwrap()[0];
        spot.rms_radius_um.unwrap() / scale
    };
    let reference = rms(1.0);
    for scale in [1e-3, 1e3] {
        assert!((rms(scale) / reference - 1.0).abs() < 1e-9, "scale {scale}");
    }
}

/// The same lens seen from the image side: surfaces in reverse order, z mirrored, media shifted.
fn reversed(lens: &Lens) -> Lens {
    let optical = &lens.surfaces[..lens.image_index()];
    let medium = |m: &unicac_optics::Medium| match m {
        unicac_optics::Medium::Model { nd, vd } => Some(MaterialSpec::Model { nd: *nd, vd: *vd }),
        unicac_optics::Medium::Air => None,
        unicac_optics::Medium::Catalog(g) => Some(MaterialSpec::Named(g.qualified_name())),
        other => panic!("no spec form for {other:?}"),
    };
    let mut surfaces: Vec<SurfaceSpec> = optical
        .iter()
        .enumerate()
        .rev()
        .map(|(i, s)| {
            let before = if i == 0 {
                None
            } else {
                medium(&optical[i - 1].medium_after)
            };
            let gap_before = if i == 0 { 10.0 } else { optical[i - 1].thickness_mm };
            surface(-s.profile.curvature_per_mm, gap_before, before)
        })
        .collect();
    surfaces.push(surface(0.0, 0.0, None));
    lens_of(surfaces)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

    /// Random lenses and rays: whatever happens, nothing non-finite comes out, and every ray has a status.
    #[test]
    fn random_lenses_never_yield_nan(
        curvatures in prop::collection::vec(-0.3f64..0.3, 2..8),
        thicknesses in prop::collection::vec(0.0f64..10.0, 8),
        indices in prop::collection::vec(1.0f64..2.2, 8),
        aspheric in prop::collection::vec(-1e-3f64..1e-3, 4),
        conic in -3.0f64..2.0,
        start_y in -8.0f64..8.0,
        slope in -1.5f64..1.5,
    ) {
        let count = curvatures.len();
        let mut surfaces: Vec<SurfaceSpec> = curvatures.iter().enumerate().map(|(i, &c)| {
            let material = if i % 2 == 0 { glass(indices[i]) } else { None };
            surface(c, thicknesses[i], material)
        }).collect();
        surfaces[0].surface_type = SurfaceType::EvenAsphere;
        surfaces[0].conic = conic;
        surfaces[0].aspheric_coefficients = aspheric.clone();
        surfaces.push(surface(0.0, 0.0, None));
        let _ = count;
        let lens = lens_of(surfaces);
        let (ray, status) = trace(&lens, Ray::new([0.3, start_y, -2.0], [0.0, slope, 1.0]));
        prop_assert!(ray.is_finite());
        if status.is_ok() {
            let norm: f64 = ray.direction.iter().map(|d| d * d).sum();
            prop_assert!((norm - 1.0).abs() < 1e-9);
        }
    }

    /// A ray traced forward and then backward through the reversed lens returns to its start.
    #[test]
    fn traced_backwards_a_ray_retraces_its_path(px in -0.9f64..0.9, py in -0.9f64..0.9, field in -20.0f64..20.0) {
        let lens = builtin::lens("cooke_triplet").unwrap();
        let forward = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
        let (s, c) = field.to_radians().sin_cos();
        let start = Ray::new([px * 5.0, py * 5.0 - 10.0 * s / c, -10.0], [0.0, s, c]);
        let mut ray = start;
        // Trace to the last optical surface (refracting there too).
        let last_optical = lens.image_index() - 1;
        prop_assume!(forward.trace_through(&mut ray, last_optical, true).is_ok());
        let back_lens = reversed(&lens);
        let backward = TraceSystem::new(&back_lens, D_LINE, Clipping::None).unwrap();
        let z_last = lens.surfaces[last_optical].z_mm;
        // Mirror z about the last optical surface; the reversed lens has it at z = 0.
        // Reversing the ray, (L, M, N) -> (-L, -M, -N), and mirroring z gives (-L, -M, N).
        let mut back = Ray::new([ray.position_mm[0], ray.position_mm[1], z_last - ray.position_mm[2]],
            [-ray.direction[0], -ray.direction[1], ray.direction[2]]);
        let status = backward.trace(&mut back);
        prop_assert!(status.is_ok(), "{status}");
        // The reversed lens's image plane sits 10 mm before the original surface 1 (z = -10 here).
        prop_assert!((back.position_mm[0] - start.position_mm[0]).abs() < 1e-9, "{:?} vs {:?}", back, start);
        prop_assert!((back.position_mm[1] - start.position_mm[1]).abs() < 1e-9, "{:?} vs {:?}", back, start);
    }
}
