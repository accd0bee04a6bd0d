//! A test set for models trained elsewhere must hold lenses those models never saw: with `unseen_by`
//! naming the models' dataset, a lens of this build that is one of its training or validation lenses is
//! refused before any work (one lens specification and one design seed give one lens, so two libraries
//! designed alike share lenses). Lenses are matched by `lens_sha256`, the hash of the lens file's
//! bytes: the same file under another name is caught, an edited copy (even a whitespace change) is not.

use super::sources::LensSource;
use crate::error::{DatasetError, Result};
use crate::folder::Dataset;
use std::collections::BTreeMap;

/// How many of the offending lenses an error names.
const NAMED_IN_ERROR: usize = 5;

/// Refuses the build when a source is a training or validation lens of `seen_by`.
pub fn refuse_seen_lenses(sources: &[LensSource], seen_by: &Dataset) -> Result<()> {
    let bad = |why: String| DatasetError::setting("unseen_by", format!("{}: {why}", seen_by.dir.display()));
    let seen: BTreeMap<String, String> = seen_by
        .lenses()
        .map_err(|e| bad(e.to_string()))?
        .into_iter()
        .filter(|row| row.split != "test")
        .map(|row| (row.lens_sha256, format!("{} lens {}", row.split, row.lens_id)))
        .collect();
    let shared: Vec<String> = sources
        .iter()
        .filter_map(|source| {
            seen.get(&source.sha256)
                .map(|there| format!("{} (its {there})", source.source))
        })
        .collect();
    if shared.is_empty() {
        return Ok(());
    }
    let more = shared.len().saturating_sub(NAMED_IN_ERROR);
    let named = shared[..shared.len().min(NAMED_IN_ERROR)].join(", ");
    let tail = if more > 0 {
        format!(" and {more} more")
    } else {
        String::new()
    };
    Err(bad(format!(
        "{} of the {} lenses given are lenses that dataset trained or validated on: {named}{tail}; models trained there have seen them (design the library with another seed, or leave them out)",
        shared.len(),
        sources.len()
    )))
}
