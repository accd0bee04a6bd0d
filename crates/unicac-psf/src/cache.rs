//! On-disk cache of traced PSFs, so that a second run over the same lens, sensor and settings loads
//! them instead of tracing again.
//!
//! Key: SHA-256 over everything the PSFs depend on (the validated lens model, the sensor pitch, the
//! PSF settings, the wavelengths and camera curves, the field points), plus the cache format and the
//! unicac version, so a change to any of them, or to the code, is a miss rather than a stale hit.
//! The lens enters through `lens_fingerprint`: the model's canonical serialised form
//! (`unicac_io::digest::canonical_json`: every field by name, every f64 in its shortest round-trip
//! form, catalogue glasses with their dispersion coefficients), so two lenses share a fingerprint only
//! if every number that reaches the tracer is equal; the settings enter the same way.
//!
//! File: `<dir>/<key>.psf`: a magic line, the JSON metadata of the PSFs (length-prefixed), then every
//! kernel's samples as little-endian f32 in order, then the SHA-256 of everything before it. Written
//! to a temporary file and renamed, so a crash never leaves a half-written entry; an entry that is
//! unreadable, fails its checksum (a flipped bit on disk, an edited file) or holds non-finite samples
//! is a miss, never an error and never a silently different PSF: the next store replaces it.

use crate::geometric::FieldPsf;
use std::path::{Path, PathBuf};
use unicac_io::digest::{canonical_sha256_hex, sha256, Digest};
use unicac_optics::Lens;

const MAGIC: &[u8] = b"unicac-psf-cache 2\n";

/// Bytes of the trailing content checksum (SHA-256).
const CHECKSUM_BYTES: usize = 32;

/// A directory of cached PSF sets.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PsfCache {
    pub dir: PathBuf,
}

/// A hex SHA-256 of the lens model (see the module docs); also written into PSF metadata as provenance.
pub fn lens_fingerprint(lens: &Lens) -> String {
    canonical_sha256_hex(lens)
}

/// unicac's cache folder (PSFs, converted metric weights): `$UNICAC_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/unicac`, else `$HOME/.cache/unicac`; `None` when none of them is set.
pub fn cache_root() -> Option<PathBuf> {
    let from = |name: &str| {
        std::env::var_os(name)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    from("UNICAC_CACHE_DIR")
        .or_else(|| from("XDG_CACHE_HOME").map(|d| d.join("unicac")))
        .or_else(|| from("HOME").map(|d| d.join(".cache").join("unicac")))
}

impl PsfCache {
    pub fn new(dir: impl Into<PathBuf>) -> PsfCache {
        PsfCache { dir: dir.into() }
    }

    /// The PSF cache in [`cache_root`].
    pub fn default_location() -> Option<PsfCache> {
        cache_root().map(PsfCache::new)
    }

    /// The key of a PSF set: each part is length-prefixed so that no two part lists collide.
    pub fn key(parts: &[&[u8]]) -> String {
        Digest::new()
            .raw(MAGIC)
            .raw(env!("CARGO_PKG_VERSION").as_bytes())
            .parts(parts)
            .hex()
    }

    fn path(&self, key: &str) -> PathBuf {
        self.dir.join(format!("{key}.psf"))
    }

    /// The cached PSFs under `key`, or `None` on a miss (absent, unreadable or corrupt).
    pub fn load(&self, key: &str) -> Option<Vec<FieldPsf>> {
        decode(&std::fs::read(self.path(key)).ok()?)
    }

    /// Decodes the bytes of a cache entry (`None` when corrupt); public for the fuzzer.
    pub fn decode_entry(bytes: &[u8]) -> Option<Vec<FieldPsf>> {
        decode(bytes)
    }

    /// The bytes of a cache entry holding `psfs`.
    pub fn encode_entry(psfs: &[FieldPsf]) -> Vec<u8> {
        encode(psfs)
    }

    /// Stores `psfs` under `key` (atomically).
    pub fn store(&self, key: &str, psfs: &[FieldPsf]) -> std::io::Result<()> {
        std::fs::create_dir_all(&self.dir)?;
        write_atomically(&self.path(key), &encode(psfs))
    }
}

fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    unicac_optics::io::write_atomically(path, bytes).map_err(std::io::Error::other)
}

fn encode(psfs: &[FieldPsf]) -> Vec<u8> {
    let metadata = serde_json::to_vec(psfs).expect("PSF metadata serialises");
    let mut bytes = MAGIC.to_vec();
    bytes.extend((metadata.len() as u64).to_le_bytes());
    bytes.extend(metadata);
    for kernel in psfs.iter().flat_map(|p| &p.kernels) {
        bytes.extend(kernel.data.iter().flat_map(|v| v.to_le_bytes()));
    }
    let checksum = sha256(&bytes);
    bytes.extend(checksum);
    bytes
}

fn decode(bytes: &[u8]) -> Option<Vec<FieldPsf>> {
    let (content, checksum) = bytes.split_at_checked(bytes.len().checked_sub(CHECKSUM_BYTES)?)?;
    if sha256(content).as_slice() != checksum {
        return None;
    }
    let rest = content.strip_prefix(MAGIC)?;
    let (length, rest) = rest.split_first_chunk::<8>()?;
    let length = usize::try_from(u64::from_le_bytes(*length)).ok()?;
    let metadata = rest.get(..length)?;
    let mut samples = rest.get(length..)?.chunks_exact(4);
    let mut psfs: Vec<FieldPsf> = serde_json::from_slice(metadata).ok()?;
    for kernel in psfs.iter_mut().flat_map(|p| &mut p.kernels) {
        let count = kernel.size.checked_mul(kernel.size)?;
        // Never allocate more than the entry holds (a corrupt size must not ask for terabytes).
        if count > samples.len() {
            return None;
        }
        kernel.data = (0..count)
            .map(|_| {
                samples
                    .next()
                    .map(|s| f32::from_le_bytes(s.try_into().expect("4 bytes")))
            })
            .collect::<Option<Vec<f32>>>()?;
    }
    let finite = psfs
        .iter()
        .flat_map(|p| &p.kernels)
        .all(|k| k.data.iter().all(|v| v.is_finite()));
    (finite && samples.len() == 0 && samples.remainder().is_empty()).then_some(psfs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::Kernel;

    fn psf(size: usize, value: f32) -> FieldPsf {
        let mut kernel = Kernel::zeros(size, 2.5);
        kernel
            .data
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = value + i as f32);
        FieldPsf {
            field_deg: 12.5,
            field_x_deg: 0.0,
            reference_mm: [0.0, -1.25],
            kernels: vec![kernel.clone(), kernel],
            transmission: 0.75,
            energy_cut: vec![0.0, 0.01],
            rays_traced: 2048,
        }
    }

    #[test]
    fn entries_round_trip_exactly_and_corrupt_ones_are_misses() {
        let dir = std::env::temp_dir().join(format!("unicac-cache-test-{}", std::process::id()));
        let cache = PsfCache::new(&dir);
        let key = PsfCache::key(&[b"lens", b"settings"]);
        let psfs = vec![psf(3, 0.5), psf(5, -1.0)];
        assert!(cache.load(&key).is_none());
        cache.store(&key, &psfs).unwrap();
        let loaded = cache.load(&key).unwrap();
        assert_eq!(loaded.len(), 2);
        for (a, b) in loaded.iter().zip(&psfs) {
            assert_eq!(a.kernels, b.kernels);
            assert_eq!(
                (a.field_deg, a.reference_mm, a.transmission),
                (b.field_deg, b.reference_mm, b.transmission)
            );
            assert_eq!((&a.energy_cut, a.rays_traced), (&b.energy_cut, b.rays_traced));
        }
        // Truncated and padded files are misses, not errors or garbage.
        let path = cache.path(&key);
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        assert!(cache.load(&key).is_none());
        std::fs::write(&path, [bytes.as_slice(), &[0, 0, 0, 0]].concat()).unwrap();
        assert!(cache.load(&key).is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Issue 16: one changed byte anywhere in an entry (here: in every position of a small entry) is a
    /// miss; before the checksum a changed sample byte loaded as a valid, different PSF.
    #[test]
    fn any_changed_byte_is_a_miss() {
        let bytes = encode(&[psf(3, 0.5)]);
        assert!(decode(&bytes).is_some());
        for position in 0..bytes.len() {
            let mut changed = bytes.clone();
            changed[position] ^= 0x01;
            assert!(
                decode(&changed).is_none(),
                "byte {position} changed and still loaded"
            );
        }
        // A kernel size that the samples do not back (with a valid checksum) never allocates it.
        let mut psfs = vec![psf(3, 0.5)];
        psfs[0].kernels[0].size = 1 << 31;
        assert!(decode(&encode(&psfs)).is_none());
    }

    #[test]
    fn keys_separate_their_parts() {
        assert_ne!(PsfCache::key(&[b"ab", b"c"]), PsfCache::key(&[b"a", b"bc"]));
        assert_eq!(PsfCache::key(&[b"ab", b"c"]), PsfCache::key(&[b"ab", b"c"]));
    }
}
