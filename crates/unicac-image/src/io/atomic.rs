//! Atomic file output: encode into a uniquely named temporary file in the target's folder, flush and sync
//! it, then rename it over the target (POSIX `rename(2)` is atomic within one file system). On any error
//! the temporary file is removed, so a failed write leaves neither a half-written target nor debris.
//!
//! Uses `tempfile` for the unique name and the remove-on-drop guard (safe against concurrent writers in
//! other threads and processes, and against panics inside an encoder).

use crate::error::{ImageError, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// The buffered, seekable writer an encoder writes into (TIFF and OpenEXR encoders need `Seek`).
pub(crate) type Sink<'a> = BufWriter<&'a mut File>;

/// Writes `path` atomically with the bytes `encode` produces; `encode` reports failures as a message that
/// becomes [`ImageError::Encode`] for `format`.
pub(crate) fn write_atomically(
    path: &Path,
    format: &'static str,
    encode: impl FnOnce(&mut Sink<'_>) -> std::result::Result<(), String>,
) -> Result<()> {
    let io_error = |source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    };
    let folder = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = format!(".{file_name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // tempfile's default is 0600; an image is an ordinary file (the umask still applies).
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut temporary = builder.tempfile_in(folder).map_err(io_error)?;
    {
        let mut sink = BufWriter::new(temporary.as_file_mut());
        encode(&mut sink).map_err(|message| ImageError::Encode {
            path: path.to_path_buf(),
            format,
            message,
        })?;
        sink.flush().map_err(io_error)?;
    }
    temporary.as_file().sync_all().map_err(io_error)?;
    temporary.persist(path).map_err(|e| io_error(e.error))?;
    Ok(())
}
