//! Atomic writes and the clean-up of what killed runs left behind.
//!
//! A temporary is `.{file name}.tmp-{pid}-{n}-h{host}.{extension}` next to its target: dot-named
//! (hidden from globs such as `*.png`), carrying the writer's process id and a hash of its host name
//! (so a later or concurrent run, on this machine or another one sharing the folder, can tell a live
//! writer's file from debris) and ending in the target's extension (encoders that pick their format
//! from the name, such as the plotters bitmap backend, see the right one).
//!
//! Clean-up never removes a live writer's temporary: concurrent shards of one dataset build write into
//! one folder, and each starts by cleaning it (removing another shard's temporary made its rename
//! fail). A temporary from another host is removed only when older than [`STALE_TEMPORARY_AGE`],
//! since its writer's liveness cannot be checked from here.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, SystemTime};

/// The marker between a target's name and the writer's process id.
const TEMPORARY_MARKER: &str = ".tmp-";

/// Temporaries of a writer whose liveness cannot be checked are removed after this long.
pub const STALE_TEMPORARY_AGE: Duration = Duration::from_secs(3600);

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The temporary sibling a write of `path` goes through (unique within this process).
pub fn temporary_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let extension = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(
        ".{name}{TEMPORARY_MARKER}{}-{n}-h{:08x}{extension}",
        std::process::id(),
        this_host()
    ))
}

/// A 32-bit FNV-1a hash of this machine's host name (0 where it cannot be read), read once per
/// process (every temporary's name carries it).
fn this_host() -> u32 {
    static HOST: OnceLock<u32> = OnceLock::new();
    *HOST.get_or_init(|| {
        let name = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .or_else(|_| std::env::var("HOSTNAME"))
            .unwrap_or_default();
        name.trim().bytes().fold(0x811c_9dc5_u32, |h, b| {
            (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
        })
    })
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_with(path, |file| file.write_all(bytes))
}

/// Writes `path` atomically, only if no file is there yet: an exclusive claim. The bytes go to a
/// temporary sibling, which is then hard-linked to `path`; the link fails with `AlreadyExists` when
/// another writer got there first, so of two processes racing for one path exactly one wins, and
/// nobody ever reads the file half-written. The temporary is removed either way.
pub fn write_new_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let temporary = temporary_sibling(path);
    let result = File::create(&temporary)
        .and_then(|mut file| {
            file.write_all(bytes)?;
            file.sync_all()
        })
        .and_then(|()| std::fs::hard_link(&temporary, path));
    let _ = std::fs::remove_file(&temporary);
    result
}

/// Writes `path` atomically with whatever `fill` writes into the (buffered, seekable) temporary file.
/// On any error the temporary is removed and the target is left as it was.
pub fn write_with<E>(path: &Path, fill: impl FnOnce(&mut BufWriter<File>) -> Result<(), E>) -> Result<(), E>
where
    E: From<std::io::Error>,
{
    write_via_path(path, |temporary| {
        let mut sink = BufWriter::new(File::create(temporary)?);
        fill(&mut sink)?;
        let file = sink.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        Ok(())
    })
}

/// Writes `path` atomically through an encoder that wants a file name: `create` writes the temporary
/// path it is given (same folder and extension as `path`); it is then renamed over `path`.
pub fn write_via_path<E>(path: &Path, create: impl FnOnce(&Path) -> Result<(), E>) -> Result<(), E>
where
    E: From<std::io::Error>,
{
    let temporary = temporary_sibling(path);
    let result = create(&temporary).and_then(|()| Ok(std::fs::rename(&temporary, path)?));
    if result.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    result
}

/// Whether `name` is one of this module's temporaries (or the older `.name.tmp-PID` form).
pub fn is_temporary_name(name: &str) -> bool {
    name.starts_with('.') && writer_pid(name).is_some()
}

/// The process id a temporary's name carries.
fn writer_pid(name: &str) -> Option<u32> {
    let after = &name[name.rfind(TEMPORARY_MARKER)? + TEMPORARY_MARKER.len()..];
    let digits: String = after.chars().take_while(char::is_ascii_digit).collect();
    digits.parse().ok()
}

/// The writer's host hash a temporary's name carries (`None` in the older forms without one).
fn writer_host(name: &str) -> Option<u32> {
    let after = &name[name.rfind(TEMPORARY_MARKER)? + TEMPORARY_MARKER.len()..];
    let host = after.split('-').nth(2)?.strip_prefix('h')?;
    u32::from_str_radix(host.get(..8)?, 16).ok()
}

/// Whether process `pid` is alive: `/proc` on Linux; elsewhere unknown (`None`).
fn process_alive(pid: u32) -> Option<bool> {
    let proc_root = Path::new("/proc");
    proc_root
        .join("self")
        .exists()
        .then(|| proc_root.join(pid.to_string()).exists())
}

/// Removes the temporaries in `dir` whose writer is gone (or, where that cannot be told, that are
/// older than [`STALE_TEMPORARY_AGE`]). Returns the files removed. A missing folder is not an error.
pub fn clean_stale_temporaries(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    clean(dir, false)
}

/// [`clean_stale_temporaries`] in `root` and every folder below it (symbolic links not followed).
pub fn clean_stale_temporaries_under(root: &Path) -> std::io::Result<Vec<PathBuf>> {
    clean(root, true)
}

/// One listing per folder: stale temporaries removed, sub-folders visited when `recurse`.
fn clean(root: &Path, recurse: bool) -> std::io::Result<Vec<PathBuf>> {
    let mut removed = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let entries = match std::fs::read_dir(&dir) {
            Ok(entries) => entries,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        };
        for entry in entries.flatten() {
            let Ok(kind) = entry.file_type() else { continue };
            if kind.is_dir() {
                if recurse {
                    stack.push(entry.path());
                }
            } else if kind.is_file() && is_stale_temporary(&entry) {
                std::fs::remove_file(entry.path())?;
                removed.push(entry.path());
            }
        }
    }
    Ok(removed)
}

/// A temporary whose writer is dead (same host, checked in /proc), or, where that cannot be told (no
/// /proc, another host's writer), one older than [`STALE_TEMPORARY_AGE`].
fn is_stale_temporary(entry: &std::fs::DirEntry) -> bool {
    let name = entry.file_name().to_string_lossy().into_owned();
    if !name.starts_with('.') {
        return false;
    }
    let Some(pid) = writer_pid(&name) else {
        return false;
    };
    let same_host = writer_host(&name).is_none_or(|host| host == this_host());
    match process_alive(pid).filter(|_| same_host) {
        Some(alive) => !alive,
        None => entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| SystemTime::now().duration_since(t).ok())
            .is_some_and(|age| age > STALE_TEMPORARY_AGE),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("unicac-io-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_failed_write_leaves_the_target_and_no_debris() {
        let dir = folder("failed");
        let target = dir.join("a.png");
        std::fs::write(&target, b"old").unwrap();
        let result: std::io::Result<()> = write_with(&target, |sink| {
            sink.write_all(b"half")?;
            Err(std::io::Error::other("encoder failed"))
        });
        assert!(result.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        write_atomically(&target, b"new").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_new_file_is_claimed_once_and_never_replaced() {
        let dir = folder("claim");
        let target = dir.join("claim.json");
        write_new_atomically(&target, b"first").unwrap();
        let second = write_new_atomically(&target, b"second").unwrap_err();
        assert_eq!(second.kind(), std::io::ErrorKind::AlreadyExists);
        assert_eq!(std::fs::read(&target).unwrap(), b"first");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temporaries_keep_the_extension_and_are_dot_named() {
        let t = temporary_sibling(Path::new("out/plot.png"));
        let name = t.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with(".plot.png.tmp-") && name.ends_with(".png"),
            "{name}"
        );
        assert!(is_temporary_name(&name));
        assert!(!is_temporary_name("plot.png"));
        assert!(!is_temporary_name(".hidden"));
    }

    #[test]
    fn debris_of_dead_writers_is_removed_and_live_ones_kept() {
        let dir = folder("clean");
        // A process id above the kernel's maximum (4194304) is never alive.
        let dead = dir.join(".manifest.csv.tmp-4294967");
        let dead_new_form = dir.join(".a.png.tmp-4294967-3.png");
        let live = dir.join(format!(".b.png.tmp-{}-0.png", std::process::id()));
        let ordinary = dir.join("c.png");
        for path in [&dead, &dead_new_form, &live, &ordinary] {
            std::fs::write(path, b"x").unwrap();
        }
        let mut removed = clean_stale_temporaries(&dir).unwrap();
        removed.sort();
        let mut expected = vec![dead.clone(), dead_new_form.clone()];
        expected.sort();
        if Path::new("/proc/self").exists() {
            assert_eq!(removed, expected);
            assert!(live.exists() && ordinary.exists());
        }
        assert!(clean_stale_temporaries(&dir.join("absent")).unwrap().is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_live_writers_temporary_survives_cleaning_from_another_process_view() {
        // What a concurrent shard sees: this process's in-flight temporary, one folder down.
        let dir = folder("nested");
        let target = dir.join("edges").join("lq").join("a.png");
        std::fs::create_dir_all(target.parent().unwrap()).unwrap();
        let temporary = temporary_sibling(&target);
        std::fs::write(&temporary, b"x").unwrap();
        let dead = target.with_file_name(format!(".b.png.tmp-4294967-0-h{:08x}.png", this_host()));
        let other_host = target.with_file_name(".c.png.tmp-4294967-0-h00000000.png");
        std::fs::write(&dead, b"x").unwrap();
        std::fs::write(&other_host, b"x").unwrap();
        let removed = clean_stale_temporaries_under(&dir).unwrap();
        if Path::new("/proc/self").exists() && this_host() != 0 {
            assert_eq!(removed, vec![dead]);
            assert!(temporary.exists(), "a live writer's temporary was removed");
            assert!(
                other_host.exists(),
                "a fresh temporary of another host was removed"
            );
        }
        std::fs::rename(&temporary, &target).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
