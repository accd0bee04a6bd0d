//! `HitTracer`: who traces the rays of a geometric PSF (`PsfTracer::hits`). The CPU tracer of
//! unicac-trace is the default; unicac-gpu implements it on the GPU. A process-wide default lets a
//! front end choose the device once for every PSF traced anywhere (`psf`, `simulate`, `ode`) without
//! threading it through each crate.

use std::sync::{Arc, RwLock};
use unicac_trace::{trace_rays, Ray, RayStatus, TraceSystem};

/// Traces rays (global coordinates) to the image surface in place, one status per ray, as
/// `unicac_trace::trace_rays` does. Implementations must not fail: on trouble they fall back to the CPU.
pub trait HitTracer: Send + Sync {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus>;
    /// "cpu", "gpu (f32, llvmpipe ...)": for reports.
    fn describe(&self) -> String;
}

/// The f64 reference tracer, in parallel with rayon.
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuHitTracer;

impl HitTracer for CpuHitTracer {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
        trace_rays(system, rays)
    }

    fn describe(&self) -> String {
        "cpu".into()
    }
}

static DEFAULT: RwLock<Option<Arc<dyn HitTracer>>> = RwLock::new(None);

/// Makes `tracer` the one every `PsfTracer` created from now on uses.
pub fn set_default_hit_tracer(tracer: Arc<dyn HitTracer>) {
    *DEFAULT.write().unwrap_or_else(|e| e.into_inner()) = Some(tracer);
}

/// The process-wide default (the CPU unless a front end chose otherwise).
pub fn default_hit_tracer() -> Arc<dyn HitTracer> {
    DEFAULT
        .read()
        .unwrap_or_else(|e| e.into_inner())
        .clone()
        .unwrap_or_else(|| Arc::new(CpuHitTracer))
}
