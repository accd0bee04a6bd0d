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
