//! `unicac design` through the real binary: the command line that checks outside the project call, the
//! files it writes (unicac JSON and .zmx, read back by `unicac lens info`), resume, and clear errors.

use serde_json::Value;
use std::path::PathBuf;
use std::process::{Command, Output};

fn unicac(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        .output()
        .expect("run unicac")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-design-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn design_writes_zmx_and_json_lenses_and_resumes() {
    let out = scratch("lib");
    let out_text = out.to_str().unwrap();
    let args = [
        "design",
        "--elements",
        "2",
        "--half-fov-deg",
        "20",
        "--f-number",
        "4",
        "--stop",
        "middle",
        "--focal-length-mm",
        "50",
        "--count",
        "2",
        "--seed",
        "3",
        "--time-budget-s",
        "20",
        "--out",
        out_text,
        "--json",
    ];
    let run = unicac(&args);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let summary: Value = serde_json::from_slice(&run.stdout).unwrap();
    let lenses = summary["lenses"].as_array().unwrap();
    assert!(!lenses.is_empty(), "no lens within 20 s");
    for lens in lenses {
        for key in ["json", "zmx"] {
            let path = out.join(lens[key].as_str().unwrap());
            let info = unicac(&["lens", "info", path.to_str().unwrap(), "--json"]);
            assert!(info.status.success(), "{}", String::from_utf8_lossy(&info.stderr));
            let info: Value = serde_json::from_slice(&info.stdout).unwrap();
            let efl = info["efl_mm"].as_f64().unwrap();
            assert!((efl - 50.0).abs() < 0.5, "{key}: efl {efl}");
        }
        assert!(out
            .join(lens["json"].as_str().unwrap().replace(".json", ".report.json"))
            .exists());
    }
    let manifest = std::fs::read_to_string(out.join("manifest.csv")).unwrap();
    assert_eq!(manifest.lines().count(), lenses.len() + 1);
    // Rerunning the finished job keeps the library as it is.
    let again = unicac(&args);
    assert!(again.status.success());
    assert_eq!(
        std::fs::read_to_string(out.join("manifest.csv")).unwrap(),
        manifest
    );
}

#[test]
fn design_rejects_bad_specifications_clearly() {
    let out = scratch("bad");
    let out_text = out.to_str().unwrap();
    let base = [
        "design",
        "--half-fov-deg",
        "20",
        "--f-number",
        "4",
        "--out",
        out_text,
    ];
    let run = unicac(&[&base[..], &["--elements", "7", "--stop", "front"]].concat());
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("elements"));
    let run = unicac(&[&base[..], &["--elements", "2", "--stop", "sideways"]].concat());
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("front, middle or back"));
    let run = unicac(
        &[
            &base[..],
            &["--elements", "2", "--stop", "front", "--sensor", "36"],
        ]
        .concat(),
    );
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("WIDTHxHEIGHT"));
}
