//! One GPU behind `unicac_psf::HitTracer`: every batch of at least `min_rays` rays is traced on the
//! device (smaller ones stay on the CPU: transfers would cost more than they save), and a device error
//! is the caller's error. The `--device` policy with its fallback to the CPU is `select::DeviceSelection`.

use crate::trace::GpuTracer;
use crate::RaySource;
use unicac_psf::{HitTracer, PsfError, PsfResult};
use unicac_trace::{trace_rays, Ray, RayStatus, TraceSystem};

pub struct GpuHitTracer {
    tracer: GpuTracer,
    min_rays: usize,
}

impl GpuHitTracer {
    pub fn new(tracer: GpuTracer, min_rays: usize) -> GpuHitTracer {
        GpuHitTracer { tracer, min_rays }
    }
}

impl HitTracer for GpuHitTracer {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> PsfResult<Vec<RayStatus>> {
        if rays.len() < self.min_rays {
            return Ok(trace_rays(system, rays));
        }
        let traced = self
            .tracer
            .trace(system, &RaySource::Host(rays))
            .map_err(|error| PsfError::Backend {
                backend: self.describe(),
                message: error.to_string(),
            })?;
        rays.copy_from_slice(&traced.rays);
        Ok(traced.statuses)
    }

    fn describe(&self) -> String {
        format!(
            "gpu ({}, {})",
            self.tracer.precision(),
            self.tracer.context().adapter.name
        )
    }
}
