//! Every test pair and edge patch through every method: the methods (identity, Wiener, each ONNX model),
//! what they read beside the low-quality image (maps, PSF tables, Wiener estimates), and the scores.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use unicac_dataset::folder::Dataset;
use unicac_dataset::psf_basis::PsfBasis;
use unicac_dataset::{EdgeRow, FieldCodes, FrameCrop, PairRow, PsfTable};
use unicac_image::io::{write_png, SampleDepth};
use unicac_image::Planar;

use crate::choices::Benchmark;
use crate::edges::{EdgeGroup, EdgePatch, EdgeScore, MapNeeds};
use crate::error::{BenchError, Result};
use crate::inputs::{read_rgb, wiener_at, wiener_input, InputMaps, WienerEstimates};
use crate::model_run::{run_onnx_batch, run_onnx_with};
use crate::report::write::ModelInfo;
use crate::report::{LensInfo, PairScore, Scores};
use crate::tiling::Tiling;
use unicac_learned_metrics::clipiqa::ClipIqa;
use unicac_learned_metrics::fid::FidNetwork;
use unicac_learned_metrics::lpips::Lpips;
use unicac_onnx::contract::{ModelContract, ModelInput};
use unicac_onnx::runtime::{Runtime, Session};

pub(crate) enum Method {
    Identity,
    Wiener {
        nsr: f64,
    },
    Onnx {
        contract: ModelContract,
        session: Session,
    },
}

pub(crate) struct Entry {
    pub info: ModelInfo,
    pub method: Method,
}

fn invalid(message: String) -> BenchError {
    BenchError::InvalidInput(message)
}

/// Identity, Wiener (when asked, at `wiener_nsr`) and a session per loaded model, in that order; a
/// model whose cost cannot be measured gets a notice.
pub(crate) fn method_entries(
    wiener_nsr: Option<f64>,
    loaded: Vec<crate::plan::LoadedModel>,
    runtime: Option<&'static Runtime>,
    threads: usize,
    notices: &mut Vec<String>,
) -> Result<Vec<Entry>> {
    let mut entries = vec![Entry {
        info: ModelInfo {
            name: "identity".into(),
            kind: "identity".into(),
            path: None,
            inputs: vec!["lq".into()],
            metadata: BTreeMap::new(),
            cost: None,
            failures: Vec::new(),
        },
        method: Method::Identity,
    }];
    if let Some(nsr) = wiener_nsr {
        entries.push(Entry {
            info: ModelInfo {
                name: "wiener".into(),
                kind: "wiener".into(),
                path: None,
                inputs: vec!["lq".into(), "psf table".into()],
                metadata: BTreeMap::from([("nsr".to_string(), nsr.to_string())]),
                cost: None,
                failures: Vec::new(),
            },
            method: Method::Wiener { nsr },
        });
    }
    for (name, contract, model, bytes) in loaded {
        let rt = runtime.expect("checked above");
        let cost = match unicac_onnx::cost::measure(rt, &contract, &model, threads) {
            Ok(c) => Some(c),
            Err(e) => {
                notices.push(format!("model {name}: cost not measured ({e})"));
                None
            }
        };
        let session = rt.session(
            &bytes,
            threads,
            &format!("model {name} ({})", contract.path.display()),
        )?;
        entries.push(Entry {
            info: ModelInfo {
                name: name.clone(),
                kind: "onnx".into(),
                path: Some(contract.path.clone()),
                inputs: contract.inputs.iter().map(|i| i.name().to_string()).collect(),
                metadata: contract.metadata.clone(),
                cost,
                failures: Vec::new(),
            },
            method: Method::Onnx { contract, session },
        });
    }
    Ok(entries)
}

/// What the methods read beside the low-quality image.
pub(crate) struct Needs {
    pub maps: MapNeeds,
    /// The noise-to-signal ratios of the Wiener estimates the models take as input (one estimate per
    /// distinct ratio and image), ascending.
    pub wiener_nsrs: Vec<f64>,
    /// Whether the lens's PSF table is read (maps, estimates or the Wiener method need it).
    pub table: bool,
}

impl Needs {
    pub fn of(entries: &[Entry], has_psf: bool) -> Needs {
        let wants = |input: ModelInput| {
            entries
                .iter()
                .any(|e| matches!(&e.method, Method::Onnx { contract, .. } if contract.wants(input)))
        };
        let maps = MapNeeds {
            fov: wants(ModelInput::Fov),
            psf: wants(ModelInput::Psf),
            psf_code: wants(ModelInput::PsfCode),
        };
        let mut wiener_nsrs: Vec<f64> = entries
            .iter()
            .filter_map(|e| match &e.method {
                Method::Onnx { contract, .. } => contract.wiener_input_nsr(crate::wiener::DEFAULT_NSR),
                _ => None,
            })
            .collect();
        wiener_nsrs.sort_by(f64::total_cmp);
        wiener_nsrs.dedup();
        let wiener_method = entries.iter().any(|e| matches!(e.method, Method::Wiener { .. }));
        let table = has_psf && (maps.psf || maps.psf_code || !wiener_nsrs.is_empty() || wiener_method);
        Needs {
            maps,
            wiener_nsrs,
            table,
        }
    }
}

/// Each lens's PSF table and its field codes in the dataset's basis, read once.
pub(crate) struct LensTables<'a> {
    dataset: &'a Dataset,
    basis: Option<&'a PsfBasis>,
    tables: BTreeMap<String, PsfTable>,
    codes: BTreeMap<String, FieldCodes>,
}

impl<'a> LensTables<'a> {
    pub fn new(dataset: &'a Dataset, basis: Option<&'a PsfBasis>) -> LensTables<'a> {
        LensTables {
            dataset,
            basis,
            tables: BTreeMap::new(),
            codes: BTreeMap::new(),
        }
    }

    /// The table of `lens_id`, read from the pair's `psf` folder the first time.
    pub fn table(&mut self, pair_psf: &str, lens_id: &str) -> Result<PsfTable> {
        if let Some(t) = self.tables.get(lens_id) {
            return Ok(t.clone());
        }
        let dir = self.dataset.resolve(pair_psf)?;
        let table = PsfTable::read(&dir)?;
        self.tables.insert(lens_id.to_string(), table.clone());
        Ok(table)
    }

    /// The field codes of `lens_id`'s table (a model that takes `psf_code` made the basis be read).
    pub fn codes(&mut self, table: &PsfTable, lens_id: &str) -> FieldCodes {
        let basis = self.basis;
        self.codes
            .entry(lens_id.to_string())
            .or_insert_with(|| basis.expect("basis read").field_codes(table))
            .clone()
    }
}

/// The metric networks that run (each present when its metric is computed).
pub(crate) struct Judges {
    pub lpips: Option<Lpips>,
    pub fid: Option<FidNetwork>,
    pub clip: Option<ClipIqa>,
}

/// How restorations are run and kept.
#[derive(Clone, Copy)]
pub(crate) struct Running<'a> {
    pub tiling: Tiling,
    /// Where restored test images are written (`images/MODEL/PAIR.png`), when asked.
    pub save_images_under: Option<&'a Path>,
}

fn to_planar(map: unicac_dataset::ChannelMap) -> Planar {
    Planar {
        width: map.width,
        height: map.height,
        channels: map.channels,
        data: map.data,
    }
}

fn frame_crop(pair: &PairRow) -> FrameCrop {
    FrameCrop {
        frame_w: pair.frame_px[0],
        frame_h: pair.frame_px[1],
        x0: pair.crop[0],
        y0: pair.crop[1],
        w: pair.crop[2],
        h: pair.crop[3],
    }
}

/// What every pair and patch of a run shares: the dataset, what the methods read, the metric networks.
pub(crate) struct Pass<'a> {
    pub dataset: &'a Dataset,
    pub pairs: &'a [PairRow],
    pub lenses: &'a BTreeMap<String, LensInfo>,
    pub needs: Needs,
    pub tables: LensTables<'a>,
    pub judges: Judges,
    pub running: Running<'a>,
}

impl Pass<'_> {
    /// One test pair through every method: its inputs made once, each restoration scored (a method
    /// that fails on it is listed under the method's failures).
    pub fn score_pair(&mut self, pair: &PairRow, entries: &mut [Entry], scores: &mut Scores) -> Result<()> {
        let Pass {
            dataset,
            lenses,
            needs,
            tables,
            judges,
            running,
            ..
        } = self;
        let lq_path = dataset.resolve(&pair.lq)?;
        let gt_path = dataset.resolve(&pair.gt)?;
        let (lq, gt) = (read_rgb(&lq_path)?, read_rgb(&gt_path)?);
        if (lq.width, lq.height) != (gt.width, gt.height) {
            return Err(invalid(format!(
                "{} and {} differ in size",
                lq_path.display(),
                gt_path.display()
            )));
        }
        let crop = frame_crop(pair);
        if (crop.w, crop.h) != (lq.width, lq.height) {
            return Err(invalid(format!(
                "pairs.jsonl: pair {} crop {:?} does not match its {}x{} image",
                pair.pair_id, pair.crop, lq.width, lq.height
            )));
        }
        let table = if needs.table {
            Some(tables.table(&pair.psf, &pair.lens_id)?)
        } else {
            None
        };
        let fov = if needs.maps.fov {
            Some(to_planar(unicac_dataset::fov_map(crop)?))
        } else {
            None
        };
        let psf = match (&table, needs.maps.psf) {
            (Some(t), true) => Some(to_planar(unicac_dataset::psf_feature_map(t, crop)?)),
            _ => None,
        };
        let psf_code = match (&table, needs.maps.psf_code) {
            (Some(t), true) => Some(to_planar(unicac_dataset::psf_code_map(
                &tables.codes(t, &pair.lens_id),
                crop,
            )?)),
            _ => None,
        };
        let wiener_inputs = needs
            .wiener_nsrs
            .iter()
            .map(|&nsr| {
                let t = table.as_ref().expect("PSF table loaded");
                Ok((
                    nsr.to_bits(),
                    crate::wiener::wiener_restore(&lq, t, &|r, c| crop.normalised(r, c), nsr)?,
                ))
            })
            .collect::<Result<WienerEstimates>>()?;
        if let Some(net) = judges.fid.as_mut() {
            scores
                .gt_features
                .insert(pair.pair_id.clone(), net.features(&gt)?);
        }
        let level = lenses[&pair.lens_id]
            .levels
            .get(&Benchmark::Ode)
            .copied()
            .unwrap_or(0);
        for entry in entries.iter_mut() {
            let restored = match &mut entry.method {
                Method::Identity => Ok(lq.clone()),
                Method::Wiener { nsr } => wiener_at(&wiener_inputs, *nsr, || {
                    crate::wiener::wiener_restore(
                        &lq,
                        table.as_ref().expect("PSF table loaded"),
                        &|r, c| crop.normalised(r, c),
                        *nsr,
                    )
                }),
                Method::Onnx { contract, session } => {
                    let maps = InputMaps {
                        fov: fov.as_ref(),
                        psf: psf.as_ref(),
                        psf_code: psf_code.as_ref(),
                        wiener: wiener_input(contract, &wiener_inputs),
                    };
                    run_onnx_with(session, contract, &lq, &maps, running.tiling)
                }
            };
            let restored = match restored {
                Ok(r) => r,
                Err(e) => {
                    entry.info.failures.push(format!("{}: {e}", lq_path.display()));
                    continue;
                }
            };
            scores.pairs.push(score_restored(
                pair,
                level,
                &entry.info.name,
                &restored,
                &gt,
                judges,
            )?);
            if let Some(root) = running.save_images_under {
                save_restored(root, &entry.info.name, &pair.pair_id, &restored)?;
            }
        }
        Ok(())
    }
}

/// The metrics of one restoration against its ground truth.
fn score_restored(
    pair: &PairRow,
    level: u8,
    model: &str,
    restored: &Planar,
    gt: &Planar,
    judges: &mut Judges,
) -> Result<PairScore> {
    let psnr_db =
        unicac_metrics::psnr_pyiqa(restored, gt).map_err(|e| BenchError::metrics(&pair.pair_id, e))?;
    let ssim = unicac_metrics::ssim_pyiqa(restored, gt).map_err(|e| BenchError::metrics(&pair.pair_id, e))?;
    let lpips = match judges.lpips.as_mut() {
        Some(l) => Some(l.distance(restored, gt)?),
        None => None,
    };
    let clipiqa = match judges.clip.as_mut() {
        Some(c) => Some(c.score(restored)?),
        None => None,
    };
    let features = match judges.fid.as_mut() {
        Some(net) => Some(net.features(restored)?),
        None => None,
    };
    Ok(PairScore {
        model: model.to_string(),
        pair_id: pair.pair_id.clone(),
        lens_id: pair.lens_id.clone(),
        level,
        psnr_db,
        ssim,
        lpips,
        clipiqa,
        features,
    })
}

fn save_restored(root: &Path, model: &str, pair_id: &str, restored: &Planar) -> Result<()> {
    let path: PathBuf = root.join("images").join(model).join(format!("{pair_id}.png"));
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| BenchError::io(parent, e))?;
    }
    write_png(&path, restored, SampleDepth::Eight)?;
    Ok(())
}

/// The slanted-edge summaries of each (method, lens).
pub(crate) type EdgeScores = BTreeMap<(String, String), Vec<unicac_metrics::MtfSummary>>;

impl Pass<'_> {
    /// One lens's edge patches through every method: the slanted-edge summary of each restored patch,
    /// gathered per (method, lens) into `edge_scores`.
    pub fn score_lens_edges(
        &mut self,
        rows: &[EdgeRow],
        groups: &[EdgeGroup],
        entries: &mut [Entry],
        edge_scores: &mut EdgeScores,
    ) -> Result<()> {
        let Pass {
            dataset,
            pairs,
            needs,
            tables,
            running,
            ..
        } = self;
        let tiling = running.tiling;
        let lens_id = &rows[0].lens_id;
        let table = if needs.table {
            let lens_pair = pairs
                .iter()
                .find(|p| &p.lens_id == lens_id)
                .expect("lens has pairs");
            Some(tables.table(&lens_pair.psf, lens_id)?)
        } else {
            None
        };
        let codes = match (&table, needs.maps.psf_code) {
            (Some(t), true) => Some(tables.codes(t, lens_id)),
            _ => None,
        };
        let half_diagonal_px = frames_half_diagonal(pairs);
        let patches = groups
            .iter()
            .map(|group| {
                EdgePatch::load(
                    dataset,
                    group,
                    half_diagonal_px,
                    needs.maps,
                    table.as_ref(),
                    codes.as_ref(),
                    &needs.wiener_nsrs,
                )
            })
            .collect::<Result<Vec<_>>>()?;
        for entry in entries.iter_mut() {
            let restored = restore_patches(&mut entry.method, &patches, table.as_ref(), tiling);
            for (patch, restored) in patches.iter().zip(restored) {
                for (_, path, channel) in &patch.rows {
                    let score = restored.as_ref().map_err(|e| e.to_string()).and_then(|r| {
                        patch
                            .score(r, *channel)
                            .map_err(|e| format!("slanted edge of the restored patch: {e}"))
                    });
                    match score {
                        Ok(score) => {
                            if let EdgeScore::Destroyed(why) = &score {
                                entry.info.failures.push(format!(
                                    "{}: slanted edge of the restored patch: no usable edge: {why} (scored as a zero MTF, OIQE 0)",
                                    path.display()
                                ));
                            }
                            edge_scores
                                .entry((entry.info.name.clone(), lens_id.clone()))
                                .or_default()
                                .push(score.summary())
                        }
                        Err(e) => entry.info.failures.push(format!("{}: {e}", path.display())),
                    }
                }
            }
        }
        Ok(())
    }
}

/// The half-diagonal (px) of the frames the pairs were rendered at.
fn frames_half_diagonal(pairs: &[PairRow]) -> f64 {
    let [w, h] = pairs[0].frame_px;
    unicac_dataset::half_diagonal_px(w, h)
}

/// Restores a lens's edge patches with one method. A model that leaves the batch free runs them in
/// batches (one call each, untiled: patches are smaller than any useful tile); should a batch fail as a
/// whole, its patches are retried one by one so each failure is its own.
fn restore_patches(
    method: &mut Method,
    patches: &[EdgePatch],
    table: Option<&PsfTable>,
    tiling: Tiling,
) -> Vec<Result<Planar>> {
    match method {
        Method::Identity => patches.iter().map(|p| Ok(p.lq.clone())).collect(),
        Method::Wiener { nsr } => patches
            .iter()
            .map(|p| p.wiener_restoration(table.expect("PSF table loaded"), *nsr))
            .collect(),
        Method::Onnx { contract, session } => {
            let one_by_one = |session: &mut Session, batch: &[EdgePatch]| -> Vec<Result<Planar>> {
                batch
                    .iter()
                    .map(|p| run_onnx_with(session, contract, &p.lq, &p.maps(contract), tiling))
                    .collect()
            };
            let fits_a_tile =
                |p: &EdgePatch| tiling.tile_px.is_none_or(|t| p.lq.width <= t && p.lq.height <= t);
            if !contract.dynamic_batch || !patches.iter().all(fits_a_tile) {
                return one_by_one(session, patches);
            }
            let mut out = Vec::with_capacity(patches.len());
            for batch in crate::edges::batches(patches) {
                let images: Vec<(&Planar, InputMaps)> =
                    batch.iter().map(|p| (&p.lq, p.maps(contract))).collect();
                match run_onnx_batch(session, contract, &images) {
                    Ok(restored) => out.extend(restored),
                    Err(_) => out.extend(one_by_one(session, batch)),
                }
            }
            out
        }
    }
}
