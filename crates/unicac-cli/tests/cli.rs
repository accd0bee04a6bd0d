//! The CLI contracts of issue 2, exercised through the real binary: the JSON keys outside checks read,
//! agreement with the reference tools, and clear errors for bad input.

use serde_json::Value;
use std::path::PathBuf;
use std::process::{Command, Output};

fn unicac(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        // PSF caches of tests stay out of the user's cache.
        .env("UNICAC_CACHE_DIR", scratch("cache"))
        .output()
        .expect("run unicac")
}

fn json(args: &[&str]) -> Value {
    let out = unicac(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{args:?}: {e}"))
}

fn repo(path: &str) -> String {
    format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn reference_first_order(lens: &str) -> Value {
    let text = std::fs::read_to_string(repo(&format!("tests/reference/optiland/{lens}.json"))).unwrap();
    serde_json::from_str::<Value>(&text).unwrap()["first_order"].clone()
}

#[test]
fn lens_info_json_has_the_contract_keys_and_matches_optiland() {
    let info = json(&["lens", "info", &repo("lenses/double_gauss.json"), "--json"]);
    let reference = reference_first_order("double_gauss");
    for key in [
        "efl_mm",
        "bfl_mm",
        "epd_mm",
        "f_number",
        "total_track_mm",
        "entrance_pupil_z_mm",
    ] {
        let ours = info[key].as_f64().unwrap_or_else(|| panic!("missing {key}"));
        let theirs = reference[key].as_f64().unwrap();
        assert!(
            (ours - theirs).abs() <= 1e-9 * theirs.abs().max(1.0),
            "{key}: {ours} vs {theirs}"
        );
    }
}

#[test]
fn explicit_ray_json_reports_the_image_intercept() {
    let out = json(&[
        "trace",
        &repo("lenses/cooke_triplet.json"),
        "--ray=0,2,-5,0,0,1",
        "--wavelength-um",
        "0.5875618",
        "--json",
    ]);
    assert_eq!(out["status"], "ok");
    assert!(out["x_mm"].as_f64().unwrap().abs() < 1e-12);
    let y = out["y_mm"].as_f64().unwrap();
    assert!(y.is_finite() && y.abs() < 1.0, "{y}");
    let negative = json(&[
        "trace",
        "builtin:cooke_triplet",
        "--ray=0,-2,-5,0,0,1",
        "--wavelength-um",
        "0.5875618",
        "--json",
    ]);
    assert!(
        (negative["y_mm"].as_f64().unwrap() + y).abs() < 1e-12,
        "rotational symmetry"
    );
}

#[test]
fn aimed_rays_follow_the_reference_definition() {
    // The chief ray of 14 deg, paraxially aimed, against optiland's recorded intercept.
    let text = std::fs::read_to_string(repo("tests/reference/optiland/cooke_triplet.json")).unwrap();
    let reference: Value = serde_json::from_str(&text).unwrap();
    let ray = reference["rays"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| {
            r["field_deg"] == 14.0
                && r["pupil"] == serde_json::json!([0.7, 0.7])
                && r["wavelength_um"] == 0.5875618
        })
        .expect("reference ray");
    let out = json(&[
        "trace",
        "builtin:cooke_triplet",
        "--field-deg",
        "14",
        "--pupil",
        "0.7,0.7",
        "--aim",
        "paraxial",
        "--wavelength-um",
        "0.5875618",
        "--json",
    ]);
    assert!((out["y_mm"].as_f64().unwrap() - ray["y_mm"].as_f64().unwrap()).abs() < 1e-9);
    assert!((out["x_mm"].as_f64().unwrap() - ray["x_mm"].as_f64().unwrap()).abs() < 1e-9);
    let real = json(&[
        "trace",
        "builtin:cooke_triplet",
        "--field-deg",
        "-14",
        "--pupil",
        "-0.5,0.2",
        "--aim",
        "real",
        "--json",
    ]);
    assert_eq!(real["status"], "ok");
}

#[test]
fn spot_json_lists_one_entry_per_field_and_wavelength() {
    let out = json(&[
        "spot",
        "builtin:cooke_triplet",
        "--field-deg",
        "0",
        "--field-deg",
        "20",
        "--wavelength-um",
        "0.5875618",
        "--wavelength-um",
        "0.6562725",
        "--pupil-sampling",
        "hexapolar:6",
        "--json",
    ]);
    let spots = out["spots"].as_array().unwrap();
    assert_eq!(spots.len(), 4);
    for key in [
        "field_deg",
        "wavelength_um",
        "rms_radius_um",
        "centroid_x_mm",
        "centroid_y_mm",
        "rays_traced",
        "rays_ok",
    ] {
        assert!(spots.iter().all(|s| !s[key].is_null()), "{key}");
    }
    assert_eq!(spots[0]["rays_traced"], 127);
    for sampling in ["grid:20", "fibonacci:300", "random:500"] {
        let out = json(&[
            "spot",
            "builtin:phone_asphere",
            "--field-deg",
            "28",
            "--pupil-sampling",
            sampling,
            "--aim",
            "real",
            "--json",
        ]);
        assert!(
            out["spots"][0]["rms_radius_um"].as_f64().unwrap() > 0.0,
            "{sampling}"
        );
    }
}

#[test]
fn zmx_files_work_wherever_a_lens_is_expected() {
    let zmx = scratch("petzval.zmx");
    let out = unicac(&[
        "lens",
        "convert",
        &repo("lenses/petzval.json"),
        zmx.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let from_zmx = json(&["lens", "info", zmx.to_str().unwrap(), "--json"]);
    let from_json = json(&["lens", "info", "builtin:petzval", "--json"]);
    assert_eq!(from_zmx["efl_mm"], from_json["efl_mm"]);
}

#[test]
fn plots_are_written() {
    for (command, file) in [("layout", "l.svg"), ("spot", "s.png"), ("fan", "f.png")] {
        let path = scratch(file);
        let out = unicac(&[command, "builtin:singlet", "--plot", path.to_str().unwrap()]);
        assert!(
            out.status.success(),
            "{command}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(std::fs::metadata(&path).unwrap().len() > 1000, "{command}");
    }
}

#[test]
fn bad_input_gives_one_clear_error_line() {
    let cases: [(&[&str], &str); 5] = [
        (&["lens", "info", "/no/such/lens.json"], "/no/such/lens.json"),
        (&["lens", "info", "builtin:nope"], "no bundled lens 'nope'"),
        (
            &["spot", "builtin:singlet", "--pupil-sampling", "spiral:3"],
            "spiral:3",
        ),
        (
            &["trace", "builtin:singlet", "--ray=0,0,0,0,0,0"],
            "must not be zero",
        ),
        (
            &["spot", "builtin:singlet", "--wavelength-um", "-1"],
            "--wavelength-um -1",
        ),
    ];
    for (args, expected) in cases {
        let out = unicac(args);
        assert!(!out.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    let bad = scratch("bad.json");
    std::fs::write(&bad, "{\"format_version\": 1, \"aperture\": {\"f_number\": 4}, \"fields\": {\"angles_deg\": [0]}, \"wavelengths\": [{\"wavelength_um\": 0.55}], \"surfaces\": [{\"thickness_mm\": 2, \"material\": \"N-BK8\"}, {}]}").unwrap();
    let out = unicac(&["lens", "info", bad.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("unknown glass 'N-BK8'") && stderr.contains("N-BK7"),
        "{stderr}"
    );
}

#[test]
fn ode_json_lists_one_object_per_lens_in_order() {
    let out = json(&["ode", "builtin:cooke_triplet", "builtin:singlet", "--json"]);
    let lenses = out["lenses"].as_array().unwrap();
    assert_eq!(lenses.len(), 2);
    assert_eq!(lenses[0]["lens"], "builtin:cooke_triplet");
    for key in [
        "ode",
        "oiq",
        "u_s",
        "u_c",
        "oiqe",
        "psnr_db",
        "ssim",
        "rms_radius_um",
    ] {
        for lens in lenses {
            assert!(lens[key].as_f64().is_some(), "{key}");
        }
    }
    assert_eq!(lenses[0]["table"].as_array().unwrap().len(), 15);
    // The F/1 singlet is far worse than the Cooke triplet.
    assert!(lenses[0]["ode"].as_f64().unwrap() > lenses[1]["ode"].as_f64().unwrap());
    let csv = scratch("ode.csv");
    let out = unicac(&["ode", "builtin:petzval", "--csv", csv.to_str().unwrap()]);
    assert!(out.status.success());
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 2);
}

#[test]
fn charts_mtf_psf_and_simulate_work_end_to_end() {
    let edge = scratch("edge.png");
    assert!(unicac(&[
        "chart",
        "slanted-edge",
        "--size",
        "96x96",
        "--out",
        edge.to_str().unwrap()
    ])
    .status
    .success());
    let mtf = json(&["mtf", edge.to_str().unwrap(), "--json"]);
    for channel in ["R", "G", "B"] {
        let c = &mtf["channels"][channel];
        for key in ["frequency_cy_per_px", "mtf", "mtf50_cy_per_px", "mtf_area"] {
            assert!(!c[key].is_null(), "{channel} {key}");
        }
        // A sharp rendered edge: MTF50 beyond 0.5 cy/px.
        assert!(c["mtf50_cy_per_px"].as_f64().unwrap() > 0.5);
    }
    let psf = scratch("psf.exr");
    let report = json(&[
        "psf",
        "builtin:cooke_triplet",
        "--field-deg",
        "14",
        "--out",
        psf.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(report["channels"], serde_json::json!(["R", "G", "B"]));
    let stack = unicac_image_sum(&psf);
    for sum in stack {
        assert!((sum - 1.0).abs() < 1e-4, "{sum}");
    }
    let mono = scratch("mono.exr");
    let report = json(&[
        "psf",
        "builtin:cooke_triplet",
        "--field-deg",
        "0",
        "--wavelength-um",
        "0.55",
        "--out",
        mono.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(report["channels"], serde_json::json!(["Y"]));
    let chart = scratch("leaves.png");
    assert!(unicac(&[
        "chart",
        "dead-leaves",
        "--size",
        "160x120",
        "--seed",
        "3",
        "--out",
        chart.to_str().unwrap()
    ])
    .status
    .success());
    let out_dir = scratch("sim");
    let out = unicac(&[
        "simulate",
        "builtin:cooke_triplet",
        chart.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
        "--seed",
        "1",
        "--psf-plot",
        scratch("psf-map.svg").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(out_dir.join("leaves.png").exists());
    let map = std::fs::read_to_string(scratch("psf-map.svg")).unwrap();
    assert!(map.contains("PSF map of builtin:cooke_triplet"));
}

/// Per-channel sums of an EXR PSF stack, read back through the PNG-free EXR path of `unicac mtf`'s reader.
fn unicac_image_sum(path: &std::path::Path) -> Vec<f64> {
    let loaded = unicac_image::io::read_image(path).unwrap();
    (0..loaded.image.channels)
        .map(|c| loaded.image.plane(c).iter().map(|v| *v as f64).sum())
        .collect()
}

#[test]
fn a_second_psf_run_loads_the_cache_and_no_cache_recomputes() {
    let out = |name: &str| scratch(name).to_str().unwrap().to_string();
    let run = |name: &str, extra: &[&str]| {
        let path = out(name);
        let mut args = vec![
            "psf",
            "builtin:petzval",
            "--field-deg",
            "7.5",
            "--out",
            &path,
            "--json",
        ];
        args.extend_from_slice(extra);
        (json(&args), std::fs::read(&path).unwrap())
    };
    let (first, first_exr) = run("cached-1.exr", &["--no-cache"]);
    let (second, second_exr) = run("cached-2.exr", &[]);
    let (third, third_exr) = run("cached-3.exr", &[]);
    assert_eq!(first["from_cache"], false);
    assert_eq!(
        second["from_cache"], false,
        "--no-cache neither reads nor writes the cache"
    );
    assert_eq!(third["from_cache"], true);
    assert_eq!(first_exr, third_exr);
    assert_eq!(second_exr, third_exr);
    let hash = third["lens_sha256"].as_str().unwrap();
    assert_eq!(hash.len(), 64);
    assert_eq!(first["lens_sha256"], third["lens_sha256"]);
}
