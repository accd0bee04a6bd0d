//! Inputs found by the fuzz targets (`fuzz/`, docs/reliability.md), kept as ordinary tests.

use std::path::Path;
use std::time::{Duration, Instant};

/// `image` target: a 1.5 kB OpenEXR whose header declares a huge layer made the decoder fill
/// gigabytes (timeout after 11 s in the fuzzer). Now refused from the header, at once.
#[test]
fn an_exr_header_declaring_a_huge_layer_is_refused_before_decoding() {
    let bytes = include_bytes!("fuzz_regressions/exr_huge_layer.exr");
    let start = Instant::now();
    let error = unicac_image::io::decode_image(Path::new("huge.exr"), bytes).unwrap_err().to_string();
    assert!(start.elapsed() < Duration::from_secs(2), "{:?}", start.elapsed());
    assert!(error.starts_with("huge.exr: "), "{error}");
}
