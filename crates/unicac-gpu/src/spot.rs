//! Spot diagrams on the GPU: the same `unicac_trace::Spot` as the CPU's `spots`, with the rays traced
//! by a `GpuTracer`. Paraxial aiming samples and aims on the device; real aiming aims on the CPU (an
//! iterative solve per ray) and uploads the rays.

use crate::device::GpuResult;
use crate::source::{ParaxialAim, PupilSource, RaySource};
use crate::trace::GpuTracer;
use unicac_optics::Lens;
use unicac_trace::spot::SpotStatistics;
use unicac_trace::{Aiming, PupilSampling, Spot, SpotTracer};

/// Spots for every (field, wavelength) pair, fields varying fastest (as `unicac_trace::spots`).
pub fn spots(
    tracer: &GpuTracer,
    lens: &Lens,
    fields_deg: &[f64],
    wavelengths_um: &[f64],
    aiming: Aiming,
    sampling: &PupilSampling,
) -> GpuResult<Vec<Spot>> {
    let mut spots = Vec::with_capacity(fields_deg.len() * wavelengths_um.len());
    for &wavelength in wavelengths_um {
        let cpu = SpotTracer::new(lens, wavelength, aiming)?;
        for &field in fields_deg {
            spots.push(spot(tracer, lens, &cpu, field, sampling)?);
        }
    }
    Ok(spots)
}

/// One field at one wavelength; `cpu` supplies the system, the chief ray and (real aiming) the rays.
pub fn spot(
    tracer: &GpuTracer,
    lens: &Lens,
    cpu: &SpotTracer,
    field_deg: f64,
    sampling: &PupilSampling,
) -> GpuResult<Spot> {
    let (traced, rays_not_aimed) = match cpu.aimer.aiming {
        Aiming::Paraxial => {
            let source = RaySource::Pupil(PupilSource {
                sampling: *sampling,
                aim: ParaxialAim::new(lens, field_deg)?,
            });
            (tracer.trace(&cpu.system, &source)?, 0)
        }
        Aiming::Real | Aiming::Auto => {
            let (rays, not_aimed) = cpu.aimed_rays(field_deg, &sampling.points());
            (tracer.trace(&cpu.system, &RaySource::Host(&rays))?, not_aimed)
        }
    };
    let points_mm: Vec<[f64; 2]> = traced
        .rays
        .iter()
        .zip(&traced.statuses)
        .filter(|(_, s)| s.is_ok())
        .map(|(r, _)| [r.position_mm[0], r.position_mm[1]])
        .collect();
    let chief = cpu.chief_intercept(field_deg);
    let statistics = SpotStatistics::of(&points_mm, chief);
    Ok(Spot {
        field_deg,
        field_x_deg: 0.0,
        wavelength_um: cpu.system.wavelength_um,
        rays_traced: traced.statuses.len() + rays_not_aimed,
        rays_ok: points_mm.len(),
        rays_not_aimed,
        status_counts: traced.counts,
        centroid_x_mm: statistics.centroid_mm.map(|c| c[0]),
        centroid_y_mm: statistics.centroid_mm.map(|c| c[1]),
        rms_radius_um: statistics.rms_radius_um,
        rms_radius_chief_um: statistics.rms_radius_chief_um,
        geometric_radius_um: statistics.geometric_radius_um,
        chief_x_mm: chief.map(|c| c[0]),
        chief_y_mm: chief.map(|c| c[1]),
        points_mm,
    })
}
