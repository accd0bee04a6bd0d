//! The CLI side of the output-file policy (`unicac_io`): each command lists its inputs and outputs in
//! an `OutputPlan` and checks it before any work; this module only adds what every command shares.

use crate::lens_input::BUILTIN_PREFIX;
use anyhow::Result;
use std::path::Path;
use unicac_io::{require_extension, OutputPlan};

/// Extensions of pictures (unicac-plot picks PNG or SVG by the name).
pub const PICTURE_EXTENSIONS: &[&str] = &["png", "svg"];

/// A plan whose inputs hold the lens file (a `builtin:` lens has none).
pub fn plan(lens: Option<&str>) -> OutputPlan {
    let mut plan = OutputPlan::new();
    if let Some(lens) = lens.filter(|l| !l.starts_with(BUILTIN_PREFIX)) {
        plan.input(lens);
    }
    plan
}

/// Adds an optional picture output after checking its extension.
pub fn picture(plan: &mut OutputPlan, flag: &str, path: Option<&Path>) -> Result<()> {
    if let Some(path) = path {
        require_extension(flag, path, PICTURE_EXTENSIONS)?;
        plan.output(flag, path);
    }
    Ok(())
}

/// The common case: a command that reads a lens and may write one picture.
pub fn check_lens_and_picture(lens: &str, flag: &str, path: Option<&Path>) -> Result<()> {
    let mut plan = plan(Some(lens));
    picture(&mut plan, flag, path)?;
    plan.check()?;
    Ok(())
}
