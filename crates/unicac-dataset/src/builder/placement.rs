//! Where the output folder may lie: never inside an input folder (`images`, `test_images`, lens
//! folders, the datasets of `psf_basis_from` and `unseen_by`), where a rerun would scan the dataset it wrote as scenes or lenses, and never around an
//! input (the build would read its own output). Checked with unicac-io's `OutputPlan`, as bench
//! checks its report folder, before any work.

use super::sources::{SceneSource, BUILTIN_PREFIX};
use super::BuildSettings;
use crate::error::{DatasetError, Result};
use std::path::{Path, PathBuf};
use unicac_io::{OutputError, OutputPlan};

/// The inputs of a build that are paths (charts and built-in lenses are not).
fn input_paths(settings: &BuildSettings) -> Vec<PathBuf> {
    let scenes = [&settings.images, &settings.test_images]
        .into_iter()
        .filter_map(|source| match source {
            SceneSource::Path(path) => Some(path.clone()),
            SceneSource::DeadLeaves { .. } => None,
        });
    let lenses = settings
        .lenses
        .iter()
        .filter(|argument| !argument.starts_with(BUILTIN_PREFIX))
        .map(PathBuf::from);
    let datasets = [&settings.psf_basis_from, &settings.unseen_by]
        .into_iter()
        .flatten()
        .cloned();
    scenes.chain(lenses).chain(datasets).collect()
}

/// Refuses an `out` inside an input folder, equal to an input, or holding an input.
pub fn check_output_placement(settings: &BuildSettings, out: &Path) -> Result<()> {
    let inputs = input_paths(settings);
    let mut plan = OutputPlan::new();
    for input in &inputs {
        if input.is_dir() {
            plan.input_folder(input);
        } else {
            plan.input(input);
        }
    }
    plan.output("out", out);
    plan.check().map_err(|e| match e {
        OutputError::InsideInputFolder { output, folder, .. } => DatasetError::setting(
            "out",
            format!(
                "{}: lies inside the input folder {} (a later build would read the dataset as input); choose a path outside it",
                output.display(),
                folder.display()
            ),
        ),
        OutputError::OverwritesInput { output, input, .. } => DatasetError::setting(
            "out",
            format!("{}: is the input {}; choose another folder", output.display(), input.display()),
        ),
        other => DatasetError::setting("out", other.to_string()),
    })?;
    // The other way round: an input inside the output folder would be the build's own output.
    if let Ok(out_folder) = std::fs::canonicalize(out) {
        for input in &inputs {
            if std::fs::canonicalize(input).is_ok_and(|i| i.starts_with(&out_folder)) {
                return Err(DatasetError::setting(
                    "out",
                    format!(
                        "{}: holds the input {}: the build would read its own output; choose another folder",
                        out.display(),
                        input.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}
