//! Spatially varying convolution without seams.
//!
//! PSFs are known at the nodes of a regular grid laid over the image (node columns at
//! x_i = i (W-1)/(nx-1), rows likewise). The output is the **gather** blend
//! out(p) = sum_n w_n(p) (I * K_n)(p), with w_n the bilinear weights of the four nodes around p.
//! The weights are continuous and sum to one, so there is no seam at tile borders, and a constant
//! image stays exactly constant (each I * K_n is constant when K_n sums to one). Borders replicate
//! the edge pixels.
//!
//! A tile (the pixels between two node columns and two node rows) needs the convolutions of its four
//! corner kernels over its own pixels only. They come from direct summation (`direct`, 4 K^2
//! multiply-adds per pixel) or from overlap-save FFTs (`fft`, four transforms of (T + K - 1)^2 per
//! tile of T^2 pixels, whatever K); `Method::Auto` picks the cheaper per tile from a measured cost
//! model. Bands of tiles run in parallel.
//!
//! The work follows the scene (`extent`): each tile's K is the size its own four corner kernels need
//! (all but a `tail` share of their mass, error bound in `extent`), not the field's largest kernel, so
//! the axis tiles of a lens whose corner PSF is large cost a fraction of the corner tiles; tiles whose
//! kernels are deltas need one multiply per corner and pixel, and tiles whose input patch is flat
//! are filled with the constant times the kernels' sums without any convolution.

mod direct;
mod extent;
mod fft;

pub use extent::{centre_crop, half_width_holding, KERNEL_TAIL_TOLERANCE};
pub use fft::fast_len;

use rayon::prelude::*;
use serde::Serialize;
use std::ops::Range;
use unicac_psf::Kernel;
use unicac_trace::InvalidParameter;

/// Node grid and one kernel per node (row-major, `nodes_x * nodes_y`), all of one odd size. Built by
/// [`KernelGrid::new`], which checks that, so the convolutions index it without checks.
pub struct KernelGrid {
    nodes_x: usize,
    nodes_y: usize,
    kernels: Vec<Kernel>,
}

impl KernelGrid {
    pub fn new(nodes_x: usize, nodes_y: usize, kernels: Vec<Kernel>) -> Result<KernelGrid, InvalidParameter> {
        unicac_trace::check_at_least("nodes_x", nodes_x, 1)?;
        unicac_trace::check_at_least("nodes_y", nodes_y, 1)?;
        if kernels.len() != nodes_x * nodes_y {
            return Err(InvalidParameter::new(
                "kernels",
                format!(
                    "{} kernels for {nodes_x} x {nodes_y} nodes: one per node",
                    kernels.len()
                ),
            ));
        }
        let size = kernels[0].size;
        unicac_trace::check_odd("kernels", size)?;
        if let Some(other) = kernels
            .iter()
            .find(|k| k.size != size || k.data.len() != size * size)
        {
            return Err(InvalidParameter::new(
                "kernels",
                format!(
                    "sizes {size} and {} px: all kernels of a grid share one size",
                    other.size
                ),
            ));
        }
        Ok(KernelGrid {
            nodes_x,
            nodes_y,
            kernels,
        })
    }

    pub fn nodes(&self) -> [usize; 2] {
        [self.nodes_x, self.nodes_y]
    }

    pub fn kernels(&self) -> &[Kernel] {
        &self.kernels
    }
}

/// How the corner convolutions of a tile are computed (the result is the same up to f32 rounding).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The cheaper of the two by the cost model.
    Auto,
    Direct,
    Fft,
}

/// How a pixel mixes the convolutions of its tile's four corner kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Blend {
    /// Bilinear weights of the four corners: continuous, no seams (the default).
    Bilinear,
    /// The nearest corner only: piecewise-constant PSFs with seams at the tile mid-lines; kept as the
    /// baseline that shows what blending buys (docs/performance.md).
    Nearest,
}

impl Blend {
    /// Weights of [top-left, top-right, bottom-left, bottom-right] at fractional tile position (tx, ty).
    #[inline]
    fn weights(self, tx: f32, ty: f32) -> [f32; 4] {
        match self {
            Blend::Bilinear => [(1.0 - tx) * (1.0 - ty), tx * (1.0 - ty), (1.0 - tx) * ty, tx * ty],
            Blend::Nearest => {
                let (right, bottom) = (tx >= 0.5, ty >= 0.5);
                let mut w = [0.0; 4];
                w[usize::from(right) + 2 * usize::from(bottom)] = 1.0;
                w
            }
        }
    }
}

/// Node positions along an axis of `length` pixels.
pub fn node_positions(length: usize, nodes: usize) -> Vec<f64> {
    if nodes <= 1 {
        return vec![(length as f64 - 1.0) / 2.0];
    }
    (0..nodes)
        .map(|i| i as f64 * (length as f64 - 1.0) / (nodes - 1) as f64)
        .collect()
}

/// The pixel ranges between consecutive nodes: interval `i` takes the pixels after node i up to and
/// including node i + 1 (the first interval also takes the pixels from 0, the last those to the end).
fn intervals(positions: &[f64], length: usize) -> Vec<Range<usize>> {
    let last = positions.len() - 2;
    (0..=last)
        .map(|i| {
            let start = if i == 0 {
                0
            } else {
                positions[i].floor() as usize + 1
            };
            let end = if i == last {
                length
            } else {
                positions[i + 1].floor() as usize + 1
            };
            start..end
        })
        .collect()
}

/// Relative cost of one FFT butterfly operation against one direct multiply-add, measured with the
/// `convolve` bench (`cargo bench -p unicac-sim`) on the 2-core reference machine.
const FFT_OP_COST: f64 = 0.6;

/// Whether the FFT path is cheaper for tiles of `tile_width` x `tile_height` with `kernel` px kernels.
fn fft_is_cheaper(tile_width: usize, tile_height: usize, kernel: usize) -> bool {
    let direct = 4.0 * (kernel * kernel) as f64 * (tile_width * tile_height) as f64;
    let n = (fft::fast_len(tile_width + kernel - 1) * fft::fast_len(tile_height + kernel - 1)) as f64;
    // One forward and two inverse transforms per tile, plus one kernel-pair transform per node column.
    let transforms = 4.0 * n * n.log2();
    FFT_OP_COST * transforms < direct
}

/// Convolves one plane with the kernel grid, choosing the method per tile.
pub fn convolve_varying(plane: &[f32], width: usize, height: usize, grid: &KernelGrid) -> Vec<f32> {
    convolve_varying_with(
        plane,
        width,
        height,
        grid,
        Method::Auto,
        Blend::Bilinear,
        KERNEL_TAIL_TOLERANCE,
    )
}

/// Convolves one plane with the kernel grid by the given method; `kernel_tail` is the share of each
/// kernel's L1 mass a tile may crop away (`extent`: every output pixel moves by at most
/// `kernel_tail * max|I|` for unit-sum kernels; 0 crops exact zeros only).
pub fn convolve_varying_with(
    plane: &[f32],
    width: usize,
    height: usize,
    grid: &KernelGrid,
    method: Method,
    blend: Blend,
    kernel_tail: f64,
) -> Vec<f32> {
    let mut out = vec![0.0f32; width * height];
    convolve_varying_into(plane, width, height, grid, method, blend, kernel_tail, &mut out);
    out
}

/// Where every pixel sits among the node tiles and how far each tile's corner kernels reach: the plan
/// `convolve_varying_into` follows, made once so that a device running the same blend (unicac-gpu)
/// reads the same tiles, weights and crops instead of re-deriving them.
#[derive(Debug, Clone, PartialEq)]
pub struct TileLayout {
    /// Tiles along x and y (node intervals: nodes - 1 each).
    pub tiles: [usize; 2],
    /// The tile column of each pixel column, and its fractional position across that tile (0 at the
    /// left node, 1 at the right one; the bilinear weights' tx).
    pub column_tile: Vec<u32>,
    pub column_t: Vec<f32>,
    /// Likewise for rows (ty).
    pub row_tile: Vec<u32>,
    pub row_t: Vec<f32>,
    /// Half-width (px) to which each tile's four corner kernels are cropped (row-major over tiles):
    /// the largest `half_width_holding(kernel, kernel_tail)` of its corners.
    pub tile_half_px: Vec<u32>,
    /// The pixel ranges of the tile columns and the tile rows (`intervals`).
    columns: Vec<Range<usize>>,
    rows: Vec<Range<usize>>,
}

impl TileLayout {
    pub fn new(width: usize, height: usize, grid: &KernelGrid, kernel_tail: f64) -> TileLayout {
        assert!(
            grid.nodes_x >= 2 && grid.nodes_y >= 2,
            "need at least 2 x 2 nodes"
        );
        let reaches: Vec<usize> = grid
            .kernels
            .par_iter()
            .map(|k| half_width_holding(k, kernel_tail))
            .collect();
        let (columns, column_tile, column_t) = axis_positions(&node_positions(width, grid.nodes_x), width);
        let (rows, row_tile, row_t) = axis_positions(&node_positions(height, grid.nodes_y), height);
        let tiles = [grid.nodes_x - 1, grid.nodes_y - 1];
        let tile_half_px = (0..tiles[1])
            .flat_map(|j| (0..tiles[0]).map(move |i| (i, j)))
            .map(|(i, j)| {
                let node = |di: usize, dj: usize| (j + dj) * grid.nodes_x + i + di;
                [node(0, 0), node(1, 0), node(0, 1), node(1, 1)]
                    .iter()
                    .map(|&n| reaches[n])
                    .max()
                    .unwrap_or(0) as u32
            })
            .collect();
        TileLayout {
            tiles,
            column_tile,
            column_t,
            row_tile,
            row_t,
            tile_half_px,
            columns,
            rows,
        }
    }

    /// For each tile (row-major), its four corner convolutions when the part of `plane` its kernels
    /// read is flat (the CPU path's shortcut: a device blends these instead of convolving), else None.
    pub fn flat_tiles(&self, plane: &[f32], grid: &KernelGrid) -> Vec<Option<[f32; 4]>> {
        let (width, height) = (self.column_tile.len(), self.row_tile.len());
        assert_eq!(plane.len(), width * height);
        let (columns, rows) = (&self.columns, &self.rows);
        (0..self.tiles[0] * self.tiles[1])
            .into_par_iter()
            .map(|tile| {
                let (i, j) = (tile % self.tiles[0], tile / self.tiles[0]);
                let node = |di: usize, dj: usize| &grid.kernels[(j + dj) * grid.nodes_x + i + di];
                let corners = [node(0, 0), node(1, 0), node(0, 1), node(1, 1)];
                let size = 2 * self.tile_half_px[tile] as usize + 1;
                flat_corners(plane, (width, height), corners, &columns[i], &rows[j], size)
            })
            .collect()
    }
}

/// The intervals among `positions` (`intervals`), each pixel's interval, and its fractional position
/// across it, clamped to 0..1 (pixels before the first node and after the last one take the end
/// intervals' edge weights).
fn axis_positions(positions: &[f64], length: usize) -> (Vec<Range<usize>>, Vec<u32>, Vec<f32>) {
    let ranges = intervals(positions, length);
    let mut tile = vec![0u32; length];
    let mut t = vec![0.0f32; length];
    for (i, range) in ranges.iter().enumerate() {
        let (from, to) = (positions[i], positions[i + 1]);
        for pixel in range.clone() {
            tile[pixel] = i as u32;
            t[pixel] = ((pixel as f64 - from) / (to - from)).clamp(0.0, 1.0) as f32;
        }
    }
    (ranges, tile, t)
}

/// `convolve_varying_with` into a buffer the caller owns (every pixel of `out` is written): a 12 MP
/// simulation writes its three planes straight into one image instead of copying them there, which
/// spares 144 MB of freshly faulted memory per image (page faults and page clearing were ~20% of the
/// 12 MP profile on the 2-core machine).
#[allow(clippy::too_many_arguments)]
pub fn convolve_varying_into(
    plane: &[f32],
    width: usize,
    height: usize,
    grid: &KernelGrid,
    method: Method,
    blend: Blend,
    kernel_tail: f64,
    out: &mut [f32],
) {
    assert_eq!(grid.kernels.len(), grid.nodes_x * grid.nodes_y);
    let layout = TileLayout::new(width, height, grid, kernel_tail);
    convolve_varying_laid_out(plane, width, height, grid, &layout, method, blend, out);
}

/// `convolve_varying_into` with its tile layout made by the caller (`TileLayout::new` of the same
/// plane size, grid and tail).
#[allow(clippy::too_many_arguments)]
pub fn convolve_varying_laid_out(
    plane: &[f32],
    width: usize,
    height: usize,
    grid: &KernelGrid,
    layout: &TileLayout,
    method: Method,
    blend: Blend,
    out: &mut [f32],
) {
    assert_eq!(plane.len(), width * height);
    assert_eq!(out.len(), width * height);
    assert_eq!(
        (layout.column_tile.len(), layout.row_tile.len()),
        (width, height),
        "a layout of this plane's size"
    );
    let (columns, bands) = (&layout.columns, &layout.rows);
    let mut slices: Vec<&mut [f32]> = Vec::with_capacity(bands.len());
    let mut rest = out;
    for rows in bands {
        let (band, tail) = rest.split_at_mut(rows.len() * width);
        slices.push(band);
        rest = tail;
    }
    slices
        .into_par_iter()
        .zip(bands.par_iter().enumerate())
        .for_each(|(band, (j, rows))| {
            let mut tile_fft = fft::TileFft::new();
            for (i, tile_columns) in columns.iter().enumerate() {
                let node = |di: usize, dj: usize| (j + dj) * grid.nodes_x + i + di;
                let nodes = [node(0, 0), node(1, 0), node(0, 1), node(1, 1)];
                let corners = nodes.map(|n| &grid.kernels[n]);
                let size = 2 * layout.tile_half_px[j * layout.tiles[0] + i] as usize + 1;
                let tile = Tile {
                    columns: tile_columns,
                    rows,
                    tx: &layout.column_t[tile_columns.clone()],
                    ty: &layout.row_t[rows.clone()],
                    blend,
                };
                if let Some(sums) = flat_corners(plane, (width, height), corners, tile_columns, rows, size) {
                    tile.blend(band, width, |_, _, _| sums);
                    continue;
                }
                let use_fft = match method {
                    Method::Direct => false,
                    Method::Fft => true,
                    Method::Auto => fft_is_cheaper(tile_columns.len(), rows.len(), size),
                };
                if use_fft {
                    let kernels = fft::TileKernels {
                        corners,
                        columns: (i, i + 1),
                    };
                    let values =
                        tile_fft.convolve_tile(plane, (width, height), &kernels, size, tile_columns, rows);
                    tile.blend(band, width, |column, row, _| values.at(column, row));
                } else {
                    let cropped = corners.map(|k| centre_crop(k, size));
                    tile.blend(band, width, |column, row, weights| {
                        let mut values = [0.0; 4];
                        for ((value, kernel), w) in values.iter_mut().zip(&cropped).zip(weights) {
                            // A corner whose weight is zero here costs nothing.
                            if w != 0.0 {
                                *value = direct::convolve_at(plane, width, height, kernel, column, row);
                            }
                        }
                        values
                    });
                }
            }
        });
}

/// The four corner convolutions of a tile whose input patch is flat (`flat_value`): the value times
/// each cropped kernel's sum, what any convolution gives there, without convolving; None otherwise.
fn flat_corners(
    plane: &[f32],
    dims: (usize, usize),
    corners: [&Kernel; 4],
    columns: &Range<usize>,
    rows: &Range<usize>,
    size: usize,
) -> Option<[f32; 4]> {
    let value = flat_value(plane, dims, columns, rows, size)?;
    Some(corners.map(|k| value * centre_crop(k, size).data.iter().sum::<f32>()))
}

/// The value of the input patch a tile's `size` px kernels read (the tile grown by size / 2 on every
/// side, clamped to the image like the replicated borders), if every pixel of it has that value.
fn flat_value(
    plane: &[f32],
    (width, height): (usize, usize),
    columns: &Range<usize>,
    rows: &Range<usize>,
    size: usize,
) -> Option<f32> {
    let half = size / 2;
    let x = columns.start.saturating_sub(half)..(columns.end + half).min(width);
    let y = rows.start.saturating_sub(half)..(rows.end + half).min(height);
    let value = plane[y.start * width + x.start];
    y.into_iter()
        .all(|row| plane[row * width..][x.clone()].iter().all(|&v| v == value))
        .then_some(value)
}

/// The pixels between two node columns and two node rows.
struct Tile<'a> {
    columns: &'a Range<usize>,
    rows: &'a Range<usize>,
    /// The layout's fractional positions of the tile's columns and rows.
    tx: &'a [f32],
    ty: &'a [f32],
    blend: Blend,
}

impl Tile<'_> {
    /// Writes sum_k w_k corner_k into the band, with `corners(column, row, weights)` giving the four
    /// corner convolutions [top-left, top-right, bottom-left, bottom-right] at a pixel.
    fn blend(&self, band: &mut [f32], width: usize, corners: impl Fn(usize, usize, [f32; 4]) -> [f32; 4]) {
        for (row, &ty) in self.rows.clone().zip(self.ty) {
            let target = &mut band[(row - self.rows.start) * width..][..width];
            for (column, &tx) in self.columns.clone().zip(self.tx) {
                let weights = self.blend.weights(tx, ty);
                let values = corners(column, row, weights);
                target[column] = values.iter().zip(weights).map(|(v, w)| v * w).sum();
            }
        }
    }
}

/// Kernel width from which `convolve_invariant` uses the FFT instead of direct summation (direct costs
/// K^2 per pixel, the FFT a few hundred operations per pixel whatever K).
pub const FFT_FROM_KERNEL_PX: usize = 15;

/// One kernel over the whole plane, replicated borders: direct for small kernels, FFT (f64) for large ones.
pub fn convolve_invariant(plane: &[f32], width: usize, height: usize, kernel: &Kernel) -> Vec<f32> {
    if kernel.size < FFT_FROM_KERNEL_PX {
        return convolve_direct(plane, width, height, kernel, Borders::Replicated);
    }
    fft::convolve_invariant_fft(plane, width, height, &[kernel], false, Borders::Replicated)
        .pop()
        .expect("one kernel, one plane")
}

/// Which output pixels an invariant convolution computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Borders {
    /// Every pixel, the plane's border pixels replicated outward (as `convolve_invariant`).
    Replicated,
    /// Only the pixels whose kernel footprint lies inside the plane (at least `kernel_px / 2` from every
    /// edge); the others are 0. For callers that score an interior region only (the ODE's charts): the
    /// transforms need no padding, about half the work for a 127 px kernel on a 384 px chart.
    Interior,
}

impl Borders {
    /// The output indices computed along an axis of `len` pixels for a kernel reaching `half` px either
    /// side (empty when the kernel is wider than the plane and `Interior` is asked for).
    fn computed(self, len: usize, half: usize) -> std::ops::Range<usize> {
        match self {
            Borders::Replicated => 0..len,
            Borders::Interior => half..len.saturating_sub(half).max(half),
        }
    }
}

/// `plane` convolved with each of `kernels` (all of one size), as `convolve_invariant` would one at a time
/// (on the pixels `borders` asks for); large kernels share the plane's transform and go two to a transform
/// (f32 results within an ulp).
pub fn convolve_invariant_many(
    plane: &[f32],
    width: usize,
    height: usize,
    kernels: &[&Kernel],
    borders: Borders,
) -> Vec<Vec<f32>> {
    if kernels.first().is_some_and(|k| k.size >= FFT_FROM_KERNEL_PX) {
        fft::convolve_invariant_fft(plane, width, height, kernels, false, borders)
    } else {
        kernels
            .iter()
            .map(|k| convolve_direct(plane, width, height, k, borders))
            .collect()
    }
}

/// Direct summation at the pixels `borders` asks for (0 elsewhere).
fn convolve_direct(
    plane: &[f32],
    width: usize,
    height: usize,
    kernel: &Kernel,
    borders: Borders,
) -> Vec<f32> {
    let (columns, rows) = (
        borders.computed(width, kernel.half()),
        borders.computed(height, kernel.half()),
    );
    let inside = |x: usize, y: usize| columns.contains(&x) && rows.contains(&y);
    (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % width, i / width);
            if inside(x, y) {
                direct::convolve_at(plane, width, height, kernel, x, y)
            } else {
                0.0
            }
        })
        .collect()
}

/// A square `side` x `side` plane P and its transpose P^T, each convolved with each of `kernels` (all of
/// one size): per kernel `[P * K, P^T * K]`, as `convolve_invariant_many` would give them for the two
/// planes. Large kernels take P's transform only (P^T * K is (P * K^T)^T, and K^T's spectrum is K's
/// transposed): one plane transform and one transform per kernel pair fewer (f32 results within an ulp).
pub fn convolve_invariant_many_and_transpose(
    plane: &[f32],
    side: usize,
    kernels: &[&Kernel],
    borders: Borders,
) -> Vec<[Vec<f32>; 2]> {
    assert_eq!(plane.len(), side * side, "a square plane");
    if kernels.first().is_some_and(|k| k.size >= FFT_FROM_KERNEL_PX) {
        let mut views = fft::convolve_invariant_fft(plane, side, side, kernels, true, borders).into_iter();
        kernels
            .iter()
            .map(|_| [views.next().expect("P * K"), views.next().expect("P^T * K")])
            .collect()
    } else {
        let transposed: Vec<f32> = (0..side * side)
            .map(|i| plane[(i % side) * side + i / side])
            .collect();
        kernels
            .iter()
            .map(|k| {
                [
                    convolve_direct(plane, side, side, k, borders),
                    convolve_direct(&transposed, side, side, k, borders),
                ]
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both methods, with the rounding each allows (f32 sums; f32 transforms of a few thousand points).
    const METHODS: [(Method, f32); 2] = [(Method::Direct, 1e-6), (Method::Fft, 2e-6)];

    fn delta(size: usize) -> Kernel {
        let mut k = Kernel::zeros(size, 1.0);
        k.data[size * size / 2] = 1.0;
        k
    }

    fn boxed(size: usize) -> Kernel {
        let mut k = Kernel::zeros(size, 1.0);
        k.data.iter_mut().for_each(|v| *v = 1.0);
        k.normalise();
        k
    }

    #[test]
    fn fft_and_direct_convolution_agree() {
        let (w, h) = (53, 41);
        let plane: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 101) as f32 / 101.0).collect();
        let mut k = Kernel::zeros(17, 1.0);
        k.data
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = 1.0 + ((i * 31) % 7) as f32);
        k.normalise();
        let fft = convolve_invariant(&plane, w, h, &k);
        let direct: Vec<f32> = (0..w * h)
            .map(|i| direct::convolve_at(&plane, w, h, &k, i % w, i / w))
            .collect();
        let worst = fft
            .iter()
            .zip(&direct)
            .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst < 1e-5, "{worst}");
    }

    /// A kernel of `size` px with a pseudo-random positive profile, normalised.
    fn textured(size: usize, seed: usize) -> Kernel {
        let mut k = Kernel::zeros(size, 1.0);
        k.data
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = 1.0 + ((i * 31 + seed * 17) % 11) as f32);
        k.normalise();
        k
    }

    #[test]
    fn many_kernels_at_once_equal_one_at_a_time() {
        let (w, h) = (53, 41);
        let plane: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 101) as f32 / 100.0).collect();
        for size in [5, 21] {
            let kernels: Vec<Kernel> = (0..5).map(|seed| textured(size, seed)).collect();
            let refs: Vec<&Kernel> = kernels.iter().collect();
            let many = convolve_invariant_many(&plane, w, h, &refs, Borders::Replicated);
            assert_eq!(many.len(), 5);
            for (kernel, out) in kernels.iter().zip(&many) {
                let one = convolve_invariant(&plane, w, h, kernel);
                let worst = one
                    .iter()
                    .zip(out)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0f32, f32::max);
                assert!(worst <= 2.0 * f32::EPSILON, "size {size}: {worst}");
            }
        }
        assert!(convolve_invariant_many(&plane, w, h, &[], Borders::Replicated).is_empty());
    }

    /// A square plane that is not symmetric under transposition.
    fn asymmetric_plane(side: usize) -> Vec<f32> {
        (0..side * side)
            .map(|i| ((i * 7919 + (i / side) * 13) % 101) as f32 / 100.0)
            .collect()
    }

    #[test]
    fn interior_convolution_equals_the_replicated_one_inside_and_is_zero_outside() {
        // Direct (5 px) and FFT (21 px) kernels; even and odd sides, and a plane narrower than the large
        // kernel (no interior: all 0); the transposed view as well.
        for (side, size) in [(46, 5), (46, 21), (37, 5), (37, 21), (9, 21)] {
            let plane = asymmetric_plane(side);
            let kernels: Vec<Kernel> = (0..3).map(|seed| textured(size, seed)).collect();
            let refs: Vec<&Kernel> = kernels.iter().collect();
            let half = size / 2;
            let inside = |i: usize| {
                let (x, y) = (i % side, i / side);
                side > 2 * half && (half..side - half).contains(&x) && (half..side - half).contains(&y)
            };
            let full = convolve_invariant_many_and_transpose(&plane, side, &refs, Borders::Replicated);
            let interior = convolve_invariant_many_and_transpose(&plane, side, &refs, Borders::Interior);
            let single = convolve_invariant_many(&plane, side, side, &refs, Borders::Interior);
            for ((full, interior), single) in full.iter().zip(&interior).zip(&single) {
                for (view, (f, g)) in full.iter().zip(interior).enumerate() {
                    for (i, (a, b)) in f.iter().zip(g).enumerate() {
                        if inside(i) {
                            assert!(
                                (a - b).abs() <= 2.0 * f32::EPSILON,
                                "side {side} size {size} view {view} at {i}: {a} {b}"
                            );
                        } else {
                            assert_eq!(*b, 0.0, "side {side} size {size} view {view} at {i}");
                        }
                    }
                }
                assert_eq!(
                    &interior[0], single,
                    "side {side} size {size}: the plain view is the single-view result"
                );
            }
        }
    }

    #[test]
    fn a_plane_and_its_transpose_at_once_equal_each_alone() {
        // An asymmetric plane and asymmetric kernels, so a wrong transpose (of the spectrum or of the
        // read-out) cannot pass.
        let side = 37;
        let plane = asymmetric_plane(side);
        let transposed: Vec<f32> = (0..side * side)
            .map(|i| plane[(i % side) * side + i / side])
            .collect();
        for size in [5, 21] {
            // Odd count: the last kernel goes alone through the packed path.
            let kernels: Vec<Kernel> = (0..3).map(|seed| textured(size, seed)).collect();
            let refs: Vec<&Kernel> = kernels.iter().collect();
            let both = convolve_invariant_many_and_transpose(&plane, side, &refs, Borders::Replicated);
            assert_eq!(both.len(), 3);
            for (kernel, [direct, transpose]) in kernels.iter().zip(&both) {
                for (expected, got) in [
                    (convolve_invariant(&plane, side, side, kernel), direct),
                    (convolve_invariant(&transposed, side, side, kernel), transpose),
                ] {
                    let worst = expected
                        .iter()
                        .zip(got)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0f32, f32::max);
                    assert!(worst <= 2.0 * f32::EPSILON, "size {size}: {worst}");
                }
            }
        }
    }

    #[test]
    fn nearest_blending_takes_the_nearest_node_only() {
        // Left nodes keep the image, right nodes zero it: nearest gives a hard step at the tile middle,
        // bilinear a ramp.
        let (w, h) = (21, 5);
        let plane = vec![1.0f32; w * h];
        let zero = Kernel::zeros(1, 1.0);
        let grid = KernelGrid {
            nodes_x: 2,
            nodes_y: 2,
            kernels: vec![delta(1), zero.clone(), delta(1), zero],
        };
        let nearest = convolve_varying_with(&plane, w, h, &grid, Method::Direct, Blend::Nearest, 0.0);
        let bilinear = convolve_varying_with(&plane, w, h, &grid, Method::Direct, Blend::Bilinear, 0.0);
        assert_eq!(&nearest[..w], &[[1.0; 10].as_slice(), &[0.0; 11]].concat());
        assert!((bilinear[5] - 0.75).abs() < 1e-6);
    }

    #[test]
    fn fft_and_direct_varying_convolutions_agree() {
        // Odd image sizes, uneven tiles, kernels larger than a tile and kernels reaching past the image.
        for (w, h, nodes_x, nodes_y, size) in [(61, 47, 4, 3, 9), (45, 38, 3, 5, 21), (30, 33, 2, 2, 31)] {
            let plane: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 101) as f32 / 101.0).collect();
            let grid = KernelGrid {
                nodes_x,
                nodes_y,
                kernels: (0..nodes_x * nodes_y).map(|n| textured(size, n)).collect(),
            };
            let direct = convolve_varying_with(&plane, w, h, &grid, Method::Direct, Blend::Bilinear, 0.0);
            let fft = convolve_varying_with(&plane, w, h, &grid, Method::Fft, Blend::Bilinear, 0.0);
            let worst = fft
                .iter()
                .zip(&direct)
                .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
            // f32 transforms of ~1e4 points: rounding near 1e-6 of the signal.
            assert!(worst < 2e-5, "{w}x{h}, K={size}: {worst}");
        }
    }

    /// A normalised kernel of `size` px: a textured core of half-width `core` plus a faint tail of
    /// total mass `tail_mass` spread over the outer ring.
    fn cored(size: usize, core: usize, tail_mass: f32, seed: usize) -> Kernel {
        let mut k = Kernel::zeros(size, 1.0);
        let half = size / 2;
        let ring = 8 * half;
        for y in 0..size {
            for x in 0..size {
                let d = x.abs_diff(half).max(y.abs_diff(half));
                k.data[y * size + x] = if d <= core {
                    1.0 + ((x * 31 + y * 7 + seed * 17) % 11) as f32
                } else {
                    0.0
                };
            }
        }
        k.normalise();
        for y in 0..size {
            for x in 0..size {
                if x.abs_diff(half).max(y.abs_diff(half)) == half {
                    k.data[y * size + x] += tail_mass / ring as f32;
                }
            }
        }
        k
    }

    #[test]
    fn cropping_to_the_local_extent_stays_within_its_stated_bound() {
        // Kernels whose cores range from a delta (axis) to the full size (corner), each with a faint
        // tail; an image with a flat half (flat tiles are filled without convolving) and a textured one.
        let (w, h, size) = (97, 71, 25);
        let plane: Vec<f32> = (0..w * h)
            .map(|i| {
                if i % w < 40 {
                    0.6
                } else {
                    ((i * 7919) % 101) as f32 / 101.0
                }
            })
            .collect();
        let (nodes_x, nodes_y) = (5, 4);
        let kernels: Vec<Kernel> = (0..nodes_x * nodes_y)
            .map(|n| cored(size, [0, 1, 3, 6, 12][n % nodes_x].min(size / 2), 1e-4, n))
            .collect();
        let grid = KernelGrid {
            nodes_x,
            nodes_y,
            kernels,
        };
        let l1 = grid
            .kernels
            .iter()
            .map(|k| k.data.iter().map(|v| v.abs() as f64).sum::<f64>());
        let largest_l1 = l1.fold(0.0f64, f64::max);
        let max_input = plane.iter().fold(0.0f32, |m, v| m.max(v.abs())) as f64;
        let reference = full_kernel_reference(&plane, w, h, &grid);
        // 1e-3 crops the 1e-4 tails (kernels shrink to their cores), 1e-5 must keep them.
        for (tail, crops) in [(1e-3, true), (1e-5, false)] {
            assert_eq!(
                half_width_holding(&grid.kernels[0], tail) < size / 2,
                crops,
                "tail {tail}"
            );
            // The stated bound plus f32 rounding of the FFT (as in the tests above).
            let bound = tail * largest_l1 * max_input + 2e-5;
            for method in [Method::Direct, Method::Fft, Method::Auto] {
                let out = convolve_varying_with(&plane, w, h, &grid, method, Blend::Bilinear, tail);
                let worst = out
                    .iter()
                    .zip(&reference)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs() as f64));
                assert!(worst <= bound, "tail {tail}, {method:?}: {worst} > {bound}");
            }
        }
    }

    /// Every pixel by direct summation with the four full corner kernels, blended: no cropping, no
    /// flat-tile shortcut.
    fn full_kernel_reference(plane: &[f32], w: usize, h: usize, grid: &KernelGrid) -> Vec<f32> {
        let xs = node_positions(w, grid.nodes_x);
        let ys = node_positions(h, grid.nodes_y);
        let mut out = vec![0.0f32; w * h];
        for (j, rows) in intervals(&ys, h).iter().enumerate() {
            let band = &mut out[rows.start * w..rows.end * w];
            for (i, columns) in intervals(&xs, w).iter().enumerate() {
                let node = |di: usize, dj: usize| &grid.kernels[(j + dj) * grid.nodes_x + i + di];
                let corners = [node(0, 0), node(1, 0), node(0, 1), node(1, 1)];
                // The blend positions derived here again, independently of `TileLayout`.
                let across = |pixels: &Range<usize>, from: f64, to: f64| -> Vec<f32> {
                    let t = |p: usize| ((p as f64 - from) / (to - from)).clamp(0.0, 1.0) as f32;
                    pixels.clone().map(t).collect()
                };
                let (tx, ty) = (across(columns, xs[i], xs[i + 1]), across(rows, ys[j], ys[j + 1]));
                let tile = Tile {
                    columns,
                    rows,
                    tx: &tx,
                    ty: &ty,
                    blend: Blend::Bilinear,
                };
                tile.blend(band, w, |column, row, _| {
                    corners.map(|k| direct::convolve_at(plane, w, h, k, column, row))
                });
            }
        }
        out
    }

    #[test]
    fn the_tile_layout_holds_the_node_intervals_even_when_some_are_empty() {
        // 9 nodes over 6 px: intervals of under a pixel, some holding no pixel at all.
        for (length, nodes) in [(37, 3), (23, 4), (6, 9), (2, 2)] {
            let grid = KernelGrid {
                nodes_x: nodes,
                nodes_y: 2,
                kernels: (0..2 * nodes).map(|_| delta(3)).collect(),
            };
            let layout = TileLayout::new(length, 5, &grid, 0.0);
            assert_eq!(
                layout.columns,
                intervals(&node_positions(length, nodes), length),
                "{length} px, {nodes} nodes"
            );
            // Every pixel lies in exactly the tile its per-pixel entry (the GPU's view) names.
            for (pixel, &tile) in layout.column_tile.iter().enumerate() {
                let holding: Vec<usize> = (layout.columns.iter().enumerate())
                    .filter(|(_, r)| r.contains(&pixel))
                    .map(|(i, _)| i)
                    .collect();
                assert_eq!(
                    holding,
                    vec![tile as usize],
                    "{length} px, {nodes} nodes, pixel {pixel}"
                );
            }
            assert!(layout.column_t.iter().all(|t| (0.0..=1.0).contains(t)));
            assert_eq!(
                layout.tile_half_px,
                vec![0; nodes - 1],
                "delta kernels reach nowhere"
            );
        }
    }

    #[test]
    fn delta_kernels_are_the_identity() {
        let (w, h) = (37, 23);
        let plane: Vec<f32> = (0..w * h).map(|i| (i as f32 * 0.37).sin()).collect();
        let grid = KernelGrid {
            nodes_x: 3,
            nodes_y: 4,
            kernels: (0..12).map(|_| delta(5)).collect(),
        };
        for (method, tolerance) in METHODS {
            let out = convolve_varying_with(&plane, w, h, &grid, method, Blend::Bilinear, 0.0);
            // Bilinear weights sum to one up to f32 rounding.
            assert!(
                out.iter().zip(&plane).all(|(a, b)| (a - b).abs() < tolerance),
                "{method:?}"
            );
        }
    }

    #[test]
    fn constant_images_stay_constant_with_varying_kernels() {
        let (w, h) = (40, 30);
        let plane = vec![0.37f32; w * h];
        let kernels = (0..9)
            .map(|i| if i % 2 == 0 { boxed(7) } else { delta(7) })
            .collect();
        let grid = KernelGrid {
            nodes_x: 3,
            nodes_y: 3,
            kernels,
        };
        for (method, tolerance) in METHODS {
            let out = convolve_varying_with(&plane, w, h, &grid, method, Blend::Bilinear, 0.0);
            assert!(out.iter().all(|v| (v - 0.37).abs() < tolerance), "{method:?}");
        }
    }

    #[test]
    fn a_shifted_delta_shifts_the_image() {
        // Kernel with its mass one pixel right of centre moves content one pixel right.
        let (w, h) = (16, 8);
        let plane: Vec<f32> = (0..w * h).map(|i| (i % w) as f32).collect();
        let mut k = Kernel::zeros(3, 1.0);
        k.data[3 + 2] = 1.0;
        let grid = KernelGrid {
            nodes_x: 2,
            nodes_y: 2,
            kernels: vec![k.clone(), k.clone(), k.clone(), k],
        };
        for (method, tolerance) in METHODS {
            let out = convolve_varying_with(&plane, w, h, &grid, method, Blend::Bilinear, 0.0);
            // Values up to 15: the FFT's rounding is relative to the signal.
            assert!((out[3 * w + 5] - 4.0).abs() < 15.0 * tolerance, "{method:?}");
            assert!(out[3 * w].abs() < 15.0 * tolerance, "{method:?}");
        }
    }
}
