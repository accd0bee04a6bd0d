//! PSF accumulation: the kernel against its twin, against the CPU rasteriser, and against itself
//! (determinism: same input, same grid, bit for bit, whatever the chunking). Figures are printed.

mod support;

use support::{lens, tracer_or_skip};
use unicac_gpu::layout::{self, Params};
use unicac_gpu::psf::field_psf;
use unicac_gpu::{twin, GpuTracer, ParaxialAim, Precision, PsfPass, PupilSource, RaySource, SplatGrid};
use unicac_psf::{PsfSettings, PsfTracer, SpectralResponse, SpectralWeights};
use unicac_trace::{Clipping, PupilSampling, TraceSystem};

fn setup(name: &str, field_index: usize) -> (unicac_optics::Lens, TraceSystem, PupilSource, SplatGrid) {
    let lens = lens(name);
    let field = lens.first_order().unwrap().field_angles_deg[field_index];
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let chief = unicac_psf::ChiefReference::new(&lens)
        .unwrap()
        .point_mm(field)
        .unwrap();
    let source = PupilSource {
        sampling: PupilSampling::Random { n: 200_000, seed: 1 },
        aim: ParaxialAim::new(&lens, field).unwrap(),
    };
    let grid = SplatGrid {
        size: 31,
        oversample: 4,
        pixel_um: 2.0,
        chief_mm: chief,
    };
    (lens, system, source, grid)
}

#[test]
fn accumulation_is_deterministic_bit_for_bit_across_runs_and_chunkings() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(tracer) = tracer_or_skip(precision) else {
            return;
        };
        let small = GpuTracer::with_chunk_rays(tracer.context().clone(), precision, 4096).unwrap();
        let (_, system, source, grid) = setup("phone_asphere", 2);
        let pass = PsfPass {
            system: &system,
            source: RaySource::Pupil(source),
            weights: [0.2 / 200_000.0, 0.5 / 200_000.0, 0.3 / 200_000.0],
        };
        let runs: Vec<_> = (0..3)
            .map(|_| tracer.accumulate_psf(&grid, &[pass]).unwrap())
            .chain([small.accumulate_psf(&grid, &[pass]).unwrap()])
            .collect();
        let nonzero = runs[0].grid.iter().filter(|v| **v != 0).count();
        for run in &runs[1..] {
            assert!(run == &runs[0], "{precision}: grids differ between runs");
        }
        println!(
            "{precision}: 3 runs (chunks of {}) and 1 run in chunks of 4096: identical grids ({nonzero} non-zero cells of {}), {} rays arrived",
            tracer.chunk_rays(),
            runs[0].grid.len(),
            runs[0].counts[0].ok
        );
        assert!(nonzero > 100);
    }
}

fn twin_grid<R: unicac_gpu::Real>(
    system: &TraceSystem,
    source: &PupilSource,
    grid: &SplatGrid,
    weights: [f64; 3],
) -> Vec<u64> {
    let surfaces = layout::surfaces::<R>(system);
    let mut params = Params::<R> {
        surface_count: surfaces.len() as u32,
        ray_count: source.slots().unwrap() as u32,
        chief_x_mm: R::from_f64(grid.chief_mm[0]),
        chief_y_mm: R::from_f64(grid.chief_mm[1]),
        sub_pitch_um: R::from_f64(grid.pixel_um / grid.oversample as f64),
        weight_r: R::from_f64(weights[0]),
        weight_g: R::from_f64(weights[1]),
        weight_b: R::from_f64(weights[2]),
        fine_size: grid.fine() as u32,
        ..Default::default()
    };
    unicac_gpu::psf::fill_source(source, &mut params);
    let mut cells = vec![0u64; 3 * grid.fine() * grid.fine()];
    twin::accumulate_kernel(&params, &surfaces, &[], &mut cells);
    cells
}

#[test]
fn accumulation_kernel_matches_its_twin() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(tracer) = tracer_or_skip(precision) else {
            return;
        };
        let (_, system, source, grid) = setup("cooke_triplet", 1);
        let weights = [0.2 / 200_000.0, 0.5 / 200_000.0, 0.3 / 200_000.0];
        let pass = PsfPass {
            system: &system,
            source: RaySource::Pupil(source),
            weights,
        };
        let gpu = tracer.accumulate_psf(&grid, &[pass]).unwrap();
        let twin = match precision {
            Precision::F32 => twin_grid::<f32>(&system, &source, &grid, weights),
            Precision::F64 => twin_grid::<f64>(&system, &source, &grid, weights),
        };
        let total: u64 = twin.iter().sum();
        let difference: u64 = gpu.grid.iter().zip(&twin).map(|(a, b)| a.abs_diff(*b)).sum();
        println!(
            "{precision}: GPU grid vs twin: summed |difference| {difference} of {total} fixed-point units ({:.2e} relative)",
            difference as f64 / total as f64
        );
        assert!(difference as f64 <= 1e-9 * total as f64);
    }
}

#[test]
fn gpu_psf_matches_the_cpu_psf() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(tracer) = tracer_or_skip(precision) else {
            return;
        };
        for (name, field_index) in [("cooke_triplet", 2), ("phone_asphere", 1), ("double_gauss", 0)] {
            let lens = lens(name);
            let field = lens.first_order().unwrap().field_angles_deg[field_index];
            let weights = SpectralWeights::new(
                &SpectralResponse::default_camera(),
                &unicac_psf::visible_wavelengths_um(11),
            );
            let mut settings = PsfSettings::new(2.0);
            settings.pupil_sampling = PupilSampling::Fibonacci { n: 4096 };
            let cpu = PsfTracer::new(&lens, weights.clone(), settings.clone()).unwrap();
            let expected = cpu.field_psf(field, 31, false).unwrap();
            let got = field_psf(&tracer, &lens, &weights, &settings, field, 31, false).unwrap();
            let mut worst_l1 = 0.0f64;
            for (a, b) in expected.kernels.iter().zip(&got.kernels) {
                let l1: f64 = a
                    .data
                    .iter()
                    .zip(&b.data)
                    .map(|(x, y)| (x - y).abs() as f64)
                    .sum();
                worst_l1 = worst_l1.max(l1);
            }
            let transmission = (expected.transmission - got.transmission).abs();
            println!(
                "{precision} {name} field {field}: kernel L1 vs CPU {worst_l1:.2e}, transmission {:.6} vs {:.6}",
                got.transmission, expected.transmission
            );
            // f32 hit positions differ by nanometres, moving bilinear weights by ~1e-3 of a sub-cell.
            let limit = if precision == Precision::F32 { 2e-3 } else { 1e-5 };
            assert!(worst_l1 < limit, "{name}: {worst_l1}");
            assert!(transmission < 1e-12, "{name}");
        }
    }
}

/// The `HitTracer` hook: a `PsfTracer` whose rays go through the GPU gives the CPU's PSF.
#[test]
fn psf_tracer_with_the_gpu_hit_tracer_matches_the_cpu() {
    let Some(tracer) = tracer_or_skip(Precision::F32) else {
        return;
    };
    let lens = lens("phone_asphere");
    let weights = SpectralWeights::new(
        &SpectralResponse::default_camera(),
        &unicac_psf::visible_wavelengths_um(7),
    );
    let settings = PsfSettings::new(1.5);
    let cpu = PsfTracer::new(&lens, weights.clone(), settings.clone()).unwrap();
    let backend = unicac_psf::RayBackend::new(std::sync::Arc::new(unicac_gpu::GpuHitTracer::new(tracer, 0)));
    let gpu = PsfTracer::new(&lens, weights, settings.with_backend(backend)).unwrap();
    let field = 25.0;
    let expected = cpu.field_psf(field, 41, false).unwrap();
    let got = gpu.field_psf(field, 41, false).unwrap();
    let l1: f64 = expected
        .kernels
        .iter()
        .zip(&got.kernels)
        .map(|(a, b)| {
            a.data
                .iter()
                .zip(&b.data)
                .map(|(x, y)| (x - y).abs() as f64)
                .sum::<f64>()
        })
        .fold(0.0, f64::max);
    println!(
        "PsfTracer through GpuHitTracer (f32): worst channel L1 vs CPU {l1:.2e}, transmission {} vs {}",
        got.transmission, expected.transmission
    );
    assert!(l1 < 2e-3, "{l1}");
    assert_eq!(got.transmission, expected.transmission);
}

#[test]
fn a_device_backend_names_its_device_before_its_first_trace() {
    // PSF cache keys are made before any ray is traced: a `--device gpu` run described itself as
    // "cpu" until then, so its f32 PSFs were stored under the CPU's key and served to CPU runs.
    if support::gpu_or_skip().is_none() {
        return;
    }
    let gpu = unicac_gpu::DeviceSelection::backend(unicac_gpu::DeviceChoice::Gpu, Precision::F32);
    let described = gpu.describe();
    eprintln!("--device gpu before any trace: {described}");
    assert!(described.starts_with("gpu (f32, "), "{described}");
    assert_ne!(gpu, unicac_psf::RayBackend::cpu());
    // `auto` takes a GPU only with a hardware adapter; without one it traces on the CPU, and says so.
    if !unicac_gpu::select::hardware_gpu_node_present() {
        let auto = unicac_gpu::DeviceSelection::backend(unicac_gpu::DeviceChoice::Auto, Precision::F32);
        assert_eq!(auto.describe(), "cpu");
    }
}
