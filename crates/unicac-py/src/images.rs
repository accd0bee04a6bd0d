//! Image files and generated charts as numpy arrays.

use crate::arrays::{check_size, encoded_out, image_samples, planar_out, SampleKind};
use crate::errors::{ImageError, OrRaise};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;
use unicac_image::io::{
    read_image as read_file, write_exr, write_png, write_tiff, Encoding, LoadedImage, SampleDepth,
};
use unicac_image::{charts, color, Planar};

/// The R, G, B planes of a loaded file (grey replicated, alpha dropped), as `unicac simulate` reads it.
fn rgb_planes(loaded: &LoadedImage, image: &Planar, path: &str) -> PyResult<Planar> {
    loaded.rgb_planes(image).ok_or_else(|| not_grey_or_rgb(path))
}

fn not_grey_or_rgb(path: &str) -> PyErr {
    ImageError::new_err(format!("{path}: expected a grey or RGB image"))
}

/// Reads a PNG, TIFF or OpenEXR file as an H x W x 3 array (grey replicated, alpha dropped), as
/// `unicac simulate` reads its inputs: 8-bit files as uint8 and 16-bit files as uint16 sRGB codes,
/// float files as float32 linear light; `linear=True` returns float32 linear light for every file.
#[pyfunction]
#[pyo3(signature = (path, linear=false))]
pub fn read_image<'py>(py: Python<'py>, path: PathBuf, linear: bool) -> PyResult<Bound<'py, PyAny>> {
    let name = path.display().to_string();
    let loaded = crate::pool::detach(py, || read_file(&path).or_raise())?;
    let integer = loaded.encoding == Encoding::Srgb && loaded.bit_depth <= 16 && !linear;
    if integer {
        let encoded = rgb_planes(&loaded, &loaded.image, &name)?;
        let kind = if loaded.bit_depth <= 8 {
            SampleKind::U8
        } else {
            SampleKind::U16
        };
        // encoded_out expects sRGB-encoded unit-range samples and returns codes for integer kinds.
        return encoded_out(py, &encoded, kind);
    }
    // Decoded to linear light in place: no copies of the file's planes.
    let rgb = crate::pool::detach(py, || loaded.into_linear_rgb()).ok_or_else(|| not_grey_or_rgb(&name))?;
    planar_out(py, &rgb, false)
}

/// Writes an H x W x 3 image: uint8/uint16 arrays hold sRGB codes (PNG/TIFF at that depth; EXR gets
/// the decoded linear values), float32 arrays hold linear light (EXR as is; PNG/TIFF sRGB-encoded at
/// 16 bits). The format follows the extension (.png, .tif/.tiff, .exr). Atomic.
#[pyfunction]
pub fn write_image(py: Python<'_>, path: PathBuf, image: &Bound<'_, PyAny>) -> PyResult<()> {
    let (samples, kind) = image_samples(image, "image")?;
    // Integer input is written as its codes (no decode/encode round trip); float32 is linear light.
    let (linear, encoded) = match kind {
        SampleKind::F32 => (samples.clone(), color::linear_to_srgb(&samples)),
        _ => (color::srgb_to_linear(&samples), samples),
    };
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let depth = if kind == SampleKind::U8 {
        SampleDepth::Eight
    } else {
        SampleDepth::Sixteen
    };
    crate::pool::detach(py, || match extension.as_str() {
        "exr" => write_exr(&path, &linear).or_raise(),
        "png" => write_png(&path, &encoded, depth).or_raise(),
        "tif" | "tiff" => write_tiff(&path, &encoded, depth).or_raise(),
        _ => Err(PyValueError::new_err(format!(
            "path: {}: unknown image extension (expected .png, .tif, .tiff or .exr)",
            path.display()
        ))),
    })
}

/// A generated test chart, float32 H x W x 3 linear light in [0, 1], as `unicac chart KIND --size
/// WxH --seed SEED`: "dead-leaves" (seeded), "checkerboard", "slanted-edge" or "siemens-star".
#[pyfunction]
#[pyo3(signature = (kind, width_px, height_px, seed=0))]
pub fn chart<'py>(
    py: Python<'py>,
    kind: &str,
    width_px: usize,
    height_px: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyAny>> {
    check_size(width_px, height_px)?;
    let (w, h) = (width_px, height_px);
    let image = crate::pool::detach(py, || match kind {
        "dead-leaves" => charts::dead_leaves(w, h, seed).or_raise(),
        "checkerboard" => charts::checkerboard(w, h, (w.min(h) as f64 / 8.0).max(8.0), 1.0, 5.0).or_raise(),
        "slanted-edge" => charts::slanted_edge(w, h, 5.0, 0.2, 0.8).or_raise(),
        "siemens-star" => charts::siemens_star(w, h, 36).or_raise(),
        other => Err(PyValueError::new_err(format!(
            "kind: '{other}': expected dead-leaves, checkerboard, slanted-edge or siemens-star"
        ))),
    })?;
    planar_out(py, &image, false)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(chart, m)?)?;
    Ok(())
}
