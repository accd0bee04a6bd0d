//! The GPU behind `unicac_psf::HitTracer`, so that `psf`, `simulate` and `ode` trace their PSF rays on
//! the device. Batches smaller than `min_rays` stay on the CPU (transfers would cost more than they
//! save); a device error falls back to the CPU with one warning, never a failure.

use crate::trace::GpuTracer;
use crate::RaySource;
use std::sync::atomic::{AtomicBool, Ordering};
use unicac_psf::HitTracer;
use unicac_trace::{trace_rays, Ray, RayStatus, TraceSystem};

pub struct GpuHitTracer {
    tracer: GpuTracer,
    min_rays: usize,
    warned: AtomicBool,
}

impl GpuHitTracer {
    pub fn new(tracer: GpuTracer, min_rays: usize) -> GpuHitTracer {
        GpuHitTracer {
            tracer,
            min_rays,
            warned: AtomicBool::new(false),
        }
    }
}

impl HitTracer for GpuHitTracer {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
        if rays.len() < self.min_rays {
            return trace_rays(system, rays);
        }
        match self.tracer.trace(system, &RaySource::Host(rays)) {
            Ok(traced) => {
                rays.copy_from_slice(&traced.rays);
                traced.statuses
            }
            Err(error) => {
                if !self.warned.swap(true, Ordering::Relaxed) {
                    eprintln!("warning: GPU trace failed ({error}); continuing on the CPU");
                }
                trace_rays(system, rays)
            }
        }
    }

    fn describe(&self) -> String {
        format!(
            "gpu ({}, {})",
            self.tracer.precision(),
            self.tracer.context().adapter.name
        )
    }
}
