//! The unicac lens JSON format (docs/lens-format.md, schema in docs/lens-format.schema.json).

use crate::error::{OpticsError, Result};
use crate::spec::LensSpec;
use std::path::Path;

/// Parses a lens JSON document; errors carry the file, line and column.
pub fn parse(bytes: &[u8], path: &Path) -> Result<LensSpec> {
    serde_json::from_slice(bytes).map_err(|e| OpticsError::Parse {
        path: path.to_path_buf(),
        location: format!("{}:{}", e.line(), e.column()),
        message: e
            .to_string()
            .split(" at line ")
            .next()
            .unwrap_or_default()
            .to_string(),
    })
}

/// Pretty-printed JSON; floats are written in their shortest exact form, so reading back is lossless.
pub fn to_string(spec: &LensSpec) -> String {
    let mut text = serde_json::to_string_pretty(spec).expect("a LensSpec always serialises");
    text.push('\n');
    text
}
