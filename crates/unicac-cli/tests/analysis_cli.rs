//! `unicac analysis` through the real binary: the JSON keys issue 34 names, pictures written, and bad
//! input refused before any work (exit code 1, the flag named, nothing written).

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

fn json(args: &[&str]) -> Value {
    let out = unicac(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{args:?}: {e}"))
}

/// Exit code 1 and a message holding `expected`.
fn refused(args: &[&str], expected: &str) {
    let out = unicac(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(stderr.contains(expected), "{args:?}: {stderr}");
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-analysis-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn mtf_json_has_the_keys_of_issue_34_and_stays_below_the_diffraction_limit() {
    let report = json(&[
        "analysis",
        "mtf",
        "builtin:cooke_triplet",
        "--field-deg",
        "14",
        "--frequencies",
        "17",
        "--pupil-grid",
        "64",
        "--json",
    ]);
    let fields = report["fields"].as_array().unwrap();
    assert_eq!(fields.len(), 1);
    let field = &fields[0];
    assert_eq!(field["field_deg"].as_f64(), Some(14.0));
    let frequencies = floats(&field["frequencies_cy_mm"]);
    let (t, s) = (floats(&field["tangential"]), floats(&field["sagittal"]));
    let limit = floats(&field["diffraction_limit"]["tangential"]);
    assert_eq!(frequencies.len(), 17);
    assert_eq!((t.len(), s.len(), limit.len()), (17, 17, 17));
    assert!((t[0] - 1.0).abs() < 1e-9 && (s[0] - 1.0).abs() < 1e-9);
    // An aberrated lens transfers less than its aperture allows, at every frequency.
    assert!(
        t.iter().zip(&limit).all(|(m, l)| *m <= l + 1e-9),
        "{t:?} vs {limit:?}"
    );
    assert!(
        t[8] < limit[8] - 0.05,
        "14 deg of the Cooke triplet is visibly aberrated"
    );
    assert_eq!(report["method"], "diffraction");
}

#[test]
fn every_analysis_writes_its_picture_and_report() {
    let lens = "builtin:phone_asphere";
    for (sub, extra) in [
        ("mtf", vec!["--pupil-grid", "32", "--frequencies", "9"]),
        (
            "mtf",
            vec![
                "--vs-field",
                "--fields",
                "3",
                "--pupil-grid",
                "32",
                "--method",
                "geometric",
            ],
        ),
        (
            "through-focus",
            vec!["--steps", "3", "--pupil-grid", "32", "--field-deg", "0,28"],
        ),
        ("field-curves", vec!["--fields", "5"]),
        ("illumination", vec!["--fields", "5", "--pupil-grid", "32"]),
        ("encircled-energy", vec!["--pupil-grid", "32"]),
    ] {
        let plot = scratch(&format!("{sub}-{}.svg", extra.len()));
        let out = scratch(&format!("{sub}-{}.json", extra.len()));
        let mut args = vec![
            "analysis",
            sub,
            lens,
            "--plot",
            plot.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(&extra);
        let run = unicac(&args);
        assert!(
            run.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        assert!(
            std::fs::read_to_string(&plot).unwrap().contains("<svg"),
            "{sub}: no picture"
        );
        let written: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert!(written.is_object(), "{sub}: {written}");
    }
    let png = scratch("mtf.png");
    let run = unicac(&[
        "analysis",
        "mtf",
        lens,
        "--pupil-grid",
        "32",
        "--plot",
        png.to_str().unwrap(),
    ]);
    assert!(run.status.success());
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
}

#[test]
fn bad_input_is_refused_before_any_work() {
    let lens = "builtin:cooke_triplet";
    refused(
        &["analysis", "mtf", lens, "--field-deg", "nan"],
        "--field-deg NaN",
    );
    refused(
        &["analysis", "mtf", lens, "--field-deg", "25"],
        "--field-deg 25: beyond the lens's largest field, 20 deg",
    );
    refused(
        &["analysis", "through-focus", lens, "--field-deg", "-21"],
        "beyond the lens's largest field",
    );
    refused(
        &["analysis", "field-curves", lens, "--wavelength-um", "0"],
        "--wavelength-um 0: must be positive",
    );
    refused(
        &["analysis", "encircled-energy", lens, "--pupil-grid", "4"],
        "--pupil-grid 4: must lie between 16 and 512",
    );
    refused(
        &["analysis", "mtf", lens, "--frequencies", "1"],
        "--frequencies 1",
    );
    refused(
        &["analysis", "mtf", lens, "--max-frequency-cy-mm", "inf"],
        "--max-frequency-cy-mm inf",
    );
    refused(
        &["analysis", "through-focus", lens, "--steps", "100000"],
        "--steps 100000",
    );
    refused(
        &[
            "analysis",
            "illumination",
            lens,
            "--plot",
            scratch("ri.gif").to_str().unwrap(),
        ],
        "--plot",
    );
    // Outputs never land on the lens file or on each other.
    let copy = scratch("lens.json");
    std::fs::copy(
        format!("{}/../../lenses/cooke_triplet.json", env!("CARGO_MANIFEST_DIR")),
        &copy,
    )
    .unwrap();
    let before = std::fs::read(&copy).unwrap();
    let copy = copy.to_str().unwrap();
    refused(&["analysis", "mtf", copy, "--out", copy], "--out");
    assert_eq!(std::fs::read(copy).unwrap(), before, "the lens file was touched");
}
