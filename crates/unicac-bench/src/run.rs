//! `unicac bench`: every check first (settings, models against the contract, onnxruntime, the dataset's
//! split and the inputs each model declares, metric weights), then every pair of the split through every
//! method, then the report.

use std::collections::BTreeMap;
use std::path::PathBuf;

use unicac_dataset::folder::Dataset;
use unicac_dataset::{FrameCrop, PairRow, PsfTable};
use unicac_image::io::{write_png, SampleDepth};
use unicac_image::Planar;

use crate::choices::{Benchmark, ClassicalMethod, Metric, Split};
use crate::clipiqa::ClipIqa;
use crate::contract::{load_model, ModelContract, ModelInput};
use crate::edges::{edge_groups, EdgePatch, MapNeeds};
use crate::error::{BenchError, Result};
use crate::fid::FidNetwork;
use crate::inputs::{dataset_error, wiener_at, wiener_input, WienerEstimates};
pub use crate::inputs::{read_rgb, InputMaps};
use crate::lpips::Lpips;
use crate::onnx::proto::ModelProto;
use crate::ort_library::Search;
use crate::report::write::{write_report, ModelInfo, Report};
use crate::report::{summarise, LensInfo, PairScore, Scores};
use crate::runtime::{Runtime, Session, Tensor};
use crate::tiling::{run_tiled, Tiling};
use unicac_trace::InvalidParameter;

/// Largest `threads`.
pub const MAX_THREADS: usize = 256;
/// Largest `wiener_nsr`: far past any useful noise-to-signal ratio (the restoration tends to zero).
pub const MAX_WIENER_NSR: f64 = 100.0;

/// What `unicac bench` was asked to do.
#[derive(Debug, Clone)]
pub struct BenchSettings {
    pub dataset: PathBuf,
    /// `NAME=MODEL.onnx` models.
    pub models: Vec<(String, PathBuf)>,
    /// Classical methods besides the always-present `identity`.
    pub methods: Vec<ClassicalMethod>,
    pub out: PathBuf,
    pub split: Split,
    pub benchmarks: Vec<Benchmark>,
    /// Metrics asked for explicitly (`None`: all, unavailable ones reported as null).
    pub metrics: Option<Vec<Metric>>,
    pub weights_dir: Option<PathBuf>,
    /// The cache holding `weights/lpips` (None: no LPIPS).
    pub cache_root: Option<PathBuf>,
    pub tiling: Tiling,
    pub threads: usize,
    pub save_images: bool,
    pub wiener_nsr: f64,
    /// Refuse a run whose estimated peak memory exceeds this (`None`: the memory available now).
    pub memory_limit_bytes: Option<u64>,
    /// Where onnxruntime is looked for.
    pub onnxruntime: Search,
}

/// Progress reports: (work done, total work, what is being done). Work is counted in pixels (each test
/// pair's and edge patch's, through every method), to which a run's time is about proportional, so
/// `done / total` gives a fair estimate of the time left even though pairs are larger than patches.
pub type Progress<'a> = &'a mut dyn FnMut(usize, usize, &str);

enum Method {
    Identity,
    Wiener {
        nsr: f64,
    },
    Onnx {
        contract: ModelContract,
        session: Session,
    },
}

struct Entry {
    info: ModelInfo,
    method: Method,
}

fn invalid(message: String) -> BenchError {
    BenchError::InvalidInput(message)
}

/// A setting out of its range, named by its `BenchSettings` field (each face says it in its own words).
fn bad_setting(field: &'static str, message: String) -> BenchError {
    BenchError::InvalidParameter(InvalidParameter::new(field, message))
}

fn check_settings(s: &BenchSettings) -> Result<()> {
    s.tiling.check()?;
    if !(1..=MAX_THREADS).contains(&s.threads) {
        return Err(bad_setting(
            "threads",
            format!("{}: must be between 1 and {MAX_THREADS}", s.threads),
        ));
    }
    if s.benchmarks.is_empty() {
        return Err(bad_setting(
            "benchmarks",
            "(none given): give at least one of ode, us, uc".into(),
        ));
    }
    // NaN would restore every pair to NaN (each one a failure) and 0 divides by the PSF's zeros.
    if !(s.wiener_nsr > 0.0 && s.wiener_nsr <= MAX_WIENER_NSR) {
        return Err(bad_setting(
            "wiener_nsr",
            format!("{:?}: must lie in (0, {MAX_WIENER_NSR}]", s.wiener_nsr),
        ));
    }
    if s.memory_limit_bytes == Some(0) {
        return Err(bad_setting("memory_limit_bytes", "0: must be positive".into()));
    }
    let mut names: Vec<&str> = vec!["identity", "wiener"];
    for (name, _) in &s.models {
        let ok = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
        if !ok {
            return Err(bad_setting(
                "models",
                format!("{name}=...: names use letters, digits, '-', '_' and '.'"),
            ));
        }
        if names.contains(&name.as_str()) {
            return Err(bad_setting("models", format!("{name}=...: the name is taken")));
        }
        names.push(name);
    }
    // The report folder is neither the dataset (nor inside it) nor a model file (the report would mix
    // with the dataset's own files, or replace a model).
    let mut plan = unicac_io::OutputPlan::new();
    plan.input_folder(&s.dataset);
    for (_, path) in &s.models {
        plan.input(path);
    }
    plan.output("--out", &s.out);
    plan.check().map_err(|e| invalid(e.to_string()))?;
    crate::report::folder::check(&s.out)
}

fn asked(s: &BenchSettings, metric: Metric) -> bool {
    s.metrics.as_ref().is_some_and(|m| m.contains(&metric))
}

fn wanted(s: &BenchSettings, metric: Metric) -> bool {
    s.metrics.as_ref().is_none_or(|m| m.contains(&metric))
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

/// Runs an ONNX restoration model on `lq` with the maps it declares, tiled as asked.
pub fn run_onnx(
    session: &mut Session,
    contract: &ModelContract,
    lq: &Planar,
    fov: Option<&Planar>,
    psf: Option<&Planar>,
    tiling: Tiling,
) -> Result<Planar> {
    let maps = InputMaps {
        fov,
        psf,
        ..InputMaps::default()
    };
    run_onnx_with(session, contract, lq, &maps, tiling)
}

/// [`run_onnx`] with every contract input available.
pub fn run_onnx_with(
    session: &mut Session,
    contract: &ModelContract,
    lq: &Planar,
    maps: &InputMaps,
    tiling: Tiling,
) -> Result<Planar> {
    let inputs = model_inputs(contract, lq, maps)?;
    let planes: Vec<&Planar> = inputs.iter().map(|(_, p)| *p).collect();
    let out = run_tiled(&planes, tiling, |_, tiles| {
        let named = inputs
            .iter()
            .zip(tiles)
            .map(|((name, _), t)| {
                (
                    *name,
                    Tensor {
                        shape: vec![1, t.channels, t.height, t.width],
                        data: t.data.clone(),
                    },
                )
            })
            .collect();
        let (w, h) = (tiles[0].width, tiles[0].height);
        let mut restored = run_restored(session, named, 1, w, h)?;
        Ok(restored.remove(0))
    })?;
    clamped_output(out)
}

/// Runs `images` (each with its maps; all of one size) through the model as one N x C x H x W batch,
/// untiled: the same outputs as one run per image (a convolutional network treats the batch's images
/// independently), for one call's overhead. Each image's result is checked on its own, so one
/// non-finite output fails only its image.
pub fn run_onnx_batch(
    session: &mut Session,
    contract: &ModelContract,
    images: &[(&Planar, InputMaps)],
) -> Result<Vec<Result<Planar>>> {
    let Some((first, _)) = images.first() else {
        return Ok(Vec::new());
    };
    let (w, h) = (first.width, first.height);
    if images.iter().any(|(lq, _)| (lq.width, lq.height) != (w, h)) {
        return Err(invalid("a batch holds images of one size".into()));
    }
    let per_image: Vec<Vec<(&'static str, &Planar)>> = images
        .iter()
        .map(|(lq, maps)| model_inputs(contract, lq, maps))
        .collect::<Result<_>>()?;
    let named = per_image[0]
        .iter()
        .enumerate()
        .map(|(index, (name, plane))| {
            let data = per_image
                .iter()
                .flat_map(|inputs| inputs[index].1.data.iter().copied())
                .collect();
            (
                *name,
                Tensor {
                    shape: vec![images.len(), plane.channels, h, w],
                    data,
                },
            )
        })
        .collect();
    let restored = run_restored(session, named, images.len(), w, h)?;
    Ok(restored.into_iter().map(clamped_output).collect())
}

/// The graph inputs `contract` declares, named, `lq` first.
fn model_inputs<'a>(
    contract: &ModelContract,
    lq: &'a Planar,
    maps: &InputMaps<'a>,
) -> Result<Vec<(&'static str, &'a Planar)>> {
    let mut inputs: Vec<(&'static str, &Planar)> = vec![("lq", lq)];
    for (input, map) in [
        (ModelInput::Fov, maps.fov),
        (ModelInput::Psf, maps.psf),
        (ModelInput::PsfCode, maps.psf_code),
        (ModelInput::Wiener, maps.wiener),
    ] {
        if contract.wants(input) {
            let map =
                map.ok_or_else(|| invalid(format!("model input `{}` is not available", input.name())))?;
            inputs.push((input.name(), map));
        }
    }
    Ok(inputs)
}

/// One session run; `restored` split into its `batch` images of `w` x `h`.
fn run_restored(
    session: &mut Session,
    named: Vec<(&str, Tensor)>,
    batch: usize,
    w: usize,
    h: usize,
) -> Result<Vec<Planar>> {
    let result = session.run(named, &["restored"])?.remove(0);
    if result.shape != [batch, 3, h, w] {
        return Err(invalid(format!(
            "`restored` has shape {:?}, expected [{batch}, 3, {h}, {w}]",
            result.shape
        )));
    }
    Ok(result
        .data
        .chunks_exact(3 * w * h)
        .map(|image| Planar {
            width: w,
            height: h,
            channels: 3,
            data: image.to_vec(),
        })
        .collect())
}

/// The contract's reading of `restored`: non-finite values are an error, others clamped to [0, 1].
fn clamped_output(mut out: Planar) -> Result<Planar> {
    if out.data.iter().any(|v| !v.is_finite()) {
        return Err(invalid("the model returned NaN or infinite values".into()));
    }
    out.data.iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0));
    Ok(out)
}

/// The whole benchmark; returns the report and the files written.
pub fn run_bench(s: &BenchSettings, progress: Progress) -> Result<(Report, Vec<PathBuf>)> {
    check_settings(s)?;
    let mut notices = Vec::new();
    // Models first: a bad file is refused before anything else happens.
    let mut loaded: Vec<(String, ModelContract, ModelProto, Vec<u8>)> = Vec::new();
    for (name, path) in &s.models {
        let (contract, model, bytes) = load_model(path)?;
        loaded.push((name.clone(), contract, model, bytes));
    }
    let needs_runtime = !loaded.is_empty()
        || [Metric::Lpips, Metric::Fid, Metric::ClipIqa]
            .into_iter()
            .any(|m| asked(s, m));
    let runtime = if needs_runtime {
        Some(Runtime::load_with(&s.onnxruntime)?)
    } else {
        match Runtime::load_with(&s.onnxruntime) {
            Ok(r) => Some(r),
            Err(e) => {
                notices.push(format!("LPIPS, FID and ClipIQA unavailable: {e}"));
                None
            }
        }
    };
    let dataset = Dataset::open(&s.dataset).map_err(dataset_error)?;
    let lens_rows = dataset.lenses().map_err(dataset_error)?;
    let pairs: Vec<PairRow> = dataset
        .pairs()
        .map_err(dataset_error)?
        .into_iter()
        .filter(|p| p.split == s.split.name())
        .collect();
    if pairs.is_empty() {
        return Err(invalid(format!(
            "{}: the dataset has no `{}` split (no pairs); build it with a {} split",
            s.dataset.display(),
            s.split,
            s.split
        )));
    }
    let lenses: BTreeMap<String, LensInfo> = lens_rows
        .iter()
        .filter(|l| pairs.iter().any(|p| p.lens_id == l.lens_id))
        .map(|l| {
            let mut levels = BTreeMap::new();
            for (b, v) in [
                (Benchmark::Ode, l.level),
                (Benchmark::Us, l.us_level),
                (Benchmark::Uc, l.uc_level),
            ] {
                if let Some(v) = v {
                    levels.insert(b, v as u8);
                }
            }
            (
                l.lens_id.clone(),
                LensInfo {
                    lens_id: l.lens_id.clone(),
                    levels,
                    ode: l.scores.ode,
                    rms_radius_um: l.scores.rms_radius_um,
                },
            )
        })
        .collect();
    for pair in &pairs {
        if !lenses.contains_key(&pair.lens_id) {
            return Err(invalid(format!(
                "pairs.jsonl: pair {} names lens {} that lenses.jsonl lacks",
                pair.pair_id, pair.lens_id
            )));
        }
    }
    let has_psf = pairs.iter().all(|p| !p.psf.is_empty());
    let has_fov = pairs.iter().all(|p| !p.fov.is_empty());
    for (name, contract, ..) in &loaded {
        for input in &contract.inputs {
            let available = match input {
                ModelInput::Lq => true,
                ModelInput::Fov => has_fov,
                ModelInput::Psf | ModelInput::PsfCode | ModelInput::Wiener => has_psf,
            };
            if !available {
                return Err(invalid(format!(
                    "model {name} ({}) asks for input `{}`, which the dataset {} does not provide",
                    contract.path.display(),
                    input.name(),
                    s.dataset.display()
                )));
            }
        }
    }
    // A `psf_code` model reads codes in the basis it was trained with: the dataset's must be that one.
    let needs_basis = loaded.iter().any(|(_, c, ..)| c.wants(ModelInput::PsfCode));
    let basis = if needs_basis {
        let basis = unicac_dataset::psf_basis::read_dataset_basis(&s.dataset).map_err(dataset_error)?;
        for (name, contract, ..) in &loaded {
            match &contract.psf_basis_sha256 {
                Some(sha) if contract.wants(ModelInput::PsfCode) && *sha != basis.meta.sha256 => {
                    return Err(invalid(format!(
                        "model {name} ({}) was trained with PSF basis {sha}, but the dataset {} has basis {}; \
                         a psf_code model only runs on a dataset with its basis",
                        contract.path.display(),
                        s.dataset.display(),
                        basis.meta.sha256
                    )))
                }
                _ => {}
            }
        }
        Some(basis)
    } else {
        None
    };
    if s.methods.contains(&ClassicalMethod::Wiener) && !has_psf {
        return Err(bad_setting(
            "methods",
            format!(
                "wiener needs the dataset's PSF tables; {} has none",
                s.dataset.display()
            ),
        ));
    }
    // Metrics and their weights.
    let unavailable = |metric: Metric, why: String, notices: &mut Vec<String>| -> Result<()> {
        if asked(s, metric) {
            return Err(bad_setting("metrics", format!("{metric}: {why}")));
        }
        notices.push(format!("{metric} reported as null: {why}"));
        Ok(())
    };
    let mut lpips = None;
    if wanted(s, Metric::Lpips) {
        match (runtime, &s.cache_root) {
            (Some(rt), Some(cache)) => match Lpips::load(rt, cache, s.threads) {
                Ok(l) => lpips = Some(l),
                Err(e) => unavailable(Metric::Lpips, e.to_string(), &mut notices)?,
            },
            (None, _) => unavailable(Metric::Lpips, "onnxruntime is not available".into(), &mut notices)?,
            (_, None) => unavailable(
                Metric::Lpips,
                "no cache folder (set UNICAC_CACHE_DIR)".into(),
                &mut notices,
            )?,
        }
    }
    let weights_dir = s.weights_dir.clone();
    let mut fid = None;
    let mut clip = None;
    if wanted(s, Metric::Fid) {
        match (runtime, &weights_dir) {
            (Some(rt), Some(dir)) => match FidNetwork::load(rt, dir, s.threads)? {
                Some(net) => fid = Some(net),
                None => unavailable(
                    Metric::Fid,
                    format!("no {} in the weights folder", crate::fid::FID_NETWORK),
                    &mut notices,
                )?,
            },
            _ => unavailable(
                Metric::Fid,
                "needs a weights folder holding fid/inception.onnx, and onnxruntime".into(),
                &mut notices,
            )?,
        }
    }
    if wanted(s, Metric::ClipIqa) {
        match (runtime, &weights_dir) {
            (Some(rt), Some(dir)) => match ClipIqa::load(rt, dir, s.threads)? {
                Some(c) => clip = Some(c),
                None => unavailable(
                    Metric::ClipIqa,
                    format!(
                        "no {} and {} in the weights folder",
                        crate::clipiqa::CLIPIQA_ENCODER,
                        crate::clipiqa::CLIPIQA_PROMPTS
                    ),
                    &mut notices,
                )?,
            },
            _ => unavailable(
                Metric::ClipIqa,
                "needs a weights folder holding the clipiqa/ weights, and onnxruntime".into(),
                &mut notices,
            )?,
        }
    }
    let edges = if wanted(s, Metric::Oiqe) {
        let rows = if dataset.dir.join(unicac_dataset::manifest::EDGES_JSONL).is_file() {
            dataset.edges().map_err(dataset_error)?
        } else {
            Vec::new()
        };
        let rows: Vec<_> = rows
            .into_iter()
            .filter(|e| lenses.contains_key(&e.lens_id))
            .collect();
        if rows.is_empty() {
            unavailable(
                Metric::Oiqe,
                "the dataset has no edge patches (edges.jsonl) for these lenses".into(),
                &mut notices,
            )?;
        }
        rows
    } else {
        Vec::new()
    };
    let available = Metric::ALL
        .iter()
        .map(|&m| {
            let computed = match m {
                Metric::Psnr | Metric::Ssim => true,
                Metric::Lpips => lpips.is_some(),
                Metric::Oiqe => !edges.is_empty(),
                Metric::Fid => fid.is_some(),
                Metric::ClipIqa => clip.is_some(),
            };
            (m, computed)
        })
        .collect();
    check_memory(s, &pairs, lpips.is_some())?;
    // Every check passed: the report folder is made (or a previous report cleared) before the work.
    let created = crate::report::folder::claim(&s.out)?;
    let result = benchmark(
        s,
        progress,
        Checked {
            notices,
            loaded,
            runtime,
            dataset,
            pairs,
            lenses,
            has_psf,
            available,
            lpips,
            fid,
            clip,
            edges,
            basis,
        },
    );
    if result.is_err() && created {
        let _ = std::fs::remove_dir_all(&s.out);
    }
    result
}

/// The largest pair's peak-memory estimate against the limit (given, else the memory available now).
fn check_memory(s: &BenchSettings, pairs: &[PairRow], lpips: bool) -> Result<()> {
    let Some(largest) = pairs.iter().max_by_key(|p| p.crop[2] as u64 * p.crop[3] as u64) else {
        return Ok(());
    };
    let plan = crate::memory::MemoryPlan {
        pair_px: largest.crop[2] as u64 * largest.crop[3] as u64,
        lpips,
        models: !s.models.is_empty(),
        tiled: s.tiling.tile_px.is_some(),
    };
    use crate::memory::MemoryLimit;
    let (limit_bytes, limit) = match s.memory_limit_bytes {
        Some(limit_bytes) => (limit_bytes, MemoryLimit::Setting),
        None => match crate::memory::available_bytes() {
            Some(available) => (available, MemoryLimit::Available),
            None => return Ok(()),
        },
    };
    plan.check(limit_bytes, limit, [largest.crop[2], largest.crop[3]])
        .map_err(BenchError::MemoryExceeded)
}

/// What the checks of `run_bench` hand to the work.
struct Checked {
    notices: Vec<String>,
    loaded: Vec<(String, ModelContract, ModelProto, Vec<u8>)>,
    runtime: Option<&'static Runtime>,
    dataset: Dataset,
    pairs: Vec<PairRow>,
    lenses: BTreeMap<String, LensInfo>,
    has_psf: bool,
    /// Whether each metric is computed (the others are reported as null).
    available: BTreeMap<Metric, bool>,
    lpips: Option<Lpips>,
    fid: Option<FidNetwork>,
    clip: Option<ClipIqa>,
    edges: Vec<unicac_dataset::EdgeRow>,
    /// The dataset's PSF basis, read when a model takes `psf_code`.
    basis: Option<unicac_dataset::psf_basis::PsfBasis>,
}

/// Every pair through every method, then the report.
fn benchmark(s: &BenchSettings, progress: Progress, checked: Checked) -> Result<(Report, Vec<PathBuf>)> {
    let Checked {
        mut notices,
        loaded,
        runtime,
        dataset,
        pairs,
        lenses,
        has_psf,
        available,
        mut lpips,
        mut fid,
        mut clip,
        edges,
        basis,
    } = checked;
    // Methods.
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
    let wants_wiener = s.methods.contains(&ClassicalMethod::Wiener);
    if wants_wiener {
        entries.push(Entry {
            info: ModelInfo {
                name: "wiener".into(),
                kind: "wiener".into(),
                path: None,
                inputs: vec!["lq".into(), "psf table".into()],
                metadata: BTreeMap::from([("nsr".to_string(), s.wiener_nsr.to_string())]),
                cost: None,
                failures: Vec::new(),
            },
            method: Method::Wiener { nsr: s.wiener_nsr },
        });
    }
    for (name, contract, model, bytes) in loaded {
        let rt = runtime.expect("checked above");
        let cost = match crate::cost::measure(rt, &contract, &model, s.threads) {
            Ok(c) => Some(c),
            Err(e) => {
                notices.push(format!("model {name}: cost not measured ({e})"));
                None
            }
        };
        let session = rt.session(
            &bytes,
            s.threads,
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
    // The pairs.
    let mut scores = Scores::default();
    let mut tables: BTreeMap<String, PsfTable> = BTreeMap::new();
    let mut table_for = |pair_psf: &str, lens_id: &str| -> Result<PsfTable> {
        if let Some(t) = tables.get(lens_id) {
            return Ok(t.clone());
        }
        let dir = dataset.resolve(pair_psf).map_err(dataset_error)?;
        let table = PsfTable::read(&dir).map_err(dataset_error)?;
        tables.insert(lens_id.to_string(), table.clone());
        Ok(table)
    };
    let wants = |input: ModelInput| {
        entries
            .iter()
            .any(|e| matches!(&e.method, Method::Onnx { contract, .. } if contract.wants(input)))
    };
    let needs_psf_map = wants(ModelInput::Psf);
    let needs_fov_map = wants(ModelInput::Fov);
    let needs_code_map = wants(ModelInput::PsfCode);
    // The noise-to-signal ratios of the Wiener estimates the models take as input (one per distinct
    // ratio and image).
    let mut wiener_nsrs: Vec<f64> = entries
        .iter()
        .filter_map(|e| match &e.method {
            Method::Onnx { contract, .. } => contract.wiener_input_nsr(),
            _ => None,
        })
        .collect();
    wiener_nsrs.sort_by(f64::total_cmp);
    wiener_nsrs.dedup();
    let mut codes: BTreeMap<String, unicac_dataset::FieldCodes> = BTreeMap::new();
    let mut codes_for = |table: &PsfTable, lens_id: &str| -> unicac_dataset::FieldCodes {
        codes
            .entry(lens_id.to_string())
            .or_insert_with(|| basis.as_ref().expect("basis read").field_codes(table))
            .clone()
    };
    // Methods or maps that read the lens's PSF table.
    let needs_table = has_psf && (needs_psf_map || needs_code_map || !wiener_nsrs.is_empty() || wants_wiener);
    // The edge rows by lens, and the images each lens's rows are restored as (an R, G, B triple shares one).
    let edge_lenses: Vec<(&[unicac_dataset::EdgeRow], Vec<crate::edges::EdgeGroup>)> = edges
        .chunk_by(|a, b| a.lens_id == b.lens_id)
        .map(|rows| (rows, edge_groups(rows)))
        .collect();
    let pair_px = |p: &PairRow| p.crop[2] * p.crop[3];
    let edge_px = |groups: &[crate::edges::EdgeGroup]| -> usize {
        groups.iter().map(|g| g[0].size_px * g[0].size_px).sum()
    };
    let pairs_px: usize = pairs.iter().map(pair_px).sum();
    let total = pairs_px + edge_lenses.iter().map(|(_, g)| edge_px(g)).sum::<usize>();
    let mut done = 0;
    for pair in &pairs {
        progress(done, total, &pair.pair_id);
        done += pair_px(pair);
        let lq_path = dataset.resolve(&pair.lq).map_err(dataset_error)?;
        let gt_path = dataset.resolve(&pair.gt).map_err(dataset_error)?;
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
        let table = if needs_table {
            Some(table_for(&pair.psf, &pair.lens_id)?)
        } else {
            None
        };
        let fov = if needs_fov_map {
            Some(to_planar(unicac_dataset::fov_map(crop).map_err(dataset_error)?))
        } else {
            None
        };
        let psf = match (&table, needs_psf_map) {
            (Some(t), true) => Some(to_planar(
                unicac_dataset::psf_feature_map(t, crop).map_err(dataset_error)?,
            )),
            _ => None,
        };
        let psf_code = match (&table, needs_code_map) {
            (Some(t), true) => Some(to_planar(
                unicac_dataset::psf_code_map(&codes_for(t, &pair.lens_id), crop).map_err(dataset_error)?,
            )),
            _ => None,
        };
        let wiener_inputs = wiener_nsrs
            .iter()
            .map(|&nsr| {
                let t = table.as_ref().expect("PSF table loaded");
                Ok((
                    nsr.to_bits(),
                    crate::wiener::wiener_restore(&lq, t, &|r, c| crop.normalised(r, c), nsr)?,
                ))
            })
            .collect::<Result<WienerEstimates>>()?;
        let gt_features = match fid.as_mut() {
            Some(net) => Some(net.features(&gt)?),
            None => None,
        };
        if let Some(f) = gt_features {
            scores.gt_features.insert(pair.pair_id.clone(), f);
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
                    run_onnx_with(session, contract, &lq, &maps, s.tiling)
                }
            };
            let restored = match restored {
                Ok(r) => r,
                Err(e) => {
                    entry.info.failures.push(format!("{}: {e}", lq_path.display()));
                    continue;
                }
            };
            let psnr_db = unicac_metrics::psnr_pyiqa(&restored, &gt)
                .map_err(|e| BenchError::metrics(&pair.pair_id, e))?;
            let ssim = unicac_metrics::ssim_pyiqa(&restored, &gt)
                .map_err(|e| BenchError::metrics(&pair.pair_id, e))?;
            let lpips_value = match lpips.as_mut() {
                Some(l) => Some(l.distance(&restored, &gt)?),
                None => None,
            };
            let clip_value = match clip.as_mut() {
                Some(c) => Some(c.score(&restored)?),
                None => None,
            };
            let features = match fid.as_mut() {
                Some(net) => Some(net.features(&restored)?),
                None => None,
            };
            if s.save_images {
                let path = s
                    .out
                    .join("images")
                    .join(&entry.info.name)
                    .join(format!("{}.png", pair.pair_id));
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| BenchError::io(parent, e))?;
                }
                write_png(&path, &restored, SampleDepth::Eight)?;
            }
            scores.pairs.push(PairScore {
                model: entry.info.name.clone(),
                pair_id: pair.pair_id.clone(),
                lens_id: pair.lens_id.clone(),
                level,
                psnr_db,
                ssim,
                lpips: lpips_value,
                clipiqa: clip_value,
                features,
            });
        }
    }
    // OIQE of the restored edge patches, a lens at a time: each model runs a lens's patches as batches.
    let mut edge_scores: BTreeMap<(String, String), Vec<unicac_metrics::MtfSummary>> = BTreeMap::new();
    let needs = MapNeeds {
        fov: needs_fov_map,
        psf: needs_psf_map,
        psf_code: needs_code_map,
    };
    let half_diagonal_px = lenses_half_diagonal(&pairs);
    for (rows, groups) in &edge_lenses {
        progress(done, total, &rows[0].edge_id);
        done += edge_px(groups);
        let lens_id = &rows[0].lens_id;
        let table = if needs_table {
            let lens_pair = pairs
                .iter()
                .find(|p| &p.lens_id == lens_id)
                .expect("lens has pairs");
            Some(table_for(&lens_pair.psf, lens_id)?)
        } else {
            None
        };
        let codes = match (&table, needs_code_map) {
            (Some(t), true) => Some(codes_for(t, lens_id)),
            _ => None,
        };
        let patches = groups
            .iter()
            .map(|group| {
                EdgePatch::load(
                    &dataset,
                    group,
                    half_diagonal_px,
                    needs,
                    table.as_ref(),
                    codes.as_ref(),
                    &wiener_nsrs,
                )
            })
            .collect::<Result<Vec<_>>>()?;
        for entry in entries.iter_mut() {
            let restored = restore_patches(&mut entry.method, &patches, table.as_ref(), s.tiling);
            for (patch, restored) in patches.iter().zip(restored) {
                for (_, path, channel) in &patch.rows {
                    let summary = restored.as_ref().map_err(|e| e.to_string()).and_then(|r| {
                        patch
                            .score(r, *channel)
                            .map_err(|e| format!("slanted edge of the restored patch: {e}"))
                    });
                    match summary {
                        Ok(summary) => edge_scores
                            .entry((entry.info.name.clone(), lens_id.clone()))
                            .or_default()
                            .push(summary),
                        Err(e) => entry.info.failures.push(format!("{}: {e}", path.display())),
                    }
                }
            }
        }
    }
    for (key, summaries) in edge_scores {
        if let Ok(v) = unicac_metrics::oiqe::oiqe_mean(&summaries, &unicac_metrics::OiqeWeights::default()) {
            scores.oiqe.insert(key, v);
        }
    }
    progress(total, total, "report");
    let names: Vec<String> = entries.iter().map(|e| e.info.name.clone()).collect();
    for e in &entries {
        if !e.info.failures.is_empty() {
            notices.push(format!(
                "{}: {} image(s) failed (listed under models)",
                e.info.name,
                e.info.failures.len()
            ));
        }
    }
    let learned: Vec<String> = entries
        .iter()
        .filter(|e| e.info.kind == "onnx")
        .map(|e| e.info.name.clone())
        .collect();
    let results = summarise(&scores, &names, &learned, &lenses, &s.benchmarks);
    let report = Report {
        unicac_version: env!("CARGO_PKG_VERSION"),
        dataset: s.dataset.clone(),
        split: s.split,
        benchmarks: s.benchmarks.clone(),
        // Keyed by name in the report, so the file lists them in the order of their names.
        metrics: available
            .into_iter()
            .map(|(m, on)| (m.name().to_string(), on))
            .collect(),
        notices,
        onnxruntime: runtime.map(|r| r.located().clone()),
        models: entries.into_iter().map(|e| e.info).collect(),
        results,
    };
    let written = write_report(&s.out, &report, &scores.pairs)?;
    Ok((report, written))
}

/// The half-diagonal (px) of the frames the pairs were rendered at.
fn lenses_half_diagonal(pairs: &[PairRow]) -> f64 {
    let [w, h] = pairs[0].frame_px;
    0.5 * (w as f64).hypot(h as f64)
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
