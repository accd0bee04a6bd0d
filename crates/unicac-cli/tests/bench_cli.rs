//! `unicac metrics` and `unicac bench` through the real binary: the JSON keys outside checks read and
//! clear errors before any work.

use std::path::PathBuf;
use std::process::{Command, Output};

use unicac_image::io::{write_png, SampleDepth};
use unicac_image::Planar;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("unicac-bench-cli-{}", std::process::id()))
        .join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn unicac(args: &[&str], cache: &PathBuf) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        .env("UNICAC_CACHE_DIR", cache)
        .output()
        .expect("run unicac")
}

#[test]
fn metrics_json_has_the_named_keys_and_textbook_psnr() {
    let dir = scratch("metrics");
    let a = Planar::from_fn(32, 24, 3, |c, x, y| {
        ((c * 7 + x * 3 + y * 5) % 17) as f32 / 16.0 * 0.8 + 0.1
    });
    // Every sample 10 codes brighter: MSE = (10/255)^2, PSNR = 10 log10(1 / (MSE + 1e-8)).
    let b = Planar::from_fn(32, 24, 3, |c, x, y| {
        ((a.get(c, x, y) * 255.0).round() + 10.0) / 255.0
    });
    let (pa, pb) = (dir.join("ref.png"), dir.join("dist.png"));
    write_png(&pa, &a, SampleDepth::Eight).unwrap();
    write_png(&pb, &b, SampleDepth::Eight).unwrap();
    let out = unicac(
        &["metrics", pa.to_str().unwrap(), pb.to_str().unwrap(), "--json"],
        &dir.join("cache"),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let row = &report["pairs"][0];
    let mse = (10.0f64 / 255.0).powi(2);
    let expected = 10.0 * (1.0 / (mse + 1e-8)).log10();
    assert!(
        (row["psnr_db"].as_f64().unwrap() - expected).abs() < 1e-4,
        "{row}"
    );
    assert!(row["ssim"].as_f64().unwrap() > 0.9, "{row}");
    // No LPIPS weights in this cache: null with a notice, not an error.
    assert!(row["lpips"].is_null(), "{row}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("lpips"));
    // Asked for explicitly, missing weights are an error.
    let out = unicac(
        &[
            "metrics",
            pa.to_str().unwrap(),
            pb.to_str().unwrap(),
            "--metrics",
            "lpips",
            "--json",
        ],
        &dir.join("cache"),
    );
    assert!(!out.status.success());
    // Folders are matched by name; a missing twin is named.
    std::fs::create_dir_all(dir.join("r")).unwrap();
    std::fs::create_dir_all(dir.join("d")).unwrap();
    std::fs::copy(&pa, dir.join("r/x.png")).unwrap();
    let out = unicac(
        &[
            "metrics",
            dir.join("r").to_str().unwrap(),
            dir.join("d").to_str().unwrap(),
        ],
        &dir.join("cache"),
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("x.png"));
}

#[test]
fn bench_refuses_a_non_onnx_model_before_any_work() {
    let dir = scratch("bench");
    let model = dir.join("model.onnx");
    std::fs::write(&model, b"not a model").unwrap();
    let out = unicac(
        &[
            "bench",
            "--dataset",
            dir.join("nowhere").to_str().unwrap(),
            "--model",
            &format!("m={}", model.display()),
            "--out",
            dir.join("report").to_str().unwrap(),
        ],
        &dir.join("cache"),
    );
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("model.onnx") && stderr.contains("not an ONNX model"),
        "{stderr}"
    );
    assert!(!dir.join("report").exists());
}

#[test]
fn bench_refuses_a_report_folder_that_is_the_dataset_or_a_model() {
    let dir = scratch("out-is-input");
    let dataset = dir.join("dataset");
    std::fs::create_dir_all(&dataset).unwrap();
    std::fs::write(dataset.join("keep.txt"), b"the user's file").unwrap();
    let model = dir.join("model.onnx");
    std::fs::write(&model, b"not a model").unwrap();
    for out in [&dataset, &model] {
        let result = unicac(
            &[
                "bench",
                "--dataset",
                dataset.to_str().unwrap(),
                "--model",
                &format!("m={}", model.display()),
                "--out",
                out.to_str().unwrap(),
            ],
            &dir.join("cache"),
        );
        assert!(!result.status.success());
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(
            stderr.contains("--out") && stderr.contains("would overwrite the input"),
            "{stderr}"
        );
    }
    // Nothing was written into the dataset folder, and the model is untouched.
    let names: Vec<_> = std::fs::read_dir(&dataset)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["keep.txt"]);
    assert_eq!(std::fs::read(&model).unwrap(), b"not a model");
}

#[test]
fn bench_settings_out_of_range_are_named_by_their_flags() {
    let dir = scratch("flags");
    let base = |extra: &[&str]| {
        let mut args = vec![
            "bench".to_string(),
            "--dataset".into(),
            dir.join("nowhere").display().to_string(),
            "--out".into(),
            dir.join("report").display().to_string(),
        ];
        args.extend(extra.iter().map(|a| a.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = unicac(&args, &dir.join("cache"));
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    // The library names BenchSettings fields (overlap_px, models, threads); the CLI says the flags.
    let cases: [(&[&str], &str); 4] = [
        (&["--threads", "0"], "--threads 0: must be between 1 and"),
        (
            &["--tile", "32", "--tile-overlap", "20"],
            "--tile-overlap 20: must be less than half",
        ),
        (&["--model", "a b=x.onnx"], "--model a b=...: names use"),
        (&["--metrics", "mse"], "invalid value 'mse' for '--metrics"),
    ];
    for (extra, expected) in cases {
        let stderr = base(extra);
        assert!(stderr.contains(expected), "{extra:?}: {stderr}");
    }
    assert!(!dir.join("report").exists());
}
