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

/// `image` target under AddressSanitizer (2026-12-04): a 1,389-byte B44 OpenEXR declaring a
/// 16,187,408 x 1 px, 4-channel layer (65 M samples, inside `MAX_DECODED_SAMPLES`) took the release CLI
/// to 1.99 GB before the `exr` crate failed. B44 stores at least 3 bytes per 32 of f16 pixels, so the
/// header is refused from the file's size, before any pixel is decoded.
#[test]
fn an_exr_declaring_more_pixels_than_its_compression_can_store_is_refused_from_the_header() {
    let bytes = include_bytes!("fuzz_regressions/exr_b44_declares_more_than_the_file_holds.exr");
    let error = unicac_image::io::decode_image(Path::new("b44.exr"), bytes)
        .unwrap_err()
        .to_string();
    assert!(error.starts_with("b44.exr: "), "{error}");
    assert!(error.contains("16187408 x 1 px"), "{error}");
    assert!(error.contains("1389-byte file"), "{error}");
    assert!(error.contains("b44"), "{error}");
}

/// The bound above never refuses a real file: a constant 2048 x 2048 image is the most a ZIP-compressed
/// OpenEXR shrinks (deflate's runs), and it reads back whole.
#[test]
fn the_most_compressible_exr_still_reads() {
    let dir = std::env::temp_dir().join(format!("unicac-exr-flat-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("flat.exr");
    let mut flat = unicac_image::Planar::new(2048, 2048, 1);
    flat.plane_mut(0).fill(0.25);
    unicac_image::io::write_exr(&path, &flat).unwrap();
    let file_bytes = std::fs::metadata(&path).unwrap().len();
    let read = unicac_image::io::read_image(&path).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        file_bytes < 64 * 1024,
        "{file_bytes} bytes: the test needs a highly compressed file"
    );
    assert_eq!((read.image.width, read.image.height), (2048, 2048));
    assert!(read.image.plane(0).iter().all(|&v| v == 0.25));
}

/// `image` target under AddressSanitizer (2026-12-05, the first inputs after the bound above): a
/// 221-byte OpenEXR whose channel declares a sampling of 0 made the bound's size computation divide by
/// zero (a panic inside the `exr` crate's `subsampled_resolution`). Now an error naming the file.
#[test]
fn an_exr_channel_sampled_every_zero_pixels_is_an_error_not_a_panic() {
    let bytes = include_bytes!("fuzz_regressions/exr_channel_sampling_zero.exr");
    let error = unicac_image::io::decode_image(Path::new("sampling.exr"), bytes)
        .unwrap_err()
        .to_string();
    assert!(error.starts_with("sampling.exr: "), "{error}");
    assert!(error.contains("declares a sampling of"), "{error}");
}
