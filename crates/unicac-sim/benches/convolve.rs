//! Criterion benches of the spatially varying convolution: direct summation against overlap-save FFT
//! tiles over kernel sizes and node spacings (one 768 x 512 plane). The crossover they show sets
//! `FFT_OP_COST` in `src/convolve/mod.rs`; docs/performance.md has the figures.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use unicac_psf::Kernel;
use unicac_sim::convolve::{convolve_varying_with, Blend, KernelGrid, Method, KERNEL_TAIL_TOLERANCE};

const WIDTH: usize = 768;
const HEIGHT: usize = 512;

fn grid(spacing_px: usize, size: usize) -> KernelGrid {
    let nodes = |length: usize| (length - 1).div_ceil(spacing_px) + 1;
    let (nodes_x, nodes_y) = (nodes(WIDTH), nodes(HEIGHT));
    let kernels = (0..nodes_x * nodes_y)
        .map(|n| {
            let mut k = Kernel::zeros(size, 1.0);
            k.data
                .iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = 1.0 + ((i * 31 + n * 17) % 11) as f32);
            k.normalise();
            k
        })
        .collect();
    KernelGrid::new(nodes_x, nodes_y, kernels).expect("a valid grid")
}

fn bench(c: &mut Criterion) {
    let plane: Vec<f32> = (0..WIDTH * HEIGHT)
        .map(|i| ((i * 7919) % 101) as f32 / 101.0)
        .collect();
    for spacing in [32, 128] {
        let mut group = c.benchmark_group(format!("convolve_varying/spacing {spacing} px"));
        group.throughput(Throughput::Elements((WIDTH * HEIGHT) as u64));
        group.sample_size(10);
        for size in [9, 15, 25, 41, 63] {
            let grid = grid(spacing, size);
            for method in [Method::Direct, Method::Fft, Method::Auto] {
                group.bench_with_input(BenchmarkId::new(format!("{method:?}"), size), &grid, |b, grid| {
                    b.iter(|| {
                        convolve_varying_with(
                            &plane,
                            WIDTH,
                            HEIGHT,
                            grid,
                            method,
                            Blend::Bilinear,
                            KERNEL_TAIL_TOLERANCE,
                        )
                    })
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
