//! The noisy sensor read-out of a 12 MP Bayer mosaic on the device (shaders/sensor.wgsl) against the
//! CPU's (`unicac_image::isp::read_out`, f64, all cores): run time of each (library calls, the best of
//! three; the device's includes upload and read-back) and the share of samples whose DN differ
//! (docs/gpu.md).
//!
//! Run: cargo run --release -p unicac-gpu --example read_out [WIDTHxHEIGHT] (default 4000x3000)

use std::sync::Arc;
use std::time::Instant;
use unicac_gpu::{GpuContext, GpuImagePass};
use unicac_image::charts::dead_leaves;
use unicac_image::isp::{mosaic_rggb, read_out, SensorNoise};
use unicac_image::Planar;

fn best_of_three(run: impl Fn() -> Planar) -> (Planar, f64) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..3 {
        let start = Instant::now();
        out = Some(run());
        best = best.min(start.elapsed().as_secs_f64());
    }
    (out.expect("three runs"), best)
}

fn main() {
    let size = std::env::args().nth(1).unwrap_or_else(|| "4000x3000".into());
    let (width, height) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .expect("WIDTHxHEIGHT");
    let mosaic = mosaic_rggb(&dead_leaves(width, height, 7).expect("scene")).expect("mosaic");
    let sensor = SensorNoise::default();
    let (cpu, cpu_s) = best_of_three(|| read_out(&mosaic, &sensor, Some(3)).expect("read-out"));
    let context = Arc::new(GpuContext::new().expect("a GPU adapter (lavapipe: scripts/setup.sh)"));
    let pass = GpuImagePass::new(context.clone());
    let (gpu, gpu_s) = best_of_three(|| pass.read_out(&mosaic, &sensor, 3).expect("device read-out"));
    let differ = cpu.data.iter().zip(&gpu.data).filter(|(a, b)| a != b).count();
    println!(
        "{width} x {height} mosaic: CPU {cpu_s:.3} s, {} {gpu_s:.3} s; {differ} of {} samples differ ({:.4}%)",
        context.adapter.name,
        cpu.data.len(),
        100.0 * differ as f64 / cpu.data.len() as f64
    );
}
