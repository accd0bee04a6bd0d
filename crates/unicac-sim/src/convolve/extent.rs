//! How far a kernel really reaches: the work of the spatially varying convolution follows the local
//! PSF, not the largest one of the field.
//!
//! All kernels of a `KernelGrid` share one size (the largest PSF's), but an axis PSF fills a fraction of
//! a corner one's and the rest of its kernel is (near) zero. A tile is convolved with its four corner
//! kernels cropped to the smallest centred square that keeps all but `tail` of each kernel's L1 mass.
//! **Error bound:** cropping kernel K to K' changes (I * K)(p) by at most ||K - K'||_1 max|I| <=
//! tail ||K||_1 max|I|, and the blend weights are convex, so every output pixel moves by at most
//! `tail * max_n ||K_n||_1 * max|I|` (`tail` = 1e-5 by default: -100 dB for unit-sum kernels, far
//! below f32 FFT rounding and 8-bit quantisation). Tested in `mod.rs`.

use unicac_psf::Kernel;

/// Default `tail`: the share of a kernel's L1 mass a crop may drop (see the module docs for the bound).
pub const KERNEL_TAIL_TOLERANCE: f64 = 1e-5;

/// Smallest half-width r (0 ..= kernel.half()) such that the L1 mass outside the centred (2r + 1)^2
/// square is at most `tail` times the kernel's L1 mass. A delta kernel gives 0; a zero kernel 0.
pub fn half_width_holding(kernel: &Kernel, tail: f64) -> usize {
    let half = kernel.half();
    // L1 mass on each ring of Chebyshev distance d from the centre.
    let mut rings = vec![0.0f64; half + 1];
    for y in 0..kernel.size {
        for x in 0..kernel.size {
            let d = x.abs_diff(half).max(y.abs_diff(half));
            rings[d] += f64::from(kernel.at(x, y).abs());
        }
    }
    let total: f64 = rings.iter().sum();
    let allowed = tail.max(0.0) * total;
    let mut outside = 0.0;
    for r in (0..half).rev() {
        // Dropping ring r + 1 too would leave `outside + rings[r + 1]` out.
        outside += rings[r + 1];
        if outside > allowed {
            return r + 1;
        }
    }
    0
}

/// The centred `size` x `size` part of `kernel` (`size` odd, at most the kernel's).
pub fn centre_crop(kernel: &Kernel, size: usize) -> Kernel {
    debug_assert!(size % 2 == 1 && size <= kernel.size);
    if size == kernel.size {
        return kernel.clone();
    }
    let offset = (kernel.size - size) / 2;
    let mut cropped = Kernel::zeros(size, kernel.pitch_um);
    for y in 0..size {
        cropped.data[y * size..(y + 1) * size]
            .copy_from_slice(&kernel.data[(y + offset) * kernel.size + offset..][..size]);
    }
    cropped
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_width_follows_the_support() {
        let mut k = Kernel::zeros(31, 1.0);
        k.data[15 * 31 + 15] = 1.0;
        assert_eq!(half_width_holding(&k, 0.0), 0, "delta");
        // Mass 4 px right of the centre and a faint tail 10 px up.
        k.data[15 * 31 + 19] = 0.5;
        k.data[5 * 31 + 15] = 1e-7;
        assert_eq!(
            half_width_holding(&k, 0.0),
            10,
            "exact: every non-zero sample kept"
        );
        assert_eq!(
            half_width_holding(&k, 1e-5),
            4,
            "the 1e-7 tail is below 1e-5 of the mass"
        );
        assert_eq!(half_width_holding(&Kernel::zeros(9, 1.0), 1e-5), 0, "zero kernel");
        let cropped = centre_crop(&k, 9);
        assert_eq!(cropped.at(4, 4), 1.0);
        assert_eq!(cropped.at(8, 4), 0.5);
        assert!((cropped.sum() - 1.5).abs() < 1e-12);
    }
}
