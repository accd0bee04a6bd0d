//! Image files: PNG (8/16-bit grey, grey + alpha, RGB, RGBA), TIFF (8/16-bit, and 32-bit float on read),
//! BMP (read only: pyiqa's calibration pairs are BMP) and OpenEXR (f16/f32/u32 on read, f32 with named channels on write), to and from [`Planar`].
//!
//! The codecs are the `image` crate (PNG, TIFF) and the `exr` crate (OpenEXR, which also gives named
//! multi-channel layers); this module only picks the codec from the file's first bytes, converts samples,
//! reports what the file was ([`LoadedImage`]) and makes every write atomic (`atomic`). Every error names
//! the file.
//!
//! Sample convention: integer files come back divided by their maximum code (so in [0, 1]) and are reported
//! as [`Encoding::Srgb`], since PNG/TIFF in this pipeline hold display-referred images; float files come
//! back unchanged and are reported as [`Encoding::Linear`]. Writers store exactly what they are given:
//! encode to sRGB first ([`crate::color::linear_to_srgb`]) if the file is meant for display.

mod atomic;
mod openexr;
mod png_stream;
mod raster;

use crate::error::{ImageError, Result};
use crate::Planar;
use raster::Raster;
use std::path::Path;

/// Most samples (pixels x channels) a decoded file may hold (2^28: 1 GiB as f32, e.g. 89 MP RGB).
/// Every header (OpenEXR, PNG, TIFF, BMP) is checked against it before decoding.
pub const MAX_DECODED_SAMPLES: usize = 1 << 28;

/// Largest image file read (1 GiB + 64 MiB): [`MAX_DECODED_SAMPLES`] f32 samples stored uncompressed,
/// plus room for headers and offset tables. Larger files are refused from their size, before reading.
pub const MAX_IMAGE_FILE_BYTES: u64 = (4 << 28) + (64 << 20);

/// Container formats this module reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileFormat {
    Png,
    Tiff,
    Bmp,
    OpenExr,
}

impl FileFormat {
    /// Human-readable name used in error messages.
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::Png => "PNG",
            FileFormat::Tiff => "TIFF",
            FileFormat::Bmp => "BMP",
            FileFormat::OpenExr => "OpenEXR",
        }
    }

    /// The format a file name's extension names (case-insensitive): png, tif/tiff, bmp, exr.
    pub fn from_extension(extension: &str) -> Option<FileFormat> {
        match extension.to_ascii_lowercase().as_str() {
            "png" => Some(FileFormat::Png),
            "tif" | "tiff" => Some(FileFormat::Tiff),
            "bmp" => Some(FileFormat::Bmp),
            "exr" => Some(FileFormat::OpenExr),
            _ => None,
        }
    }

    /// The extension written for this format when a name has to be made: png, tiff, exr.
    pub fn extension(self) -> &'static str {
        match self {
            FileFormat::Png => "png",
            FileFormat::Tiff => "tiff",
            FileFormat::Bmp => "bmp",
            FileFormat::OpenExr => "exr",
        }
    }

    /// The format whose signature starts `bytes`: PNG (ISO/IEC 15948, 8-byte signature), TIFF (TIFF 6.0
    /// header `II*\0` or `MM\0*`), BMP (`BM`), OpenEXR (magic number 20000630 as little-endian `76 2f 31 01`).
    pub fn sniff(bytes: &[u8]) -> Option<FileFormat> {
        const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";
        const EXR: &[u8] = &[0x76, 0x2f, 0x31, 0x01];
        if bytes.starts_with(PNG) {
            Some(FileFormat::Png)
        } else if bytes.starts_with(b"II*\0") || bytes.starts_with(b"MM\0*") {
            Some(FileFormat::Tiff)
        } else if bytes.starts_with(b"BM") {
            Some(FileFormat::Bmp)
        } else if bytes.starts_with(EXR) {
            Some(FileFormat::OpenExr)
        } else {
            None
        }
    }
}

/// How the stored values relate to light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// sRGB transfer curve applied (IEC 61966-2-1); decode with [`crate::color::srgb_to_linear`].
    Srgb,
    /// Linear light (proportional to radiance).
    Linear,
}

/// Integer sample depth for PNG and TIFF output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleDepth {
    /// 8 bits per sample, codes 0..=255.
    Eight,
    /// 16 bits per sample, codes 0..=65535.
    Sixteen,
}

/// A decoded file and what it was.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedImage {
    /// Samples in [0, 1] for integer files, as stored for float files; one plane per channel.
    pub image: Planar,
    pub format: FileFormat,
    /// Bits per stored sample: 8 or 16 (integer), 16 (half float) or 32 (float / u32).
    pub bit_depth: u8,
    pub encoding: Encoding,
    /// One name per plane: "Y", "R", "G", "B", "A", or the OpenEXR channel names.
    pub channel_names: Vec<String>,
}

impl LoadedImage {
    /// The image in linear light: colour planes of an sRGB file are decoded, an alpha plane ("A") is left
    /// as is; a linear file is returned unchanged.
    pub fn to_linear(&self) -> Planar {
        self.clone().into_linear()
    }

    /// [`Self::to_linear`] without the copy: the planes are decoded where they are.
    pub fn into_linear(self) -> Planar {
        let LoadedImage {
            mut image,
            encoding,
            channel_names,
            ..
        } = self;
        if encoding == Encoding::Srgb {
            for (index, name) in channel_names.iter().enumerate() {
                if name != "A" {
                    crate::color::apply_srgb(image.plane_mut(index), crate::color::Transfer::Decode);
                }
            }
        }
        image
    }

    /// The R, G, B planes of `image` (this file's samples, or their `to_linear` form): a grey file's plane
    /// is replicated and alpha is dropped; `None` for files that are neither grey nor RGB.
    pub fn rgb_planes(&self, image: &Planar) -> Option<Planar> {
        Some(select_planes(image, self.colour_planes()?))
    }

    /// The linear-light R, G, B planes (`rgb_planes(&to_linear())`), made in place: an RGB file's planes
    /// are decoded where they are and not copied (a 12 MP image's planes are 144 MB).
    pub fn into_linear_rgb(self) -> Option<Planar> {
        let planes = self.colour_planes()?;
        let linear = self.into_linear();
        if planes == [0, 1, 2] && linear.channels == 3 {
            return Some(linear);
        }
        Some(select_planes(&linear, planes))
    }

    /// Which planes are R, G and B: a grey plane three times, alpha skipped.
    fn colour_planes(&self) -> Option<[usize; 3]> {
        let colour: Vec<usize> = (0..self.channel_names.len())
            .filter(|&i| self.channel_names[i] != "A")
            .collect();
        match colour.as_slice() {
            [y] => Some([*y; 3]),
            [r, g, b, ..] => Some([*r, *g, *b]),
            _ => None,
        }
    }
}

/// A three-plane copy of `image`'s planes `planes`.
fn select_planes(image: &Planar, planes: [usize; 3]) -> Planar {
    let mut out = Planar::new(image.width, image.height, 3);
    for (c, &p) in planes.iter().enumerate() {
        out.plane_mut(c).copy_from_slice(image.plane(p));
    }
    out
}

/// Reads a PNG, TIFF, BMP or OpenEXR file, choosing the decoder from the file's signature (not its extension).
/// The file must be a regular file of at most [`MAX_IMAGE_FILE_BYTES`]; the size its header declares is
/// checked against [`MAX_DECODED_SAMPLES`] before decoding.
pub fn read_image(path: impl AsRef<Path>) -> Result<LoadedImage> {
    let path = path.as_ref();
    let bytes =
        unicac_io::read_capped(path, MAX_IMAGE_FILE_BYTES, "MAX_IMAGE_FILE_BYTES").map_err(|source| {
            ImageError::Io {
                path: path.to_path_buf(),
                source,
            }
        })?;
    decode_image(path, &bytes)
}

/// The width and height a PNG, TIFF or BMP file's header declares, read without decoding (a few hundred
/// bytes), so that work which depends only on the size can start beside the decode; `None` for OpenEXR
/// files and whatever cannot be read (the decode itself reports why).
pub fn declared_size(path: impl AsRef<Path>) -> Option<(usize, usize)> {
    let reader = image::ImageReader::open(path.as_ref())
        .ok()?
        .with_guessed_format()
        .ok()?;
    if !matches!(
        reader.format()?,
        image::ImageFormat::Png | image::ImageFormat::Tiff | image::ImageFormat::Bmp
    ) {
        return None;
    }
    let (width, height) = reader.into_dimensions().ok()?;
    Some((width as usize, height as usize))
}

/// Decodes the bytes of a PNG, TIFF or OpenEXR file (`path` only names it in errors); what
/// [`read_image`] does after reading the file, public for tools that hold the bytes (and the fuzzer).
pub fn decode_image(path: &Path, bytes: &[u8]) -> Result<LoadedImage> {
    if bytes.is_empty() {
        return Err(ImageError::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    match FileFormat::sniff(bytes) {
        Some(FileFormat::Png) => raster::decode(path, bytes, Raster::Png),
        Some(FileFormat::Tiff) => raster::decode(path, bytes, Raster::Tiff),
        Some(FileFormat::Bmp) => raster::decode(path, bytes, Raster::Bmp),
        Some(FileFormat::OpenExr) => openexr::decode(path, bytes),
        None => Err(ImageError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// Writes a PNG with integer samples of `depth`; `image` has 1 (grey), 2 (grey + alpha), 3 (RGB) or 4 (RGBA)
/// channels with values in [0, 1] (clipped; NaN is an error). Atomic: on error no file is left behind.
pub fn write_png(path: impl AsRef<Path>, image: &Planar, depth: SampleDepth) -> Result<()> {
    raster::encode(path.as_ref(), image, depth, Raster::Png)
}

/// Writes an uncompressed TIFF with integer samples of `depth` (16-bit for lossless intermediate images);
/// same channel and value rules as [`write_png`]. Atomic.
pub fn write_tiff(path: impl AsRef<Path>, image: &Planar, depth: SampleDepth) -> Result<()> {
    raster::encode(path.as_ref(), image, depth, Raster::Tiff)
}

/// Writes a 32-bit float OpenEXR, channels named Y / Y,A / R,G,B / R,G,B,A by channel count; other channel
/// counts need [`write_exr_channels`]. Values are stored bit-exactly (lossless ZIP). Atomic.
pub fn write_exr(path: impl AsRef<Path>, image: &Planar) -> Result<()> {
    let path = path.as_ref();
    let names = openexr::default_channel_names(image.channels).ok_or_else(|| ImageError::Encode {
        path: path.to_path_buf(),
        format: "OpenEXR",
        message: format!(
            "{} channels have no default names; use write_exr_channels",
            image.channels
        ),
    })?;
    openexr::encode(path, image, names)
}

/// Writes a 32-bit float OpenEXR with one named channel per plane (e.g. a PSF stack with channels "R", "G",
/// "B", or one per wavelength such as "psf_0450nm"). Readers list channels in name order, with Y/R/G/B/A
/// first. Atomic.
pub fn write_exr_channels(path: impl AsRef<Path>, image: &Planar, channel_names: &[&str]) -> Result<()> {
    openexr::encode(path.as_ref(), image, channel_names)
}

#[cfg(test)]
mod tests;
