//! The ISP steps a device takes, on a 12 MP Bayer mosaic, against the CPU's (all cores): the noisy
//! read-out (shaders/sensor.wgsl against `unicac_image::isp::read_out` in f64) and the development
//! (shaders/develop.wgsl against black level, white balance and Malvar-He-Cutler demosaicing). Run time
//! of each (library calls, the best of three; the device's includes upload and read-back) and the share
//! of samples that differ (docs/gpu.md).
//!
//! Run: cargo run --release -p unicac-gpu --example isp_steps [WIDTHxHEIGHT] (default 4000x3000)

use std::sync::Arc;
use std::time::Instant;
use unicac_gpu::{GpuContext, GpuImagePass};
use unicac_image::charts::dead_leaves;
use unicac_image::isp::{
    apply_white_balance_mosaic, demosaic, mosaic_rggb, read_out, subtract_black_level, Demosaic, SensorNoise,
    WhiteBalanceGains,
};
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
    let share = |a: &Planar, b: &Planar| {
        let differ = a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count();
        format!(
            "{differ} of {} samples differ ({:.4}%)",
            a.data.len(),
            100.0 * differ as f64 / a.data.len() as f64
        )
    };
    let device = &context.adapter.name;
    println!(
        "{width} x {height} read-out: CPU {cpu_s:.3} s, {device} {gpu_s:.3} s; {}",
        share(&cpu, &gpu)
    );
    let gains = WhiteBalanceGains::DEEPLENS;
    let method = Demosaic::MalvarHeCutler;
    let (cpu, cpu_s) = best_of_three(|| {
        let balanced =
            apply_white_balance_mosaic(&subtract_black_level(&gpu, &sensor).expect("black"), gains);
        demosaic(&balanced.expect("white balance"), method).expect("demosaic")
    });
    let (developed, gpu_s) = best_of_three(|| {
        pass.develop(&gpu, &sensor, gains, method)
            .expect("device development")
    });
    println!(
        "{width} x {height} development: CPU {cpu_s:.3} s, {device} {gpu_s:.3} s; {}",
        share(&cpu, &developed)
    );
}
