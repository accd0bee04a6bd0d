//! A build's hold on its output folder: the settings and the scene files' SHA-256 (the inputs that
//! decide the dataset's bytes) recorded in `DIR/.unicac-build.json` before any work, created
//! exclusively, so that of two builds started into one new folder with different settings one is
//! refused instead of both writing a mix; a build of the same settings (a resume, another shard)
//! shares the folder. The record is checked again before the first dataset file is written, and a
//! resume whose scene files changed since the build began is refused, naming the scene (its pairs
//! would otherwise mix renders of two versions).

use crate::error::{DatasetError, Result};
use crate::manifest::DATASET_JSON;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The run-independent record of a build, kept in DIR.
pub const BUILD_JSON: &str = ".unicac-build.json";

/// What a build records in `BUILD_JSON`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BuildRecord {
    pub settings: serde_json::Value,
    /// SHA-256 of every scene file, by its source (charts are generated from the seed); None in the
    /// records of builds made before scenes were recorded (not compared).
    pub scenes: Option<BTreeMap<String, String>>,
}

impl BuildRecord {
    /// The record in DIR (`BUILD_JSON`, else the settings of a finished `dataset.json`), if any.
    fn read(out: &Path) -> Option<BuildRecord> {
        let value = |name: &str| -> Option<serde_json::Value> {
            serde_json::from_slice(&std::fs::read(out.join(name)).ok()?).ok()
        };
        if let Some(value) = value(BUILD_JSON) {
            return Some(match serde_json::from_value::<BuildRecord>(value.clone()) {
                Ok(record) if value.get("settings").is_some() => record,
                // Earlier builds recorded the settings alone.
                _ => BuildRecord {
                    settings: value,
                    scenes: None,
                },
            });
        }
        value(DATASET_JSON).map(|dataset| BuildRecord {
            settings: dataset.get("settings").cloned().unwrap_or_default(),
            scenes: None,
        })
    }

    /// Refuses a folder recorded with other settings, or whose scene files changed since.
    fn matches(&self, out: &Path, previous: &BuildRecord) -> Result<()> {
        if previous.settings != self.settings {
            let differing: Vec<String> = match (previous.settings.as_object(), self.settings.as_object()) {
                // Both sides' keys: a setting recorded only when set (`device`, `exclude_flagged`)
                // is missing from one record.
                (Some(a), Some(b)) => (a.keys().chain(b.keys()))
                    .filter(|k| a.get(*k) != b.get(*k))
                    .collect::<std::collections::BTreeSet<_>>()
                    .into_iter()
                    .cloned()
                    .collect(),
                _ => vec!["settings".into()],
            };
            // The one difference a user did not choose: the release drew the noise another way.
            let why = if differing.iter().any(|k| k == super::NOISE_DRAWS_KEY) {
                " (noise_draws: its pairs' sensor noise was drawn by another release's generator, and resuming would mix two noise realisations)"
            } else {
                ""
            };
            return Err(DatasetError::format(
                out,
                format!(
                    "another build with different settings holds this folder (it differs in {}){why}; choose another folder, or remove this one",
                    differing.join(", ")
                ),
            ));
        }
        let (Some(before), Some(now)) = (&previous.scenes, &self.scenes) else {
            return Ok(());
        };
        let changed = before
            .keys()
            .chain(now.keys())
            .find(|source| before.get(*source) != now.get(*source));
        let Some(source) = changed else {
            return Ok(());
        };
        let short =
            |hash: Option<&String>| hash.map_or("absent".to_string(), |h| h[..12.min(h.len())].to_string());
        Err(DatasetError::format(
            out,
            format!(
                "the scene {source} changed since this build began (SHA-256 {} then, {} now): its pairs would mix renders of two versions; restore it, or build into a new folder",
                short(before.get(source)),
                short(now.get(source))
            ),
        ))
    }
}

/// `out` is absent, empty (dot-named leftovers aside), or holds a build of the same record.
pub fn check_output(out: &Path, record: &BuildRecord) -> Result<()> {
    if !out.exists() {
        return Ok(());
    }
    if !out.is_dir() {
        return Err(DatasetError::format(out, "exists and is not a folder"));
    }
    if let Some(previous) = BuildRecord::read(out) {
        return record.matches(out, &previous);
    }
    let entries = std::fs::read_dir(out).map_err(|e| DatasetError::io(out, e))?;
    for entry in entries {
        let name = entry.map_err(|e| DatasetError::io(out, e))?.file_name();
        if !name.to_string_lossy().starts_with('.') {
            return Err(DatasetError::format(
                out,
                format!(
                    "is not empty and holds no unicac dataset build (found {}); choose an empty or new folder",
                    name.to_string_lossy()
                ),
            ));
        }
    }
    Ok(())
}

/// This run's hold on `out`. Dropped before `keep`, a claim this run created is released, so a build
/// refused during grading leaves the folder free for other settings.
#[derive(Debug)]
pub struct Claim {
    path: PathBuf,
    created: bool,
    kept: bool,
}

/// Claims `out` for `record`: creates the folder and the record exclusively, or finds the same record
/// there (a resume or another shard); another record is refused.
pub fn claim(out: &Path, record: &BuildRecord) -> Result<Claim> {
    std::fs::create_dir_all(out).map_err(|e| DatasetError::io(out, e))?;
    let path = out.join(BUILD_JSON);
    let mut bytes = serde_json::to_vec_pretty(record).expect("a record serialises");
    bytes.push(b'\n');
    match unicac_io::write_new_atomically(&path, &bytes) {
        Ok(()) => Ok(Claim {
            path,
            created: true,
            kept: false,
        }),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            confirm(out, record)?;
            Ok(Claim {
                path,
                created: false,
                kept: false,
            })
        }
        Err(e) => Err(DatasetError::io(&path, e)),
    }
}

/// The record in `out` is still `record` (checked again before the first dataset file is written).
pub fn confirm(out: &Path, record: &BuildRecord) -> Result<()> {
    match BuildRecord::read(out) {
        Some(previous) => record.matches(out, &previous),
        None => Err(DatasetError::format(
            out,
            format!(
                "{BUILD_JSON} disappeared during the build (was the folder removed?); run the build again"
            ),
        )),
    }
}

impl Claim {
    /// The build has started writing: the claim stays.
    pub fn keep(mut self) {
        self.kept = true;
    }
}

impl Drop for Claim {
    fn drop(&mut self) {
        if self.created && !self.kept {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}
