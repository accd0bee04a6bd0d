//! `--method wiener`: field-varying Wiener deconvolution with the dataset's stored PSF tables, the
//! classical PSF-prior baseline.
//!
//! The image is decoded from sRGB to linear light (where the lens blurred it), cut into tiles of
//! [`WIENER_TILE_PX`] px overlapping by [`WIENER_OVERLAP_PX`] px, and each tile is deconvolved with the
//! PSF at its centre: the lens's radial kernel at the centre's field radius (linear interpolation between
//! the stored radii) rotated to its azimuth (docs/dataset.md), per colour channel. Per tile and channel,
//! with the tile padded by at least one kernel width (to an FFT-friendly size) against wrap-around:
//!
//! ```text
//! X = conj(H) Y / (|H|^2 + NSR)
//! ```
//!
//! NSR is the noise-to-signal power ratio, one constant for all frequencies (`--wiener-nsr`, default
//! [`DEFAULT_NSR`]: about the power of 8-bit quantisation and mild sensor noise against natural-image
//! power at mid frequencies; larger is smoother). Tiles are blended by [`crate::tiling`] (seamless
//! weights), so the PSF varies smoothly across the frame. The result is encoded back to sRGB and clipped
//! to [0, 1].

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;
use unicac_dataset::PsfTable;
use unicac_image::Planar;
use unicac_sim::convolve::fast_len;

use crate::error::{BenchError, Result};
use crate::tiling::{run_tiled, TileRect, Tiling};

/// Tile side (px).
pub const WIENER_TILE_PX: usize = 128;
/// Tile overlap (px).
pub const WIENER_OVERLAP_PX: usize = 32;
/// The default noise-to-signal ratio.
pub const DEFAULT_NSR: f64 = 0.01;

/// The kernel of `channel` at a normalised frame position (x right, y down), K x K, unit sum.
pub fn kernel_at(table: &PsfTable, channel: usize, x_norm: f64, y_norm: f64) -> Vec<f64> {
    let k = table.meta.kernel_px;
    let radii = &table.meta.field_radius_norm;
    let r = x_norm.hypot(y_norm);
    // Linear interpolation between the stored radii, clamped at both ends.
    let (i0, i1, t) = match radii.iter().position(|&ri| ri >= r) {
        Some(0) => (0, 0, 0.0),
        None => (radii.len() - 1, radii.len() - 1, 0.0),
        Some(i) => (i - 1, i, (r - radii[i - 1]) / (radii[i] - radii[i - 1])),
    };
    let (a, b) = (table.kernel(i0, channel), table.kernel(i1, channel));
    let radial: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(&a, &b)| (1.0 - t) * a as f64 + t * b as f64)
        .collect();
    let phi = y_norm.atan2(x_norm);
    let (s, c) = phi.sin_cos();
    let h = (k / 2) as f64;
    let sample = |x: f64, y: f64| -> f64 {
        // Bilinear sample of the radial kernel at offset (x, y) from its centre; 0 outside.
        let (fx, fy) = (x + h, y + h);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let at = |xi: f64, yi: f64| -> f64 {
            if xi < 0.0 || yi < 0.0 || xi >= k as f64 || yi >= k as f64 {
                0.0
            } else {
                radial[yi as usize * k + xi as usize]
            }
        };
        at(x0, y0) * (1.0 - tx) * (1.0 - ty)
            + at(x0 + 1.0, y0) * tx * (1.0 - ty)
            + at(x0, y0 + 1.0) * (1.0 - tx) * ty
            + at(x0 + 1.0, y0 + 1.0) * tx * ty
    };
    let mut out = vec![0.0; k * k];
    for row in 0..k {
        for column in 0..k {
            let (u, v) = (column as f64 - h, row as f64 - h);
            // The rotated kernel at (u, v) is the radial kernel at R(-phi) (u, v).
            out[row * k + column] = sample(c * u + s * v, -s * u + c * v);
        }
    }
    let sum: f64 = out.iter().sum();
    if sum > 0.0 {
        out.iter_mut().for_each(|v| *v /= sum);
    }
    out
}

fn fft2(data: &mut [Complex<f64>], w: usize, h: usize, planner: &mut FftPlanner<f64>, inverse: bool) {
    let rows = if inverse {
        planner.plan_fft_inverse(w)
    } else {
        planner.plan_fft_forward(w)
    };
    for row in data.chunks_exact_mut(w) {
        rows.process(row);
    }
    let columns = if inverse {
        planner.plan_fft_inverse(h)
    } else {
        planner.plan_fft_forward(h)
    };
    let mut column = vec![Complex::new(0.0, 0.0); h];
    for x in 0..w {
        for y in 0..h {
            column[y] = data[y * w + x];
        }
        columns.process(&mut column);
        for y in 0..h {
            data[y * w + x] = column[y];
        }
    }
}

/// Wiener-deconvolves `plane` (the whole linear image plane, `width` x `height`) over `rect` with
/// `kernel` (K x K, centred), returning the rect's pixels.
fn deconvolve_rect(
    plane: &[f32],
    width: usize,
    height: usize,
    rect: TileRect,
    kernel: &[f64],
    k: usize,
    nsr: f64,
) -> Vec<f32> {
    let pad = k;
    // At least one kernel width of replicated pixels on every side, grown to a size with prime factors
    // 2, 3 and 5 only: a tile plus two pads is often 2 x a prime (128 + 2 x 127 = 382 = 2 x 191), whose
    // transform rustfft can only do by Rader's algorithm, several times slower.
    let (w, h) = (fast_len(rect.width + 2 * pad), fast_len(rect.height + 2 * pad));
    let mut planner = FftPlanner::new();
    let mut y = vec![Complex::new(0.0, 0.0); w * h];
    for row in 0..h {
        let iy = (rect.y0 as isize + row as isize - pad as isize).clamp(0, height as isize - 1) as usize;
        for column in 0..w {
            let ix =
                (rect.x0 as isize + column as isize - pad as isize).clamp(0, width as isize - 1) as usize;
            y[row * w + column].re = plane[iy * width + ix] as f64;
        }
    }
    let mut kf = vec![Complex::new(0.0, 0.0); w * h];
    let c = (k / 2) as isize;
    for row in 0..k {
        for column in 0..k {
            let (dy, dx) = (row as isize - c, column as isize - c);
            let (py, px) = (
                dy.rem_euclid(h as isize) as usize,
                dx.rem_euclid(w as isize) as usize,
            );
            kf[py * w + px].re += kernel[row * k + column];
        }
    }
    fft2(&mut y, w, h, &mut planner, false);
    fft2(&mut kf, w, h, &mut planner, false);
    for (yv, hv) in y.iter_mut().zip(&kf) {
        *yv = *yv * hv.conj() / (hv.norm_sqr() + nsr);
    }
    fft2(&mut y, w, h, &mut planner, true);
    let scale = 1.0 / (w * h) as f64;
    let mut out = Vec::with_capacity(rect.width * rect.height);
    for row in 0..rect.height {
        for column in 0..rect.width {
            out.push((y[(row + pad) * w + column + pad].re * scale) as f32);
        }
    }
    out
}

/// Restores `lq` (sRGB-encoded RGB in [0, 1]) by field-varying Wiener deconvolution with
/// noise-to-signal ratio `nsr`; `position(row, column)` is a pixel's normalised frame position
/// (docs/models.md), e.g. `FrameCrop::normalised` of the image's crop.
pub fn wiener_restore(
    lq: &Planar,
    table: &PsfTable,
    position: &dyn Fn(usize, usize) -> [f64; 2],
    nsr: f64,
) -> Result<Planar> {
    if !(nsr.is_finite() && nsr > 0.0) {
        return Err(BenchError::InvalidParameter(unicac_trace::InvalidParameter::new(
            "wiener_nsr",
            format!("{nsr}: must be positive"),
        )));
    }
    if lq.channels != 3 {
        return Err(BenchError::InvalidInput(format!(
            "Wiener: image has {} channels, not 3",
            lq.channels
        )));
    }
    let linear = unicac_image::color::srgb_to_linear(lq);
    let k = table.meta.kernel_px;
    let tiling = Tiling {
        tile_px: Some(WIENER_TILE_PX),
        overlap_px: WIENER_OVERLAP_PX,
    };
    let restored = run_tiled(&[&linear], tiling, |rect, _| {
        let (cx, cy) = (rect.x0 + rect.width / 2, rect.y0 + rect.height / 2);
        let [x_norm, y_norm] = position(cy, cx);
        let mut out = Planar::new(rect.width, rect.height, 3);
        for channel in 0..3 {
            let kernel = kernel_at(table, channel, x_norm, y_norm);
            let values = deconvolve_rect(
                linear.plane(channel),
                linear.width,
                linear.height,
                rect,
                &kernel,
                k,
                nsr,
            );
            out.plane_mut(channel).copy_from_slice(&values);
        }
        Ok(out)
    })?;
    let mut clamped = restored;
    clamped
        .data
        .iter_mut()
        .for_each(|v| *v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 });
    Ok(unicac_image::color::linear_to_srgb(&clamped))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deconvolution_undoes_a_known_blur() {
        // A smooth pattern blurred with a 3-tap horizontal kernel without a spectral zero (H = 0.2 at
        // Nyquist: [0.25, 0.5, 0.25] vanishes there, and the edge padding's content near Nyquist then
        // rings through the whole tile at NSR 1e-6); Wiener with a tiny NSR recovers it
        // away from the padded border.
        let (w, h) = (40usize, 32usize);
        let sharp: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                0.5 + 0.3 * (x * 0.7).sin() * (y * 0.4).cos()
            })
            .collect();
        let k = 3;
        let mut kernel = vec![0.0; 9];
        kernel[3] = 0.2;
        kernel[4] = 0.6;
        kernel[5] = 0.2;
        let blurred: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let at = |xx: isize| sharp[y * w + xx.clamp(0, w as isize - 1) as usize];
                0.2 * at(x as isize - 1) + 0.6 * at(x as isize) + 0.2 * at(x as isize + 1)
            })
            .collect();
        let rect = TileRect {
            x0: 0,
            y0: 0,
            width: w,
            height: h,
        };
        let out = deconvolve_rect(&blurred, w, h, rect, &kernel, k, 1e-6);
        let mut worst = 0.0f32;
        for y in 4..h - 4 {
            for x in 4..w - 4 {
                worst = worst.max((out[y * w + x] - sharp[y * w + x]).abs());
            }
        }
        assert!(worst < 0.02, "worst error {worst}");
    }
}
