//! `unicac dataset build --task aligned|full` and the pair checks `dataset info` prints, through the
//! real binary (docs/dataset.md, "What a pair teaches", "Pair checks").

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("unicac-pairs-cli-{}", std::process::id()))
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn wide_angle_100() -> String {
    format!("{}/../../lenses/wide_angle_100.json", env!("CARGO_MANIFEST_DIR"))
}

fn unicac(args: &[String]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        .output()
        .expect("run unicac")
}

/// A 3-lens, 1-level build with the 100-degree wide angle; `task` None: the default.
fn build(out: &Path, task: Option<&str>) -> Output {
    let mut args: Vec<String> = [
        "dataset",
        "build",
        "--lenses",
        "builtin:cooke_triplet",
        "builtin:double_gauss",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.push(wide_angle_100());
    for a in [
        "--images",
        "dead-leaves:2:128x96",
        "--test-images",
        "dead-leaves:1",
        "--frame",
        "128x96",
        "--levels",
        "1",
        "--test-lenses-per-level",
        "1",
        "--val-lenses",
        "1",
        "--pairs-per-lens",
        "2",
        "--crop",
        "64x48",
        "--out",
    ] {
        args.push(a.into());
    }
    args.push(out.display().to_string());
    if let Some(task) = task {
        args.extend(["--task".into(), task.into()]);
    }
    unicac(&args)
}

fn info(dir: &Path) -> (String, serde_json::Value) {
    let text = unicac(&["dataset".into(), "info".into(), dir.display().to_string()]);
    assert!(text.status.success(), "{}", String::from_utf8_lossy(&text.stderr));
    let json = unicac(&[
        "dataset".into(),
        "info".into(),
        dir.display().to_string(),
        "--json".into(),
    ]);
    assert!(json.status.success());
    (
        String::from_utf8(text.stdout).unwrap(),
        serde_json::from_slice(&json.stdout).unwrap(),
    )
}

fn wide_row(info: &serde_json::Value) -> serde_json::Value {
    info["pair_checks"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["lens_id"].as_str().unwrap().starts_with("wide_angle_100"))
        .unwrap()
        .clone()
}

#[test]
fn the_default_task_is_aligned_and_full_pairs_of_a_wide_angle_are_flagged() {
    let aligned = scratch("aligned");
    let done = build(&aligned, None);
    assert_eq!(
        done.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let (text, json) = info(&aligned);
    assert_eq!(json["task"], "aligned");
    assert_eq!(json["comparable_by_ode_level"], true);
    assert!(text.contains("task: aligned\n"), "{text}");
    assert!(text.contains("0 lens(es) flagged"), "{text}");
    let wide = wide_row(&json);
    assert!(wide["mean_lq_gt_psnr_db"].as_f64().unwrap() > 25.0, "{wide}");
    assert!(wide["flag"].is_null(), "{wide}");

    let full = scratch("full");
    let done = build(&full, Some("full"));
    assert_eq!(
        done.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let (text, json) = info(&full);
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(full.join("dataset.json")).unwrap()).unwrap();
    assert_eq!(manifest["task"], "full");
    assert_eq!(manifest["settings"]["task"], "full");
    assert_eq!(manifest["comparable_by_ode_level"], false);
    assert!(
        text.contains("task: full (the GT is undistorted and unshaded"),
        "{text}"
    );
    let wide = wide_row(&json);
    let full_psnr = wide["mean_lq_gt_psnr_db"].as_f64().unwrap();
    assert!(full_psnr < 20.0, "{wide}");
    let flag = wide["flag"].as_str().unwrap();
    assert!(
        flag.contains("misregistered") && flag.contains("blur explains"),
        "{flag}"
    );
    let line = text.lines().find(|l| l.starts_with("wide_angle_100")).unwrap();
    assert!(line.contains("misregistered"), "{line}");

    // Another task in the same folder is another dataset: refused by name, nothing changed.
    let before = std::fs::read(full.join("pairs.jsonl")).unwrap();
    let again = build(&full, Some("aligned"));
    assert_eq!(again.status.code(), Some(1));
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(err.contains("task"), "{err}");
    assert_eq!(std::fs::read(full.join("pairs.jsonl")).unwrap(), before);
    let bad = build(&scratch("bad"), Some("sideways"));
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--task"));
    let _ = std::fs::remove_dir_all(aligned.parent().unwrap());
}
