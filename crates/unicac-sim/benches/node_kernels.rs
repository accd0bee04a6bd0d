//! Criterion bench of the node kernels' rotation (`psf_map::rotate`, one per node and channel: 336 x 3
//! for the 12 MP phone-lens simulation): a 127 px kernel whose support is compact (a median node of that
//! lens needs ~49 px) and one that fills the grid. Only the targets within reach of the support are
//! resampled, so the compact one costs a fraction of the full one; docs/performance.md has the figures.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use unicac_psf::Kernel;
use unicac_sim::psf_map::rotate;

const SIZE: usize = 127;

/// A smooth blob of `radius_px` about the centre of a `SIZE` px kernel.
fn blob(radius_px: f64) -> Kernel {
    let mut kernel = Kernel::zeros(SIZE, 1.0);
    let half = kernel.half() as f64;
    for row in 0..SIZE {
        for column in 0..SIZE {
            let r = (column as f64 - half + 3.0).hypot(row as f64 - half);
            if r <= radius_px {
                kernel.data[row * SIZE + column] = (1.0 - r / (radius_px + 1.0)) as f32;
            }
        }
    }
    kernel
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("rotate 127 px kernel");
    group.sample_size(20);
    for support_px in [24.0, 62.0, 90.0] {
        let kernel = blob(support_px);
        group.bench_with_input(
            BenchmarkId::new("support radius px", support_px),
            &kernel,
            |b, kernel| b.iter(|| rotate(kernel, 0.7)),
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
