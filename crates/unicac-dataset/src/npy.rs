//! float32 NPY files (numpy's own format, read with `np.load(path, allow_pickle=False)`) through the
//! `npyz` crate: C order, little-endian `<f4`, shape in the header. Written atomically.

use crate::error::{DatasetError, Result};
use npyz::WriterBuilder;
use std::path::Path;

/// The bytes of a C-order little-endian float32 NPY file of `shape` holding `data`.
pub fn encode_f32(shape: &[usize], data: &[f32]) -> Result<Vec<u8>> {
    let count: usize = shape.iter().product();
    if count != data.len() {
        return Err(DatasetError::Invalid(format!(
            "NPY shape {shape:?} holds {count} values, got {}",
            data.len()
        )));
    }
    let shape_u64: Vec<u64> = shape.iter().map(|&s| s as u64).collect();
    let mut bytes = Vec::with_capacity(128 + 4 * data.len());
    let mut writer = npyz::WriteOptions::<f32>::new()
        .dtype(npyz::DType::Plain("<f4".parse().expect("valid type string")))
        .shape(&shape_u64)
        .writer(&mut bytes)
        .begin_nd()
        .map_err(|e| DatasetError::Invalid(format!("NPY header: {e}")))?;
    writer
        .extend(data.iter().copied())
        .map_err(|e| DatasetError::Invalid(format!("NPY data: {e}")))?;
    writer
        .finish()
        .map_err(|e| DatasetError::Invalid(format!("NPY data: {e}")))?;
    Ok(bytes)
}

/// Writes `data` as a float32 NPY file of `shape` (atomically).
pub fn write_f32(path: &Path, shape: &[usize], data: &[f32]) -> Result<()> {
    crate::manifest::write_atomically(path, &encode_f32(shape, data)?)
}

/// Reads a float32 NPY file: its shape and C-order data. Anything else (another dtype, Fortran
/// order, a truncated file) is an error naming the file.
pub fn read_f32(path: &Path) -> Result<(Vec<usize>, Vec<f32>)> {
    let bytes = std::fs::read(path).map_err(|e| DatasetError::io(path, e))?;
    decode_f32(&bytes).map_err(|message| DatasetError::format(path, message))
}

fn decode_f32(bytes: &[u8]) -> std::result::Result<(Vec<usize>, Vec<f32>), String> {
    let file = npyz::NpyFile::new(bytes).map_err(|e| format!("not a readable NPY file: {e}"))?;
    if file.order() != npyz::Order::C {
        return Err("Fortran-order NPY arrays are not supported; save with C order".into());
    }
    let dtype = file.dtype();
    let wanted = npyz::DType::Plain("<f4".parse().expect("valid type string"));
    if dtype != wanted {
        return Err(format!("expected float32 ('<f4') data, found {}", dtype.descr()));
    }
    let shape: Vec<usize> = file.shape().iter().map(|&s| s as usize).collect();
    let data = file.into_vec::<f32>().map_err(|e| format!("NPY data: {e}"))?;
    if data.len() != shape.iter().product::<usize>() {
        return Err(format!("shape {shape:?} does not match {} values", data.len()));
    }
    Ok((shape, data))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_has_numpys_header() {
        let data: Vec<f32> = (0..24).map(|i| i as f32 * 0.5 - 3.0).collect();
        let bytes = encode_f32(&[2, 3, 4], &data).unwrap();
        assert_eq!(&bytes[..6], b"\x93NUMPY");
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        // NPY pads the header so the data starts on a 64-byte boundary.
        assert_eq!((10 + header_len) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
        assert!(header.contains("'descr': '<f4'"), "{header}");
        assert!(header.contains("'fortran_order': False"), "{header}");
        assert!(header.contains("'shape': (2, 3, 4"), "{header}");
        let (shape, back) = decode_f32(&bytes).unwrap();
        assert_eq!((shape, back), (vec![2, 3, 4], data));
        assert!(decode_f32(&bytes[..bytes.len() - 1]).is_err());
        assert!(encode_f32(&[5], &[1.0]).is_err());
    }
}
