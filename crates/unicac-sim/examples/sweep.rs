//! Run time against error of the image simulator's fidelity knobs (docs/performance.md, issue 3):
//! one knob at a time, the others at their defaults, against the same simulation with that knob at a
//! high-fidelity value, on a dead-leaves chart filling the lens's field (no noise, no ISP: optics only). Error: PSNR (dB) of the simulated linear image
//! against the reference, and the mean L1 difference of the on-axis and corner G kernels.
//!
//! Run: cargo run --release -p unicac-sim --example sweep [LENS] (default phone_asphere)

use std::time::Instant;
use unicac_image::charts::dead_leaves;
use unicac_image::Planar;
use unicac_optics::examples;
use unicac_sim::{LensSimulator, SimulationSettings};
use unicac_trace::PupilSampling;

const SIZE: (usize, usize) = (640, 480);

fn settings(rays: usize, wavelengths: usize, radial: usize, nodes: usize) -> SimulationSettings {
    let mut s = SimulationSettings {
        wavelengths,
        radial_samples: radial,
        node_intervals: nodes,
        ..Default::default()
    };
    s.psf.pupil_sampling = PupilSampling::Fibonacci { n: rays };
    s
}

fn psnr(a: &Planar, b: &Planar) -> f64 {
    let mse: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.data.len() as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    }
}

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "phone_asphere".into());
    let lens = examples::lens(&name).unwrap();
    let chart = dead_leaves(SIZE.0, SIZE.1, 7).unwrap();
    let run = |s: SimulationSettings| {
        let start = Instant::now();
        let sim = LensSimulator::new(&lens, SIZE.0, SIZE.1, None, s).unwrap();
        let out = sim.apply(&chart).unwrap();
        (start.elapsed().as_secs_f64(), out, sim)
    };
    let corner_of = |sim: &LensSimulator| sim.grid.half_diagonal_mm() * 0.99;
    let kernel_l1 = |sim: &LensSimulator, reference: &LensSimulator| {
        let corner = corner_of(reference);
        [(0.0, 0.0), (0.0, corner)]
            .iter()
            .map(|&(x, y)| {
                let (a, b) = (sim.radial.kernel_at(x, y, 1), reference.radial.kernel_at(x, y, 1));
                if a.size != b.size {
                    return f64::NAN;
                }
                a.data
                    .iter()
                    .zip(&b.data)
                    .map(|(p, q)| (p - q).abs() as f64)
                    .sum::<f64>()
                    / 2.0
            })
            .sum::<f64>()
    };
    println!("lens {name}, image {}x{}; each knob against its own high-fidelity value, the others at their defaults", SIZE.0, SIZE.1);
    println!("| knob | value | seconds | PSNR vs reference (dB) | G kernel L1, axis + corner |");
    println!("|---|---|---|---|---|");
    let default = (2048, 31, 17, 64);
    type Knob = (
        &'static str,
        Vec<usize>,
        fn((usize, usize, usize, usize), usize) -> (usize, usize, usize, usize),
    );
    let knobs: [Knob; 4] = [
        (
            "rays per PSF",
            vec![32768, 256, 512, 1024, 2048, 4096, 8192],
            |d, v| (v, d.1, d.2, d.3),
        ),
        ("wavelengths", vec![61, 5, 11, 21, 31, 41], |d, v| {
            (d.0, v, d.2, d.3)
        }),
        ("radial PSF samples", vec![49, 5, 9, 17, 25, 33], |d, v| {
            (d.0, d.1, v, d.3)
        }),
        ("node spacing (px)", vec![8, 128, 64, 32, 16], |d, v| {
            (d.0, d.1, d.2, v)
        }),
    ];
    for (knob, values, apply) in knobs {
        let at = |v: usize| {
            let (r, w, p, n) = apply(default, v);
            settings(r, w, p, n)
        };
        let (reference_s, reference, reference_sim) = run(at(values[0]));
        println!(
            "| {knob} | {} (reference) | {reference_s:.3} | - | - |",
            values[0]
        );
        for &value in &values[1..] {
            let (seconds, out, sim) = run(at(value));
            println!(
                "| {knob} | {value} | {seconds:.3} | {:.2} | {:.4} |",
                psnr(&out, &reference),
                kernel_l1(&sim, &reference_sim)
            );
        }
    }
}
