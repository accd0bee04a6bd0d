//! `unicac dataset build|info|plot` through the real binary, as users run it: a build killed with SIGKILL
//! at an arbitrary moment and started again equals an uninterrupted build byte for byte; `info` and
//! `plot` read it back; bad input is refused by name before anything is written.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

/// Four built-in lenses: the fewest a 2-level build with one validation lens accepts.
const LENSES: [&str; 4] = [
    "builtin:achromat",
    "builtin:cooke_triplet",
    "builtin:double_gauss",
    "builtin:petzval",
];

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("unicac-dataset-cli-{}", std::process::id()))
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn unicac() -> Command {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
}

fn build_args(lenses: &[&str], out: &Path, seed: u64) -> Vec<String> {
    let mut args = vec!["dataset".to_string(), "build".into(), "--lenses".into()];
    args.extend(lenses.iter().map(|l| l.to_string()));
    for a in [
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
        "2",
        "--crop",
        "32x24",
    ] {
        args.push(a.into());
    }
    args.extend(["--seed".into(), seed.to_string()]);
    args.extend(["--out".into(), out.display().to_string()]);
    args
}

fn run(args: &[String]) -> Output {
    unicac().args(args).output().expect("run unicac")
}

/// Every file under `dir` (relative path -> bytes), dot-named ones included.
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let rel = path.strip_prefix(root).unwrap().display().to_string();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_build_killed_with_sigkill_resumes_to_the_bytes_of_an_uninterrupted_one() {
    let dir = scratch("resume");
    let reference = dir.join("reference");
    let started = Instant::now();
    let out = run(&build_args(&LENSES, &reference, 3));
    assert!(out.status.success(), "{}", stderr(&out));
    let full_run = started.elapsed();
    let expected = tree(&reference);
    assert!(expected.keys().any(|k| k.starts_with("test/lq/")));

    // Killed at 1/4 and at 3/5 of an uninterrupted run's time (the ODE stage, then the rendering stage),
    // each time resumed by the same command; then finished.
    let resumed = dir.join("resumed");
    let mut interrupted = 0;
    for fraction in [0.25, 0.6] {
        let mut child = unicac()
            .args(build_args(&LENSES, &resumed, 3))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(full_run.mul_f64(fraction));
        if child.try_wait().unwrap().is_none() {
            interrupted += 1;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
    }
    assert!(interrupted > 0, "no run was interrupted");
    let out = run(&build_args(&LENSES, &resumed, 3));
    assert!(out.status.success(), "{}", stderr(&out));
    let got = tree(&resumed);
    let missing: Vec<_> = expected.keys().filter(|k| !got.contains_key(*k)).collect();
    let extra: Vec<_> = got.keys().filter(|k| !expected.contains_key(*k)).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "missing {missing:?}, extra {extra:?}"
    );
    for (name, bytes) in &expected {
        assert!(got[name] == *bytes, "{name} differs after kill and resume");
    }

    // `info` reads the counts back; `plot` draws the levels.
    let out = unicac()
        .args(["dataset", "info", reference.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(info["lenses"]["test"], 2, "{info}");
    assert_eq!(info["pairs"]["test"], 2, "{info}");
    assert_eq!(info["pairs"]["train"], 2, "{info}");
    assert_eq!(info["levels"].as_array().unwrap().len(), 2, "{info}");
    let plot = dir.join("levels.png");
    let out = unicac()
        .args(["dataset", "plot", reference.to_str().unwrap(), "--out"])
        .arg(&plot)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::read(&plot).unwrap().starts_with(b"\x89PNG"));

    // The same folder asked for another dataset (another seed) is refused and left as it was.
    let out = run(&build_args(&LENSES, &reference, 4));
    assert!(!out.status.success());
    assert!(stderr(&out).contains("reference"), "{}", stderr(&out));
    assert!(tree(&reference) == expected, "a refused build changed the folder");
}

#[test]
fn a_missing_lens_file_is_named_and_nothing_is_written() {
    let dir = scratch("missing-lens");
    let out_dir = dir.join("out");
    let missing = dir.join("no_such_lens.json");
    let missing = missing.to_str().unwrap();
    let out = run(&build_args(
        &[LENSES[0], LENSES[1], LENSES[2], missing],
        &out_dir,
        3,
    ));
    assert!(!out.status.success());
    assert!(stderr(&out).contains("no_such_lens.json"), "{}", stderr(&out));
    assert!(!out_dir.exists() || tree(&out_dir).is_empty());
}

#[test]
fn a_library_too_small_for_the_levels_is_refused_with_the_numbers() {
    let dir = scratch("too-small");
    let out_dir = dir.join("out");
    // 2 levels x 1 test lens + 1 validation lens + 1 training lens = 4 needed, 3 given.
    let out = run(&build_args(&LENSES[..3], &out_dir, 3));
    assert!(!out.status.success());
    let message = stderr(&out);
    assert!(message.contains('3') && message.contains('4'), "{message}");
    assert!(!out_dir.join("dataset.json").exists());
}
