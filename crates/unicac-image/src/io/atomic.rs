//! Atomic file output through the one implementation, `unicac_io::write_with`: encode into a dot-named
//! temporary sibling, flush and sync it, then rename it over the target. On any error the temporary is
//! removed, so a failed write leaves neither a half-written target nor debris.

use crate::error::{ImageError, Result};
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// The buffered, seekable writer an encoder writes into (TIFF and OpenEXR encoders need `Seek`).
pub(crate) type Sink = BufWriter<File>;

/// Why an atomic write failed: the encoder's message, or the file system.
enum Failure {
    Encode(String),
    Io(std::io::Error),
}

impl From<std::io::Error> for Failure {
    fn from(error: std::io::Error) -> Self {
        Failure::Io(error)
    }
}

/// Writes `path` atomically with the bytes `encode` produces; `encode` reports failures as a message that
/// becomes [`ImageError::Encode`] for `format`.
pub(crate) fn write_atomically(
    path: &Path,
    format: &'static str,
    encode: impl FnOnce(&mut Sink) -> std::result::Result<(), String>,
) -> Result<()> {
    unicac_io::write_with(path, |sink| encode(sink).map_err(Failure::Encode)).map_err(|failure| match failure {
        Failure::Encode(message) => ImageError::Encode {
            path: path.to_path_buf(),
            format,
            message,
        },
        Failure::Io(source) => ImageError::Io {
            path: path.to_path_buf(),
            source,
        },
    })
}
