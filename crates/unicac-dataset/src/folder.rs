//! An opened dataset folder: `dataset.json` checked when it is opened, and each manifest's rows checked
//! against the counts it records when they are read (`row_counts`), so a truncated manifest is an error,
//! never a smaller dataset. Apart from `manifest` (the on-disk types) so that the checks can use those
//! types without the types depending on the checks.

use crate::error::{DatasetError, Result};
use crate::manifest::{
    read_jsonl, read_manifest, DatasetManifest, EdgeRow, LensRow, PairRow, EDGES_JSONL, LENSES_JSONL,
    PAIRS_JSONL,
};
use crate::row_counts;
use std::path::{Path, PathBuf};

/// An opened dataset directory whose `dataset.json` was checked.
#[derive(Debug, Clone)]
pub struct Dataset {
    pub dir: PathBuf,
    pub manifest: DatasetManifest,
}

impl Dataset {
    /// Opens DIR: a clear error when it holds no `dataset.json` of this format, or a newer version.
    pub fn open(dir: &Path) -> Result<Dataset> {
        Ok(Dataset {
            dir: dir.to_path_buf(),
            manifest: read_manifest(dir)?,
        })
    }

    /// The lens rows, checked against `dataset.json`'s counts per split and per level.
    pub fn lenses(&self) -> Result<Vec<LensRow>> {
        let path = self.dir.join(LENSES_JSONL);
        let rows: Vec<LensRow> = read_jsonl(&path)?;
        row_counts::check_lenses(&path, &rows, &self.manifest)?;
        Ok(rows)
    }

    /// The pair rows, checked against `dataset.json`'s counts per split.
    pub fn pairs(&self) -> Result<Vec<PairRow>> {
        let path = self.dir.join(PAIRS_JSONL);
        let rows: Vec<PairRow> = read_jsonl(&path)?;
        row_counts::check_pairs(&path, &rows, &self.manifest.counts)?;
        Ok(rows)
    }

    /// The edge rows, checked against `dataset.json`'s count.
    pub fn edges(&self) -> Result<Vec<EdgeRow>> {
        let path = self.dir.join(EDGES_JSONL);
        let rows: Vec<EdgeRow> = read_jsonl(&path)?;
        row_counts::check_edges(&path, &rows, &self.manifest.counts)?;
        Ok(rows)
    }

    /// A path from a manifest row, resolved against DIR (refusing absolute paths and `..`).
    pub fn resolve(&self, relative: &str) -> Result<PathBuf> {
        resolve_relative(&self.dir, relative)
    }
}

/// A path from a manifest row, resolved against the dataset folder `dir`: absolute paths, `..`, `.` and
/// the empty path are refused, so no row can point outside the folder.
pub fn resolve_relative(dir: &Path, relative: &str) -> Result<PathBuf> {
    let path = Path::new(relative);
    if relative.is_empty()
        || path.is_absolute()
        || path
            .components()
            .any(|c| !matches!(c, std::path::Component::Normal(_)))
    {
        return Err(DatasetError::format(
            dir,
            format!("manifest path {relative:?} must be relative to the dataset folder"),
        ));
    }
    Ok(dir.join(path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::{write_json, Counts, PairTask, DATASET_JSON, FORMAT_NAME, FORMAT_VERSION};

    fn manifest() -> DatasetManifest {
        DatasetManifest {
            format: FORMAT_NAME.into(),
            format_version: FORMAT_VERSION,
            unicac_version: "0.1.0".into(),
            settings: serde_json::json!({"seed": 1}),
            seed: 1,
            frame_px: [64, 48],
            stratifications: vec![],
            counts: Counts::default(),
            task: PairTask::Aligned,
            comparable_by_ode_level: true,
        }
    }

    #[test]
    fn opening_checks_the_format_and_its_version() {
        let dir = std::env::temp_dir().join(format!("unicac-dataset-manifest-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let error = Dataset::open(&dir).unwrap_err().to_string();
        assert!(error.contains(": not a unicac dataset"), "{error}");
        std::fs::write(dir.join(DATASET_JSON), r#"{"format": "something-else"}"#).unwrap();
        assert!(matches!(
            Dataset::open(&dir),
            Err(DatasetError::NotADataset { .. })
        ));
        let mut newer = serde_json::to_value(manifest()).unwrap();
        newer["format_version"] = serde_json::json!(FORMAT_VERSION + 1);
        write_json(&dir.join(DATASET_JSON), &newer).unwrap();
        let error = Dataset::open(&dir).unwrap_err().to_string();
        assert!(error.contains("newer"), "{error}");
        write_json(&dir.join(DATASET_JSON), &manifest()).unwrap();
        let dataset = Dataset::open(&dir).unwrap();
        assert_eq!(dataset.manifest, manifest());
        assert!(dataset.resolve("../x").is_err() && dataset.resolve("/etc/passwd").is_err());
        assert!(dataset.resolve("").is_err() && dataset.resolve("./a").is_err());
        assert_eq!(
            dataset.resolve("test/lq/a.png").unwrap(),
            dir.join("test/lq/a.png")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
