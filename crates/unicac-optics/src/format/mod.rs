//! Lens file formats: the unicac JSON format and Zemax .zmx. Both read into and write from `LensSpec`.

mod breaks;
pub mod json;
pub mod zmx;

use crate::error::{OpticsError, Result};
use crate::lens::Lens;
use crate::spec::LensSpec;
use std::path::Path;

/// A lens file read from disk, with any notes about ignored content (Zemax keywords without optical
/// effect that this reader does not model, named one by one).
#[derive(Debug, Clone)]
pub struct LoadedSpec {
    pub spec: LensSpec,
    pub warnings: Vec<String>,
}

/// Largest lens file read (16 MiB): a lens of a thousand surfaces takes well under 1 MiB in either
/// format, so anything larger is not a lens file, and is refused before it is read.
pub const MAX_LENS_FILE_BYTES: u64 = 16 << 20;

/// Reads a `.json` or `.zmx` lens file into its spec (a regular file of at most
/// [`MAX_LENS_FILE_BYTES`]).
pub fn read_spec(path: &Path) -> Result<LoadedSpec> {
    let bytes =
        unicac_io::read_capped(path, MAX_LENS_FILE_BYTES, "MAX_LENS_FILE_BYTES").map_err(|source| {
            OpticsError::Io {
                path: path.to_path_buf(),
                source,
            }
        })?;
    match extension(path).as_str() {
        "json" => Ok(LoadedSpec {
            spec: json::parse(&bytes, path)?,
            warnings: Vec::new(),
        }),
        "zmx" => zmx::parse(&bytes, path),
        _ => Err(OpticsError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// Writes a spec as `.json` or `.zmx` (by extension), atomically.
pub fn write_spec(spec: &LensSpec, path: &Path) -> Result<()> {
    let text = match extension(path).as_str() {
        "json" => json::to_string(spec),
        "zmx" => {
            // A .zmx GLAS line names the glass; the index error of a built unit would be lost.
            if let Some(i) = spec.surfaces.iter().position(|s| s.index_offset != 0.0) {
                return Err(OpticsError::invalid(
                    format!("surfaces[{i}].index_offset"),
                    format!(
                        "{}: a .zmx file has no form for an index offset; write the lens as .json",
                        path.display()
                    ),
                ));
            }
            zmx::to_string(spec)
        }
        _ => {
            return Err(OpticsError::UnknownFormat {
                path: path.to_path_buf(),
            })
        }
    };
    crate::io::write_atomically(path, text.as_bytes())
}

/// Reads and validates a lens file.
pub fn load_lens(path: &Path) -> Result<(Lens, Vec<String>)> {
    let loaded = read_spec(path)?;
    let lens = Lens::from_spec(&loaded.spec).map_err(|e| match e {
        OpticsError::InvalidLens { field, message } => OpticsError::InvalidLens {
            field: format!("{}: {field}", path.display()),
            message,
        },
        other => other,
    })?;
    Ok((lens, loaded.warnings))
}

fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}
