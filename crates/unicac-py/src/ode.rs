//! The Optical Degradation Evaluator (ODE) of a lens and the OIQE score of a PSF.

use crate::arrays::planar_f32;
use crate::errors::{self, OdeError, OrRaise};
use crate::json;
use crate::lens::PyLens;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use unicac_ode::evaluate::edge_mtfs;
use unicac_ode::{evaluate, FrameSensor, LensOde, OdeSettings};
use unicac_psf::Kernel;

/// ODE, OIQ, uniformity, OIQE, PSNR, SSIM and RMS spot radius of a lens with the default settings
/// (docs/ode.md): a dict with the keys of one entry of `unicac ode LENS --json` (`lens` is the
/// lens's source; `times` are wall-clock seconds and vary run to run). `device`: "cpu", "gpu" or
/// "auto", who traces the PSF rays (as `unicac ode --device`). `frame_px=(W, H)` and `pixel_um`:
/// graded on that frame instead of the lens file's sensor (as `unicac ode --frame WxH --pixel-um X`
/// and `unicac dataset build`). GIL released.
#[pyfunction]
#[pyo3(signature = (lens, device="cpu", frame_px=None, pixel_um=None))]
pub fn ode<'py>(
    py: Python<'py>,
    lens: &PyLens,
    device: &str,
    frame_px: Option<(usize, usize)>,
    pixel_um: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let frame = match (frame_px, pixel_um) {
        (Some((w, h)), _) => Some(FrameSensor {
            frame_px: [w, h],
            pixel_um,
        }),
        (None, Some(_)) => return Err(PyValueError::new_err("pixel_um: needs frame_px")),
        (None, None) => None,
    };
    if let Some(frame) = &frame {
        frame.check().map_err(errors::parameter_error)?;
    }
    let settings = OdeSettings {
        backend: crate::device::backend(device)?,
        ..frame.map_or_else(OdeSettings::default, |f| f.ode_settings())
    };
    let graded = frame.map(|f| f.apply(&lens.lens));
    let report = crate::pool::detach(py, || {
        evaluate(graded.as_ref().unwrap_or(&lens.lens), &settings).or_raise()
    });
    crate::device::warn_notes(py, &settings.backend)?;
    json::serialize_dict(
        py,
        &LensOde {
            lens: lens.source.clone(),
            report: report?,
        },
    )
}

/// OIQE of one PSF kernel (float32, K x K, K odd, at the pixel pitch), as ODE scores a field and
/// channel: slanted edges imaged through the kernel, MTF50 and normalised MTF area in both directions.
/// Returns a dict with `oiqe`, `mtf50_sagittal_cy_per_px` and `mtf50_tangential_cy_per_px`.
#[pyfunction]
pub fn oiqe_of_psf<'py>(py: Python<'py>, kernel: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let plane = planar_f32(kernel, "kernel", 2, &[])?;
    if plane.width != plane.height {
        return Err(PyValueError::new_err(format!(
            "kernel: expected a square kernel of odd size, got {} x {}",
            plane.height, plane.width
        )));
    }
    let kernel = Kernel::normalised_from(plane.width, 1.0, &plane.data).map_err(errors::parameter_error)?;
    let settings = OdeSettings::default();
    let (oiqe, sagittal, tangential) = crate::pool::detach(py, || -> PyResult<(f64, f64, f64)> {
        let edges = edge_mtfs(&kernel, &settings)
            .map_err(|(direction, e)| OdeError::new_err(format!("slanted edge, {direction}: {e}")))?;
        let (sagittal, tangential) = (edges[0].summary(), edges[1].summary());
        let oiqe = unicac_metrics::oiqe(&tangential, &sagittal, &settings.oiqe_weights).or_raise()?;
        Ok((oiqe, sagittal.mtf50_cy_per_px, tangential.mtf50_cy_per_px))
    })?;
    let out = PyDict::new(py);
    out.set_item("oiqe", oiqe)?;
    out.set_item("mtf50_sagittal_cy_per_px", sagittal)?;
    out.set_item("mtf50_tangential_cy_per_px", tangential)?;
    Ok(out)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(ode, m)?)?;
    m.add_function(wrap_pyfunction!(oiqe_of_psf, m)?)?;
    Ok(())
}
