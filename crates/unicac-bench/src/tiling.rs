//! Large images in overlapping tiles with seamless blending and bounded memory.
//!
//! Tiles of `tile_px` x `tile_px` start every `tile_px - overlap_px` pixels; the last tile on each axis is
//! moved back to end at the image edge, and an image no larger than a tile is one tile. Each tile's output
//! is weighted by a separable window that is 1 in its interior and, on every side that borders another
//! tile (never on the image's own edges), 0 over the outer quarter of the overlap and a linear ramp over
//! the middle half; the weighted outputs are summed and divided by the summed weights. So the weights of
//! two neighbours add to 1 across their overlap (no seams), and a pixel within a quarter-overlap of a
//! tile's inner edge (where a network sees zero padding instead of image) never counts: a model whose
//! receptive-field radius is at most `overlap_px / 4` gives the same result tiled as untiled (tested to
//! 1e-5). Memory: the inputs, one tile at a time, and two image-sized accumulators.

use unicac_image::Planar;

use crate::error::{BenchError, Result};
use unicac_trace::InvalidParameter;

/// Largest tile side (px): a stated limit.
pub const MAX_TILE_PX: usize = 8192;
/// Smallest tile side (px): the model contract's minimum image side.
pub const MIN_TILE_PX: usize = 16;

/// Tiling settings; `tile_px = None` runs the whole image at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Tiling {
    pub tile_px: Option<usize>,
    pub overlap_px: usize,
}

/// Where a tile lies in the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileRect {
    pub x0: usize,
    pub y0: usize,
    pub width: usize,
    pub height: usize,
}

impl Tiling {
    pub fn check(&self) -> Result<()> {
        if let Some(tile) = self.tile_px {
            if !(MIN_TILE_PX..=MAX_TILE_PX).contains(&tile) {
                return Err(BenchError::InvalidParameter(InvalidParameter::new(
                    "tile_px",
                    format!("{tile}: must be between {MIN_TILE_PX} and {MAX_TILE_PX} px"),
                )));
            }
            if self.overlap_px >= tile / 2 {
                return Err(BenchError::InvalidParameter(InvalidParameter::new(
                    "overlap_px",
                    format!("{}: must be less than half the tile ({tile} px)", self.overlap_px),
                )));
            }
        }
        Ok(())
    }
}

/// Start positions of the tiles along an axis of `length` px.
pub fn tile_starts(length: usize, tile: usize, overlap: usize) -> Vec<usize> {
    if tile >= length {
        return vec![0];
    }
    let step = tile - overlap;
    let mut starts: Vec<usize> = (0..)
        .map(|i| i * step)
        .take_while(|&s| s + tile < length)
        .collect();
    starts.push(length - tile);
    starts.dedup();
    starts
}

/// The blending weight of each position of a tile of `size` px starting at `start` on an axis of `length`.
fn axis_weights(start: usize, size: usize, length: usize, overlap: usize) -> Vec<f32> {
    let margin = overlap / 4;
    let ramp = overlap.saturating_sub(2 * margin);
    let side = |distance: usize| -> f32 {
        if ramp == 0 {
            1.0
        } else {
            ((distance as f32 - margin as f32 + 0.5) / ramp as f32).clamp(0.0, 1.0)
        }
    };
    (0..size)
        .map(|i| {
            let left = if start > 0 { side(i) } else { 1.0 };
            let right = if start + size < length {
                side(size - 1 - i)
            } else {
                1.0
            };
            left.min(right)
        })
        .collect()
}

/// A crop of `image`.
pub fn crop(image: &Planar, rect: TileRect) -> Planar {
    let mut out = Planar::new(rect.width, rect.height, image.channels);
    for c in 0..image.channels {
        let src = image.plane(c);
        let dst = out.plane_mut(c);
        for y in 0..rect.height {
            let row = (rect.y0 + y) * image.width + rect.x0;
            dst[y * rect.width..(y + 1) * rect.width].copy_from_slice(&src[row..row + rect.width]);
        }
    }
    out
}

/// Runs `infer` on `inputs` (all of one width and height) tile by tile and blends the outputs, which
/// must have the tile's width and height (any channel count, the same for every tile).
pub fn run_tiled(
    inputs: &[&Planar],
    tiling: Tiling,
    mut infer: impl FnMut(TileRect, &[Planar]) -> Result<Planar>,
) -> Result<Planar> {
    tiling.check()?;
    let (width, height) = (inputs[0].width, inputs[0].height);
    let whole = TileRect {
        x0: 0,
        y0: 0,
        width,
        height,
    };
    let Some(tile) = tiling.tile_px.filter(|&t| t < width || t < height) else {
        let owned: Vec<Planar> = inputs.iter().map(|p| (*p).clone()).collect();
        return infer(whole, &owned);
    };
    let overlap = tiling.overlap_px;
    let xs = tile_starts(width, tile, overlap);
    let ys = tile_starts(height, tile, overlap);
    let (tw, th) = (tile.min(width), tile.min(height));
    let mut sum: Option<Planar> = None;
    let mut weight_sum = vec![0.0f32; width * height];
    for &y0 in &ys {
        let wy = axis_weights(y0, th, height, overlap);
        for &x0 in &xs {
            let wx = axis_weights(x0, tw, width, overlap);
            let rect = TileRect {
                x0,
                y0,
                width: tw,
                height: th,
            };
            let crops: Vec<Planar> = inputs.iter().map(|p| crop(p, rect)).collect();
            let out = infer(rect, &crops)?;
            if (out.width, out.height) != (tw, th) {
                return Err(BenchError::InvalidInput(format!(
                    "a {tw}x{th} tile came back as {}x{}",
                    out.width, out.height
                )));
            }
            let acc = sum.get_or_insert_with(|| Planar::new(width, height, out.channels));
            if acc.channels != out.channels {
                return Err(BenchError::InvalidInput(
                    "tiles returned different channel counts".into(),
                ));
            }
            for (y, &weight_y) in wy.iter().enumerate().take(th) {
                for (x, &weight_x) in wx.iter().enumerate().take(tw) {
                    let w = weight_y * weight_x;
                    let at = (y0 + y) * width + x0 + x;
                    weight_sum[at] += w;
                    for c in 0..out.channels {
                        acc.data[c * width * height + at] += w * out.data[(c * th + y) * tw + x];
                    }
                }
            }
        }
    }
    let mut out = sum.expect("at least one tile");
    let plane = width * height;
    for c in 0..out.channels {
        for (v, w) in out.data[c * plane..(c + 1) * plane].iter_mut().zip(&weight_sum) {
            debug_assert!(*w > 0.0, "every pixel has a positive total weight");
            *v /= *w;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_axis_and_end_at_the_edge() {
        assert_eq!(tile_starts(100, 128, 16), vec![0]);
        assert_eq!(tile_starts(100, 40, 8), vec![0, 32, 60]);
        assert_eq!(tile_starts(64, 32, 0), vec![0, 32]);
    }

    #[test]
    fn weights_of_neighbours_sum_to_one() {
        let (length, tile, overlap) = (100, 40, 16);
        let mut total = vec![0.0f32; length];
        for s in tile_starts(length, tile, overlap) {
            for (i, w) in axis_weights(s, tile, length, overlap).into_iter().enumerate() {
                total[s + i] += w;
            }
        }
        // Regular overlaps sum to exactly 1; the last, larger overlap sums to at least 1.
        assert!(total.iter().all(|&t| t >= 1.0 - 1e-6), "{total:?}");
        assert!(total[..60].iter().all(|&t| (t - 1.0).abs() < 1e-6), "{total:?}");
    }

    #[test]
    fn a_pointwise_function_is_unchanged_by_tiling() {
        let image = Planar::from_fn(70, 45, 2, |c, x, y| (c * 1000 + y * 70 + x) as f32);
        let tiling = Tiling {
            tile_px: Some(32),
            overlap_px: 8,
        };
        let out = run_tiled(&[&image], tiling, |_, t| {
            Ok(Planar::from_fn(t[0].width, t[0].height, 1, |_, x, y| {
                2.0 * t[0].get(1, x, y)
            }))
        })
        .unwrap();
        for y in 0..45 {
            for x in 0..70 {
                assert!((out.get(0, x, y) - 2.0 * image.get(1, x, y)).abs() < 1e-3);
            }
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        let bad = Tiling {
            tile_px: Some(32),
            overlap_px: 16,
        };
        assert!(bad.check().is_err());
        assert!(Tiling {
            tile_px: Some(8),
            overlap_px: 0
        }
        .check()
        .is_err());
    }
}
