//! Real ray aiming on a lens with strong pupil aberration: the 100-degree retrofocus
//! `lenses/wide_angle_100.json` (Laikin p. 108 via optiland, stop surface 9 of 20, 50 deg half field),
//! against optiland rays aimed explicitly at the stop by tests/reference/make_aimed_references.py
//! (tests/reference/aimed/wide_angle_100.json; Newton on optiland's own trace, never on unicac's).
//! Tolerances: stop intercepts 1e-9 relative to R_stop; image intercepts 1e-9 mm; RMS spot radii
//! 1e-9 relative (the same hexapolar rays, so only tracing arithmetic and aiming convergence differ).

use serde_json::Value;
use std::path::Path;
use unicac_optics::{builtin, Lens};
use unicac_trace::{spots, Aimer, Aiming, AutoAiming, Clipping, PupilSampling, TraceSystem};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn wide_angle() -> Lens {
    unicac_optics::format::load_lens(&Path::new(ROOT).join("lenses/wide_angle_100.json"))
        .unwrap()
        .0
}

fn reference() -> Value {
    let path = Path::new(ROOT).join("tests/reference/aimed/wide_angle_100.json");
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn real_aimed_rays_cross_the_stop_where_the_convention_says_at_every_field() {
    let lens = wide_angle();
    let first = lens.first_order().unwrap();
    let r_stop = first.stop_radius_mm;
    assert!((r_stop - f(&reference()["aiming"]["stop_marginal_height_mm"])).abs() < 1e-9 * r_stop);
    for wavelength in lens.wavelengths_um() {
        let aimer = Aimer::new(&lens, wavelength, Aiming::Real).unwrap();
        let system = TraceSystem::new(&lens, wavelength, Clipping::None).unwrap();
        for field in [0.0, 10.0, 20.0, 35.0, 50.0] {
            for (px, py) in [(0.0, 1.0), (0.0, -1.0), (1.0, 0.0), (0.0, 0.0), (0.6, -0.7)] {
                let mut ray = aimer.ray(field, px, py).unwrap();
                assert!(system.trace_through(&mut ray, lens.stop_index, false).is_ok());
                let miss = (ray.position_mm[0] - px * r_stop).hypot(ray.position_mm[1] - py * r_stop);
                assert!(
                    miss <= 1e-9 * r_stop,
                    "{wavelength} um, {field} deg, pupil ({px}, {py}): misses its stop point by {miss:e} mm"
                );
            }
        }
    }
}

#[test]
#[allow(clippy::needless_range_loop)] // axis indexes three arrays
fn real_aimed_rays_match_the_stop_aimed_references() {
    let lens = wide_angle();
    let r = reference();
    let mut checked = 0;
    for ray in r["rays"].as_array().unwrap() {
        assert_eq!(ray["ok"], true, "the reference aims every ray: {ray}");
        let wavelength = f(&ray["wavelength_um"]);
        let aimer = Aimer::new(&lens, wavelength, Aiming::Real).unwrap();
        let system = TraceSystem::new(&lens, wavelength, Clipping::None).unwrap();
        let pupil: Vec<f64> = ray["pupil"].as_array().unwrap().iter().map(f).collect();
        let mut ours = aimer.ray(f(&ray["field_deg"]), pupil[0], pupil[1]).unwrap();
        // The start point: same ray, so the same height on the reference's start plane.
        let start = ray["start_mm"].as_array().unwrap();
        let t = (f(&start[2]) - ours.position_mm[2]) / ours.direction[2];
        for axis in 0..2 {
            let on_plane = ours.position_mm[axis] + t * ours.direction[axis];
            assert!(
                (on_plane - f(&start[axis])).abs() < 1e-9,
                "start {axis}: {on_plane} vs {} ({ray})",
                start[axis]
            );
        }
        assert!(system.trace(&mut ours).is_ok());
        for (axis, key) in ["x_mm", "y_mm"].iter().enumerate() {
            let d = (ours.position_mm[axis] - f(&ray[*key])).abs();
            assert!(
                d < 1e-9,
                "{key}: {} vs {} ({ray})",
                ours.position_mm[axis],
                ray[*key]
            );
        }
        checked += 1;
    }
    assert_eq!(checked, 3 * 4 * 6);
}

fn assert_spots_match(aiming: Aiming) -> f64 {
    let lens = wide_angle();
    let mut worst = 0.0f64;
    for spot in reference()["spots"].as_array().unwrap() {
        let ours = &spots(
            &lens,
            &[f(&spot["field_deg"])],
            &[f(&spot["wavelength_um"])],
            aiming,
            &PupilSampling::Hexapolar { rings: 6 },
        )
        .unwrap()[0];
        assert_eq!(ours.rays_ok as u64, spot["rays_ok"].as_u64().unwrap(), "{spot}");
        let (rms, theirs) = (ours.rms_radius_um.unwrap(), f(&spot["rms_radius_um"]));
        worst = worst.max((rms - theirs).abs() / theirs);
        assert!(
            (rms - theirs).abs() <= 1e-9 * theirs,
            "{aiming:?} field {} wl {}: RMS {rms} um vs {theirs} um",
            spot["field_deg"],
            spot["wavelength_um"]
        );
        assert!((ours.centroid_y_mm.unwrap() - f(&spot["centroid_y_mm"])).abs() < 1e-9);
    }
    worst
}

#[test]
fn real_aimed_spot_radii_equal_the_references() {
    let worst = assert_spots_match(Aiming::Real);
    println!("real aiming: worst relative RMS difference {worst:e}");
}

#[test]
fn default_aimed_spot_radii_equal_the_real_aimed_references() {
    assert_eq!(Aiming::default(), Aiming::Auto);
    let worst = assert_spots_match(Aiming::default());
    println!("default aiming: worst relative RMS difference {worst:e}");
}

#[test]
fn auto_aiming_switches_on_the_wide_angle_only() {
    let decision = AutoAiming::decide(&wide_angle()).unwrap();
    println!("wide_angle_100: {decision:?}");
    assert_eq!(decision.aiming, Aiming::Real);
    assert!(decision.chief_ray_stop_miss.is_none_or(|m| m > 0.1));
    // The bundled classics keep paraxial aiming, so their results stay as they were, bit for bit.
    let decisions: Vec<(&str, AutoAiming)> = builtin::names()
        .map(|name| (name, AutoAiming::decide(&builtin::lens(name).unwrap()).unwrap()))
        .collect();
    for (name, decision) in &decisions {
        println!("{name}: {decision:?}");
    }
    for (name, decision) in &decisions {
        assert_eq!(decision.aiming, Aiming::Paraxial, "{name}");
    }
}
