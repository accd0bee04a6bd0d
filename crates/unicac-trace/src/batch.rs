//! Many rays at once, in parallel over chunks with rayon.

use crate::ray::{Ray, RayStatus, StatusCounts};
use crate::system::TraceSystem;
use rayon::prelude::*;

/// Rays per rayon task: large enough to amortise scheduling, small enough to balance two cores.
const CHUNK: usize = 2048;

/// Traces every ray to the image surface in place and returns one status per ray.
pub fn trace_rays(system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
    in_parallel_chunks(rays, |rays, statuses| system.trace_chunk(rays, statuses))
}

/// Traces rays that physically start where they are (rays given by a user, e.g. through Python): a ray
/// that would have to travel backwards to a surface is `Missed` there (`TraceSystem::trace_from_start`).
/// Ray by ray, not in SIMD lanes: user rays need the per-surface direction check, aimed rays (which
/// start on a possibly virtual entrance pupil) use `trace_rays`.
pub fn trace_rays_from_start(system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
    in_parallel_chunks(rays, |rays, statuses| {
        for (ray, status) in rays.iter_mut().zip(statuses) {
            *status = system.trace_from_start(ray);
        }
    })
}

/// One status per ray, with `trace` run on chunks of `CHUNK` rays (and their statuses) in parallel.
fn in_parallel_chunks(
    rays: &mut [Ray],
    trace: impl Fn(&mut [Ray], &mut [RayStatus]) + Sync,
) -> Vec<RayStatus> {
    let mut statuses = vec![RayStatus::Ok; rays.len()];
    rays.par_chunks_mut(CHUNK)
        .zip(statuses.par_chunks_mut(CHUNK))
        .for_each(|(rays, statuses)| trace(rays, statuses));
    statuses
}

/// Traces on the calling thread only (for callers that parallelise at a coarser level).
pub fn trace_rays_serial(system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
    let mut statuses = vec![RayStatus::Ok; rays.len()];
    system.trace_chunk(rays, &mut statuses);
    statuses
}

/// Status counts of a finished batch.
pub fn count(statuses: &[RayStatus]) -> StatusCounts {
    statuses
        .par_chunks(CHUNK)
        .map(StatusCounts::from_statuses)
        .reduce(StatusCounts::default, StatusCounts::merge)
}
