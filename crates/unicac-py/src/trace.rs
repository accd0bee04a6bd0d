//! Real-ray tracing of ray batches, ray aiming and spot diagrams.
//!
//! Status codes (int32, also `unicac.STATUS_NAMES`): 0 ok, 1 missed, 2 tir, 3 clipped,
//! 4 no_convergence, 5 invalid_input — the names `unicac trace --json` prints.

use crate::arrays::{f64_array, i32_array, rows_f64};
use crate::errors::{keyword_error, OrRaise};
use crate::json;
use crate::lens::PyLens;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use unicac_trace::{
    spots as trace_spots, trace_rays, trace_rays_from_start, Aimer, Aiming, Clipping, PupilSampling,
};
use unicac_trace::{Ray, RayStatus, TraceSystem};

/// Status names in code order.
pub const STATUS_NAMES: [&str; 6] = [
    "ok",
    "missed",
    "tir",
    "clipped",
    "no_convergence",
    "invalid_input",
];

fn status_code(status: &RayStatus) -> i32 {
    match status {
        RayStatus::Ok => 0,
        RayStatus::Missed { .. } => 1,
        RayStatus::Tir { .. } => 2,
        RayStatus::Clipped { .. } => 3,
        RayStatus::NoConvergence { .. } => 4,
        RayStatus::InvalidInput => 5,
    }
}

/// 1-based surface where the ray stopped; 0 when it arrived or its input was invalid.
fn failed_surface(status: &RayStatus) -> i32 {
    match status {
        RayStatus::Missed { surface }
        | RayStatus::Tir { surface }
        | RayStatus::Clipped { surface }
        | RayStatus::NoConvergence { surface } => *surface as i32 + 1,
        RayStatus::Ok | RayStatus::InvalidInput => 0,
    }
}

pub fn wavelength_or_primary(lens: &PyLens, wavelength_um: Option<f64>) -> PyResult<f64> {
    let w = wavelength_um.unwrap_or_else(|| lens.lens.primary_wavelength_um());
    unicac_trace::check_wavelength_um(w).map_err(|e| keyword_error("wavelength_um", e))
}

pub fn parse_aiming(aiming: &str) -> PyResult<Aiming> {
    aiming
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("aiming: {e}")))
}

fn parse_sampling(sampling: &str) -> PyResult<PupilSampling> {
    sampling
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("pupil_sampling: {e}")))
}

/// Traced rays: end states and statuses.
struct Traced {
    rays: Vec<Ray>,
    statuses: Vec<RayStatus>,
}

fn trace_inputs(
    py: Python<'_>,
    lens: &PyLens,
    starts: &Bound<'_, PyAny>,
    dirs: &Bound<'_, PyAny>,
    wavelength_um: Option<f64>,
    clip: bool,
    virtual_start: bool,
) -> PyResult<Traced> {
    let starts = rows_f64::<3>(starts, "starts")?;
    let dirs = rows_f64::<3>(dirs, "dirs")?;
    if starts.len() != dirs.len() {
        return Err(PyValueError::new_err(format!(
            "starts and dirs: {} and {} rows; they must have the same length",
            starts.len(),
            dirs.len()
        )));
    }
    let wavelength = wavelength_or_primary(lens, wavelength_um)?;
    let clipping = if clip { Clipping::Apertures } else { Clipping::None };
    crate::pool::detach(py, || {
        let system = TraceSystem::new(&lens.lens, wavelength, clipping).or_raise()?;
        // Ray::new normalises; a zero or non-finite direction becomes an invalid_input status.
        let mut rays: Vec<Ray> = starts.iter().zip(&dirs).map(|(p, d)| Ray::new(*p, *d)).collect();
        // User rays start where they are given: one pointing away from the lens or starting past the
        // image is missed, as in `unicac trace --ray` (docs/reliability.md). Aimed rays start on the
        // entrance-pupil plane, which may lie inside or behind the lens (virtual), as `unicac trace
        // --field-deg` traces them.
        let statuses = if virtual_start {
            trace_rays(&system, &mut rays)
        } else {
            trace_rays_from_start(&system, &mut rays)
        };
        Ok(Traced { rays, statuses })
    })
}

/// Traces rays to the image surface.
///
/// `starts` and `dirs`: float64 arrays of shape (N, 3), start points (mm) and directions (normalised
/// here) in global coordinates (surface 1's vertex at the origin, z towards the image). Rays start where
/// they are: a ray that would have to travel backwards to reach a surface (pointing away from the lens,
/// starting past the image) is `missed` at that surface. `virtual_start=True` is for the rays of
/// `aim_rays`, which start on the entrance-pupil plane and may reach the first surface backwards (a
/// virtual segment), as `unicac trace --field-deg` traces them.
/// `wavelength_um` defaults to the lens's primary wavelength; `clip` applies clear semi-diameters.
/// Returns `xy` (float64, (N, 2), mm, on the image surface; NaN where the ray did not arrive) and
/// `status` (int32, (N,), codes of `STATUS_NAMES`). The GIL is released while tracing (in parallel).
#[pyfunction]
#[pyo3(signature = (lens, starts, dirs, wavelength_um=None, clip=true, virtual_start=false))]
pub fn trace<'py>(
    py: Python<'py>,
    lens: &PyLens,
    starts: &Bound<'py, PyAny>,
    dirs: &Bound<'py, PyAny>,
    wavelength_um: Option<f64>,
    clip: bool,
    virtual_start: bool,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let traced = trace_inputs(py, lens, starts, dirs, wavelength_um, clip, virtual_start)?;
    let n = traced.rays.len();
    let mut xy = Vec::with_capacity(2 * n);
    for (ray, status) in traced.rays.iter().zip(&traced.statuses) {
        if status.is_ok() {
            xy.extend_from_slice(&ray.position_mm[..2]);
        } else {
            xy.extend_from_slice(&[f64::NAN, f64::NAN]);
        }
    }
    let codes = traced.statuses.iter().map(status_code).collect();
    Ok((f64_array(py, xy, &[n, 2])?, i32_array(py, codes, &[n])?))
}

/// Like `trace`, with everything: a dict of `position_mm` (N, 3) and `direction` (N, 3) at the image
/// surface (for rays that stopped early: their last valid state), `status` (N,) and
/// `failed_at_surface` (N,), the 1-based surface where a ray stopped (0 when it arrived).
#[pyfunction]
#[pyo3(signature = (lens, starts, dirs, wavelength_um=None, clip=true, virtual_start=false))]
pub fn trace_detailed<'py>(
    py: Python<'py>,
    lens: &PyLens,
    starts: &Bound<'py, PyAny>,
    dirs: &Bound<'py, PyAny>,
    wavelength_um: Option<f64>,
    clip: bool,
    virtual_start: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let traced = trace_inputs(py, lens, starts, dirs, wavelength_um, clip, virtual_start)?;
    let n = traced.rays.len();
    let positions: Vec<f64> = traced.rays.iter().flat_map(|r| r.position_mm).collect();
    let directions: Vec<f64> = traced.rays.iter().flat_map(|r| r.direction).collect();
    let out = PyDict::new(py);
    out.set_item("position_mm", f64_array(py, positions, &[n, 3])?)?;
    out.set_item("direction", f64_array(py, directions, &[n, 3])?)?;
    out.set_item(
        "status",
        i32_array(py, traced.statuses.iter().map(status_code).collect(), &[n])?,
    )?;
    out.set_item(
        "failed_at_surface",
        i32_array(py, traced.statuses.iter().map(failed_surface).collect(), &[n])?,
    )?;
    Ok(out)
}

/// Object-space rays of field `field_deg` through normalised pupil points `pupil` (float64, (M, 2)),
/// aimed `"auto"` (the default: real where the pupil is aberrated), `"paraxial"` or `"real"`
/// (docs/conventions.md), at `wavelength_um` (default: primary).
/// Returns `(starts, dirs)`, float64 (M, 3) each, for `trace(..., virtual_start=True)` (they start on the
/// entrance-pupil plane, which may be virtual); rows that real aiming could not
/// place are NaN (and trace as `invalid_input`).
#[pyfunction]
#[pyo3(signature = (lens, field_deg, pupil, wavelength_um=None, aiming="auto"))]
pub fn aim_rays<'py>(
    py: Python<'py>,
    lens: &PyLens,
    field_deg: f64,
    pupil: &Bound<'py, PyAny>,
    wavelength_um: Option<f64>,
    aiming: &str,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let pupil = rows_f64::<2>(pupil, "pupil")?;
    let wavelength = wavelength_or_primary(lens, wavelength_um)?;
    let aiming = parse_aiming(aiming)?;
    unicac_trace::check_field_deg(field_deg).map_err(|e| keyword_error("field_deg", e))?;
    let rays: Vec<Option<Ray>> = crate::pool::detach(py, || {
        let aimer = Aimer::new(&lens.lens, wavelength, aiming).or_raise()?;
        Ok::<_, PyErr>(
            pupil
                .iter()
                .map(|[px, py]| aimer.ray(field_deg, *px, *py).ok())
                .collect(),
        )
    })?;
    let n = rays.len();
    let nan = [f64::NAN; 3];
    let starts = rays
        .iter()
        .flat_map(|r| r.map_or(nan, |r| r.position_mm))
        .collect();
    let dirs = rays.iter().flat_map(|r| r.map_or(nan, |r| r.direction)).collect();
    Ok((f64_array(py, starts, &[n, 3])?, f64_array(py, dirs, &[n, 3])?))
}

/// Spot diagrams for every (field, wavelength) pair, fields varying fastest: a list of dicts with the
/// keys of `unicac spot --json` (`rms_radius_um`, `centroid_x_mm`, ...) plus `points_mm`, the
/// image-surface intercepts (float64, (M, 2)). Defaults: the lens's fields and wavelengths.
/// `pupil_sampling`: "hexapolar:R", "grid:N", "fibonacci:N" or "random:N[:SEED]".
#[pyfunction]
#[pyo3(signature = (lens, fields_deg=None, wavelengths_um=None, aiming="auto", pupil_sampling="hexapolar:10"))]
pub fn spots<'py>(
    py: Python<'py>,
    lens: &PyLens,
    fields_deg: Option<Vec<f64>>,
    wavelengths_um: Option<Vec<f64>>,
    aiming: &str,
    pupil_sampling: &str,
) -> PyResult<Bound<'py, PyList>> {
    let aiming = parse_aiming(aiming)?;
    let sampling = parse_sampling(pupil_sampling)?;
    let fields = match fields_deg {
        Some(f) => f,
        None => lens.lens.first_order().or_raise()?.field_angles_deg,
    };
    let wavelengths = wavelengths_um.unwrap_or_else(|| lens.lens.wavelengths_um());
    unicac_trace::check_wavelengths_um(&wavelengths).map_err(|e| keyword_error("wavelengths_um", e))?;
    unicac_trace::check_fields_deg(&fields).map_err(|e| keyword_error("fields_deg", e))?;
    let computed = crate::pool::detach(py, || {
        trace_spots(&lens.lens, &fields, &wavelengths, aiming, &sampling).or_raise()
    })?;
    let list = PyList::empty(py);
    for spot in &computed {
        let dict = json::serialize_dict(py, spot)?;
        let points: Vec<f64> = spot.points_mm.iter().flatten().copied().collect();
        dict.set_item("points_mm", f64_array(py, points, &[spot.points_mm.len(), 2])?)?;
        list.append(dict)?;
    }
    Ok(list)
}

/// Registers this module's functions and constants.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("STATUS_NAMES", STATUS_NAMES.to_vec())?;
    m.add_function(wrap_pyfunction!(trace, m)?)?;
    m.add_function(wrap_pyfunction!(trace_detailed, m)?)?;
    m.add_function(wrap_pyfunction!(aim_rays, m)?)?;
    m.add_function(wrap_pyfunction!(spots, m)?)?;
    Ok(())
}
