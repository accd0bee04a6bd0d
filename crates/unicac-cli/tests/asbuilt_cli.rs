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

/// A one-level dataset of three bundled lenses (one test lens) with `--as-built UNITS` drawn within
/// `tolerances` (a JSON text).
fn build_as_built(name: &str, tolerances: &str, units: &str) -> (PathBuf, Output) {
    let spec = scratch(&format!("{name}.json"));
    std::fs::write(&spec, tolerances).unwrap();
    let out_dir = scratch(name);
    let out = unicac(&[
        "dataset",
        "build",
        "--lenses",
        "builtin:cooke_triplet",
        "builtin:petzval",
        "builtin:double_gauss",
        "--images",
        "dead-leaves:2:96x72",
        "--test-images",
        "dead-leaves:2:96x72",
        "--out",
        out_dir.to_str().unwrap(),
        "--levels",
        "1",
        "--test-lenses-per-level",
        "1",
        "--val-lenses",
        "1",
        "--pairs-per-lens",
        "1",
        "--crop",
        "48x48",
        "--as-built",
        units,
        "--tolerances",
        spec.to_str().unwrap(),
        "--json",
    ]);
    (out_dir, out)
}

fn as_built_bench(dataset: &std::path::Path, name: &str) -> Value {
    let report = scratch(name);
    let out = unicac(&[
        "bench",
        "--dataset",
        dataset.to_str().unwrap(),
        "--split",
        "as_built",
        "--metrics",
        "psnr,ssim",
        "--out",
        report.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&std::fs::read(report.join("results.json")).unwrap()).unwrap()
}

#[test]
fn the_as_built_split_renders_units_beside_their_design_and_the_bench_scores_the_loss() {
    // Errors far below any traced quantity: every unit renders as its design's reference does.
    let (dataset, out) = build_as_built("as-built-zero", r#"{"element_decentre_mm": 1e-12}"#, "1");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        report["as_built_pairs_rendered"], 4,
        "2 test pairs x (the design + 1 unit)"
    );
    let results = as_built_bench(&dataset, "bench-zero");
    // pairs.csv lists the units' pairs and their design references' (to regroup the table outside).
    let csv = std::fs::read_to_string(scratch("bench-zero").join("pairs.csv")).unwrap();
    let ids: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(ids.iter().filter(|id| id.ends_with("__u0")).count(), 2);
    assert_eq!(ids.iter().filter(|id| id.ends_with("__d")).count(), 2);
    let rows = results["as_built"]["rows"].as_array().unwrap();
    assert!(!rows.is_empty());
    for row in rows {
        let change = row["psnr"]["difference"].as_f64().unwrap();
        assert!(change.abs() < 0.01, "{row}");
    }
    // A rerun finds everything done.
    let (_, again) = build_as_built("as-built-zero", r#"{"element_decentre_mm": 1e-12}"#, "1");
    let report: Value = serde_json::from_slice(&again.stdout).unwrap();
    assert_eq!(report["as_built_pairs_rendered"], 0);

    // Textbook tolerances: the unit carries its drawn errors and an ODE of its own.
    let textbook = std::fs::read_to_string(repo("docs/tolerancing/textbook.json")).unwrap();
    let (dataset, out) = build_as_built("as-built-textbook", &textbook, "1");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let units = std::fs::read_to_string(dataset.join("as_built/units.jsonl")).unwrap();
    let units: Vec<Value> = units.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(units.len(), 2, "the design's reference and one unit");
    assert!(units[0]["unit"].is_null() && units[1]["unit"] == 0);
    assert!(!units[1]["changes"].as_array().unwrap().is_empty());
    assert!(units[1]["ode"].as_f64().unwrap() > 0.0);
    let results = as_built_bench(&dataset, "bench-textbook");
    assert_eq!(results["split"], "as_built");
    assert_eq!(results["as_built"]["units_per_lens"], 1);
}

#[test]
fn as_built_flags_are_refused_alone_or_beyond_their_limit() {
    let out = unicac(&[
        "dataset",
        "build",
        "--lenses",
        "builtin:cooke_triplet",
        "--images",
        "dead-leaves:1:64x48",
        "--test-images",
        "dead-leaves:1:64x48",
        "--out",
        scratch("alone").to_str().unwrap(),
        "--as-built",
        "2",
    ]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "clap refuses --as-built without --tolerances"
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("--tolerances"));
    let spec = scratch("too-many.json");
    std::fs::write(&spec, r#"{"radius_fraction": 0.001}"#).unwrap();
    let out = unicac(&[
        "dataset",
        "build",
        "--lenses",
        "builtin:cooke_triplet",
        "--images",
        "dead-leaves:1:64x48",
        "--test-images",
        "dead-leaves:1:64x48",
        "--out",
        scratch("too-many").to_str().unwrap(),
        "--as-built",
        "17",
        "--tolerances",
        spec.to_str().unwrap(),
    ]);
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(message.contains("--as-built 17: takes 1 to 16"), "{message}");
    assert!(!scratch("too-many").exists());
}
