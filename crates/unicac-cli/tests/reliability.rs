//! Issue 16 through the real binary: every count and size flag has a stated limit, no output is ever
//! written over an input or another output, and inputs that used to give a confident wrong answer
//! (rc 0) are errors naming the file, flag or position. Each test failed before its fix.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn unicac(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        .env("UNICAC_CACHE_DIR", folder("cache"))
        .output()
        .expect("run unicac")
}

/// Runs a command that must fail fast with rc 1 (a refused request) or 2 (clap's code for a flag value
/// that does not parse), not a panic's 101 or an abort's 134, with an error containing each of
/// `expected`.
fn refused(args: &[&str], expected: &[&str]) -> String {
    let start = Instant::now();
    let out = unicac(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        matches!(out.status.code(), Some(1 | 2)),
        "{args:?}: {:?} {stderr}",
        out.status.code()
    );
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{args:?} took {:?}",
        start.elapsed()
    );
    for text in expected {
        assert!(stderr.contains(text), "{args:?}: expected '{text}' in: {stderr}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

fn ok(args: &[&str]) -> Output {
    let out = unicac(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("unicac-reliability-{}", std::process::id()))
        .join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn chart(path: &Path, size: &str) {
    ok(&["chart", "slanted-edge", "--size", size, "--out", s(path)]);
}

#[test]
fn unbounded_counts_and_sizes_are_refused_with_the_limit() {
    for sampling in [
        "fibonacci:18446744073709551615",
        "random:18446744073709551615",
        "random:4294967296",
        "hexapolar:100000",
        "grid:100000",
        "grid:4294967295",
    ] {
        refused(
            &["spot", "builtin:cooke_triplet", "--pupil-sampling", sampling],
            &["--pupil-sampling", "MAX_PUPIL_SAMPLES"],
        );
    }
    let out = folder("limits").join("big.png");
    refused(
        &[
            "chart",
            "dead-leaves",
            "--size",
            "100000x100000",
            "--out",
            s(&out),
        ],
        &["--size 100000x100000", "MAX_CHART_PIXELS"],
    );
    assert!(!out.exists());
    let plot = folder("limits").join("layout.png");
    refused(
        &[
            "layout",
            "builtin:cooke_triplet",
            "--plot",
            s(&plot),
            "--rays",
            "1000000000",
        ],
        &["--rays 1000000000", "MAX_LAYOUT_RAYS"],
    );
    refused(
        &["fan", "builtin:cooke_triplet", "--samples", "1000000000"],
        &["--samples", "MAX_FAN_SAMPLES"],
    );
    // `fan --samples 0` used to become 2 silently.
    refused(
        &["fan", "builtin:cooke_triplet", "--samples", "0"],
        &["--samples", "fan samples 0"],
    );
}

#[test]
fn simulate_never_overwrites_an_input_or_another_output() {
    let dir = folder("simulate-inputs");
    let input = dir.join("a.png");
    chart(&input, "64x48");
    let before = std::fs::read(&input).unwrap();
    // `simulate d/a.png --out d/` used to overwrite the input.
    refused(
        &["simulate", "builtin:cooke_triplet", s(&input), "--out", s(&dir)],
        &["would overwrite the input", "a.png"],
    );
    assert_eq!(std::fs::read(&input).unwrap(), before);
    // Two inputs with one name used to print "wrote 2 image(s)" with one overwriting the other.
    let other = folder("simulate-other").join("a.png");
    chart(&other, "64x48");
    let out = folder("simulate-collision-out").join("o");
    refused(
        &[
            "simulate",
            "builtin:cooke_triplet",
            s(&input),
            s(&other),
            "--out",
            s(&out),
        ],
        &["same file"],
    );
    // A refused or failed run leaves no (empty) output folder behind.
    assert!(!out.exists());
    // --out naming a file (the input itself, here) is refused by name, before any work.
    refused(
        &["simulate", "builtin:cooke_triplet", s(&input), "--out", s(&input)],
        &["--out", "a.png", "is a file"],
    );
    assert_eq!(std::fs::read(&input).unwrap(), before);
    let missing = dir.join("missing.png");
    refused(
        &["simulate", "builtin:cooke_triplet", s(&missing), "--out", s(&out)],
        &["missing.png"],
    );
    assert!(!out.exists());
}

#[test]
fn simulate_refuses_non_finite_float_input_and_a_truncated_png() {
    let dir = folder("simulate-bad-pixels");
    let mut image = unicac_image::Planar::from_fn(40, 30, 3, |_, _, _| 0.5);
    image.set(1, 7, 4, f32::INFINITY);
    let exr = dir.join("inf.exr");
    unicac_image::io::write_exr_channels(&exr, &image, &["R", "G", "B"]).unwrap();
    let out = dir.join("out");
    refused(
        &["simulate", "builtin:cooke_triplet", s(&exr), "--out", s(&out)],
        &["inf.exr", "pixel (x 7, y 4) of channel G is inf"],
    );
    // The header declares the size (the PSF map starts on it); the pixel data is cut short.
    let png = dir.join("cut.png");
    chart(&png, "64x48");
    let bytes = std::fs::read(&png).unwrap();
    std::fs::write(&png, &bytes[..bytes.len() / 2]).unwrap();
    refused(
        &["simulate", "builtin:cooke_triplet", s(&png), "--out", s(&out)],
        &["cut.png", "cannot decode PNG"],
    );
    assert!(!out.exists());
}

#[test]
fn simulate_keeps_the_input_file_name_and_extension() {
    let dir = folder("simulate-names");
    let tif = dir.join("IMG.tif");
    chart(&tif, "64x48");
    let out = folder("simulate-names-out");
    ok(&[
        "simulate",
        "builtin:cooke_triplet",
        s(&tif),
        "--out",
        s(&out),
        "--no-noise",
    ]);
    // Used to be written as IMG.tiff.
    assert!(out.join("IMG.tif").exists());
    assert!(!out.join("IMG.tiff").exists());
    let written = unicac_image::io::read_image(out.join("IMG.tif")).unwrap();
    assert_eq!(written.format, unicac_image::io::FileFormat::Tiff);
    // --format changes the extension to the format's.
    ok(&[
        "simulate",
        "builtin:cooke_triplet",
        s(&tif),
        "--out",
        s(&out),
        "--format",
        "png",
        "--no-noise",
    ]);
    let png = unicac_image::io::read_image(out.join("IMG.png")).unwrap();
    assert_eq!(png.format, unicac_image::io::FileFormat::Png);
}

#[test]
fn psf_and_mtf_outputs_never_replace_inputs_and_match_their_format() {
    let dir = folder("psf-outputs");
    let lens = dir.join("L.json");
    std::fs::copy(
        format!("{}/../../lenses/cooke_triplet.json", env!("CARGO_MANIFEST_DIR")),
        &lens,
    )
    .unwrap();
    let before = std::fs::read(&lens).unwrap();
    // `psf L.json --out L.exr` used to write its JSON sidecar over the lens file.
    refused(
        &[
            "psf",
            s(&lens),
            "--field-deg",
            "0",
            "--out",
            s(&dir.join("L.exr")),
        ],
        &["would overwrite the input", "L.json"],
    );
    assert_eq!(std::fs::read(&lens).unwrap(), before);
    // `psf --out k.png` used to write EXR data under a .png name.
    refused(
        &[
            "psf",
            "builtin:cooke_triplet",
            "--field-deg",
            "0",
            "--out",
            s(&dir.join("k.png")),
        ],
        &["--out", "must be .exr"],
    );
    assert!(!dir.join("k.png").exists());
    for bad in ["NaN", "90", "-95"] {
        refused(
            &[
                "psf",
                "builtin:cooke_triplet",
                "--field-deg",
                bad,
                "--out",
                s(&dir.join("f.exr")),
            ],
            &["--field-deg"],
        );
    }
    // `mtf e.png --plot e.png` used to overwrite the image.
    let edge = dir.join("e.png");
    chart(&edge, "64x64");
    let before = std::fs::read(&edge).unwrap();
    refused(
        &["mtf", s(&edge), "--plot", s(&edge)],
        &["--plot", "would overwrite the input"],
    );
    assert_eq!(std::fs::read(&edge).unwrap(), before);
    refused(
        &[
            "spot",
            "builtin:cooke_triplet",
            "--plot",
            s(&dir.join("spot.jpg")),
        ],
        &["--plot", ".png or .svg"],
    );
}

#[test]
fn confident_wrong_answers_are_now_errors() {
    let dir = folder("wrong-answers");
    // A ray pointing away from the lens used to report `ok` with the forward ray's image point.
    let out = ok(&["trace", "builtin:cooke_triplet", "--ray=0,1,-5,0,0,-1", "--json"]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["status"], "missed", "{report}");
    assert!(report["y_mm"].is_null());
    // A lens where no ray arrives used to give a 1 x 1 zero kernel with rc 0.
    let mut spec: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!(
            "{}/../../lenses/singlet.json",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap(),
    )
    .unwrap();
    for surface in spec["surfaces"].as_array_mut().unwrap() {
        if surface.get("semi_diameter_mm").is_some() || surface["stop"] != true {
            surface["semi_diameter_mm"] = serde_json::json!(1e-6);
        }
    }
    let blocked = dir.join("blocked.json");
    std::fs::write(&blocked, serde_json::to_string_pretty(&spec).unwrap()).unwrap();
    refused(
        &[
            "psf",
            s(&blocked),
            "--field-deg",
            "0",
            "--out",
            s(&dir.join("k.exr")),
            "--no-cache",
        ],
        &["no ray"],
    );
    // One +inf pixel used to give MTF50 1.0 with every MTF value null.
    let mut edge = unicac_image::charts::slanted_edge(64, 64, 5.0, 0.2, 0.8).unwrap();
    edge.data[20 * 64 + 30] = f32::INFINITY;
    let exr = dir.join("inf.exr");
    unicac_image::io::write_exr(&exr, &edge).unwrap();
    refused(&["mtf", s(&exr)], &["inf.exr", "pixel (x 30, y 20)"]);
    let simulated = folder("wrong-answers-out");
    refused(
        &[
            "simulate",
            "builtin:cooke_triplet",
            s(&exr),
            "--out",
            s(&simulated.join("o")),
        ],
        &["inf.exr", "pixel (x 30, y 20)"],
    );
}

#[test]
fn errors_name_the_path_once() {
    // The OS error used to be printed twice: "No such file or directory (os error 2): No such ...".
    let stderr = refused(
        &["lens", "info", "/nonexistent/lens.json"],
        &["/nonexistent/lens.json"],
    );
    assert_eq!(stderr.matches("os error 2").count(), 1, "{stderr}");
    // A plot into a missing folder names the path (it used to print a Rust debug structure).
    let stderr = refused(
        &[
            "spot",
            "builtin:cooke_triplet",
            "--plot",
            "/nonexistent/folder/spot.png",
        ],
        &["/nonexistent/folder/spot.png"],
    );
    assert!(!stderr.contains("Os {"), "{stderr}");
}

#[test]
fn temporaries_of_killed_runs_are_cleaned_on_the_next_run() {
    let input = folder("temporaries-in").join("t.png");
    chart(&input, "48x48");
    let out = folder("temporaries-out");
    // What a SIGKILLed writer leaves (its process id is above the kernel's maximum: never alive).
    let debris = out.join(".t.png.tmp-4294967-0.png");
    std::fs::write(&debris, b"half").unwrap();
    ok(&[
        "simulate",
        "builtin:cooke_triplet",
        s(&input),
        "--out",
        s(&out),
        "--no-noise",
    ]);
    assert!(!debris.exists());
    assert!(out.join("t.png").exists());
}
