//! # unicac-dataset
//!
//! ODE-stratified benchmark and training datasets (docs/dataset.md). This crate holds the on-disk
//! format that the builder writes and that `unicac bench` and the Python training code read:
//!
//! - `manifest`: the rows of `lenses.jsonl`, `pairs.jsonl`, `edges.jsonl` and `dataset.json`, with
//!   readers that check the format version and writers;
//! - `folder`: an opened dataset folder whose manifests are checked against `dataset.json`'s counts
//!   (`row_counts`) when read;
//! - `psf_table`: per-lens radial PSF tables (`psf/LENS_ID/kernels.npy` + `table.json`) and the
//!   PSF-feature map of docs/models.md;
//! - `psf_basis`: the dataset's PCA basis of its PSF kernels (`psf/basis/`) and the `psf_code` map of
//!   docs/models.md;
//! - `fov`: the field-of-view map of docs/models.md;
//! - `npy`: float32 NPY files through the `npyz` crate (no ndarray needed; numpy reads them with
//!   `allow_pickle=False`).

pub mod builder;
pub mod error;
pub mod folder;
pub mod fov;
pub mod info;

pub mod manifest;
pub mod npy;
pub mod psf_basis;
pub mod psf_table;
pub mod row_counts;
pub mod seeds;

pub use error::{DatasetError, Result};
pub use fov::fov_map;
pub use manifest::{DatasetManifest, EdgeRow, LensRow, PairRow, FORMAT_NAME, FORMAT_VERSION};
pub use psf_basis::{psf_code_map, FieldCodes, PsfBasis, PSF_CODE_CHANNELS};
pub use psf_table::{psf_feature_map, PsfTable, PsfTableMeta, PSF_FEATURES};
/// The scores in each lens row (declared by the ODE, flattened into `LensRow`).
pub use unicac_ode::OdeScores;

/// A float32 map of `channels` planes of `height` x `width` pixels, channel-major ([C, H, W]).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelMap {
    pub channels: usize,
    pub height: usize,
    pub width: usize,
    pub data: Vec<f32>,
}

impl ChannelMap {
    pub fn at(&self, channel: usize, row: usize, column: usize) -> f32 {
        self.data[(channel * self.height + row) * self.width + column]
    }
}

/// Half the diagonal (px) of a `frame_w` x `frame_h` frame: the unit of normalised field positions
/// (docs/models.md).
pub fn half_diagonal_px(frame_w: usize, frame_h: usize) -> f64 {
    0.5 * (frame_w as f64).hypot(frame_h as f64)
}

/// A crop (or the whole frame) of a `frame_w` x `frame_h` sensor frame, in frame pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameCrop {
    pub frame_w: usize,
    pub frame_h: usize,
    pub x0: usize,
    pub y0: usize,
    pub w: usize,
    pub h: usize,
}

/// Largest frame side the maps accept (px): a stated limit, not an allocation failure.
pub const MAX_FRAME_SIDE_PX: usize = 1 << 15;

impl FrameCrop {
    /// The whole frame.
    pub fn full(frame_w: usize, frame_h: usize) -> FrameCrop {
        FrameCrop {
            frame_w,
            frame_h,
            x0: 0,
            y0: 0,
            w: frame_w,
            h: frame_h,
        }
    }

    /// Checks that the crop is non-empty and inside the frame.
    pub fn check(&self) -> Result<()> {
        let FrameCrop {
            frame_w,
            frame_h,
            x0,
            y0,
            w,
            h,
        } = *self;
        if frame_w == 0 || frame_h == 0 || frame_w > MAX_FRAME_SIDE_PX || frame_h > MAX_FRAME_SIDE_PX {
            return Err(DatasetError::Invalid(format!(
                "frame {frame_w} x {frame_h} px: each side must be between 1 and {MAX_FRAME_SIDE_PX}"
            )));
        }
        if w == 0
            || h == 0
            || x0.checked_add(w).is_none_or(|e| e > frame_w)
            || y0.checked_add(h).is_none_or(|e| e > frame_h)
        {
            return Err(DatasetError::Invalid(format!(
                "crop x0={x0} y0={y0} w={w} h={h} is empty or outside the {frame_w} x {frame_h} frame"
            )));
        }
        Ok(())
    }

    /// Normalised position (x, y) of a crop pixel's centre in the full frame (docs/models.md).
    pub fn normalised(&self, row: usize, column: usize) -> [f64; 2] {
        let (fw, fh) = (self.frame_w as f64, self.frame_h as f64);
        let half_diagonal = half_diagonal_px(self.frame_w, self.frame_h);
        [
            ((self.x0 + column) as f64 + 0.5 - fw / 2.0) / half_diagonal,
            ((self.y0 + row) as f64 + 0.5 - fh / 2.0) / half_diagonal,
        ]
    }
}
