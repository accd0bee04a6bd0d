//! Issue 28, the dataset half, through the real binary: a lens under two names is one lens, a build
//! claims its folder before any work, an output never lands in an input folder, every count has a
//! stated limit checked before grading, a changed scene is named on resume, and bench refuses a
//! manifest missing rows. Each test failed (or panicked) before its fix.

use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "support/rel.rs"]
mod rel;

use rel::{dataset, files, ok, refused, s, scratch, stderr};

/// A copy of the shared dataset (the tests below damage their copy).
fn copy_of_dataset(name: &str) -> PathBuf {
    let copy = scratch(name).join("ds");
    for relative in files(dataset()) {
        let to = copy.join(&relative);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(dataset().join(&relative), &to).unwrap();
    }
    copy
}

/// Case 6: a `pairs.jsonl` (or `edges.jsonl`, `lenses.jsonl`) missing rows was benchmarked as if complete.
#[test]
fn bench_refuses_a_manifest_missing_rows() {
    for (manifest, expected) in [
        ("pairs.jsonl", "1 test pairs, but dataset.json counts 2"),
        ("edges.jsonl", "edge patches, but dataset.json counts"),
    ] {
        let ds = copy_of_dataset(&format!("missing-{manifest}"));
        let path = ds.join(manifest);
        let text = std::fs::read_to_string(&path).unwrap();
        let rows: Vec<&str> = text.lines().collect();
        // The last test row goes (pairs are written by split, test last).
        let kept: String = rows[..rows.len() - 1].iter().map(|r| format!("{r}\n")).collect();
        std::fs::write(&path, kept).unwrap();
        let out = scratch(&format!("missing-{manifest}-report")).join("report");
        let message = refused(
            &[
                "bench",
                "--dataset",
                s(&ds),
                "--method",
                "wiener",
                "--metrics",
                "psnr,oiqe",
                "--out",
                s(&out),
            ],
            &[
                s(&path),
                expected,
                "(the manifest is incomplete or belongs to another build)",
            ],
        );
        assert!(!out.exists(), "{message}");
    }
}

/// The settings of the small builds below (two levels, 64 x 48 frame), with `lenses`, `images` and `out`.
fn build_args<'a>(lenses: &[&'a str], images: &'a str, seed: &'a str, out: &'a str) -> Vec<&'a str> {
    let mut args = vec!["dataset", "build", "--lenses"];
    args.extend_from_slice(lenses);
    args.extend_from_slice(&[
        "--images",
        images,
        "--test-images",
        "dead-leaves:1",
        "--frame",
        "64x48",
        "--levels",
        "1",
        "--test-lenses-per-level",
        "1",
        "--val-lenses",
        "0",
        "--pairs-per-lens",
        "1",
        "--crop",
        "32x24",
        "--seed",
        seed,
        "--out",
        out,
    ]);
    args
}

fn repository_lens(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../lenses")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// Case 1: `builtin:cooke_triplet` and `lenses/cooke_triplet.json` (or a copy with a trailing newline)
/// were two lenses, which could land in two splits.
#[test]
fn one_lens_under_two_names_is_refused_naming_both() {
    let dir = scratch("same-lens");
    let json = repository_lens("cooke_triplet.json");
    let copy = dir.join("cooke_copy.json");
    let mut bytes = std::fs::read(&json).unwrap();
    bytes.push(b'\n');
    std::fs::write(&copy, bytes).unwrap();
    let out = dir.join("ds");
    for other in [json.as_str(), s(&copy)] {
        let name = Path::new(other).file_name().unwrap().to_str().unwrap();
        refused(
            &build_args(
                &["builtin:double_gauss", "builtin:cooke_triplet", other],
                "dead-leaves:1:80x60",
                "1",
                s(&out),
            ),
            &["builtin:cooke_triplet and", name, "are the same lens"],
        );
        assert!(!out.exists(), "refused before any work: nothing made");
    }
}

/// Counts panicked ("capacity overflow"), a 1 x 1 crop was accepted, and bad levels, counts or
/// oversized charts were refused only after every lens was graded.
#[test]
fn every_count_is_refused_before_grading_with_its_flag_and_limit() {
    let dir = scratch("counts");
    let out = dir.join("ds");
    let lenses = ["builtin:double_gauss", "builtin:cooke_triplet", "builtin:petzval"];
    let base = build_args(&lenses, "dead-leaves:1:80x60", "1", s(&out));
    let with = |flag: &str, value: &'static str| {
        let mut args = base.clone();
        let at = args.iter().position(|a| *a == flag).unwrap();
        args[at + 1] = value;
        args
    };
    for (flag, value, expected) in [
        (
            "--test-lenses-per-level",
            "9223372036854775808",
            "MAX_TEST_LENSES_PER_LEVEL",
        ),
        ("--test-lenses-per-level", "1000000", "MAX_ITEMS"),
        ("--levels", "0", "[1, 100]"),
        ("--levels", "101", "MAX_LEVELS"),
        ("--val-lenses", "18446744073709551615", "MAX_VAL_LENSES"),
        ("--pairs-per-lens", "0", "MAX_PAIRS_PER_LENS"),
        ("--crop", "1x1", "[11, 32768] px"),
        ("--frame", "8x8", "MIN_CROP_SIDE_PX"),
        ("--images", "dead-leaves:1:32768x32768", "MAX_CHART_PIXELS"),
        ("--test-lenses-per-level", "3", "holds 3 lenses"),
    ] {
        let message = refused(&with(flag, value), &[expected]);
        if !expected.starts_with("holds") {
            assert!(message.contains(&format!("{flag} {value}")), "{message}");
        }
        assert!(
            !out.exists(),
            "{flag} {value}: refused before any work, nothing made"
        );
    }
}

/// Case 5: `--out` inside the `--images` folder: a rerun scanned its own output as scenes.
#[test]
fn dataset_build_never_writes_into_an_input_folder() {
    let dir = scratch("inside");
    let images = dir.join("images");
    std::fs::create_dir_all(&images).unwrap();
    ok(&[
        "chart",
        "dead-leaves",
        "--size",
        "80x60",
        "--out",
        s(&images.join("a.png")),
    ]);
    let out = images.join("ds");
    let lenses = ["builtin:double_gauss", "builtin:cooke_triplet"];
    refused(
        &build_args(&lenses, s(&images), "1", s(&out)),
        &["--out", "lies inside the input folder", s(&images)],
    );
    assert!(!out.exists());
    refused(
        &build_args(&lenses, s(&images), "1", s(&dir)),
        &["--out", "holds the input"],
    );
}

/// Case 3: two builds with different settings into one new folder both succeeded and mixed their files.
#[test]
fn two_builds_with_different_settings_never_share_a_folder() {
    let dir = scratch("race");
    let out = dir.join("ds");
    let lenses = ["builtin:double_gauss", "builtin:cooke_triplet"];
    let spawn = |seed: &str| {
        Command::new(env!("CARGO_BIN_EXE_unicac"))
            .args(build_args(&lenses, "dead-leaves:1:80x60", seed, s(&out)))
            .env("UNICAC_CACHE_DIR", dir.join("cache"))
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn("1"), spawn("2"));
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    let codes = [a.status.code(), b.status.code()];
    assert!(
        codes.contains(&Some(0)) && codes.contains(&Some(1)),
        "{codes:?}: {} / {}",
        stderr(&a),
        stderr(&b)
    );
    let loser = if a.status.success() { &b } else { &a };
    assert!(
        stderr(loser).contains("another build with different settings holds this folder"),
        "{}",
        stderr(loser)
    );
    // The folder holds the winner's dataset alone, and the loser, run again, is still refused.
    let winner_seed = if a.status.success() { "1" } else { "2" };
    let loser_seed = if winner_seed == "1" { "2" } else { "1" };
    let recorded = std::fs::read_to_string(out.join("dataset.json")).unwrap();
    assert!(
        recorded.contains(&format!("\"seed\": {winner_seed}")),
        "{recorded}"
    );
    refused(
        &build_args(&lenses, "dead-leaves:1:80x60", loser_seed, s(&out)),
        &["another build with different settings holds this folder", "seed"],
    );
}

/// Case 8: a scene changed between a killed build and its resume left pairs rendered from the old scene.
#[test]
fn a_resume_after_a_scene_changed_is_refused_naming_the_scene() {
    let dir = scratch("scene");
    let images = dir.join("images");
    std::fs::create_dir_all(&images).unwrap();
    for (name, seed) in [("a.png", "1"), ("b.png", "2")] {
        ok(&[
            "chart",
            "dead-leaves",
            "--size",
            "80x60",
            "--seed",
            seed,
            "--out",
            s(&images.join(name)),
        ]);
    }
    let out = dir.join("ds");
    let lenses = ["builtin:double_gauss", "builtin:cooke_triplet"];
    let args = build_args(&lenses, s(&images), "1", s(&out));
    ok(&args);
    // As if killed: the training pairs are gone, then a scene is replaced.
    std::fs::remove_dir_all(out.join("train")).unwrap();
    std::fs::remove_file(out.join("dataset.json")).unwrap();
    ok(&[
        "chart",
        "dead-leaves",
        "--size",
        "80x60",
        "--seed",
        "3",
        "--out",
        s(&images.join("b.png")),
    ]);
    refused(&args, &["the scene", "b.png", "changed since this build began"]);
    assert!(
        !out.join("train").exists(),
        "nothing rendered from the changed scene"
    );
    // Restored, the build resumes.
    ok(&[
        "chart",
        "dead-leaves",
        "--size",
        "80x60",
        "--seed",
        "2",
        "--out",
        s(&images.join("b.png")),
    ]);
    ok(&args);
    assert!(out.join("dataset.json").exists());
}
