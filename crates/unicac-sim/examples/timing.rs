//! Seconds to simulate one image through a lens (docs/performance.md, issue 3): the PSF map (radial
//! PSFs traced over the spectrum, then one rotated kernel per node and channel) and the image pass
//! (spatially varying convolution, distortion warp, relative illumination), optics only.
//!
//! Run: cargo run --release -p unicac-sim --example timing [LENS] [WIDTHxHEIGHT] (default phone_asphere
//! 4000x3000, 12 megapixels)

use std::time::Instant;
use unicac_image::charts::dead_leaves;
use unicac_optics::examples;
use unicac_sim::{LensSimulator, SimulationSettings};

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "phone_asphere".into());
    let size = args.next().unwrap_or_else(|| "4000x3000".into());
    let (width, height) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .expect("size as WIDTHxHEIGHT");
    let lens = examples::lens(&name).expect("a built-in lens");
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
        simulator.radial.kernel_size,
        simulator.radial.requested_kernel_size,
        100.0 * simulator.radial.psfs.iter().flat_map(|p| &p.energy_cut).fold(0.0f64, |m, v| m.max(*v)),
        simulator.node_spacing_px()
    );
    println!(
        "PSF map {psf_map_s:.2} s, image pass {image_s:.2} s, total {:.2} s",
        psf_map_s + image_s
    );
}
