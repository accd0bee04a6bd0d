//! Ray-surface intersection throughput on the bundled Cooke triplet and phone lens, for
//! docs/performance.md: the same workload as bench/peers/optiland_throughput.py (1,000,000 rays,
//! half on axis and half at the largest field, uniform over the paraxial entrance pupil, primary
//! wavelength, paraxial aiming), timed on 1 and on 2 threads (median of 15 runs after one warm-up), at
//! every SIMD level the CPU supports (`"simd"`; the widest is what `trace_rays` uses).
//!
//! Run: cargo run --release -p unicac-trace --example throughput [LENS...] [LEVEL...]
//! (LEVEL: portable, avx2, avx512; default every level the CPU supports).

use rayon::prelude::*;
use std::time::Instant;
use unicac_optics::builtin;
use unicac_trace::workload::axis_and_edge_rays;
use unicac_trace::{Clipping, Ray, RayStatus, SimdLevel, TraceSystem};

const RAYS: usize = 1_000_000;
/// Timed runs per row (one warm-up before): the median of many, since one run is ~30 ms on 2 cores.
const RUNS: usize = 15;
/// Rays per rayon task, as in `trace_rays`.
const CHUNK: usize = 2048;

fn median_seconds(system: &TraceSystem, rays: &[Ray], threads: usize, level: SimdLevel) -> (f64, usize) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut ok = 0;
    // Allocated (and first touched by the warm-up) outside the timed region, like the rays: the
    // figure is the tracer's, not the allocator's.
    let mut statuses = vec![RayStatus::Ok; rays.len()];
    let mut times: Vec<f64> = (0..=RUNS)
        .map(|_| {
            let mut batch = rays.to_vec();
            let start = Instant::now();
            pool.install(|| {
                batch
                    .par_chunks_mut(CHUNK)
                    .zip(statuses.par_chunks_mut(CHUNK))
                    .for_each(|(rays, statuses)| system.trace_chunk_at(level, rays, statuses))
            });
            let seconds = start.elapsed().as_secs_f64();
            ok = statuses.iter().filter(|s| s.is_ok()).count();
            seconds
        })
        .skip(1)
        .collect();
    times.sort_by(f64::total_cmp);
    (times[RUNS / 2], ok)
}

fn is_level(arg: &str) -> bool {
    ["portable", "avx2", "avx512"].contains(&arg)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let levels: Vec<SimdLevel> = SimdLevel::supported()
        .into_iter()
        .filter(|level| !args.iter().any(|a| is_level(a)) || args.iter().any(|a| a == level.name()))
        .collect();
    let lenses: Vec<&String> = args.iter().filter(|a| !is_level(a)).collect();
    for name in ["cooke_triplet", "phone_asphere"]
        .into_iter()
        .filter(|n| lenses.is_empty() || lenses.iter().any(|o| o == n))
    {
        let lens = builtin::lens(name).unwrap();
        let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
        let rays = axis_and_edge_rays(&lens, RAYS, 12345).unwrap();
        let surfaces = lens.surfaces.len();
        for &level in &levels {
            for threads in [1, 2] {
                let (seconds, ok) = median_seconds(&system, &rays, threads, level);
                println!(
                    "{{\"lens\": \"{name}\", \"simd\": \"{}\", \"rays\": {RAYS}, \"rays_ok\": {ok}, \"surfaces_traced_per_ray\": {surfaces}, \"threads\": {threads}, \"seconds\": {seconds:.5}, \"ray_surface_intersections_per_s\": {:.4e}}}",
                    level.name(),
                    (RAYS * surfaces) as f64 / seconds
                );
            }
        }
    }
}
