//! The simulator's image pass on the GPU against the CPU path, on one dead-leaves frame (docs/gpu.md):
//! the run time of each (library calls, PSF map built once beforehand), their per-sample difference and
//! PSNR, and the blur's multiply-adds (each pixel's four corner kernels at its tile's crop), from which
//! the device's sustained rate and a time for any other device follow.
//!
//! Run: cargo run --release -p unicac-gpu --example image_pass [LENS] [WIDTHxHEIGHT] [count|sweep]
//! (default phone_asphere 1600x1200; `count`: the CPU path and the multiply-adds only, no GPU run: a
//! 12 MP frame takes ~15 min per run on lavapipe; `sweep`: the GPU's run time against its error over
//! the kernel crop `kernel_tail`, the one fidelity setting it has, against the CPU path at tail 0)

use std::sync::Arc;
use std::time::Instant;
use unicac_gpu::{GpuContext, GpuImagePass};
use unicac_image::charts::dead_leaves;
use unicac_image::Planar;
use unicac_optics::builtin;
use unicac_sim::convolve::TileLayout;
use unicac_sim::{ImageBackend, LensSimulator, SimulationSettings};

fn timed(sim: &LensSimulator, image: &Planar) -> (Planar, f64) {
    let start = Instant::now();
    let out = sim.apply(image).expect("simulation");
    (out, start.elapsed().as_secs_f64())
}

/// The blur's multiply-adds: each pixel's four corner kernels at its tile's crop.
fn multiply_adds(sim: &LensSimulator) -> f64 {
    let (width, height) = (sim.grid.width_px, sim.grid.height_px);
    sim.kernel_grids()
        .iter()
        .map(|grid| {
            let layout = TileLayout::new(width, height, grid, sim.settings.kernel_tail);
            let mut pixels = vec![0usize; layout.tile_half_px.len()];
            for &j in &layout.row_tile {
                for &i in &layout.column_tile {
                    pixels[j as usize * layout.tiles[0] + i as usize] += 1;
                }
            }
            (pixels.iter().zip(&layout.tile_half_px))
                .map(|(&n, &half)| 4.0 * n as f64 * ((2 * half + 1) as f64).powi(2))
                .sum::<f64>()
        })
        .sum()
}

/// Largest difference and PSNR (peak: the reference's largest value).
fn difference(reference: &Planar, other: &Planar) -> (f32, f64) {
    let peak = reference.data.iter().fold(0.0f32, |m, v| m.max(*v));
    let (mut worst, mut squares) = (0.0f32, 0.0f64);
    for (a, b) in reference.data.iter().zip(&other.data) {
        worst = worst.max((a - b).abs());
        squares += f64::from(a - b).powi(2);
    }
    let mse = squares / reference.data.len() as f64;
    (worst, 10.0 * (f64::from(peak).powi(2) / mse.max(1e-30)).log10())
}

fn sweep(lens: &unicac_optics::Lens, chart: &Planar, context: Arc<GpuContext>) {
    let (width, height) = (chart.width, chart.height);
    let simulator = |tail: f64| {
        let settings = SimulationSettings {
            kernel_tail: tail,
            ..SimulationSettings::default()
        };
        LensSimulator::new(lens, width, height, None, settings).expect("simulator")
    };
    let (reference, _) = timed(&simulator(0.0), chart);
    println!("kernel_tail | blur G multiply-adds | GPU s | worst vs CPU at tail 0 | PSNR dB");
    for tail in [0.0, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2] {
        let mut sim = simulator(tail);
        sim.settings.image = ImageBackend::new(Arc::new(GpuImagePass::new(context.clone())));
        let (out, seconds) = timed(&sim, chart);
        let (worst, psnr) = difference(&reference, &out);
        println!(
            "{tail:e} | {:.2} | {seconds:.2} | {worst:.2e} | {psnr:.1}",
            multiply_adds(&sim) / 1e9
        );
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "phone_asphere".into());
    let size = args.next().unwrap_or_else(|| "1600x1200".into());
    let [width, height] = unicac_image::size::parse_wxh(&size).expect("size as WIDTHxHEIGHT");
    let lens = builtin::lens(&name).expect("a built-in lens");
    let chart = dead_leaves(width, height, 7).expect("chart");
    let mode = args.next();
    if mode.as_deref() == Some("sweep") {
        let context = Arc::new(GpuContext::new().expect("a GPU adapter"));
        println!("adapter: {}; lens {name}, {width}x{height}", context.adapter.name);
        return sweep(&lens, &chart, context);
    }
    let mut sim =
        LensSimulator::new(&lens, width, height, None, SimulationSettings::default()).expect("simulator");
    let multiply_adds = multiply_adds(&sim);
    let (cpu, cpu_s) = timed(&sim, &chart);
    let (_, cpu_again_s) = timed(&sim, &chart);
    println!(
        "lens {name}, {width}x{height} ({:.1} MP): kernel {} px, node spacing {} px",
        (width * height) as f64 / 1e6,
        sim.kernel_size(),
        sim.node_spacing_px()
    );
    println!("CPU path: {cpu_s:.3} s, {cpu_again_s:.3} s");
    println!("blur: {:.1} G multiply-adds", multiply_adds / 1e9);
    if mode.as_deref() == Some("count") {
        return;
    }
    let context = Arc::new(GpuContext::new().expect("a GPU adapter"));
    println!("adapter: {}", context.adapter.name);
    sim.settings.image = ImageBackend::new(Arc::new(GpuImagePass::new(context)));
    let (gpu, gpu_s) = timed(&sim, &chart);
    let (again, gpu_again_s) = timed(&sim, &chart);
    let notes = sim.settings.image.take_notes();
    assert!(notes.is_empty(), "the GPU pass failed: {notes:?}");
    assert!(again.data == gpu.data, "GPU runs differ");
    let (worst, psnr) = difference(&cpu, &gpu);
    println!("GPU path: {gpu_s:.3} s, {gpu_again_s:.3} s (identical outputs)");
    println!(
        "GPU vs CPU: worst {worst:.2e}, PSNR {psnr:.1} dB; {:.2} G multiply-adds/s on this device",
        multiply_adds / 1e9 / gpu_again_s
    );
}
