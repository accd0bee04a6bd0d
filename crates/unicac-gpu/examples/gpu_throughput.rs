//! GPU throughput and the `--device auto` threshold, for docs/performance.md and docs/gpu.md.
//!
//! 1. Throughput: the workload of unicac-trace's throughput example (1,000,000 rays, half on axis and
//!    half at the largest field, uniform over the paraxial entrance pupil, primary wavelength, paraxial
//!    aiming) on the Cooke triplet and the phone lens, in f32 and f64, three ways: host rays (upload,
//!    trace, read back: what `HitTracer` does), device-sampled rays read back (`spot`), and
//!    device-sampled rays with counts only (the kernel alone). CPU f64 on 2 threads alongside.
//! 2. Threshold: host-ray batches of 2^10 .. 2^20 rays, GPU (everything included) against the CPU.
//!
//! Median of 5 runs after one warm-up. Run: cargo run --release -p unicac-gpu --example gpu_throughput

use std::sync::Arc;
use std::time::Instant;
use unicac_gpu::{GpuContext, GpuTracer, ParaxialAim, Precision, PupilSource, RaySource};
use unicac_optics::builtin;
use unicac_trace::workload::axis_and_edge_rays;
use unicac_trace::{trace_rays, Clipping, PupilSampling, TraceSystem};

const RAYS: usize = 1_000_000;
const RUNS: usize = 5;

fn median(mut run: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..=RUNS)
        .map(|_| {
            let start = Instant::now();
            run();
            start.elapsed().as_secs_f64()
        })
        .skip(1)
        .collect();
    times.sort_by(f64::total_cmp);
    times[RUNS / 2]
}

fn report(name: &str, path: &str, precision: &str, surfaces: usize, seconds: f64) {
    println!(
        "{{\"lens\": \"{name}\", \"path\": \"{path}\", \"precision\": \"{precision}\", \"rays\": {RAYS}, \"seconds\": {seconds:.4}, \"ray_surface_intersections_per_s\": {:.3e}}}",
        (RAYS * surfaces) as f64 / seconds
    );
}

fn main() {
    let context = match GpuContext::new() {
        Ok(context) => Arc::new(context),
        Err(e) => {
            eprintln!("no GPU: {e}");
            return;
        }
    };
    println!(
        "adapter: {} ({})",
        context.adapter.name, context.adapter.driver_info
    );
    for name in ["cooke_triplet", "phone_asphere"] {
        let lens = builtin::lens(name).unwrap();
        let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
        let surfaces = lens.surfaces.len();
        let rays = axis_and_edge_rays(&lens, RAYS, 12345).unwrap();
        let cpu = median(|| {
            let mut batch = rays.clone();
            trace_rays(&system, &mut batch);
        });
        report(name, "cpu host rays (2 threads)", "f64", surfaces, cpu);
        let max_field = lens.first_order().unwrap().max_field_deg();
        for precision in [Precision::F32, Precision::F64] {
            let tracer = GpuTracer::new(context.clone(), precision).unwrap();
            let host = median(|| {
                tracer.trace(&system, &RaySource::Host(&rays)).unwrap();
            });
            report(
                name,
                "gpu host rays (upload + trace + read back)",
                &precision.to_string(),
                surfaces,
                host,
            );
            // Two fields, half the rays each, as the CPU workload.
            let sources: Vec<RaySource> = [0.0, max_field]
                .iter()
                .map(|&field| {
                    RaySource::Pupil(PupilSource {
                        sampling: PupilSampling::Random {
                            n: RAYS / 2,
                            seed: 12345,
                        },
                        aim: ParaxialAim::new(&lens, field).unwrap(),
                    })
                })
                .collect();
            let sampled = median(|| {
                for source in &sources {
                    tracer.trace(&system, source).unwrap();
                }
            });
            report(
                name,
                "gpu device-sampled rays, read back",
                &precision.to_string(),
                surfaces,
                sampled,
            );
            let kernel = median(|| {
                for source in &sources {
                    tracer.count(&system, source).unwrap();
                }
            });
            report(
                name,
                "gpu device-sampled rays, counts only",
                &precision.to_string(),
                surfaces,
                kernel,
            );
        }
    }
    // The auto threshold: host-ray batches as PsfTracer::hits sends them.
    let lens = builtin::lens("cooke_triplet").unwrap();
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let tracer = GpuTracer::new(context.clone(), Precision::F32).unwrap();
    println!("batch rays | cpu ms | gpu f32 ms (cooke triplet, host rays, everything included)");
    for shift in (10..=20).step_by(2) {
        let rays = axis_and_edge_rays(&lens, 1 << shift, 12345).unwrap();
        let cpu = median(|| {
            let mut batch = rays.clone();
            trace_rays(&system, &mut batch);
        });
        let gpu = median(|| {
            tracer.trace(&system, &RaySource::Host(&rays)).unwrap();
        });
        println!("{:>10} | {:>7.3} | {:>7.3}", 1 << shift, cpu * 1e3, gpu * 1e3);
    }
}
