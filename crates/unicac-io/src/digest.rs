//! The one SHA-256 of unicac: file hashes in manifests, cache keys and derived seeds.
//!
//! A key made of several parts hashes each part with its length in front (`Digest::part`), so no two
//! part lists collide ("ab" + "c" differs from "a" + "bc"); fixed tags and versions may go in raw
//! (`Digest::raw`). The rules of each existing key (which parts, prefixed or raw) are part of its
//! format: a change there is a cache miss or a different dataset, so callers keep theirs.

use serde::Serialize;
use sha2::{Digest as _, Sha256};

/// Lower-case hex of bytes.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 of bytes.
pub fn sha256(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// Hex SHA-256 of bytes (what `sha256sum` prints).
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&sha256(bytes))
}

/// The canonical bytes of a value for a key: its JSON, fields by name in declaration order and every
/// f64 in its shortest round-trip form, so two values share them only if every serialised field is
/// equal, and renaming a field is a miss rather than an alias (what a key built from `Debug` text could
/// not promise: a hand-written `Debug` may leave fields out). Keyed values are validated first: JSON
/// writes a non-finite number as `null`.
pub fn canonical_json(value: &impl Serialize) -> Vec<u8> {
    serde_json::to_vec(value).expect("keyed values are plain data (no maps with non-string keys)")
}

/// Hex SHA-256 of a value's canonical bytes (`canonical_json`).
pub fn canonical_sha256_hex(value: &impl Serialize) -> String {
    sha256_hex(&canonical_json(value))
}

/// A SHA-256 fed part by part.
#[derive(Clone, Default)]
pub struct Digest(Sha256);

impl Digest {
    pub fn new() -> Digest {
        Digest(Sha256::new())
    }

    /// Bytes as they are (a fixed tag, a version).
    pub fn raw(mut self, bytes: &[u8]) -> Digest {
        self.0.update(bytes);
        self
    }

    /// One part of a list, its length (u64, little-endian) first.
    pub fn part(mut self, bytes: &[u8]) -> Digest {
        self.0.update((bytes.len() as u64).to_le_bytes());
        self.0.update(bytes);
        self
    }

    /// Every part of a list (`part` each).
    pub fn parts(self, parts: &[&[u8]]) -> Digest {
        parts.iter().fold(self, |d, p| d.part(p))
    }

    pub fn bytes(self) -> [u8; 32] {
        self.0.finalize().into()
    }

    pub fn hex(self) -> String {
        hex(&self.bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plain_hash_is_sha256sums() {
        // FIPS 180-2 test vector.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(Digest::new().raw(b"a").raw(b"bc").hex(), sha256_hex(b"abc"));
    }

    #[test]
    fn parts_are_length_prefixed_so_lists_do_not_collide() {
        let a = Digest::new().parts(&[b"ab", b"c"]).hex();
        assert_ne!(a, Digest::new().parts(&[b"a", b"bc"]).hex());
        let mut manual = 2u64.to_le_bytes().to_vec();
        manual.extend(b"ab");
        manual.extend(1u64.to_le_bytes());
        manual.extend(b"c");
        assert_eq!(a, sha256_hex(&manual));
    }

    #[derive(Serialize)]
    struct Settings {
        pixel_um: f64,
        rays: usize,
    }

    #[test]
    fn canonical_bytes_name_every_field_and_keep_every_digit() {
        let a = Settings {
            pixel_um: 0.1 + 0.2,
            rays: 2048,
        };
        assert_eq!(
            canonical_json(&a),
            br#"{"pixel_um":0.30000000000000004,"rays":2048}"#.to_vec()
        );
        // One unit in the last place is another key.
        let b = Settings { pixel_um: 0.3, ..a };
        assert_ne!(canonical_sha256_hex(&a), canonical_sha256_hex(&b));
    }
}
