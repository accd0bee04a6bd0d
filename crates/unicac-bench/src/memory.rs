//! Peak memory of a bench run, estimated before any work from the largest test pair, so that a frame
//! the machine cannot hold is refused with the figure instead of aborting on allocation hours in.
//!
//! The model is docs/reliability.md's measurement (peak RSS ≈ 0.3 GB + 335 B x W x H with a tiled model,
//! Wiener and every metric; pairs are benchmarked one at a time), split into its parts:
//! reading the pair, identity, PSNR/SSIM/OIQE 107 B/px (Wiener adds nothing measurable: it works on
//! 128 px tiles); LPIPS 69 B/px of at most one LPIPS tile (it ran on the whole image when measured, and
//! now runs in tiles of at most [`LPIPS_TILE_MAX_PX`]); a model run on tiles 159 B/px (its inputs,
//! the maps and the two image-sized accumulators of `tiling`). A model run on the whole image also holds
//! its activations at full size, which depend on the network: [`UNTILED_ACTIVATION_BYTES_PER_PX`] is an
//! assumption (not a measurement) of a few dozen float channels alive at once.

pub use crate::error::{MemoryExceeded, MemoryLimit, MemoryRemedy};

/// What every run holds besides the pair (onnxruntime, metric networks, buffers), bytes.
pub const BASE_BYTES: u64 = 300_000_000;
/// Reading the pair, identity, PSNR, SSIM and OIQE, per pixel of the largest pair.
pub const PAIR_BYTES_PER_PX: u64 = 107;
/// LPIPS, per pixel of the image or of its largest tile, whichever is smaller.
pub const LPIPS_BYTES_PER_PX: u64 = 69;
/// The largest LPIPS tile (px): a core plus its margins on both sides, squared.
pub const LPIPS_TILE_MAX_PX: u64 = ((unicac_learned_metrics::lpips::TILE_CORE_PX
    + 2 * unicac_learned_metrics::lpips::TILE_MARGIN_PX)
    * (unicac_learned_metrics::lpips::TILE_CORE_PX + 2 * unicac_learned_metrics::lpips::TILE_MARGIN_PX))
    as u64;
/// A model run on tiles (inputs, maps and accumulators; one tile of activations), per pixel.
pub const TILED_MODEL_BYTES_PER_PX: u64 = 159;
/// Assumed activations of a model run on the whole image, per pixel (see the module note).
pub const UNTILED_ACTIVATION_BYTES_PER_PX: u64 = 1024;

/// What a run asks for, as far as memory goes.
#[derive(Debug, Clone, Copy)]
pub struct MemoryPlan {
    /// Pixels of the largest pair.
    pub pair_px: u64,
    pub lpips: bool,
    /// Whether any ONNX model runs, and whether on tiles.
    pub models: bool,
    pub tiled: bool,
}

impl MemoryPlan {
    /// Estimated peak bytes.
    pub fn peak_bytes(&self) -> u64 {
        let mut per_px = PAIR_BYTES_PER_PX;
        let mut fixed = BASE_BYTES;
        if self.lpips {
            fixed += self.pair_px.min(LPIPS_TILE_MAX_PX) * LPIPS_BYTES_PER_PX;
        }
        if self.models {
            per_px += TILED_MODEL_BYTES_PER_PX;
            if !self.tiled {
                per_px += UNTILED_ACTIVATION_BYTES_PER_PX;
            }
        }
        fixed.saturating_add(self.pair_px.saturating_mul(per_px))
    }

    /// Refuses a run whose estimate exceeds `limit_bytes`, with the figure and what lowers it.
    pub fn check(
        &self,
        limit_bytes: u64,
        limit: MemoryLimit,
        pair_size_px: [usize; 2],
    ) -> Result<(), MemoryExceeded> {
        let peak_bytes = self.peak_bytes();
        if peak_bytes <= limit_bytes {
            return Ok(());
        }
        let mut remedies = Vec::new();
        if self.models && !self.tiled {
            remedies.push(MemoryRemedy::TileModels { tile_px: 512 });
        }
        if self.lpips {
            remedies.push(MemoryRemedy::LeaveOutLpips);
        }
        remedies.push(MemoryRemedy::SmallerFrame);
        Err(MemoryExceeded {
            pair_size_px,
            peak_bytes,
            limit_bytes,
            limit,
            remedies,
        })
    }
}

/// The memory the kernel says can be allocated now without swapping (`MemAvailable`), if known.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_matches_the_measurements_it_comes_from() {
        // docs/reliability.md: 24 MP with a tiled model, Wiener and every metric peaked at 8.15 GB,
        // 6 MP at 2.27 GB, when LPIPS ran on the whole image (69 B/px); with that part restored, the
        // model reproduces both within 5%.
        for (px, measured_gb) in [(6000u64 * 4000, 8.150_708), (3000 * 2000, 2.266_124)] {
            let plan = MemoryPlan {
                pair_px: px,
                lpips: true,
                models: true,
                tiled: true,
            };
            let whole_image_lpips = (px - px.min(LPIPS_TILE_MAX_PX)) * LPIPS_BYTES_PER_PX;
            let estimate_gb = (plan.peak_bytes() + whole_image_lpips) as f64 / 1e9;
            assert!(
                (estimate_gb / (measured_gb * 1.024) - 1.0).abs() < 0.05,
                "{px} px: {estimate_gb} GB against {measured_gb} GiB-ish"
            );
        }
    }

    #[test]
    fn a_frame_beyond_the_limit_is_refused_with_the_figure_and_what_lowers_it() {
        let plan = MemoryPlan {
            pair_px: 10_000 * 10_000,
            lpips: true,
            models: true,
            tiled: false,
        };
        let Err(refusal) = plan.check(24_000_000_000, MemoryLimit::Available, [10_000, 10_000]) else {
            panic!("refused");
        };
        assert_eq!(
            refusal.remedies,
            [
                MemoryRemedy::TileModels { tile_px: 512 },
                MemoryRemedy::LeaveOutLpips,
                MemoryRemedy::SmallerFrame
            ]
        );
        let message = refusal.to_string();
        assert!(
            message.contains("10000 x 10000 px")
                && message.contains("129.4 GB")
                && message.contains("tile_px 512"),
            "{message}"
        );
        assert!(!message.contains("--"), "the library names no flag: {message}");
        assert!(plan
            .check(u64::MAX, MemoryLimit::Available, [10_000, 10_000])
            .is_ok());
    }
}
