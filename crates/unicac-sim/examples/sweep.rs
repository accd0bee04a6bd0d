//! Run time against error of the image simulator's fidelity knobs (docs/performance.md, issue 3):
//! one knob at a time, the others at their defaults, against the same simulation with that knob at a
//! high-fidelity value, on a dead-leaves chart filling the lens's field (no noise, no ISP: optics
//! only). Error: PSNR (dB) of the simulated linear image against the reference, and the mean L1
//! difference of the on-axis and corner G kernels (kernels of different sizes are compared centred).
//!
//! Run: cargo run --release -p unicac-sim --example sweep [LENS] [WIDTHxHEIGHT] [KNOB] (default
//! phone_asphere 640x480, every knob; LENS: a built-in name or a lens file, e.g. a decentred unit for
//! the planar knob; KNOB: a part of a knob's name)

use std::time::Instant;
use unicac_image::charts::dead_leaves;
use unicac_image::Planar;
use unicac_optics::builtin;
use unicac_psf::Kernel;
use unicac_sim::convolve::{Blend, Method};
use unicac_sim::psf_map::RADIAL_GRID;
use unicac_sim::{LensSimulator, RadialSampling, SimulationSettings};
use unicac_trace::PupilSampling;

/// One knob: a label per setting, the first being the high-fidelity reference.
struct Knob {
    name: &'static str,
    values: Vec<(String, SimulationSettings)>,
}

fn with(change: impl Fn(&mut SimulationSettings)) -> SimulationSettings {
    let mut settings = SimulationSettings::default();
    change(&mut settings);
    settings
}

fn knobs() -> Vec<Knob> {
    let numeric = |name, values: &[usize], set: fn(&mut SimulationSettings, usize)| Knob {
        name,
        values: values
            .iter()
            .map(|&v| (v.to_string(), with(|s| set(s, v))))
            .collect(),
    };
    vec![
        numeric("rays per PSF", &[32768, 256, 1024, 2048, 8192], |s, v| {
            s.psf.pupil_sampling = PupilSampling::Fibonacci { n: v }
        }),
        numeric("wavelengths", &[61, 5, 11, 21, 31], |s, v| s.wavelengths = v),
        Knob {
            name: "radial tolerance (half-L1 at a midpoint)",
            // Tolerance 0 halves every interval while the budget lasts: 9, 17, 33 or 65 uniform samples.
            values: [
                (0.0, RADIAL_GRID + 1),
                (0.0, 9),
                (0.0, 17),
                (0.0, 33),
                (0.1, 33),
                (0.05, 33),
                (0.02, 33),
                (0.01, 33),
            ]
            .iter()
            .map(|&(tolerance, max_samples)| {
                let label = if tolerance == 0.0 {
                    format!("0: {max_samples} uniform samples")
                } else {
                    format!("{tolerance}, at most {max_samples} samples")
                };
                (
                    label,
                    with(|s| {
                        s.radial = RadialSampling {
                            max_samples,
                            tolerance,
                        }
                    }),
                )
            })
            .collect(),
        },
        numeric("node intervals (longer side)", &[80, 5, 10, 20, 40], |s, v| {
            s.node_intervals = v
        }),
        // Only lenses that are not rotationally symmetric (a decentred unit) read this knob.
        numeric(
            "planar PSF intervals (longer side)",
            &[40, 4, 8, 12, 16, 24],
            |s, v| s.planar_psf_intervals = v,
        ),
        Knob {
            name: "kernel energy fraction",
            values: [0.99999, 0.95, 0.98, 0.99, 0.995, 0.999]
                .iter()
                .map(|&f| {
                    let mut s = with(|s| s.psf.energy_fraction = f);
                    s.psf.max_kernel_px = 255;
                    (f.to_string(), s)
                })
                .collect(),
        },
        Knob {
            name: "blending",
            values: vec![
                ("bilinear, 80 intervals".into(), with(|s| s.node_intervals = 80)),
                ("nearest node".into(), with(|s| s.blend = Blend::Nearest)),
                ("bilinear".into(), with(|_| ())),
            ],
        },
        Knob {
            name: "kernel tail cropped per tile",
            values: [0.0, 1e-2, 1e-3, 1e-4, 1e-5]
                .iter()
                .map(|&tail| (tail.to_string(), with(|s| s.kernel_tail = tail)))
                .collect(),
        },
        Knob {
            name: "convolution method",
            values: vec![
                ("direct".into(), with(|s| s.method = Method::Direct)),
                ("fft".into(), with(|s| s.method = Method::Fft)),
                ("auto".into(), with(|_| ())),
            ],
        },
    ]
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

/// Half the L1 distance of two kernels laid over each other by their centres.
fn kernel_l1(a: &Kernel, b: &Kernel) -> f64 {
    let size = a.size.max(b.size);
    let sample = |k: &Kernel, x: usize, y: usize| {
        let offset = (size - k.size) / 2;
        let inside = |v: usize| v >= offset && v < offset + k.size;
        if inside(x) && inside(y) {
            k.at(x - offset, y - offset) as f64
        } else {
            0.0
        }
    };
    (0..size * size)
        .map(|i| (sample(a, i % size, i / size) - sample(b, i % size, i / size)).abs())
        .sum::<f64>()
        / 2.0
}

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "phone_asphere".into());
    let size = args.next().unwrap_or_else(|| "640x480".into());
    let (width, height): (usize, usize) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .expect("size as WIDTHxHEIGHT");
    let only = args.next().unwrap_or_default();
    let lens = if name.ends_with(".json") || name.ends_with(".zmx") {
        unicac_optics::load_lens(std::path::Path::new(&name)).unwrap().0
    } else {
        builtin::lens(&name).unwrap()
    };
    let chart = dead_leaves(width, height, 7).unwrap();
    let run = |s: &SimulationSettings| {
        let start = Instant::now();
        let sim = LensSimulator::new(&lens, width, height, None, s.clone()).unwrap();
        let out = sim.apply(&chart).unwrap();
        (start.elapsed().as_secs_f64(), out, sim)
    };
    let kernels_l1 = |sim: &LensSimulator, reference: &LensSimulator| {
        let corner = reference.grid.half_diagonal_mm() * 0.99;
        [(0.0, 0.0), (0.0, corner)]
            .iter()
            .map(|&(x, y)| kernel_l1(&sim.kernel_at(x, y, 1), &reference.kernel_at(x, y, 1)))
            .sum::<f64>()
    };
    println!(
        "lens {name}, image {width}x{height}, {} threads; each knob against its own high-fidelity value, the others at their defaults",
        rayon::current_num_threads()
    );
    println!("| knob | value | kernel px | traced PSFs | seconds | PSNR vs reference (dB) | G kernel L1, axis + corner |");
    println!("|---|---|---|---|---|---|---|");
    for knob in knobs().into_iter().filter(|k| k.name.contains(&only)) {
        let (reference_label, reference_settings) = &knob.values[0];
        let (reference_s, reference, reference_sim) = run(reference_settings);
        println!(
            "| {} | {reference_label} (reference) | {} | {} | {reference_s:.2} | - | - |",
            knob.name,
            reference_sim.kernel_size(),
            reference_sim.psfs().len()
        );
        for (label, settings) in &knob.values[1..] {
            let (seconds, out, sim) = run(settings);
            println!(
                "| {} | {label} | {} | {} | {seconds:.2} | {:.1} | {:.4} |",
                knob.name,
                sim.kernel_size(),
                sim.psfs().len(),
                psnr(&out, &reference),
                kernels_l1(&sim, &reference_sim)
            );
        }
    }
}
