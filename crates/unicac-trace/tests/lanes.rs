//! The SIMD lane tracer (`lanes.rs`) against the scalar per-ray step (`TraceSystem::trace`): same
//! statuses and the same f64 bits for every ray, at every instruction-set level this CPU supports, on
//! random rays that include missed, clipped, totally internally reflected, non-converging and invalid
//! ones. Tolerance: none (bit equality), because both paths perform the same correctly rounded
//! operations in the same order.

use unicac_optics::{builtin, Lens};
use unicac_trace::pupil::{counter_hash, unit_interval};
use unicac_trace::{Clipping, Ray, RayStatus, SimdLevel, StatusCounts, TraceSystem};

/// Random rays aimed loosely at `lens`: starts spread over 1.5x the largest semi-diameter in front of
/// the first surface, directions up to ~70 degrees off axis (some backwards, some grazing), and a few
/// non-finite inputs.
fn random_rays(lens: &Lens, count: usize, seed: u64) -> Vec<Ray> {
    let mut counter = 0u64;
    let mut uniform = |low: f64, high: f64| {
        counter += 1;
        low + (high - low) * unit_interval(counter_hash(seed, counter))
    };
    let radius = lens
        .surfaces
        .iter()
        .filter_map(|s| s.semi_diameter_mm)
        .fold(1.0f64, f64::max);
    let z0 = lens.surfaces[0].z_mm - 0.2 * radius;
    (0..count)
        .map(|i| {
            let x = uniform(-1.5, 1.5) * radius;
            let y = uniform(-1.5, 1.5) * radius;
            let tilt = uniform(0.0, 1.2);
            let azimuth = uniform(0.0, std::f64::consts::TAU);
            let mut direction = [tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), tilt.cos()];
            match i % 97 {
                0 => direction = [1.0, 0.0, 0.0],  // parallel to the tangent planes
                1 => direction[2] = -direction[2], // backwards
                2 => return Ray::new([f64::NAN, y, z0], direction),
                3 => return Ray::new([x, f64::INFINITY, z0], direction),
                4 => direction = [1e-7, 0.0, 1.0], // nearly axial
                _ => {}
            }
            Ray::new([x, y, z0 + uniform(-0.1, 0.1) * radius], direction)
        })
        .collect()
}

fn same_bits(a: &Ray, b: &Ray) -> bool {
    a.position_mm
        .iter()
        .chain(&a.direction)
        .zip(b.position_mm.iter().chain(&b.direction))
        .all(|(p, q)| p.to_bits() == q.to_bits())
}

/// Traces `rays` both ways at `level` and asserts equality; returns the status counts.
fn assert_lanes_equal_scalar(
    system: &TraceSystem,
    rays: &[Ray],
    level: SimdLevel,
    what: &str,
) -> StatusCounts {
    let mut lanes = rays.to_vec();
    let mut statuses = vec![RayStatus::Ok; rays.len()];
    system.trace_chunk_at(level, &mut lanes, &mut statuses);
    let mut counts = StatusCounts::default();
    for (i, ray) in rays.iter().enumerate() {
        let mut scalar = *ray;
        let status = system.trace(&mut scalar);
        assert_eq!(statuses[i], status, "{what}, {}, ray {i}: {ray:?}", level.name());
        assert!(
            same_bits(&lanes[i], &scalar),
            "{what}, {}, ray {i}: lanes {:?} scalar {scalar:?}",
            level.name(),
            lanes[i]
        );
        if status.is_ok() {
            assert!(lanes[i].is_finite(), "{what}: ok ray with non-finite data");
        }
        counts.add(status);
    }
    counts
}

#[test]
fn every_simd_level_traces_bit_for_bit_like_the_scalar_step() {
    let levels = SimdLevel::supported();
    assert!(levels.contains(&SimdLevel::Portable));
    let mut total = StatusCounts::default();
    for name in builtin::names() {
        let lens = builtin::lens(name).unwrap();
        let rays = random_rays(&lens, 4099, 7);
        for clipping in [Clipping::Apertures, Clipping::None] {
            for wavelength_um in [lens.primary_wavelength_um(), 0.45] {
                let system = TraceSystem::new(&lens, wavelength_um, clipping).unwrap();
                for &level in &levels {
                    let what = format!("{name} at {wavelength_um} um, {clipping:?}");
                    let counts = assert_lanes_equal_scalar(&system, &rays, level, &what);
                    if level == SimdLevel::Portable {
                        total = total.merge(counts);
                    }
                }
            }
        }
    }
    // The ray set must exercise every masked path, or the test proves less than it says.
    assert!(total.ok > 10_000, "{total:?}");
    assert!(total.missed > 1_000, "{total:?}");
    assert!(total.clipped > 1_000, "{total:?}");
    assert!(total.tir > 100, "{total:?}");
    assert!(total.invalid_input > 100, "{total:?}");
}

#[test]
fn short_and_ragged_batches_match_the_scalar_step() {
    // Lengths around the block and vector sizes: padding lanes must never leak into results.
    let lens = builtin::lens("phone_asphere").unwrap();
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let rays = random_rays(&lens, 200, 11);
    for &level in &SimdLevel::supported() {
        for len in [0, 1, 3, 4, 5, 7, 8, 9, 63, 64, 65, 127, 129, 200] {
            assert_lanes_equal_scalar(&system, &rays[..len], level, &format!("{len} rays"));
        }
    }
}

#[test]
fn newton_failures_are_flagged_identically() {
    // An even asphere whose polynomial turns the sag over steeply: rays far out meet no surface point
    // Newton can reach, and must fail the same way in both paths (missed or no convergence).
    let json = r#"{"format_version": 1, "aperture": {"entrance_pupil_diameter_mm": 8.0},
        "fields": {"angles_deg": [0.0, 20.0]}, "wavelengths": [{"wavelength_um": 0.55}],
        "surfaces": [
          {"type": "even_asphere", "radius_mm": 20.0, "thickness_mm": 2.0, "material": {"nd": 1.5168, "vd": 64.2}, "stop": true,
           "aspheric_coefficients": [0.0, 0.02, -0.004, 0.0003]},
          {"radius_mm": -20.0, "thickness_mm": 20.0},
          {"thickness_mm": 0.0}]}"#;
    let spec: unicac_optics::LensSpec = serde_json::from_str(json).expect("test lens JSON");
    let lens = Lens::from_spec(&spec).expect("valid test lens");
    let system = TraceSystem::new(&lens, 0.55, Clipping::None).unwrap();
    let rays = random_rays(&lens, 2000, 3);
    let mut counts = StatusCounts::default();
    for &level in &SimdLevel::supported() {
        counts = assert_lanes_equal_scalar(&system, &rays, level, "wild asphere");
    }
    eprintln!("wild asphere: {counts:?}");
    assert!(counts.missed > 10 && counts.no_convergence > 10, "{counts:?}");
}

#[test]
fn detected_level_is_supported_and_levels_above_it_fall_back() {
    let best = SimdLevel::detected();
    assert_eq!(SimdLevel::supported().last(), Some(&best));
    // Asking for AVX-512 on a CPU without it runs the best level it has, with the same results.
    let lens = builtin::lens("cooke_triplet").unwrap();
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let rays = random_rays(&lens, 300, 5);
    assert_lanes_equal_scalar(&system, &rays, SimdLevel::Avx512, "forced avx512");
}
