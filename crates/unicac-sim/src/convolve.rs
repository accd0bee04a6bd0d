//! Spatially varying convolution without seams.
//!
//! PSFs are known at the nodes of a regular grid laid over the image (node columns at
//! x_i = i (W-1)/(nx-1), rows likewise). The output is the **gather** blend
//! out(p) = sum_n w_n(p) (I * K_n)(p), with w_n the bilinear weights of the four nodes around p.
//! The weights are continuous and sum to one, so there is no seam at tile borders, and a constant
//! image stays exactly constant (each I * K_n is constant when K_n sums to one). Borders replicate
//! the edge pixels. Each tile needs the convolutions of its four corner kernels over its own pixels
//! only; tiles run in parallel. Direct summation costs 4 K^2 multiply-adds per pixel.

use rayon::prelude::*;
use unicac_psf::Kernel;

/// Node grid and one kernel per node (row-major, `nodes_x * nodes_y`).
pub struct KernelGrid {
    pub nodes_x: usize,
    pub nodes_y: usize,
    pub kernels: Vec<Kernel>,
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

/// Convolves one plane with the kernel grid.
pub fn convolve_varying(plane: &[f32], width: usize, height: usize, grid: &KernelGrid) -> Vec<f32> {
    assert_eq!(plane.len(), width * height);
    assert!(
        grid.nodes_x >= 2 && grid.nodes_y >= 2,
        "need at least 2 x 2 nodes"
    );
    let xs = node_positions(width, grid.nodes_x);
    let ys = node_positions(height, grid.nodes_y);
    let mut out = vec![0.0f32; width * height];
    // One task per band of rows between two node rows; within it, tile by tile.
    let bands: Vec<(usize, usize, usize)> = (0..grid.nodes_y - 1)
        .map(|j| {
            let start = if j == 0 { 0 } else { ys[j].floor() as usize + 1 };
            let end = if j + 2 == grid.nodes_y {
                height
            } else {
                ys[j + 1].floor() as usize + 1
            };
            (j, start, end)
        })
        .collect();
    let mut slices: Vec<&mut [f32]> = Vec::with_capacity(bands.len());
    let mut rest = out.as_mut_slice();
    for &(_, start, end) in &bands {
        let (band, tail) = rest.split_at_mut((end - start) * width);
        slices.push(band);
        rest = tail;
    }
    slices
        .into_par_iter()
        .zip(bands.par_iter())
        .for_each(|(band, &(j, row_start, row_end))| {
            for i in 0..grid.nodes_x - 1 {
                let column_start = if i == 0 { 0 } else { xs[i].floor() as usize + 1 };
                let column_end = if i + 2 == grid.nodes_x {
                    width
                } else {
                    xs[i + 1].floor() as usize + 1
                };
                let corners = [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)];
                for row in row_start..row_end {
                    let ty = ((row as f64 - ys[j]) / (ys[j + 1] - ys[j])).clamp(0.0, 1.0) as f32;
                    for column in column_start..column_end {
                        let tx = ((column as f64 - xs[i]) / (xs[i + 1] - xs[i])).clamp(0.0, 1.0) as f32;
                        let weights = [(1.0 - tx) * (1.0 - ty), tx * (1.0 - ty), (1.0 - tx) * ty, tx * ty];
                        let mut value = 0.0f32;
                        for (&(ni, nj), w) in corners.iter().zip(weights) {
                            if w != 0.0 {
                                value += w * convolve_at(
                                    plane,
                                    width,
                                    height,
                                    &grid.kernels[nj * grid.nodes_x + ni],
                                    column,
                                    row,
                                );
                            }
                        }
                        band[(row - row_start) * width + column] = value;
                    }
                }
            }
        });
    out
}

/// (I * K)(column, row) with replicated borders: sum over kernel samples K(u, v) I(p - (u, v)).
#[inline]
fn convolve_at(
    plane: &[f32],
    width: usize,
    height: usize,
    kernel: &Kernel,
    column: usize,
    row: usize,
) -> f32 {
    let half = kernel.half() as i64;
    let size = kernel.size;
    let mut sum = 0.0f32;
    for kr in 0..size {
        // Output p receives from input p - offset; offset (kc - half, kr - half).
        let source_row = (row as i64 - (kr as i64 - half)).clamp(0, height as i64 - 1) as usize;
        let source = &plane[source_row * width..(source_row + 1) * width];
        let kernel_row = &kernel.data[kr * size..(kr + 1) * size];
        let first = column as i64 + half;
        if first - (size as i64 - 1) >= 0 && first < width as i64 {
            // Interior: a contiguous, reversed run of the source row.
            let start = (first - (size as i64 - 1)) as usize;
            let run = &source[start..start + size];
            sum += kernel_row
                .iter()
                .zip(run.iter().rev())
                .map(|(k, v)| k * v)
                .sum::<f32>();
        } else {
            for (kc, k) in kernel_row.iter().enumerate() {
                let source_column = (first - kc as i64).clamp(0, width as i64 - 1) as usize;
                sum += k * source[source_column];
            }
        }
    }
    sum
}

/// Kernel width from which `convolve_invariant` uses the FFT instead of direct summation (direct costs
/// K^2 per pixel, the FFT a few hundred operations per pixel whatever K).
pub const FFT_FROM_KERNEL_PX: usize = 15;

/// One kernel over the whole plane, replicated borders: direct for small kernels, FFT for large ones.
pub fn convolve_invariant(plane: &[f32], width: usize, height: usize, kernel: &Kernel) -> Vec<f32> {
    if kernel.size < FFT_FROM_KERNEL_PX {
        return (0..width * height)
            .into_par_iter()
            .map(|i| convolve_at(plane, width, height, kernel, i % width, i / width))
            .collect();
    }
    fft_convolve(plane, width, height, kernel)
}

/// Linear convolution by FFT (rustfft, f64): the plane is padded by half a kernel of replicated border on
/// each side, transformed with the zero-padded kernel, multiplied and transformed back; the padding is
/// cropped away so the result equals the direct sum with replicated borders.
fn fft_convolve(plane: &[f32], width: usize, height: usize, kernel: &Kernel) -> Vec<f32> {
    use rustfft::{num_complex::Complex, FftPlanner};
    let half = kernel.half();
    let (pw, ph) = (width + 2 * half + kernel.size, height + 2 * half + kernel.size);
    let mut planner = FftPlanner::<f64>::new();
    let (row_fft, row_ifft) = (planner.plan_fft_forward(pw), planner.plan_fft_inverse(pw));
    let (col_fft, col_ifft) = (planner.plan_fft_forward(ph), planner.plan_fft_inverse(ph));
    let transform = |grid: &mut Vec<Complex<f64>>,
                     rows: &std::sync::Arc<dyn rustfft::Fft<f64>>,
                     cols: &std::sync::Arc<dyn rustfft::Fft<f64>>| {
        grid.par_chunks_mut(pw).for_each(|row| rows.process(row));
        let mut transposed = vec![Complex::default(); pw * ph];
        for y in 0..ph {
            for x in 0..pw {
                transposed[x * ph + y] = grid[y * pw + x];
            }
        }
        transposed
            .par_chunks_mut(ph)
            .for_each(|column| cols.process(column));
        for y in 0..ph {
            for x in 0..pw {
                grid[y * pw + x] = transposed[x * ph + y];
            }
        }
    };
    // Image padded with replicated borders, placed at the origin.
    let mut image = vec![Complex::default(); pw * ph];
    for y in 0..height + 2 * half {
        let source_y = (y as i64 - half as i64).clamp(0, height as i64 - 1) as usize;
        for x in 0..width + 2 * half {
            let source_x = (x as i64 - half as i64).clamp(0, width as i64 - 1) as usize;
            image[y * pw + x] = Complex::new(plane[source_y * width + source_x] as f64, 0.0);
        }
    }
    let mut filter = vec![Complex::default(); pw * ph];
    for y in 0..kernel.size {
        for x in 0..kernel.size {
            filter[y * pw + x] = Complex::new(kernel.at(x, y) as f64, 0.0);
        }
    }
    transform(&mut image, &row_fft, &col_fft);
    transform(&mut filter, &row_fft, &col_fft);
    image.par_iter_mut().zip(&filter).for_each(|(a, b)| *a *= b);
    transform(&mut image, &row_ifft, &col_ifft);
    let scale = 1.0 / (pw * ph) as f64;
    // Full linear convolution index of output (x, y) is (x + 2 half, y + 2 half) in padded coordinates.
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            (image[(y + 2 * half) * pw + x + 2 * half].re * scale) as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let fft = fft_convolve(&plane, w, h, &k);
        let direct: Vec<f32> = (0..w * h)
            .map(|i| convolve_at(&plane, w, h, &k, i % w, i / w))
            .collect();
        let worst = fft
            .iter()
            .zip(&direct)
            .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst < 1e-5, "{worst}");
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
        let out = convolve_varying(&plane, w, h, &grid);
        // Bilinear weights sum to one up to f32 rounding.
        assert!(out.iter().zip(&plane).all(|(a, b)| (a - b).abs() < 1e-6));
    }

    #[test]
    fn constant_images_stay_constant_with_varying_kernels() {
        let (w, h) = (40, 30);
        let plane = vec![0.37f32; w * h];
        let kernels = (0..9)
            .map(|i| if i % 2 == 0 { boxed(7) } else { delta(7) })
            .collect();
        let out = convolve_varying(
            &plane,
            w,
            h,
            &KernelGrid {
                nodes_x: 3,
                nodes_y: 3,
                kernels,
            },
        );
        assert!(out.iter().all(|v| (v - 0.37).abs() < 1e-6));
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
        let out = convolve_varying(&plane, w, h, &grid);
        assert!((out[3 * w + 5] - 4.0).abs() < 1e-6);
        assert!(out[3 * w].abs() < 1e-6);
    }
}
