//! Issue 16: rays given by a user that never reach the lens are `missed`, and random valid lenses
//! never give a ray reported `ok` with non-finite data.

use unicac_optics::spec::{ApertureSpec, FieldSpec, MaterialSpec, SurfaceSpec};
use unicac_optics::{builtin, Lens, LensSpec};
use unicac_trace::pupil::{counter_hash, unit_interval};
use unicac_trace::{spots, Aiming, Clipping, PupilSampling, Ray, RayStatus, StatusCounts, TraceSystem};

const D_LINE: f64 = 0.5875618;

#[test]
fn rays_that_never_reach_the_lens_are_missed() {
    let lens = builtin::lens("cooke_triplet").unwrap();
    let system = TraceSystem::new(&lens, D_LINE, Clipping::Apertures).unwrap();
    // Pointing away from the lens (used to report `ok` with the forward ray's image point).
    let away = Ray::new([0.0, 1.0, -5.0], [0.0, 0.0, -1.0]);
    assert_eq!(
        system.trace_path_from_start(away).1,
        RayStatus::Missed { surface: 0 }
    );
    // Starting past the image surface, pointing along +z.
    let z_image = lens.surfaces[lens.image_index()].z_mm;
    let past = Ray::new([0.0, 1.0, z_image + 10.0], [0.0, 0.0, 1.0]);
    assert_eq!(
        system.trace_path_from_start(past).1,
        RayStatus::Missed { surface: 0 }
    );
    // Starting past the image surface, pointing back at the lens: it reaches surface 1 from behind,
    // then would have to travel backwards to surface 2.
    let back = Ray::new([0.0, 1.0, z_image + 10.0], [0.0, 0.0, -1.0]);
    assert!(!system.trace_path_from_start(back).1.is_ok());
    // An ordinary ray in front of the lens is traced exactly as `trace_path` traces it.
    let forward = Ray::new([0.0, 2.0, -5.0], [0.0, 0.0, 1.0]);
    assert_eq!(system.trace_path_from_start(forward), system.trace_path(forward));
    assert!(system.trace_path_from_start(forward).1.is_ok());
}

/// A random lens that `Lens::from_spec` accepts, from a counter-based generator (so any failing case
/// is reproduced from its index alone): 1 to 8 elements of model glass, spherical or conic surfaces,
/// apertures from F/1.4 to F/16, fields up to 40 degrees.
fn random_lens(seed: u64) -> Option<Lens> {
    let mut counter = 0u64;
    let mut uniform = |low: f64, high: f64| {
        counter += 1;
        low + (high - low) * unit_interval(counter_hash(seed, counter))
    };
    let elements = 1 + (uniform(0.0, 8.0) as usize).min(7);
    let focal_scale = uniform(5.0, 200.0);
    let mut surfaces = Vec::new();
    let stop_at = (uniform(0.0, (2 * elements) as f64) as usize).min(2 * elements - 1);
    for i in 0..2 * elements {
        let glass = i % 2 == 0;
        surfaces.push(SurfaceSpec {
            curvature_per_mm: Some(uniform(-2.5, 2.5) / focal_scale),
            thickness_mm: focal_scale
                * if glass {
                    uniform(0.02, 0.3)
                } else {
                    uniform(0.0, 0.4)
                },
            conic: if uniform(0.0, 1.0) < 0.2 {
                uniform(-3.0, 1.0)
            } else {
                0.0
            },
            material: glass.then(|| MaterialSpec::Model {
                nd: uniform(1.45, 1.95),
                vd: uniform(20.0, 80.0),
            }),
            stop: i == stop_at,
            ..SurfaceSpec::default()
        });
    }
    surfaces.push(SurfaceSpec::default());
    let mut spec: LensSpec = builtin::spec("cooke_triplet").unwrap();
    spec.name = format!("random {seed}");
    spec.surfaces = surfaces;
    spec.object_distance_mm = None;
    spec.aperture = ApertureSpec::FNumber(uniform(1.4, 16.0));
    spec.fields = FieldSpec::AnglesDeg(vec![0.0, uniform(0.0, 28.0), uniform(0.0, 40.0)]);
    spec.field_weights = None;
    let mut lens = Lens::from_spec(&spec).ok()?;
    // Put the image surface at the paraxial focus (when there is one), as a designer would.
    let focus = lens.first_order().ok()?.paraxial_image_z_mm;
    let last = spec.surfaces.len() - 2;
    let gap = focus - lens.surfaces[last].z_mm;
    if gap.is_finite() && gap > 0.0 {
        spec.surfaces[last].thickness_mm = gap;
        lens = Lens::from_spec(&spec).ok()?;
    }
    Some(lens)
}

/// What a sweep saw: lenses built and skipped, and every ray's status.
#[derive(Debug, Default)]
struct Sweep {
    lenses: usize,
    lenses_rejected: usize,
    lenses_without_first_order: usize,
    counts: StatusCounts,
}

/// Traces `rays` random pupil rays at each field of `lenses` random lenses and checks every ray
/// reported `ok`: finite image point and unit direction. Panics name the lens seed.
fn sweep(lenses: u64, rays: usize) -> Sweep {
    let mut result = Sweep::default();
    let fields_per_lens = 3;
    let sampling = PupilSampling::Random {
        n: rays.div_ceil(fields_per_lens),
        seed: 7,
    };
    for seed in 0..lenses {
        let Some(lens) = random_lens(seed) else {
            result.lenses_rejected += 1;
            continue;
        };
        let Ok(first) = lens.first_order() else {
            result.lenses_without_first_order += 1;
            continue;
        };
        result.lenses += 1;
        let system = TraceSystem::new(&lens, D_LINE, Clipping::None).unwrap();
        for &field in &first.field_angles_deg {
            // Through the tracer directly, to see every ray's final state.
            let aimer = unicac_trace::Aimer::new(&lens, D_LINE, Aiming::Paraxial).unwrap();
            let mut traced: Vec<Ray> = sampling
                .points()
                .iter()
                .filter_map(|[px, py]| aimer.ray(field, *px, *py).ok())
                .collect();
            let statuses = unicac_trace::trace_rays(&system, &mut traced);
            for (ray, status) in traced.iter().zip(&statuses) {
                result.counts.add(*status);
                assert!(
                    ray.is_finite(),
                    "lens seed {seed}, field {field}: non-finite ray {ray:?} ({status})"
                );
                if status.is_ok() {
                    let norm: f64 = ray.direction.iter().map(|d| d * d).sum();
                    assert!(
                        (norm - 1.0).abs() < 1e-9,
                        "lens seed {seed}: direction norm {norm}"
                    );
                }
            }
        }
        // The spot summary of the same lens reports only finite numbers.
        let summary = spots(
            &lens,
            &first.field_angles_deg,
            &[D_LINE],
            Aiming::Paraxial,
            &PupilSampling::Hexapolar { rings: 3 },
        )
        .unwrap();
        for spot in summary {
            for value in [spot.rms_radius_um, spot.centroid_x_mm, spot.centroid_y_mm]
                .into_iter()
                .flatten()
            {
                assert!(value.is_finite(), "lens seed {seed}: spot value {value}");
            }
        }
    }
    result
}

#[test]
fn random_valid_lenses_never_report_non_finite_rays() {
    let result = sweep(200, 1000);
    eprintln!("{result:?}");
    assert!(result.lenses >= 100, "{result:?}");
    assert!(
        result.counts.ok > 0 && result.counts.total() >= 100 * 999,
        "{result:?}"
    );
}

/// The full size: 10,000 lenses x 10,000 rays (1e8 rays). Run by hand:
/// `cargo test --release -p unicac-trace --test reliability -- --ignored --nocapture`.
#[test]
#[ignore]
fn random_valid_lenses_full_size() {
    let start = std::time::Instant::now();
    let result = sweep(10_000, 10_000);
    eprintln!("{result:?} in {:.1} s", start.elapsed().as_secs_f64());
    assert!(result.lenses >= 5_000, "{result:?}");
}

/// The singlet example with a fuzzer's extreme data: a finite object distance, an entrance-pupil
/// diameter, field image heights, equally weighted wavelengths and surfaces.
fn fuzzed_lens_spec(
    object_distance_mm: f64,
    epd_mm: f64,
    image_heights_mm: Vec<f64>,
    wavelengths_um: &[f64],
    surfaces: Vec<SurfaceSpec>,
) -> LensSpec {
    let mut spec: LensSpec = builtin::spec("singlet").unwrap();
    spec.object_distance_mm = Some(object_distance_mm);
    spec.aperture = ApertureSpec::EntrancePupilDiameterMm(epd_mm);
    spec.fields = FieldSpec::ImageHeightsMm(image_heights_mm);
    spec.field_weights = None;
    spec.wavelengths = wavelengths_um
        .iter()
        .map(|&w| unicac_optics::spec::WavelengthSpec {
            wavelength_um: w,
            weight: 1.0,
        })
        .collect();
    spec.primary_wavelength_index = None;
    spec.surfaces = surfaces;
    spec
}

/// A surface of a fuzzed spec: curvature, thickness, conic, even-asphere terms (none: standard), an
/// optional model glass (nd, Vd), an optional semi-diameter, and whether it is the stop.
fn fuzzed_surface(
    c: f64,
    t: f64,
    k: f64,
    a: Vec<f64>,
    glass: Option<(f64, f64)>,
    semi: Option<f64>,
    stop: bool,
) -> SurfaceSpec {
    SurfaceSpec {
        surface_type: if a.is_empty() {
            unicac_optics::spec::SurfaceType::Standard
        } else {
            unicac_optics::spec::SurfaceType::EvenAsphere
        },
        curvature_per_mm: Some(c),
        thickness_mm: t,
        conic: k,
        aspheric_coefficients: a,
        material: glass.map(|(nd, vd)| MaterialSpec::Model { nd, vd }),
        semi_diameter_mm: semi,
        stop,
        ..SurfaceSpec::default()
    }
}

/// The fuzz harness's pupil points (`fuzz/fuzz_targets/common.rs`).
const FUZZ_PUPIL_POINTS: [[f64; 2]; 4] = [[0.0, 0.0], [0.0, 1.0], [0.7, -0.7], [-1.0, 0.0]];

/// Traces the paraxially aimed rays of the lens's first three fields through the scalar and the lane
/// tracer; asserts that both agree bit for bit and that every ray stays finite, and every `ok` one has a
/// unit direction. Returns the statuses.
fn trace_both_ways(lens: &Lens) -> Vec<RayStatus> {
    let first = lens.first_order().unwrap();
    let wavelength = lens.primary_wavelength_um();
    let system = TraceSystem::new(lens, wavelength, Clipping::Apertures).unwrap();
    let aimer = unicac_trace::Aimer::new(lens, wavelength, Aiming::Paraxial).unwrap();
    let rays: Vec<Ray> = first
        .field_angles_deg
        .iter()
        .take(3)
        .flat_map(|&field| FUZZ_PUPIL_POINTS.iter().map(move |&[px, py]| (field, px, py)))
        .filter_map(|(field, px, py)| aimer.ray(field, px, py).ok())
        .collect();
    assert!(!rays.is_empty());
    let mut lanes = rays.clone();
    let mut lane_statuses = vec![RayStatus::Ok; lanes.len()];
    system.trace_chunk(&mut lanes, &mut lane_statuses);
    let mut statuses = Vec::new();
    for ((mut ray, lane), lane_status) in rays.into_iter().zip(&lanes).zip(&lane_statuses) {
        let status = system.trace(&mut ray);
        assert!(ray.is_finite(), "{status}: {ray:?}");
        assert_eq!(status, *lane_status, "scalar and lane tracers agree");
        assert_eq!(ray.position_mm, lane.position_mm);
        assert_eq!(ray.direction, lane.direction);
        if status.is_ok() {
            let norm: f64 = ray.direction.iter().map(|d| d * d).sum();
            assert!(
                (norm - 1.0).abs() < 1e-6,
                "ok ray without a unit direction: {ray:?}"
            );
        }
        statuses.push(status);
    }
    statuses
}

/// Fuzzing regression (`lens_model`, 2026-12-02): a lens with finite but extreme data (an object
/// 6e-314 mm away, a pupil 6e257 mm behind it) made paraxial aiming return a ray whose direction was
/// [NaN, -inf, inf]. Aiming now refuses a non-finite ray with an error; any ray it gives is finite.
#[test]
fn extreme_lens_data_never_aim_a_non_finite_ray() {
    let spec = fuzzed_lens_spec(
        6.3659885167e-314,
        4.38362120400908e-193,
        vec![
            6.444099150936363e257,
            6.444099150936363e257,
            -1.8293195150832117e-253,
        ],
        &[
            6.444099150936386e257,
            6.444099150936363e257,
            6.444099150936363e257,
            4.186342259261225e-149,
            4.186341030828635e-149,
            1.257582681175048e-308,
        ],
        vec![
            fuzzed_surface(
                7.291122019556398e-304,
                6.44409914276555e257,
                6.444099150936363e257,
                vec![],
                Some((2.2953128657477968e256, 1.63594197111569e261)),
                None,
                true,
            ),
            fuzzed_surface(1.81574e-319, 0.0, 0.0, vec![], None, None, false),
        ],
    );
    // The lens may be refused outright; what it must never do is aim a non-finite ray.
    let Ok(lens) = Lens::from_spec(&spec) else { return };
    let Ok(first) = lens.first_order() else { return };
    let wavelength = lens.primary_wavelength_um();
    let Ok(aimer) = unicac_trace::Aimer::new(&lens, wavelength, Aiming::Paraxial) else {
        return;
    };
    let mut refused = 0;
    for &field in first.field_angles_deg.iter().take(3) {
        for [px, py] in FUZZ_PUPIL_POINTS {
            match aimer.ray(field, px, py) {
                Ok(ray) => assert!(ray.is_finite(), "aimed ray not finite: {ray:?}"),
                Err(_) => refused += 1,
            }
        }
    }
    assert!(
        refused > 0,
        "the fuzzed lens's overflowing rays are refused, not traced"
    );
}

/// Fuzzing regression (`lens_json`, 2026-12-02): a phone lens whose surface 12 has an r^2 coefficient of
/// 6.14e306 overflowed the surface normal, refraction gave a NaN direction with status `ok` for that
/// surface, and the ray reached the caller holding NaN (as `missed` at the next surface). Both tracers
/// now report `missed` at the surface whose normal overflows, and the ray keeps finite data.
#[test]
fn an_overflowing_surface_normal_misses_the_ray_and_keeps_it_finite() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz_lens_json_overflowing_normal.json");
    let bytes = std::fs::read(&path).unwrap();
    let spec = unicac_optics::format::json::parse(&bytes, &path).unwrap();
    let statuses = trace_both_ways(&Lens::from_spec(&spec).unwrap());
    assert!(
        statuses.contains(&RayStatus::Missed { surface: 12 }),
        "the overflowing surface loses some rays"
    );
}

/// Fuzzing regression (`lens_model`, 2026-12-02): an index ratio of about 5e36 between two model glasses
/// (nd 8.6e192 then 1.8e156) cancelled the refracted direction to [0, 0, 0], reported `ok`. Both tracers
/// now report such a ray `missed` at that surface; every ray reported `ok` has a unit direction.
#[test]
fn a_refraction_that_cancels_the_direction_misses_the_ray() {
    let spec = fuzzed_lens_spec(
        1.390671153797295e-309,
        3.658696952696364e-111,
        vec![-1.829175133157691e-253],
        &[6.444099150936454e257, 6.444099150936363e257],
        vec![
            fuzzed_surface(
                4.186342259261225e-149,
                6.141501531882228e-149,
                2.028752738975725e-309,
                vec![1.14970054116e-313],
                None,
                None,
                false,
            ),
            fuzzed_surface(
                1.678076560593478e-147,
                6.593295591259359e259,
                -8.348572013879745e-234,
                vec![],
                Some((8.554576158041617e192, 6.443833381907996e257)),
                Some(6.44409915093624e257),
                true,
            ),
            fuzzed_surface(
                -1.8291751280872214e-253,
                1.9889752002392534e-304,
                2.568425733177917e207,
                vec![-8.618545049796882e-188],
                Some((1.7565805777302384e156, 1.756580577739303e156)),
                None,
                false,
            ),
            fuzzed_surface(8.288793e-317, 0.0, 0.0, vec![], None, None, false),
        ],
    );
    trace_both_ways(&Lens::from_spec(&spec).unwrap());
}
