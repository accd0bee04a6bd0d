//! Resolving a LENS argument: a `.json`/`.zmx` path or `builtin:NAME`. Reader warnings go to stderr.

use anyhow::Result;
use std::path::Path;
pub use unicac_optics::builtin::BUILTIN_PREFIX;
use unicac_optics::{builtin, Lens, LensSpec};

pub fn load_spec(argument: &str) -> Result<LensSpec> {
    let loaded = builtin::resolve_spec(Path::new(argument))?;
    for warning in &loaded.warnings {
        eprintln!("warning: {argument}: {warning}");
    }
    Ok(loaded.spec)
}

pub fn load_lens(argument: &str) -> Result<Lens> {
    let spec = load_spec(argument)?;
    Lens::from_spec(&spec).map_err(|e| anyhow::anyhow!("{argument}: {e}"))
}
