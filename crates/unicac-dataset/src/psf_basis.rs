//! The dense PSF code (docs/models.md, model input `psf_code`): a PCA basis of a dataset's PSF kernels,
//! fitted once per dataset on its training lenses' PSF tables and stored with them (`DIR/psf/basis/`),
//! and the per-pixel code map computed from it.
//!
//! Why a basis of the kernels and not their moments: two PSFs with the same centroid and covariance can
//! have very different MTFs (coma tails, halos, defocus rings, colour fringes); the leading principal
//! components of the real kernels describe those shapes in a few numbers (the SRMD / IKC kernel code).
//!
//! Fit, per colour channel: every field of every training lens's table, zero-padded to the dataset's
//! largest kernel (K x K), mirrored about its radius and averaged with the mirror image (below), minus
//! the mean kernel, forms the columns of X (K^2 x n). The components are the leading eigenvectors v of
//! the Gram matrix X^T X (n x n), mapped back by X v / sqrt(lambda); as many as explain the stated share
//! of the variance about the mean (at most [`CODE_COMPONENTS`]). At most [`MAX_FIT_KERNELS`] kernels
//! (and [`FIT_BYTES`] of matrix) enter a fit: beyond that an evenly spaced subset. The linear algebra is
//! nalgebra (`SymmetricEigen`, matrix products through matrixmultiply): pure Rust, so no system LAPACK
//! to install, and already in the workspace for the bench's FID.
//!
//! Code of a kernel: per colour, its first `components[c]` coefficients `<k - mean, b_i> / std_i` (std_i:
//! the coefficient's standard deviation over the fit kernels, so each has unit variance), zeros up to
//! [`CODE_COMPONENTS`]; the map adds cos and sin of the pixel's azimuth (the kernel there is the radial
//! kernel rotated by it, docs/dataset.md). The coefficients are linear in the kernel, so the code of the
//! kernel interpolated at a radius (linear between stored fields) is the same interpolation of the
//! fields' codes: exact, and O(1) per pixel.
//!
//! Symmetrising: a rotationally symmetric lens forms, on the +x radius, PSFs that are mirror-symmetric
//! about that radius (y -> -y); the stored kernels are so up to ray-sampling noise. Averaging each
//! kernel with its mirror image removes that noise, and makes the coefficients the same for a kernel and
//! its mirror image: a flipped or transposed crop (a crop of the mirrored lens) keeps its coefficients,
//! and only the azimuth channels change, by the FoV map's rules.

use crate::error::{DatasetError, Result};
use crate::psf_table::{bracket, PsfTable};
use crate::{ChannelMap, FrameCrop};
use nalgebra::{DMatrix, SymmetricEigen};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Where a dataset stores its basis, relative to the dataset folder.
pub const BASIS_RELATIVE: &str = "psf/basis";
pub const BASIS_JSON: &str = "basis.json";
pub const COMPONENTS_NPY: &str = "components.npy";
pub const MEAN_NPY: &str = "mean.npy";
pub const BASIS_FORMAT: &str = "unicac-psf-basis";
pub const BASIS_FORMAT_VERSION: u32 = 1;
/// Coefficients per colour channel in the code (the contract's fixed size; unused ones are 0).
pub const CODE_COMPONENTS: usize = 16;
/// Channels of the `psf_code` map: the coefficients of R, G, B, then cos and sin of the azimuth.
pub const PSF_CODE_CHANNELS: usize = 3 * CODE_COMPONENTS + 2;
/// Share of the fit kernels' variance (about their mean) the components in use explain, per colour.
pub const DEFAULT_ENERGY_SHARE: f64 = 0.95;
/// Most kernels per colour a fit uses (the Gram matrix is n x n).
pub const MAX_FIT_KERNELS: usize = 2048;
/// Most bytes of the kernel matrix X (float64) a fit holds; wider kernels mean fewer of them.
pub const FIT_BYTES: usize = 256 << 20;
/// Largest basis kernel side (px).
pub const MAX_BASIS_KERNEL_PX: usize = 511;
/// Eigenvalues below this share of the largest are noise, never components.
const EIGEN_FLOOR: f64 = 1e-12;

/// `basis.json`: everything about the basis except its arrays.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PsfBasisMeta {
    pub format: String,
    pub format_version: u32,
    /// Side of the basis kernels (px, odd): the dataset's largest PSF kernel.
    pub kernel_px: usize,
    /// Components in use per colour (R, G, B), each at most [`CODE_COMPONENTS`].
    pub components: [usize; 3],
    pub energy_share_target: f64,
    /// Share of the fit kernels' variance about the mean that the components in use explain.
    pub explained: [f64; 3],
    /// The same share for the kernels of the lenses the fit did not see (validation and test lenses).
    pub explained_held_out: Option<[f64; 3]>,
    /// Standard deviation of each coefficient over the fit kernels (per colour, `components[c]` values).
    pub coefficient_std: [Vec<f64>; 3],
    pub fit_lenses: usize,
    pub fit_kernels: usize,
    /// SHA-256 of the numbers that define the code ([`PsfBasis::content_sha256`]); an ONNX model using
    /// `psf_code` records it (`psf_basis_sha256`), and a reader refuses a dataset with another basis.
    pub sha256: String,
    pub unicac_version: String,
}

/// A fitted basis: metadata, the mean kernel [3, K, K] and the components [3, CODE_COMPONENTS, K, K]
/// (rows beyond `components[c]` are zero), float32 in C order.
#[derive(Debug, Clone, PartialEq)]
pub struct PsfBasis {
    pub meta: PsfBasisMeta,
    pub mean: Vec<f32>,
    pub components: Vec<f32>,
}

/// A PSF table offered to a fit: its folder and whether the fit may use it (training lenses) or only
/// report how well the basis describes it (`held_out`).
#[derive(Debug, Clone)]
pub struct FitTable {
    pub dir: PathBuf,
    pub held_out: bool,
}

/// Kernel `k` (k x k) centred in a `size` x `size` frame (zero-padded or centre-cropped), averaged with
/// its mirror image about the horizontal axis (the radius), as float64.
fn prepared(kernel: &[f32], k: usize, size: usize) -> Vec<f64> {
    let mut out = vec![0.0f64; size * size];
    let (ck, cs) = ((k / 2) as isize, (size / 2) as isize);
    for row in 0..k {
        let y = row as isize - ck + cs;
        if y < 0 || y >= size as isize {
            continue;
        }
        for column in 0..k {
            let x = column as isize - ck + cs;
            if x < 0 || x >= size as isize {
                continue;
            }
            out[y as usize * size + x as usize] = kernel[row * k + column] as f64;
        }
    }
    let mut mirrored = out.clone();
    for row in 0..size {
        let other = size - 1 - row;
        mirrored[row * size..(row + 1) * size].copy_from_slice(&out[other * size..(other + 1) * size]);
    }
    out.iter().zip(&mirrored).map(|(a, b)| 0.5 * (a + b)).collect()
}

/// Indices of at most `limit` of `count` items, evenly spaced and in order.
fn evenly_spaced(count: usize, limit: usize) -> Vec<usize> {
    if count <= limit {
        return (0..count).collect();
    }
    (0..limit).map(|i| i * count / limit).collect()
}

fn check_share(energy_share: f64) -> Result<()> {
    if !(energy_share > 0.0 && energy_share <= 1.0) {
        return Err(DatasetError::Invalid(format!(
            "PSF basis energy share {energy_share}: must be in (0, 1]"
        )));
    }
    Ok(())
}

/// One colour's fit: the mean kernel, the unit-norm components in use, their eigenvalues, and the
/// explained share.
struct ChannelFit {
    mean: Vec<f64>,
    components: Vec<Vec<f64>>,
    eigenvalues: Vec<f64>,
    explained: f64,
}

fn fit_channel(columns: DMatrix<f64>, energy_share: f64) -> ChannelFit {
    let (d, n) = columns.shape();
    let mut x = columns;
    let mean: Vec<f64> = (0..d).map(|i| x.row(i).sum() / n as f64).collect();
    for mut column in x.column_iter_mut() {
        for (v, m) in column.iter_mut().zip(&mean) {
            *v -= m;
        }
    }
    // A general product (matrixmultiply's packed kernels) on an explicit transpose: several times
    // faster than `tr_mul`'s one dot product per entry.
    let gram = x.transpose() * &x;
    let total = gram.trace();
    let eigen = SymmetricEigen::new(gram);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        eigen.eigenvalues[b]
            .total_cmp(&eigen.eigenvalues[a])
            .then(a.cmp(&b))
    });
    let largest = eigen.eigenvalues[order[0]].max(0.0);
    let mut components = Vec::new();
    let mut eigenvalues = Vec::new();
    let mut explained = if total > 0.0 { 0.0 } else { 1.0 };
    for &i in &order {
        let lambda = eigen.eigenvalues[i];
        if explained >= energy_share
            || components.len() == CODE_COMPONENTS
            || lambda <= EIGEN_FLOOR * largest
            || lambda <= 0.0
        {
            break;
        }
        let mut b: Vec<f64> = (&x * eigen.eigenvectors.column(i)).iter().copied().collect();
        let norm = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        // The sign of an eigenvector is arbitrary: fix it so that its largest entry is positive.
        let peak = b
            .iter()
            .copied()
            .fold(0.0f64, |p, v| if v.abs() > p.abs() { v } else { p });
        let sign = if peak < 0.0 { -1.0 } else { 1.0 };
        b.iter_mut().for_each(|v| *v *= sign / norm);
        components.push(b);
        eigenvalues.push(lambda);
        explained = eigenvalues.iter().sum::<f64>() / total;
    }
    ChannelFit {
        mean,
        components,
        eigenvalues,
        explained: explained.min(1.0),
    }
}

impl PsfBasis {
    /// Fits the basis on the tables that are not `held_out` (their every field, each colour apart) and
    /// measures it on the held-out ones. Errors name the table folder at fault.
    pub fn fit(tables: &[FitTable], energy_share: f64, unicac_version: &str) -> Result<PsfBasis> {
        check_share(energy_share)?;
        let metas = tables
            .iter()
            .map(|t| PsfTable::read_meta(&t.dir))
            .collect::<Result<Vec<_>>>()?;
        let size = metas
            .iter()
            .map(|m| m.kernel_px)
            .max()
            .ok_or_else(|| DatasetError::Invalid("PSF basis: no PSF tables to fit".into()))?;
        if size > MAX_BASIS_KERNEL_PX {
            return Err(DatasetError::Invalid(format!(
                "PSF basis: the largest kernel is {size} px, above the limit of {MAX_BASIS_KERNEL_PX} px"
            )));
        }
        // (table, field) of every training kernel, in table order.
        let all: Vec<(usize, usize)> = tables
            .iter()
            .enumerate()
            .filter(|(_, t)| !t.held_out)
            .flat_map(|(i, _)| (0..metas[i].field_radius_norm.len()).map(move |f| (i, f)))
            .collect();
        if all.is_empty() {
            return Err(DatasetError::Invalid(
                "PSF basis: no training lens has a PSF table to fit the basis on".into(),
            ));
        }
        let d = size * size;
        let limit = MAX_FIT_KERNELS.min((FIT_BYTES / (8 * d)).max(1));
        let chosen: Vec<(usize, usize)> = evenly_spaced(all.len(), limit)
            .into_iter()
            .map(|i| all[i])
            .collect();
        let fit_lenses = {
            let mut ids: Vec<usize> = chosen.iter().map(|c| c.0).collect();
            ids.dedup();
            ids.len()
        };
        let mut fits = Vec::with_capacity(3);
        for channel in 0..3 {
            let mut x = DMatrix::<f64>::zeros(d, chosen.len());
            let mut column = 0;
            let mut at = 0;
            while at < chosen.len() {
                let table_index = chosen[at].0;
                let table = PsfTable::read(&tables[table_index].dir)?;
                while at < chosen.len() && chosen[at].0 == table_index {
                    let kernel = prepared(table.kernel(chosen[at].1, channel), table.meta.kernel_px, size);
                    x.column_mut(column).copy_from_slice(&kernel);
                    column += 1;
                    at += 1;
                }
            }
            fits.push(fit_channel(x, energy_share));
        }
        let explained_held_out = held_out_share(tables, &fits, size)?;
        let n = chosen.len() as f64;
        let mut mean = Vec::with_capacity(3 * d);
        let mut components = vec![0.0f32; 3 * CODE_COMPONENTS * d];
        for (channel, fit) in fits.iter().enumerate() {
            mean.extend(fit.mean.iter().map(|&v| v as f32));
            for (i, b) in fit.components.iter().enumerate() {
                let start = (channel * CODE_COMPONENTS + i) * d;
                components[start..start + d]
                    .iter_mut()
                    .zip(b)
                    .for_each(|(o, &v)| *o = v as f32);
            }
        }
        let mut basis = PsfBasis {
            meta: PsfBasisMeta {
                format: BASIS_FORMAT.into(),
                format_version: BASIS_FORMAT_VERSION,
                kernel_px: size,
                components: std::array::from_fn(|c| fits[c].components.len()),
                energy_share_target: energy_share,
                explained: std::array::from_fn(|c| fits[c].explained),
                explained_held_out,
                coefficient_std: std::array::from_fn(|c| {
                    fits[c].eigenvalues.iter().map(|l| (l / n).sqrt()).collect()
                }),
                fit_lenses,
                fit_kernels: chosen.len(),
                sha256: String::new(),
                unicac_version: unicac_version.into(),
            },
            mean,
            components,
        };
        basis.meta.sha256 = basis.content_sha256();
        Ok(basis)
    }

    /// SHA-256 of what defines the code: the kernel size, the components in use, the coefficient
    /// scales, the mean and the components (little-endian bytes).
    pub fn content_sha256(&self) -> String {
        let m = &self.meta;
        let mut header = Vec::new();
        header.extend((m.kernel_px as u64).to_le_bytes());
        for c in m.components {
            header.extend((c as u64).to_le_bytes());
        }
        for stds in &m.coefficient_std {
            for s in stds {
                header.extend(s.to_le_bytes());
            }
        }
        let floats = |values: &[f32]| values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>();
        crate::seeds::parts_sha256_hex(&[&header, &floats(&self.mean), &floats(&self.components)])
    }

    /// Checks shapes and values (a basis read from disk or about to be written).
    pub fn validate(&self) -> std::result::Result<(), String> {
        let m = &self.meta;
        if m.kernel_px == 0 || m.kernel_px.is_multiple_of(2) || m.kernel_px > MAX_BASIS_KERNEL_PX {
            return Err(format!(
                "kernel_px {} must be odd, positive and at most {MAX_BASIS_KERNEL_PX}",
                m.kernel_px
            ));
        }
        let d = m.kernel_px * m.kernel_px;
        if self.mean.len() != 3 * d || self.components.len() != 3 * CODE_COMPONENTS * d {
            return Err("mean or components do not match kernel_px".into());
        }
        for c in 0..3 {
            if m.components[c] > CODE_COMPONENTS || m.coefficient_std[c].len() != m.components[c] {
                return Err(format!(
                    "channel {c}: {} components with {} coefficient scales (at most {CODE_COMPONENTS})",
                    m.components[c],
                    m.coefficient_std[c].len()
                ));
            }
            if m.coefficient_std[c].iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                return Err(format!("channel {c}: a coefficient scale is not positive"));
            }
        }
        if self.mean.iter().chain(&self.components).any(|v| !v.is_finite()) {
            return Err("the basis holds a non-finite value".into());
        }
        Ok(())
    }

    /// Writes the arrays, then `basis.json` (the basis is complete once `basis.json` exists).
    pub fn write(&self, dir: &Path) -> Result<()> {
        self.validate()
            .map_err(|message| DatasetError::format(dir, message))?;
        let k = self.meta.kernel_px;
        crate::npy::write_f32(&dir.join(MEAN_NPY), &[3, k, k], &self.mean)?;
        crate::npy::write_f32(
            &dir.join(COMPONENTS_NPY),
            &[3, CODE_COMPONENTS, k, k],
            &self.components,
        )?;
        crate::manifest::write_json(&dir.join(BASIS_JSON), &self.meta)
    }

    /// Reads a basis folder, checking shapes and that the arrays hash to the recorded `sha256`.
    pub fn read(dir: &Path) -> Result<PsfBasis> {
        let json_path = dir.join(BASIS_JSON);
        let text = std::fs::read(&json_path).map_err(|e| DatasetError::io(&json_path, e))?;
        let meta: PsfBasisMeta =
            serde_json::from_slice(&text).map_err(|e| DatasetError::format(&json_path, e.to_string()))?;
        if meta.format != BASIS_FORMAT {
            return Err(DatasetError::format(
                &json_path,
                format!("format is not {BASIS_FORMAT:?}"),
            ));
        }
        if meta.format_version > BASIS_FORMAT_VERSION {
            return Err(DatasetError::NewerFormat {
                path: json_path,
                found: meta.format_version,
                supported: BASIS_FORMAT_VERSION,
            });
        }
        let k = meta.kernel_px;
        let read = |name: &str, shape: &[usize]| -> Result<Vec<f32>> {
            let path = dir.join(name);
            let (found, data) = crate::npy::read_f32(&path)?;
            if found != shape {
                return Err(DatasetError::format(
                    &path,
                    format!("shape {found:?}, but basis.json describes {shape:?}"),
                ));
            }
            Ok(data)
        };
        let mean = read(MEAN_NPY, &[3, k, k])?;
        let components = read(COMPONENTS_NPY, &[3, CODE_COMPONENTS, k, k])?;
        let basis = PsfBasis {
            meta,
            mean,
            components,
        };
        basis
            .validate()
            .map_err(|message| DatasetError::format(dir, message))?;
        let sha = basis.content_sha256();
        if sha != basis.meta.sha256 {
            return Err(DatasetError::format(
                dir,
                format!(
                    "the arrays hash to {sha}, but basis.json records {}",
                    basis.meta.sha256
                ),
            ));
        }
        Ok(basis)
    }

    /// The codes of a table's stored fields (each kernel's whitened coefficients).
    pub fn field_codes(&self, table: &PsfTable) -> FieldCodes {
        let k = self.meta.kernel_px;
        let d = k * k;
        let codes = (0..table.fields())
            .map(|field| {
                let mut code = [0.0f32; 3 * CODE_COMPONENTS];
                for channel in 0..3 {
                    let kernel = prepared(table.kernel(field, channel), table.meta.kernel_px, k);
                    let mean = &self.mean[channel * d..(channel + 1) * d];
                    for (i, std) in self.meta.coefficient_std[channel].iter().enumerate() {
                        let start = (channel * CODE_COMPONENTS + i) * d;
                        let b = &self.components[start..start + d];
                        let dot: f64 = kernel
                            .iter()
                            .zip(mean)
                            .zip(b)
                            .map(|((v, m), b)| (v - *m as f64) * *b as f64)
                            .sum();
                        code[channel * CODE_COMPONENTS + i] = (dot / std) as f32;
                    }
                }
                code
            })
            .collect();
        FieldCodes {
            radii: table.meta.field_radius_norm.clone(),
            codes,
        }
    }
}

/// Share of the held-out kernels' variance about the fit's mean that the components explain, per
/// colour (None when nothing is held out).
fn held_out_share(tables: &[FitTable], fits: &[ChannelFit], size: usize) -> Result<Option<[f64; 3]>> {
    let mut total = [0.0f64; 3];
    let mut residual = [0.0f64; 3];
    let mut any = false;
    for t in tables.iter().filter(|t| t.held_out) {
        any = true;
        let table = PsfTable::read(&t.dir)?;
        for field in 0..table.fields() {
            for (channel, fit) in fits.iter().enumerate() {
                let centred: Vec<f64> = prepared(table.kernel(field, channel), table.meta.kernel_px, size)
                    .iter()
                    .zip(&fit.mean)
                    .map(|(v, m)| v - m)
                    .collect();
                let energy: f64 = centred.iter().map(|v| v * v).sum();
                let captured: f64 = fit
                    .components
                    .iter()
                    .map(|b| centred.iter().zip(b).map(|(v, b)| v * b).sum::<f64>().powi(2))
                    .sum();
                total[channel] += energy;
                residual[channel] += (energy - captured).max(0.0);
            }
        }
    }
    Ok(any.then(|| {
        std::array::from_fn(|c| {
            if total[c] > 0.0 {
                1.0 - residual[c] / total[c]
            } else {
                1.0
            }
        })
    }))
}

/// A table's field codes: ready to be evaluated anywhere on the frame ([`FieldCodes::at`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FieldCodes {
    radii: Vec<f64>,
    codes: Vec<[f32; 3 * CODE_COMPONENTS]>,
}

impl FieldCodes {
    /// From stored radii (normalised, ascending) and codes [F][3 x CODE_COMPONENTS] (the bindings' path).
    pub fn new(radii: Vec<f64>, codes: Vec<[f32; 3 * CODE_COMPONENTS]>) -> Result<FieldCodes> {
        if radii.is_empty() || radii.len() != codes.len() {
            return Err(DatasetError::Invalid(format!(
                "PSF field codes: {} radii for {} codes (need the same, at least one)",
                radii.len(),
                codes.len()
            )));
        }
        if radii
            .windows(2)
            .any(|w| w[0].partial_cmp(&w[1]) != Some(std::cmp::Ordering::Less))
            || radii.iter().any(|r| !r.is_finite() || *r < 0.0)
        {
            return Err(DatasetError::Invalid(
                "PSF field codes: radii must be finite, non-negative and strictly ascending".into(),
            ));
        }
        if codes.iter().flatten().any(|v| !v.is_finite()) {
            return Err(DatasetError::Invalid(
                "PSF field codes: a code is not finite".into(),
            ));
        }
        Ok(FieldCodes { radii, codes })
    }

    pub fn radii(&self) -> &[f64] {
        &self.radii
    }

    pub fn codes(&self) -> &[[f32; 3 * CODE_COMPONENTS]] {
        &self.codes
    }

    /// The code at a normalised frame position (x right, y down; docs/models.md).
    pub fn at(&self, x_norm: f64, y_norm: f64) -> [f32; PSF_CODE_CHANNELS] {
        let (i, j, t) = bracket(&self.radii, x_norm.hypot(y_norm));
        let mut out = [0.0f32; PSF_CODE_CHANNELS];
        for (n, o) in out.iter_mut().take(3 * CODE_COMPONENTS).enumerate() {
            *o = ((1.0 - t) * self.codes[i][n] as f64 + t * self.codes[j][n] as f64) as f32;
        }
        let (s, c) = y_norm.atan2(x_norm).sin_cos();
        out[3 * CODE_COMPONENTS] = c as f32;
        out[3 * CODE_COMPONENTS + 1] = s as f32;
        out
    }
}

/// The `psf_code` map `[PSF_CODE_CHANNELS, h, w]` of a crop of the frame (docs/models.md).
pub fn psf_code_map(codes: &FieldCodes, crop: FrameCrop) -> Result<ChannelMap> {
    crop.check()?;
    let (w, h) = (crop.w, crop.h);
    let plane = w * h;
    let mut data = vec![0.0f32; PSF_CODE_CHANNELS * plane];
    for row in 0..h {
        for column in 0..w {
            let [x, y] = crop.normalised(row, column);
            for (channel, value) in codes.at(x, y).iter().enumerate() {
                data[channel * plane + row * w + column] = *value;
            }
        }
    }
    Ok(ChannelMap {
        channels: PSF_CODE_CHANNELS,
        height: h,
        width: w,
        data,
    })
}

/// The basis of a dataset folder (`DIR/psf/basis`), with an error that says how to make one.
pub fn read_dataset_basis(dataset: &Path) -> Result<PsfBasis> {
    let dir = dataset.join(BASIS_RELATIVE);
    if !dir.join(BASIS_JSON).is_file() {
        return Err(DatasetError::format(
            &dir,
            "no PSF basis (basis.json); run the same `unicac dataset build` command again: it resumes the \
             finished dataset and fits the basis",
        ));
    }
    PsfBasis::read(&dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::psf_table::{PsfTableMeta, TABLE_FORMAT};

    /// A mirror-symmetric (about the horizontal axis) pattern on a k x k grid.
    fn pattern(k: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f64> {
        let h = (k / 2) as f64;
        (0..k * k)
            .map(|i| f((i % k) as f64 - h, (i / k) as f64 - h))
            .collect()
    }

    fn table(k: usize, kernels_per_field: &[Vec<f64>], radii: &[f64]) -> PsfTable {
        let f = radii.len();
        PsfTable {
            meta: PsfTableMeta {
                format: TABLE_FORMAT.into(),
                format_version: 1,
                lens_id: "test".into(),
                field_radius_norm: radii.to_vec(),
                field_deg: radii.iter().map(|r| r * 20.0).collect(),
                kernel_px: k,
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
                .map(|v| v as f32)
                .collect(),
        }
    }

    /// Kernels mean + a P1 + b P2 with P1, P2 orthogonal, symmetric, of zero sum: a 2-dimensional family.
    fn family(k: usize, coefficients: &[(f64, f64)]) -> Vec<Vec<f64>> {
        let mean = pattern(k, |x, y| (-(x * x + y * y) / 4.0).exp());
        let p1 = pattern(k, |x, y| x * (-(x * x + y * y) / 3.0).exp());
        let p2 = pattern(k, |x, y| (x * x - y * y) * (-(x * x + y * y) / 3.0).exp());
        coefficients
            .iter()
            .map(|(a, b)| {
                mean.iter()
                    .zip(&p1)
                    .zip(&p2)
                    .map(|((m, p), q)| m + a * p + b * q)
                    .collect()
            })
            .collect()
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("unicac-psf-basis-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn write_tables(dir: &Path, tables: &[(PsfTable, bool)]) -> Vec<FitTable> {
        tables
            .iter()
            .enumerate()
            .map(|(i, (t, held_out))| {
                let d = dir.join(format!("lens{i}"));
                t.write(&d).unwrap();
                FitTable {
                    dir: d,
                    held_out: *held_out,
                }
            })
            .collect()
    }

    #[test]
    fn a_two_dimensional_family_is_recovered_exactly() {
        let dir = scratch("family");
        let radii = [0.0, 0.5, 1.0];
        let a = family(9, &[(0.1, 0.0), (0.3, -0.2), (-0.2, 0.4)]);
        let b = family(9, &[(0.0, 0.1), (0.5, 0.5), (-0.4, -0.1)]);
        // A held-out lens of the same family.
        let c: Vec<Vec<f64>> = family(9, &[(0.2, 0.1), (0.0, 0.0), (-0.1, 0.3)]);
        let tables = write_tables(
            &dir,
            &[
                (table(9, &a, &radii), false),
                (table(9, &b, &radii), false),
                (table(9, &c, &radii), true),
            ],
        );
        let basis = PsfBasis::fit(&tables, 0.999, "test").unwrap();
        assert_eq!(basis.meta.kernel_px, 9);
        assert_eq!(basis.meta.components, [2, 2, 2], "{:?}", basis.meta);
        assert!(basis.meta.explained.iter().all(|e| (e - 1.0).abs() < 1e-9));
        assert_eq!(basis.meta.fit_kernels, 6);
        // Every training kernel is mean + sum of code x std x component, to float32 precision.
        let t = PsfTable::read(&tables[1].dir).unwrap();
        let codes = basis.field_codes(&t);
        let d = 81;
        for (field, code) in codes.codes().iter().enumerate() {
            let mut rebuilt: Vec<f64> = basis.mean[..d].iter().map(|&v| v as f64).collect();
            for (i, (value, std)) in code.iter().zip(&basis.meta.coefficient_std[0]).enumerate() {
                let b = &basis.components[i * d..(i + 1) * d];
                let scale = *value as f64 * std;
                rebuilt
                    .iter_mut()
                    .zip(b)
                    .for_each(|(r, &b)| *r += scale * b as f64);
            }
            let worst = rebuilt
                .iter()
                .zip(t.kernel(field, 0))
                .map(|(r, &k)| (r - k as f64).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-6, "field {field}: {worst}");
            assert!(code[2..CODE_COMPONENTS].iter().all(|&v| v == 0.0));
        }
        // The held-out lens lies in the same family: its kernels are explained too.
        let held = basis.meta.explained_held_out.unwrap();
        assert!(held.iter().all(|e| (e - 1.0).abs() < 1e-6), "{held:?}");
        // Whitened: the coefficients over the fit kernels have unit variance.
        let mut all = Vec::new();
        for t in &tables[..2] {
            all.extend(
                basis
                    .field_codes(&PsfTable::read(&t.dir).unwrap())
                    .codes()
                    .to_vec(),
            );
        }
        for i in 0..2 {
            let var = all.iter().map(|c| (c[i] as f64).powi(2)).sum::<f64>() / all.len() as f64;
            assert!((var - 1.0).abs() < 1e-5, "component {i}: variance {var}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn components_are_the_leading_singular_vectors() {
        // An independent route to the same subspace: nalgebra's SVD of the centred kernel matrix
        // itself (not the Gram matrix's eigendecomposition). Tolerance: |cos| of each matched pair >
        // 1 - 1e-9.
        let dir = scratch("svd");
        let k = 7;
        let radii: Vec<f64> = (0..5).map(|i| i as f64 * 0.25).collect();
        let mut state = 12345u64;
        let mut noise = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let lenses: Vec<(PsfTable, bool)> = (0..4)
            .map(|_| {
                let kernels: Vec<Vec<f64>> = (0..5)
                    .map(|_| {
                        let (a, b, s) = (noise() - 0.5, noise() - 0.5, 1.0 + noise());
                        let raw = pattern(k, |x, y| {
                            (-(((x - a) * (x - a)) / s + y * y / (2.0 + b)) / 2.0).exp()
                        });
                        let sum: f64 = raw.iter().sum();
                        raw.iter().map(|v| v / sum).collect()
                    })
                    .collect();
                (table(k, &kernels, &radii), false)
            })
            .collect();
        let tables = write_tables(&dir, &lenses);
        let basis = PsfBasis::fit(&tables, 0.99, "test").unwrap();
        let d = k * k;
        let mut x = DMatrix::<f64>::zeros(d, 20);
        let mut column = 0;
        for t in &tables {
            let t = PsfTable::read(&t.dir).unwrap();
            for field in 0..5 {
                x.column_mut(column)
                    .copy_from_slice(&prepared(t.kernel(field, 0), k, k));
                column += 1;
            }
        }
        let mean: Vec<f64> = (0..d).map(|i| x.row(i).sum() / 20.0).collect();
        for mut c in x.column_iter_mut() {
            c.iter_mut().zip(&mean).for_each(|(v, m)| *v -= m);
        }
        let svd = nalgebra::SVD::new(x, true, false);
        let u = svd.u.unwrap();
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
        let m = basis.meta.components[0];
        assert!(m >= 2, "{:?}", basis.meta);
        let total: f64 = svd.singular_values.iter().map(|s| s * s).sum();
        let explained: f64 = order[..m]
            .iter()
            .map(|&i| svd.singular_values[i].powi(2))
            .sum::<f64>()
            / total;
        assert!((explained - basis.meta.explained[0]).abs() < 1e-9);
        for (i, &j) in order[..m].iter().enumerate() {
            let b = &basis.components[i * d..(i + 1) * d];
            let cos: f64 = b.iter().zip(u.column(j).iter()).map(|(a, b)| *a as f64 * b).sum();
            assert!(cos.abs() > 1.0 - 1e-6, "component {i}: |cos| {}", cos.abs());
            let std = svd.singular_values[j] / 20f64.sqrt();
            assert!((std - basis.meta.coefficient_std[0][i]).abs() < 1e-9 * std.max(1.0));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn kernels_are_centred_in_the_basis_frame_and_symmetrised() {
        // 3 x 3 into 5 x 5: zero-padded around the centre; then averaged with its mirror (rows flipped).
        let k: Vec<f32> = (1..=9).map(|v| v as f32).collect();
        let out = prepared(&k, 3, 5);
        assert_eq!(out[2 * 5 + 2], 5.0);
        assert_eq!(out[5 + 1], 0.5 * (1.0 + 7.0));
        assert_eq!(out[3 * 5 + 1], 0.5 * (7.0 + 1.0));
        assert_eq!(out[2 * 5 + 3], 6.0);
        assert!(out[..5].iter().all(|&v| v == 0.0));
        // 5 x 5 into 3 x 3: the centre is kept.
        let big: Vec<f32> = (0..25).map(|v| v as f32).collect();
        let out = prepared(&big, 5, 3);
        assert_eq!(out[4], 12.0);
        assert_eq!(out[0], 0.5 * (6.0 + 16.0));
        assert_eq!(evenly_spaced(10, 4), vec![0, 2, 5, 7]);
        assert_eq!(evenly_spaced(3, 4), vec![0, 1, 2]);
    }

    #[test]
    fn codes_interpolate_like_kernels_and_mirror_keeps_them() {
        let dir = scratch("interp");
        let radii = [0.0, 0.5, 1.0];
        let a = family(9, &[(0.1, 0.0), (0.3, -0.2), (-0.2, 0.4)]);
        let tables = write_tables(&dir, &[(table(9, &a, &radii), false)]);
        let basis = PsfBasis::fit(&tables, 1.0, "test").unwrap();
        let t = PsfTable::read(&tables[0].dir).unwrap();
        let codes = basis.field_codes(&t);
        // A quarter of the way from field 1 to field 2, at azimuth 90 deg (straight down).
        let at = codes.at(0.0, 0.625);
        let mixed: Vec<f32> = t
            .kernel(1, 0)
            .iter()
            .zip(t.kernel(2, 0))
            .map(|(p, q)| 0.75 * p + 0.25 * q)
            .collect();
        let mut one = t.clone();
        one.meta.field_radius_norm = vec![0.0];
        one.kernels = [mixed.clone(), mixed.clone(), mixed].concat();
        one.meta.field_deg = vec![0.0];
        one.meta.relative_illumination = vec![1.0];
        one.meta.distortion = vec![1.0];
        one.meta.energy_cut = vec![[0.0; 3]];
        let direct = basis.field_codes(&one).codes()[0];
        for n in 0..3 * CODE_COMPONENTS {
            assert!(
                (at[n] - direct[n]).abs() < 1e-5,
                "{n}: {} vs {}",
                at[n],
                direct[n]
            );
        }
        assert!(at[3 * CODE_COMPONENTS].abs() < 1e-7 && (at[3 * CODE_COMPONENTS + 1] - 1.0).abs() < 1e-7);
        // A kernel and its mirror image (y -> -y) have the same code.
        let mut mirrored = t.clone();
        let k = 9;
        for (f, c) in (0..3).flat_map(|f| (0..3).map(move |c| (f, c))) {
            let start = (f * 3 + c) * k * k;
            let original = t.kernel(f, c).to_vec();
            for row in 0..k {
                mirrored.kernels[start + row * k..start + (row + 1) * k]
                    .copy_from_slice(&original[(k - 1 - row) * k..(k - row) * k]);
            }
        }
        assert_eq!(basis.field_codes(&mirrored), codes);
        // The map is the pointwise code at every pixel.
        let crop = FrameCrop {
            x0: 10,
            y0: 5,
            w: 20,
            h: 12,
            ..FrameCrop::full(64, 48)
        };
        let map = psf_code_map(&codes, crop).unwrap();
        assert_eq!((map.channels, map.height, map.width), (PSF_CODE_CHANNELS, 12, 20));
        let [x, y] = crop.normalised(7, 3);
        for (c, v) in codes.at(x, y).iter().enumerate() {
            assert_eq!(map.at(c, 7, 3), *v);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_basis_round_trips_and_a_changed_array_is_refused() {
        let dir = scratch("disk");
        let radii = [0.0, 1.0];
        let a = family(9, &[(0.1, 0.3), (0.3, -0.2)]);
        let b = family(9, &[(0.2, 0.1), (-0.3, 0.2)]);
        let tables = write_tables(
            &dir,
            &[(table(9, &a, &radii), false), (table(9, &b, &radii), false)],
        );
        let basis = PsfBasis::fit(&tables, 0.95, "test").unwrap();
        let again = PsfBasis::fit(&tables, 0.95, "test").unwrap();
        assert_eq!(basis, again, "a fit is a pure function of the tables");
        let out = dir.join("basis");
        basis.write(&out).unwrap();
        assert_eq!(PsfBasis::read(&out).unwrap(), basis);
        let mut changed = basis.mean.clone();
        changed[40] += 0.01;
        crate::npy::write_f32(&out.join(MEAN_NPY), &[3, 9, 9], &changed).unwrap();
        let error = PsfBasis::read(&out).unwrap_err().to_string();
        assert!(error.contains("hash") && error.contains("basis"), "{error}");
        assert!(PsfBasis::fit(&tables, 1.5, "test")
            .unwrap_err()
            .to_string()
            .contains("energy share"));
        let error = read_dataset_basis(&dir.join("nothing")).unwrap_err().to_string();
        assert!(
            error.contains("psf/basis") && error.contains("unicac dataset build"),
            "{error}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
