//! OpenEXR through the `exr` crate: the first valid layer of a file as `Planar` (any number of named
//! channels, f16/f32/u32 samples widened to f32), and 32-bit float output with named channels, so that
//! PSF stacks (one channel per colour or wavelength) and linear images share one format. Compression is
//! ZIP (lossless), so f32 samples round-trip bit for bit.

use super::atomic::write_atomically;
use super::{Encoding, FileFormat, LoadedImage};
use crate::error::{check_layout, ImageError, Result};
use crate::Planar;
use exr::prelude::{
    AnyChannel, AnyChannels, FlatSamples, Image, Layer, LayerAttributes, ReadChannels, ReadLayers, SmallVec,
    Text, WritableImage,
};
use std::path::Path;

const FORMAT: &str = "OpenEXR";

/// Conventional order of well-known channel names; other channels follow in name order.
const CANONICAL_ORDER: [&str; 5] = ["Y", "R", "G", "B", "A"];

/// Decodes the first valid layer of an OpenEXR file. Channels come back as R, G, B, A (or Y, A) first, then
/// the others in name order; samples are reported as linear light with the widest stored sample depth.
pub(super) fn decode(path: &Path, bytes: &[u8]) -> Result<LoadedImage> {
    let decode_error = |message: String| ImageError::Decode {
        path: path.to_path_buf(),
        format: FORMAT,
        message,
    };
    // The header's declared size is checked before the decoder allocates for it (a 1.5 kB file may
    // declare billions of samples; found by the `image` fuzz target).
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| decode_error(e.to_string()))?;
    for header in meta.headers.iter() {
        check_declared_size_fits_the_file(header, bytes.len()).map_err(decode_error)?;
        let samples = header
            .layer_size
            .0
            .checked_mul(header.layer_size.1)
            .and_then(|pixels| pixels.checked_mul(header.channels.list.len()));
        if samples.is_none_or(|s| s > super::MAX_DECODED_SAMPLES) {
            return Err(decode_error(format!(
                "the header declares {} x {} px x {} channels, beyond the limit of {} samples \
                 (MAX_DECODED_SAMPLES)",
                header.layer_size.0,
                header.layer_size.1,
                header.channels.list.len(),
                super::MAX_DECODED_SAMPLES
            )));
        }
    }
    let file = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| decode_error(e.to_string()))?;
    let layer = file.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let mut channels: Vec<&AnyChannel<FlatSamples>> = layer.channel_data.list.iter().collect();
    channels.sort_by_key(|c| {
        let name = c.name.to_string();
        (
            CANONICAL_ORDER
                .iter()
                .position(|&n| n == name)
                .unwrap_or(CANONICAL_ORDER.len()),
            name,
        )
    });
    let mut image = Planar::new(width, height, channels.len());
    let mut bit_depth = 16;
    for (index, channel) in channels.iter().enumerate() {
        let samples = &channel.sample_data;
        if samples.len() != width * height {
            return Err(decode_error(format!(
                "channel {} is subsampled ({} samples for {width}x{height})",
                channel.name,
                samples.len()
            )));
        }
        if !matches!(samples, FlatSamples::F16(_)) {
            bit_depth = 32;
        }
        for (out, value) in image.plane_mut(index).iter_mut().zip(samples.values_as_f32()) {
            *out = value;
        }
    }
    let channel_names = channels.iter().map(|c| c.name.to_string()).collect();
    Ok(LoadedImage {
        image,
        format: FileFormat::OpenExr,
        bit_depth,
        encoding: Encoding::Linear,
        channel_names,
    })
}

/// Most uncompressed bytes one stored byte can expand to under each OpenEXR compression, a bound no
/// valid file exceeds: RLE stores a run of at most 128 bytes in 2; deflate (ZIP, PXR24 after its 24-bit
/// rounding of f32, DWA's lossless parts) expands at most 1,032-fold; PIZ's Huffman stage writes a run of
/// at most 255 16-bit values in at least 9 bits; B44 packs 32 bytes of f16 into at least 3 (B44A's flat
/// blocks) and stores f32/u32 as is. DWA and HTJ2K layer entropy coders, so they get deflate's bound
/// times RLE's. A header declaring more pixel bytes than its file could hold is refused before the
/// `exr` crate allocates for it (it allocates ~30 bytes per declared sample while decoding: a 1.4 kB
/// B44 file declaring 65 M samples took 2 GB before it failed; found by the `image` fuzz target).
fn max_expansion(compression: exr::compression::Compression) -> usize {
    use exr::compression::Compression::*;
    match compression {
        Uncompressed => 1,
        RLE => 64,
        ZIP1 | ZIP16 => 1_032,
        PXR24 => 1_032 * 4 / 3 + 1,
        PIZ => 455,
        B44 | B44A => 11,
        _ => 1_032 * 64,
    }
}

/// Refuses a header whose uncompressed pixel bytes could not come out of `file_bytes` bytes under its
/// compression (see [`max_expansion`]); 64 bytes of slack per chunk cover the chunk headers.
fn check_declared_size_fits_the_file(
    header: &exr::meta::header::Header,
    file_bytes: usize,
) -> std::result::Result<(), String> {
    if header.deep {
        return Ok(()); // deep data is refused later by `no_deep_data`
    }
    // A hostile header's sampling may be 0 (`subsampled_resolution` would divide by it).
    if let Some(channel) = header
        .channels
        .list
        .iter()
        .find(|c| c.sampling.0 == 0 || c.sampling.1 == 0)
    {
        return Err(format!(
            "channel {} declares a sampling of {} x {} px; it must be at least 1",
            channel.name, channel.sampling.0, channel.sampling.1
        ));
    }
    let declared = header.channels.list.iter().try_fold(0usize, |sum, channel| {
        let size = channel.subsampled_resolution(header.layer_size);
        size.0
            .checked_mul(size.1)?
            .checked_mul(channel.sample_type.bytes_per_sample())?
            .checked_add(sum)
    });
    let expansion = max_expansion(header.compression);
    let most = file_bytes.saturating_mul(expansion);
    match declared {
        Some(declared) if declared <= most => Ok(()),
        _ => Err(format!(
            "the header declares {} x {} px x {} channels ({} bytes of pixels), more than a {file_bytes}-byte \
             file can hold with {} (at most {expansion} bytes per stored byte)",
            header.layer_size.0,
            header.layer_size.1,
            header.channels.list.len(),
            declared.map_or_else(|| "an overflowing number of".to_string(), |d| d.to_string()),
            header.compression
        )),
    }
}

/// Default channel names by channel count: Y, (Y, A), (R, G, B), (R, G, B, A).
pub(super) fn default_channel_names(channels: usize) -> Option<&'static [&'static str]> {
    match channels {
        1 => Some(&["Y"]),
        2 => Some(&["Y", "A"]),
        3 => Some(&["R", "G", "B"]),
        4 => Some(&["R", "G", "B", "A"]),
        _ => None,
    }
}

/// Writes every plane of `image` as a 32-bit float channel named by `channel_names` (same count as
/// channels; non-empty, unique, ASCII-compatible names as the OpenEXR header requires).
pub(super) fn encode(path: &Path, image: &Planar, channel_names: &[&str]) -> Result<()> {
    let encode_error = |message: String| ImageError::Encode {
        path: path.to_path_buf(),
        format: FORMAT,
        message,
    };
    check_layout(image, "image", &[]).map_err(|e| encode_error(e.to_string()))?;
    if image.pixels() == 0 || image.channels == 0 {
        return Err(encode_error(format!(
            "{}x{}x{} image has no samples",
            image.width, image.height, image.channels
        )));
    }
    if channel_names.len() != image.channels {
        return Err(encode_error(format!(
            "{} channel names for {} channels",
            channel_names.len(),
            image.channels
        )));
    }
    let mut list = SmallVec::new();
    for (index, name) in channel_names.iter().enumerate() {
        if name.is_empty() || channel_names[..index].contains(name) {
            return Err(encode_error(format!(
                "channel name {name:?} is empty or repeated"
            )));
        }
        let text = Text::new_or_none(name).ok_or_else(|| {
            encode_error(format!("channel name {name:?} is not valid in an OpenEXR header"))
        })?;
        list.push(AnyChannel::new(
            text,
            FlatSamples::F32(image.plane(index).to_vec()),
        ));
    }
    let layer = Layer::new(
        (image.width, image.height),
        LayerAttributes::default(),
        exr::prelude::Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let file = Image::from_layer(layer);
    write_atomically(path, FORMAT, |sink| {
        file.write()
            .non_parallel()
            .to_buffered(sink)
            .map_err(|e| e.to_string())
    })
}
