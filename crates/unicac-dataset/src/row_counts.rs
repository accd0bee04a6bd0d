//! A manifest's rows against the counts `dataset.json` records: a manifest missing rows (a truncated
//! copy, or one from another build) is refused instead of being read as a smaller dataset. The Python
//! reader (`unicac.dataset.DatasetFolder`) reads through these checks (the bindings' `read_dataset`).

use crate::error::{DatasetError, Result};
use crate::manifest::{Counts, DatasetManifest, EdgeRow, LensRow, PairRow};
use std::collections::BTreeMap;
use std::path::Path;

/// Rows per split, as `dataset.json` records them.
pub fn per_split<'a>(splits: impl Iterator<Item = &'a str>) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for split in splits {
        *counts.entry(split.to_string()).or_insert(0) += 1;
    }
    counts
}

fn mismatch(path: &Path, found: usize, what: &str, expected: usize) -> DatasetError {
    DatasetError::format(
        path,
        format!(
            "{found} {what}, but dataset.json counts {expected} (the manifest is incomplete or belongs to another build)"
        ),
    )
}

/// Every split's row count equals the recorded one (a split absent from either side counts 0).
fn check_splits(
    path: &Path,
    found: &BTreeMap<String, usize>,
    recorded: &BTreeMap<String, usize>,
    rows: &str,
) -> Result<()> {
    for split in found.keys().chain(recorded.keys()) {
        let (n, expected) = (
            found.get(split).copied().unwrap_or(0),
            recorded.get(split).copied().unwrap_or(0),
        );
        if n != expected {
            return Err(mismatch(path, n, &format!("{split} {rows}"), expected));
        }
    }
    Ok(())
}

/// `pairs.jsonl` holds as many pairs per split as `dataset.json` counts.
pub fn check_pairs(path: &Path, rows: &[PairRow], counts: &Counts) -> Result<()> {
    let found = per_split(rows.iter().map(|r| r.split.as_str()));
    check_splits(path, &found, &counts.pairs, "pairs")
}

/// `lenses.jsonl` holds as many lenses per split, and per level of every stratification, as
/// `dataset.json` counts.
pub fn check_lenses(path: &Path, rows: &[LensRow], manifest: &DatasetManifest) -> Result<()> {
    let found = per_split(rows.iter().map(|r| r.split.as_str()));
    check_splits(path, &found, &manifest.counts.lenses, "lenses")?;
    for stratification in &manifest.stratifications {
        let metric = stratification.metric.as_str();
        for level in &stratification.levels {
            let n = rows
                .iter()
                .filter(|r| r.level_in(metric) == Some(level.level))
                .count();
            if n != level.lenses {
                return Err(mismatch(
                    path,
                    n,
                    &format!("lenses at {metric} level {}", level.level),
                    level.lenses,
                ));
            }
        }
    }
    Ok(())
}

/// `edges.jsonl` holds as many edge patches as `dataset.json` counts.
pub fn check_edges(path: &Path, rows: &[EdgeRow], counts: &Counts) -> Result<()> {
    if rows.len() != counts.edges {
        return Err(mismatch(path, rows.len(), "edge patches", counts.edges));
    }
    Ok(())
}
