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
        // What decodes re-encodes to an entry that decodes to the same kernels. Not to the same bytes:
        // the JSON header of a valid entry need not be canonical (`1205` and `1205.0` are one number;
        // an earlier byte-length assertion here fired on exactly that, a harness error, not a defect).
        let again = PsfCache::decode_entry(&PsfCache::encode_entry(&psfs)).expect("a re-encoded entry decodes");
        assert_eq!(again.len(), psfs.len());
        for (a, b) in again.iter().zip(&psfs) {
            assert_eq!(a.kernels.len(), b.kernels.len());
            for (ka, kb) in a.kernels.iter().zip(&b.kernels) {
                assert_eq!((ka.size, &ka.data), (kb.size, &kb.data));
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    check(data);
    let mut entry = data.to_vec();
    let checksum = Sha256::digest(data);
    entry.extend(checksum);
    check(&entry);
});
