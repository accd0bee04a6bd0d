//! The report folder holds one run's report and nothing else. A new or empty folder is used as is; a
//! previous report (every entry one the report writes) is cleared before the run's work starts, so no
//! picture, table or restored image of an earlier run stays beside the new results; any other folder is
//! refused before any work, so a mistyped `--out` never mixes a report into (or clears) the user's files.

use std::path::{Path, PathBuf};

use crate::error::{BenchError, Result};

/// Files a run may write at the top of the folder (`write::write_report`).
const FILES: &[&str] = &[
    "results.json",
    "pairs.csv",
    "lens_op.csv",
    "tables.md",
    "report.html",
    "ranking_trend.png",
    "metric_psnr.png",
    "metric_ssim.png",
    "metric_lpips.png",
    "metric_op.png",
    "analysis.png",
];
/// `tables/BENCHMARK.tex`.
const TABLES: &str = "tables";
/// `images/MODEL/PAIR_ID.png` (`--save-images`).
const IMAGES: &str = "images";

fn io(path: &Path, e: std::io::Error) -> BenchError {
    BenchError::io(path, e)
}

/// Entries of a folder (name, path, type without following symlinks).
fn entries(dir: &Path) -> Result<Vec<(String, PathBuf, std::fs::FileType)>> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| io(dir, e))? {
        let entry = entry.map_err(|e| io(dir, e))?;
        let kind = entry.file_type().map_err(|e| io(&entry.path(), e))?;
        out.push((
            entry.file_name().to_string_lossy().into_owned(),
            entry.path(),
            kind,
        ));
    }
    Ok(out)
}

/// The first entry under `dir` that a bench report does not write, if any.
fn foreign_entry(dir: &Path) -> Result<Option<PathBuf>> {
    let owned_file = |name: &str, kind: &std::fs::FileType, allowed: &dyn Fn(&str) -> bool| {
        kind.is_file() && (allowed(name) || unicac_io::is_temporary_name(name))
    };
    for (name, path, kind) in entries(dir)? {
        let ok = if kind.is_dir() && name == TABLES {
            let tex = |n: &str| crate::Benchmark::ALL.iter().any(|b| n == format!("{b}.tex"));
            entries(&path)?.iter().all(|(n, _, k)| owned_file(n, k, &tex))
        } else if kind.is_dir() && name == IMAGES {
            let mut ok = true;
            for (_, model, model_kind) in entries(&path)? {
                let png = |n: &str| n.ends_with(".png");
                ok &= model_kind.is_dir() && entries(&model)?.iter().all(|(n, _, k)| owned_file(n, k, &png));
            }
            ok
        } else {
            owned_file(&name, &kind, &|n| FILES.contains(&n))
        };
        if !ok {
            return Ok(Some(path));
        }
    }
    Ok(None)
}

/// Refuses `dir` unless it is absent, an empty folder or a previous report. Run before any work.
pub fn check(dir: &Path) -> Result<()> {
    let metadata = match std::fs::symlink_metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(io(dir, e)),
    };
    // A symlink to a folder is followed (the plan compared its target with the inputs).
    let is_dir = metadata.is_dir() || std::fs::metadata(dir).is_ok_and(|m| m.is_dir());
    if !is_dir {
        return Err(unicac_trace::InvalidParameter::new(
            "out",
            format!(
                "{}: exists and is not a folder; give a new folder, an empty one or a previous report",
                dir.display()
            ),
        )
        .into());
    }
    if let Some(foreign) = foreign_entry(dir)? {
        return Err(unicac_trace::InvalidParameter::new(
            "out",
            format!(
                "{}: holds {}, which is not part of a bench report; give a new folder, an empty one or \
                 a previous report (whose files are replaced)",
                dir.display(),
                foreign.display()
            ),
        )
        .into());
    }
    Ok(())
}

/// Checks `dir` again, makes it (true when this run made it) and clears a previous report from it.
/// Run after every check, right before the work.
pub fn claim(dir: &Path) -> Result<bool> {
    check(dir)?;
    let made = !dir.exists();
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    for (_, path, kind) in entries(dir)? {
        let removed = if kind.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        removed.map_err(|e| io(&path, e))?;
    }
    Ok(made)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_new_empty_or_report_folders_are_taken_and_a_report_is_cleared() {
        let root = std::env::temp_dir().join(format!("unicac-bench-folder-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let report = root.join("report");
        check(&report).unwrap();
        assert!(claim(&report).unwrap());
        std::fs::create_dir_all(report.join("images/m")).unwrap();
        std::fs::create_dir_all(report.join("tables")).unwrap();
        for file in [
            "results.json",
            "analysis.png",
            "tables/us.tex",
            "images/m/p1.png",
            ".tables.md.tmp-1-2.md",
        ] {
            std::fs::write(report.join(file), b"old").unwrap();
        }
        check(&report).unwrap();
        assert!(!claim(&report).unwrap());
        assert_eq!(std::fs::read_dir(&report).unwrap().count(), 0);
        // The user's own files anywhere in it: refused, nothing removed.
        for foreign in ["notes.txt", "images/m/p1.jpg", "tables/x.tex"] {
            std::fs::create_dir_all(report.join("images/m")).unwrap();
            std::fs::create_dir_all(report.join("tables")).unwrap();
            std::fs::write(report.join(foreign), b"mine").unwrap();
            let message = claim(&report).unwrap_err().to_string();
            assert!(message.contains("not part of a bench report"), "{message}");
            assert_eq!(std::fs::read(report.join(foreign)).unwrap(), b"mine");
            std::fs::remove_file(report.join(foreign)).unwrap();
        }
        let file = root.join("file");
        std::fs::write(&file, b"x").unwrap();
        assert!(check(&file).unwrap_err().to_string().contains("not a folder"));
        std::fs::remove_dir_all(&root).unwrap();
    }
}
