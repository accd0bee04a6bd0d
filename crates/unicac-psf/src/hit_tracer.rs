//! `HitTracer`: who traces the rays of a geometric PSF (`PsfTracer::hits`), and `RayBackend`, the value
//! that carries one through `PsfSettings` (and so through the simulation and ODE settings) from the
//! face that chose it (`unicac ... --device`, Python `device=`) to every PSF traced for that job. The
//! CPU tracer of unicac-trace is the default; unicac-gpu implements the trait on the GPU.

use crate::error::PsfResult;
use std::sync::Arc;
use unicac_trace::{trace_rays, Ray, RayStatus, TraceSystem};

/// Traces rays (global coordinates) to the image surface in place, one status per ray, as
/// `unicac_trace::trace_rays` does.
pub trait HitTracer: Send + Sync {
    /// A device failure is an error (`PsfError::Backend`); a policy that falls back to the CPU instead
    /// records why in `take_notes`.
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> PsfResult<Vec<RayStatus>>;
    /// "cpu", "gpu (f32, llvmpipe ...)": for reports and PSF cache keys.
    fn describe(&self) -> String;
    /// What the user should be told about the run so far (a fallback to the CPU, ...), once each:
    /// libraries do not print, the face that chose the backend does.
    fn take_notes(&self) -> Vec<String> {
        Vec::new()
    }
}

/// The f64 reference tracer, in parallel with rayon.
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuHitTracer;

impl HitTracer for CpuHitTracer {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> PsfResult<Vec<RayStatus>> {
        Ok(trace_rays(system, rays))
    }

    fn describe(&self) -> String {
        "cpu".into()
    }
}

/// The ray backend of a job: a shared `HitTracer`, cheap to clone. Its `Debug` and serialised forms are
/// its description, so a cache key that holds it names the device that traced.
#[derive(Clone)]
pub struct RayBackend(Arc<dyn HitTracer>);

impl RayBackend {
    pub fn new(tracer: Arc<dyn HitTracer>) -> RayBackend {
        RayBackend(tracer)
    }

    /// The CPU reference tracer.
    pub fn cpu() -> RayBackend {
        RayBackend(Arc::new(CpuHitTracer))
    }

    pub fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> PsfResult<Vec<RayStatus>> {
        self.0.trace(system, rays)
    }

    /// "cpu", "gpu (f32, ...)": part of a PSF's provenance and cache key.
    pub fn describe(&self) -> String {
        self.0.describe()
    }

    /// Notes gathered since the last call (see `HitTracer::take_notes`).
    pub fn take_notes(&self) -> Vec<String> {
        self.0.take_notes()
    }
}

impl Default for RayBackend {
    fn default() -> Self {
        RayBackend::cpu()
    }
}

impl std::fmt::Debug for RayBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.describe())
    }
}

impl serde::Serialize for RayBackend {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.describe())
    }
}

/// Two backends are the same when they describe the same device (what a cache may share).
impl PartialEq for RayBackend {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.describe() == other.describe()
    }
}
