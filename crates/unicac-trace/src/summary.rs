//! `LensSummary`: what `unicac lens info --json` prints and `unicac.Lens.first_order()` returns, built in
//! one place so the two faces cannot drift apart.

use crate::apertures::clear_semi_diameters;
use crate::error::TraceResult;
use crate::spot::{self, DistortionPoint};
use crate::Aiming;
use serde::Serialize;
use unicac_optics::{FirstOrder, Lens};

#[derive(Debug, Clone, Serialize)]
pub struct LensSummary {
    pub name: String,
    /// Written only when false (a decentred or tilted surface): the first-order data are then the
    /// nominal, centred system's (docs/conventions.md).
    #[serde(skip_serializing_if = "is_true")]
    pub rotationally_symmetric: bool,
    pub surfaces: usize,
    pub stop_surface_number: usize,
    #[serde(flatten)]
    pub first_order: FirstOrder,
    /// 1 / (2 n' sin theta') of the real on-axis marginal ray.
    pub working_f_number: Option<f64>,
    pub clear_semi_diameters_mm: Vec<f64>,
    pub distortion: Vec<DistortionPoint>,
}

impl LensSummary {
    pub fn of(lens: &Lens) -> TraceResult<LensSummary> {
        let first_order = lens.first_order()?;
        Ok(LensSummary {
            name: lens.name.clone(),
            rotationally_symmetric: lens.is_rotationally_symmetric(),
            surfaces: lens.surfaces.len(),
            stop_surface_number: lens.stop_index + 1,
            working_f_number: spot::real_working_f_number(lens)?,
            clear_semi_diameters_mm: clear_semi_diameters(lens, Aiming::Auto)?,
            distortion: spot::distortion(lens, &first_order.field_angles_deg)?,
            first_order,
        })
    }
}

fn is_true(value: &bool) -> bool {
    *value
}
