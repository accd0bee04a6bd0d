//! FFT convolution (rustfft): one kernel over a whole plane (f64), and the four corner kernels of one
//! tile of the spatially varying convolution (f32, overlap-save).
//!
//! Overlap-save: a tile of T pixels needs an input patch of T + K - 1 pixels (a K px kernel reaches
//! K/2 either side; outside the image the border pixels are replicated). Its circular convolution with
//! the zero-padded kernel on an N >= T + K - 1 grid equals the linear one at the T outputs that start
//! K - 1 samples in, so nothing wraps around.
//!
//! Two real kernels share one complex transform: with Z = FFT(K_top + i K_bottom) and X the patch's
//! spectrum, IFFT(X Z) = (I * K_top) + i (I * K_bottom) because I, K_top and K_bottom are real. A tile's
//! four corner kernels therefore cost two inverse transforms, and its left and right corner pairs are
//! each one transform shared with the neighbouring tile.

use super::Borders;
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftNum, FftPlanner};
use std::ops::Range;
use std::sync::Arc;
use unicac_psf::Kernel;

/// Smallest n >= `minimum` whose only prime factors are 2, 3 and 5 (rustfft's fastest sizes).
pub fn fast_len(minimum: usize) -> usize {
    (minimum.max(1)..)
        .find(|&n| {
            let mut m = n;
            for p in [2, 3, 5] {
                while m % p == 0 {
                    m /= p;
                }
            }
            m == 1
        })
        .expect("some n is 5-smooth")
}

/// A planned 2-D transform of `width` x `height` (row-major grids). Spectra stay transposed
/// (column-major): they are only multiplied and transformed back, so two transposes are saved.
struct Fft2<T: FftNum> {
    width: usize,
    height: usize,
    rows: [Arc<dyn Fft<T>>; 2],
    columns: [Arc<dyn Fft<T>>; 2],
}

impl<T: FftNum> Fft2<T> {
    fn new(width: usize, height: usize) -> Fft2<T> {
        Fft2::with_planner(&mut FftPlanner::<T>::new(), width, height)
    }

    fn with_planner(planner: &mut FftPlanner<T>, width: usize, height: usize) -> Fft2<T> {
        Fft2 {
            width,
            height,
            rows: [planner.plan_fft_forward(width), planner.plan_fft_inverse(width)],
            columns: [planner.plan_fft_forward(height), planner.plan_fft_inverse(height)],
        }
    }

    fn len(&self) -> usize {
        self.width * self.height
    }

    /// Row-major `grid` (overwritten) to the transposed spectrum.
    fn forward(&self, grid: &mut [Complex<T>], spectrum: &mut [Complex<T>]) {
        process_rows(&self.rows[0], grid, self.width);
        transpose(grid, spectrum, self.width, self.height);
        process_rows(&self.columns[0], spectrum, self.height);
    }

    /// Transposed `spectrum` (overwritten) back to a row-major grid, unscaled (times width x height).
    fn inverse(&self, spectrum: &mut [Complex<T>], grid: &mut [Complex<T>]) {
        process_rows(&self.columns[1], spectrum, self.height);
        transpose(spectrum, grid, self.height, self.width);
        process_rows(&self.rows[1], grid, self.width);
    }
}

/// Side of the square blocks that transposed sweeps work through (16 x 16 complex f64 = 4 KB).
const BLOCK: usize = 16;

/// Transforms every row; rows are handed out in groups so that small transforms stay cheap to schedule.
fn process_rows<T: FftNum>(fft: &Arc<dyn Fft<T>>, data: &mut [Complex<T>], row_len: usize) {
    const ROWS_PER_TASK: usize = 16;
    data.par_chunks_mut(row_len * ROWS_PER_TASK)
        .for_each(|rows| fft.process(rows));
}

/// `target` (`height` wide) = `source` (`width` wide) transposed, in blocks of `BLOCK` x `BLOCK` so
/// that reads and writes both stay within a few cache lines (a whole-row sweep writes one element per
/// cache line and thrashes the cache once a grid outgrows it; the transposes were a tenth of the ODE's
/// profile), and over groups of target rows in parallel.
fn transpose<T: Copy + Send + Sync>(source: &[T], target: &mut [T], width: usize, height: usize) {
    target
        .par_chunks_mut(BLOCK * height)
        .enumerate()
        .for_each(|(chunk, rows)| {
            let x0 = chunk * BLOCK;
            for y0 in (0..height).step_by(BLOCK) {
                let y1 = (y0 + BLOCK).min(height);
                for (dx, row) in rows.chunks_exact_mut(height).enumerate() {
                    let x = x0 + dx;
                    for (y, value) in (y0..y1).zip(&mut row[y0..y1]) {
                        *value = source[y * width + x];
                    }
                }
            }
        });
}

/// Writes the plane's pixels from (`x0`, `y0`) over `patch_width` x `patch_height` (replicated borders)
/// into the top-left of a zeroed row-major grid `stride` wide.
#[allow(clippy::too_many_arguments)]
fn fill_patch<T: FftNum>(
    plane: &[f32],
    (width, height): (usize, usize),
    (x0, y0): (i64, i64),
    (patch_width, patch_height): (usize, usize),
    grid: &mut [Complex<T>],
    stride: usize,
) {
    grid.iter_mut()
        .for_each(|v| *v = Complex::new(T::zero(), T::zero()));
    for py in 0..patch_height {
        let source_y = (y0 + py as i64).clamp(0, height as i64 - 1) as usize;
        let source = &plane[source_y * width..(source_y + 1) * width];
        let target = &mut grid[py * stride..py * stride + patch_width];
        for (px, value) in target.iter_mut().enumerate() {
            let source_x = (x0 + px as i64).clamp(0, width as i64 - 1) as usize;
            *value = Complex::new(T::from_f32(source[source_x]).expect("f32 converts"), T::zero());
        }
    }
}

/// The zero-padded transform of the centred `size` x `size` parts of `real` + i `imaginary` (either
/// may be absent; `size` is at most their size) on `fft`'s grid, into `spectrum` (every element
/// written), with `grid` as the (overwritten) working grid; both `fft.len()`.
fn kernel_spectrum_into<T: FftNum>(
    fft: &Fft2<T>,
    real: &Kernel,
    imaginary: Option<&Kernel>,
    size: usize,
    grid: &mut [Complex<T>],
    spectrum: &mut [Complex<T>],
) {
    let to_t = |v: f32| T::from_f32(v).expect("f32 converts");
    let offset = (real.size - size) / 2;
    grid.fill(Complex::new(T::zero(), T::zero()));
    for y in 0..size {
        for x in 0..size {
            let im = imaginary.map_or(0.0, |k| k.at(x + offset, y + offset));
            grid[y * fft.width + x] = Complex::new(to_t(real.at(x + offset, y + offset)), to_t(im));
        }
    }
    fft.forward(grid, spectrum);
}

/// The grids one worker of `convolve_invariant_fft` reuses from one kernel pair to the next. Fresh
/// grids per pair (six of 6.5 MB each for the ODE's 127 px kernels on 508 px patches) made page
/// faults and page clearing about 15% of the ODE's profile.
struct PairBuffers {
    grid: Vec<Complex<f64>>,
    spectrum: Vec<Complex<f64>>,
    product: Vec<Complex<f64>>,
}

impl PairBuffers {
    fn new(len: usize) -> PairBuffers {
        let zeros = || vec![Complex::new(0.0, 0.0); len];
        PairBuffers {
            grid: zeros(),
            spectrum: zeros(),
            product: Vec::with_capacity(len),
        }
    }
}

/// One plane convolved with each of `kernels` (all of one size) over the whole plane with replicated
/// borders, in f64 (the invariant path is used for reference-quality metrics). The plane's transform is
/// computed once, and two kernels share each kernel transform and each inverse (real and imaginary
/// parts, as the tiles' corner pairs do); a lone kernel is exactly the plain one-kernel convolution, and a
/// packed one equals it to f64 rounding (the f32 outputs differ by at most an ulp).
///
/// With `and_transpose` (a square plane) each kernel also convolves the plane's transpose, from the same
/// two transforms: (P^T * K)(r, c) = (P * K^T)(c, r), and K^T's spectrum is K's spectrum transposed, so
/// only the inverse is extra. The result holds, per kernel in order, P * K and then (if asked) P^T * K.
pub(super) fn convolve_invariant_fft(
    plane: &[f32],
    width: usize,
    height: usize,
    kernels: &[&Kernel],
    and_transpose: bool,
    borders: Borders,
) -> Vec<Vec<f32>> {
    let Some(first) = kernels.first() else {
        return Vec::new();
    };
    let size = first.size;
    assert!(kernels.iter().all(|k| k.size == size), "kernels of one size");
    assert!(
        !and_transpose || width == height,
        "only a square plane has a transpose of its shape"
    );
    let half = first.half();
    // Replicated borders: the plane padded by a kernel's reach on every side, so that nothing wraps
    // around. Interior: the plane alone; its circular convolution equals the linear one wherever the
    // kernel stays inside the plane (`half` px from every edge), read `half` samples in.
    let (padding, read_offset) = match borders {
        Borders::Replicated => (size - 1, size - 1),
        Borders::Interior => (0, half),
    };
    // The grid also holds the whole kernel (a plane narrower than the kernel has no interior, but its
    // kernel's spectrum is still formed).
    let fft = Fft2::<f64>::new(
        fast_len((width + padding).max(size)),
        fast_len((height + padding).max(size)),
    );
    let mut grid = vec![Complex::new(0.0, 0.0); fft.len()];
    let start = -((padding / 2) as i64);
    fill_patch(
        plane,
        (width, height),
        (start, start),
        (width + padding, height + padding),
        &mut grid,
        fft.width,
    );
    // The output rows and columns computed (the others stay 0).
    let (rows, columns) = (borders.computed(height, half), borders.computed(width, half));
    let mut plane_spectrum = vec![Complex::new(0.0, 0.0); fft.len()];
    fft.forward(&mut grid, &mut plane_spectrum);
    let scale = 1.0 / fft.len() as f64;
    let n = fft.width;
    // The first kernel of a pair comes back in the real parts, the second in the imaginary ones.
    let parts: [fn(&Complex<f64>) -> f64; 2] = [|c| c.re, |c| c.im];
    let views = if and_transpose { 2 } else { 1 };
    let convolve_pair = |pair: &[&Kernel], buffers: &mut PairBuffers| -> Vec<Vec<f32>> {
        let PairBuffers {
            grid,
            spectrum,
            product,
        } = buffers;
        kernel_spectrum_into(&fft, pair[0], pair.get(1).copied(), size, grid, spectrum);
        // outputs[view][part]: view 0 is P * K, view 1 is P^T * K.
        let mut outputs: Vec<Vec<Vec<f32>>> = (0..views)
            .map(|view| {
                // Spectra are column-major: (u, v) sits at u * height + v; the grids are square when
                // view 1 is asked for, so K^T's spectrum at (u, v) is K's at (v, u).
                if view == 0 {
                    product.clear();
                    product.extend(spectrum.iter().zip(&plane_spectrum).map(|(k, x)| k * x));
                } else {
                    // product(a, b) = K(b, a) X(a, b), in blocks so that the transposed reads stay in cache.
                    product.resize(fft.len(), Complex::new(0.0, 0.0));
                    for_each_in_blocks(0..n, 0..n, |a, b| {
                        product[a * n + b] = spectrum[b * n + a] * plane_spectrum[a * n + b];
                    });
                }
                fft.inverse(product, grid);
                parts[..pair.len()]
                    .iter()
                    .map(|part| {
                        let mut out = vec![0.0f32; width * height];
                        let value = |row: usize, column: usize| {
                            (part(&grid[(row + read_offset) * n + column + read_offset]) * scale) as f32
                        };
                        if view == 0 {
                            for row in rows.clone() {
                                for column in columns.clone() {
                                    out[row * width + column] = value(row, column);
                                }
                            }
                        } else {
                            // Output (x, y) of P^T * K is (P * K^T) at grid (row x, column y).
                            for_each_in_blocks(rows.clone(), columns.clone(), |y, x| {
                                out[y * width + x] = value(x, y);
                            });
                        }
                        out
                    })
                    .collect()
            })
            .collect();
        // Per kernel of the pair: its views in order.
        (0..pair.len())
            .flat_map(|k| (0..views).map(move |view| (view, k)))
            .map(|(view, k)| std::mem::take(&mut outputs[view][k]))
            .collect()
    };
    // One group of consecutive pairs per thread, each with its own reused buffers (the transforms
    // inside are parallel too, so a thread that finishes early helps the others).
    let pairs: Vec<&[&Kernel]> = kernels.chunks(2).collect();
    let per_group = pairs.len().div_ceil(rayon::current_num_threads().max(1));
    pairs
        .par_chunks(per_group)
        .flat_map_iter(|group| {
            let mut buffers = PairBuffers::new(fft.len());
            group
                .iter()
                .flat_map(|pair| convolve_pair(pair, &mut buffers))
                .collect::<Vec<Vec<f32>>>()
        })
        .collect()
}

/// Calls `f(a, b)` for every a in `outer`, b in `inner`, in 16 x 16 blocks: a loop that reads or
/// writes one of two grids transposed then touches few cache lines at a time.
fn for_each_in_blocks(outer: Range<usize>, inner: Range<usize>, mut f: impl FnMut(usize, usize)) {
    for a0 in outer.clone().step_by(BLOCK) {
        for b0 in inner.clone().step_by(BLOCK) {
            for a in a0..(a0 + BLOCK).min(outer.end) {
                for b in b0..(b0 + BLOCK).min(inner.end) {
                    f(a, b);
                }
            }
        }
    }
}

/// The corner kernels of one tile: [top-left, top-right, bottom-left, bottom-right], and the node
/// columns of its left and right pairs (a tile's right pair is the next tile's left pair).
pub(super) struct TileKernels<'a> {
    pub corners: [&'a Kernel; 4],
    pub columns: (usize, usize),
}

/// Which kernel-pair spectrum a buffer holds: node column, crop size and transform size.
type PairKey = (usize, usize, (usize, usize));

/// The FFT state of one band of tiles (between two node rows), reused from tile to tile. Every tile
/// gets its own transform size, from its own kernel size (`extent`): a small PSF costs a small FFT.
pub(super) struct TileFft {
    planner: FftPlanner<f32>,
    plans: Vec<Fft2<f32>>,
    grid: Vec<Complex<f32>>,
    spectrum: Vec<Complex<f32>>,
    product: Vec<Complex<f32>>,
    left: Vec<Complex<f32>>,
    right: Vec<Complex<f32>>,
    /// The previous tile's right pair spectrum, reused as this tile's left one when the keys match.
    previous_right: Option<(PairKey, Vec<Complex<f32>>)>,
    /// The previous tile's left pair spectrum's buffer, for this tile's right pair.
    spare: Vec<Complex<f32>>,
}

impl TileFft {
    pub(super) fn new() -> TileFft {
        TileFft {
            planner: FftPlanner::new(),
            plans: Vec::new(),
            grid: Vec::new(),
            spectrum: Vec::new(),
            product: Vec::new(),
            left: Vec::new(),
            right: Vec::new(),
            previous_right: None,
            spare: Vec::new(),
        }
    }

    /// The plan for a `width` x `height` transform (planned once per band and size).
    fn plan(&mut self, width: usize, height: usize) -> usize {
        if let Some(index) = self
            .plans
            .iter()
            .position(|p| (p.width, p.height) == (width, height))
        {
            return index;
        }
        self.plans
            .push(Fft2::with_planner(&mut self.planner, width, height));
        self.plans.len() - 1
    }

    /// Convolves the tile over `columns` x `rows` with its four corner kernels cropped to `size` (odd);
    /// afterwards `corners(column, row)` gives [top-left, top-right, bottom-left, bottom-right] at a
    /// pixel of the tile.
    pub(super) fn convolve_tile(
        &mut self,
        plane: &[f32],
        (width, height): (usize, usize),
        kernels: &TileKernels,
        size: usize,
        columns: &Range<usize>,
        rows: &Range<usize>,
    ) -> TileCorners<'_> {
        let reach = size - 1;
        let half = (size / 2) as i64;
        let plan = self.plan(fast_len(columns.len() + reach), fast_len(rows.len() + reach));
        let fft = &self.plans[plan];
        let n = fft.len();
        for buffer in [
            &mut self.grid,
            &mut self.spectrum,
            &mut self.product,
            &mut self.left,
            &mut self.right,
        ] {
            buffer.resize(n, Complex::default());
        }
        fill_patch(
            plane,
            (width, height),
            (columns.start as i64 - half, rows.start as i64 - half),
            (columns.len() + reach, rows.len() + reach),
            &mut self.grid,
            fft.width,
        );
        fft.forward(&mut self.grid, &mut self.spectrum);
        let [top_left, top_right, bottom_left, bottom_right] = kernels.corners;
        let key = |column| (column, size, (fft.width, fft.height));
        let left_key = key(kernels.columns.0);
        // The patch's transform is in `self.spectrum`, so `self.grid` is free to be the kernels'
        // working grid; their spectra go to recycled buffers (fresh zeroed ones per tile cost page
        // clearing), which the transform overwrites whole.
        let mut pair_spectrum = |real, imaginary, spare: &mut Vec<Complex<f32>>| {
            let mut spectrum = std::mem::take(spare);
            spectrum.resize(n, Complex::default());
            kernel_spectrum_into(fft, real, Some(imaginary), size, &mut self.grid, &mut spectrum);
            spectrum
        };
        let left_spectrum = match self.previous_right.take() {
            Some((k, spectrum)) if k == left_key => spectrum,
            Some((_, stale)) => pair_spectrum(top_left, bottom_left, &mut { stale }),
            None => pair_spectrum(top_left, bottom_left, &mut Vec::new()),
        };
        let right_spectrum = pair_spectrum(top_right, bottom_right, &mut self.spare);
        for (spectrum, out) in [
            (&left_spectrum, &mut self.left),
            (&right_spectrum, &mut self.right),
        ] {
            self.product
                .iter_mut()
                .zip(self.spectrum.iter().zip(spectrum))
                .for_each(|(p, (a, b))| *p = a * b);
            fft.inverse(&mut self.product, out);
        }
        self.previous_right = Some((key(kernels.columns.1), right_spectrum));
        self.spare = left_spectrum;
        TileCorners {
            left: &self.left,
            right: &self.right,
            stride: fft.width,
            origin: (columns.start, rows.start),
            reach,
            scale: 1.0 / n as f32,
        }
    }
}

/// The four corner convolutions of one tile, read per pixel.
pub(super) struct TileCorners<'a> {
    left: &'a [Complex<f32>],
    right: &'a [Complex<f32>],
    stride: usize,
    origin: (usize, usize),
    reach: usize,
    scale: f32,
}

impl TileCorners<'_> {
    #[inline]
    pub(super) fn at(&self, column: usize, row: usize) -> [f32; 4] {
        let index = (row - self.origin.1 + self.reach) * self.stride + column - self.origin.0 + self.reach;
        let (l, r) = (self.left[index], self.right[index]);
        [l.re, r.re, l.im, r.im].map(|v| v * self.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocked_transpose_equals_the_definition() {
        // Sizes below, at and across the block size, square and not.
        for (width, height) in [(1, 1), (3, 40), (16, 16), (17, 33), (50, 7)] {
            let source: Vec<u32> = (0..(width * height) as u32).collect();
            let mut target = vec![0; width * height];
            transpose(&source, &mut target, width, height);
            for y in 0..height {
                for x in 0..width {
                    assert_eq!(
                        target[x * height + y],
                        source[y * width + x],
                        "{width} x {height} at ({x}, {y})"
                    );
                }
            }
        }
    }
}
