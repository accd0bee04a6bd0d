//! Batch real aiming (`Aimer::rays_at`: an aiming map, then chord-Newton steps per ray) against the
//! per-ray solve (`Aimer::ray_at`) it replaces for many-ray callers.
//!
//! Stated bound, checked here on every ray: each batch-aimed ray crosses the stop within
//! 1e-13 R_stop (per axis) of its target, the per-ray solve's own tolerance, so the two rays of one
//! pupil point differ by at most about twice that at the stop; their image intercepts agree within
//! 1e-9 mm. Lenses: the 100-degree retrofocus (the lens that needs real aiming), the Cooke triplet and
//! the bundled reverse telephoto, all aimed for real, every wavelength, fields from the axis to the edge.

use std::path::Path;
use unicac_optics::{builtin, Lens};
use unicac_trace::{Aimer, Aiming, Clipping, PupilSampling, TraceSystem};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn wide_angle_100() -> Lens {
    unicac_optics::format::load_lens(&Path::new(ROOT).join("lenses/wide_angle_100.json"))
        .unwrap()
        .0
}

/// Largest per-axis stop-intercept error of `ray` for target p * R_stop, as a fraction of R_stop.
fn stop_error(lens: &Lens, wavelength: f64, ray: unicac_trace::Ray, p: [f64; 2]) -> f64 {
    let system = TraceSystem::new(lens, wavelength, Clipping::None).unwrap();
    let r_stop = lens.first_order().unwrap().stop_radius_mm;
    let mut ray = ray;
    assert!(system.trace_through(&mut ray, lens.stop_index, false).is_ok());
    let hit = system.to_surface_frame(lens.stop_index, ray.position_mm);
    (hit[0] - p[0] * r_stop).abs().max((hit[1] - p[1] * r_stop).abs()) / r_stop
}

fn check_lens(name: &str, lens: &Lens, fields: &[f64]) {
    let pupil = PupilSampling::Fibonacci { n: 700 }.points();
    let mut worst_stop = 0.0f64;
    let mut worst_image_mm = 0.0f64;
    for wavelength in lens.wavelengths_um() {
        let aimer = Aimer::new(lens, wavelength, Aiming::Real).unwrap();
        let system = TraceSystem::new(lens, wavelength, Clipping::None).unwrap();
        for &field in fields {
            let batch = aimer.rays(field, &pupil);
            assert_eq!(batch.len(), pupil.len());
            for (&[px, py], batch_ray) in pupil.iter().zip(batch) {
                let single = aimer.ray(field, px, py);
                let (batch_ray, single) = match (batch_ray, single) {
                    (Ok(b), Ok(s)) => (b, s),
                    (Err(_), Err(_)) => continue,
                    (b, s) => panic!("{name} {field} deg ({px}, {py}): batch {b:?} vs per-ray {s:?}"),
                };
                let error = stop_error(lens, wavelength, batch_ray, [px, py]);
                assert!(
                    error <= 1e-13,
                    "{name} {field} deg ({px}, {py}): stop error {error:e} R_stop"
                );
                worst_stop = worst_stop.max(error);
                let (mut a, mut b) = (batch_ray, single);
                if system.trace(&mut a).is_ok() && system.trace(&mut b).is_ok() {
                    let d = (a.position_mm[0] - b.position_mm[0]).hypot(a.position_mm[1] - b.position_mm[1]);
                    assert!(
                        d <= 1e-9,
                        "{name} {field} deg ({px}, {py}): image intercepts {d:e} mm apart"
                    );
                    worst_image_mm = worst_image_mm.max(d);
                }
            }
        }
    }
    println!(
        "{name}: worst stop error {worst_stop:.2e} R_stop, worst image difference {worst_image_mm:.2e} mm"
    );
}

#[test]
fn batch_aiming_meets_the_per_ray_tolerance_on_the_wide_angle_100() {
    check_lens(
        "wide_angle_100",
        &wide_angle_100(),
        &[0.0, 12.5, 25.0, 37.5, 45.0, 50.0],
    );
}

#[test]
fn batch_aiming_meets_the_per_ray_tolerance_on_classic_lenses() {
    check_lens(
        "cooke_triplet",
        &builtin::lens("cooke_triplet").unwrap(),
        &[0.0, 14.0, 20.0],
    );
    check_lens(
        "wide_angle",
        &builtin::lens("wide_angle").unwrap(),
        &[0.0, 21.0, 30.0],
    );
}

#[test]
fn small_pupils_and_paraxial_aiming_give_the_per_ray_rays_bit_for_bit() {
    let lens = wide_angle_100();
    let pupil = PupilSampling::Hexapolar { rings: 3 }.points();
    for aiming in [Aiming::Real, Aiming::Paraxial] {
        let aimer = Aimer::new(&lens, lens.primary_wavelength_um(), aiming).unwrap();
        for (&[px, py], ray) in pupil.iter().zip(aimer.rays(40.0, &pupil)) {
            let single = aimer.ray(40.0, px, py).unwrap();
            assert_eq!(ray.unwrap(), single, "{aiming:?} ({px}, {py})");
        }
    }
}

#[test]
fn paraxially_aimed_rays_drop_the_points_that_cannot_be_aimed_and_keep_the_order() {
    let lens = builtin::lens("cooke_triplet").unwrap();
    let aimer = Aimer::new(&lens, lens.primary_wavelength_um(), Aiming::Paraxial).unwrap();
    let mut pupil = PupilSampling::Hexapolar { rings: 4 }.points();
    pupil[3] = [f64::NAN, 0.2];
    pupil[17] = [0.1, f64::INFINITY];
    let aiming = aimer.for_field([0.0, 14.0], pupil.len());
    // Rays already in the buffer stay, and are not counted.
    let earlier = aimer.ray(5.0, 0.0, 0.5).unwrap();
    let mut out = vec![earlier; 2];
    let not_aimed = aiming.aimed_rays_into(&pupil, &mut out);
    assert_eq!(not_aimed, 2);
    let expected: Vec<_> = pupil
        .iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .map(|&[px, py]| aimer.ray(14.0, px, py).unwrap())
        .collect();
    assert_eq!(out[..2], [earlier, earlier]);
    assert_eq!(out[2..], expected[..]);
}
