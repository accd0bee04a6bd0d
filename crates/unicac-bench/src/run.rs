//! `unicac bench`: every check first (settings, models against the contract, onnxruntime, the dataset's
//! split and the inputs each model declares, metric weights), then every pair of the split through every
//! method, then the report.

use std::collections::BTreeMap;
use std::path::PathBuf;

use unicac_dataset::folder::Dataset;
use unicac_dataset::PairRow;

use crate::choices::{Benchmark, ClassicalMethod, Metric, Split};
use crate::edges::edge_groups;
use crate::error::{BenchError, Result};
use crate::inputs::dataset_error;
pub use crate::inputs::{read_rgb, InputMaps};
pub use crate::model_run::{run_onnx, run_onnx_batch, run_onnx_with};
use crate::report::write::{write_report, Report};
use crate::report::{summarise, LensInfo, Scores};
use crate::scoring::{method_entries, EdgeScores, Judges, LensTables, Needs, Pass, Running};
use crate::tiling::Tiling;
use unicac_learned_metrics::clipiqa::ClipIqa;
use unicac_learned_metrics::fid::FidNetwork;
use unicac_learned_metrics::lpips::Lpips;
use unicac_onnx::contract::{load_model, ModelContract, ModelInput};
use unicac_onnx::ort_library::Search;
use unicac_onnx::proto::ModelProto;
use unicac_onnx::runtime::Runtime;
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

/// Progress of a run (`unicac_io::progress`): one stage, "test pixels", whose work is counted in pixels
/// (each test pair's and edge patch's, through every method), to which a run's time is about
/// proportional, so the share done gives a fair estimate of the time left even though pairs are larger
/// than patches.
pub use unicac_io::progress::Progress;

/// The name of the bench's one progress stage.
pub const PROGRESS_STAGE: &str = "test pixels";

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

/// The whole benchmark; returns the report and the files written.
pub fn run_bench(s: &BenchSettings, progress: &dyn Progress) -> Result<(Report, Vec<PathBuf>)> {
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
                    format!(
                        "no {} in the weights folder",
                        unicac_learned_metrics::fid::FID_NETWORK
                    ),
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
                        unicac_learned_metrics::clipiqa::CLIPIQA_ENCODER,
                        unicac_learned_metrics::clipiqa::CLIPIQA_PROMPTS
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

/// Every pair and edge patch through every method, then the report.
fn benchmark(s: &BenchSettings, progress: &dyn Progress, checked: Checked) -> Result<(Report, Vec<PathBuf>)> {
    let Checked {
        mut notices,
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
    } = checked;
    let wiener_nsr = s
        .methods
        .contains(&ClassicalMethod::Wiener)
        .then_some(s.wiener_nsr);
    let mut entries = method_entries(wiener_nsr, loaded, runtime, s.threads, &mut notices)?;
    let needs = Needs::of(&entries, has_psf);
    let mut pass = Pass {
        dataset: &dataset,
        pairs: &pairs,
        lenses: &lenses,
        needs,
        tables: LensTables::new(&dataset, basis.as_ref()),
        judges: Judges { lpips, fid, clip },
        running: Running {
            tiling: s.tiling,
            save_images_under: s.save_images.then_some(s.out.as_path()),
        },
    };
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
    progress.stage(PROGRESS_STAGE, total);
    let mut scores = Scores::default();
    for pair in &pairs {
        pass.score_pair(pair, &mut entries, &mut scores)?;
        progress.advance(pair_px(pair));
    }
    // OIQE of the restored edge patches, a lens at a time: each model runs a lens's patches as batches.
    let mut edge_scores = EdgeScores::new();
    for (rows, groups) in &edge_lenses {
        pass.score_lens_edges(rows, groups, &mut entries, &mut edge_scores)?;
        progress.advance(edge_px(groups));
    }
    for (key, summaries) in edge_scores {
        if let Ok(v) = unicac_metrics::oiqe::oiqe_mean(&summaries, &unicac_metrics::OiqeWeights::default()) {
            scores.oiqe.insert(key, v);
        }
    }
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
