//! unicac against optiland 0.6.3 and ray-optics 0.9.10 on every lens of `lenses/`
//! (tests/reference/{optiland,rayoptics}/*.json, made by tests/reference/make_references.py).
//! Both tools were given the same refractive indices (recorded in the files and checked here first),
//! so differences are tracing arithmetic only. Tolerances, as issue 2 states them:
//! first-order data 1e-9 relative; real-ray intercepts 1e-9 mm; RMS spot radius 1e-9 relative.
//! One stated exception: ray-optics places an object at infinity 1e10 mm away, which perturbs its
//! first-order values (pupil positions by up to 1.3e-6 mm, F/# by ~3e-9 relative; see
//! tests/reference/README.md), so its first-order data are held to 1e-7 relative + 2e-6 mm.

use serde_json::Value;
use unicac_optics::builtin;
use unicac_trace::{spots, Aimer, Aiming, Clipping, PupilSampling, Ray, TraceSystem};

const TOOLS: [&str; 2] = ["optiland", "rayoptics"];

fn reference(tool: &str, lens: &str) -> Value {
    let path = format!(
        "{}/../../tests/reference/{tool}/{lens}.json",
        env!("CARGO_MANIFEST_DIR")
    );
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))).unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn close(ours: f64, theirs: f64, relative: f64, absolute: f64) -> bool {
    (ours - theirs).abs() <= relative * theirs.abs().max(ours.abs()) + absolute
}

#[test]
fn refractive_indices_match_the_references() {
    for tool in TOOLS {
        for name in builtin::names() {
            let lens = builtin::lens(name).unwrap();
            let r = reference(tool, name);
            for (w, row) in r["wavelengths_um"]
                .as_array()
                .unwrap()
                .iter()
                .zip(r["indices"].as_array().unwrap())
            {
                let ours = lens.media_indices(f(w)).unwrap();
                for (i, n) in row.as_array().unwrap().iter().enumerate() {
                    assert!(
                        close(ours[i + 1], f(n), 0.0, 1e-12),
                        "{tool} {name} surface {} at {w}: {} vs {n}",
                        i + 1,
                        ours[i + 1]
                    );
                }
            }
        }
    }
}

#[test]
fn first_order_data_match_the_references() {
    let mut worst = 0.0f64;
    let mut failures = Vec::new();
    for tool in TOOLS {
        for name in builtin::names() {
            let first = builtin::lens(name).unwrap().first_order().unwrap();
            let r = &reference(tool, name)["first_order"];
            let (relative, absolute) = if tool == "rayoptics" {
                (1e-7, 2e-6)
            } else {
                (1e-9, 1e-12)
            };
            let pairs = [
                ("efl_mm", Some(first.efl_mm)),
                ("bfl_mm", Some(first.bfl_mm)),
                ("ffl_mm", Some(first.ffl_mm)),
                ("epd_mm", Some(first.epd_mm)),
                ("entrance_pupil_z_mm", Some(first.entrance_pupil_z_mm)),
                ("exit_pupil_z_mm", first.exit_pupil_z_mm),
                ("exit_pupil_diameter_mm", first.exit_pupil_diameter_mm),
                ("f_number", Some(first.f_number)),
                ("total_track_mm", Some(first.total_track_mm)),
                ("stop_marginal_height_mm", Some(first.stop_radius_mm)),
            ];
            for (key, ours) in pairs {
                let Some(theirs) = r.get(key).and_then(Value::as_f64) else {
                    continue;
                };
                let ours = ours.unwrap_or_else(|| panic!("{name}: {key} missing"));
                if tool == "optiland" {
                    worst = worst.max((ours - theirs).abs() / theirs.abs().max(1e-300));
                }
                if !close(ours, theirs, relative, absolute) {
                    failures.push(format!("{tool} {name} {key}: ours {ours} vs {theirs}"));
                }
            }
            // Both tools report the paraxial chief ray's height on the image surface.
            if let Some(heights) = r.get("paraxial_image_heights_mm").and_then(Value::as_array) {
                for (ours, theirs) in first
                    .paraxial_chief_heights_at_image_surface_mm
                    .iter()
                    .zip(heights)
                {
                    // Sign conventions differ between tools; magnitudes must agree.
                    if !close(ours.abs(), f(theirs).abs(), relative, absolute) {
                        failures.push(format!("{tool} {name} image height {ours} vs {theirs}"));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    println!("worst relative first-order difference against optiland: {worst:e}");
}

#[test]
fn real_ray_intercepts_match_the_references() {
    let mut worst = 0.0f64;
    for tool in TOOLS {
        for name in builtin::names() {
            let lens = builtin::lens(name).unwrap();
            let r = reference(tool, name);
            for ray in r["rays"].as_array().unwrap() {
                let system = TraceSystem::new(&lens, f(&ray["wavelength_um"]), Clipping::Apertures).unwrap();
                let start: Vec<f64> = ray["start_mm"].as_array().unwrap().iter().map(f).collect();
                let dir: Vec<f64> = ray["direction"].as_array().unwrap().iter().map(f).collect();
                let mut traced = Ray::new([start[0], start[1], start[2]], [dir[0], dir[1], dir[2]]);
                let status = system.trace(&mut traced);
                assert_eq!(
                    status.is_ok(),
                    ray["ok"].as_bool().unwrap(),
                    "{tool} {name} {ray}: {status}"
                );
                if status.is_ok() {
                    for (axis, key) in ["x_mm", "y_mm", "z_mm"].iter().enumerate() {
                        let d = (traced.position_mm[axis] - f(&ray[*key])).abs();
                        worst = worst.max(d);
                        assert!(
                            d < 1e-9,
                            "{tool} {name} {key}: {} vs {}",
                            traced.position_mm[axis],
                            ray[*key]
                        );
                    }
                }
            }
        }
    }
    println!("worst intercept difference: {worst:e} mm");
}

#[test]
fn paraxially_aimed_rays_start_where_the_references_start_them() {
    for tool in TOOLS {
        for name in builtin::names() {
            let lens = builtin::lens(name).unwrap();
            let r = reference(tool, name);
            for ray in r["rays"].as_array().unwrap() {
                let aimer = Aimer::new(&lens, f(&ray["wavelength_um"]), Aiming::Paraxial).unwrap();
                let pupil: Vec<f64> = ray["pupil"].as_array().unwrap().iter().map(f).collect();
                let ours = aimer.ray(f(&ray["field_deg"]), pupil[0], pupil[1]).unwrap();
                let start: Vec<f64> = ray["start_mm"].as_array().unwrap().iter().map(f).collect();
                let dir: Vec<f64> = ray["direction"].as_array().unwrap().iter().map(f).collect();
                for (o, d) in ours.direction.iter().zip(&dir) {
                    assert!((o - d).abs() < 1e-12, "{tool} {name} direction");
                }
                // Same line: the reference start point lies on our ray.
                let t = (start[2] - ours.position_mm[2]) / ours.direction[2];
                for ((p, d), s) in ours.position_mm.iter().zip(&ours.direction).zip(&start).take(2) {
                    let on_ours = p + t * d;
                    assert!(
                        (on_ours - s).abs() < 1e-9,
                        "{tool} {name} {ray}: {on_ours} vs {s}"
                    );
                }
            }
        }
    }
}

#[test]
fn rms_spot_radii_match_the_references() {
    let mut worst = 0.0f64;
    for tool in TOOLS {
        for name in builtin::names() {
            let lens = builtin::lens(name).unwrap();
            for spot in reference(tool, name)["spots"].as_array().unwrap() {
                let ours = &spots(
                    &lens,
                    &[f(&spot["field_deg"])],
                    &[f(&spot["wavelength_um"])],
                    Aiming::Paraxial,
                    &PupilSampling::Hexapolar { rings: 6 },
                )
                .unwrap()[0];
                assert_eq!(ours.rays_traced as u64, spot["rays_traced"].as_u64().unwrap());
                assert_eq!(
                    ours.rays_ok as u64,
                    spot["rays_ok"].as_u64().unwrap(),
                    "{tool} {name}"
                );
                let theirs = f(&spot["rms_radius_um"]);
                let rms = ours.rms_radius_um.unwrap();
                worst = worst.max((rms - theirs).abs() / theirs);
                assert!(
                    close(rms, theirs, 1e-9, 1e-12),
                    "{tool} {name} field {}: {rms} vs {theirs}",
                    spot["field_deg"]
                );
                assert!((ours.centroid_y_mm.unwrap() - f(&spot["centroid_y_mm"])).abs() < 1e-9);
            }
        }
    }
    println!("worst relative RMS difference: {worst:e}");
}

#[test]
fn real_aimed_rays_match_the_references() {
    for tool in TOOLS {
        for name in builtin::names() {
            let lens = builtin::lens(name).unwrap();
            let r = reference(tool, name);
            let Some(rays) = r.get("real_aimed").and_then(Value::as_array) else {
                continue;
            };
            for ray in rays.iter().filter(|r| r["ok"].as_bool() == Some(true)) {
                let wavelength = f(&ray["wavelength_um"]);
                let aimer = Aimer::new(&lens, wavelength, Aiming::Real).unwrap();
                // The references trace aimed rays without aperture clipping.
                let system = TraceSystem::new(&lens, wavelength, Clipping::None).unwrap();
                let pupil: Vec<f64> = ray["pupil"].as_array().unwrap().iter().map(f).collect();
                let mut ours = aimer.ray(f(&ray["field_deg"]), pupil[0], pupil[1]).unwrap();
                let status = system.trace(&mut ours);
                assert!(status.is_ok(), "{tool} {name} {ray}: {status}");
                for (axis, key) in ["x_mm", "y_mm"].iter().enumerate() {
                    let d = (ours.position_mm[axis] - f(&ray[*key])).abs();
                    assert!(
                        d < 1e-8,
                        "{tool} {name} {key} field {}: {} vs {} (diff {d:e})",
                        ray["field_deg"],
                        ours.position_mm[axis],
                        ray[*key]
                    );
                }
            }
        }
    }
}
