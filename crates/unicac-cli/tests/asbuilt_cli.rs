//! Decentred and tilted lenses through the real binary (issue 36): what works on them, what is refused
//! with an error naming the surface, and bad placements named by their field.

use serde_json::Value;
use std::path::PathBuf;
use std::process::{Command, Output};

fn unicac(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        .env("UNICAC_CACHE_DIR", scratch("cache"))
        .output()
        .expect("run unicac")
}

fn repo(path: &str) -> String {
    format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-asbuilt-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

const AS_BUILT: &str = "tests/reference/asbuilt/lenses/cooke_mixed.json";

#[test]
fn an_as_built_lens_is_traced_and_reported_as_not_symmetric() {
    let lens = repo(AS_BUILT);
    let out = unicac(&["lens", "info", &lens, "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let info: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(info["rotationally_symmetric"], Value::Bool(false));
    let out = unicac(&["spot", &lens, "--json", "--device", "cpu"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let spots: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(spots["auto_aiming"]["aiming"], "real");
    assert!(String::from_utf8_lossy(&out.stderr).contains("decentred or tilted"));
    // Real aiming puts the pupil point (0, 1) at (0, R_stop) in the tilted, decentred stop's frame.
    let out = unicac(&["trace", &lens, "--field-deg", "14", "--pupil", "0,1", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let trace: Value = serde_json::from_slice(&out.stdout).unwrap();
    let r_stop = info["stop_radius_mm"].as_f64().unwrap();
    let stop = &trace["stop_xy_mm"];
    assert!(stop[0].as_f64().unwrap().abs() < 1e-9, "{stop}");
    assert!(
        (stop[1].as_f64().unwrap() - r_stop).abs() < 1e-9,
        "{stop} vs {r_stop}"
    );
    // A centred lens keeps the key out of `lens info`.
    let out = unicac(&["lens", "info", "builtin:cooke_triplet", "--json"]);
    let info: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(info.get("rotationally_symmetric").is_none());
}

#[test]
fn simulate_takes_an_as_built_lens_over_the_whole_image_plane() {
    let lens = repo(AS_BUILT);
    let chart = scratch("chart.png");
    let out = unicac(&[
        "chart",
        "dead-leaves",
        "--size",
        "96x72",
        "--out",
        chart.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (folder, plot) = (scratch("simulated"), scratch("psf-map.png"));
    let out = unicac(&[
        "simulate",
        &lens,
        chart.to_str().unwrap(),
        "--out",
        folder.to_str().unwrap(),
        "--psf-plot",
        plot.to_str().unwrap(),
        "--device",
        "cpu",
        "--no-isp",
        "--no-noise",
    ]);
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{message}");
    assert!(
        message.contains("decentred or tilted: PSFs traced at 221 fields"),
        "{message}"
    );
    assert!(folder.join("chart.png").exists() && plot.exists());
}

#[test]
fn the_ode_grades_an_as_built_lens_at_four_azimuths() {
    let lens = repo(AS_BUILT);
    let out = unicac(&["ode", &lens, "--json", "--device", "cpu"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let table = report["lenses"][0]["table"].as_array().unwrap();
    assert_eq!(
        table.len(),
        3 * (1 + 4 * 4),
        "the axis once, four fractions at four azimuths"
    );
    assert!(table.iter().any(|row| row["azimuth_deg"] == 270.0));
    // A centred lens's rows carry no azimuth.
    let out = unicac(&["ode", "builtin:cooke_triplet", "--json", "--device", "cpu"]);
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(report["lenses"][0]["table"][3].get("azimuth_deg").is_none());
}

#[test]
fn a_dataset_build_refuses_an_as_built_lens_before_any_work() {
    let out_dir = scratch("dataset");
    let out = unicac(&[
        "dataset",
        "build",
        "--lenses",
        &repo(AS_BUILT),
        "builtin:cooke_triplet",
        "--images",
        "dead-leaves:2:64x48",
        "--test-images",
        "dead-leaves:1:64x48",
        "--out",
        out_dir.to_str().unwrap(),
        "--levels",
        "1",
        "--test-lenses-per-level",
        "1",
        "--val-lenses",
        "0",
    ]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains("cooke_mixed.json: a decentred or tilted lens"),
        "{message}"
    );
    assert!(!out_dir.exists(), "nothing written");
}

#[test]
fn a_tilt_out_of_range_is_an_error_naming_the_field() {
    let text = std::fs::read_to_string(repo(AS_BUILT)).unwrap();
    let mut lens: Value = serde_json::from_str(&text).unwrap();
    lens["surfaces"][1]["tilt_x_deg"] = Value::from(95.0);
    let path = scratch("bad_tilt.json");
    std::fs::write(&path, lens.to_string()).unwrap();
    let out = unicac(&["lens", "info", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains("surfaces[1].tilt_x_deg") && message.contains("bad_tilt.json"),
        "{message}"
    );
}
