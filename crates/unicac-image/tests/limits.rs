//! Issue 28: image files are read within stated limits. A path that is not a regular file is refused
//! before it is opened; a file's declared size is checked before anything is decoded.

use std::path::Path;
use std::time::{Duration, Instant};
use unicac_image::io::{decode_image, read_image, MAX_DECODED_SAMPLES};

/// CRC-32 (ISO-HDLC, as PNG uses) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A PNG declaring `width` x `height` 8-bit RGB pixels whose image data is an empty zlib stream (the
/// decoder reads up to the first IDAT chunk before it reports the header's size).
fn png_without_pixels(width: u32, height: u32) -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        png.extend((data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend(data);
        png.extend(&body);
        png.extend(crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(b"IEND", &[]);
    png
}

/// 10000 x 9000 RGB is 2.7e8 samples, just past MAX_DECODED_SAMPLES (2^28) but inside the `image`
/// crate's own limit (270 MB as 8-bit): before, the decoder went ahead (and the f32 copies took 2 GiB).
#[test]
fn a_png_declaring_more_samples_than_the_limit_is_refused_from_its_header() {
    const { assert!(10_000 * 9_000 * 3 > MAX_DECODED_SAMPLES) };
    let start = Instant::now();
    let error = decode_image(Path::new("big.png"), &png_without_pixels(10_000, 9_000))
        .unwrap_err()
        .to_string();
    assert!(start.elapsed() < Duration::from_secs(2), "{:?}", start.elapsed());
    assert!(
        error.starts_with("big.png: ")
            && error.contains("10000 x 9000 px x 3 channels")
            && error.contains("MAX_DECODED_SAMPLES"),
        "{error}"
    );
    // Within the limit the header passes, and the missing image data is the error.
    let error = decode_image(Path::new("small.png"), &png_without_pixels(100, 100))
        .unwrap_err()
        .to_string();
    assert!(!error.contains("MAX_DECODED_SAMPLES"), "{error}");
}

#[test]
fn devices_fifos_and_folders_are_refused_without_reading() {
    let start = Instant::now();
    let error = read_image("/dev/zero").unwrap_err().to_string();
    assert!(
        error.starts_with("/dev/zero: ") && error.contains("not a regular file (a character device)"),
        "{error}"
    );
    let dir = tempfile::tempdir().unwrap();
    let error = read_image(dir.path()).unwrap_err().to_string();
    assert!(error.contains("a folder"), "{error}");
    let fifo = dir.path().join("pipe.png");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        // Opening a FIFO without a writer blocks forever: refused from its type instead.
        let error = read_image(&fifo).unwrap_err().to_string();
        assert!(error.contains("a FIFO"), "{error}");
    }
    assert!(start.elapsed() < Duration::from_secs(2), "{:?}", start.elapsed());
}
