//! Writing files so that a reader never sees a half-written output: the one implementation is
//! `unicac_io::write_atomically` (temporary sibling, synced, renamed); this wraps its error.

use crate::error::{OpticsError, Result};
use std::path::Path;

pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    unicac_io::write_atomically(path, bytes).map_err(|source| OpticsError::Io {
        path: path.to_path_buf(),
        source,
    })
}
