//! The dataset maps models receive (docs/models.md), from the one Rust implementation
//! (`unicac_dataset`): the field-of-view map and the PSF-feature map of a lens's PSF table.

use crate::arrays::f32_array;
use crate::errors::OrRaise;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;
use unicac_dataset::{FrameCrop, PsfTable};

/// The crop (x0, y0, w, h) of a frame; `w`/`h` None run to the frame's edge.
fn crop(
    frame_w: usize,
    frame_h: usize,
    x0: usize,
    y0: usize,
    w: Option<usize>,
    h: Option<usize>,
) -> PyResult<FrameCrop> {
    let crop = FrameCrop {
        frame_w,
        frame_h,
        x0,
        y0,
        w: w.unwrap_or(frame_w.saturating_sub(x0)),
        h: h.unwrap_or(frame_h.saturating_sub(y0)),
    };
    crop.check().map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(crop)
}

/// Field-of-view map of the crop (x0, y0, w, h) of a frame_w x frame_h frame: float32 [2, h, w],
/// channel 0 = x, 1 = y of each pixel centre relative to the frame centre, divided by the frame's
/// half-diagonal (x right, y down; docs/models.md).
#[pyfunction]
#[pyo3(signature = (frame_w, frame_h, x0=0, y0=0, w=None, h=None))]
pub fn fov_map<'py>(
    py: Python<'py>,
    frame_w: usize,
    frame_h: usize,
    x0: usize,
    y0: usize,
    w: Option<usize>,
    h: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let crop = crop(frame_w, frame_h, x0, y0, w, h)?;
    let map = crate::pool::detach(py, || unicac_dataset::fov_map(crop).or_raise())?;
    f32_array(py, map.data, &[map.channels, map.height, map.width])
}

/// PSF-feature map of the crop (x0, y0, w, h) of a frame_w x frame_h frame from a dataset's PSF
/// table folder (`DIR/psf/LENS_ID`): float32 [15, h, w], per channel R, G, B the centroid (dx, dy)
/// and signed-sqrt second central moments (sxx, sxy, syy) in px, rotated to each pixel's azimuth
/// (docs/models.md).
#[pyfunction]
#[pyo3(signature = (table_dir, frame_w, frame_h, x0=0, y0=0, w=None, h=None))]
#[allow(clippy::too_many_arguments)]
pub fn psf_features<'py>(
    py: Python<'py>,
    table_dir: PathBuf,
    frame_w: usize,
    frame_h: usize,
    x0: usize,
    y0: usize,
    w: Option<usize>,
    h: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let crop = crop(frame_w, frame_h, x0, y0, w, h)?;
    let map = crate::pool::detach(py, || {
        let table = PsfTable::read(&table_dir).or_raise()?;
        unicac_dataset::psf_feature_map(&table, crop).or_raise()
    })?;
    f32_array(py, map.data, &[map.channels, map.height, map.width])
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fov_map, m)?)?;
    m.add_function(wrap_pyfunction!(psf_features, m)?)?;
    Ok(())
}
