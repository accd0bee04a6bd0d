//! PSFs over the sensor. A rotationally symmetric lens needs PSFs along one radius only (sensor +y);
//! the PSF at any other point is the radial PSF at its distance from the axis, interpolated linearly
//! between the two nearest radial samples and rotated to its azimuth.
//!
//! The radial samples follow the PSF (`RadialSampling`): a coarse uniform set first, then every interval
//! over which linear interpolation errs by more than a tolerance at its midpoint is halved, so samples
//! are dense only where the PSF changes fast (usually towards the corner), up to a stated count.

use crate::chief::ChiefRayMap;
use crate::error::SimResult;
use serde::Serialize;
use std::collections::BTreeMap;
use unicac_psf::{DarkFields, FieldPsf, Kernel, PsfTracer, TracedField};

/// Intervals of the uniform start of the radial refinement (5 samples; 9 once their midpoints are in).
pub const INITIAL_RADIAL_INTERVALS: usize = 4;
/// Finest radial step, as a fraction of the radius: every sample sits at k / `RADIAL_GRID` of it, so
/// at most `RADIAL_GRID` + 1 samples, and the cache can rebuild each radius exactly from its field angle.
pub const RADIAL_GRID: usize = 64;

/// Default radial sampling: 17 uniform samples (tolerance 0 halves every interval while the budget
/// lasts). On the bundled lenses a tolerance buys no image PSNR per second over uniform samples
/// (docs/performance.md, the sweep's radial rows); it guards lenses whose PSF changes abruptly.
pub const DEFAULT_RADIAL_SAMPLING: RadialSampling = RadialSampling {
    max_samples: 17,
    tolerance: 0.0,
};

/// Where the radial PSF samples go (defaults at the knee of the sweep in docs/performance.md).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RadialSampling {
    /// Most radial samples traced (>= `INITIAL_RADIAL_INTERVALS` + 1; at most `RADIAL_GRID` + 1 are used).
    pub max_samples: usize,
    /// An interval is halved while the PSF interpolated at its midpoint differs from the PSF traced
    /// there by more than this half-L1 distance (0: equal kernels, 1: disjoint), largest channel; every
    /// output pixel then moves by at most twice it times the image's largest value. 0 halves every
    /// interval while `max_samples` lasts: 5, 9, 17, 33 or 65 uniform samples.
    pub tolerance: f64,
}

/// Radial PSF samples from the axis to the sensor's half-diagonal.
#[derive(Debug, Clone, Serialize)]
pub struct RadialPsfs {
    /// Increasing, from 0 to the half-diagonal.
    pub radii_mm: Vec<f64>,
    pub psfs: Vec<FieldPsf>,
    pub kernel_size: usize,
    /// Kernel size the spots asked for before the cap (equal to `kernel_size` unless capped).
    pub requested_kernel_size: usize,
    /// The largest midpoint error (half-L1, as `RadialSampling::tolerance`) of the checks that ended the
    /// refinement: at most the tolerance unless the sample count or the finest step stopped it (the
    /// intervals left are halves of the checked ones). `None` when nothing was checked (tolerance 0)
    /// or the map was rebuilt from the cache.
    pub checked_half_l1: Option<f64>,
}

/// One interval of the radial grid waiting for its midpoint check, with its parent's error (the
/// order in which a short sample budget is spent).
struct Interval {
    lo: usize,
    hi: usize,
    parent_error: f64,
}

impl RadialPsfs {
    /// Traces the radial PSFs from 0 to `max_radius_mm` with samples placed by `sampling`, sizing one
    /// common kernel for all of them from the largest spot.
    pub fn trace(
        tracer: &PsfTracer,
        chief: &ChiefRayMap,
        max_radius_mm: f64,
        sampling: RadialSampling,
        monochromatic: bool,
    ) -> SimResult<RadialPsfs> {
        let trace_at = |points: &[usize]| {
            let angles: Vec<f64> = points
                .iter()
                .map(|&k| chief.angle_for_height(grid_radius(max_radius_mm, k)))
                .collect();
            tracer.trace_fields(&angles)
        };
        let (traced, checked_half_l1) = if sampling.tolerance > 0.0 {
            let (traced, checked) = refine(tracer, &trace_at, sampling, monochromatic)?;
            (traced, Some(checked))
        } else {
            // Uniform: every sample is known up front and traced in one parallel batch.
            let points = halved_grid_points(sampling.max_samples);
            let fields = trace_at(&points)?;
            (points.into_iter().zip(fields).collect(), None)
        };
        let radii_mm = traced.keys().map(|&k| grid_radius(max_radius_mm, k)).collect();
        let fields: Vec<TracedField> = traced.into_values().collect();
        // A lens that lights no field at all fails here with PsfError::AllFieldsVignetted (one error
        // kind for it, whichever stage finds it).
        let set = tracer.rasterise_common_size(&fields, monochromatic, DarkFields::AllowedIfAnyLit)?;
        Ok(RadialPsfs {
            radii_mm,
            psfs: set.psfs,
            kernel_size: set.kernel_px,
            requested_kernel_size: set.requested_kernel_px,
            checked_half_l1,
        })
    }

    /// Rebuilds the map from PSFs traced by `trace` with the same `max_radius_mm` and `chief` (the cache
    /// stores only the PSFs: each radius is the grid point its field angle lands on); `None` if they do
    /// not form one (empty, kernels of different sizes, radii off the grid or not increasing from 0 to
    /// the half-diagonal).
    pub fn from_psfs(max_radius_mm: f64, chief: &ChiefRayMap, psfs: Vec<FieldPsf>) -> Option<RadialPsfs> {
        let kernel_size = psfs.first()?.kernels.first()?.size;
        if psfs.len() < 2
            || psfs
                .iter()
                .flat_map(|p| &p.kernels)
                .any(|k| k.size != kernel_size)
        {
            return None;
        }
        let step_mm = max_radius_mm / RADIAL_GRID as f64;
        let grid_points: Option<Vec<usize>> = psfs
            .iter()
            .map(|p| {
                let position = chief.height_for_angle(p.field_deg) / step_mm;
                let k = position.round();
                // The angle came from the same piecewise-linear map: only rounding separates them.
                ((position - k).abs() < 1e-3 && (0.0..=RADIAL_GRID as f64).contains(&k)).then_some(k as usize)
            })
            .collect();
        let grid_points = grid_points?;
        if grid_points.first() != Some(&0)
            || grid_points.last() != Some(&RADIAL_GRID)
            || grid_points.windows(2).any(|pair| pair[0] >= pair[1])
        {
            return None;
        }
        Some(RadialPsfs {
            radii_mm: grid_points
                .iter()
                .map(|&k| grid_radius(max_radius_mm, k))
                .collect(),
            psfs,
            kernel_size,
            // The cap's request is not kept; `energy_cut` in each PSF still says what was cut.
            requested_kernel_size: kernel_size,
            checked_half_l1: None,
        })
    }

    /// The two samples around `radius_mm` and the weight of the second (clamped to the sampled range;
    /// a single sample brackets itself).
    fn bracket(&self, radius_mm: f64) -> (usize, usize, f64) {
        let last = self.radii_mm.len() - 1;
        let upper = self
            .radii_mm
            .partition_point(|&r| r <= radius_mm)
            .clamp(1, last.max(1))
            .min(last);
        let lower = upper.saturating_sub(1);
        let span = self.radii_mm[upper] - self.radii_mm[lower];
        let t = if span > 0.0 {
            ((radius_mm - self.radii_mm[lower]) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (lower, upper, t)
    }

    pub fn channels(&self) -> usize {
        self.psfs[0].kernels.len()
    }

    /// The PSF of `channel` at sensor point (x, y) mm: radial interpolation, then rotation.
    pub fn kernel_at(&self, x_mm: f64, y_mm: f64, channel: usize) -> Kernel {
        let (i, j, t) = self.bracket(x_mm.hypot(y_mm));
        let t = t as f32;
        let mut radial = Kernel::zeros(self.kernel_size, self.psfs[i].kernels[channel].pitch_um);
        radial.add_scaled(&self.psfs[i].kernels[channel], 1.0 - t);
        radial.add_scaled(&self.psfs[j].kernels[channel], t);
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
        let (i, j, t) = self.bracket(radius_mm);
        self.psfs[i].transmission * (1.0 - t) + self.psfs[j].transmission * t
    }
}

/// Radius (mm) of point k of the radial grid.
fn grid_radius(max_radius_mm: f64, k: usize) -> f64 {
    max_radius_mm * k as f64 / RADIAL_GRID as f64
}

/// The first samples of every refinement: `INITIAL_RADIAL_INTERVALS` + 1 uniform grid points.
fn initial_grid_points() -> Vec<usize> {
    let step = RADIAL_GRID / INITIAL_RADIAL_INTERVALS;
    (0..=INITIAL_RADIAL_INTERVALS).map(|i| i * step).collect()
}

/// Grid points of at most `budget` samples (at least the initial ones) placed by halving every interval,
/// level by level and from the axis outwards, while the budget lasts: uniform when it is 2^n + 1.
fn halved_grid_points(budget: usize) -> Vec<usize> {
    let mut points = initial_grid_points();
    let mut intervals: Vec<(usize, usize)> = points.windows(2).map(|pair| (pair[0], pair[1])).collect();
    while !intervals.is_empty() {
        let mut next = Vec::new();
        for (lo, hi) in intervals {
            if points.len() < budget && hi - lo >= 2 {
                let middle = (lo + hi) / 2;
                points.push(middle);
                next.extend([(lo, middle), (middle, hi)]);
            }
        }
        intervals = next;
    }
    points.sort_unstable();
    points
}

/// The refinement of `RadialSampling` with a tolerance: the traced fields by grid point, and the
/// checked bound (`RadialPsfs::checked_half_l1`).
fn refine(
    tracer: &PsfTracer,
    trace_at: &dyn Fn(&[usize]) -> unicac_psf::PsfResult<Vec<TracedField>>,
    sampling: RadialSampling,
    monochromatic: bool,
) -> SimResult<(BTreeMap<usize, TracedField>, f64)> {
    let initial = initial_grid_points();
    let first = trace_at(&initial)?;
    // The checks compare kernels at the first samples' common size (the corner's spot is nearly
    // always the largest); the result is rasterised again at the size of all samples.
    let start = tracer.rasterise_common_size(&first, monochromatic, DarkFields::AllowedIfAnyLit)?;
    let check_px = start.kernel_px;
    let mut checked: BTreeMap<usize, FieldPsf> = initial.iter().copied().zip(start.psfs).collect();
    let mut traced: BTreeMap<usize, TracedField> = initial.iter().copied().zip(first).collect();
    let mut pending: Vec<Interval> = initial
        .windows(2)
        .map(|pair| Interval {
            lo: pair[0],
            hi: pair[1],
            parent_error: f64::INFINITY,
        })
        .collect();
    let mut checked_half_l1 = 0.0f64;
    let budget = sampling.max_samples.max(initial.len());
    while !pending.is_empty() {
        // Largest errors first when the budget cannot cover every interval; intervals at the finest
        // step, or beyond the budget, stay as they are with their parent's error.
        pending.sort_by(|a, b| b.parent_error.total_cmp(&a.parent_error));
        let mut room = budget.saturating_sub(traced.len());
        let mut now = Vec::new();
        for interval in pending {
            if room > 0 && interval.hi - interval.lo >= 2 {
                room -= 1;
                now.push(interval);
            } else if interval.parent_error.is_finite() {
                checked_half_l1 = checked_half_l1.max(interval.parent_error);
            }
        }
        let middles: Vec<usize> = now.iter().map(|i| (i.lo + i.hi) / 2).collect();
        let fields = trace_at(&middles)?;
        pending = Vec::new();
        for ((interval, &k), field) in now.iter().zip(&middles).zip(fields) {
            let psf = tracer.rasterise_field(&field, check_px, monochromatic);
            let error = midpoint_half_l1(&checked[&interval.lo], &checked[&interval.hi], &psf);
            checked.insert(k, psf);
            traced.insert(k, field);
            if error > sampling.tolerance {
                for (lo, hi) in [(interval.lo, k), (k, interval.hi)] {
                    pending.push(Interval {
                        lo,
                        hi,
                        parent_error: error,
                    });
                }
            } else {
                checked_half_l1 = checked_half_l1.max(error);
            }
        }
    }
    Ok((traced, checked_half_l1))
}

/// Half-L1 distance (largest channel) between the PSF traced at an interval's midpoint and the one
/// linear interpolation gives there from the interval's ends (all rasterised at one size).
fn midpoint_half_l1(lo: &FieldPsf, hi: &FieldPsf, middle: &FieldPsf) -> f64 {
    middle
        .kernels
        .iter()
        .zip(lo.kernels.iter().zip(&hi.kernels))
        .map(|(m, (a, b))| {
            let sum: f64 = m
                .data
                .iter()
                .zip(a.data.iter().zip(&b.data))
                .map(|(&m, (&a, &b))| (m as f64 - 0.5 * (a as f64 + b as f64)).abs())
                .sum();
            0.5 * sum
        })
        .fold(0.0, f64::max)
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

    #[test]
    fn a_power_of_two_budget_plus_one_halves_into_uniform_samples() {
        let uniform = |n: usize| (0..n).map(|i| i * RADIAL_GRID / (n - 1)).collect::<Vec<_>>();
        for n in [5, 9, 17, 33, 65] {
            assert_eq!(halved_grid_points(n), uniform(n), "{n} samples");
        }
        // A budget between levels halves from the axis outwards; below the start it keeps the start;
        // above the grid it stops at the finest step.
        assert_eq!(halved_grid_points(6), vec![0, 8, 16, 32, 48, 64]);
        assert_eq!(halved_grid_points(2), uniform(5));
        assert_eq!(halved_grid_points(1000), uniform(RADIAL_GRID + 1));
    }
}
