//! PNG output through the `png` crate's streaming writer, with the file written behind it by a second
//! thread. The `image` crate's PNG encoder (the same codec: fdeflate's fast compression, adaptive row
//! filters) compresses the whole image before writing a byte, and both halves are serial: for a 12 MP
//! 16-bit image ~0.2 s of compression, then ~0.15 s of the kernel copying 67 MB into the page cache.
//! Streamed, the copy runs on the other core while the compressor works. The pixels are the same; the
//! IDAT chunks are cut differently (1 MiB each), and incompressible data is not replaced by stored blocks
//! (the whole-image encoder's fallback, which only small images need: 16-bit noise compresses 7% at
//! 12 MP, and came out 20% larger than stored at 64 x 48). So only images of at least
//! [`STREAMED_FROM_BYTES`] are streamed; smaller ones keep the whole-image encoder and its exact bytes.

use super::atomic::Sink;
use image::ExtendedColorType;
use std::io::{self, Write};
use std::sync::mpsc::{sync_channel, SyncSender};

/// Raw image size (interleaved samples) from which a PNG is streamed: 8 MiB, a 1.4 MP 16-bit RGB image.
const STREAMED_FROM_BYTES: usize = 8 << 20;

/// Whether a PNG of `raw_bytes` of samples is written streamed ([`write`]).
pub(super) fn worth_streaming(raw_bytes: usize) -> bool {
    raw_bytes >= STREAMED_FROM_BYTES
}

/// Bytes handed to the writing thread at a time; also the IDAT chunk size.
const BLOCK_BYTES: usize = 1 << 20;
/// Blocks that may wait for the writing thread (bounds the memory in flight to 8 MiB).
const BLOCKS_IN_FLIGHT: usize = 8;

/// Writes `codes` (interleaved samples, 16-bit ones big-endian) as a PNG of `colour` into `sink`.
pub(super) fn write(
    sink: &mut Sink,
    codes: &[u8],
    width: u32,
    height: u32,
    colour: ExtendedColorType,
) -> Result<(), String> {
    let (colour, depth) = png_layout(colour)?;
    written_behind(sink, |out| {
        let mut encoder = png::Encoder::new(out, width, height);
        encoder.set_color(colour);
        encoder.set_depth(depth);
        encoder.set_compression(png::Compression::Fast);
        encoder.set_filter(png::Filter::Adaptive);
        let mut stream = encoder
            .write_header()
            .and_then(|header| header.into_stream_writer_with_size(BLOCK_BYTES))
            .map_err(|e| e.to_string())?;
        stream.write_all(codes).map_err(|e| e.to_string())?;
        stream.finish().map_err(|e| e.to_string())
    })
}

fn png_layout(colour: ExtendedColorType) -> Result<(png::ColorType, png::BitDepth), String> {
    use png::{BitDepth, ColorType};
    Ok(match colour {
        ExtendedColorType::L8 => (ColorType::Grayscale, BitDepth::Eight),
        ExtendedColorType::La8 => (ColorType::GrayscaleAlpha, BitDepth::Eight),
        ExtendedColorType::Rgb8 => (ColorType::Rgb, BitDepth::Eight),
        ExtendedColorType::Rgba8 => (ColorType::Rgba, BitDepth::Eight),
        ExtendedColorType::L16 => (ColorType::Grayscale, BitDepth::Sixteen),
        ExtendedColorType::La16 => (ColorType::GrayscaleAlpha, BitDepth::Sixteen),
        ExtendedColorType::Rgb16 => (ColorType::Rgb, BitDepth::Sixteen),
        ExtendedColorType::Rgba16 => (ColorType::Rgba, BitDepth::Sixteen),
        other => return Err(format!("no PNG layout for {other:?}")),
    })
}

/// Runs `produce` with a writer whose bytes a second thread writes into `sink`, in blocks (the last one
/// when the writer is dropped). A failed file write is the error reported (the producer then only sees
/// its blocks refused).
fn written_behind(
    sink: &mut Sink,
    produce: impl FnOnce(BlockSender) -> Result<(), String>,
) -> Result<(), String> {
    std::thread::scope(|scope| {
        let (blocks, received) = sync_channel::<Vec<u8>>(BLOCKS_IN_FLIGHT);
        let writer = scope.spawn(move || -> io::Result<()> {
            for block in received {
                sink.write_all(&block)?;
            }
            Ok(())
        });
        let produced = produce(BlockSender {
            block: Vec::with_capacity(BLOCK_BYTES),
            blocks,
        });
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(io::Error::other("the file-writing thread panicked")));
        written.map_err(|e| e.to_string()).and(produced)
    })
}

/// The producing side: collects bytes into blocks and queues each full one for the writing thread, and
/// the rest when dropped.
struct BlockSender {
    block: Vec<u8>,
    blocks: SyncSender<Vec<u8>>,
}

impl BlockSender {
    fn send(&mut self) -> io::Result<()> {
        if self.block.is_empty() {
            return Ok(());
        }
        let full = std::mem::replace(&mut self.block, Vec::with_capacity(BLOCK_BYTES));
        self.blocks
            .send(full)
            .map_err(|_| io::Error::new(io::ErrorKind::BrokenPipe, "the file-writing thread stopped"))
    }
}

impl Write for BlockSender {
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        self.block.extend_from_slice(data);
        if self.block.len() >= BLOCK_BYTES {
            self.send()?;
        }
        Ok(data.len())
    }

    /// Queues what is collected; the file itself is flushed and synced by the atomic writer afterwards.
    fn flush(&mut self) -> io::Result<()> {
        self.send()
    }
}

impl Drop for BlockSender {
    fn drop(&mut self) {
        // Fails only when the writing thread has stopped on an error, which is then the one reported.
        let _ = self.send();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_file_write_is_the_error_reported() {
        let folder = tempfile::tempdir().unwrap();
        // A file opened read-only: every write fails.
        let path = folder.path().join("read-only");
        std::fs::write(&path, b"").unwrap();
        let mut sink = std::io::BufWriter::with_capacity(16, std::fs::File::open(&path).unwrap());
        let error = written_behind(&mut sink, |mut out| {
            for _ in 0..64 {
                out.write_all(&[7u8; BLOCK_BYTES / 2])
                    .map_err(|e| e.to_string())?;
            }
            Ok(())
        })
        .unwrap_err();
        assert!(error.contains("Bad file descriptor"), "{error}");
    }

    #[test]
    fn every_byte_arrives_in_order() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("out");
        let mut sink = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let bytes: Vec<u8> = (0..3 * BLOCK_BYTES + 12_345)
            .map(|i| (i * 31 % 251) as u8)
            .collect();
        written_behind(&mut sink, |mut out| {
            for piece in bytes.chunks(70_001) {
                out.write_all(piece).map_err(|e| e.to_string())?;
            }
            Ok(())
        })
        .unwrap();
        sink.flush().unwrap();
        drop(sink);
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
    }
}
