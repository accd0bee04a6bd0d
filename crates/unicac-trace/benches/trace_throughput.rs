//! Criterion benches of the f64 tracer on the bundled lenses (100k rays per iteration of
//! `workload::axis_and_edge_rays`: paraxially aimed, half on axis and half at the largest field). Throughput is reported as ray-surface intersections.
//! docs/performance.md has the 1M-ray figures and the peer comparison (examples/throughput.rs).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use unicac_optics::examples;
use unicac_trace::workload::axis_and_edge_rays;
use unicac_trace::{trace_rays, Clipping, TraceSystem};

const RAYS: usize = 100_000;

fn bench_lens(c: &mut Criterion, name: &str) {
    let lens = examples::lens(name).unwrap();
    let rays = axis_and_edge_rays(&lens, RAYS, 1).unwrap();
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let mut group = c.benchmark_group(format!("trace/{name}"));
    group.throughput(Throughput::Elements((RAYS * lens.surfaces.len()) as u64));
    group.sample_size(20);
    group.bench_function("100k rays", |b| {
        b.iter_batched_ref(
            || rays.clone(),
            |batch| trace_rays(&system, batch),
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
