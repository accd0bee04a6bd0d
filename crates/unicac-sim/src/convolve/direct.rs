//! Direct summation: K^2 multiply-adds per pixel and kernel, cheapest for small kernels.

use unicac_psf::Kernel;

/// (I * K)(column, row) with replicated borders: sum over kernel samples K(u, v) I(p - (u, v)).
#[inline]
pub(super) fn convolve_at(
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
