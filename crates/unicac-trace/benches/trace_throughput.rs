//! Criterion benches of the f64 tracer on the bundled lenses (100k rays per iteration of
//! `workload::axis_and_edge_rays`: paraxially aimed, half on axis and half at the largest field).
//! Throughput is reported as ray-surface intersections. `trace/LENS/100k rays` is `trace_rays` (all
//! threads, the widest SIMD level); `lanes/LENS/LEVEL` is one thread at each SIMD level the CPU
//! supports, and `lanes/LENS/scalar step` the per-ray scalar reference (`TraceSystem::trace`).
//! docs/performance.md has the 1M-ray figures and the peer comparison (examples/throughput.rs).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use unicac_optics::builtin;
use unicac_trace::workload::axis_and_edge_rays;
use unicac_trace::{trace_rays, Clipping, RayStatus, SimdLevel, TraceSystem};

const RAYS: usize = 100_000;

fn bench_lens(c: &mut Criterion, name: &str) {
    let lens = builtin::lens(name).unwrap();
    let rays = axis_and_edge_rays(&lens, RAYS, 1).unwrap();
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let throughput = Throughput::Elements((RAYS * lens.surfaces.len()) as u64);
    let mut group = c.benchmark_group(format!("trace/{name}"));
    group.throughput(throughput.clone());
    group.sample_size(20);
    group.bench_function("100k rays", |b| {
        b.iter_batched_ref(
            || rays.clone(),
            |batch| trace_rays(&system, batch),
            criterion::BatchSize::LargeInput,
        )
    });
    group.finish();
    let mut group = c.benchmark_group(format!("lanes/{name}"));
    group.throughput(throughput);
    group.sample_size(10);
    for level in SimdLevel::supported() {
        group.bench_function(level.name(), |b| {
            b.iter_batched_ref(
                || (rays.clone(), vec![RayStatus::Ok; RAYS]),
                |(batch, statuses)| system.trace_chunk_at(level, batch, statuses),
                criterion::BatchSize::LargeInput,
            )
        });
    }
    group.bench_function("scalar step", |b| {
        b.iter_batched_ref(
            || rays.clone(),
            |batch| {
                batch
                    .iter_mut()
                    .map(|ray| system.trace(ray).is_ok())
                    .filter(|ok| *ok)
                    .count()
            },
            criterion::BatchSize::LargeInput,
        )
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    for name in ["cooke_triplet", "phone_asphere", "double_gauss"] {
        bench_lens(c, name);
    }
}

criterion_group!(trace, benches);
criterion_main!(trace);
