//! Seconds to simulate one image through a lens (docs/performance.md, issue 3): the PSF map (radial
//! PSFs traced over the spectrum, then one rotated kernel per node and channel) and the image pass
//! (spatially varying convolution, distortion warp, relative illumination), optics only.
//!
//! Then, side by side: the spatially varying convolution alone (three planes), the floor of any
//! spatially varying method (one FFT convolution of the same three planes with the field's largest
//! kernel, `convolve_invariant`), and how the tiles' own kernel sizes spread (`convolve::extent`).
//!
//! Run: cargo run --release -p unicac-sim --example timing [LENS] [WIDTHxHEIGHT] (default phone_asphere
//! 4000x3000, 12 megapixels)

use std::time::Instant;
use unicac_image::charts::dead_leaves;
use unicac_optics::builtin;
use unicac_sim::convolve::{convolve_invariant, convolve_varying_with, half_width_holding};
use unicac_sim::{LensSimulator, SimulationSettings};

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "phone_asphere".into());
    let size = args.next().unwrap_or_else(|| "4000x3000".into());
    let [width, height] = unicac_image::size::parse_wxh(&size).expect("size as WIDTHxHEIGHT");
    let lens = builtin::lens(&name).expect("a built-in lens");
    let chart = dead_leaves(width, height, 7).expect("chart");
    let threads = rayon::current_num_threads();
    let start = Instant::now();
    let simulator =
        LensSimulator::new(&lens, width, height, None, SimulationSettings::default()).expect("simulator");
    let psf_map_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let out = simulator.apply(&chart).expect("simulation");
    let image_s = start.elapsed().as_secs_f64();
    assert!(out.data.iter().all(|v| v.is_finite()));
    println!(
        "lens {name}, {width}x{height} ({:.1} MP), {threads} threads: pixel {:.3} um, kernel {} px (spots ask {} px; worst energy cut {:.2}%), node spacing {} px",
        (width * height) as f64 / 1e6,
        simulator.grid.pitch_um,
        simulator.kernel_size(),
        simulator.radial().unwrap().requested_kernel_size,
        100.0 * simulator.radial().unwrap().psfs.iter().flat_map(|p| &p.energy_cut).fold(0.0f64, |m, v| m.max(*v)),
        simulator.node_spacing_px()
    );
    println!(
        "PSF map {psf_map_s:.2} s, image pass {image_s:.2} s, total {:.2} s",
        psf_map_s + image_s
    );
    // The same pass without the distortion warp and the shading: what those two cost.
    let plain = LensSimulator::new(
        &lens,
        width,
        height,
        None,
        SimulationSettings {
            distortion: false,
            illumination: false,
            ..SimulationSettings::default()
        },
    )
    .expect("simulator");
    let start = Instant::now();
    plain.apply(&chart).expect("simulation");
    let plain_s = start.elapsed().as_secs_f64();
    println!(
        "image pass without warp and shading {plain_s:.2} s: warp + shading {:.2} s",
        image_s - plain_s
    );
    let settings = &simulator.settings;
    let grids = simulator.kernel_grids();
    let start = Instant::now();
    for (c, grid) in grids.iter().enumerate() {
        let plane = chart.plane(c);
        let out = convolve_varying_with(
            plane,
            width,
            height,
            grid,
            settings.method,
            settings.blend,
            settings.kernel_tail,
        );
        assert_eq!(out.len(), plane.len());
    }
    let varying_s = start.elapsed().as_secs_f64();
    // The floor: each plane convolved once with the largest kernel of its grid.
    let start = Instant::now();
    for (c, grid) in grids.iter().enumerate() {
        let largest = grid
            .kernels()
            .iter()
            .max_by_key(|k| half_width_holding(k, settings.kernel_tail))
            .expect("kernels");
        let out = convolve_invariant(chart.plane(c), width, height, largest);
        assert_eq!(out.len(), width * height);
    }
    let floor_s = start.elapsed().as_secs_f64();
    println!(
        "spatially varying convolution (3 planes) {varying_s:.2} s; one FFT convolution with the largest kernel (3 planes) {floor_s:.2} s; ratio {:.2}",
        varying_s / floor_s
    );
    let mut sizes: Vec<usize> = grids[1]
        .kernels()
        .iter()
        .map(|k| 2 * half_width_holding(k, settings.kernel_tail) + 1)
        .collect();
    sizes.sort_unstable();
    let quantile = |q: f64| sizes[((sizes.len() - 1) as f64 * q).round() as usize];
    println!(
        "G node kernels needed (px, tail {:e}): min {}, median {}, 90% {}, max {} of {}",
        settings.kernel_tail,
        quantile(0.0),
        quantile(0.5),
        quantile(0.9),
        quantile(1.0),
        grids[1].kernels()[0].size
    );
}
