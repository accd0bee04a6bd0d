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
pub fn rotate(kernel: &Kernel, angle: f64) -> Kernel {
    let (sin, cos) = angle.sin_cos();
    let size = kernel.size;
    let half = kernel.half() as f64;
    let mut rotated = Kernel::zeros(size, kernel.pitch_um);
    for row in 0..size {
        for column in 0..size {
            // Sensor offset of this target sample (kernel rows run towards -y).
            let (dx, dy) = (column as f64 - half, half - row as f64);
            // Rotate back by -angle: R(-a)(x, y) = (x cos a - y sin a, x sin a + y cos a).
            let (sx, sy) = (dx * cos - dy * sin, dx * sin + dy * cos);
            let (fc, fr) = (half + sx, half - sy);
            rotated.data[row * size + column] = bilinear(kernel, fc, fr);
        }
    }
    let (before, after) = (kernel.sum(), rotated.sum());
    if after > 0.0 {
        let scale = (before / after) as f32;
        rotated.data.iter_mut().for_each(|v| *v *= scale);
    }
    rotated
}

fn bilinear(kernel: &Kernel, column: f64, row: f64) -> f32 {
    let (c0, r0) = (column.floor(), row.floor());
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
