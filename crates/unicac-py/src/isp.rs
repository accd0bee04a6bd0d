//! The sensor and ISP chain one step at a time (unicac_image::isp), on float32 numpy arrays.
//!
//! RGB images are H x W x 3, mosaics and read-outs H x W (one plane). `isp_draw`, `isp_unprocess`,
//! `isp_process` and `isp_target` are the composed pipeline of `unicac simulate`, split where the
//! optics go.

use crate::arrays::{any_f32, f32_array, planar_f32, planar_out};
use crate::errors::OrRaise;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use unicac_image::isp::{self, Demosaic, IspDraw, Pipeline, SensorNoise, WhiteBalanceGains};
use unicac_image::{color, Planar};

type Gains = (f32, f32, f32);

fn gains((red, green, blue): Gains) -> WhiteBalanceGains {
    WhiteBalanceGains { red, green, blue }
}

fn pipeline(isp: bool, noise: bool) -> Pipeline {
    Pipeline {
        no_isp: !isp,
        no_noise: !noise,
        ..Default::default()
    }
}

/// The draw of `seed`: a pure function of the seed and the switches, so every step can redo it.
fn draw(isp: bool, noise: bool, seed: u64) -> PyResult<IspDraw> {
    pipeline(isp, noise).draw(seed).or_raise()
}

/// Sensor parameters; None keeps DeepLens' default (10 bits, black level 64 DN, ISO 100, ...).
#[allow(clippy::too_many_arguments)]
fn sensor(
    bit_depth: Option<u8>,
    black_level_dn: Option<f32>,
    iso: Option<f32>,
    iso_base: Option<f32>,
    dn_per_electron_at_base_iso: Option<f32>,
    read_noise_dn_at_base_iso: Option<f32>,
) -> SensorNoise {
    let d = SensorNoise::default();
    SensorNoise {
        bit_depth: bit_depth.unwrap_or(d.bit_depth),
        black_level_dn: black_level_dn.unwrap_or(d.black_level_dn),
        iso: iso.unwrap_or(d.iso),
        iso_base: iso_base.unwrap_or(d.iso_base),
        dn_per_electron_at_base_iso: dn_per_electron_at_base_iso.unwrap_or(d.dn_per_electron_at_base_iso),
        read_noise_dn_at_base_iso: read_noise_dn_at_base_iso.unwrap_or(d.read_noise_dn_at_base_iso),
    }
}

/// The random ISP parameters of `seed` (as `unicac simulate` draws them): a dict with `gains` (R, G, B
/// white-balance gains) and `noise_seed` (None when `noise=False`).
#[pyfunction]
#[pyo3(signature = (seed, isp=true, noise=true))]
pub fn isp_draw<'py>(py: Python<'py>, seed: u64, isp: bool, noise: bool) -> PyResult<Bound<'py, PyDict>> {
    let d = draw(isp, noise, seed)?;
    let out = PyDict::new(py);
    out.set_item("gains", (d.gains.red, d.gains.green, d.gains.blue))?;
    out.set_item("noise_seed", d.noise_seed)?;
    Ok(out)
}

/// Camera raw of a linear ground truth (float32 H x W x 3): inverse white balance with the gains of
/// `seed`. Step 1 of the chain; the optics come next (`Simulator.optics`).
#[pyfunction]
#[pyo3(signature = (ground_truth, seed, isp=true, noise=true))]
pub fn isp_unprocess<'py>(
    py: Python<'py>,
    ground_truth: &Bound<'py, PyAny>,
    seed: u64,
    isp: bool,
    noise: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(ground_truth, "ground_truth", 3, &[3])?;
    let p = pipeline(isp, noise);
    let d = draw(isp, noise, seed)?;
    let out = crate::pool::detach(py, || p.unprocess(image, &d).or_raise())?;
    planar_out(py, &out, false)
}

/// Sensor and ISP on camera raw after the optics (float32 H x W x 3): mosaic, read-out with the noise
/// of `seed`, black level, white balance, demosaic, clip, sRGB encoding. float32 H x W x 3 out.
#[pyfunction]
#[pyo3(signature = (raw, seed, isp=true, noise=true))]
pub fn isp_process<'py>(
    py: Python<'py>,
    raw: &Bound<'py, PyAny>,
    seed: u64,
    isp: bool,
    noise: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(raw, "raw", 3, &[3])?;
    let p = pipeline(isp, noise);
    let d = draw(isp, noise, seed)?;
    let out = crate::pool::detach(py, || p.process(&image, &d).or_raise())?;
    planar_out(py, &out, false)
}

/// The training target of a linear ground truth: clipped to [0, 1] and sRGB-encoded like the output.
#[pyfunction]
pub fn isp_target<'py>(py: Python<'py>, ground_truth: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(ground_truth, "ground_truth", 3, &[3])?;
    let out = Pipeline::default().finish_reference(&image).or_raise()?;
    planar_out(py, &out, false)
}

/// Channel c times gain c (float32 H x W x 3).
#[pyfunction]
pub fn apply_white_balance<'py>(
    py: Python<'py>,
    rgb: &Bound<'py, PyAny>,
    gains_rgb: Gains,
) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(rgb, "rgb", 3, &[3])?;
    planar_out(
        py,
        &isp::apply_white_balance(&image, gains(gains_rgb)).or_raise()?,
        false,
    )
}

/// Channel c divided by gain c (float32 H x W x 3): "unprocessing".
#[pyfunction]
pub fn invert_white_balance<'py>(
    py: Python<'py>,
    rgb: &Bound<'py, PyAny>,
    gains_rgb: Gains,
) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(rgb, "rgb", 3, &[3])?;
    planar_out(
        py,
        &isp::invert_white_balance(&image, gains(gains_rgb)).or_raise()?,
        false,
    )
}

/// White balance on an RGGB mosaic (float32 H x W), photosite by photosite.
#[pyfunction]
pub fn apply_white_balance_mosaic<'py>(
    py: Python<'py>,
    mosaic: &Bound<'py, PyAny>,
    gains_rgb: Gains,
) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(mosaic, "mosaic", 2, &[])?;
    planar_out(
        py,
        &isp::apply_white_balance_mosaic(&image, gains(gains_rgb)).or_raise()?,
        true,
    )
}

/// Gains + N(0, std_dev^2) per channel, floored at 0.05, deterministic for `seed`.
#[pyfunction]
pub fn perturb_white_balance(gains_rgb: Gains, std_dev: f32, seed: u64) -> PyResult<Gains> {
    let g = isp::perturb_white_balance(gains(gains_rgb), std_dev, seed).or_raise()?;
    Ok((g.red, g.green, g.blue))
}

/// RGGB Bayer mosaic (float32 H x W) of an RGB image (float32 H x W x 3).
#[pyfunction]
pub fn mosaic_rggb<'py>(py: Python<'py>, rgb: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let image = planar_f32(rgb, "rgb", 3, &[3])?;
    planar_out(py, &isp::mosaic_rggb(&image).or_raise()?, true)
}

/// RGB (float32 H x W x 3) from an RGGB mosaic (float32 H x W); `method`: "malvar" (Malvar-He-Cutler,
/// the default) or "bilinear". Not clipped.
#[pyfunction]
#[pyo3(signature = (mosaic, method="malvar"))]
pub fn demosaic<'py>(
    py: Python<'py>,
    mosaic: &Bound<'py, PyAny>,
    method: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let method = match method {
        "malvar" => Demosaic::MalvarHeCutler,
        "bilinear" => Demosaic::Bilinear,
        other => {
            return Err(PyValueError::new_err(format!(
                "method: '{other}': expected \"malvar\" or \"bilinear\""
            )))
        }
    };
    let image = planar_f32(mosaic, "mosaic", 2, &[])?;
    let out = crate::pool::detach(py, || isp::demosaic(&image, method).or_raise())?;
    planar_out(py, &out, false)
}

/// Sensor read-out in DN (float32, same shape as `exposure`, H x W or H x W x 3): black level +
/// signal with Poisson shot and Gaussian read noise from `noise_seed` (None: noiseless), rounded and
/// clipped to the bit depth. Sensor parameters default to DeepLens' sensor.
#[pyfunction]
#[pyo3(signature = (exposure, noise_seed=None, bit_depth=None, black_level_dn=None, iso=None, iso_base=None, dn_per_electron_at_base_iso=None, read_noise_dn_at_base_iso=None))]
#[allow(clippy::too_many_arguments)]
pub fn read_out<'py>(
    py: Python<'py>,
    exposure: &Bound<'py, PyAny>,
    noise_seed: Option<u64>,
    bit_depth: Option<u8>,
    black_level_dn: Option<f32>,
    iso: Option<f32>,
    iso_base: Option<f32>,
    dn_per_electron_at_base_iso: Option<f32>,
    read_noise_dn_at_base_iso: Option<f32>,
) -> PyResult<Bound<'py, PyAny>> {
    let image = plane_or_rgb(exposure, "exposure")?;
    let s = sensor(
        bit_depth,
        black_level_dn,
        iso,
        iso_base,
        dn_per_electron_at_base_iso,
        read_noise_dn_at_base_iso,
    );
    let out = crate::pool::detach(py, || isp::read_out(&image, &s, noise_seed).or_raise())?;
    planar_out(py, &out, true)
}

/// Relative exposure from DN (float32 H x W or H x W x 3): (DN - black) / (white - black), not clipped.
#[pyfunction]
#[pyo3(signature = (dn, bit_depth=None, black_level_dn=None))]
pub fn subtract_black_level<'py>(
    py: Python<'py>,
    dn: &Bound<'py, PyAny>,
    bit_depth: Option<u8>,
    black_level_dn: Option<f32>,
) -> PyResult<Bound<'py, PyAny>> {
    let image = plane_or_rgb(dn, "dn")?;
    let s = sensor(bit_depth, black_level_dn, None, None, None, None);
    planar_out(py, &isp::subtract_black_level(&image, &s).or_raise()?, true)
}

/// sRGB encoding (IEC 61966-2-1) of linear samples: any float32 array, same shape out.
#[pyfunction]
pub fn linear_to_srgb<'py>(py: Python<'py>, linear: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let (mut data, shape) = any_f32(linear, "linear")?;
    color::apply_srgb(&mut data, color::Transfer::Encode);
    f32_array(py, data, &shape)
}

/// sRGB decoding to linear light: any float32 array, same shape out.
#[pyfunction]
pub fn srgb_to_linear<'py>(py: Python<'py>, encoded: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let (mut data, shape) = any_f32(encoded, "encoded")?;
    color::apply_srgb(&mut data, color::Transfer::Decode);
    f32_array(py, data, &shape)
}

/// Rounds every sample (any float32 array) to the nearest of the 2^bits levels in [0, 1].
#[pyfunction]
pub fn quantise<'py>(py: Python<'py>, image: &Bound<'py, PyAny>, bits: u8) -> PyResult<Bound<'py, PyAny>> {
    let (data, shape) = any_f32(image, "image")?;
    let n = data.len();
    let planar = Planar {
        width: n,
        height: 1,
        channels: 1,
        data,
    };
    let out = unicac_image::quantise::quantise(&planar, bits).or_raise()?;
    f32_array(py, out.data, &shape)
}

fn plane_or_rgb(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Planar> {
    match obj.getattr("ndim").and_then(|n| n.extract::<usize>()) {
        Ok(3) => planar_f32(obj, name, 3, &[3]),
        _ => planar_f32(obj, name, 2, &[]),
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(isp_draw, m)?)?;
    m.add_function(wrap_pyfunction!(isp_unprocess, m)?)?;
    m.add_function(wrap_pyfunction!(isp_process, m)?)?;
    m.add_function(wrap_pyfunction!(isp_target, m)?)?;
    m.add_function(wrap_pyfunction!(apply_white_balance, m)?)?;
    m.add_function(wrap_pyfunction!(invert_white_balance, m)?)?;
    m.add_function(wrap_pyfunction!(apply_white_balance_mosaic, m)?)?;
    m.add_function(wrap_pyfunction!(perturb_white_balance, m)?)?;
    m.add_function(wrap_pyfunction!(mosaic_rggb, m)?)?;
    m.add_function(wrap_pyfunction!(demosaic, m)?)?;
    m.add_function(wrap_pyfunction!(read_out, m)?)?;
    m.add_function(wrap_pyfunction!(subtract_black_level, m)?)?;
    m.add_function(wrap_pyfunction!(linear_to_srgb, m)?)?;
    m.add_function(wrap_pyfunction!(srgb_to_linear, m)?)?;
    m.add_function(wrap_pyfunction!(quantise, m)?)?;
    Ok(())
}
