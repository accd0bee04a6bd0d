//! The slanted-edge patches behind `unicac bench`'s OIQE: each patch read with the maps its models take
//! (positions on the frame's +y radius, where the dataset rendered it), and its restoration scored by the
//! slanted-edge MTF of the blurred channel inside a border.

use std::collections::BTreeMap;
use std::path::PathBuf;

use unicac_dataset::folder::Dataset;
use unicac_dataset::psf_basis::FieldCodes;
use unicac_dataset::{EdgeRow, PsfTable};
use unicac_image::Planar;

use crate::contract::{ModelContract, ModelInput};
use crate::error::{BenchError, Result};
use crate::run::{read_rgb, InputMaps};

/// Most pixels of edge patches run through a model in one batch (2^20: 64 patches of 128 x 128, whose
/// 50-channel PSF codes take 200 MB as f32).
pub const MAX_EDGE_BATCH_PX: usize = 1 << 20;

/// Which per-pixel maps the benchmarked models take.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct MapNeeds {
    pub fov: bool,
    pub psf: bool,
    pub psf_code: bool,
}

/// One edge patch, read, with the maps its models take.
pub(crate) struct EdgePatch<'a> {
    pub row: &'a EdgeRow,
    pub path: PathBuf,
    pub lq: Planar,
    /// The channel whose kernel blurred the patch (0 = R).
    pub channel: usize,
    /// Half-diagonal (px) of the frames the lens's pairs were rendered at: the field's unit.
    half_diagonal_px: f64,
    fov: Option<Planar>,
    psf: Option<Planar>,
    psf_code: Option<Planar>,
    /// Wiener estimates keyed by the bits of their noise-to-signal ratio.
    wiener: BTreeMap<u64, Planar>,
}

impl<'a> EdgePatch<'a> {
    /// Reads the patch of `row` and computes the maps `needs` names (from `table`, the lens's PSF
    /// table, and `codes`, its field codes) and the Wiener estimates at `wiener_nsrs`.
    pub fn load(
        dataset: &Dataset,
        row: &'a EdgeRow,
        half_diagonal_px: f64,
        needs: MapNeeds,
        table: Option<&PsfTable>,
        codes: Option<&FieldCodes>,
        wiener_nsrs: &[f64],
    ) -> Result<EdgePatch<'a>> {
        let path = dataset
            .resolve(&row.lq)
            .map_err(|e| BenchError::InvalidInput(e.to_string()))?;
        let lq = read_rgb(&path)?;
        let channel = match row.channel.as_str() {
            "R" => 0,
            "G" => 1,
            "B" => 2,
            other => {
                return Err(BenchError::InvalidInput(format!(
                    "edges.jsonl: edge {} has channel `{other}`",
                    row.edge_id
                )))
            }
        };
        let mut patch = EdgePatch {
            row,
            path,
            lq,
            channel,
            half_diagonal_px,
            fov: None,
            psf: None,
            psf_code: None,
            wiener: BTreeMap::new(),
        };
        if needs.fov {
            patch.fov = Some(patch.map(|x, y| [x as f32, y as f32]));
        }
        if let (true, Some(table)) = (needs.psf, table) {
            let features = table.features();
            patch.psf = Some(patch.map(|x, y| features.at(x, y)));
        }
        if let (true, Some(codes)) = (needs.psf_code, codes) {
            patch.psf_code = Some(patch.map(|x, y| codes.at(x, y)));
        }
        for &nsr in wiener_nsrs {
            let table = table.expect("a Wiener input needs the lens's PSF table");
            let estimate = patch.wiener_restore(table, nsr)?;
            patch.wiener.insert(nsr.to_bits(), estimate);
        }
        Ok(patch)
    }

    /// Normalised field position [x, y] of the patch pixel (row, column): the patch is centred on the
    /// ODE field on the frame's +y radius (docs/ode.md).
    pub fn position(&self, row: usize, column: usize) -> [f64; 2] {
        let (w, h) = (self.lq.width as f64, self.lq.height as f64);
        [
            (column as f64 + 0.5 - 0.5 * w) / self.half_diagonal_px,
            self.row.field_fraction + (row as f64 + 0.5 - 0.5 * h) / self.half_diagonal_px,
        ]
    }

    /// The field-varying Wiener restoration of the patch with `table`'s PSFs.
    pub fn wiener_restore(&self, table: &PsfTable, nsr: f64) -> Result<Planar> {
        crate::wiener::wiener_restore(&self.lq, table, &|r, c| self.position(r, c), nsr)
    }

    /// The maps `contract` may take (those not computed are `None`).
    pub fn maps(&self, contract: &ModelContract) -> InputMaps<'_> {
        InputMaps {
            fov: self.fov.as_ref(),
            psf: self.psf.as_ref(),
            psf_code: self.psf_code.as_ref(),
            wiener: contract
                .wants(ModelInput::Wiener)
                .then(|| {
                    let nsr = contract.wiener_nsr.unwrap_or(crate::wiener::DEFAULT_NSR);
                    self.wiener.get(&nsr.to_bits())
                })
                .flatten(),
        }
    }

    /// The slanted-edge MTF summary of a restoration of this patch, measured in linear light on the
    /// blurred channel inside a border of an eighth of the patch (where the edge is whole).
    pub fn score(&self, restored: &Planar) -> std::result::Result<unicac_metrics::MtfSummary, String> {
        let linear = unicac_image::color::srgb_to_linear(restored);
        let border = self.lq.width.min(self.lq.height) / 8;
        let roi = unicac_metrics::Roi {
            x: border,
            y: border,
            width: self.lq.width - 2 * border,
            height: self.lq.height - 2 * border,
        };
        unicac_metrics::slanted_edge_mtf(
            &linear,
            self.channel,
            roi,
            &unicac_metrics::SlantedEdgeOptions::default(),
        )
        .map(|mtf| mtf.summary())
        .map_err(|e| e.to_string())
    }

    /// A map of `N` channels holding `value` at each pixel's field position.
    fn map<const N: usize>(&self, value: impl Fn(f64, f64) -> [f32; N]) -> Planar {
        let mut map = Planar::new(self.lq.width, self.lq.height, N);
        for row in 0..self.lq.height {
            for column in 0..self.lq.width {
                let [x, y] = self.position(row, column);
                for (c, v) in value(x, y).into_iter().enumerate() {
                    map.set(c, column, row, v);
                }
            }
        }
        map
    }
}

/// Splits `patches` into runs of one size and at most [`MAX_EDGE_BATCH_PX`] pixels, in order.
pub(crate) fn batches<'p, 'a>(patches: &'p [EdgePatch<'a>]) -> Vec<&'p [EdgePatch<'a>]> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < patches.len() {
        let size = (patches[start].lq.width, patches[start].lq.height);
        let per_patch = (size.0 * size.1).max(1);
        let most = (MAX_EDGE_BATCH_PX / per_patch).max(1);
        let mut end = start + 1;
        while end < patches.len()
            && end - start < most
            && (patches[end].lq.width, patches[end].lq.height) == size
        {
            end += 1;
        }
        out.push(&patches[start..end]);
        start = end;
    }
    out
}
