//! GPU kernels against their plain-Rust twins and against the f64 CPU reference tracer, on every
//! bundled lens, in f32 and f64. Figures are printed (`-- --nocapture`).
//!
//! Stated parity (docs/gpu.md): f32 RMS spot radius within 1% and centroids within 0.05 um of the CPU;
//! f64 within 1e-9 relative; identical status counts.

mod support;

use support::{lens, relative, tracer_or_skip};
use unicac_gpu::{Precision, RaySource};
use unicac_trace::{spots, Aiming, PupilSampling};

fn check_spots(precision: Precision, sampling: PupilSampling, aiming: Aiming) {
    let Some(tracer) = tracer_or_skip(precision) else {
        return;
    };
    let (rms_tolerance, centroid_tolerance_um) = match precision {
        Precision::F32 => (0.01, 0.05),
        Precision::F64 => (1e-9, 0.0),
    };
    let mut worst_rms = 0.0f64;
    let mut worst_centroid_um = 0.0f64;
    for name in unicac_optics::builtin::names() {
        let lens = lens(name);
        let fields = lens.first_order().unwrap().field_angles_deg;
        let wavelengths = lens.wavelengths_um();
        let cpu = spots(&lens, &fields, &wavelengths, aiming, &sampling).unwrap();
        let gpu = unicac_gpu::spot::spots(&tracer, &lens, &fields, &wavelengths, aiming, &sampling).unwrap();
        for (c, g) in cpu.iter().zip(&gpu) {
            let what = format!("{name} {precision} field {} wl {}", c.field_deg, c.wavelength_um);
            assert_eq!(c.status_counts, g.status_counts, "{what}");
            let (Some(rc), Some(rg)) = (c.rms_radius_um, g.rms_radius_um) else {
                continue;
            };
            let rms = relative(rg, rc);
            let dx = (g.centroid_x_mm.unwrap() - c.centroid_x_mm.unwrap()) * 1e3;
            let dy = (g.centroid_y_mm.unwrap() - c.centroid_y_mm.unwrap()) * 1e3;
            let centroid_um = dx.hypot(dy);
            let centroid_limit = match precision {
                Precision::F32 => centroid_tolerance_um,
                // 1e-9 relative to the spot's distance from the axis (and to its size).
                Precision::F64 => {
                    1e-9 * (c.centroid_y_mm.unwrap().hypot(c.centroid_x_mm.unwrap()) * 1e3 + rc)
                }
            };
            assert!(
                rms <= rms_tolerance,
                "{what}: RMS {rg} vs {rc} um ({rms:.2e} relative)"
            );
            assert!(
                centroid_um <= centroid_limit,
                "{what}: centroid off by {centroid_um:.3e} um"
            );
            worst_rms = worst_rms.max(rms);
            worst_centroid_um = worst_centroid_um.max(centroid_um);
        }
    }
    println!(
        "{precision} {sampling:?} {aiming:?}: worst RMS radius {worst_rms:.3e} relative, worst centroid {worst_centroid_um:.3e} um (limits {rms_tolerance:e}, {centroid_tolerance_um} um)"
    );
}

#[test]
fn f32_spots_match_the_cpu_on_every_lens() {
    for sampling in ["hexapolar:16", "grid:32", "fibonacci:2000", "random:2000:9"] {
        check_spots(Precision::F32, sampling.parse().unwrap(), Aiming::Paraxial);
    }
    check_spots(Precision::F32, "hexapolar:6".parse().unwrap(), Aiming::Real);
}

#[test]
fn f64_spots_match_the_cpu_on_every_lens() {
    for sampling in ["hexapolar:16", "grid:32", "fibonacci:2000", "random:2000:9"] {
        check_spots(Precision::F64, sampling.parse().unwrap(), Aiming::Paraxial);
    }
    check_spots(Precision::F64, "hexapolar:6".parse().unwrap(), Aiming::Real);
}

/// Host rays through the GPU and through the CPU, ray by ray.
#[test]
fn host_rays_match_the_cpu_ray_by_ray() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(tracer) = tracer_or_skip(precision) else {
            return;
        };
        let mut worst_mm = 0.0f64;
        for name in unicac_optics::builtin::names() {
            let lens = lens(name);
            let system = unicac_trace::TraceSystem::new(
                &lens,
                lens.primary_wavelength_um(),
                unicac_trace::Clipping::Apertures,
            )
            .unwrap();
            let aimer = unicac_trace::Aimer::new(&lens, system.wavelength_um, Aiming::Paraxial).unwrap();
            let field = *lens.first_order().unwrap().field_angles_deg.last().unwrap();
            let rays: Vec<_> = PupilSampling::Random { n: 5000, seed: 3 }
                .points()
                .iter()
                .map(|[px, py]| aimer.ray(field, *px * 1.1, *py * 1.1).unwrap())
                .collect();
            let mut cpu_rays = rays.clone();
            let cpu = unicac_trace::trace_rays(&system, &mut cpu_rays);
            let gpu = tracer.trace(&system, &RaySource::Host(&rays)).unwrap();
            let differing: Vec<_> = cpu
                .iter()
                .zip(&gpu.statuses)
                .enumerate()
                .filter(|(_, (c, g))| c != g)
                .collect();
            assert!(
                differing.is_empty(),
                "{name} {precision}: {} statuses differ, first {:?}",
                differing.len(),
                differing.first()
            );
            for ((c, g), s) in cpu_rays.iter().zip(&gpu.rays).zip(&cpu) {
                if s.is_ok() {
                    let d = (0..3)
                        .map(|k| (c.position_mm[k] - g.position_mm[k]).abs())
                        .fold(0.0, f64::max);
                    worst_mm = worst_mm.max(d);
                }
            }
        }
        println!(
            "{precision}: host rays, worst image-point difference {worst_mm:.3e} mm, statuses identical"
        );
        let limit = if precision == Precision::F32 { 1e-4 } else { 1e-11 };
        assert!(worst_mm < limit, "{precision}: {worst_mm}");
    }
}
