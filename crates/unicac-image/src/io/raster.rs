//! PNG and TIFF through the `image` crate (codecs `png` and `tiff` only): decoding to `Planar` and encoding
//! 8/16-bit integer samples (large PNG outputs streamed through the same codec: `png_stream`). The codecs
//! are theirs; this module only maps between their interleaved pixel buffers and planar unit-range f32.

use super::atomic::write_atomically;
use super::{Encoding, FileFormat, LoadedImage, SampleDepth};
use crate::error::{check_layout, ImageError, Result};
use crate::quantise::{from_code, max_code, to_code};
use crate::Planar;
use image::{ExtendedColorType, ImageDecoder, ImageEncoder};
use std::path::Path;

/// The two integer-raster formats this module handles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Raster {
    Png,
    Tiff,
    /// Read only.
    Bmp,
}

impl Raster {
    fn format(self) -> FileFormat {
        match self {
            Raster::Png => FileFormat::Png,
            Raster::Tiff => FileFormat::Tiff,
            Raster::Bmp => FileFormat::Bmp,
        }
    }
}

/// Decodes PNG or TIFF bytes. Integer samples are divided by their maximum code (255 or 65535) and reported
/// as sRGB-encoded; 32-bit float TIFF samples are kept as stored and reported as linear.
pub(super) fn decode(path: &Path, bytes: &[u8], raster: Raster) -> Result<LoadedImage> {
    let format = raster.format();
    let decode_error = |message: String| ImageError::Decode {
        path: path.to_path_buf(),
        format: format.name(),
        message,
    };
    if raster == Raster::Png {
        check_png_palette(bytes).map_err(decode_error)?;
    }
    let codec = match raster {
        Raster::Png => image::ImageFormat::Png,
        Raster::Tiff => image::ImageFormat::Tiff,
        Raster::Bmp => image::ImageFormat::Bmp,
    };
    let decoder = image::ImageReader::with_format(std::io::Cursor::new(bytes), codec)
        .into_decoder()
        .map_err(|e| decode_error(e.to_string()))?;
    // The size the header declares is checked before the decoder allocates for it: the `image`
    // crate's own limit (512 MiB per buffer) admits 8-bit files whose samples take 2 GiB as f32.
    let (declared_w, declared_h) = decoder.dimensions();
    let declared_channels = decoder.color_type().channel_count();
    let samples = u64::from(declared_w) * u64::from(declared_h) * u64::from(declared_channels);
    if samples > super::MAX_DECODED_SAMPLES as u64 {
        return Err(decode_error(format!(
            "the header declares {declared_w} x {declared_h} px x {declared_channels} channels, beyond \
             the limit of {} samples (MAX_DECODED_SAMPLES)",
            super::MAX_DECODED_SAMPLES
        )));
    }
    let decoded = image::DynamicImage::from_decoder(decoder).map_err(|e| decode_error(e.to_string()))?;
    let (width, height) = (decoded.width() as usize, decoded.height() as usize);
    let colour = decoded.color();
    let channels = usize::from(colour.channel_count());
    let names: &[&str] = match channels {
        1 => &["Y"],
        2 => &["Y", "A"],
        3 => &["R", "G", "B"],
        4 => &["R", "G", "B", "A"],
        _ => return Err(decode_error(format!("unsupported sample layout {colour:?}"))),
    };
    // `as_bytes` is the decoded buffer in native endianness, whatever the sample type.
    let raw = decoded.as_bytes();
    let (bit_depth, encoding) = match usize::from(colour.bytes_per_pixel()) / channels {
        1 => (8, Encoding::Srgb),
        2 => (16, Encoding::Srgb),
        4 => (32, Encoding::Linear),
        _ => return Err(decode_error(format!("unsupported sample layout {colour:?}"))),
    };
    let image = deinterleave(raw, width, height, channels, bit_depth);
    let channel_names = names.iter().map(|n| n.to_string()).collect();
    Ok(LoadedImage {
        image,
        format,
        bit_depth,
        encoding,
        channel_names,
    })
}

/// The planes of interleaved native-endian samples (`bit_depth` 8 or 16: integer codes as unit-range
/// values; 32: f32 as stored), row by row in parallel.
fn deinterleave(raw: &[u8], width: usize, height: usize, channels: usize, bit_depth: u8) -> Planar {
    let bytes = usize::from(bit_depth / 8);
    let sample = |index: usize| -> f32 {
        let b = &raw[index * bytes..(index + 1) * bytes];
        match bit_depth {
            8 => from_code(b[0].into(), 255),
            16 => from_code(u16::from_ne_bytes([b[0], b[1]]).into(), 65535),
            _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
        }
    };
    Planar::from_fn_parallel(width, height, channels, |c, x, y| {
        sample((y * width + x) * channels + c)
    })
}

/// Writes `image` (1 = grey, 2 = grey + alpha, 3 = RGB, 4 = RGBA channels; values in [0, 1], clipped) as
/// integer samples of `depth` in PNG or TIFF (uncompressed TIFF, as the `image` encoder writes it).
pub(super) fn encode(path: &Path, image: &Planar, depth: SampleDepth, raster: Raster) -> Result<()> {
    let format = raster.format();
    let encode_error = |message: String| ImageError::Encode {
        path: path.to_path_buf(),
        format: format.name(),
        message,
    };
    check_layout(image, "image", &[1, 2, 3, 4]).map_err(|e| encode_error(e.to_string()))?;
    let too_large = || {
        encode_error(format!(
            "{}x{} exceeds the 32-bit size limit",
            image.width, image.height
        ))
    };
    let width = u32::try_from(image.width).map_err(|_| too_large())?;
    let height = u32::try_from(image.height).map_err(|_| too_large())?;
    if width == 0 || height == 0 {
        return Err(encode_error(format!("{width}x{height} image has no pixels")));
    }
    let bits = match depth {
        SampleDepth::Eight => 8,
        SampleDepth::Sixteen => 16,
    };
    let bytes_per_sample = usize::from(bits / 8);
    let streamed = raster == Raster::Png
        && super::png_stream::worth_streaming(image.pixels() * image.channels * bytes_per_sample);
    // PNG stores 16-bit samples big-endian; the `image` encoders take native-endian ones.
    let bytes = interleaved_codes(image, bits, max_code(bits)?, streamed)
        .ok_or_else(|| encode_error("NaN or infinite sample cannot be stored as an integer".into()))?;
    let colour = colour_type(image.channels, depth);
    write_atomically(path, format.name(), |sink| match raster {
        Raster::Png if streamed => super::png_stream::write(sink, &bytes, width, height, colour),
        Raster::Png => image::codecs::png::PngEncoder::new(sink)
            .write_image(&bytes, width, height, colour)
            .map_err(|e| e.to_string()),
        Raster::Tiff => image::codecs::tiff::TiffEncoder::new(sink)
            .write_image(&bytes, width, height, colour)
            .map_err(|e| e.to_string()),
        Raster::Bmp => Err("BMP is read only".to_string()),
    })
}

fn colour_type(channels: usize, depth: SampleDepth) -> ExtendedColorType {
    match (channels, depth) {
        (1, SampleDepth::Eight) => ExtendedColorType::L8,
        (2, SampleDepth::Eight) => ExtendedColorType::La8,
        (3, SampleDepth::Eight) => ExtendedColorType::Rgb8,
        (_, SampleDepth::Eight) => ExtendedColorType::Rgba8,
        (1, SampleDepth::Sixteen) => ExtendedColorType::L16,
        (2, SampleDepth::Sixteen) => ExtendedColorType::La16,
        (3, SampleDepth::Sixteen) => ExtendedColorType::Rgb16,
        (_, SampleDepth::Sixteen) => ExtendedColorType::Rgba16,
    }
}

/// The integer codes of `image` (8 or 16 `bits`, codes up to `max`) in pixel-interleaved order as the
/// image encoders take them (16-bit codes big-endian or native-endian), row by row in parallel; `None`
/// when a sample is NaN or infinite.
fn interleaved_codes(image: &Planar, bits: u8, max: u32, big_endian: bool) -> Option<Vec<u8>> {
    match (bits, big_endian) {
        (8, _) => interleaved_codes_as(image, max, |code| [code as u8]),
        (_, true) => interleaved_codes_as(image, max, |code| (code as u16).to_be_bytes()),
        (_, false) => interleaved_codes_as(image, max, |code| (code as u16).to_ne_bytes()),
    }
}

/// [`interleaved_codes`] with each code stored as the `BYTES` bytes `store` makes. Rows in parallel,
/// each filled a channel at a time along the row, without a division per sample or an early exit,
/// so the loop compiles to straight-line code (a non-finite sample is remembered, not branched on).
fn interleaved_codes_as<const BYTES: usize>(
    image: &Planar,
    max: u32,
    store: impl Fn(u32) -> [u8; BYTES] + Sync,
) -> Option<Vec<u8>> {
    use rayon::prelude::*;
    let (width, channels) = (image.width, image.channels);
    let row_bytes = width * channels * BYTES;
    let mut bytes = vec![0u8; row_bytes * image.height];
    if row_bytes == 0 {
        return Some(bytes);
    }
    let planes: Vec<&[f32]> = (0..channels).map(|c| image.plane(c)).collect();
    let all_finite = bytes
        .par_chunks_mut(row_bytes)
        .enumerate()
        .map(|(y, row)| {
            let mut finite = true;
            for (c, plane) in planes.iter().enumerate() {
                let samples = &plane[y * width..(y + 1) * width];
                let pixels = row.chunks_exact_mut(channels * BYTES);
                for (pixel, &value) in pixels.zip(samples) {
                    let code = to_code(value, max);
                    finite &= code.is_some();
                    pixel[c * BYTES..(c + 1) * BYTES].copy_from_slice(&store(code.unwrap_or(0)));
                }
            }
            finite
        })
        .reduce(|| true, |a, b| a && b);
    all_finite.then_some(bytes)
}

/// Refuses a PNG whose palette (PLTE chunk) is not a whole number of 3-byte RGB entries, which the
/// PNG specification forbids and which makes the `png` crate (0.18.1) panic while expanding the palette
/// (found by the `image` fuzz target). Walks the chunk headers only; anything else malformed is left to
/// the decoder, which reports it.
fn check_png_palette(bytes: &[u8]) -> std::result::Result<(), String> {
    const SIGNATURE_LEN: usize = 8;
    let mut at = SIGNATURE_LEN;
    // Each chunk: length (4 bytes, big-endian), type (4), data, CRC (4).
    while let Some(header) = bytes.get(at..at + 8) {
        let length = u32::from_be_bytes([header[0], header[1], header[2], header[3]]) as usize;
        let kind = &header[4..8];
        if kind == b"PLTE" && !length.is_multiple_of(3) {
            return Err(format!(
                "its palette (PLTE chunk) has {length} bytes, not a whole number of 3-byte RGB entries"
            ));
        }
        if kind == b"IEND" || kind == b"IDAT" {
            // The palette comes before the image data.
            return Ok(());
        }
        at = match at.checked_add(12).and_then(|a| a.checked_add(length)) {
            Some(next) => next,
            None => return Ok(()),
        };
    }
    Ok(())
}
