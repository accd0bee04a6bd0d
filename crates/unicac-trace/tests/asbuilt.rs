//! Decentred and tilted lenses (issue 36).
//!
//! - Against optiland 0.6.3 (tests/reference/asbuilt, made by `make_asbuilt_references.py`): the same
//!   explicit rays, no clipping; every surface intercept within `INTERCEPT_TOLERANCE_MM` and every RMS
//!   spot radius within `RMS_RELATIVE_TOLERANCE`, for the lens file as written and after the round trip
//!   through `.zmx` (coordinate breaks).
//! - The lane tracer against the scalar step on perturbed lenses: bit equality at every SIMD level.
//! - A lens whose placements are all zero traces bit for bit like the centred one.

use serde_json::Value;
use std::path::{Path, PathBuf};
use unicac_optics::format::zmx;
use unicac_optics::{builtin, load_lens, Lens, LensSpec, Placement};
use unicac_trace::pupil::{counter_hash, unit_interval};
use unicac_trace::{Clipping, Ray, RayStatus, SimdLevel, TraceSystem};

const INTERCEPT_TOLERANCE_MM: f64 = 1e-9;
const RMS_RELATIVE_TOLERANCE: f64 = 1e-6;
const VARIANTS: [&str; 4] = [
    "cooke_decentred",
    "cooke_tilted",
    "cooke_mixed",
    "double_gauss_mixed",
];

fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/reference/asbuilt")
}

fn reference(name: &str) -> Value {
    let text = std::fs::read_to_string(reference_dir().join(format!("{name}.json"))).expect("reference file");
    serde_json::from_str(&text).expect("reference JSON")
}

fn lens(name: &str) -> Lens {
    load_lens(&reference_dir().join(format!("lenses/{name}.json")))
        .expect("as-built lens")
        .0
}

fn vec3(v: &Value) -> [f64; 3] {
    let a = v.as_array().expect("3-vector");
    [0, 1, 2].map(|k| a[k].as_f64().expect("number"))
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

/// `lens` through `.zmx` and back.
fn through_zmx(lens_name: &str) -> Lens {
    let path = reference_dir().join(format!("lenses/{lens_name}.json"));
    let spec: LensSpec = unicac_optics::read_spec(&path).expect("lens").spec;
    let text = zmx::to_string(&spec);
    assert!(
        text.contains("TYPE COORDBRK"),
        "{lens_name}: no coordinate break written"
    );
    let back = zmx::parse(text.as_bytes(), Path::new("roundtrip.zmx")).expect("zmx reads back");
    Lens::from_spec(&back.spec).expect("valid after the round trip")
}

/// Compares `lens` with the optiland reference `name`; returns the largest differences (intercept mm,
/// relative RMS).
fn compare(name: &str, lens: &Lens) -> (f64, f64) {
    let reference = reference(name);
    let mut worst_intercept = 0.0f64;
    let mut rays_compared = 0;
    for record in reference["rays"].as_array().unwrap() {
        let wavelength = f(&record["wavelength_um"]);
        let system = TraceSystem::new(lens, wavelength, Clipping::None).unwrap();
        let ray = Ray::new(vec3(&record["start_mm"]), vec3(&record["direction"]));
        let (points, status) = system.trace_path(ray);
        assert_eq!(
            status.is_ok(),
            record["ok"].as_bool().unwrap(),
            "{name}: {record}"
        );
        if !status.is_ok() {
            continue;
        }
        let expected = record["intercepts_mm"].as_array().unwrap();
        // All surfaces at the primary wavelength, the image surface only at the others.
        let ours = &points[points.len() - expected.len()..];
        for (p, e) in ours.iter().zip(expected) {
            let e = vec3(e);
            for k in 0..3 {
                worst_intercept = worst_intercept.max((p[k] - e[k]).abs());
            }
        }
        rays_compared += 1;
    }
    assert!(rays_compared > 80, "{name}: only {rays_compared} rays arrived");
    let aim = &reference["aiming"];
    let (epd, z_ep) = (f(&aim["epd_mm"]), f(&aim["entrance_pupil_z_mm"]));
    let z0 = z_ep.min(0.0) - 10.0;
    let pupil = unicac_trace::PupilSampling::Hexapolar { rings: 6 }.points();
    let mut worst_rms = 0.0f64;
    for spot in reference["spots"].as_array().unwrap() {
        let system = TraceSystem::new(lens, f(&spot["wavelength_um"]), Clipping::None).unwrap();
        let field = spot["field_deg"].as_array().unwrap();
        let (fx, fy) = (f(&field[0]).to_radians(), f(&field[1]).to_radians());
        let d = Ray::new([0.0; 3], [fx.tan(), fy.tan(), 1.0]).direction;
        let hits: Vec<[f64; 2]> = pupil
            .iter()
            .filter_map(|[px, py]| {
                let s = (z0 - z_ep) / d[2];
                let mut ray = Ray {
                    position_mm: [px * epd / 2.0 + s * d[0], py * epd / 2.0 + s * d[1], z0],
                    direction: d,
                };
                system
                    .trace(&mut ray)
                    .is_ok()
                    .then_some([ray.position_mm[0], ray.position_mm[1]])
            })
            .collect();
        assert_eq!(
            hits.len() as u64,
            spot["rays_ok"].as_u64().unwrap(),
            "{name}: {spot}"
        );
        let n = hits.len() as f64;
        let cx = hits.iter().map(|h| h[0]).sum::<f64>() / n;
        let cy = hits.iter().map(|h| h[1]).sum::<f64>() / n;
        let rms_um = (hits
            .iter()
            .map(|h| (h[0] - cx).powi(2) + (h[1] - cy).powi(2))
            .sum::<f64>()
            / n)
            .sqrt()
            * 1e3;
        let expected = f(&spot["rms_radius_um"]);
        worst_rms = worst_rms.max((rms_um - expected).abs() / expected);
    }
    (worst_intercept, worst_rms)
}

#[test]
fn decentred_and_tilted_lenses_trace_like_optiland() {
    for name in VARIANTS {
        let lens = lens(name);
        assert!(!lens.is_rotationally_symmetric(), "{name}");
        let (intercept, rms) = compare(name, &lens);
        eprintln!("{name}: largest intercept difference {intercept:.2e} mm, RMS {rms:.2e} relative");
        assert!(intercept <= INTERCEPT_TOLERANCE_MM, "{name}: {intercept:e} mm");
        assert!(rms <= RMS_RELATIVE_TOLERANCE, "{name}: {rms:e}");
    }
}

#[test]
fn the_zmx_round_trip_keeps_the_placements() {
    for name in VARIANTS {
        let original = lens(name);
        let back = through_zmx(name);
        for (a, b) in original.surfaces.iter().zip(&back.surfaces) {
            let (p, q) = (a.placement, b.placement);
            assert_eq!(
                (p.decentre_x_mm, p.decentre_y_mm),
                (q.decentre_x_mm, q.decentre_y_mm),
                "{name}"
            );
            assert!(
                (p.tilt_x_deg - q.tilt_x_deg).abs() < 1e-12 && (p.tilt_y_deg - q.tilt_y_deg).abs() < 1e-12,
                "{name}: {p:?} {q:?}"
            );
            // Centred surfaces and every thickness come back bit for bit.
            assert_eq!(a.thickness_mm.to_bits(), b.thickness_mm.to_bits(), "{name}");
            assert_eq!(a.z_mm.to_bits(), b.z_mm.to_bits(), "{name}");
        }
        assert_eq!(original.surfaces.len(), back.surfaces.len(), "{name}");
        assert_eq!(original.stop_index, back.stop_index, "{name}");
        let (intercept, rms) = compare(name, &back);
        eprintln!("{name} via .zmx: largest intercept difference {intercept:.2e} mm, RMS {rms:.2e} relative");
        assert!(
            intercept <= INTERCEPT_TOLERANCE_MM,
            "{name} via .zmx: {intercept:e} mm"
        );
        assert!(rms <= RMS_RELATIVE_TOLERANCE, "{name} via .zmx: {rms:e}");
    }
}

#[test]
fn a_persistent_coordinate_break_moves_every_following_surface() {
    // A break left open (no return) tilts the rest of the system: each later surface reads as decentred
    // and tilted by the same frame, and thicknesses follow the tilted axis.
    let text = "MODE SEQ\nUNIT MM X W X CM MR CPMM\nENPD 10\nFTYP 0 0 1 1 0 0 0\nYFLN 0\nWAVM 1 0.55 1\n\
        SURF 0\n CURV 0\n DISZ INFINITY\n\
        SURF 1\n STOP\n CURV 0.02\n DISZ 5\n GLAS ___BLANK 1 0 1.5 60 0 0 0 0 0 0\n\
        SURF 2\n TYPE COORDBRK\n CURV 0\n PARM 1 0.5\n PARM 3 2.0\n DISZ 0\n\
        SURF 3\n CURV -0.02\n DISZ 40\n\
        SURF 4\n CURV 0\n DISZ 0\n";
    let spec = zmx::parse(text.as_bytes(), Path::new("open.zmx"))
        .expect("reads")
        .spec;
    let lens = Lens::from_spec(&spec).unwrap();
    assert!(lens.surfaces[0].placement.is_centred());
    let turn = 2.0f64.to_radians();
    for (surface, along) in [(&lens.surfaces[1], 0.0), (&lens.surfaces[2], 40.0)] {
        let p = surface.placement;
        assert_eq!(p.decentre_x_mm, 0.5);
        assert!(
            (p.tilt_x_deg - 2.0).abs() < 1e-12 && p.tilt_y_deg.abs() < 1e-12,
            "{p:?}"
        );
        // Along the tilted axis: y goes to -sin(2 deg) * distance.
        assert!((p.decentre_y_mm + along * turn.sin()).abs() < 1e-12, "{p:?}");
        assert!((surface.z_mm - (5.0 + along * turn.cos())).abs() < 1e-12);
    }
}

#[test]
fn coordinate_breaks_that_cannot_be_read_are_errors_naming_the_line() {
    let base =
        "MODE SEQ\nENPD 10\nFTYP 0 0 1 1 0 0 0\nYFLN 0\nWAVM 1 0.55 1\nSURF 0\n CURV 0\n DISZ INFINITY\n";
    for (body, expected) in [
        ("SURF 1\n TYPE COORDBRK\n CURV 0\n STOP\n DISZ 0\nSURF 2\n CURV 0\n DISZ 1\nSURF 3\n CURV 0\n DISZ 0\n", "cannot be the stop"),
        ("SURF 1\n TYPE COORDBRK\n CURV 0\n DISZ 2\nSURF 2\n STOP\n CURV 0\n DISZ 1\nSURF 3\n CURV 0\n DISZ 0\n", "surface 1's vertex"),
    ] {
        let text = format!("{base}{body}");
        let error = zmx::parse(text.as_bytes(), Path::new("bad.zmx")).expect_err(expected).to_string();
        assert!(error.contains(expected) && error.contains("bad.zmx"), "{error}");
    }
}

#[test]
fn zero_placements_trace_bit_for_bit_like_the_centred_lens() {
    let lens = builtin::lens("double_gauss").unwrap();
    let mut spec = builtin::spec("double_gauss").unwrap();
    for s in &mut spec.surfaces {
        s.set_placement(Placement::default());
    }
    let same = Lens::from_spec(&spec).unwrap();
    assert!(same.is_rotationally_symmetric() && lens.is_rotationally_symmetric());
    let rays = random_rays(&lens, 500, 3);
    for wavelength in lens.wavelengths_um() {
        let a = TraceSystem::new(&lens, wavelength, Clipping::Apertures).unwrap();
        let b = TraceSystem::new(&same, wavelength, Clipping::Apertures).unwrap();
        for ray in &rays {
            let (mut p, mut q) = (*ray, *ray);
            assert_eq!(a.trace(&mut p), b.trace(&mut q));
            assert!(same_bits(&p, &q));
        }
    }
}

/// `name` with every surface decentred and tilted by seeded random amounts of about `scale` (mm, deg).
fn perturbed(name: &str, seed: u64, scale: f64) -> Lens {
    let mut spec = builtin::spec(name).unwrap();
    let mut counter = 0;
    let mut uniform = || {
        counter += 1;
        scale * (2.0 * unit_interval(counter_hash(seed, counter)) - 1.0)
    };
    for s in &mut spec.surfaces {
        s.set_placement(Placement {
            decentre_x_mm: uniform(),
            decentre_y_mm: uniform(),
            tilt_x_deg: uniform(),
            tilt_y_deg: uniform(),
        });
    }
    Lens::from_spec(&spec).unwrap()
}

/// Random rays loosely aimed at `lens` (as in tests/lanes.rs): some miss, clip or reflect totally.
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
    let z0 = -0.2 * radius;
    (0..count)
        .map(|i| {
            let tilt = uniform(0.0, 1.2);
            let azimuth = uniform(0.0, std::f64::consts::TAU);
            let start = [uniform(-1.5, 1.5) * radius, uniform(-1.5, 1.5) * radius, z0];
            if i % 97 == 2 {
                return Ray::new([f64::NAN, 0.0, z0], [0.0, 0.0, 1.0]);
            }
            Ray::new(
                start,
                [tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), tilt.cos()],
            )
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

#[test]
fn the_lane_tracer_matches_the_scalar_step_on_perturbed_lenses() {
    let mut kinds = std::collections::BTreeMap::new();
    for name in builtin::names() {
        for (seed, scale) in [(1, 0.05), (2, 1.0)] {
            let lens = perturbed(name, seed, scale);
            let rays = random_rays(&lens, 1500, seed);
            for clipping in [Clipping::Apertures, Clipping::None] {
                let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), clipping).unwrap();
                for &level in &SimdLevel::supported() {
                    let mut lanes = rays.clone();
                    let mut statuses = vec![RayStatus::Ok; rays.len()];
                    system.trace_chunk_at(level, &mut lanes, &mut statuses);
                    for (i, ray) in rays.iter().enumerate() {
                        let mut scalar = *ray;
                        let status = system.trace(&mut scalar);
                        assert_eq!(statuses[i], status, "{name} {seed} {}: ray {i}", level.name());
                        assert!(
                            same_bits(&lanes[i], &scalar),
                            "{name} {seed} {}: ray {i}: {:?} vs {scalar:?}",
                            level.name(),
                            lanes[i]
                        );
                        *kinds.entry(status.kind()).or_insert(0usize) += 1;
                    }
                }
            }
        }
    }
    eprintln!("{kinds:?}");
    for kind in ["ok", "missed", "clipped", "invalid_input"] {
        assert!(kinds.get(kind).copied().unwrap_or(0) > 100, "{kind}: {kinds:?}");
    }
}
