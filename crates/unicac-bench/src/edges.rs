//! The slanted-edge patches behind `unicac bench`'s OIQE. The dataset stores, per test lens, ODE field
//! and edge direction, one grey edge per colour channel, each blurred by that channel's kernel. The
//! bench restores them as the lens renders an edge: one RGB image whose channel c is channel c's patch
//! (a grey edge through the lens's three kernels, colour fringes included), and measures channel c's
//! slanted-edge MTF on its restoration. Per-channel methods (identity, Wiener) score exactly as on the
//! separate patches; a network sees an edge of the kind it was trained on, and runs a third of the pixels.
//! Rows that do not form such a triple (a hand-made dataset) are restored one by one, as stored.

use std::collections::HashMap;
use std::path::PathBuf;

use unicac_dataset::folder::Dataset;
use unicac_dataset::psf_basis::FieldCodes;
use unicac_dataset::{EdgeRow, PsfTable};
use unicac_image::Planar;

use crate::error::{BenchError, Result};
use crate::inputs::{read_rgb, wiener_at, wiener_input, InputMaps, WienerEstimates};
use unicac_onnx::contract::ModelContract;

/// Most pixels of edge images run through a model in one batch (2^18: a 512 x 512 image's worth, so a
/// batch needs no more memory than a test pair of that size; 2^20 doubled the small run's peak to 1.2 GB).
pub const MAX_EDGE_BATCH_PX: usize = 1 << 18;

/// Which per-pixel maps the benchmarked models take.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct MapNeeds {
    pub fov: bool,
    pub psf: bool,
    pub psf_code: bool,
}

/// Edge rows restored as one image: the R, G and B patches of one field and direction, or one row.
pub(crate) type EdgeGroup<'a> = Vec<&'a EdgeRow>;

/// Groups `rows` (in order of first appearance) into the images the bench restores.
pub(crate) fn edge_groups(rows: &[EdgeRow]) -> Vec<EdgeGroup<'_>> {
    // Groups in order of first appearance, found by key (borrowed: no string copies).
    let mut index: HashMap<(&str, u64, &str, usize), usize> = HashMap::new();
    let mut order: Vec<EdgeGroup> = Vec::new();
    for row in rows {
        let key = (
            row.lens_id.as_str(),
            row.field_fraction.to_bits(),
            row.direction.as_str(),
            row.size_px,
        );
        match index.get(&key) {
            Some(&i) => order[i].push(row),
            None => {
                index.insert(key, order.len());
                order.push(vec![row]);
            }
        }
    }
    let mut groups = Vec::new();
    for group in order {
        let mut channels: Vec<&str> = group.iter().map(|r| r.channel.as_str()).collect();
        channels.sort_unstable();
        if channels == ["B", "G", "R"] {
            groups.push(group);
        } else {
            groups.extend(group.into_iter().map(|row| vec![row]));
        }
    }
    groups
}

/// The channel index of an edge row's `channel` (R, G, B).
fn channel_index(row: &EdgeRow) -> Result<usize> {
    match row.channel.as_str() {
        "R" => Ok(0),
        "G" => Ok(1),
        "B" => Ok(2),
        other => Err(BenchError::InvalidInput(format!(
            "edges.jsonl: edge {} has channel `{other}`",
            row.edge_id
        ))),
    }
}

/// What the slanted-edge measurement of a restored patch gives.
pub(crate) enum EdgeScore {
    Measured(unicac_metrics::MtfSummary),
    /// No edge found (why): scored as a zero MTF.
    Destroyed(String),
}

impl EdgeScore {
    /// The summary OIQE is computed from (a destroyed edge's MTF50 and area are 0).
    pub fn summary(&self) -> unicac_metrics::MtfSummary {
        match self {
            EdgeScore::Measured(summary) => *summary,
            EdgeScore::Destroyed(_) => unicac_metrics::MtfSummary {
                mtf50_cy_per_px: 0.0,
                mtf50_kind: unicac_metrics::mtf::Mtf50Kind::BelowNyquist,
                mtf_area: 0.0,
            },
        }
    }
}

/// One image of edge rows to restore, read, with the maps its models take.
pub(crate) struct EdgePatch<'a> {
    /// The rows it scores, each with its file and the channel measured.
    pub rows: Vec<(&'a EdgeRow, PathBuf, usize)>,
    pub lq: Planar,
    /// Normalised image height of the patch's centre (its ODE field).
    field_fraction: f64,
    /// Half-diagonal (px) of the frames the lens's pairs were rendered at: the field's unit.
    half_diagonal_px: f64,
    fov: Option<Planar>,
    psf: Option<Planar>,
    psf_code: Option<Planar>,
    /// The Wiener estimates the models take as input.
    wiener: WienerEstimates,
}

impl<'a> EdgePatch<'a> {
    /// Reads the patches of `group` (composed into one RGB image when it is an R, G, B triple) and
    /// computes the maps `needs` names (from `table`, the lens's PSF table, and `codes`, its field
    /// codes) and the Wiener estimates at `wiener_nsrs`.
    pub fn load(
        dataset: &Dataset,
        group: &[&'a EdgeRow],
        half_diagonal_px: f64,
        needs: MapNeeds,
        table: Option<&PsfTable>,
        codes: Option<&FieldCodes>,
        wiener_nsrs: &[f64],
    ) -> Result<EdgePatch<'a>> {
        let mut rows = Vec::with_capacity(group.len());
        let mut lq: Option<Planar> = None;
        for &row in group {
            let path = dataset.resolve(&row.lq)?;
            let channel = channel_index(row)?;
            let patch = read_rgb(&path)?;
            match &mut lq {
                None => lq = Some(patch),
                Some(image) if (image.width, image.height) == (patch.width, patch.height) => {
                    image.plane_mut(channel).copy_from_slice(patch.plane(channel))
                }
                Some(image) => {
                    return Err(BenchError::InvalidInput(format!(
                        "{}: {}x{} px, but the other channels' patches of edge {} are {}x{}",
                        path.display(),
                        patch.width,
                        patch.height,
                        row.edge_id,
                        image.width,
                        image.height
                    )))
                }
            }
            rows.push((row, path, channel));
        }
        let lq = lq.expect("an edge group has a row");
        let row = group[0];
        let mut patch = EdgePatch {
            rows,
            lq,
            field_fraction: row.field_fraction,
            half_diagonal_px,
            fov: None,
            psf: None,
            psf_code: None,
            wiener: WienerEstimates::new(),
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
            self.field_fraction + (row as f64 + 0.5 - 0.5 * h) / self.half_diagonal_px,
        ]
    }

    /// The field-varying Wiener restoration of the patch with `table`'s PSFs.
    pub fn wiener_restore(&self, table: &PsfTable, nsr: f64) -> Result<Planar> {
        crate::wiener::wiener_restore(&self.lq, table, &|r, c| self.position(r, c), nsr)
    }

    /// [`EdgePatch::wiener_restore`], taken from the models' input estimates when one has this ratio.
    pub fn wiener_restoration(&self, table: &PsfTable, nsr: f64) -> Result<Planar> {
        wiener_at(&self.wiener, nsr, || self.wiener_restore(table, nsr))
    }

    /// The maps `contract` may take (those not computed are `None`).
    pub fn maps(&self, contract: &ModelContract) -> InputMaps<'_> {
        InputMaps {
            fov: self.fov.as_ref(),
            psf: self.psf.as_ref(),
            psf_code: self.psf_code.as_ref(),
            wiener: wiener_input(contract, &self.wiener),
        }
    }

    /// The slanted-edge MTF summary of `channel` of a restoration of this patch, measured in linear
    /// light inside a border of an eighth of the patch (where the edge is whole). A restoration in
    /// which the ISO 12233 fit finds no edge (`MetricsError::NoEdge`: no step across the rows, or no
    /// straight line through them) has destroyed the edge the input held: it scores a zero MTF
    /// ([`EdgeScore::Destroyed`], OIQE 0) rather than being left out, which would credit the method
    /// with the mean of the edges it kept.
    pub fn score(&self, restored: &Planar, channel: usize) -> std::result::Result<EdgeScore, String> {
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
            channel,
            roi,
            &unicac_metrics::SlantedEdgeOptions::default(),
        )
        .map(|mtf| EdgeScore::Measured(mtf.summary()))
        .or_else(|e| match e {
            unicac_metrics::MetricsError::NoEdge(why) => Ok(EdgeScore::Destroyed(why)),
            other => Err(other.to_string()),
        })
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

#[cfg(test)]
mod tests {
    use super::*;

    fn row(lens: &str, field: f64, channel: &str, direction: &str) -> EdgeRow {
        EdgeRow {
            edge_id: format!("{lens}_{field}_{channel}_{direction}"),
            lens_id: lens.into(),
            level: Some(1),
            field_fraction: field,
            field_deg: 0.0,
            channel: channel.into(),
            direction: direction.into(),
            lq: String::new(),
            gt: String::new(),
            size_px: 64,
            slant_deg: 5.0,
            pixel_um: 2.0,
        }
    }

    #[test]
    fn the_three_channels_of_a_field_and_direction_form_one_image_and_others_stay_alone() {
        let rows = vec![
            row("a", 0.0, "R", "sagittal"),
            row("a", 0.0, "R", "tangential"),
            row("a", 0.0, "G", "sagittal"),
            row("a", 0.0, "G", "tangential"),
            row("a", 0.0, "B", "sagittal"),
            row("a", 0.0, "B", "tangential"),
            row("a", 0.5, "R", "sagittal"),
            row("a", 0.5, "G", "sagittal"),
            row("b", 0.0, "R", "sagittal"),
        ];
        let groups: Vec<Vec<&str>> = edge_groups(&rows)
            .iter()
            .map(|g| g.iter().map(|r| r.edge_id.as_str()).collect())
            .collect();
        assert_eq!(
            groups,
            vec![
                vec!["a_0_R_sagittal", "a_0_G_sagittal", "a_0_B_sagittal"],
                vec!["a_0_R_tangential", "a_0_G_tangential", "a_0_B_tangential"],
                vec!["a_0.5_R_sagittal"],
                vec!["a_0.5_G_sagittal"],
                vec!["b_0_R_sagittal"],
            ]
        );
    }
}
