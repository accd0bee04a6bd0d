//! RGGB Bayer colour filter array (Bayer, US patent 3,971,065, 1976): sampling an RGB image into a 1-channel
//! mosaic, and demosaicing it back with bilinear interpolation or with the gradient-corrected linear
//! interpolation of Malvar, He & Cutler, "High-quality linear interpolation for demosaicing of
//! Bayer-patterned color images", ICASSP 2004 (the eight 5x5 filters of their Fig. 2).
//!
//! Both demosaicers are the same 5x5 linear filter bank, one kernel per (photosite colour, missing colour);
//! only the table differs (Malvar's filters are bilinear interpolation plus a scaled Laplacian of the
//! channel present at the site). Borders are handled by mirror reflection without repeating the edge sample
//! (index -1 -> 1), which keeps the parity of every index and therefore the CFA colour of every tap.
//! Hand-written: no maintained Rust crate implements Malvar-He-Cutler on f32 planes.

use crate::error::{check_layout, Result};
use crate::Planar;
use rayon::prelude::*;

/// RGB channel (0 = R, 1 = G, 2 = B) of the filter over photosite (x, y) of an RGGB mosaic: R at even
/// row/even column, B at odd row/odd column, G elsewhere.
pub fn rggb_channel(x: usize, y: usize) -> usize {
    match (y % 2, x % 2) {
        (0, 0) => 0,
        (1, 1) => 2,
        _ => 1,
    }
}

/// 1-channel RGGB mosaic of a 3-channel RGB image: each photosite keeps the channel its filter passes.
pub fn mosaic_rggb(rgb: &Planar) -> Result<Planar> {
    check_layout(rgb, "rgb", &[3])?;
    Ok(Planar::from_fn_parallel(rgb.width, rgb.height, 1, |_, x, y| {
        rgb.get(rggb_channel(x, y), x, y)
    }))
}

/// Demosaicing method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Demosaic {
    /// Average of the nearest samples of the missing colour (2 or 4 taps).
    Bilinear,
    /// Malvar-He-Cutler 2004 gradient-corrected 5x5 filters (the default of DeepLens' ISP).
    MalvarHeCutler,
}

/// 5x5 filter, row-major, applied centred on the photosite.
type Kernel = [[f32; 5]; 5];

/// Which kernel interpolates a missing colour, by where that colour sits around the photosite.
#[derive(Clone, Copy)]
enum Neighbours {
    /// The photosite has the colour itself.
    Own,
    /// Green at a red or blue site (4-connected neighbours).
    Cross,
    /// Red/blue at a green site whose row holds that colour (left and right neighbours).
    Row,
    /// Red/blue at a green site whose column holds that colour (up and down neighbours).
    Column,
    /// Red at a blue site or blue at a red site (diagonal neighbours).
    Diagonal,
}

/// Kernel choice per RGGB site (R, G in red row, G in blue row, B) and output channel (R, G, B).
const SITES: [[Neighbours; 3]; 4] = {
    use Neighbours::*;
    [
        [Own, Cross, Diagonal], // red site
        [Row, Own, Column],     // green site in a red row
        [Column, Own, Row],     // green site in a blue row
        [Diagonal, Cross, Own], // blue site
    ]
};

const BILINEAR_CROSS: Kernel = [
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.25, 0.0, 0.0],
    [0.0, 0.25, 0.0, 0.25, 0.0],
    [0.0, 0.0, 0.25, 0.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0],
];
const BILINEAR_ROW: Kernel = [
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.5, 0.0, 0.5, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0],
];
const BILINEAR_COLUMN: Kernel = transpose(BILINEAR_ROW);
const BILINEAR_DIAGONAL: Kernel = [
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.25, 0.0, 0.25, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.25, 0.0, 0.25, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0],
];

/// Malvar-He-Cutler Fig. 2, "G at R locations" (and at B), coefficients / 8.
const MALVAR_CROSS: Kernel = scale([
    [0.0, 0.0, -1.0, 0.0, 0.0],
    [0.0, 0.0, 2.0, 0.0, 0.0],
    [-1.0, 2.0, 4.0, 2.0, -1.0],
    [0.0, 0.0, 2.0, 0.0, 0.0],
    [0.0, 0.0, -1.0, 0.0, 0.0],
]);
/// Malvar-He-Cutler Fig. 2, "R at green in R row, B column" (and B at green in B row), / 8.
const MALVAR_ROW: Kernel = scale([
    [0.0, 0.0, 0.5, 0.0, 0.0],
    [0.0, -1.0, 0.0, -1.0, 0.0],
    [-1.0, 4.0, 5.0, 4.0, -1.0],
    [0.0, -1.0, 0.0, -1.0, 0.0],
    [0.0, 0.0, 0.5, 0.0, 0.0],
]);
/// Malvar-He-Cutler Fig. 2, "R at green in B row, R column": the transpose of the row filter.
const MALVAR_COLUMN: Kernel = transpose(MALVAR_ROW);
/// Malvar-He-Cutler Fig. 2, "R at blue in B row, B column" (and B at red), / 8.
const MALVAR_DIAGONAL: Kernel = scale([
    [0.0, 0.0, -1.5, 0.0, 0.0],
    [0.0, 2.0, 0.0, 2.0, 0.0],
    [-1.5, 0.0, 6.0, 0.0, -1.5],
    [0.0, 2.0, 0.0, 2.0, 0.0],
    [0.0, 0.0, -1.5, 0.0, 0.0],
]);

const fn scale(mut kernel: Kernel) -> Kernel {
    let mut j = 0;
    while j < 5 {
        let mut i = 0;
        while i < 5 {
            kernel[j][i] /= 8.0;
            i += 1;
        }
        j += 1;
    }
    kernel
}

const fn transpose(kernel: Kernel) -> Kernel {
    let mut out = [[0.0; 5]; 5];
    let mut j = 0;
    while j < 5 {
        let mut i = 0;
        while i < 5 {
            out[i][j] = kernel[j][i];
            i += 1;
        }
        j += 1;
    }
    out
}

impl Demosaic {
    fn kernel(self, neighbours: Neighbours) -> Option<&'static Kernel> {
        match (self, neighbours) {
            (_, Neighbours::Own) => None,
            (Demosaic::Bilinear, Neighbours::Cross) => Some(&BILINEAR_CROSS),
            (Demosaic::Bilinear, Neighbours::Row) => Some(&BILINEAR_ROW),
            (Demosaic::Bilinear, Neighbours::Column) => Some(&BILINEAR_COLUMN),
            (Demosaic::Bilinear, Neighbours::Diagonal) => Some(&BILINEAR_DIAGONAL),
            (Demosaic::MalvarHeCutler, Neighbours::Cross) => Some(&MALVAR_CROSS),
            (Demosaic::MalvarHeCutler, Neighbours::Row) => Some(&MALVAR_ROW),
            (Demosaic::MalvarHeCutler, Neighbours::Column) => Some(&MALVAR_COLUMN),
            (Demosaic::MalvarHeCutler, Neighbours::Diagonal) => Some(&MALVAR_DIAGONAL),
        }
    }
}

/// Mirror index into 0..n without repeating the edge sample (period 2(n - 1); parity preserved).
fn reflect(index: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let period = 2 * (n as isize - 1);
    let m = index.rem_euclid(period);
    (if m >= n as isize { period - m } else { m }) as usize
}

/// Non-zero taps of a kernel as (row offset 0..5, column offset 0..5, weight), in row-major order: the
/// order the sum has always been taken in, so results stay bit-identical.
pub type Taps = Vec<(usize, usize, f32)>;

/// The [`Taps`] of `kernel`.
fn nonzero_taps(kernel: &Kernel) -> Taps {
    let mut taps = Vec::new();
    for (j, weights) in kernel.iter().enumerate() {
        for (i, &weight) in weights.iter().enumerate() {
            if weight != 0.0 {
                taps.push((j, i, weight));
            }
        }
    }
    taps
}

/// The filter bank of `method` as the [`Taps`] each RGGB site (0 red, 1 green in a red row, 2 green in
/// a blue row, 3 blue: 2 (y % 2) + x % 2) sums for each output channel; None: the site's own sample.
/// Tap (j, i) reads row y + j - 2 and column x + i - 2, mirrored at the borders (`reflect`).
pub fn demosaic_taps(method: Demosaic) -> [[Option<Taps>; 3]; 4] {
    std::array::from_fn(|site| {
        std::array::from_fn(|channel| method.kernel(SITES[site][channel]).map(nonzero_taps))
    })
}

/// RGB image from a 1-channel RGGB mosaic. Output values are not clipped (Malvar's filters can overshoot
/// slightly at edges); any width and height work.
///
/// Every output sample is the sum of its taps in [`Taps`] order, whatever the path: the columns whose
/// taps all lie inside the row are summed a row at a time over contiguous halves of the rows (even and
/// odd columns: one site of the pattern each), which the compiler vectorises for the machine's
/// instruction set; the two columns at each edge, whose taps reflect, one sample at a time. The same
/// IEEE operations in the same order on both paths, so the same bits (tested).
pub fn demosaic(mosaic: &Planar, method: Demosaic) -> Result<Planar> {
    check_layout(mosaic, "mosaic", &[1])?;
    let (width, height) = (mosaic.width, mosaic.height);
    let raw = mosaic.plane(0);
    let plan = demosaic_taps(method);
    let columns = reflected_columns(width);
    let mut rgb = Planar::new(width, height, 3);
    if width == 0 {
        return Ok(rgb);
    }
    let interior = 2..width.saturating_sub(2).max(2);
    let arch = pulp::Arch::new();
    // Rows in parallel, each output sample on its own: the result does not depend on the threads.
    let (red, green_blue) = rgb.data.split_at_mut(width * height);
    let (green, blue) = green_blue.split_at_mut(width * height);
    red.par_chunks_mut(width)
        .zip(green.par_chunks_mut(width))
        .zip(blue.par_chunks_mut(width))
        .enumerate()
        .for_each_init(RowScratch::default, |scratch, (y, ((r, g), b))| {
            let rows = reflected_rows(y, height, width);
            let out = [r, g, b];
            if !interior.is_empty() {
                scratch.split_rows(raw, &rows, width);
                let own_row = &raw[y * width..(y + 1) * width];
                for parity in 0..2 {
                    let site = 2 * (y % 2) + parity;
                    let half = InteriorHalfRow { parity, width };
                    for (channel, taps) in plan[site].iter().enumerate() {
                        half.fill(out[channel], taps.as_deref(), own_row, scratch, arch);
                    }
                }
            }
            for x in (0..width).filter(|x| !interior.contains(x)) {
                let site = 2 * (y % 2) + x % 2;
                for (channel, taps) in plan[site].iter().enumerate() {
                    out[channel][x] = demosaiced_sample(raw, taps.as_deref(), &rows, &columns, x, y * width);
                }
            }
        });
    Ok(rgb)
}

/// Start offsets of the five rows y - 2 ..= y + 2 that row y's taps read, mirrored at the borders.
fn reflected_rows(y: usize, height: usize, width: usize) -> [usize; 5] {
    std::array::from_fn(|j| reflect(y as isize + j as isize - 2, height) * width)
}

/// The interior columns of one parity in one output row: x = 2k + parity for k in 1 .. (width - 1 -
/// parity) / 2, the columns whose taps all lie inside the row.
struct InteriorHalfRow {
    parity: usize,
    width: usize,
}

impl InteriorHalfRow {
    /// Writes this half of one channel's output row: the site's own sample (`taps` None, read from
    /// `own_row`) or its tap sums over the halves `scratch` holds for this row.
    fn fill(
        &self,
        out: &mut [f32],
        taps: Option<&[(usize, usize, f32)]>,
        own_row: &[f32],
        scratch: &mut RowScratch,
        arch: pulp::Arch,
    ) {
        let parity = self.parity;
        let ks = 1..(self.width - 1 - parity) / 2;
        match taps {
            None => ks.for_each(|k| out[2 * k + parity] = own_row[2 * k + parity]),
            Some(taps) => {
                scratch.sums.clear();
                scratch.sums.resize(ks.len(), 0.0);
                arch.dispatch(HalfRowSums {
                    taps,
                    halves: &scratch.halves,
                    parity,
                    first_k: ks.start,
                    sums: &mut scratch.sums,
                });
                for (k, &sum) in ks.zip(&scratch.sums) {
                    out[2 * k + parity] = sum;
                }
            }
        }
    }
}

/// Reflected column index of tap offset i (x - 2 .. x + 2) at column x: entry x + i.
fn reflected_columns(width: usize) -> Vec<usize> {
    (0..width + 4).map(|x| reflect(x as isize - 2, width)).collect()
}

/// One output sample of [`demosaic`] at column x: the site's own sample (`taps` None) or the sum of its
/// taps through the reflected rows (offsets `rows`) and columns.
#[inline]
fn demosaiced_sample(
    raw: &[f32],
    taps: Option<&[(usize, usize, f32)]>,
    rows: &[usize; 5],
    columns: &[usize],
    x: usize,
    row_start: usize,
) -> f32 {
    match taps {
        None => raw[row_start + x],
        Some(taps) => {
            let mut sum = 0.0;
            for &(j, i, weight) in taps {
                sum += weight * raw[rows[j] + columns[x + i]];
            }
            sum
        }
    }
}

/// A [`demosaic`] task's buffers, reused from row to row: the five rows it reads, split into even and
/// odd columns, which rows those are, and the sums of one half row.
#[derive(Default)]
struct RowScratch {
    halves: [[Vec<f32>; 2]; 5],
    loaded: Option<[usize; 5]>,
    sums: Vec<f32>,
}

impl RowScratch {
    /// `halves[j][h][m]` = sample 2m + h of the row starting at `rows[j]`. A task's rows mostly come one
    /// after another, so the window rolls: four of the five rows are kept and only the new one is split.
    fn split_rows(&mut self, raw: &[f32], rows: &[usize; 5], width: usize) {
        let rolls_by_one = self.loaded.is_some_and(|loaded| loaded[1..] == rows[..4]);
        let fresh = if rolls_by_one {
            self.halves.rotate_left(1);
            4..5
        } else {
            0..5
        };
        self.loaded = Some(*rows);
        for j in fresh {
            let row = &raw[rows[j]..rows[j] + width];
            for (h, half) in self.halves[j].iter_mut().enumerate() {
                half.clear();
                half.extend(row.iter().skip(h).step_by(2));
            }
        }
    }
}

/// The tap sums of one interior half row (columns x = 2k + parity, k = first_k ..), compiled by `pulp`
/// once per instruction set. Tap (j, i) of column x reads column x + i - 2 = 2m + h of row j, with
/// q = parity + i, h = q mod 2 and m = k + q / 2 - 1: a contiguous run of one half.
struct HalfRowSums<'a> {
    taps: &'a [(usize, usize, f32)],
    halves: &'a [[Vec<f32>; 2]; 5],
    parity: usize,
    first_k: usize,
    sums: &'a mut [f32],
}

impl pulp::WithSimd for HalfRowSums<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let n = self.sums.len();
        for &(j, i, weight) in self.taps {
            let q = self.parity + i;
            let first = self.first_k + q / 2 - 1;
            let source = &self.halves[j][q % 2][first..first + n];
            for (sum, &sample) in self.sums.iter_mut().zip(source) {
                *sum += weight * sample;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::psnr;

    #[test]
    fn every_kernel_sums_to_one_so_flat_fields_are_preserved() {
        for kernel in [
            &BILINEAR_CROSS,
            &BILINEAR_ROW,
            &BILINEAR_COLUMN,
            &BILINEAR_DIAGONAL,
            &MALVAR_CROSS,
            &MALVAR_ROW,
            &MALVAR_COLUMN,
            &MALVAR_DIAGONAL,
        ] {
            let sum: f32 = kernel.iter().flatten().sum();
            assert!((sum - 1.0).abs() < 1e-6, "{kernel:?}");
        }
        let flat = Planar::from_fn(9, 7, 3, |c, _, _| [0.3, 0.5, 0.7][c]);
        for method in [Demosaic::Bilinear, Demosaic::MalvarHeCutler] {
            let back = demosaic(&mosaic_rggb(&flat).unwrap(), method).unwrap();
            assert!(back
                .data
                .iter()
                .zip(&flat.data)
                .all(|(a, b)| (a - b).abs() < 1e-6));
        }
    }

    #[test]
    fn mosaic_keeps_the_rggb_channel_of_each_site() {
        let rgb = Planar::from_fn(4, 4, 3, |c, x, y| (c * 100 + y * 4 + x) as f32);
        let mosaic = mosaic_rggb(&rgb).unwrap();
        assert_eq!(mosaic.channels, 1);
        assert_eq!(mosaic.plane(0)[..4], [0.0, 101.0, 2.0, 103.0]);
        assert_eq!(mosaic.plane(0)[4..8], [104.0, 205.0, 106.0, 207.0]);
        assert!(mosaic_rggb(&Planar::new(4, 4, 1)).is_err());
    }

    #[test]
    fn the_row_path_gives_the_bits_of_one_sample_at_a_time() {
        // Interior columns go through the half-row sums, the edges through demosaiced_sample: both
        // must give what demosaiced_sample gives at every column, for every width parity and the
        // narrow images that have no interior.
        for (width, height) in [(1, 1), (2, 3), (4, 4), (5, 3), (6, 5), (9, 7), (64, 9), (67, 8)] {
            let mosaic = Planar::from_fn(width, height, 1, |_, x, y| {
                ((x * 7919 + y * 104_729) % 1000) as f32 / 997.0 - 0.1
            });
            let columns = reflected_columns(width);
            for method in [Demosaic::Bilinear, Demosaic::MalvarHeCutler] {
                let plan = demosaic_taps(method);
                let rgb = demosaic(&mosaic, method).unwrap();
                for y in 0..height {
                    let rows = reflected_rows(y, height, width);
                    for x in 0..width {
                        let site = 2 * (y % 2) + x % 2;
                        for (c, taps) in plan[site].iter().enumerate() {
                            let expected = demosaiced_sample(
                                mosaic.plane(0),
                                taps.as_deref(),
                                &rows,
                                &columns,
                                x,
                                y * width,
                            );
                            assert_eq!(
                                rgb.get(c, x, y).to_bits(),
                                expected.to_bits(),
                                "{method:?} {width}x{height}: channel {c} at ({x}, {y})"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn reflection_preserves_parity() {
        for n in 2..7 {
            for i in -6..(n as isize + 6) {
                let r = reflect(i, n);
                assert!(r < n);
                assert_eq!(r as isize % 2, i.rem_euclid(2));
            }
        }
        assert_eq!(reflect(-3, 1), 0);
    }

    #[test]
    fn malvar_reproduces_a_smooth_image_above_60_db_and_beats_bilinear_on_edges() {
        // Smooth colour gradients: Malvar is exact on linear ramps, so the error is curvature only.
        let smooth = Planar::from_fn(128, 96, 3, |c, x, y| {
            let (u, v) = (x as f32 / 128.0, y as f32 / 96.0);
            0.5 + 0.3 * ((1.3 + c as f32) * u + (2.1 - 0.4 * c as f32) * v).sin() * 0.8
        });
        let smooth_malvar = psnr(
            &demosaic(&mosaic_rggb(&smooth).unwrap(), Demosaic::MalvarHeCutler).unwrap(),
            &smooth,
        );
        assert!(smooth_malvar > 60.0, "smooth image: Malvar {smooth_malvar:.1} dB");

        // Grey slanted edge: bilinear zippers and fringes, Malvar uses the green Laplacian to correct.
        let edge = crate::charts::slanted_edge(128, 128, 5.0, 0.2, 0.8).unwrap();
        let mosaic = mosaic_rggb(&edge).unwrap();
        let bilinear = psnr(&demosaic(&mosaic, Demosaic::Bilinear).unwrap(), &edge);
        let malvar = psnr(&demosaic(&mosaic, Demosaic::MalvarHeCutler).unwrap(), &edge);
        eprintln!("demosaic PSNR: smooth Malvar {smooth_malvar:.1} dB; edge Malvar {malvar:.1} dB, bilinear {bilinear:.1} dB");
        assert!(
            malvar > bilinear + 3.0,
            "edge: Malvar {malvar:.1} dB vs bilinear {bilinear:.1} dB"
        );
    }
}
