//! numpy arrays in and out, checked before any value reaches Rust code that assumes a shape.
//!
//! Rules (documented in python/README.md):
//! - the dtype must match exactly (no silent conversion) and be in native byte order: else `TypeError`
//!   naming the argument;
//! - the number of dimensions and the fixed axes must match: else `ValueError` naming the argument;
//! - any strides are accepted (non-contiguous views are read element by element, which is a copy);
//!   misaligned buffers raise `ValueError` with the fix (`np.ascontiguousarray`).
//!
//! Images cross the boundary as H x W x C (numpy's natural layout); inside they are `Planar`.

use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{
    dtype, Element, IntoPyArray, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use unicac_image::quantise::{from_code, to_code};
use unicac_image::Planar;

/// Largest image this module makes or accepts (2^28 pixels, e.g. 16384 x 16384): beyond it an
/// allocation could fail, which aborts the process instead of raising.
pub const MAX_PIXELS: usize = 1 << 28;

/// `ValueError` for an image size that is zero or beyond `MAX_PIXELS`.
pub fn check_size(width_px: usize, height_px: usize) -> PyResult<()> {
    match width_px.checked_mul(height_px) {
        Some(n) if n > 0 && n <= MAX_PIXELS => Ok(()),
        _ => Err(PyValueError::new_err(format!(
            "width_px x height_px = {width_px} x {height_px}: must be positive and at most {MAX_PIXELS} pixels"
        ))),
    }
}

/// "float32 array of shape (2, 3)" for messages.
fn describe(array: &Bound<'_, PyUntypedArray>) -> String {
    let shape: Vec<String> = array.shape().iter().map(|s| s.to_string()).collect();
    let shape = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!("({})", shape.join(", ")),
    };
    let dtype = array
        .dtype()
        .str()
        .map(|s| s.to_string())
        .unwrap_or_else(|_| "?".into());
    let order = if array.dtype().is_native_byteorder() == Some(false) {
        " (non-native byte order)"
    } else {
        ""
    };
    format!("{dtype}{order} array of shape {shape}")
}

fn untyped<'a, 'py>(obj: &'a Bound<'py, PyAny>, name: &str) -> PyResult<&'a Bound<'py, PyUntypedArray>> {
    obj.cast::<PyUntypedArray>().map_err(|_| {
        let type_name = obj
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_else(|_| "?".into());
        PyTypeError::new_err(format!("{name}: expected a numpy array, got {type_name}"))
    })
}

/// The array as `T` elements with checked dtype and alignment; `expected` describes the wanted array.
fn typed<'a, 'py, T: Element>(
    obj: &'a Bound<'py, PyAny>,
    name: &str,
    expected: &str,
) -> PyResult<&'a Bound<'py, PyArrayDyn<T>>> {
    let array = untyped(obj, name)?;
    if !array.dtype().is_equiv_to(&dtype::<T>(obj.py())) {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected {expected}, got a {}",
            describe(array)
        )));
    }
    if !array.is_aligned() {
        return Err(PyValueError::new_err(format!(
            "{name}: the array's memory is not aligned for its dtype; pass np.ascontiguousarray({name})"
        )));
    }
    Ok(obj.cast::<PyArrayDyn<T>>()?)
}

/// Copies the elements in C order (any strides).
fn elements<T: Element + Copy>(array: &Bound<'_, PyArrayDyn<T>>) -> Vec<T> {
    let readonly = array.readonly();
    let view = readonly.as_array();
    match view.as_slice() {
        Some(slice) => slice.to_vec(),
        None => view.iter().copied().collect(),
    }
}

/// An (N, C) float64 array as rows.
pub fn rows_f64<const C: usize>(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<[f64; C]>> {
    let expected = format!("a float64 array of shape (N, {C})");
    let array = typed::<f64>(obj, name, &expected)?;
    let shape = array.shape().to_vec();
    if shape.len() != 2 || shape[1] != C {
        return Err(PyValueError::new_err(format!(
            "{name}: expected {expected}, got a {}",
            describe(array.as_untyped())
        )));
    }
    let flat = elements(array);
    Ok(flat
        .chunks_exact(C)
        .map(|row| std::array::from_fn(|k| row[k]))
        .collect())
}

/// How an image's samples are stored in numpy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleKind {
    /// sRGB-encoded codes 0..=255.
    U8,
    /// sRGB-encoded codes 0..=65535.
    U16,
    /// Linear light (float32).
    F32,
}

impl SampleKind {
    fn max_code(self) -> u32 {
        match self {
            SampleKind::U8 => 255,
            SampleKind::U16 => 65535,
            SampleKind::F32 => 1,
        }
    }
}

const IMAGE_TYPES: &str = "an H x W x 3 array of uint8 or uint16 (sRGB) or float32 (linear)";

/// An H x W x 3 image of uint8/uint16 (sRGB codes) or float32 (linear) as linear-light planes.
pub fn image_linear(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Planar, SampleKind)> {
    let (mut planar, kind) = image_samples(obj, name)?;
    if kind != SampleKind::F32 {
        unicac_image::color::apply_srgb(&mut planar.data, unicac_image::color::Transfer::Decode);
    }
    Ok((planar, kind))
}

/// An H x W x 3 image of uint8/uint16 (codes, scaled to [0, 1], still sRGB-encoded) or float32 (as is).
pub fn image_samples(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Planar, SampleKind)> {
    let array = untyped(obj, name)?;
    let shape = array.shape().to_vec();
    if shape.len() != 3 || shape[2] != 3 || shape[0] == 0 || shape[1] == 0 {
        return Err(PyValueError::new_err(format!(
            "{name}: expected {IMAGE_TYPES}, got a {}",
            describe(array)
        )));
    }
    let (h, w) = (shape[0], shape[1]);
    let py = obj.py();
    let dt = array.dtype();
    let (samples, kind): (Vec<f32>, SampleKind) = if dt.is_equiv_to(&dtype::<u8>(py)) {
        let v = elements(typed::<u8>(obj, name, IMAGE_TYPES)?);
        (
            v.into_iter().map(|c| from_code(c.into(), 255)).collect(),
            SampleKind::U8,
        )
    } else if dt.is_equiv_to(&dtype::<u16>(py)) {
        let v = elements(typed::<u16>(obj, name, IMAGE_TYPES)?);
        (
            v.into_iter().map(|c| from_code(c.into(), 65535)).collect(),
            SampleKind::U16,
        )
    } else if dt.is_equiv_to(&dtype::<f32>(py)) {
        (elements(typed::<f32>(obj, name, IMAGE_TYPES)?), SampleKind::F32)
    } else {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected {IMAGE_TYPES}, got a {}",
            describe(array)
        )));
    };
    if kind == SampleKind::F32 && samples.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!("{name}: NaN or infinite sample")));
    }
    Ok((interleaved_to_planar(&samples, w, h, 3), kind))
}

/// A float32 array with `ndim` dimensions (2: H x W, one plane; 3: H x W x C with C in `channels`).
pub fn planar_f32(obj: &Bound<'_, PyAny>, name: &str, ndim: usize, channels: &[usize]) -> PyResult<Planar> {
    let expected = match ndim {
        2 => "a float32 array of shape (H, W)".to_string(),
        _ => format!("a float32 array of shape (H, W, C) with C in {channels:?}"),
    };
    let array = typed::<f32>(obj, name, &expected)?;
    let shape = array.shape().to_vec();
    let ok =
        shape.len() == ndim && shape[0] > 0 && shape[1] > 0 && (ndim == 2 || channels.contains(&shape[2]));
    if !ok {
        return Err(PyValueError::new_err(format!(
            "{name}: expected {expected}, got a {}",
            describe(array.as_untyped())
        )));
    }
    let c = if ndim == 2 { 1 } else { shape[2] };
    Ok(interleaved_to_planar(&elements(array), shape[1], shape[0], c))
}

/// Any float32 array, its elements in C order and its shape.
pub fn any_f32(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<f32>, Vec<usize>)> {
    let array = typed::<f32>(obj, name, "a float32 array")?;
    Ok((elements(array), array.shape().to_vec()))
}

/// A float32 array of the given shape.
pub fn f32_array<'py>(py: Python<'py>, data: Vec<f32>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let array = ArrayD::from_shape_vec(IxDyn(shape), data)
        .map_err(|e| PyValueError::new_err(format!("internal shape error: {e}")))?;
    Ok(array.into_pyarray(py).into_any())
}

/// A float64 array of the given shape.
pub fn f64_array<'py>(py: Python<'py>, data: Vec<f64>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let array = ArrayD::from_shape_vec(IxDyn(shape), data)
        .map_err(|e| PyValueError::new_err(format!("internal shape error: {e}")))?;
    Ok(array.into_pyarray(py).into_any())
}

/// An int32 array of the given shape.
pub fn i32_array<'py>(py: Python<'py>, data: Vec<i32>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let array = ArrayD::from_shape_vec(IxDyn(shape), data)
        .map_err(|e| PyValueError::new_err(format!("internal shape error: {e}")))?;
    Ok(array.into_pyarray(py).into_any())
}

fn interleaved_to_planar(samples: &[f32], w: usize, h: usize, c: usize) -> Planar {
    let mut planar = Planar::new(w, h, c);
    let n = w * h;
    for (i, pixel) in samples.chunks_exact(c).enumerate() {
        for (k, v) in pixel.iter().enumerate() {
            planar.data[k * n + i] = *v;
        }
    }
    planar
}

/// H x W x C samples of a planar image (H x W when it has one plane and `squeeze`).
pub fn planar_to_interleaved(image: &Planar) -> Vec<f32> {
    let (n, c) = (image.pixels(), image.channels);
    let mut out = vec![0.0f32; n * c];
    for k in 0..c {
        for (i, v) in image.plane(k).iter().enumerate() {
            out[i * c + k] = *v;
        }
    }
    out
}

/// A planar image as an H x W x C float32 array (H x W when `squeeze` and it has one plane).
pub fn planar_out<'py>(py: Python<'py>, image: &Planar, squeeze: bool) -> PyResult<Bound<'py, PyAny>> {
    let data = planar_to_interleaved(image);
    if squeeze && image.channels == 1 {
        f32_array(py, data, &[image.height, image.width])
    } else {
        f32_array(py, data, &[image.height, image.width, image.channels])
    }
}

/// An sRGB-encoded unit-range image in the representation of `kind`: integer codes for uint8/uint16,
/// decoded to linear float32 for float32 (what `unicac simulate` writes for PNG/TIFF and EXR).
pub fn encoded_out<'py>(py: Python<'py>, encoded: &Planar, kind: SampleKind) -> PyResult<Bound<'py, PyAny>> {
    let (h, w) = (encoded.height, encoded.width);
    match kind {
        SampleKind::F32 => planar_out(py, &unicac_image::color::srgb_to_linear(encoded), false),
        SampleKind::U8 | SampleKind::U16 => {
            let max = kind.max_code();
            let codes: Vec<u32> = planar_to_interleaved(encoded)
                .into_iter()
                .map(|v| to_code(v, max).unwrap_or(0))
                .collect();
            if kind == SampleKind::U8 {
                let data: Vec<u8> = codes.into_iter().map(|c| c as u8).collect();
                let array = ArrayD::from_shape_vec(IxDyn(&[h, w, 3]), data)
                    .map_err(|e| PyValueError::new_err(format!("internal shape error: {e}")))?;
                Ok(array.into_pyarray(py).into_any())
            } else {
                let data: Vec<u16> = codes.into_iter().map(|c| c as u16).collect();
                let array = ArrayD::from_shape_vec(IxDyn(&[h, w, 3]), data)
                    .map_err(|e| PyValueError::new_err(format!("internal shape error: {e}")))?;
                Ok(array.into_pyarray(py).into_any())
            }
        }
    }
}
