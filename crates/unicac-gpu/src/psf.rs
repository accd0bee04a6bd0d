//! PSF accumulation on the device: rays are traced and splatted onto the supersampled grid of
//! `unicac_psf::kernel::rasterise`, weighted into R, G, B, in one kernel (psf.wgsl) with nothing but
//! the grid coming back. Sums are 64-bit fixed point added with integer atomics, so the grid is the
//! same bit for bit run after run, whatever the dispatch order or chunking.

use crate::device::GpuResult;
use crate::layout::{self, Params};
use crate::real::{Precision, Real};
use crate::source::{ParaxialAim, PupilSource, RaySource};
use crate::trace::GpuTracer;
use crate::twin::FIXED_SCALE;
use unicac_optics::Lens;
use unicac_psf::{ChiefReference, FieldPsf, Kernel, PsfSettings, SpectralWeights};
use unicac_trace::{Aiming, Clipping, StatusCounts, TraceSystem};

/// The kernel being accumulated: `size` pixels (odd) at `pixel_um`, `oversample` sub-cells per pixel
/// and axis, centred on `chief_mm` (image-surface x, y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplatGrid {
    pub size: usize,
    pub oversample: usize,
    pub pixel_um: f64,
    pub chief_mm: [f64; 2],
}

impl SplatGrid {
    pub fn fine(&self) -> usize {
        self.size * self.oversample
    }
}

/// One wavelength's rays and what each ray weighs in R, G, B.
#[derive(Debug, Clone, Copy)]
pub struct PsfPass<'a> {
    pub system: &'a TraceSystem,
    pub source: RaySource<'a>,
    pub weights: [f64; 3],
}

/// The accumulated fine grid (3 channels x fine^2 cells, 2^44 units per unit weight) and each pass's
/// status counts.
#[derive(Debug, Clone, PartialEq)]
pub struct Accumulated {
    pub fine: usize,
    pub grid: Vec<u64>,
    pub counts: Vec<StatusCounts>,
}

impl Accumulated {
    /// Per-channel kernels at the pixel pitch (each pixel sums its oversample^2 cells), not normalised:
    /// `rasterise` + `combine_channels` before normalisation.
    pub fn kernels(&self, grid: &SplatGrid) -> Vec<Kernel> {
        let (fine, over) = (self.fine, grid.oversample);
        (0..3)
            .map(|c| {
                let cells = &self.grid[c * fine * fine..(c + 1) * fine * fine];
                let mut kernel = Kernel::zeros(grid.size, grid.pixel_um);
                for y in 0..grid.size {
                    for x in 0..grid.size {
                        let mut sum = 0u64;
                        for sy in 0..over {
                            let row = (y * over + sy) * fine + x * over;
                            sum += cells[row..row + over].iter().sum::<u64>();
                        }
                        kernel.data[y * grid.size + x] = (sum as f64 / FIXED_SCALE) as f32;
                    }
                }
                kernel
            })
            .collect()
    }
}

impl GpuTracer {
    /// Traces and splats every pass into one grid.
    pub fn accumulate_psf(&self, grid: &SplatGrid, passes: &[PsfPass]) -> GpuResult<Accumulated> {
        unicac_trace::check_odd("grid.size", grid.size)?;
        unicac_trace::check_at_least("grid.oversample", grid.oversample, 1)?;
        unicac_trace::check_positive("grid.pixel_um", grid.pixel_um)?;
        match self.precision() {
            Precision::F32 => self.accumulate::<f32>(grid, passes),
            Precision::F64 => self.accumulate::<f64>(grid, passes),
        }
    }

    fn accumulate<R: Real>(&self, grid: &SplatGrid, passes: &[PsfPass]) -> GpuResult<Accumulated> {
        let fine = grid.fine();
        let words = 3 * fine * fine * 2;
        let mut buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        let mut counts = Vec::with_capacity(passes.len());
        let mut cleared = false;
        let mut previous = StatusCounts::default();
        for pass in passes {
            layout::check_supported(pass.system)?;
            let surfaces = layout::surfaces::<R>(pass.system);
            if !cleared {
                self.begin(&mut buffers, &surfaces, words)?;
                cleared = true;
            } else {
                self.context
                    .queue
                    .write_buffer(&buffers.surfaces, 0, bytemuck::cast_slice(&surfaces));
            }
            let slots = pass.source.slots()? as usize;
            for first in (0..slots).step_by(self.chunk_rays()) {
                let count = self.chunk_rays().min(slots - first);
                let mut params: Params<R> =
                    self.chunk_params(&pass.source, &buffers, surfaces.len(), first, count);
                params.chief_x_mm = R::from_f64(grid.chief_mm[0]);
                params.chief_y_mm = R::from_f64(grid.chief_mm[1]);
                params.sub_pitch_um = R::from_f64(grid.pixel_um / grid.oversample as f64);
                params.weight_r = R::from_f64(pass.weights[0]);
                params.weight_g = R::from_f64(pass.weights[1]);
                params.weight_b = R::from_f64(pass.weights[2]);
                params.fine_size = fine as u32;
                self.dispatch(&buffers, self.psf_pipeline(), &params, count);
            }
            // Counters accumulate over passes: each pass's counts are the difference.
            let total = self.read_counters(&buffers)?;
            counts.push(difference(total, previous));
            previous = total;
        }
        let grid = if cleared {
            self.read_grid(&buffers, words)?
        } else {
            vec![0; words / 2]
        };
        Ok(Accumulated { fine, grid, counts })
    }
}

/// The pattern and aiming fields of `params` for `source` (for twins and tests).
pub fn fill_source<R: Real>(source: &PupilSource, params: &mut Params<R>) {
    source.fill(params);
}

fn difference(a: StatusCounts, b: StatusCounts) -> StatusCounts {
    StatusCounts {
        ok: a.ok - b.ok,
        missed: a.missed - b.missed,
        tir: a.tir - b.tir,
        clipped: a.clipped - b.clipped,
        no_convergence: a.no_convergence - b.no_convergence,
        invalid_input: a.invalid_input - b.invalid_input,
    }
}

/// A geometric PSF of one field accumulated on the GPU: what `PsfTracer::field_psf` computes, with the
/// pupil sampled on the device (paraxial aiming) or aimed on the CPU (real aiming).
pub fn field_psf(
    tracer: &GpuTracer,
    lens: &Lens,
    weights: &SpectralWeights,
    settings: &PsfSettings,
    field_deg: f64,
    size: usize,
    monochromatic: bool,
) -> GpuResult<FieldPsf> {
    let chief_mm = ChiefReference::new(lens)?.point_mm(field_deg)?;
    let grid = SplatGrid {
        size: size.min(settings.max_kernel_px) | 1,
        oversample: settings.oversample,
        pixel_um: settings.pixel_um,
        chief_mm,
    };
    let aim = ParaxialAim::new(lens, field_deg)?;
    let pupil = PupilSource {
        sampling: settings.pupil_sampling,
        aim,
    };
    pupil.slots()?;
    let systems = weights
        .wavelengths_um
        .iter()
        .map(|&w| TraceSystem::new(lens, w, Clipping::Apertures))
        .collect::<Result<Vec<_>, _>>()?;
    let aiming = settings.aiming.resolve(lens)?;
    let host_rays: Vec<Vec<unicac_trace::Ray>> = match aiming {
        Aiming::Paraxial => Vec::new(),
        Aiming::Real | Aiming::Auto => {
            let points = settings.pupil_sampling.points();
            systems
                .iter()
                .map(|s| {
                    let aimer = unicac_trace::Aimer::new(lens, s.wavelength_um, Aiming::Real)?;
                    Ok(points
                        .iter()
                        .filter_map(|[px, py]| aimer.ray(field_deg, *px, *py).ok())
                        .collect())
                })
                .collect::<GpuResult<_>>()?
        }
    };
    // Rays per wavelength: the pattern's points (grid: only the cells inside the disc).
    let traced = settings.pupil_sampling.points().len() as f64;
    let passes: Vec<PsfPass> = systems
        .iter()
        .enumerate()
        .map(|(i, system)| PsfPass {
            system,
            source: match aiming {
                Aiming::Paraxial => RaySource::Pupil(pupil),
                Aiming::Real | Aiming::Auto => RaySource::Host(&host_rays[i]),
            },
            weights: weights.weights[i].map(|w| w / traced),
        })
        .collect();
    let accumulated = tracer.accumulate_psf(&grid, &passes)?;
    let per_channel = accumulated.kernels(&grid);
    // The CPU path's bookkeeping (unicac_psf::spectrum::combine_channels): energy that arrived per
    // channel, the part of it outside the kernel, then unit-sum kernels.
    let channels = if monochromatic { 1 } else { 3 };
    let arrived: Vec<f64> = accumulated.counts.iter().map(|c| c.ok as f64 / traced).collect();
    let mut kernels = Vec::with_capacity(channels);
    let mut energy_cut = Vec::with_capacity(channels);
    let mut transmission = 0.0;
    for (c, mut kernel) in per_channel.into_iter().take(channels).enumerate() {
        let fraction: f64 = arrived.iter().zip(&weights.weights).map(|(a, w)| a * w[c]).sum();
        energy_cut.push(if fraction > 0.0 {
            (1.0 - kernel.sum() / fraction).max(0.0)
        } else {
            0.0
        });
        transmission += fraction / channels as f64;
        kernel.normalise();
        kernels.push(kernel);
    }
    Ok(FieldPsf {
        field_deg,
        field_x_deg: 0.0,
        reference_mm: chief_mm,
        kernels,
        transmission,
        energy_cut,
        rays_traced: traced as usize * systems.len(),
    })
}
