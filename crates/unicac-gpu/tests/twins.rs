//! Each GPU kernel against its plain-Rust twin (`unicac_gpu::twin`), and the twins against the f64
//! reference path. Figures are printed (`-- --nocapture`).

mod support;

use support::{lens, tracer_or_skip};
use unicac_gpu::layout::{self, Params};
use unicac_gpu::trace::to_gpu;
use unicac_gpu::{twin, Precision, RaySource, Real};
use unicac_trace::{Aimer, Aiming, Clipping, PupilSampling, TraceSystem};

fn host_rays(name: &str) -> (TraceSystem, Vec<unicac_trace::Ray>) {
    let lens = lens(name);
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let aimer = Aimer::new(&lens, system.wavelength_um, Aiming::Paraxial).unwrap();
    let field = *lens.first_order().unwrap().field_angles_deg.last().unwrap();
    let rays = PupilSampling::Random { n: 3000, seed: 5 }
        .points()
        .iter()
        .map(|[px, py]| aimer.ray(field, *px * 1.1, *py * 1.1).unwrap())
        .collect();
    (system, rays)
}

/// The f64 twin reproduces the CPU reference statuses exactly and positions to 1e-12 mm.
fn twin_matches_cpu<R: Real>() -> (usize, f64) {
    let mut mismatched = 0;
    let mut worst = 0.0f64;
    for name in unicac_optics::builtin::names() {
        let (system, rays) = host_rays(name);
        let surfaces = layout::surfaces::<R>(&system);
        let host: Vec<_> = rays.iter().map(to_gpu::<R>).collect();
        let params = Params::<R> {
            surface_count: surfaces.len() as u32,
            ray_count: host.len() as u32,
            ..Default::default()
        };
        let (out, words, _) = twin::trace_kernel(&params, &surfaces, &host);
        let mut cpu_rays = rays.clone();
        let cpu = unicac_trace::trace_rays(&system, &mut cpu_rays);
        for ((c, s), (g, w)) in cpu_rays.iter().zip(&cpu).zip(out.iter().zip(&words)) {
            let status = layout::decode_status(*w).unwrap();
            if status != *s {
                mismatched += 1;
                continue;
            }
            if s.is_ok() {
                worst = worst.max(
                    (c.position_mm[0] - g.x.to_f64())
                        .abs()
                        .max((c.position_mm[1] - g.y.to_f64()).abs()),
                );
            }
        }
    }
    (mismatched, worst)
}

#[test]
fn trace_twins_match_the_cpu_reference() {
    let (m32, w32) = twin_matches_cpu::<f32>();
    let (m64, w64) = twin_matches_cpu::<f64>();
    println!("twin f32 vs CPU: {m32} statuses differ, worst image point {w32:.3e} mm");
    println!("twin f64 vs CPU: {m64} statuses differ, worst image point {w64:.3e} mm");
    assert_eq!(m64, 0);
    assert!(w64 < 1e-11, "{w64}");
    assert!(w32 < 1e-4, "{w32}");
}

fn gpu_matches_twin<R: Real>(precision: Precision) {
    let Some(tracer) = tracer_or_skip(precision) else {
        return;
    };
    let mut worst = 0.0f64;
    let mut mismatched = 0;
    let mut undecided = 0;
    for name in unicac_optics::builtin::names() {
        let (system, rays) = host_rays(name);
        let surfaces = layout::surfaces::<R>(&system);
        let host: Vec<_> = rays.iter().map(to_gpu::<R>).collect();
        let params = Params::<R> {
            surface_count: surfaces.len() as u32,
            ray_count: host.len() as u32,
            ..Default::default()
        };
        let (out, words, _) = twin::trace_kernel(&params, &surfaces, &host);
        let gpu = tracer.trace(&system, &RaySource::Host(&rays)).unwrap();
        for ((g, s), (t, w)) in gpu.rays.iter().zip(&gpu.statuses).zip(out.iter().zip(&words)) {
            // Undecided rays come back re-traced in f64 by the host: not the kernel's output.
            if w & layout::kind::UNDECIDED != 0 {
                undecided += 1;
                continue;
            }
            let status = layout::decode_status(*w).unwrap();
            if status != *s {
                mismatched += 1;
                continue;
            }
            if s.is_ok() {
                worst = worst.max(
                    (g.position_mm[0] - t.x.to_f64())
                        .abs()
                        .max((g.position_mm[1] - t.y.to_f64()).abs()),
                );
            }
        }
    }
    println!(
        "GPU {precision} vs twin: {mismatched} statuses differ, worst image point {worst:.3e} mm ({undecided} undecided rays left out)"
    );
    assert_eq!(mismatched, 0);
}

#[test]
fn trace_kernel_matches_its_twin_f32() {
    gpu_matches_twin::<f32>(Precision::F32);
}

#[test]
fn trace_kernel_matches_its_twin_f64() {
    gpu_matches_twin::<f64>(Precision::F64);
}
