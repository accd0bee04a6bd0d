//! What a new user meets (issue 34), through the real binary: onnxruntime found without
//! `ORT_DYLIB_PATH` (in the `python3` on PATH or `UNICAC_PYTHON`), an explicitly asked metric that cannot
//! run refused with rc 1, and `unicac ode --frame` printing the grade a dataset records for a lens.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use unicac_image::io::{write_png, SampleDepth};
use unicac_image::Planar;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("unicac-users-{}", std::process::id()))
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The binary with none of the variables that steer the onnxruntime search.
fn unicac() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_unicac"));
    for name in ["ORT_DYLIB_PATH", "UNICAC_PYTHON", "VIRTUAL_ENV"] {
        command.env_remove(name);
    }
    command
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Skips (prints why) or, under CI, fails.
fn unavailable(reason: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("CI is set and this test could not prepare: {reason}");
    }
    eprintln!("skipped: {reason}");
}

/// A Python whose `onnxruntime` package exists: `UNICAC_PYTHON`, the repository's `.venv` (made by
/// scripts/setup_python.sh), or the `python3` on PATH.
fn python_with_onnxruntime() -> Option<PathBuf> {
    let mut candidates: Vec<PathBuf> = std::env::var_os("UNICAC_PYTHON")
        .map(PathBuf::from)
        .into_iter()
        .collect();
    candidates.push(Path::new(ROOT).join(".venv/bin/python3"));
    candidates.push("python3".into());
    candidates.into_iter().find(|python| {
        Command::new(python)
            .args(["-c", "import onnxruntime"])
            .output()
            .is_ok_and(|out| out.status.success())
    })
}

/// The interpreter's own path (`sys.executable`), so that a folder holding it can go on PATH.
fn executable(python: &Path) -> PathBuf {
    let out = Command::new(python)
        .args(["-c", "import sys; print(sys.executable)"])
        .output()
        .unwrap();
    PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
}

/// LPIPS weights in a cache kept between runs under the target folder (fetched once by pip).
fn lpips_cache(python: &Path) -> Option<PathBuf> {
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("downloads/cache");
    let out = unicac()
        .args(["weights", "fetch", "lpips", "--python"])
        .arg(python)
        .env("UNICAC_CACHE_DIR", &cache)
        .output()
        .unwrap();
    if out.status.success() {
        Some(cache)
    } else {
        unavailable(&format!("LPIPS weights: {}", stderr(&out)));
        None
    }
}

/// Two 48 x 40 images 10 codes apart (LPIPS needs 32 px or more per side).
fn image_pair(dir: &Path) -> (PathBuf, PathBuf) {
    let a = Planar::from_fn(48, 40, 3, |c, x, y| {
        ((c * 7 + x * 3 + y * 5) % 17) as f32 / 16.0 * 0.8 + 0.1
    });
    let b = Planar::from_fn(48, 40, 3, |c, x, y| {
        ((a.get(c, x, y) * 255.0).round() + 10.0) / 255.0
    });
    let (pa, pb) = (dir.join("ref.png"), dir.join("dist.png"));
    write_png(&pa, &a, SampleDepth::Eight).unwrap();
    write_png(&pb, &b, SampleDepth::Eight).unwrap();
    (pa, pb)
}

/// A PATH holding only `dirs`.
fn path_of(dirs: &[&Path]) -> OsString {
    std::env::join_paths(dirs).unwrap()
}

#[test]
fn metrics_finds_onnxruntime_in_the_python3_on_path_and_names_the_library() {
    let Some(python) = python_with_onnxruntime() else {
        return unavailable("no Python with onnxruntime (set UNICAC_PYTHON)");
    };
    let Some(cache) = lpips_cache(&python) else { return };
    let dir = scratch("found");
    let (a, b) = image_pair(&dir);
    // The interpreter's own folder first on PATH (a virtual environment's `bin`: a copy or link of its
    // `python3` elsewhere would not be that environment).
    let python = executable(&python);
    let bin = python.parent().unwrap().to_path_buf();
    if !bin.join("python3").is_file() {
        return unavailable(&format!("no python3 beside {}", python.display()));
    }
    let out = unicac()
        .args(["metrics", a.to_str().unwrap(), b.to_str().unwrap(), "--json"])
        .env("UNICAC_CACHE_DIR", &cache)
        .env("PATH", path_of(&[&bin, Path::new("/usr/bin"), Path::new("/bin")]))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let lpips = report["pairs"][0]["lpips"]
        .as_f64()
        .unwrap_or_else(|| panic!("no LPIPS value: {report}"));
    assert!(lpips > 0.0 && lpips < 1.0, "{report}");
    let runtime = &report["onnxruntime"];
    let library = runtime["library"].as_str().unwrap();
    assert!(
        library.contains("onnxruntime/capi/libonnxruntime.so") && Path::new(library).is_file(),
        "{runtime}"
    );
    assert!(
        runtime["found_by"].as_str().unwrap().contains("python3 on PATH"),
        "{runtime}"
    );

    // The same interpreter named by UNICAC_PYTHON, with no python3 on PATH: the same value.
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let out = unicac()
        .args([
            "metrics",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--metrics",
            "lpips",
            "--json",
        ])
        .env("UNICAC_CACHE_DIR", &cache)
        .env("UNICAC_PYTHON", &python)
        .env("PATH", &empty)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let again: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(again["pairs"][0]["lpips"].as_f64(), Some(lpips));
    assert!(again["onnxruntime"]["found_by"]
        .as_str()
        .unwrap()
        .contains("UNICAC_PYTHON"));
}

#[test]
fn an_explicit_lpips_without_a_findable_onnxruntime_is_an_error_naming_the_fix() {
    let dir = scratch("missing");
    let (a, b) = image_pair(&dir);
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let metrics = |extra: &[&str], env: &[(&str, &Path)]| {
        let mut command = unicac();
        command
            .args(["metrics", a.to_str().unwrap(), b.to_str().unwrap(), "--json"])
            .args(extra)
            .env("PATH", &empty)
            .env("UNICAC_CACHE_DIR", dir.join("cache"));
        for (name, value) in env {
            command.env(name, value);
        }
        command.output().unwrap()
    };
    let out = metrics(&["--metrics", "lpips"], &[]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(out.stdout.is_empty());
    let message = stderr(&out);
    for part in [
        "--metrics lpips",
        "onnxruntime not found",
        "python3",
        "UNICAC_PYTHON",
        "ORT_DYLIB_PATH",
    ] {
        assert!(message.contains(part), "{part}: {message}");
    }
    // The default set still runs: LPIPS null, the reason on stderr and in the JSON.
    let out = metrics(&[], &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(report["pairs"][0]["lpips"].is_null() && report["pairs"][0]["psnr_db"].is_f64());
    assert!(report["onnxruntime"].is_null());
    assert!(report["notices"][0]
        .as_str()
        .unwrap()
        .contains("onnxruntime not found"));

    // A Python whose onnxruntime is older than the API this build uses is named with its version.
    let package = dir.join("site/onnxruntime");
    std::fs::create_dir_all(package.join("capi")).unwrap();
    std::fs::write(package.join("capi/libonnxruntime.so.1.20.1"), b"").unwrap();
    let old = dir.join("old-python");
    std::fs::write(
        &old,
        format!("#!/bin/sh\necho \"$0\"\necho '{}'\n", package.display()),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&old, std::fs::Permissions::from_mode(0o755)).unwrap();
    let out = metrics(&["--metrics", "lpips"], &[("UNICAC_PYTHON", &old)]);
    assert_eq!(out.status.code(), Some(1));
    let message = stderr(&out);
    assert!(
        message.contains("1.20.1") && message.contains("older than 1.31"),
        "{message}"
    );

    // ORT_DYLIB_PATH naming something that is not a library: refused by name, no fallback.
    let not_a_library = dir.join("libonnxruntime.so.1.31.1");
    std::fs::write(&not_a_library, b"not a library").unwrap();
    let out = metrics(&["--metrics", "lpips"], &[("ORT_DYLIB_PATH", &not_a_library)]);
    assert_eq!(out.status.code(), Some(1));
    let message = stderr(&out);
    assert!(
        message.contains("cannot load it") && message.contains("libonnxruntime.so.1.31.1"),
        "{message}"
    );
}

/// `unicac dataset build` on two built-in lenses, with `extra` flags; returns the folder.
fn build_dataset(dir: &Path, extra: &[&str]) -> PathBuf {
    let out_dir = dir.join("data");
    let mut args: Vec<&str> = vec![
        "dataset",
        "build",
        "--lenses",
        "builtin:achromat",
        "builtin:cooke_triplet",
        "builtin:double_gauss",
        "builtin:petzval",
        "--images",
        "dead-leaves:2:80x60",
        "--test-images",
        "dead-leaves:1",
        "--frame",
        "64x48",
        "--levels",
        "2",
        "--test-lenses-per-level",
        "1",
        "--val-lenses",
        "1",
        "--pairs-per-lens",
        "1",
        "--crop",
        "32x24",
        "--out",
    ];
    let out_text = out_dir.display().to_string();
    args.push(&out_text);
    args.extend(extra);
    let out = unicac().args(&args).output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    out_dir
}

/// Runs the `unicac ode` command `dataset info` prints, for every lens the dataset records, and
/// compares the scores to the last digit.
fn recorded_grades_are_what_the_printed_ode_command_prints(data: &Path, expected_flags: &str) {
    let out = unicac()
        .args(["dataset", "info", data.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let command = info["ode_command"].as_str().unwrap().to_string();
    assert_eq!(command, format!("unicac ode LENS {expected_flags}"));
    let text = unicac()
        .args(["dataset", "info", data.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&text.stdout).contains(&command));
    let rows: Vec<serde_json::Value> = std::fs::read_to_string(data.join("lenses.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let lenses: Vec<String> = rows
        .iter()
        .map(|r| r["source"].as_str().unwrap().to_string())
        .collect();
    let words: Vec<String> = command.split_whitespace().skip(1).map(String::from).collect();
    let mut args: Vec<String> = Vec::new();
    for word in &words {
        match word.as_str() {
            "LENS" => args.extend(lenses.iter().cloned()),
            other => args.push(other.to_string()),
        }
    }
    args.push("--json".into());
    let out = unicac().args(&args).output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for (row, graded) in rows.iter().zip(printed["lenses"].as_array().unwrap()) {
        assert_eq!(row["source"], graded["lens"]);
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
            assert_eq!(row[key], graded[key], "{}: {key}", row["source"]);
        }
        assert_eq!(row["pixel_pitch_um"], graded["pixel_um"], "{}", row["source"]);
    }
}

#[test]
fn ode_with_the_frame_prints_the_grade_a_dataset_records_for_each_lens() {
    let dir = scratch("frame");
    let data = build_dataset(&dir, &[]);
    recorded_grades_are_what_the_printed_ode_command_prints(&data, "--frame 64x48 --device cpu");
}

#[test]
fn ode_with_the_frame_and_pitch_prints_the_grade_a_dataset_records_for_each_lens() {
    let dir = scratch("frame-pitch");
    let data = build_dataset(&dir, &["--pixel-um", "20"]);
    recorded_grades_are_what_the_printed_ode_command_prints(
        &data,
        "--frame 64x48 --pixel-um 20 --device cpu",
    );
}

#[test]
fn ode_refuses_a_bad_frame_or_pitch_by_flag_before_any_work() {
    for (args, flag) in [
        (vec!["--frame", "64"], "--frame"),
        (vec!["--frame", "0x48"], "--frame"),
        (vec!["--frame", "64x48", "--pixel-um", "0"], "--pixel-um"),
        (vec!["--frame", "64x48", "--pixel-um", "nan"], "--pixel-um"),
        (vec!["--pixel-um", "2"], "--frame"),
    ] {
        let out = unicac()
            .args(["ode", "builtin:cooke_triplet"])
            .args(&args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        assert!(stderr(&out).contains(flag), "{args:?}: {}", stderr(&out));
        assert!(out.stdout.is_empty());
    }
}
