//! NPZ archives of float32 arrays (numpy's `np.savez` layout: a ZIP of `NAME.npy` members, stored
//! uncompressed), readable by `np.load(path, allow_pickle=False)`. The NPY members are encoded and
//! decoded by `unicac_dataset::npy` (the one NPY implementation); the ZIP container by the `zip` crate.
//! Written deterministically (fixed member order and timestamps, so the same weights give the same
//! SHA-256) and atomically.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::Path;

use crate::error::{LearnedMetricError, Result};

/// A named float32 array.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedArray {
    pub name: String,
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

/// The NPZ bytes of `arrays`, in the given order.
pub fn encode(arrays: &[NamedArray]) -> Result<Vec<u8>> {
    let invalid = |e: String| LearnedMetricError::InvalidInput(format!("NPZ encoding: {e}"));
    let mut cursor = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut cursor);
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored)
            .last_modified_time(zip::DateTime::default())
            .large_file(false);
        for array in arrays {
            let npy = unicac_dataset::npy::encode_f32(&array.shape, &array.data)
                .map_err(|e| invalid(e.to_string()))?;
            zip.start_file(format!("{}.npy", array.name), options)
                .map_err(|e| invalid(e.to_string()))?;
            zip.write_all(&npy).map_err(|e| invalid(e.to_string()))?;
        }
        zip.finish().map_err(|e| invalid(e.to_string()))?;
    }
    Ok(cursor.into_inner())
}

/// Writes `bytes` to `path` through a temporary sibling and a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(folder).map_err(|e| LearnedMetricError::io(folder, e))?;
    unicac_io::write_atomically(path, bytes).map_err(|e| LearnedMetricError::io(path, e))
}

/// Reads every member of an NPZ file as float32 arrays, keyed by name (without `.npy`).
pub fn read(path: &Path) -> Result<BTreeMap<String, NamedArray>> {
    let bad = |why: String| LearnedMetricError::Weights {
        path: path.to_path_buf(),
        why,
    };
    let file = std::fs::File::open(path).map_err(|e| LearnedMetricError::io(path, e))?;
    let mut archive = zip::ZipArchive::new(file).map_err(|e| bad(format!("not an NPZ (ZIP) file: {e}")))?;
    let mut out = BTreeMap::new();
    for index in 0..archive.len() {
        let mut member = archive.by_index(index).map_err(|e| bad(e.to_string()))?;
        let Some(name) = member.name().strip_suffix(".npy").map(str::to_string) else {
            return Err(bad(format!("member `{}` is not an .npy file", member.name())));
        };
        let mut bytes = Vec::new();
        member
            .read_to_end(&mut bytes)
            .map_err(|e| LearnedMetricError::io(path, e))?;
        // The one NPY reader takes a path: the member goes through a temporary file.
        let temp =
            tempfile::NamedTempFile::new().map_err(|e| LearnedMetricError::io(std::env::temp_dir(), e))?;
        std::fs::write(temp.path(), &bytes).map_err(|e| LearnedMetricError::io(temp.path(), e))?;
        let (shape, data) = unicac_dataset::npy::read_f32(temp.path())
            .map_err(|why| bad(format!("member `{name}`: {why}")))?;
        out.insert(name.clone(), NamedArray { name, shape, data });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_is_deterministic() {
        let arrays = vec![
            NamedArray {
                name: "conv0.weight".into(),
                shape: vec![2, 1, 1, 1],
                data: vec![1.5, -2.0],
            },
            NamedArray {
                name: "lin0.weight".into(),
                shape: vec![1, 2, 1, 1],
                data: vec![0.25, 0.5],
            },
        ];
        let bytes = encode(&arrays).unwrap();
        assert_eq!(bytes, encode(&arrays).unwrap());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.npz");
        write_atomically(&path, &bytes).unwrap();
        let back = read(&path).unwrap();
        assert_eq!(back["conv0.weight"], arrays[0]);
        assert_eq!(back["lin0.weight"], arrays[1]);
    }
}
