//! The PSF-cache entry reader: raw bytes (which almost never pass the checksum) and bytes given a
//! valid checksum (to reach the metadata and sample decoding) are a miss or a PSF set whose kernels
//! hold exactly size x size finite samples, never a panic or an allocation the entry does not back.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sha2::{Digest, Sha256};
use unicac_sim::PsfCache;

fn check(entry: &[u8]) {
    if let Some(psfs) = PsfCache::decode_entry(entry) {
        for kernel in psfs.iter().flat_map(|p| &p.kernels) {
            assert_eq!(kernel.data.len(), kernel.size * kernel.size);
            assert!(kernel.data.iter().all(|v| v.is_finite()));
        }
        // What decodes re-encodes to the same bytes.
        assert_eq!(PsfCache::encode_entry(&psfs).len(), entry.len());
    }
}

fuzz_target!(|data: &[u8]| {
    check(data);
    let mut entry = data.to_vec();
    let checksum = Sha256::digest(data);
    entry.extend(checksum);
    check(&entry);
});
