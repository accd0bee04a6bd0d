//! Per-lens radial PSF tables (`psf/LENS_ID/kernels.npy` + `table.json`, docs/dataset.md) and the
//! PSF-feature map computed from them (docs/models.md).
//!
//! The feature map needs, per pixel, the moments of the kernel interpolated at the pixel's field
//! radius and rotated to its azimuth. Raw moments are linear in the kernel, so interpolating each
//! field's raw moments equals taking the moments of the interpolated kernel (each kernel sums to 1);
//! the central moments follow from them, and a rotation R acts on them as R d and R S R^T. No kernel
//! is resampled, so the features are exact for the interpolated kernel and cost O(1) per pixel.

use crate::error::{DatasetError, Result};
use crate::{ChannelMap, FrameCrop};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const KERNELS_NPY: &str = "kernels.npy";
pub const TABLE_JSON: &str = "table.json";
pub const TABLE_FORMAT: &str = "unicac-psf-table";
/// Channels of the PSF-feature map: [dx, dy, sxx, sxy, syy] for R, G and B.
pub const PSF_FEATURES: usize = 15;

/// `table.json`: everything about the kernels except their samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PsfTableMeta {
    pub format: String,
    pub format_version: u32,
    pub lens_id: String,
    /// Normalised radii of the stored fields along frame +x (0 = centre, 1 = half-diagonal), ascending.
    pub field_radius_norm: Vec<f64>,
    /// Field angle of each stored field (deg).
    pub field_deg: Vec<f64>,
    /// Side of the square kernels (px, odd); the kernel centre is the chief ray's image point.
    pub kernel_px: usize,
    #[serde(rename = "pixel_pitch_um")]
    pub pixel_um: f64,
    /// The sensor frame the table was made for [W, H] (px).
    pub frame_px: [usize; 2],
    /// Relative illumination at each field (1 = the brightest field).
    pub relative_illumination: Vec<f64>,
    /// Real image height / paraxial image height at each field (1 = no distortion).
    pub distortion: Vec<f64>,
    pub wavelengths_um: Vec<f64>,
    /// Per channel (R, G, B), the weight of each wavelength (each row sums to 1).
    pub channel_weights: Vec<Vec<f64>>,
    /// Energy the kernel-size cap cut, per field and channel (0 = none).
    pub energy_cut: Vec<[f64; 3]>,
    pub unicac_version: String,
}

/// A PSF table: its metadata and kernels, float32 [F, 3, K, K] in C order.
#[derive(Debug, Clone, PartialEq)]
pub struct PsfTable {
    pub meta: PsfTableMeta,
    pub kernels: Vec<f32>,
}

impl PsfTable {
    pub fn fields(&self) -> usize {
        self.meta.field_radius_norm.len()
    }

    /// The kernel of `field` in `channel` (row-major, rows down the image).
    pub fn kernel(&self, field: usize, channel: usize) -> &[f32] {
        let k2 = self.meta.kernel_px * self.meta.kernel_px;
        let start = (field * 3 + channel) * k2;
        &self.kernels[start..start + k2]
    }

    /// Checks shapes, ordering and values (a table read from disk or about to be written).
    pub fn validate(&self) -> std::result::Result<(), String> {
        let m = &self.meta;
        let f = m.field_radius_norm.len();
        if f == 0 {
            return Err("the table has no fields".into());
        }
        if m.kernel_px == 0 || m.kernel_px.is_multiple_of(2) {
            return Err(format!("kernel_px {} must be odd and positive", m.kernel_px));
        }
        for (name, len) in [
            ("field_deg", m.field_deg.len()),
            ("relative_illumination", m.relative_illumination.len()),
            ("distortion", m.distortion.len()),
            ("energy_cut", m.energy_cut.len()),
        ] {
            if len != f {
                return Err(format!("{name} has {len} entries for {f} fields"));
            }
        }
        if m.field_radius_norm
            .windows(2)
            .any(|w| w[0].partial_cmp(&w[1]) != Some(std::cmp::Ordering::Less))
            || m.field_radius_norm.iter().any(|r| !r.is_finite() || *r < 0.0)
        {
            return Err("field_radius_norm must be finite, non-negative and strictly ascending".into());
        }
        if self.kernels.len() != f * 3 * m.kernel_px * m.kernel_px {
            return Err(format!(
                "kernels hold {} values, expected [{f}, 3, {k}, {k}]",
                self.kernels.len(),
                k = m.kernel_px
            ));
        }
        if self.kernels.iter().any(|v| !v.is_finite()) {
            return Err("kernels hold a non-finite value".into());
        }
        Ok(())
    }

    /// Writes `kernels.npy`, then `table.json` (the table is complete once `table.json` exists).
    pub fn write(&self, dir: &Path) -> Result<()> {
        self.validate()
            .map_err(|message| DatasetError::format(dir, message))?;
        let k = self.meta.kernel_px;
        crate::npy::write_f32(&dir.join(KERNELS_NPY), &[self.fields(), 3, k, k], &self.kernels)?;
        crate::manifest::write_json(&dir.join(TABLE_JSON), &self.meta)
    }

    /// Reads `table.json` of a table folder (the metadata without the kernels).
    pub fn read_meta(dir: &Path) -> Result<PsfTableMeta> {
        let json_path = dir.join(TABLE_JSON);
        let text = std::fs::read(&json_path).map_err(|e| DatasetError::io(&json_path, e))?;
        let meta: PsfTableMeta =
            serde_json::from_slice(&text).map_err(|e| DatasetError::format(&json_path, e.to_string()))?;
        if meta.format != TABLE_FORMAT {
            return Err(DatasetError::format(
                &json_path,
                format!("format is not {TABLE_FORMAT:?}"),
            ));
        }
        if meta.format_version > crate::FORMAT_VERSION {
            return Err(DatasetError::NewerFormat {
                path: json_path,
                found: meta.format_version,
                supported: crate::FORMAT_VERSION,
            });
        }
        Ok(meta)
    }

    /// Reads a table folder, checking the NPY shape against `table.json`.
    pub fn read(dir: &Path) -> Result<PsfTable> {
        let meta = PsfTable::read_meta(dir)?;
        let npy_path = dir.join(KERNELS_NPY);
        let (shape, kernels) = crate::npy::read_f32(&npy_path)?;
        let k = meta.kernel_px;
        let expected = [meta.field_radius_norm.len(), 3, k, k];
        if shape != expected {
            return Err(DatasetError::format(
                &npy_path,
                format!("shape {shape:?}, but table.json describes {expected:?}"),
            ));
        }
        let table = PsfTable { meta, kernels };
        table
            .validate()
            .map_err(|message| DatasetError::format(dir, message))?;
        Ok(table)
    }

    /// Raw moments [m_x, m_y, m_xx, m_xy, m_yy] (px, about the kernel centre, normalised by the sum)
    /// of every field and channel.
    fn raw_moments(&self) -> Vec<[[f64; 5]; 3]> {
        (0..self.fields())
            .map(|f| std::array::from_fn(|c| raw_moments(self.kernel(f, c), self.meta.kernel_px)))
            .collect()
    }

    /// The table's PSF features, ready to be evaluated anywhere on the frame (`PsfFeatures::at`).
    pub fn features(&self) -> PsfFeatures<'_> {
        PsfFeatures {
            moments: self.raw_moments(),
            radii: &self.meta.field_radius_norm,
        }
    }
}

/// The kernels' raw moments, computed once: each costs K^2 per field and channel, and a feature map
/// evaluates them at every pixel (computing them per pixel made a bench's edge patches take minutes).
pub struct PsfFeatures<'a> {
    moments: Vec<[[f64; 5]; 3]>,
    radii: &'a [f64],
}

impl PsfFeatures<'_> {
    /// The 15 features at a normalised frame position (x right, y down; docs/models.md).
    pub fn at(&self, x_norm: f64, y_norm: f64) -> [f32; PSF_FEATURES] {
        features_from(&self.moments, self.radii, x_norm, y_norm)
    }
}

/// Raw moments of one K x K kernel about its centre, divided by its sum (a zero kernel gives zeros).
pub fn raw_moments(kernel: &[f32], k: usize) -> [f64; 5] {
    let half = (k / 2) as f64;
    let mut m = [0.0f64; 6];
    for row in 0..k {
        let y = row as f64 - half;
        for column in 0..k {
            let x = column as f64 - half;
            let v = kernel[row * k + column] as f64;
            m[0] += v;
            m[1] += v * x;
            m[2] += v * y;
            m[3] += v * x * x;
            m[4] += v * x * y;
            m[5] += v * y * y;
        }
    }
    if m[0] == 0.0 {
        return [0.0; 5];
    }
    [m[1] / m[0], m[2] / m[0], m[3] / m[0], m[4] / m[0], m[5] / m[0]]
}

// `channel` indexes the two field tables and the output at once.
#[allow(clippy::needless_range_loop)]
fn features_from(moments: &[[[f64; 5]; 3]], radii: &[f64], x: f64, y: f64) -> [f32; PSF_FEATURES] {
    let (i, j, t) = bracket(radii, x.hypot(y));
    let phi = y.atan2(x);
    let (s, c) = phi.sin_cos();
    let mut out = [0.0f32; PSF_FEATURES];
    for channel in 0..3 {
        let m: [f64; 5] =
            std::array::from_fn(|n| moments[i][channel][n] * (1.0 - t) + moments[j][channel][n] * t);
        let (dx, dy) = (m[0], m[1]);
        let (sxx, sxy, syy) = (m[2] - dx * dx, m[3] - dx * dy, m[4] - dy * dy);
        // R = [[c, -s], [s, c]] takes the table's +x axis to the azimuth phi (y down).
        let (rx, ry) = (c * dx - s * dy, s * dx + c * dy);
        let rxx = c * c * sxx - 2.0 * c * s * sxy + s * s * syy;
        let rxy = c * s * (sxx - syy) + (c * c - s * s) * sxy;
        let ryy = s * s * sxx + 2.0 * c * s * sxy + c * c * syy;
        let base = 5 * channel;
        out[base] = rx as f32;
        out[base + 1] = ry as f32;
        out[base + 2] = signed_sqrt(rxx) as f32;
        out[base + 3] = signed_sqrt(rxy) as f32;
        out[base + 4] = signed_sqrt(ryy) as f32;
    }
    out
}

/// The stored fields `i`, `j` that bracket `radius` and the weight `t` of `j`: the kernel there is
/// `(1 - t) k_i + t k_j` (linear in radius, clamped outside the stored radii; `radii` ascending, non-empty).
pub fn bracket(radii: &[f64], radius: f64) -> (usize, usize, f64) {
    let last = radii.len() - 1;
    let (i, t) = if radius <= radii[0] || last == 0 {
        (0, 0.0)
    } else if radius >= radii[last] {
        (last - 1, 1.0)
    } else {
        let i = radii.partition_point(|&r| r <= radius) - 1;
        (i, (radius - radii[i]) / (radii[i + 1] - radii[i]))
    };
    (i, (i + 1).min(last), t)
}

fn signed_sqrt(v: f64) -> f64 {
    v.signum() * v.abs().sqrt()
}

/// The PSF-feature map `[15, h, w]` of a crop of the frame (docs/models.md): per pixel and channel
/// [dx, dy, sxx, sxy, syy] of the table's kernel at the pixel's radius, rotated to its azimuth.
pub fn psf_feature_map(table: &PsfTable, crop: FrameCrop) -> Result<ChannelMap> {
    crop.check()?;
    table.validate().map_err(|message| {
        DatasetError::Invalid(format!("PSF table of {}: {message}", table.meta.lens_id))
    })?;
    let features = table.features();
    let (w, h) = (crop.w, crop.h);
    let plane = w * h;
    let mut data = vec![0.0f32; PSF_FEATURES * plane];
    for row in 0..h {
        for column in 0..w {
            let [x, y] = crop.normalised(row, column);
            for (channel, value) in features.at(x, y).iter().enumerate() {
                data[channel * plane + row * w + column] = *value;
            }
        }
    }
    Ok(ChannelMap {
        channels: PSF_FEATURES,
        height: h,
        width: w,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const K: usize = 7;

    /// An asymmetric kernel: mass spread along +x with a tail towards +y (down), unit sum.
    fn kernel(spread: f32) -> Vec<f32> {
        let mut k = vec![0.0f32; K * K];
        let h = K / 2;
        k[h * K + h] = 1.0;
        k[h * K + h + 1] = spread;
        k[h * K + h + 2] = 0.5 * spread;
        k[(h + 1) * K + h + 1] = 0.25 * spread;
        let sum: f32 = k.iter().sum();
        k.iter_mut().for_each(|v| *v /= sum);
        k
    }

    /// Rotates a K x K kernel by +90 deg in the image frame (x right, y down): +x goes to +y.
    fn rotate_90(k: &[f32]) -> Vec<f32> {
        let mut out = vec![0.0f32; K * K];
        let h = (K / 2) as isize;
        for row in 0..K {
            for column in 0..K {
                let (x, y) = (column as isize - h, row as isize - h);
                // (x, y) -> (-y, x)
                let (nx, ny) = (-y, x);
                out[((ny + h) as usize) * K + (nx + h) as usize] = k[row * K + column];
            }
        }
        out
    }

    fn table(kernels_per_field: &[Vec<f32>], radii: &[f64]) -> PsfTable {
        let f = radii.len();
        PsfTable {
            meta: PsfTableMeta {
                format: TABLE_FORMAT.into(),
                format_version: 1,
                lens_id: "test".into(),
                field_radius_norm: radii.to_vec(),
                field_deg: radii.iter().map(|r| r * 20.0).collect(),
                kernel_px: K,
                pixel_um: 2.0,
                frame_px: [64, 48],
                relative_illumination: vec![1.0; f],
                distortion: vec![1.0; f],
                wavelengths_um: vec![0.55],
                channel_weights: vec![vec![1.0]; 3],
                energy_cut: vec![[0.0; 3]; f],
                unicac_version: "test".into(),
            },
            kernels: kernels_per_field
                .iter()
                .flat_map(|k| [k.clone(), k.clone(), k.clone()])
                .flatten()
                .collect(),
        }
    }

    fn direct_features(k: &[f32]) -> [f64; 5] {
        let [dx, dy, xx, xy, yy] = raw_moments(k, K);
        [
            dx,
            dy,
            signed_sqrt(xx - dx * dx),
            signed_sqrt(xy - dx * dy),
            signed_sqrt(yy - dy * dy),
        ]
    }

    #[test]
    fn at_azimuth_zero_the_features_are_the_stored_fields() {
        let t = table(&[kernel(0.2), kernel(0.6)], &[0.0, 1.0]);
        let at_edge = t.features().at(1.0, 0.0);
        let expected = direct_features(&kernel(0.6));
        for c in 0..3 {
            for n in 0..5 {
                assert!((at_edge[5 * c + n] as f64 - expected[n]).abs() < 1e-6, "{n}");
            }
        }
        // The centroid of kernel(0.6) is clearly off-centre along +x and a little along +y.
        assert!(expected[0] > 0.3 && expected[1] > 0.0 && expected[3] > 0.0);
    }

    #[test]
    fn a_kernel_rotated_by_90_degrees_gives_the_features_at_azimuth_90() {
        let k = kernel(0.6);
        let t = table(&[k.clone(), k.clone()], &[0.0, 1.0]);
        // Straight below the centre: phi = +90 deg in the image frame (y down).
        let below = t.features().at(0.0, 0.7);
        let expected = direct_features(&rotate_90(&k));
        for n in 0..5 {
            assert!(
                (below[n] as f64 - expected[n]).abs() < 1e-6,
                "feature {n}: {} vs {}",
                below[n],
                expected[n]
            );
        }
        // dx, dy swap into (-dy, dx); sxy changes sign, sxx and syy swap.
        let at_zero = direct_features(&k);
        assert!((below[0] as f64 + at_zero[1]).abs() < 1e-6 && (below[1] as f64 - at_zero[0]).abs() < 1e-6);
        assert!((below[3] as f64 + at_zero[3]).abs() < 1e-6);
        assert!((below[2] as f64 - at_zero[4]).abs() < 1e-6 && (below[4] as f64 - at_zero[2]).abs() < 1e-6);
    }

    #[test]
    fn fields_are_interpolated_linearly_in_radius() {
        let (a, b) = (kernel(0.1), kernel(0.9));
        let t = table(&[a.clone(), b.clone(), b.clone()], &[0.0, 0.5, 1.0]);
        // A quarter of the way from field 0 to field 1: the moments of 0.75 a + 0.25 b.
        let mixed: Vec<f32> = a.iter().zip(&b).map(|(x, y)| 0.75 * x + 0.25 * y).collect();
        let expected = direct_features(&mixed);
        let got = t.features().at(0.125, 0.0);
        for n in 0..5 {
            assert!((got[n] as f64 - expected[n]).abs() < 1e-6, "feature {n}");
        }
        // Beyond the last field the table is clamped; between fields 1 and 2 it is constant.
        assert_eq!(t.features().at(0.75, 0.0), t.features().at(1.3, 0.0));
    }

    #[test]
    fn the_map_matches_pointwise_features_and_round_trips_on_disk() {
        let t = table(&[kernel(0.2), kernel(0.5), kernel(0.8)], &[0.0, 0.5, 1.0]);
        let crop = FrameCrop {
            x0: 10,
            y0: 5,
            w: 20,
            h: 12,
            ..FrameCrop::full(64, 48)
        };
        let map = psf_feature_map(&t, crop).unwrap();
        assert_eq!((map.channels, map.height, map.width), (15, 12, 20));
        let [x, y] = crop.normalised(7, 3);
        let point = t.features().at(x, y);
        for (c, v) in point.iter().enumerate() {
            assert_eq!(map.at(c, 7, 3), *v);
        }
        let dir = std::env::temp_dir().join(format!("unicac-psf-table-{}", std::process::id()));
        t.write(&dir).unwrap();
        assert_eq!(PsfTable::read(&dir).unwrap(), t);
        // A table whose NPY disagrees with its JSON is refused, naming the file.
        crate::npy::write_f32(&dir.join(KERNELS_NPY), &[1, 3, K, K], &t.kernels[..3 * K * K]).unwrap();
        let error = PsfTable::read(&dir).unwrap_err().to_string();
        assert!(
            error.contains("kernels.npy") && error.contains("shape"),
            "{error}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
