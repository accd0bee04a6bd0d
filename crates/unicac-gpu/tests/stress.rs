//! Stress tests in f32 (the default precision): a million rays through every bundled lens (the phone
//! lens is the tiny one, EFL 5.7 mm; the double Gauss the large one, EFL 100 mm), rays that all fail,
//! a field with about half the pupil vignetted. Checks: no NaN leaves the device, and the status counts
//! (ok, missed, TIR, clipped, no convergence, invalid input) equal the f64 CPU reference's.
//! The 10M-ray run per lens is `#[ignore]`d (figures in docs/performance.md):
//!   cargo test --release -p unicac-gpu --test stress -- --ignored --nocapture

mod support;

use std::time::Instant;
use support::{lens, tracer_or_skip};
use unicac_gpu::{GpuTracer, ParaxialAim, Precision, PupilSource, RaySource};
use unicac_optics::Lens;
use unicac_trace::{
    batch::count, trace_rays, Aimer, Aiming, Clipping, PupilSampling, Ray, StatusCounts, TraceSystem,
};

fn system(lens: &Lens) -> TraceSystem {
    TraceSystem::new(lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap()
}

fn max_field(lens: &Lens) -> f64 {
    lens.first_order().unwrap().max_field_deg()
}

/// The CPU reference for the device's pupil source, `pupil_scale` times the entrance pupil.
fn cpu_counts(lens: &Lens, field: f64, sampling: PupilSampling, pupil_scale: f64) -> StatusCounts {
    let aimer = Aimer::new(lens, lens.primary_wavelength_um(), Aiming::Paraxial).unwrap();
    let mut rays: Vec<Ray> = sampling
        .points()
        .iter()
        .map(|[px, py]| aimer.ray(field, px * pupil_scale, py * pupil_scale).unwrap())
        .collect();
    count(&trace_rays(&system(lens), &mut rays))
}

fn source(lens: &Lens, field: f64, sampling: PupilSampling, pupil_scale: f64) -> RaySource<'static> {
    let mut aim = ParaxialAim::new(lens, field).unwrap();
    aim.pupil_radius_mm *= pupil_scale;
    RaySource::Pupil(PupilSource { sampling, aim })
}

/// Traces on the GPU, reads every ray back, checks it is finite and returns the counts and how many
/// undecided rays the CPU re-traced.
fn gpu_counts(tracer: &GpuTracer, lens: &Lens, source: &RaySource) -> (StatusCounts, usize) {
    let traced = tracer.trace(&system(lens), source).unwrap();
    let non_finite = traced
        .rays
        .iter()
        .filter(|r| !r.position_mm.iter().chain(&r.direction).all(|v| v.is_finite()))
        .count();
    assert_eq!(non_finite, 0, "NaN or infinite rays came back");
    (traced.counts, traced.resolved_on_cpu)
}

#[test]
fn a_million_rays_through_every_lens_in_f32_count_like_the_cpu() {
    let Some(tracer) = tracer_or_skip(Precision::F32) else {
        return;
    };
    for name in unicac_optics::builtin::names() {
        let lens = lens(name);
        let field = max_field(&lens);
        let sampling = PupilSampling::Random {
            n: 1_000_000,
            seed: 77,
        };
        let start = Instant::now();
        let (gpu, resolved) = gpu_counts(&tracer, &lens, &source(&lens, field, sampling, 1.05));
        let seconds = start.elapsed().as_secs_f64();
        let cpu = cpu_counts(&lens, field, sampling, 1.05);
        println!(
            "{name} field {field} deg, 1M rays at 1.05 x the pupil: GPU f32 {seconds:.2} s, {resolved} undecided rays re-traced on the CPU, {gpu:?}"
        );
        assert_eq!(gpu, cpu, "{name}");
    }
}

#[test]
fn rays_that_all_fail_fail_the_same_way_and_stay_finite() {
    let Some(tracer) = tracer_or_skip(Precision::F32) else {
        return;
    };
    for name in ["cooke_triplet", "phone_asphere", "double_gauss"] {
        let lens = lens(name);
        let system = system(&lens);
        let aimer = Aimer::new(&lens, lens.primary_wavelength_um(), Aiming::Paraxial).unwrap();
        // Through an annulus of 2 to 3 entrance-pupil radii (outside every clear aperture), and at 85 deg.
        let annulus: Vec<Ray> = PupilSampling::Random { n: 100_000, seed: 3 }
            .points()
            .iter()
            .map(|[px, py]| {
                let r = px.hypot(*py).max(1e-12);
                let scale = (2.0 + r) / r;
                aimer.ray(0.0, px * scale, py * scale).unwrap()
            })
            .collect();
        let steep: Vec<Ray> = PupilSampling::Random { n: 100_000, seed: 4 }
            .points()
            .iter()
            .map(|[px, py]| aimer.ray(85.0, *px, *py).unwrap())
            .collect();
        for (what, rays) in [("pupil annulus 2-3", annulus), ("field 85 deg", steep)] {
            let traced = tracer.trace(&system, &RaySource::Host(&rays)).unwrap();
            let mut cpu_rays = rays.clone();
            let cpu = count(&trace_rays(&system, &mut cpu_rays));
            let finite = traced
                .rays
                .iter()
                .all(|r| r.position_mm.iter().chain(&r.direction).all(|v| v.is_finite()));
            println!(
                "{name}, {what}: {:?} ({} re-traced on the CPU)",
                traced.counts, traced.resolved_on_cpu
            );
            assert!(finite, "{name} {what}");
            assert_eq!(traced.counts.ok, 0, "{name} {what}");
            assert_eq!(traced.counts, cpu, "{name} {what}");
        }
    }
    // Invalid input (NaN) rays from the host.
    let lens = lens("cooke_triplet");
    let rays = vec![
        Ray {
            position_mm: [f64::NAN, 0.0, 0.0],
            direction: [0.0, 0.0, 1.0]
        };
        1000
    ];
    let traced = tracer.trace(&system(&lens), &RaySource::Host(&rays)).unwrap();
    assert_eq!(traced.counts.invalid_input, 1000);
}

#[test]
fn a_field_with_half_the_pupil_vignetted_counts_like_the_cpu() {
    let Some(tracer) = tracer_or_skip(Precision::F32) else {
        return;
    };
    // The field beyond the design field where about half the rays fail (found on the CPU).
    let lens = lens("cooke_triplet");
    let probe = PupilSampling::Fibonacci { n: 2000 };
    let (field, fraction) = (0..=60)
        .map(|i| max_field(&lens) * (1.0 + i as f64 / 40.0))
        .map(|f| {
            let c = cpu_counts(&lens, f, probe, 1.0);
            (f, 1.0 - c.ok as f64 / c.total() as f64)
        })
        .min_by(|a, b| (a.1 - 0.5).abs().total_cmp(&(b.1 - 0.5).abs()))
        .unwrap();
    let sampling = PupilSampling::Random {
        n: 1_000_000,
        seed: 5,
    };
    let (gpu, resolved) = gpu_counts(&tracer, &lens, &source(&lens, field, sampling, 1.0));
    let cpu = cpu_counts(&lens, field, sampling, 1.0);
    println!(
        "cooke_triplet at {field:.2} deg ({:.0}% vignetted in the probe): {gpu:?}, {resolved} re-traced on the CPU",
        100.0 * fraction
    );
    assert!((0.3..0.7).contains(&(gpu.ok as f64 / gpu.total() as f64)));
    assert_eq!(gpu, cpu);
}

#[test]
#[ignore = "10M rays per lens: minutes on lavapipe; figures in docs/performance.md"]
fn ten_million_rays_through_every_lens() {
    let Some(tracer) = tracer_or_skip(Precision::F32) else {
        return;
    };
    for name in unicac_optics::builtin::names() {
        let lens = lens(name);
        let field = max_field(&lens);
        let sampling = PupilSampling::Random {
            n: 10_000_000,
            seed: 10,
        };
        let start = Instant::now();
        let traced = tracer
            .count(&system(&lens), &source(&lens, field, sampling, 1.05))
            .unwrap();
        let gpu = traced.counts;
        let gpu_seconds = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let cpu = cpu_counts(&lens, field, sampling, 1.05);
        let cpu_seconds = start.elapsed().as_secs_f64();
        println!(
            "{name}: 10M rays, {} surfaces: GPU f32 {gpu_seconds:.2} s (device sampling, counts only), CPU f64 {cpu_seconds:.2} s (incl. aiming); {} re-traced on the CPU; {gpu:?}",
            lens.surfaces.len(),
            traced.resolved_on_cpu
        );
        assert_eq!(gpu, cpu, "{name}");
    }
}
