//! Built datasets as Rust reads them, for `unicac.dataset.DatasetFolder`: the manifests checked by the
//! one reader (`unicac_dataset::folder`), the manifest-path rule, PSF table metadata and the pair checks
//! per lens; and the dataset maps models receive (docs/models.md), from the one Rust implementation
//! (`unicac_dataset`, `unicac_bench::wiener`): the field-of-view map, the PSF-feature map and the
//! `psf_code` map of a lens's PSF table, the dataset's PSF basis, and the field-varying Wiener estimate.

use crate::arrays::{any_f32, f32_array, f64_array, planar_f32, planar_out};
use crate::errors::OrRaise;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;
use unicac_dataset::folder::Dataset;
use unicac_dataset::psf_basis::{FieldCodes, PsfBasis, CODE_COMPONENTS};
use unicac_dataset::{FrameCrop, PsfTable};
use unicac_image::color::linear_to_srgb;
use unicac_image::Planar;

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

/// The PSF basis of a built dataset (`DIR/psf/basis`, docs/models.md): its `basis.json` as a dict,
/// after fitting and writing it when the folder has none (on the training lenses' tables named in
/// `lenses.jsonl`; what `unicac dataset build` does when it completes a dataset).
#[pyfunction]
pub fn psf_basis<'py>(py: Python<'py>, dataset_dir: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let meta = crate::pool::detach(py, || -> PyResult<_> {
        let dir = dataset_dir.join(unicac_dataset::psf_basis::BASIS_RELATIVE);
        if dir.join(unicac_dataset::psf_basis::BASIS_JSON).is_file() {
            return Ok(PsfBasis::read(&dir).or_raise()?.meta);
        }
        let path = dataset_dir.join(unicac_dataset::manifest::LENSES_JSONL);
        let lenses: Vec<unicac_dataset::LensRow> = unicac_dataset::manifest::read_jsonl(&path).or_raise()?;
        let basis = unicac_dataset::builder::fit_psf_basis(&dataset_dir, &lenses).or_raise()?;
        basis.write(&dir).or_raise()?;
        Ok(basis.meta)
    })?;
    crate::json::serialize(py, &meta)
}

/// The codes of a PSF table's stored fields in a basis (`DIR/psf/basis`): `(radii, codes)`, float64
/// [F] normalised field radii and float32 [F, 48] whitened coefficients (R, G, B x 16).
#[pyfunction]
pub fn psf_field_codes<'py>(
    py: Python<'py>,
    table_dir: PathBuf,
    basis_dir: PathBuf,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let codes = crate::pool::detach(py, || -> PyResult<FieldCodes> {
        let basis = PsfBasis::read(&basis_dir).or_raise()?;
        let table = PsfTable::read(&table_dir).or_raise()?;
        Ok(basis.field_codes(&table))
    })?;
    let fields = codes.radii().len();
    let flat: Vec<f32> = codes.codes().iter().flatten().copied().collect();
    Ok((
        f64_array(py, codes.radii().to_vec(), &[fields])?,
        f32_array(py, flat, &[fields, 3 * CODE_COMPONENTS])?,
    ))
}

/// The `psf_code` map of the crop (x0, y0, w, h) of a frame_w x frame_h frame from a table's field
/// codes (`psf_field_codes`): float32 [50, h, w], the coefficients interpolated at each pixel's field
/// radius, then cos and sin of its azimuth (docs/models.md).
#[pyfunction]
#[pyo3(signature = (radii, codes, frame_w, frame_h, x0=0, y0=0, w=None, h=None))]
#[allow(clippy::too_many_arguments)]
pub fn psf_code_map<'py>(
    py: Python<'py>,
    radii: Vec<f64>,
    codes: &Bound<'py, PyAny>,
    frame_w: usize,
    frame_h: usize,
    x0: usize,
    y0: usize,
    w: Option<usize>,
    h: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let crop = crop(frame_w, frame_h, x0, y0, w, h)?;
    let (values, shape) = any_f32(codes, "codes")?;
    if shape != [radii.len(), 3 * CODE_COMPONENTS] {
        return Err(PyValueError::new_err(format!(
            "codes: expected float32 [{}, {}] (one row per radius), got {shape:?}",
            radii.len(),
            3 * CODE_COMPONENTS
        )));
    }
    let rows = values
        .chunks_exact(3 * CODE_COMPONENTS)
        .map(|c| c.try_into().expect("chunk length"))
        .collect();
    let codes = FieldCodes::new(radii, rows).or_raise()?;
    let map = crate::pool::detach(py, || unicac_dataset::psf_code_map(&codes, crop).or_raise())?;
    f32_array(py, map.data, &[map.channels, map.height, map.width])
}

/// The field-varying Wiener estimate of `lq` (float32 H x W x 3, sRGB-encoded in [0, 1]), the crop at
/// (x0, y0) of a frame_w x frame_h frame, with a dataset's PSF table: what `unicac bench --method wiener`
/// computes (float32 H x W x 3, sRGB in [0, 1]). `nsr` defaults to the bench's (0.01).
#[pyfunction]
#[pyo3(signature = (lq, table_dir, frame_w, frame_h, x0=0, y0=0, nsr=0.01))]
#[allow(clippy::too_many_arguments)]
pub fn wiener_restore<'py>(
    py: Python<'py>,
    lq: &Bound<'py, PyAny>,
    table_dir: PathBuf,
    frame_w: usize,
    frame_h: usize,
    x0: usize,
    y0: usize,
    nsr: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(lq, "lq", 3, &[3])?;
    if image.data.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err("lq: NaN or infinite sample"));
    }
    let crop = crop(frame_w, frame_h, x0, y0, Some(image.width), Some(image.height))?;
    let restored = crate::pool::detach(py, || -> PyResult<_> {
        let table = PsfTable::read(&table_dir).or_raise()?;
        unicac_bench::wiener::wiener_restore(&image, &table, &|r, c| crop.normalised(r, c), nsr)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    })?;
    planar_out(py, &restored, false)
}

/// Training twins of the bench's slanted-edge pairs, for any lens with a PSF table: the ODE's two edge
/// charts (an isolated 0.2-0.8 edge slanted by the ODE's angle, max(`min_edge_px`, 4 kernel widths) on
/// a side, and its transpose) imaged through stored field `field` of the table, channel c through the
/// channel-c kernel (a grey edge with the lens's colour fringes, as the bench composes a test lens's three
/// edge patches), centred on that field's radius on the frame's +x axis. Returns one dict per chart asked
/// for (`edge`: "vertical", "horizontal", or None for both, in that order), each with `edge`, `gt`, `lq`
/// and `wiener` (float32 H x W x 3, sRGB in [0, 1], `gt` and `lq` 16-bit like the dataset's PNGs;
/// `wiener`: the bench's estimate of `lq` at `nsr`, computed only for the charts returned).
#[pyfunction]
#[pyo3(signature = (table_dir, field, min_edge_px=64, nsr=0.01, edge=None))]
pub fn table_edge_pairs<'py>(
    py: Python<'py>,
    table_dir: PathBuf,
    field: usize,
    min_edge_px: usize,
    nsr: f64,
    edge: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    const EDGES: [&str; 2] = ["vertical", "horizontal"];
    // Chart indices in `unicac_ode::edge_patches` order (the near-vertical edge, then its transpose).
    let wanted: Vec<usize> = match edge {
        None => vec![0, 1],
        Some(name) => match EDGES.iter().position(|e| *e == name) {
            Some(d) => vec![d],
            None => {
                return Err(PyValueError::new_err(format!(
                    "edge: '{name}': expected vertical, horizontal or None (both)"
                )))
            }
        },
    };
    if !(nsr.is_finite() && nsr > 0.0) {
        return Err(PyValueError::new_err(format!(
            "nsr: {nsr} is not a positive finite number"
        )));
    }
    if !(16..=4096).contains(&min_edge_px) {
        return Err(PyValueError::new_err(format!(
            "min_edge_px: {min_edge_px} is outside 16..=4096"
        )));
    }
    let pairs = crate::pool::detach(py, || -> PyResult<Vec<[Planar; 3]>> {
        let table = PsfTable::read(&table_dir).or_raise()?;
        if field >= table.fields() {
            return Err(PyValueError::new_err(format!(
                "field: {field} is not a stored field of {} (it has {})",
                table_dir.display(),
                table.fields()
            )));
        }
        let settings = unicac_ode::OdeSettings {
            min_edge_px,
            ..unicac_ode::OdeSettings::default()
        };
        let k = table.meta.kernel_px;
        let per_channel = (0..3)
            .map(|c| {
                let kernel = unicac_psf::Kernel {
                    size: k,
                    pitch_um: table.meta.pixel_um,
                    data: table.kernel(field, c).to_vec(),
                };
                unicac_ode::edge_patches(&kernel, &settings)
                    .map_err(|(direction, e)| PyValueError::new_err(format!("{direction} edge: {e}")))
            })
            .collect::<PyResult<Vec<_>>>()?;
        let [frame_w, frame_h] = table.meta.frame_px;
        let half_diagonal_px = unicac_dataset::half_diagonal_px(frame_w, frame_h);
        let radius = table.meta.field_radius_norm[field];
        wanted
            .iter()
            .map(|&d| {
                let ideal = &per_channel[0][d].ideal;
                let (w, h) = (ideal.width, ideal.height);
                let sixteen_bit = |linear: Planar| {
                    unicac_image::quantise::quantise(&linear_to_srgb(&linear), 16).or_raise()
                };
                let gt = sixteen_bit(Planar::from_fn(w, h, 3, |_, x, y| ideal.get(0, x, y)))?;
                let lq = sixteen_bit(Planar::from_fn(w, h, 3, |c, x, y| {
                    per_channel[c][d].blurred.get(0, x, y)
                }))?;
                // The bench's placement of an edge patch (centred on its field), turned to the +x axis.
                let position = |row: usize, column: usize| {
                    [
                        radius + (column as f64 + 0.5 - 0.5 * w as f64) / half_diagonal_px,
                        (row as f64 + 0.5 - 0.5 * h as f64) / half_diagonal_px,
                    ]
                };
                let wiener = unicac_bench::wiener::wiener_restore(&lq, &table, &position, nsr)
                    .map_err(|e| PyValueError::new_err(e.to_string()))?;
                Ok([gt, lq, wiener])
            })
            .collect()
    })?;
    let out = pyo3::types::PyList::empty(py);
    for (&d, [gt, lq, wiener]) in wanted.iter().zip(&pairs) {
        let edge = EDGES[d];
        let pair = pyo3::types::PyDict::new(py);
        pair.set_item("edge", edge)?;
        pair.set_item("gt", planar_out(py, gt, false)?)?;
        pair.set_item("lq", planar_out(py, lq, false)?)?;
        pair.set_item("wiener", planar_out(py, wiener, false)?)?;
        out.append(pair)?;
    }
    Ok(out.into_any())
}

/// A built dataset's manifests, read and checked as `unicac bench` reads them: a dict with `manifest`
/// (`dataset.json`), `pairs` and `lenses` (the rows of `pairs.jsonl` and `lenses.jsonl`, every field of
/// docs/dataset.md). A folder without `dataset.json`, a newer format, a row missing a field or of the
/// wrong type (named by file and line) and a manifest whose rows disagree with `dataset.json`'s counts
/// raise `DatasetError`.
#[pyfunction]
pub fn read_dataset<'py>(py: Python<'py>, dataset_dir: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let (manifest, pairs, lenses) = crate::pool::detach(py, || -> PyResult<_> {
        let dataset = Dataset::open(&dataset_dir).or_raise()?;
        let pairs = dataset.pairs().or_raise()?;
        let lenses = dataset.lenses().or_raise()?;
        Ok((dataset.manifest, pairs, lenses))
    })?;
    let out = pyo3::types::PyDict::new(py);
    out.set_item("manifest", crate::json::serialize(py, &manifest)?)?;
    out.set_item("pairs", crate::json::serialize(py, &pairs)?)?;
    out.set_item("lenses", crate::json::serialize(py, &lenses)?)?;
    Ok(out.into_any())
}

/// A manifest path resolved against the dataset folder: absolute paths, `..`, `.` and the empty path
/// raise `DatasetError` (no row may point outside the folder).
#[pyfunction]
pub fn dataset_path(dataset_dir: PathBuf, relative: &str) -> PyResult<PathBuf> {
    unicac_dataset::folder::resolve_relative(&dataset_dir, relative).or_raise()
}

/// A PSF table's `table.json` (`DIR/psf/LENS_ID`) as a dict, its format and version checked.
#[pyfunction]
pub fn psf_table_meta<'py>(py: Python<'py>, table_dir: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let meta = PsfTable::read_meta(&table_dir).or_raise()?;
    crate::json::serialize(py, &meta)
}

/// The mean checks of each lens's pairs in `split` (all splits when None), as `unicac dataset info`
/// prints them: a list of dicts (lens_id, split, level, ode, pairs, checked, mean_lq_gt_psnr_db,
/// mean_registration_px, mean_blur_share, flag), in `lenses.jsonl` order.
#[pyfunction]
#[pyo3(signature = (dataset_dir, split=None))]
pub fn dataset_pair_checks<'py>(
    py: Python<'py>,
    dataset_dir: PathBuf,
    split: Option<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let checks = crate::pool::detach(py, || -> PyResult<_> {
        let dataset = Dataset::open(&dataset_dir).or_raise()?;
        let mut pairs = dataset.pairs().or_raise()?;
        pairs.retain(|p| split.as_ref().is_none_or(|s| &p.split == s));
        Ok(unicac_dataset::info::pair_checks(
            &dataset.lenses().or_raise()?,
            &pairs,
        ))
    })?;
    crate::json::serialize(py, &checks)
}

/// Why a lens's pairs are dominated by something other than blur, from their mean registration shift
/// (px) and mean blur share (`unicac_dataset::info::pair_check_flag`); None when they are not.
#[pyfunction]
#[pyo3(signature = (mean_registration_px, mean_blur_share))]
pub fn pair_check_flag(mean_registration_px: Option<f64>, mean_blur_share: Option<f64>) -> Option<String> {
    unicac_dataset::info::pair_check_flag(mean_registration_px, mean_blur_share)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_path, m)?)?;
    m.add_function(wrap_pyfunction!(psf_table_meta, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_pair_checks, m)?)?;
    m.add_function(wrap_pyfunction!(pair_check_flag, m)?)?;
    m.add_function(wrap_pyfunction!(fov_map, m)?)?;
    m.add_function(wrap_pyfunction!(psf_features, m)?)?;
    m.add_function(wrap_pyfunction!(psf_basis, m)?)?;
    m.add_function(wrap_pyfunction!(psf_field_codes, m)?)?;
    m.add_function(wrap_pyfunction!(psf_code_map, m)?)?;
    m.add_function(wrap_pyfunction!(wiener_restore, m)?)?;
    m.add_function(wrap_pyfunction!(table_edge_pairs, m)?)?;
    Ok(())
}
