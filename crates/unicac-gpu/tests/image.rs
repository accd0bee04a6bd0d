//! The simulator's image pass on the GPU (shaders/blur.wgsl, geometry.wgsl) against its twin, the CPU
//! path, on the same simulator: the blur alone, the whole pass (warp and shading), a window, the
//! nearest-corner blend; and against itself (bit for bit, run after run). Figures are printed.
//!
//! Tolerances (stated in docs/gpu.md), per sample of an image in 0..1: both paths blend by the same
//! weights and crops in the same order, so the blur equals the CPU's direct tiles bit for bit and its
//! FFT tiles within their rounding (`BLUR_TOLERANCE`); the warp's source positions are the exact pixel
//! index plus an f32 offset (~1e-6 px from the CPU's f64 position) and the tables are f32, so the whole
//! pass stays within `PASS_TOLERANCE` and above `PASS_PSNR_DB`.

mod support;

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use support::{gpu_or_skip, lens};
use unicac_gpu::{DeviceChoice, DeviceSelection, GpuContext, GpuImagePass, Precision};
use unicac_image::isp::{Demosaic, IspDevice, Pipeline, SensorNoise, WhiteBalanceGains};
use unicac_image::Planar;
use unicac_sim::convolve::{Blend, Method};
use unicac_sim::psf_map::RadialSampling;
use unicac_sim::{ImageBackend, ImageDevice, LensSimulator, PixelWindow, SimulationSettings};

const BLUR_TOLERANCE: f32 = 1e-6;
const PASS_TOLERANCE: f32 = 2e-6;
const PASS_PSNR_DB: f64 = 130.0;

/// The GPU image pass as the simulator's device (it takes every pass; a failure would be a note).
fn gpu_backend(context: &Arc<GpuContext>) -> ImageBackend {
    ImageBackend::new(Arc::new(GpuImagePass::new(context.clone())))
}

/// A fast simulator (5 wavelengths, 9 radial PSFs) of a bundled lens.
fn simulator(name: &str, width: usize, height: usize, distortion: bool, method: Method) -> LensSimulator {
    let settings = SimulationSettings {
        wavelengths: 5,
        radial: RadialSampling {
            max_samples: 9,
            ..SimulationSettings::default().radial
        },
        distortion,
        illumination: distortion,
        method,
        ..SimulationSettings::default()
    };
    LensSimulator::new(&lens(name), width, height, None, settings).unwrap()
}

/// A sharp test scene in 0..1: checkerboard squares of several sizes, a ramp and hashed noise.
fn scene(width: usize, height: usize) -> Planar {
    let mut image = Planar::new(width, height, 3);
    for c in 0..3 {
        let plane = image.plane_mut(c);
        for y in 0..height {
            for x in 0..width {
                let hash = ((x * 73_856_093) ^ (y * 19_349_663) ^ (c * 83_492_791)) % 1000;
                let checker = ((x / (4 + 3 * c)) + (y / 7)) % 2;
                let ramp = x as f32 / width as f32;
                plane[y * width + x] = 0.5 * checker as f32 + 0.3 * ramp + 0.2 * hash as f32 / 1000.0;
            }
        }
    }
    image
}

/// Largest per-sample difference and PSNR (peak 1).
fn compare(a: &Planar, b: &Planar) -> (f32, f64) {
    assert_eq!((a.width, a.height, a.channels), (b.width, b.height, b.channels));
    let worst = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    let mse = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| f64::from(x - y).powi(2))
        .sum::<f64>()
        / a.data.len() as f64;
    (worst, 10.0 * (1.0 / mse.max(1e-30)).log10())
}

fn cpu_and_gpu(
    sim: &mut LensSimulator,
    context: &Arc<GpuContext>,
    run: impl Fn(&LensSimulator) -> Planar,
) -> (Planar, Planar) {
    sim.settings.image = ImageBackend::cpu();
    let cpu = run(sim);
    sim.settings.image = gpu_backend(context);
    let gpu = run(sim);
    let notes = sim.settings.image.take_notes();
    assert!(notes.is_empty(), "the GPU pass failed: {notes:?}");
    (cpu, gpu)
}

#[test]
fn the_blur_equals_the_cpu_path_up_to_summation_order() {
    let Some(context) = gpu_or_skip() else {
        return;
    };
    for (name, method) in [
        ("cooke_triplet", Method::Direct),
        ("phone_asphere", Method::Auto),
        ("cooke_triplet", Method::Fft),
    ] {
        let (width, height) = (240, 180);
        let mut sim = simulator(name, width, height, false, method);
        let image = scene(width, height);
        let (cpu, gpu) = cpu_and_gpu(&mut sim, &context, |s| s.apply(&image).unwrap());
        let (worst, psnr) = compare(&cpu, &gpu);
        println!("{name} {method:?} {width}x{height} blur: worst {worst:.2e}, PSNR {psnr:.1} dB");
        assert!(worst <= BLUR_TOLERANCE, "{name} {method:?}: worst {worst}");
        if method == Method::Direct {
            assert!(worst == 0.0, "direct tiles: bit for bit; worst {worst}");
        }
    }
}

#[test]
fn the_whole_pass_with_warp_and_shading_matches_the_cpu_path() {
    let Some(context) = gpu_or_skip() else {
        return;
    };
    for name in ["cooke_triplet", "phone_asphere", "wide_angle"] {
        let (width, height) = (320, 240);
        let mut sim = simulator(name, width, height, true, Method::Auto);
        let image = scene(width, height);
        let (cpu, gpu) = cpu_and_gpu(&mut sim, &context, |s| s.apply(&image).unwrap());
        let (worst, psnr) = compare(&cpu, &gpu);
        println!("{name} {width}x{height} blur + warp + shading: worst {worst:.2e}, PSNR {psnr:.1} dB");
        assert!(worst <= PASS_TOLERANCE, "{name}: worst {worst}");
        assert!(psnr >= PASS_PSNR_DB, "{name}: PSNR {psnr}");
        // The two halves on their own (the dataset builder's calls): the blur, the geometry.
        let (cpu, gpu) = cpu_and_gpu(&mut sim, &context, |s| s.blur(&image).unwrap());
        let (worst, _) = compare(&cpu, &gpu);
        assert!(worst <= BLUR_TOLERANCE, "{name} blur alone: worst {worst}");
        let (cpu, gpu) = cpu_and_gpu(&mut sim, &context, |s| s.geometry(&image).unwrap());
        let (worst, psnr) = compare(&cpu, &gpu);
        println!("{name} geometry alone: worst {worst:.2e}, PSNR {psnr:.1} dB");
        assert!(worst <= PASS_TOLERANCE, "{name} geometry alone: worst {worst}");
        // A window of the frame through the same pass.
        let window = PixelWindow {
            x0: 200,
            y0: 30,
            width: 96,
            height: 80,
        };
        let (cpu, gpu) = cpu_and_gpu(&mut sim, &context, |s| s.apply_window(&image, window).unwrap());
        let (worst, psnr) = compare(&cpu, &gpu);
        println!("{name} window {window:?}: worst {worst:.2e}, PSNR {psnr:.1} dB");
        assert!(
            worst <= PASS_TOLERANCE && psnr >= PASS_PSNR_DB,
            "{name} window: {worst} {psnr}"
        );
    }
}

#[test]
fn flat_tiles_take_the_cpu_paths_shortcut_bit_for_bit() {
    let Some(context) = gpu_or_skip() else {
        return;
    };
    let (width, height) = (320, 240);
    let mut sim = simulator("cooke_triplet", width, height, false, Method::Direct);
    // The left half flat, the right half textured.
    let mut image = scene(width, height);
    for c in 0..3 {
        for row in image.plane_mut(c).chunks_mut(width) {
            row[..width / 2].fill(0.3);
        }
    }
    let grid = &sim.kernel_grids()[1];
    let layout = unicac_sim::convolve::TileLayout::new(width, height, grid, sim.settings.kernel_tail);
    let flat = layout.flat_tiles(image.plane(1), grid);
    let count = flat.iter().filter(|f| f.is_some()).count();
    assert!(
        count > 0 && count < flat.len(),
        "{count} flat tiles of {}",
        flat.len()
    );
    let (cpu, gpu) = cpu_and_gpu(&mut sim, &context, |s| s.apply(&image).unwrap());
    let (worst, _) = compare(&cpu, &gpu);
    println!("{count} of {} tiles flat: worst {worst:.2e}", flat.len());
    assert!(worst == 0.0, "direct and flat tiles: bit for bit; worst {worst}");
}

#[test]
fn the_nearest_corner_blend_matches_the_cpu_path() {
    let Some(context) = gpu_or_skip() else {
        return;
    };
    let (width, height) = (200, 150);
    let mut sim = simulator("phone_asphere", width, height, false, Method::Direct);
    sim.settings.blend = Blend::Nearest;
    let image = scene(width, height);
    let (cpu, gpu) = cpu_and_gpu(&mut sim, &context, |s| s.apply(&image).unwrap());
    let (worst, psnr) = compare(&cpu, &gpu);
    println!("phone_asphere nearest blend: worst {worst:.2e}, PSNR {psnr:.1} dB");
    assert!(worst == 0.0, "direct tiles: bit for bit; worst {worst}");
}

#[test]
fn the_gpu_pass_is_deterministic_bit_for_bit() {
    let Some(context) = gpu_or_skip() else {
        return;
    };
    let (width, height) = (240, 180);
    let mut sim = simulator("phone_asphere", width, height, true, Method::Auto);
    sim.settings.image = gpu_backend(&context);
    let image = scene(width, height);
    let first = sim.apply(&image).unwrap();
    for _ in 0..2 {
        assert!(sim.apply(&image).unwrap().data == first.data, "runs differ");
    }
}

#[test]
fn auto_leaves_small_or_software_jobs_on_the_cpu() {
    let (width, height) = (64, 48);
    let mut sim = simulator("cooke_triplet", width, height, true, Method::Auto);
    let image = scene(width, height);
    let cpu = sim.apply(&image).unwrap();
    let selection = Arc::new(DeviceSelection::new(DeviceChoice::Auto, Precision::F32));
    sim.settings.image = DeviceSelection::image_backend(&selection);
    let auto = sim.apply(&image).unwrap();
    assert!(
        auto.data == cpu.data,
        "auto on a small image is the CPU path, bit for bit"
    );
    assert_eq!(sim.settings.image.describe(), "cpu");
    assert!(sim.settings.image.take_notes().is_empty());
}

/// The GPU pass as a device that counts the ISP steps it is asked for: [read-outs, developments].
struct CountingDevice(GpuImagePass, [AtomicUsize; 2]);

impl ImageDevice for CountingDevice {
    fn apply(&self, pass: &unicac_sim::ImagePass) -> Option<Planar> {
        ImageDevice::apply(&self.0, pass)
    }
    fn describe(&self) -> String {
        self.0.describe()
    }
    fn take_notes(&self) -> Vec<String> {
        ImageDevice::take_notes(&self.0)
    }
}

impl IspDevice for CountingDevice {
    fn read_out(&self, exposure: &Planar, sensor: &SensorNoise, seed: u64) -> Option<Planar> {
        self.1[0].fetch_add(1, Ordering::Relaxed);
        IspDevice::read_out(&self.0, exposure, sensor, seed)
    }
    fn develop(
        &self,
        dn: &Planar,
        sensor: &SensorNoise,
        gains: WhiteBalanceGains,
        method: Demosaic,
    ) -> Option<Planar> {
        self.1[1].fetch_add(1, Ordering::Relaxed);
        IspDevice::develop(&self.0, dn, sensor, gains, method)
    }
}

/// `LensSimulator::process` on a GPU backend reads the sensor out and develops the mosaic on the
/// device (the output encoding on the CPU), and comes out close to the CPU's: the development is
/// bit for bit the CPU's on lavapipe, the read-out's f32 draws move a few samples.
#[test]
fn the_simulators_isp_steps_run_on_its_image_device() {
    let Some(context) = gpu_or_skip() else {
        return;
    };
    let mut sim = simulator("cooke_triplet", 640, 480, true, Method::Auto);
    let pipeline = Pipeline::default();
    let draw = pipeline.draw(5).unwrap();
    let raw = scene(640, 480);
    let cpu = sim.process(&pipeline, &raw, &draw).unwrap();
    let device = Arc::new(CountingDevice(
        GpuImagePass::new(context.clone()),
        Default::default(),
    ));
    sim.settings.image = ImageBackend::new(device.clone());
    let gpu = sim.process(&pipeline, &raw, &draw).unwrap();
    assert!(sim.settings.image.take_notes().is_empty());
    let counts = |d: &CountingDevice| d.1.each_ref().map(|c| c.load(Ordering::Relaxed));
    assert_eq!(
        counts(&device),
        [1, 1],
        "one read-out and one development on the device"
    );
    let (worst, psnr) = compare(&cpu, &gpu);
    let differ = cpu.data.iter().zip(&gpu.data).filter(|(a, b)| a != b).count();
    eprintln!(
        "ISP with read-out and development on the device vs the CPU: {differ} of {} samples differ, \
         worst {worst:.2e}, PSNR {psnr:.1} dB",
        cpu.data.len()
    );
    assert!(psnr > 60.0, "PSNR {psnr}");
    // Noiseless, nothing is drawn: the read-out stays on the CPU, the development goes to the device,
    // and the result is the CPU's (lavapipe rounds as the CPU does).
    let quiet = Pipeline {
        no_noise: true,
        ..pipeline
    };
    let quiet_draw = quiet.draw(5).unwrap();
    let quiet_gpu = sim.process(&quiet, &raw, &quiet_draw).unwrap();
    assert_eq!(counts(&device), [1, 2]);
    sim.settings.image = ImageBackend::cpu();
    let quiet_cpu = sim.process(&quiet, &raw, &quiet_draw).unwrap();
    let (worst, _) = compare(&quiet_cpu, &quiet_gpu);
    eprintln!("noiseless ISP, development on the device vs the CPU: worst {worst:.2e}");
    assert!(worst <= 1e-6, "worst {worst}");
}
