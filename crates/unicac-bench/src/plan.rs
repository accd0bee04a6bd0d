//! The plan of a bench: every check before any work (settings, models against the contract,
//! onnxruntime, the dataset's split and the inputs each model declares, the PSF basis, metric weights,
//! memory), handed to the work as one value (`Plan`), so a refused run has written nothing.

use std::collections::BTreeMap;

use unicac_dataset::folder::Dataset;
use unicac_dataset::{EdgeRow, PairRow};

use crate::choices::{Benchmark, ClassicalMethod, Metric, Split};
use crate::error::{BenchError, Result};
use crate::report::LensInfo;
use crate::settings::{BenchSettings, MAX_THREADS, MAX_WIENER_NSR};
use unicac_learned_metrics::clipiqa::ClipIqa;
use unicac_learned_metrics::fid::FidNetwork;
use unicac_learned_metrics::lpips::Lpips;
use unicac_onnx::contract::{load_model, ModelContract, ModelInput};
use unicac_onnx::proto::ModelProto;
use unicac_onnx::runtime::Runtime;
use unicac_trace::InvalidParameter;

/// A model as loaded: its name, contract, graph and file bytes.
pub(crate) type LoadedModel = (String, ModelContract, ModelProto, Vec<u8>);

/// What the checks hand to the work.
pub(crate) struct Plan {
    pub notices: Vec<String>,
    pub loaded: Vec<LoadedModel>,
    pub runtime: Option<&'static Runtime>,
    pub dataset: Dataset,
    pub pairs: Vec<PairRow>,
    pub lenses: BTreeMap<String, LensInfo>,
    pub has_psf: bool,
    /// Whether each metric is computed (the others are reported as null).
    pub available: BTreeMap<Metric, bool>,
    pub judges: LearnedJudges,
    pub edges: Vec<EdgeRow>,
    /// The dataset's PSF basis, read when a model takes `psf_code`.
    pub basis: Option<unicac_dataset::psf_basis::PsfBasis>,
    /// For the as-built split: the design lenses' test pairs and the designs, scored beside the units'
    /// pairs so the report can say what each method loses on units as built.
    pub designs: Option<SplitRows>,
}

/// A split's pairs and their lenses.
pub(crate) struct SplitRows {
    pub pairs: Vec<PairRow>,
    pub lenses: BTreeMap<String, LensInfo>,
}

/// The learned metrics that could be loaded.
#[derive(Default)]
pub(crate) struct LearnedJudges {
    pub lpips: Option<Lpips>,
    pub fid: Option<FidNetwork>,
    pub clip: Option<ClipIqa>,
}

/// Every check, in the order a user would want to hear of a fault: settings, then model files, the
/// runtime, the dataset, what the models ask of it, the metrics, the memory.
pub(crate) fn plan(s: &BenchSettings) -> Result<Plan> {
    check_settings(s)?;
    let mut notices = Vec::new();
    // Models first: a bad file is refused before anything else happens.
    let loaded = s
        .models
        .iter()
        .map(|(name, path)| {
            let (contract, model, bytes) = load_model(path)?;
            Ok((name.clone(), contract, model, bytes))
        })
        .collect::<Result<Vec<LoadedModel>>>()?;
    let runtime = runtime(s, !loaded.is_empty(), &mut notices)?;
    let (dataset, SplitRows { pairs, lenses }, designs) = read_split(s)?;
    let has_psf = pairs.iter().all(|p| !p.psf.is_empty());
    let has_fov = pairs.iter().all(|p| !p.fov.is_empty());
    check_model_inputs(s, &loaded, has_psf, has_fov)?;
    let basis = matching_basis(s, &loaded)?;
    if s.methods.contains(&ClassicalMethod::Wiener) && !has_psf {
        return Err(bad_setting(
            "methods",
            format!(
                "wiener needs the dataset's PSF tables; {} has none",
                s.dataset.display()
            ),
        ));
    }
    let judges = learned_judges(s, runtime, &mut notices)?;
    let edges = edge_rows(s, &dataset, &lenses, &mut notices)?;
    let available = Metric::ALL
        .iter()
        .map(|&m| {
            let computed = match m {
                Metric::Psnr | Metric::Ssim => true,
                Metric::Lpips => judges.lpips.is_some(),
                Metric::Oiqe => !edges.is_empty(),
                Metric::Fid => judges.fid.is_some(),
                Metric::ClipIqa => judges.clip.is_some(),
            };
            (m, computed)
        })
        .collect();
    check_memory(s, &pairs, judges.lpips.is_some())?;
    Ok(Plan {
        notices,
        loaded,
        runtime,
        dataset,
        pairs,
        lenses,
        has_psf,
        available,
        judges,
        edges,
        basis,
        designs,
    })
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
    plan.check()?;
    crate::report::folder::check(&s.out)
}

fn asked(s: &BenchSettings, metric: Metric) -> bool {
    s.metrics.as_ref().is_some_and(|m| m.contains(&metric))
}

fn wanted(s: &BenchSettings, metric: Metric) -> bool {
    s.metrics.as_ref().is_none_or(|m| m.contains(&metric))
}

/// onnxruntime: required by models and by learned metrics asked for by name; otherwise loaded when it
/// can be, and its absence noted (LPIPS, FID and ClipIQA then reported as null).
fn runtime(
    s: &BenchSettings,
    has_models: bool,
    notices: &mut Vec<String>,
) -> Result<Option<&'static Runtime>> {
    let needs_runtime = has_models
        || [Metric::Lpips, Metric::Fid, Metric::ClipIqa]
            .into_iter()
            .any(|m| asked(s, m));
    if needs_runtime {
        return Ok(Some(Runtime::load_with(&s.onnxruntime)?));
    }
    Ok(match Runtime::load_with(&s.onnxruntime) {
        Ok(r) => Some(r),
        Err(e) => {
            notices.push(format!("LPIPS, FID and ClipIQA unavailable: {e}"));
            None
        }
    })
}

/// The dataset, the pairs of the asked split and their lenses (each pair's lens must be listed), and
/// for the as-built split the design references.
fn read_split(s: &BenchSettings) -> Result<(Dataset, SplitRows, Option<SplitRows>)> {
    let dataset = Dataset::open(&s.dataset)?;
    if s.split == Split::AsBuilt {
        let [units, designs] = read_as_built(s, &dataset)?;
        return Ok((dataset, units, Some(designs)));
    }
    let split = read_pairs(s, &dataset, s.split)?;
    Ok((dataset, split, None))
}

/// The pairs of split `split` and their lenses (each pair's lens must be listed).
fn read_pairs(s: &BenchSettings, dataset: &Dataset, split: Split) -> Result<SplitRows> {
    let lens_rows = dataset.lenses()?;
    let pairs: Vec<PairRow> = dataset
        .pairs()?
        .into_iter()
        .filter(|p| p.split == split.name())
        .collect();
    if pairs.is_empty() {
        return Err(invalid(format!(
            "{}: the dataset has no `{split}` split (no pairs); build it with a {split} split",
            s.dataset.display(),
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
    if let Some(pair) = pairs.iter().find(|p| !lenses.contains_key(&p.lens_id)) {
        return Err(invalid(format!(
            "pairs.jsonl: pair {} names lens {} that lenses.jsonl lacks",
            pair.pair_id, pair.lens_id
        )));
    }
    Ok(SplitRows { pairs, lenses })
}

/// The as-built split: the units' pairs and the design references' (each unit or reference as a lens:
/// its design's levels, its own ODE and RMS).
fn read_as_built(s: &BenchSettings, dataset: &Dataset) -> Result<[SplitRows; 2]> {
    let Some((units, pairs)) = unicac_dataset::builder::as_built::read_as_built(&dataset.dir)? else {
        return Err(invalid(format!(
            "{}: the dataset has no as-built split; build it with `unicac dataset build --as-built N \
             --tolerances TOL.json`",
            s.dataset.display()
        )));
    };
    let lens_info = |u: &unicac_dataset::builder::as_built::UnitRow| {
        let levels = [
            (Benchmark::Ode, u.level),
            (Benchmark::Us, u.us_level),
            (Benchmark::Uc, u.uc_level),
        ]
        .into_iter()
        .filter_map(|(b, v)| Some((b, v? as u8)))
        .collect();
        let info = LensInfo {
            lens_id: u.unit_id.clone(),
            levels,
            ode: u.scores.ode,
            rms_radius_um: u.scores.rms_radius_um,
        };
        (u.unit_id.clone(), info)
    };
    // The design references (`unit` None) apart from the units.
    let split = |designs: bool| {
        let lenses: BTreeMap<String, LensInfo> = units
            .iter()
            .filter(|u| u.unit.is_none() == designs)
            .map(lens_info)
            .collect();
        let pairs = pairs
            .iter()
            .filter(|p| lenses.contains_key(&p.lens_id))
            .cloned()
            .collect();
        SplitRows { pairs, lenses }
    };
    Ok([split(false), split(true)])
}

/// Every input a model declares is one the dataset provides.
fn check_model_inputs(s: &BenchSettings, loaded: &[LoadedModel], has_psf: bool, has_fov: bool) -> Result<()> {
    for (name, contract, ..) in loaded {
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
    Ok(())
}

/// The dataset's PSF basis when a model takes `psf_code`: a model reads codes in the basis it was
/// trained with, so the dataset's must be that one.
fn matching_basis(
    s: &BenchSettings,
    loaded: &[LoadedModel],
) -> Result<Option<unicac_dataset::psf_basis::PsfBasis>> {
    if !loaded.iter().any(|(_, c, ..)| c.wants(ModelInput::PsfCode)) {
        return Ok(None);
    }
    let basis = unicac_dataset::psf_basis::read_dataset_basis(&s.dataset)?;
    for (name, contract, ..) in loaded {
        match &contract.psf_basis_sha256 {
            Some(sha) if contract.wants(ModelInput::PsfCode) && *sha != basis.meta.sha256 => {
                // `unicac-train export` writes the basis beside the model as NAME.basis/.
                let beside = contract.path.with_extension("basis");
                let holds_it =
                    unicac_dataset::psf_basis::PsfBasis::read(&beside).is_ok_and(|b| b.meta.sha256 == *sha);
                let source = if holds_it {
                    beside.display().to_string()
                } else {
                    "the model's training dataset".to_string()
                };
                return Err(invalid(format!(
                    "model {name} ({}) was trained with PSF basis {sha}, but the dataset {} has basis {}; \
                     a psf_code model only runs on a dataset with its basis (build one with `unicac dataset \
                     build ... --psf-basis-from {source}`)",
                    contract.path.display(),
                    s.dataset.display(),
                    basis.meta.sha256
                )));
            }
            _ => {}
        }
    }
    Ok(Some(basis))
}

/// A metric that cannot be computed: an error when asked for by name, else a notice (reported as null).
fn unavailable(s: &BenchSettings, metric: Metric, why: String, notices: &mut Vec<String>) -> Result<()> {
    if asked(s, metric) {
        return Err(bad_setting("metrics", format!("{metric}: {why}")));
    }
    notices.push(format!("{metric} reported as null: {why}"));
    Ok(())
}

/// LPIPS (weights in the cache), FID and ClipIQA (weights in the weights folder), as far as wanted and
/// available.
fn learned_judges(
    s: &BenchSettings,
    runtime: Option<&'static Runtime>,
    notices: &mut Vec<String>,
) -> Result<LearnedJudges> {
    let mut judges = LearnedJudges::default();
    if wanted(s, Metric::Lpips) {
        match (runtime, &s.cache_root) {
            (Some(rt), Some(cache)) => match Lpips::load(rt, cache, s.threads) {
                Ok(l) => judges.lpips = Some(l),
                Err(e) => unavailable(s, Metric::Lpips, e.to_string(), notices)?,
            },
            (None, _) => unavailable(s, Metric::Lpips, "onnxruntime is not available".into(), notices)?,
            (_, None) => unavailable(
                s,
                Metric::Lpips,
                "no cache folder (set UNICAC_CACHE_DIR)".into(),
                notices,
            )?,
        }
    }
    if wanted(s, Metric::Fid) {
        match (runtime, &s.weights_dir) {
            (Some(rt), Some(dir)) => match FidNetwork::load(rt, dir, s.threads)? {
                Some(net) => judges.fid = Some(net),
                None => unavailable(
                    s,
                    Metric::Fid,
                    format!(
                        "no {} in the weights folder",
                        unicac_learned_metrics::fid::FID_NETWORK
                    ),
                    notices,
                )?,
            },
            _ => unavailable(
                s,
                Metric::Fid,
                "needs a weights folder holding fid/inception.onnx, and onnxruntime".into(),
                notices,
            )?,
        }
    }
    if wanted(s, Metric::ClipIqa) {
        match (runtime, &s.weights_dir) {
            (Some(rt), Some(dir)) => match ClipIqa::load(rt, dir, s.threads)? {
                Some(c) => judges.clip = Some(c),
                None => unavailable(
                    s,
                    Metric::ClipIqa,
                    format!(
                        "no {} and {} in the weights folder",
                        unicac_learned_metrics::clipiqa::CLIPIQA_ENCODER,
                        unicac_learned_metrics::clipiqa::CLIPIQA_PROMPTS
                    ),
                    notices,
                )?,
            },
            _ => unavailable(
                s,
                Metric::ClipIqa,
                "needs a weights folder holding the clipiqa/ weights, and onnxruntime".into(),
                notices,
            )?,
        }
    }
    Ok(judges)
}

/// The slanted-edge patches of the split's lenses, when OIQE is wanted.
fn edge_rows(
    s: &BenchSettings,
    dataset: &Dataset,
    lenses: &BTreeMap<String, LensInfo>,
    notices: &mut Vec<String>,
) -> Result<Vec<EdgeRow>> {
    if !wanted(s, Metric::Oiqe) {
        return Ok(Vec::new());
    }
    let rows = if dataset.dir.join(unicac_dataset::manifest::EDGES_JSONL).is_file() {
        dataset.edges()?
    } else {
        Vec::new()
    };
    let rows: Vec<_> = rows
        .into_iter()
        .filter(|e| lenses.contains_key(&e.lens_id))
        .collect();
    if rows.is_empty() {
        unavailable(
            s,
            Metric::Oiqe,
            "the dataset has no edge patches (edges.jsonl) for these lenses".into(),
            notices,
        )?;
    }
    Ok(rows)
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
