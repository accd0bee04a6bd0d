//! Inputs found by the fuzz targets (`fuzz/`, docs/reliability.md), kept as ordinary tests.

use std::path::Path;
use std::time::{Duration, Instant};

/// `image` target: a 1.5 kB OpenEXR whose header declares a huge layer made the decoder fill
/// gigabytes (timeout after 11 s in the fuzzer). Now refused from the header, at once.
#[test]
fn an_exr_header_declaring_a_huge_layer_is_refused_before_decoding() {
    let bytes = include_bytes!("fuzz_regressions/exr_huge_layer.exr");
    let start = Instant::now();
    let error = unicac_image::io::decode_image(Path::new("huge.exr"), bytes)
        .unwrap_err()
        .to_string();
    assert!(start.elapsed() < Duration::from_secs(2), "{:?}", start.elapsed());
    assert!(error.starts_with("huge.exr: "), "{error}");
}

/// `image` target (2026-12-02, after 4.3 M executions): a 16 x 16 palette PNG whose PLTE chunk holds
/// 461 bytes (not a multiple of 3) made the `png` crate panic ("range end index 3 out of range for
/// slice of length 2"). Now an error naming the file and the chunk.
#[test]
fn a_png_palette_of_a_partial_entry_is_an_error_not_a_panic() {
    let bytes = include_bytes!("fuzz_regressions/png_palette_not_multiple_of_3.png");
    let error = unicac_image::io::decode_image(Path::new("palette.png"), bytes)
        .unwrap_err()
        .to_string();
    assert!(error.starts_with("palette.png: "), "{error}");
    assert!(error.contains("(PLTE chunk) has 461 bytes"), "{error}");
}
