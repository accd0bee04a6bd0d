//! PSFs over the sensor. A rotationally symmetric lens needs PSFs along one radius only (sensor +y);
//! the PSF at any other point is the radial PSF at its distance from the axis, interpolated linearly
//! between the two nearest radial samples and rotated to its azimuth.

use crate::chief::ChiefRayMap;
use crate::error::SimResult;
use serde::Serialize;
use unicac_psf::{DarkFields, FieldPsf, Kernel, PsfTracer};

/// Radial PSF samples from the axis to the sensor's half-diagonal.
#[derive(Debug, Clone, Serialize)]
pub struct RadialPsfs {
    pub radii_mm: Vec<f64>,
    pub psfs: Vec<FieldPsf>,
    pub kernel_size: usize,
    /// Kernel size the spots asked for before the cap (equal to `kernel_size` unless capped).
    pub requested_kernel_size: usize,
}

impl RadialPsfs {
    /// Traces `samples` radial PSFs (evenly spaced from 0 to `max_radius_mm`), sizing one common
    /// kernel for all of them from the largest spot.
    pub fn trace(
        tracer: &PsfTracer,
        chief: &ChiefRayMap,
        max_radius_mm: f64,
        samples: usize,
        monochromatic: bool,
    ) -> SimResult<RadialPsfs> {
        let samples = samples.max(2);
        let radii_mm: Vec<f64> = (0..samples)
            .map(|i| max_radius_mm * i as f64 / (samples - 1) as f64)
            .collect();
        let angles: Vec<f64> = radii_mm.iter().map(|&r| chief.angle_for_height(r)).collect();
        // A lens that lights no field at all fails here with PsfError::AllFieldsVignetted (one error
        // kind for it, whichever stage finds it).
        let set = tracer.common_size_psfs(&angles, monochromatic, DarkFields::AllowedIfAnyLit)?;
        let (psfs, kernel_size, requested_kernel_size) = (set.psfs, set.kernel_px, set.requested_kernel_px);
        Ok(RadialPsfs {
            radii_mm,
            psfs,
            kernel_size,
            requested_kernel_size,
        })
    }

    /// Rebuilds the map from PSFs traced by `trace` with the same `max_radius_mm` (the cache stores
    /// only the PSFs); `None` if they do not form one (empty, or kernels of different sizes).
    pub fn from_psfs(max_radius_mm: f64, psfs: Vec<FieldPsf>) -> Option<RadialPsfs> {
        let kernel_size = psfs.first()?.kernels.first()?.size;
        if psfs.len() < 2
            || psfs
                .iter()
                .flat_map(|p| &p.kernels)
                .any(|k| k.size != kernel_size)
        {
            return None;
        }
        let last = (psfs.len() - 1) as f64;
        Some(RadialPsfs {
            radii_mm: (0..psfs.len()).map(|i| max_radius_mm * i as f64 / last).collect(),
            psfs,
            kernel_size,
            // The cap's request is not kept; `energy_cut` in each PSF still says what was cut.
            requested_kernel_size: kernel_size,
        })
    }

    pub fn channels(&self) -> usize {
        self.psfs[0].kernels.len()
    }

    /// The PSF of `channel` at sensor point (x, y) mm: radial interpolation, then rotation.
    pub fn kernel_at(&self, x_mm: f64, y_mm: f64, channel: usize) -> Kernel {
        let radius = x_mm.hypot(y_mm);
        let last = self.radii_mm.len() - 1;
        let position = (radius / self.radii_mm[last] * last as f64).clamp(0.0, last as f64);
        let i = (position.floor() as usize).min(last.saturating_sub(1));
        let t = (position - i as f64) as f32;
        let mut radial = Kernel::zeros(self.kernel_size, self.psfs[i].kernels[channel].pitch_um);
        radial.add_scaled(&self.psfs[i].kernels[channel], 1.0 - t);
        radial.add_scaled(&self.psfs[(i + 1).min(last)].kernels[channel], t);
        // Azimuth measured from sensor +y towards +x.
        let azimuth = x_mm.atan2(y_mm);
        if azimuth.abs() < 1e-12 {
            return radial;
        }
        rotate(&radial, azimuth)
    }

    /// The largest transmission over the field (on axis for any usual lens): relative illumination
    /// is normalised by it, so a lens darker on axis than off axis cannot scale pixels up without bound.
    pub fn peak_transmission(&self) -> f64 {
        self.psfs.iter().map(|p| p.transmission).fold(0.0, f64::max)
    }

    /// Transmission (vignetting) at a radius, interpolated.
    pub fn transmission_at(&self, radius_mm: f64) -> f64 {
        let last = self.radii_mm.len() - 1;
        let position = (radius_mm / self.radii_mm[last] * last as f64).clamp(0.0, last as f64);
        let i = (position.floor() as usize).min(last.saturating_sub(1));
        let t = position - i as f64;
        self.psfs[i].transmission * (1.0 - t) + self.psfs[(i + 1).min(last)].transmission * t
    }
}

/// Rotates a kernel by `angle` (rad) about its centre, taking sensor +y towards +x (clockwise in the
/// sensor's x-y plane), by bilinear resampling; renormalised to the input's sum.
///
/// Only the targets within reach of the kernel's support are resampled: a rotation keeps the distance
/// from the centre and a bilinear tap reaches at most sqrt(2) px from its sample, so a target further
/// than the support's radius + 2 px has four zero taps and stays exactly 0, as its sum would be (most
/// node kernels of a wide-field lens are far smaller than the field's common kernel size).
pub fn rotate(kernel: &Kernel, angle: f64) -> Kernel {
    let size = kernel.size;
    let mut rotated = Kernel::zeros(size, kernel.pitch_um);
    let Some(support_px) = support_radius_px(kernel) else {
        return rotated;
    };
    let (sin, cos) = angle.sin_cos();
    let centre = kernel.half();
    let half = centre as f64;
    let span = ((support_px + 2.0).ceil() as usize).min(centre);
    let targets = centre - span..=centre + span;
    for row in targets.clone() {
        for column in targets.clone() {
            rotated.data[row * size + column] = rotated_sample(kernel, half, (sin, cos), row, column);
        }
    }
    renormalise(kernel, &mut rotated);
    rotated
}

/// The rotated kernel's sample at (row, column): the input bilinearly resampled where R(-angle) takes it.
fn rotated_sample(kernel: &Kernel, half: f64, (sin, cos): (f64, f64), row: usize, column: usize) -> f32 {
    // Sensor offset of this target sample (kernel rows run towards -y).
    let (dx, dy) = (column as f64 - half, half - row as f64);
    // Rotate back by -angle: R(-a)(x, y) = (x cos a - y sin a, x sin a + y cos a).
    let (sx, sy) = (dx * cos - dy * sin, dx * sin + dy * cos);
    bilinear(kernel, half + sx, half - sy)
}

/// Scales the rotated kernel back to the input's sum (resampling moves it slightly).
fn renormalise(kernel: &Kernel, rotated: &mut Kernel) {
    let (before, after) = (kernel.sum(), rotated.sum());
    if after > 0.0 {
        let scale = (before / after) as f32;
        rotated.data.iter_mut().for_each(|v| *v *= scale);
    }
}

/// The largest distance (px) of a non-zero sample from the kernel's centre; None for a zero kernel.
fn support_radius_px(kernel: &Kernel) -> Option<f64> {
    let centre = kernel.half() as f64;
    let mut largest_squared: Option<f64> = None;
    for (row, samples) in kernel.data.chunks_exact(kernel.size).enumerate() {
        let dy = row as f64 - centre;
        for (column, &value) in samples.iter().enumerate() {
            if value != 0.0 {
                let dx = column as f64 - centre;
                let squared = dx * dx + dy * dy;
                largest_squared = Some(largest_squared.map_or(squared, |l| l.max(squared)));
            }
        }
    }
    largest_squared.map(f64::sqrt)
}

fn bilinear(kernel: &Kernel, column: f64, row: f64) -> f32 {
    let (c0, r0) = (floor(column), floor(row));
    let (tc, tr) = ((column - c0) as f32, (row - r0) as f32);
    let mut value = 0.0;
    for (dr, wr) in [(0, 1.0 - tr), (1, tr)] {
        for (dc, wc) in [(0, 1.0 - tc), (1, tc)] {
            let (c, r) = (c0 as i64 + dc, r0 as i64 + dr);
            if c >= 0 && r >= 0 && (c as usize) < kernel.size && (r as usize) < kernel.size {
                value += wc * wr * kernel.at(c as usize, r as usize);
            }
        }
    }
    value
}

/// `f64::floor` for the kernel's sample coordinates (|x| far below 2^52), without the libm call that
/// x86-64's baseline instruction set makes of `floor`; a zero's sign may differ, which the bilinear
/// weights do not see.
fn floor(x: f64) -> f64 {
    let truncated = x as i64 as f64;
    if truncated > x {
        truncated - 1.0
    } else {
        truncated
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rotation over every target sample, with the standard library's floor: what `rotate` was
    /// before it skipped the targets out of the support's reach.
    fn rotate_every_sample(kernel: &Kernel, angle: f64) -> Kernel {
        let mut rotated = Kernel::zeros(kernel.size, kernel.pitch_um);
        let half = kernel.half() as f64;
        for row in 0..kernel.size {
            for column in 0..kernel.size {
                rotated.data[row * kernel.size + column] =
                    rotated_sample(kernel, half, angle.sin_cos(), row, column);
            }
        }
        renormalise(kernel, &mut rotated);
        rotated
    }

    /// A kernel of `size` px whose non-zero samples lie within `radius_px` of the centre, off-centre
    /// and asymmetric, so that a wrong reach or orientation shows.
    fn blob(size: usize, radius_px: f64) -> Kernel {
        let mut kernel = Kernel::zeros(size, 1.0);
        let half = kernel.half() as f64;
        for row in 0..size {
            for column in 0..size {
                let (dx, dy) = (column as f64 - half, row as f64 - half);
                if dx.hypot(dy) <= radius_px {
                    kernel.data[row * size + column] = (1.0 + 0.3 * dx + 0.1 * dy * dy + 40.0) as f32;
                }
            }
        }
        kernel
    }

    #[test]
    fn rotating_only_the_supports_reach_equals_rotating_every_sample_bit_for_bit() {
        for (size, radius_px) in [
            (1, 0.0),
            (5, 0.0),
            (9, 1.5),
            (31, 4.0),
            (31, 15.0),
            (33, 22.5),
            (127, 9.0),
            (127, 90.0),
        ] {
            let kernel = blob(size, radius_px);
            for angle in [0.3, -1.2, std::f64::consts::FRAC_PI_2, 2.9, -3.1] {
                let fast = rotate(&kernel, angle);
                let reference = rotate_every_sample(&kernel, angle);
                let fast_bits: Vec<u32> = fast.data.iter().map(|v| v.to_bits()).collect();
                let reference_bits: Vec<u32> = reference.data.iter().map(|v| v.to_bits()).collect();
                assert_eq!(
                    fast_bits, reference_bits,
                    "size {size}, support {radius_px} px, angle {angle}"
                );
                assert!((fast.sum() - kernel.sum()).abs() <= 1e-6 * kernel.sum());
            }
        }
        let zero = Kernel::zeros(15, 1.0);
        assert!(rotate(&zero, 0.7).data.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn the_fast_floor_is_the_standard_floor_on_sample_coordinates() {
        for i in -4000..4000 {
            let x = i as f64 * 0.0371 + 1e-9 * (i % 7) as f64;
            assert_eq!(floor(x), x.floor(), "x = {x}");
        }
        for x in [
            -1.0,
            -0.5,
            -1e-300,
            0.0,
            1e-300,
            0.5,
            1.0,
            126.99999999999999,
            127.0,
        ] {
            assert_eq!(floor(x), x.floor(), "x = {x}");
        }
    }
}
