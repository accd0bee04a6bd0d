//! Reading an input file whole, within a stated size. A path that is not a regular file is refused
//! before it is opened: `/dev/zero` never ends, `/dev/stdin` or a FIFO may block forever, and a folder
//! has no bytes; a file beyond the limit is refused from its size, before any allocation.

use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// The whole of the regular file `path` when it holds at most `max_bytes` bytes; `limit` names the
/// limit in the message (e.g. `MAX_LENS_FILE_BYTES`). Errors say what the path is or how large it is;
/// the caller adds the path.
pub fn read_capped(path: &Path, max_bytes: u64, limit: &str) -> std::io::Result<Vec<u8>> {
    let kind = std::fs::metadata(path)?.file_type();
    if !kind.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("not a regular file ({}); give a file", describe(kind)),
        ));
    }
    let file = std::fs::File::open(path)?;
    // Checked again on the open file: the path may have changed since.
    let metadata = file.metadata()?;
    let too_large = |bytes: u64| {
        Error::new(
            ErrorKind::InvalidData,
            format!("{bytes} bytes or more, beyond the limit of {max_bytes} bytes ({limit})"),
        )
    };
    if !metadata.is_file() {
        return Err(Error::new(ErrorKind::InvalidInput, "not a regular file"));
    }
    if metadata.len() > max_bytes {
        return Err(too_large(metadata.len()));
    }
    let mut bytes = Vec::with_capacity(metadata.len() as usize);
    file.take(max_bytes.saturating_add(1)).read_to_end(&mut bytes)?;
    // A file that grew while it was read.
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

fn describe(kind: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_char_device() {
            return "a character device";
        }
        if kind.is_block_device() {
            return "a block device";
        }
        if kind.is_fifo() {
            return "a FIFO";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    if kind.is_dir() {
        "a folder"
    } else {
        "not a file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_folders_and_oversized_files_are_refused_before_reading() {
        let dir = std::env::temp_dir().join(format!("unicac-io-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let message = |path: &Path, max: u64| read_capped(path, max, "MAX_TEST").unwrap_err().to_string();
        #[cfg(unix)]
        assert!(message(Path::new("/dev/zero"), 10).contains("a character device"));
        assert!(message(&dir, 10).contains("a folder"));
        let file = dir.join("f.txt");
        std::fs::write(&file, b"0123456789").unwrap();
        assert_eq!(read_capped(&file, 10, "MAX_TEST").unwrap(), b"0123456789");
        assert_eq!(
            message(&file, 9),
            "10 bytes or more, beyond the limit of 9 bytes (MAX_TEST)"
        );
        #[cfg(unix)]
        {
            // A FIFO without a writer would block `open` forever: refused from its type.
            let fifo = dir.join("fifo");
            let _ = std::fs::remove_file(&fifo);
            let made = std::process::Command::new("mkfifo").arg(&fifo).status();
            if made.is_ok_and(|s| s.success()) {
                assert!(message(&fifo, 10).contains("a FIFO"));
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
