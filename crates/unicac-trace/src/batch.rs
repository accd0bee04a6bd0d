//! Many rays at once, in parallel over chunks with rayon.

use crate::ray::{Ray, RayStatus, StatusCounts};
use crate::system::TraceSystem;
use rayon::prelude::*;

/// Rays per rayon task: large enough to amortise scheduling, small enough to balance two cores.
const CHUNK: usize = 2048;

/// Rays traced surface by surface together: fits in L1 cache (48 bytes a ray) and gives the CPU
/// independent work to overlap.
const LANE_BLOCK: usize = 64;

/// Traces every ray to the image surface in place and returns one status per ray.
pub fn trace_rays(system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
    let mut statuses = vec![RayStatus::Ok; rays.len()];
    rays.par_chunks_mut(CHUNK)
        .zip(statuses.par_chunks_mut(CHUNK))
        .for_each(|(rays, statuses)| {
            trace_blocks(system, rays, statuses);
        });
    statuses
}

/// Traces on the calling thread only (for callers that parallelise at a coarser level).
pub fn trace_rays_serial(system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
    let mut statuses = vec![RayStatus::Ok; rays.len()];
    trace_blocks(system, rays, &mut statuses);
    statuses
}

fn trace_blocks(system: &TraceSystem, rays: &mut [Ray], statuses: &mut [RayStatus]) {
    for (rays, statuses) in rays.chunks_mut(LANE_BLOCK).zip(statuses.chunks_mut(LANE_BLOCK)) {
        system.trace_chunk(rays, statuses);
    }
}

/// Status counts of a finished batch.
pub fn count(statuses: &[RayStatus]) -> StatusCounts {
    statuses
        .par_chunks(CHUNK)
        .map(StatusCounts::from_statuses)
        .reduce(StatusCounts::default, StatusCounts::merge)
}
