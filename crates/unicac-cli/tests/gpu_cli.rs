//! The GPU faces of the CLI (issue 5): `unicac gpu info`, `--device` / `--gpu-precision`, and the rule
//! that a missing adapter means a message and the CPU path, never a failure. The no-adapter case is
//! forced by pointing the Vulkan loader at a driver list that does not exist.

use serde_json::Value;
use std::process::{Command, Output};

fn unicac(args: &[&str], no_adapter: bool) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_unicac"));
    command.args(args).env(
        "UNICAC_CACHE_DIR",
        std::env::temp_dir().join("unicac-gpu-cli-cache"),
    );
    if no_adapter {
        command
            .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
            .env("VK_DRIVER_FILES", "/nonexistent/icd.json");
    }
    command.output().expect("run unicac")
}

fn json(out: &Output) -> Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn rms(report: &Value) -> Vec<f64> {
    report["spots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["rms_radius_um"].as_f64().unwrap())
        .collect()
}

#[test]
fn gpu_info_lists_adapters_or_says_there_are_none() {
    let info = json(&unicac(&["gpu", "info", "--json"], false));
    assert!(info["adapters"].is_array());
    assert_eq!(info["auto_min_rays"].as_u64(), Some(16384));
    let none = json(&unicac(&["gpu", "info", "--json"], true));
    assert_eq!(none["adapters"].as_array().unwrap().len(), 0);
    let text = unicac(&["gpu", "info"], true);
    assert!(text.status.success());
    assert!(String::from_utf8_lossy(&text.stdout).contains("no GPU adapter"));
}

#[test]
fn spot_on_the_gpu_agrees_with_the_cpu_and_falls_back_without_an_adapter() {
    let base = [
        "spot",
        "builtin:cooke_triplet",
        "--pupil-sampling",
        "hexapolar:8",
        "--json",
    ];
    let cpu = rms(&json(&unicac(&[&base[..], &["--device", "cpu"]].concat(), false)));
    for precision in ["f32", "f64"] {
        let out = unicac(
            &[&base[..], &["--device", "gpu", "--gpu-precision", precision]].concat(),
            false,
        );
        let gpu = rms(&json(&out));
        let worst = cpu
            .iter()
            .zip(&gpu)
            .map(|(c, g)| (c - g).abs() / c)
            .fold(0.0, f64::max);
        // Where no adapter exists, this compares the CPU fallback with itself (worst = 0).
        assert!(worst < 0.01, "{precision}: {worst}");
    }
    let out = unicac(&[&base[..], &["--device", "gpu"]].concat(), true);
    assert_eq!(rms(&json(&out)), cpu, "the fallback is the CPU path");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("no GPU adapter") && stderr.contains("CPU"),
        "{stderr}"
    );
}

#[test]
fn bad_device_values_are_rejected_by_the_parser() {
    let out = unicac(&["spot", "builtin:singlet", "--device", "tpu"], false);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected cpu, gpu or auto"));
}

/// A fresh folder under the system temp dir for one test.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-gpu-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn samples(path: &std::path::Path) -> Vec<f32> {
    unicac_image::io::read_image(path).unwrap().image.data
}

#[test]
fn simulate_on_the_gpu_matches_the_cpu_and_falls_back_without_an_adapter() {
    let dir = scratch("simulate");
    let chart = dir.join("chart.png");
    let chart_arg = chart.to_str().unwrap();
    assert!(unicac(
        &["chart", "dead-leaves", "--size", "200x150", "--out", chart_arg],
        false
    )
    .status
    .success());
    let run = |device: &str, no_adapter: bool| {
        let out = dir.join(format!("{device}-{no_adapter}"));
        let args = [
            "simulate",
            "builtin:phone_asphere",
            chart_arg,
            "--no-isp",
            "--no-noise",
            "--device",
            device,
            "--out",
            out.to_str().unwrap(),
        ];
        let output = unicac(&args, no_adapter);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        (
            out.join("chart.png"),
            String::from_utf8_lossy(&output.stderr).into_owned(),
        )
    };
    let (cpu, _) = run("cpu", false);
    let (gpu, stderr) = run("gpu", false);
    let (cpu, gpu_samples) = (samples(&cpu), samples(&gpu));
    // Within 1e-6 of the CPU in linear light: a 16-bit sRGB code apart at most (rounding).
    let worst = cpu
        .iter()
        .zip(&gpu_samples)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 1.5 / 65535.0, "worst {worst}; {stderr}");
    // Without an adapter: the CPU path, bit for bit, and a note saying so.
    let (fallback, stderr) = run("gpu", true);
    assert!(samples(&fallback) == cpu, "the fallback is the CPU path");
    assert!(
        stderr.contains("no GPU adapter") && stderr.contains("CPU"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_dataset_built_on_the_gpu_records_its_device_and_resumes_only_there() {
    let dir = scratch("dataset");
    let build = |name: &str, device: &str, no_adapter: bool| {
        let out = dir.join(name);
        let args = [
            "dataset",
            "build",
            "--lenses",
            "builtin:cooke_triplet",
            "builtin:petzval",
            "--images",
            "dead-leaves:1:160x120",
            "--test-images",
            "dead-leaves:1:160x120",
            "--levels",
            "1",
            "--test-lenses-per-level",
            "1",
            "--val-lenses",
            "0",
            "--pairs-per-lens",
            "1",
            "--crop",
            "64x64",
            "--device",
            device,
            "--out",
            out.to_str().unwrap(),
        ];
        let output = unicac(&args, no_adapter);
        (
            out,
            output.status.success(),
            String::from_utf8_lossy(&output.stderr).into_owned(),
        )
    };
    // No adapter: `gpu` is refused before any work (the record must name the device that renders),
    // `auto` builds on the CPU.
    let (out, ok, stderr) = build("refused", "gpu", true);
    assert!(!ok && stderr.contains("--device gpu"), "{stderr}");
    assert!(!out.join("dataset.json").exists());
    let (_, ok, stderr) = build("auto", "auto", true);
    assert!(ok, "{stderr}");
    let (gpu, ok, stderr) = build("gpu", "gpu", false);
    assert!(ok, "{stderr}");
    let record: Value = serde_json::from_slice(&std::fs::read(gpu.join("dataset.json")).unwrap()).unwrap();
    assert_eq!(record["settings"]["device"], "gpu");
    let auto: Value =
        serde_json::from_slice(&std::fs::read(dir.join("auto").join("dataset.json")).unwrap()).unwrap();
    assert!(
        auto["settings"].get("device").is_none(),
        "a CPU build's record has no device"
    );
    // Resuming the GPU folder on the CPU is refused, naming the setting.
    let (_, ok, stderr) = build("gpu", "cpu", false);
    assert!(!ok && stderr.contains("device"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
