//! The helpers of the reliability tests (`bench_reliability.rs`, `dataset_reliability.rs`): the real binary in a
//! scratch folder of its own test binary, refusals checked for exit code, speed and message, and one small
//! dataset shared by the tests of a file.
#![allow(dead_code)] // each test file uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!(
            "unicac-{}-{}",
            env!("CARGO_CRATE_NAME"),
            std::process::id()
        ))
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

pub fn unicac(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        .env(
            "UNICAC_CACHE_DIR",
            std::env::temp_dir()
                .join(format!(
                    "unicac-{}-{}",
                    env!("CARGO_CRATE_NAME"),
                    std::process::id()
                ))
                .join("cache"),
        )
        .env_remove("ORT_DYLIB_PATH")
        .output()
        .expect("run unicac")
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

pub fn ok(args: &[&str]) -> Output {
    let out = unicac(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    out
}

/// A command that must be refused fast with rc 1 (or clap's 2 for a value that does not parse), never
/// a panic (101) or an abort (134), with each of `expected` in the message.
pub fn refused(args: &[&str], expected: &[&str]) -> String {
    let start = Instant::now();
    let out = unicac(args);
    let text = stderr(&out);
    assert!(
        matches!(out.status.code(), Some(1 | 2)),
        "{args:?}: {:?} {text}",
        out.status.code()
    );
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "{args:?} took {:?}",
        start.elapsed()
    );
    for e in expected {
        assert!(text.contains(e), "{args:?}: expected '{e}' in: {text}");
    }
    assert!(!text.contains("panicked"), "{text}");
    text
}

/// One small dataset (64 x 48 frame, two levels) shared by the tests of this file.
pub fn dataset() -> &'static Path {
    static DATASET: OnceLock<PathBuf> = OnceLock::new();
    DATASET.get_or_init(|| {
        let out = scratch("dataset");
        let out = out.join("ds");
        ok(&[
            "dataset",
            "build",
            "--lenses",
            "builtin:cooke_triplet",
            "builtin:double_gauss",
            "builtin:petzval",
            "builtin:achromat",
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
            "--seed",
            "3",
            "--out",
            s(&out),
        ]);
        out
    })
}

/// Every file under `dir` (relative paths), sorted.
pub fn files(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                out.push(path.strip_prefix(root).unwrap().display().to_string());
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}
