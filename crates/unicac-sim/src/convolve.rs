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
