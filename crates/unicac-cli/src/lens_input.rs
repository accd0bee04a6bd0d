//! Resolving a LENS argument: a `.json`/`.zmx` path or `builtin:NAME`. Reader warnings go to stderr.

use anyhow::Result;
use std::path::Path;
use unicac_optics::{examples, format, Lens, LensSpec};

pub const BUILTIN_PREFIX: &str = "builtin:";

pub fn load_spec(argument: &str) -> Result<LensSpec> {
    if let Some(name) = argument.strip_prefix(BUILTIN_PREFIX) {
        return Ok(examples::spec(name)?);
    }
    let loaded = format::read_spec(Path::new(argument))?;
    for warning in &loaded.warnings {
        eprintln!("warning: {argument}: {warning}");
    }
    Ok(loaded.spec)
}

pub fn load_lens(argument: &str) -> Result<Lens> {
    let spec = load_spec(argument)?;
    Lens::from_spec(&spec).map_err(|e| anyhow::anyhow!("{argument}: {e}"))
}
