//! The ray set behind every throughput figure of the tracers (docs/performance.md), in one place so the
//! CPU example, the criterion bench and the GPU example measure the same work.

use crate::error::TraceResult;
use crate::{Aimer, Aiming, PupilSampling, Ray};
use unicac_optics::Lens;

/// `count` rays uniform over the paraxial entrance pupil (seeded), the first half on axis and the rest at
/// the lens's largest field, primary wavelength, paraxially aimed.
pub fn axis_and_edge_rays(lens: &Lens, count: usize, seed: u64) -> TraceResult<Vec<Ray>> {
    let aimer = Aimer::new(lens, lens.primary_wavelength_um(), Aiming::Paraxial)?;
    let max_field = aimer.first_order.max_field_deg();
    PupilSampling::Random { n: count, seed }
        .points()
        .iter()
        .enumerate()
        .map(|(i, [px, py])| aimer.ray(if i < count / 2 { 0.0 } else { max_field }, *px, *py))
        .collect()
}
