//! `unicac metrics REF DIST`: the bench's full-reference metrics on one pair of images or on two folders
//! (matched by file name), for images restored elsewhere.
//!
//! Images are read as pyiqa reads them: integer files (PNG, TIFF, BMP) divided by their maximum code,
//! grey replicated to RGB; float files (OpenEXR, float TIFF) hold linear light and are sRGB-encoded first,
//! then clipped to [0, 1].

use std::path::{Path, PathBuf};

use serde::Serialize;
use unicac_image::io::{read_image, Encoding};
use unicac_image::Planar;

use crate::error::{BenchError, Result};
use unicac_learned_metrics::lpips::Lpips;

/// Largest number of pairs one call compares (a stated limit).
pub const MAX_PAIRS: usize = 100_000;
const IMAGE_EXTENSIONS: [&str; 7] = ["png", "tif", "tiff", "exr", "bmp", "PNG", "BMP"];

/// The scores of one pair (`unicac metrics --json` prints a list of these).
#[derive(Debug, Clone, Serialize)]
pub struct PairMetrics {
    pub name: String,
    pub reference: PathBuf,
    pub distorted: PathBuf,
    pub psnr_db: Option<f64>,
    pub ssim: Option<f64>,
    pub lpips: Option<f64>,
}

/// An image as pyiqa sees it: RGB in [0, 1], display-encoded.
pub fn read_display_rgb(path: &Path) -> Result<Planar> {
    let loaded = read_image(path)?;
    let mut rgb = loaded.rgb_planes(&loaded.image).ok_or_else(|| {
        BenchError::InvalidInput(format!("{}: expected a grey or RGB image", path.display()))
    })?;
    if loaded.encoding == Encoding::Linear {
        rgb = unicac_image::color::linear_to_srgb(&rgb);
    }
    rgb.data
        .iter_mut()
        .for_each(|v| *v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 });
    Ok(rgb)
}

fn is_image(path: &Path) -> bool {
    path.is_file()
        && path.extension().and_then(|e| e.to_str()).is_some_and(|e| {
            IMAGE_EXTENSIONS.contains(&e) || IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str())
        })
}

/// The (name, reference, distorted) pairs: the two files, or the files of the two folders with the same
/// name (every reference image must have its distorted twin).
pub fn image_pairs(reference: &Path, distorted: &Path) -> Result<Vec<(String, PathBuf, PathBuf)>> {
    match (reference.is_dir(), distorted.is_dir()) {
        (false, false) => {
            for p in [reference, distorted] {
                if !p.is_file() {
                    let what = if p.exists() {
                        "not a regular file or folder"
                    } else {
                        "no such file"
                    };
                    return Err(BenchError::InvalidInput(format!("{}: {what}", p.display())));
                }
            }
            let name = distorted
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            Ok(vec![(name, reference.to_path_buf(), distorted.to_path_buf())])
        }
        (true, true) => {
            let entries = std::fs::read_dir(reference).map_err(|e| BenchError::io(reference, e))?;
            let mut names: Vec<String> = Vec::new();
            for entry in entries {
                let entry = entry.map_err(|e| BenchError::io(reference, e))?;
                if is_image(&entry.path()) {
                    names.push(entry.file_name().to_string_lossy().into_owned());
                }
                if names.len() > MAX_PAIRS {
                    return Err(BenchError::InvalidInput(format!(
                        "{}: more than {MAX_PAIRS} images",
                        reference.display()
                    )));
                }
            }
            names.sort();
            if names.is_empty() {
                return Err(BenchError::InvalidInput(format!(
                    "{}: no PNG, TIFF, EXR or BMP images",
                    reference.display()
                )));
            }
            names
                .into_iter()
                .map(|name| {
                    let d = distorted.join(&name);
                    if !d.is_file() {
                        return Err(BenchError::InvalidInput(format!(
                            "{}: no image named {name} to compare with {}",
                            distorted.display(),
                            reference.join(&name).display()
                        )));
                    }
                    Ok((name.clone(), reference.join(&name), d))
                })
                .collect()
        }
        _ => Err(BenchError::InvalidInput(format!(
            "{} and {}: give two files or two folders",
            reference.display(),
            distorted.display()
        ))),
    }
}

/// Scores every pair with the metrics asked for (`psnr`, `ssim`, `lpips`).
pub fn compare(
    pairs: &[(String, PathBuf, PathBuf)],
    metrics: &[String],
    mut lpips: Option<&mut Lpips>,
) -> Result<Vec<PairMetrics>> {
    let has = |m: &str| metrics.iter().any(|x| x == m);
    pairs
        .iter()
        .map(|(name, r, d)| {
            let (reference, distorted) = (read_display_rgb(r)?, read_display_rgb(d)?);
            let label = format!("{} vs {}", d.display(), r.display());
            let metric = |e| BenchError::metrics(label.clone(), e);
            Ok(PairMetrics {
                name: name.clone(),
                reference: r.clone(),
                distorted: d.clone(),
                psnr_db: if has("psnr") {
                    Some(unicac_metrics::psnr_pyiqa(&distorted, &reference).map_err(metric)?)
                } else {
                    None
                },
                ssim: if has("ssim") {
                    Some(unicac_metrics::ssim_pyiqa(&distorted, &reference).map_err(metric)?)
                } else {
                    None
                },
                lpips: match lpips.as_deref_mut() {
                    Some(l) if has("lpips") => Some(l.distance(&distorted, &reference)?),
                    _ => None,
                },
            })
        })
        .collect()
}
