//! `unicac dataset build`: grade every lens, choose splits and levels, render the pairs, PSF tables,
//! FoV maps and edge patches (docs/dataset.md).
//!
//! Reproducible by construction: every file is a pure function of the settings (lens content, scenes,
//! seed), every random draw comes from a seed derived from `--seed` and the pair's id, and the
//! manifests are written in a fixed order by every run and every shard alike. Hence:
//! - resume: files are written atomically (dot-named temporary + rename) and skipped when present,
//!   so a killed run started again recomputes only what is missing, with the same bytes;
//! - shards: `--shard I/N` renders the pairs, PSF table and edge patches of the lenses in use whose rank is
//!   I-1 modulo N (whole lenses, so each PSF map is traced by one shard only) and writes
//!   the same manifests; whichever run finds every file present writes `dataset.json` (last, the
//!   completion mark), so N shards in one folder equal the single run byte for byte.
//!
//! Everything that can fail on bad input (lens files, images, the ODE, PSF maps larger than the
//! frame, a library too small) is checked before the first dataset file is written.

pub mod as_built;
pub mod claim;
mod duplicates;
pub mod grading;
pub mod pair_check;
mod placement;
pub mod render;
pub mod sources;
pub mod stratify;
mod unseen;

use crate::error::{DatasetError, Result};
use crate::manifest::{
    self, Counts, DatasetManifest, EdgeRow, LensRow, PairCheck, PairRow, DATASET_JSON, EDGES_JSONL,
    LENSES_CSV, LENSES_JSONL, PAIRS_JSONL, SPLITS,
};
use crate::seeds::{below, derive_seed};
use grading::{BuildSensor, Grade, GradeCache};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
pub use sources::SceneSource;
use sources::{LensSource, Scene};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use stratify::{Assignment, LevelCounts};
use unicac_image::io::SampleDepth;
use unicac_image::isp::Pipeline;
use unicac_image::Planar;
use unicac_optics::Lens;

pub use crate::manifest::PairTask;

/// Every option that decides the dataset's content (recorded as `settings` in `dataset.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BuildSettings {
    /// Lens files, folders, `unicac design` libraries or `builtin:NAME`, as given.
    pub lenses: Vec<String>,
    /// Scenes of the training and validation pairs: a folder, a file or `dead-leaves:N[:WxH]`.
    pub images: SceneSource,
    /// Scenes of the test pairs (disjoint from `images`).
    pub test_images: SceneSource,
    /// Sensor frame (px); None: the first test scene's size.
    pub frame_px: Option<[usize; 2]>,
    /// Pixel pitch (um) for grading and rendering; None: the lens's largest field fills the frame's
    /// half-diagonal.
    pub pixel_um: Option<f64>,
    pub levels: usize,
    pub test_lenses_per_level: usize,
    pub val_lenses: usize,
    pub sub_benchmarks: bool,
    pub pairs_per_lens: usize,
    /// Training/validation patch size (px); None: the whole frame.
    pub crop_px: Option<[usize; 2]>,
    pub seed: u64,
    pub isp: bool,
    pub noise: bool,
    pub white_balance_jitter: f32,
    pub iso: f32,
    pub distortion: bool,
    pub illumination: bool,
    /// What a pair asks a model to undo: `aligned` (blur; the GT carries the lens's geometry) or
    /// `full` (blur, distortion and shading).
    pub task: PairTask,
    /// 8 or 16 (PNG sample depth of the pairs).
    pub bit_depth: u8,
    /// A dataset whose PSF basis this one adopts instead of fitting its own: a held-out test set
    /// scored by models trained on that dataset must express its `psf_code` in their basis. `None`:
    /// fitted on this dataset's training lenses. Left out of the record when `None` (older records
    /// stay valid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub psf_basis_from: Option<std::path::PathBuf>,
    /// The dataset of the models this build is a test set for: none of its training or validation
    /// lenses may be among this build's lenses (refused before any work, builder/unseen.rs). A check
    /// that changes no byte, so it is not part of the build's record: a folder resumes with or without it.
    #[serde(skip)]
    pub unseen_by: Option<std::path::PathBuf>,
    /// Leave out the lenses of `unicac design` libraries flagged as failing basic photographic
    /// usefulness (edge illumination, lateral colour: `ManifestRow::photographic_flags`), so that
    /// the severe levels hold hard optics rather than failed designs. Recorded only when set (older
    /// records stay valid).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub exclude_flagged: bool,
    /// Where the pairs' image passes run: `cpu` (the reference, the default) or `gpu` (through
    /// `image`, which the face opens). A GPU renders within 1e-6 of the CPU (docs/gpu.md), not bit
    /// for bit, so the device is part of the record (only when it is not the CPU: older records stay
    /// valid) and a folder resumes on the device that began it.
    #[serde(default, skip_serializing_if = "RenderDevice::is_cpu")]
    pub device: RenderDevice,
    /// The image device of `device = gpu` (`unicac_sim::ImageBackend`); the CPU path otherwise.
    #[serde(skip)]
    pub image: unicac_sim::ImageBackend,
    /// The as-built split (`as_built`): units per test lens and the tolerances they are drawn within.
    /// Recorded only when asked for (older records stay valid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub as_built: Option<as_built::AsBuiltSettings>,
}

/// The device a dataset's pairs are rendered on (`BuildSettings::device`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RenderDevice {
    #[default]
    Cpu,
    Gpu,
}

impl RenderDevice {
    fn is_cpu(&self) -> bool {
        *self == RenderDevice::Cpu
    }
}

/// Largest `pairs_per_lens`.
pub const MAX_PAIRS_PER_LENS: usize = 100_000;
/// Largest `levels`.
pub use stratify::MAX_LEVELS;
/// Largest `test_lenses_per_level` and `val_lenses`: a build takes at most `MAX_ITEMS` lenses.
pub const MAX_TEST_LENSES_PER_LEVEL: usize = sources::MAX_ITEMS;
pub const MAX_VAL_LENSES: usize = sources::MAX_ITEMS;
/// Most pairs one build plans (each a manifest row held in memory: about 1 kB).
pub const MAX_PAIRS: usize = 10_000_000;
/// Smallest side of a training crop or of the frame (px): every metric scores it (SSIM's Gaussian
/// window is 11 x 11 px).
pub const MIN_CROP_SIDE_PX: usize = 2 * unicac_metrics::ssim::SSIM_RADIUS + 1;

impl BuildSettings {
    /// The defaults of `unicac dataset build` (the paper's 5 levels x 24 test lenses, 75 validation).
    pub fn new(lenses: Vec<String>, images: SceneSource, test_images: SceneSource) -> BuildSettings {
        BuildSettings {
            lenses,
            images,
            test_images,
            frame_px: None,
            pixel_um: None,
            levels: 5,
            test_lenses_per_level: 24,
            val_lenses: 75,
            sub_benchmarks: false,
            pairs_per_lens: 8,
            crop_px: Some([256, 256]),
            seed: 0,
            isp: true,
            noise: true,
            white_balance_jitter: 0.1,
            iso: 100.0,
            distortion: true,
            illumination: true,
            task: PairTask::Aligned,
            bit_depth: 8,
            psf_basis_from: None,
            unseen_by: None,
            exclude_flagged: false,
            device: RenderDevice::Cpu,
            image: unicac_sim::ImageBackend::cpu(),
            as_built: None,
        }
    }

    /// Every setting within its stated limit, before any file is read (errors name the field).
    pub fn check(&self) -> Result<()> {
        let within = |field: &str, value: usize, min: usize, max: usize, limit: &str| {
            if (min..=max).contains(&value) {
                Ok(())
            } else {
                Err(DatasetError::setting(
                    field,
                    format!("{value}: must lie in [{min}, {max}] ({limit})"),
                ))
            }
        };
        within("levels", self.levels, 1, MAX_LEVELS, "MAX_LEVELS")?;
        if self.device == RenderDevice::Gpu && self.image.is_cpu() {
            return Err(DatasetError::setting(
                "device",
                "gpu: no image device was given (`image`); the CLI opens one for `--device gpu`",
            ));
        }
        within(
            "test_lenses_per_level",
            self.test_lenses_per_level,
            1,
            MAX_TEST_LENSES_PER_LEVEL,
            "MAX_TEST_LENSES_PER_LEVEL",
        )?;
        within("val_lenses", self.val_lenses, 0, MAX_VAL_LENSES, "MAX_VAL_LENSES")?;
        within(
            "pairs_per_lens",
            self.pairs_per_lens,
            1,
            MAX_PAIRS_PER_LENS,
            "MAX_PAIRS_PER_LENS",
        )?;
        self.level_counts().lenses_needed()?;
        if let Some(frame) = self.frame_px {
            check_frame(frame)?;
        }
        if let Some(crop) = self.crop_px {
            check_side("crop_px", crop)?;
            if let Some(frame) = self.frame_px {
                if crop[0] > frame[0] || crop[1] > frame[1] {
                    return Err(DatasetError::setting(
                        "crop_px",
                        format!(
                            "{}x{} is larger than the {} x {} frame",
                            crop[0], crop[1], frame[0], frame[1]
                        ),
                    ));
                }
            }
        }
        if !matches!(self.bit_depth, 8 | 16) {
            return Err(DatasetError::setting(
                "bit_depth",
                format!("{}: must be 8 or 16", self.bit_depth),
            ));
        }
        if let Some(p) = self.pixel_um {
            unicac_ode::frame::check_pixel_um(p).map_err(|e| DatasetError::setting("pixel_um", e.message))?;
        }
        if !(self.iso.is_finite() && self.iso > 0.0 && self.iso <= 1.0e6) {
            return Err(DatasetError::setting(
                "iso",
                format!("{}: must be in (0, 1e6]", self.iso),
            ));
        }
        if !(self.white_balance_jitter.is_finite() && (0.0..=1.0).contains(&self.white_balance_jitter)) {
            return Err(DatasetError::setting(
                "white_balance_jitter",
                format!("{}: must be in [0, 1]", self.white_balance_jitter),
            ));
        }
        if let Some(as_built) = &self.as_built {
            as_built.check()?;
        }
        Ok(())
    }

    fn level_counts(&self) -> LevelCounts {
        LevelCounts {
            levels: self.levels,
            per_level: self.test_lenses_per_level,
            val: self.val_lenses,
            sub_benchmarks: self.sub_benchmarks,
        }
    }

    fn pipeline(&self) -> Pipeline {
        let mut pipeline = Pipeline {
            white_balance_jitter: self.white_balance_jitter,
            no_isp: !self.isp,
            no_noise: !self.noise,
            ..Pipeline::default()
        };
        pipeline.sensor.iso = self.iso;
        pipeline
    }
}

/// Which part of the work a run does (`unicac_io::shard`): lens k in use is shard (k mod N) + 1's.
pub use unicac_io::shard::{Shard, MAX_SHARDS};

/// Progress of a build: stages with a known amount of work (the protocol every long job shares).
pub use unicac_io::progress::{Progress, Silent};

/// What a run did.
#[derive(Debug, Clone, Serialize)]
pub struct BuildReport {
    pub out: PathBuf,
    /// Every file of the dataset exists and `dataset.json` is written.
    pub complete: bool,
    pub shard: String,
    pub frame_px: [usize; 2],
    pub lenses: BTreeMap<String, usize>,
    pub pairs: BTreeMap<String, usize>,
    pub edges: usize,
    /// Work this run did (the rest was present or belongs to other shards).
    pub pairs_rendered: usize,
    pub psf_tables_written: usize,
    pub edge_patches_written: usize,
    /// As-built pairs rendered (by the run that completes the dataset, `as_built`).
    pub as_built_pairs_rendered: usize,
    pub odes_computed: usize,
    pub odes_from_cache: usize,
    pub temporaries_removed: usize,
}

/// One lens with everything the plan needs.
struct PlannedLens {
    source: LensSource,
    lens: Lens,
    grade: Grade,
}

/// The dataset as rows, before any pixel is rendered.
pub struct Plan {
    pub frame_px: [usize; 2],
    pub lenses: Vec<LensRow>,
    pub pairs: Vec<PairRow>,
    pub edges: Vec<EdgeRow>,
    pub manifest: DatasetManifest,
}

/// A finished dataset named by a setting (`psf_basis_from`, `unseen_by`), or that setting's error:
/// not a folder, or no `dataset.json` of this format (`Dataset::open`'s message names the folder).
fn other_dataset(field: &str, dir: &Path) -> Result<crate::folder::Dataset> {
    if !dir.is_dir() {
        return Err(DatasetError::setting(
            field,
            format!(
                "{}: not a folder (give a dataset built by `unicac dataset build`)",
                dir.display()
            ),
        ));
    }
    crate::folder::Dataset::open(dir).map_err(|e| DatasetError::setting(field, e.to_string()))
}

/// The basis `psf_basis_from` names: a basis folder itself (basis.json inside: the `NAME.basis/` that
/// `unicac-train export` writes beside a psf_code model, whose dataset may be long gone) or a finished
/// dataset's.
fn adopted_basis(dir: &Path) -> Result<crate::PsfBasis> {
    use crate::psf_basis::{read_dataset_basis, PsfBasis, BASIS_JSON};
    let read = if dir.join(BASIS_JSON).is_file() {
        PsfBasis::read(dir)
    } else if !dir.join(crate::manifest::DATASET_JSON).is_file() {
        return Err(DatasetError::setting(
            "psf_basis_from",
            format!(
                "{}: neither a PSF basis folder ({BASIS_JSON} inside: a model's NAME.basis/) nor a dataset \
                 built by `unicac dataset build` (dataset.json inside)",
                dir.display()
            ),
        ));
    } else {
        read_dataset_basis(&other_dataset("psf_basis_from", dir)?.dir)
    };
    read.map_err(|e| DatasetError::setting("psf_basis_from", format!("{}: {e}", dir.display())))
}

/// Builds (or resumes, or builds one shard of) the dataset in `out`: every check, the claim on `out`,
/// the grades and the plan, this shard's PSF maps, then the files (manifests, pairs, PSF tables, edge
/// patches) and, by the run that completes it, the PSF basis and `dataset.json`.
pub fn build(
    settings: &BuildSettings,
    out: &Path,
    shard: Shard,
    progress: &dyn Progress,
) -> Result<BuildReport> {
    let Inputs {
        settings_json,
        adopted_basis,
        sources,
        lenses,
        frame_px,
        train_scenes,
        test_scenes,
        sensor,
        record,
    } = check_inputs(settings, out)?;
    let hold = claim::claim(out, &record)?;
    let ode_settings = sensor.ode_settings();
    let (planned, odes_from_cache) = grade(out, sources, lenses, &sensor, progress)?;
    let ids: Vec<String> = planned.iter().map(|p| p.source.lens_id.clone()).collect();
    let grades: Vec<Grade> = planned.iter().map(|p| p.grade.clone()).collect();
    let assignment = stratify::assign(&ids, &grades, settings.level_counts())?;
    let plan = make_plan(
        settings,
        &settings_json,
        &planned,
        &assignment,
        &train_scenes,
        &test_scenes,
        frame_px,
    )?;
    let work = ShardWork::of(&plan, shard);
    let cache_psf = Some(unicac_sim::PsfCache::new(grading::cache_dir(out).join("psf")));
    let simulator = |p: &PlannedLens| {
        render::simulator(
            &p.lens,
            frame_px,
            p.grade.pixel_um,
            settings.distortion,
            settings.illumination,
            cache_psf.clone(),
            settings.image.clone(),
        )
        .map_err(DatasetError::simulation(format!("lens {}", p.source.source)))
    };
    // This shard's PSF maps, traced (into the cache) before anything is written.
    progress.stage("tracing PSF maps", work.lenses.len());
    for &i in &work.lenses {
        simulator(&planned[i])?;
        progress.advance(1);
    }
    // Writing starts here.
    claim::confirm(out, &record)?;
    hold.keep();
    let temporaries_removed = remove_temporaries(out)?;
    write_manifests(out, &plan)?;
    let fov_path = out.join(fov_relative(frame_px));
    if !fov_path.exists() {
        let map = crate::fov_map(crate::FrameCrop::full(frame_px[0], frame_px[1]))?;
        crate::npy::write_f32(&fov_path, &[2, map.height, map.width], &map.data)?;
    }
    let scenes: BTreeMap<&str, &Scene> = train_scenes
        .iter()
        .chain(&test_scenes)
        .map(|s| (s.image_id.as_str(), s))
        .collect();
    let rendered = render_pairs(
        settings, out, &plan, &planned, &work, &scenes, &simulator, progress,
    )?;
    let edge_patches_written =
        write_edge_patches(out, &plan, &planned, &assignment, &work, &ode_settings, progress)?;
    let complete = dataset_complete(out, &plan);
    let mut as_built_pairs_rendered = 0;
    if complete {
        finish(out, &plan, adopted_basis, progress)?;
        if let Some(as_built) = &settings.as_built {
            let context = as_built::Context {
                settings,
                as_built,
                out,
                plan: &plan,
                planned: &planned,
                scenes: &scenes,
                ode: &ode_settings,
                depth: sample_depth(settings),
            };
            as_built_pairs_rendered = as_built::render_as_built(&context, progress)?;
        }
    }
    Ok(BuildReport {
        out: out.to_path_buf(),
        complete,
        shard: format!("{}/{}", shard.index, shard.count),
        frame_px,
        lenses: plan.manifest.counts.lenses.clone(),
        pairs: plan.manifest.counts.pairs.clone(),
        edges: plan.edges.len(),
        pairs_rendered: rendered.pairs,
        psf_tables_written: rendered.tables,
        edge_patches_written,
        as_built_pairs_rendered,
        odes_computed: planned.len() - odes_from_cache,
        odes_from_cache,
        temporaries_removed,
    })
}

/// A build's inputs, each checked: nothing is claimed or written until all of them pass.
struct Inputs {
    settings_json: serde_json::Value,
    /// The basis of `psf_basis_from`, adopted instead of fitting one.
    adopted_basis: Option<crate::PsfBasis>,
    sources: Vec<LensSource>,
    lenses: Vec<Lens>,
    frame_px: [usize; 2],
    train_scenes: Vec<Scene>,
    test_scenes: Vec<Scene>,
    sensor: BuildSensor,
    /// What `out` is claimed for: the settings and the scenes' hashes.
    record: claim::BuildRecord,
}

/// Every check comes before any work: settings, where the output lies, the folder's record, the
/// inputs (lenses, scenes, frame, the library's size, duplicate lenses).
/// The settings as `dataset.json` and the build's claim record them. With noise on, they name the
/// noise's generator (`isp::NOISE_DRAWS`, read out in f32 by a GPU build): pairs of another
/// release's generator are another noise realisation, so a folder begun by it is not resumed into a mix.
fn recorded_settings(settings: &BuildSettings) -> serde_json::Value {
    let mut record = serde_json::to_value(settings).expect("settings serialise");
    if settings.noise {
        // The device draws the same streams in f32 (a sample in ~1e4 lands an electron apart).
        record[NOISE_DRAWS_KEY] = match settings.device {
            RenderDevice::Cpu => unicac_image::isp::NOISE_DRAWS.into(),
            RenderDevice::Gpu => format!("{}, f32 on the device", unicac_image::isp::NOISE_DRAWS).into(),
        };
    }
    record
}

/// The recorded setting that names the noise's generator (the one setting the release, not the user,
/// decides; `claim` explains it when it differs).
const NOISE_DRAWS_KEY: &str = "noise_draws";

fn check_inputs(settings: &BuildSettings, out: &Path) -> Result<Inputs> {
    settings.check()?;
    placement::check_output_placement(settings, out)?;
    let adopted_basis = settings
        .psf_basis_from
        .as_deref()
        .map(adopted_basis)
        .transpose()?;
    let settings_json = recorded_settings(settings);
    claim::check_output(
        out,
        &claim::BuildRecord {
            settings: settings_json.clone(),
            scenes: None,
        },
    )?;
    let sources = sources::lens_sources(&settings.lenses, out, settings.exclude_flagged)?;
    if let Some(dir) = &settings.unseen_by {
        unseen::refuse_seen_lenses(&sources, &other_dataset("unseen_by", dir)?)?;
    }
    settings.level_counts().check(sources.len())?;
    let lenses: Vec<Lens> = sources.iter().map(|s| s.load()).collect::<Result<_>>()?;
    if let Some(source) =
        (sources.iter().zip(&lenses)).find_map(|(s, l)| (!l.is_rotationally_symmetric()).then_some(s))
    {
        return Err(DatasetError::setting(
            "lenses",
            format!(
                "{}: a decentred or tilted lens (a built unit); dataset builds take rotationally symmetric \
                 lenses, whose PSF tables sample one field radius (as-built splits: not yet, docs/tolerancing.md)",
                source.location
            ),
        ));
    }
    let test_scenes = sources::scenes(
        &settings.test_images,
        "test_images",
        "test",
        settings.seed,
        settings.frame_px,
        out,
    )?;
    let frame_px = match settings.frame_px {
        Some(frame) => frame,
        None => {
            let first = test_scenes[0].load_linear()?;
            let frame = [first.width, first.height];
            check_frame(frame).map_err(|e| {
                DatasetError::Invalid(format!(
                    "the frame from the first test scene {}: {e}",
                    test_scenes[0].source
                ))
            })?;
            frame
        }
    };
    let train_scenes = sources::scenes(
        &settings.images,
        "images",
        "train",
        settings.seed,
        Some(frame_px),
        out,
    )?;
    check_scenes(&train_scenes, &test_scenes, frame_px, settings.crop_px)?;
    check_pair_count(settings, sources.len(), test_scenes.len())?;
    let sensor = BuildSensor {
        frame_px,
        pixel_um: settings.pixel_um,
    };
    duplicates::refuse_duplicate_models(&sources, &lenses, &sensor)?;
    let record = claim::BuildRecord {
        settings: settings_json.clone(),
        scenes: Some(sources::scene_hashes(train_scenes.iter().chain(&test_scenes))),
    };
    Ok(Inputs {
        settings_json,
        adopted_basis,
        sources,
        lenses,
        frame_px,
        train_scenes,
        test_scenes,
        sensor,
        record,
    })
}

/// Every lens on the build's sensor with its grade (cached under `out`), and how many grades came from
/// the cache.
fn grade(
    out: &Path,
    sources: Vec<LensSource>,
    lenses: Vec<Lens>,
    sensor: &BuildSensor,
    progress: &dyn Progress,
) -> Result<(Vec<PlannedLens>, usize)> {
    let cache = GradeCache {
        dir: grading::cache_dir(out).join("ode"),
    };
    let ode_settings = sensor.ode_settings();
    progress.stage("grading", lenses.len());
    let graded: Vec<(Grade, bool)> = sources
        .par_iter()
        .zip(&lenses)
        .map(|(source, lens)| {
            let result = cache.grade(&sensor.apply(lens), &ode_settings, &source.source);
            progress.advance(1);
            result
        })
        .collect::<Result<_>>()?;
    let from_cache = graded.iter().filter(|(_, cached)| *cached).count();
    let planned = sources
        .into_iter()
        .zip(lenses)
        .zip(graded)
        .map(|((source, lens), (grade, _))| PlannedLens {
            lens: sensor.apply(&lens),
            source,
            grade,
        })
        .collect();
    Ok((planned, from_cache))
}

/// A shard's share of the work: whole lenses (the k-th lens in use, train, val or test, goes to shard
/// k mod N) with their pairs, PSF tables and edge patches, so each lens's PSF map is traced by one
/// shard only.
struct ShardWork {
    /// Indices of the plan's lenses, ascending.
    lenses: Vec<usize>,
    /// Indices of the plan's pairs.
    pairs: Vec<usize>,
}

impl ShardWork {
    fn of(plan: &Plan, shard: Shard) -> ShardWork {
        // The lenses in use are the ones with a PSF table.
        let lenses: Vec<usize> = (0..plan.lenses.len())
            .filter(|&i| !plan.lenses[i].psf.is_empty())
            .enumerate()
            .filter(|(k, _)| shard.owns(*k))
            .map(|(_, i)| i)
            .collect();
        let index: BTreeMap<&str, usize> = (plan.lenses.iter().enumerate())
            .map(|(i, row)| (row.lens_id.as_str(), i))
            .collect();
        let mut work = ShardWork {
            lenses,
            pairs: Vec::new(),
        };
        work.pairs = (0..plan.pairs.len())
            .filter(|&p| work.owns(index[plan.pairs[p].lens_id.as_str()]))
            .collect();
        work
    }

    fn owns(&self, lens: usize) -> bool {
        self.lenses.binary_search(&lens).is_ok()
    }
}

/// What `render_pairs` wrote.
struct Rendered {
    pairs: usize,
    tables: usize,
}

/// The shard's pairs not yet complete, and the PSF tables of its lenses not yet written, a lens at a
/// time (its pairs in parallel).
#[allow(clippy::too_many_arguments)]
fn render_pairs(
    settings: &BuildSettings,
    out: &Path,
    plan: &Plan,
    planned: &[PlannedLens],
    work: &ShardWork,
    scenes: &BTreeMap<&str, &Scene>,
    simulator: &dyn Fn(&PlannedLens) -> Result<unicac_sim::LensSimulator>,
    progress: &dyn Progress,
) -> Result<Rendered> {
    let depth = sample_depth(settings);
    let missing: Vec<&PairRow> = (work.pairs.iter())
        .map(|&p| &plan.pairs[p])
        .filter(|pair| !pair_complete(out, pair))
        .collect();
    progress.stage("rendering pairs", missing.len());
    let scene_cache = sources::SceneCache::new(sources::SCENE_CACHE_BYTES);
    // The scenes of the pairs still to render, each once, in the order the pairs need them.
    let mut seen = std::collections::HashSet::new();
    let needed: Vec<&Scene> = (missing.iter())
        .map(|pair| scenes[pair.image_id.as_str()])
        .filter(|scene| seen.insert(scene.image_id.as_str()))
        .collect();
    scene_cache.warm(&needed)?;
    let mut rendered = Rendered { pairs: 0, tables: 0 };
    for &i in &work.lenses {
        let row = &plan.lenses[i];
        let table_dir = out.join(&row.psf);
        let pairs: Vec<&PairRow> = (missing.iter().copied())
            .filter(|r| r.lens_id == row.lens_id)
            .collect();
        let needs_table = !table_dir.join(crate::psf_table::TABLE_JSON).exists();
        if pairs.is_empty() && !needs_table {
            continue;
        }
        let sim = simulator(&planned[i])?;
        if needs_table {
            // `check_inputs` refused every lens that is not rotationally symmetric: there is a radial map.
            let radial = sim.radial().ok_or_else(|| {
                DatasetError::simulation(format!("lens {}", row.lens_id))(unicac_sim::SimError::Unsupported(
                    "no radial PSF map".into(),
                ))
            })?;
            render::psf_table(&row.lens_id, &sim, radial).write(&table_dir)?;
            rendered.tables += 1;
        }
        pairs.par_iter().try_for_each(|pair| -> Result<()> {
            render_and_write(
                out,
                &sim,
                &scene_cache,
                scenes[pair.image_id.as_str()],
                pair,
                depth,
            )?;
            progress.advance(1);
            Ok(())
        })?;
        rendered.pairs += pairs.len();
    }
    Ok(rendered)
}

/// Renders one pair from its scene and writes its GT, LQ and, last (its presence marks the pair
/// complete), its checks.
fn render_and_write(
    out: &Path,
    sim: &unicac_sim::LensSimulator,
    scene_cache: &sources::SceneCache,
    scene: &Scene,
    pair: &PairRow,
    depth: SampleDepth,
) -> Result<()> {
    let image = scene_cache.get(scene)?;
    let frame = sources::cut(&image, pair.scene_crop);
    let pixels = render::render_pair(sim, &frame, pair)?;
    write_png(&out.join(&pair.gt), &pixels.gt, depth)?;
    write_png(&out.join(&pair.lq), &pixels.lq, depth)?;
    manifest::write_json(&out.join(check_relative(pair)), &pixels.check)
}

/// The ODE edge patches of the shard's test lenses not yet written; returns how many files were
/// written.
fn write_edge_patches(
    out: &Path,
    plan: &Plan,
    planned: &[PlannedLens],
    assignment: &Assignment,
    work: &ShardWork,
    ode_settings: &unicac_ode::OdeSettings,
    progress: &dyn Progress,
) -> Result<usize> {
    let lenses: Vec<usize> = (0..planned.len())
        .filter(|&i| assignment.split[i] == "test" && work.owns(i))
        .collect();
    progress.stage("edge patches", lenses.len());
    let mut written = 0;
    for &i in &lenses {
        let rows: Vec<&EdgeRow> = (plan.edges.iter())
            .filter(|e| e.lens_id == planned[i].source.lens_id)
            .collect();
        if !rows
            .iter()
            .all(|e| out.join(&e.lq).exists() && out.join(&e.gt).exists())
        {
            written += write_edges(out, &planned[i], ode_settings, &rows)?;
        }
        progress.advance(1);
    }
    Ok(written)
}

/// What the run that completes the dataset writes: the PSF basis (it needs every training lens's
/// table; a pure function of them, so every shard would write the same bytes), `pairs.jsonl` with every
/// pair's checks (the manifests written at the run's start lacked the pairs it rendered), and
/// `dataset.json`.
fn finish(
    out: &Path,
    plan: &Plan,
    adopted_basis: Option<crate::PsfBasis>,
    progress: &dyn Progress,
) -> Result<()> {
    let basis_dir = out.join(crate::psf_basis::BASIS_RELATIVE);
    if !basis_dir.join(crate::psf_basis::BASIS_JSON).exists() {
        match adopted_basis {
            Some(basis) => basis.write(&basis_dir)?,
            None => {
                progress.stage("fitting the PSF basis", 1);
                fit_psf_basis(out, &plan.lenses)?.write(&basis_dir)?;
                progress.advance(1);
            }
        }
    }
    write_manifests(out, plan)?;
    manifest::write_json(&out.join(DATASET_JSON), &plan.manifest)
}

/// The row plan: lens rows, pair rows (train, val, test; by lens id, then pair), edge rows, and
/// `dataset.json`, all pure functions of the inputs.
fn make_plan(
    settings: &BuildSettings,
    settings_json: &serde_json::Value,
    planned: &[PlannedLens],
    assignment: &Assignment,
    train_scenes: &[Scene],
    test_scenes: &[Scene],
    frame_px: [usize; 2],
) -> Result<Plan> {
    let lenses: Vec<LensRow> = planned
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let g = &p.grade;
            let split = assignment.split[i];
            LensRow {
                lens_id: p.source.lens_id.clone(),
                source: p.source.source.clone(),
                lens_sha256: p.source.sha256.clone(),
                scores: g.scores,
                split: split.into(),
                level: assignment.level[i],
                us_level: assignment.us_level[i],
                uc_level: assignment.uc_level[i],
                pixel_um: g.pixel_um,
                psf: if split == "unused" {
                    String::new()
                } else {
                    format!("psf/{}", p.source.lens_id)
                },
            }
        })
        .collect();
    let pipeline = settings.pipeline();
    let crop = settings.crop_px.unwrap_or(frame_px);
    let fov = fov_relative(frame_px);
    let scene_crop = |scene: &Scene| -> Result<[usize; 4]> {
        let [w, h] = scene_size(scene)?;
        scene.frame_crop(w, h, frame_px)
    };
    let train_crops: Vec<[usize; 4]> = train_scenes.iter().map(scene_crop).collect::<Result<_>>()?;
    let test_crops: Vec<[usize; 4]> = test_scenes.iter().map(scene_crop).collect::<Result<_>>()?;
    let pair_row = |split: &str,
                    lens: &LensRow,
                    pair_id: String,
                    scene: &Scene,
                    scene_crop: [usize; 4],
                    crop: [usize; 4],
                    seed: u64|
     -> Result<PairRow> {
        let draw = pipeline
            .draw(seed)
            .map_err(DatasetError::image(format!("pair {pair_id}")))?;
        Ok(PairRow {
            lq: format!("{split}/lq/{pair_id}.png"),
            gt: format!("{split}/gt/{pair_id}.png"),
            pair_id,
            split: split.into(),
            lens_id: lens.lens_id.clone(),
            image_id: scene.image_id.clone(),
            image_source: scene.source.clone(),
            seed,
            frame_px,
            scene_crop,
            crop,
            pixel_um: lens.pixel_um,
            distortion: settings.distortion,
            illumination: settings.illumination,
            task: settings.task,
            isp_draw: render::isp_record(&pipeline, &draw),
            psf: lens.psf.clone(),
            fov: fov.clone(),
            check: None,
        })
    };
    let mut pairs = Vec::new();
    for split in SPLITS {
        for lens in lenses.iter().filter(|l| l.split == split) {
            if split == "test" {
                for (scene, &sc) in test_scenes.iter().zip(&test_crops) {
                    let pair_id = format!("{}__{}", lens.lens_id, scene.image_id);
                    let seed = derive_seed(settings.seed, &[b"pair", pair_id.as_bytes()]);
                    pairs.push(pair_row(
                        split,
                        lens,
                        pair_id,
                        scene,
                        sc,
                        [0, 0, frame_px[0], frame_px[1]],
                        seed,
                    )?);
                }
                continue;
            }
            for j in 0..settings.pairs_per_lens {
                let pair_id = format!("{}__{j:04}", lens.lens_id);
                let seed = derive_seed(settings.seed, &[b"pair", pair_id.as_bytes()]);
                let s = below(derive_seed(seed, &[b"scene"]), train_scenes.len());
                let x0 = below(derive_seed(seed, &[b"crop-x"]), frame_px[0] - crop[0] + 1);
                let y0 = below(derive_seed(seed, &[b"crop-y"]), frame_px[1] - crop[1] + 1);
                pairs.push(pair_row(
                    split,
                    lens,
                    pair_id,
                    &train_scenes[s],
                    train_crops[s],
                    [x0, y0, crop[0], crop[1]],
                    seed,
                )?);
            }
        }
    }
    let ode_settings = unicac_ode::OdeSettings::default();
    let mut edges = Vec::new();
    for (p, lens) in planned.iter().zip(&lenses).filter(|(_, l)| l.split == "test") {
        let size_px = ode_settings.min_edge_px.max(4 * p.grade.kernel_px);
        let chief = unicac_sim::ChiefRayMap::new(&p.lens)
            .map_err(DatasetError::simulation(format!("lens {}", p.source.source)))?;
        for (f, &fraction) in ode_settings.field_fractions.iter().enumerate() {
            for channel in ["R", "G", "B"] {
                for direction in ["sagittal", "tangential"] {
                    let edge_id = format!("{}__f{f}_{channel}_{}", lens.lens_id, &direction[..3]);
                    edges.push(EdgeRow {
                        lq: format!("edges/lq/{edge_id}.png"),
                        gt: format!("edges/gt/{edge_id}.png"),
                        edge_id,
                        lens_id: lens.lens_id.clone(),
                        level: lens.level,
                        field_fraction: fraction,
                        field_deg: chief.angle_for_height(fraction * p.grade.half_diagonal_mm),
                        channel: channel.into(),
                        direction: direction.into(),
                        size_px,
                        slant_deg: ode_settings.slant_deg,
                        pixel_um: p.grade.pixel_um,
                    });
                }
            }
        }
    }
    let mut counts = Counts {
        edges: edges.len(),
        train_images: train_scenes.len(),
        test_images: test_scenes.len(),
        ..Counts::default()
    };
    for split in ["train", "val", "test", "unused"] {
        counts
            .lenses
            .insert(split.into(), lenses.iter().filter(|l| l.split == split).count());
    }
    for split in SPLITS {
        counts
            .pairs
            .insert(split.into(), pairs.iter().filter(|p| p.split == split).count());
    }
    let manifest = DatasetManifest {
        format: manifest::FORMAT_NAME.into(),
        format_version: manifest::FORMAT_VERSION,
        unicac_version: env!("CARGO_PKG_VERSION").into(),
        settings: settings_json.clone(),
        seed: settings.seed,
        frame_px,
        stratifications: assignment.stratifications.clone(),
        counts,
        task: settings.task,
        comparable_by_ode_level: settings.task.comparable_by_ode_level(),
    };
    Ok(Plan {
        frame_px,
        lenses,
        pairs,
        edges,
        manifest,
    })
}

fn scene_size(scene: &Scene) -> Result<[usize; 2]> {
    match &scene.kind {
        sources::SceneKind::DeadLeaves { width, height, .. } => Ok([*width, *height]),
        sources::SceneKind::File { .. } => {
            let image = scene.load_linear()?;
            Ok([image.width, image.height])
        }
    }
}

/// The plan holds at most `MAX_PAIRS` pairs: every lens rendered with `pairs_per_lens` pairs or, for
/// the test lenses, one per test scene (an upper bound, checked before grading).
fn check_pair_count(settings: &BuildSettings, lenses: usize, test_scenes: usize) -> Result<()> {
    let test_lenses = settings.levels.saturating_mul(settings.test_lenses_per_level);
    let pairs = lenses
        .saturating_sub(test_lenses)
        .checked_mul(settings.pairs_per_lens)
        .zip(test_lenses.checked_mul(test_scenes))
        .and_then(|(a, b)| a.checked_add(b))
        .filter(|&n| n <= MAX_PAIRS);
    match pairs {
        Some(_) => Ok(()),
        None => Err(DatasetError::setting(
            "pairs_per_lens",
            format!(
                "{}: {lenses} lenses x {} pairs (test lenses: {test_scenes} test scenes each) exceed the {MAX_PAIRS} pairs a build plans (MAX_PAIRS)",
                settings.pairs_per_lens, settings.pairs_per_lens
            ),
        )),
    }
}

/// A frame every stage can render and score: sides within `check_side`, at most
/// `MAX_SIMULATE_PIXELS` pixels.
fn check_frame([w, h]: [usize; 2]) -> Result<()> {
    check_side("frame_px", [w, h])?;
    if w.saturating_mul(h) > unicac_sim::MAX_SIMULATE_PIXELS {
        return Err(DatasetError::setting(
            "frame_px",
            format!(
                "{w}x{h}: more than {} px (MAX_SIMULATE_PIXELS)",
                unicac_sim::MAX_SIMULATE_PIXELS
            ),
        ));
    }
    Ok(())
}

/// Both sides of a frame or crop at least `MIN_CROP_SIDE_PX` (at most `MAX_FRAME_SIDE_PX`).
fn check_side(field: &str, [w, h]: [usize; 2]) -> Result<()> {
    let max = crate::MAX_FRAME_SIDE_PX;
    if w < MIN_CROP_SIDE_PX || h < MIN_CROP_SIDE_PX || w > max || h > max {
        return Err(DatasetError::setting(
            field,
            format!(
                "{w}x{h}: each side must lie in [{MIN_CROP_SIDE_PX}, {max}] px (MIN_CROP_SIDE_PX: SSIM's 11 x 11 px window must fit; MAX_FRAME_SIDE_PX)"
            ),
        ));
    }
    Ok(())
}

/// `fov/WxH.npy`.
pub fn fov_relative(frame_px: [usize; 2]) -> String {
    format!("fov/{}x{}.npy", frame_px[0], frame_px[1])
}

/// Scenes are readable, at least the frame (and the frame at least the crop), and no scene is both a
/// training and a test scene.
fn check_scenes(
    train: &[Scene],
    test: &[Scene],
    frame_px: [usize; 2],
    crop_px: Option<[usize; 2]>,
) -> Result<()> {
    if let Some([w, h]) = crop_px {
        if w > frame_px[0] || h > frame_px[1] {
            return Err(DatasetError::setting(
                "crop_px",
                format!(
                    "{w}x{h} is larger than the {} x {} frame",
                    frame_px[0], frame_px[1]
                ),
            ));
        }
    }
    let mut hashes = BTreeMap::new();
    for scene in train {
        if let sources::SceneKind::File { sha256, .. } = &scene.kind {
            hashes.insert(sha256.clone(), scene.source.clone());
        }
    }
    for scene in test {
        if let sources::SceneKind::File { sha256, .. } = &scene.kind {
            if let Some(other) = hashes.get(sha256) {
                return Err(DatasetError::Invalid(format!(
                    "test image {} is the same image as training image {other}: scenes must be disjoint",
                    scene.source
                )));
            }
        }
    }
    for scene in train.iter().chain(test) {
        let [w, h] = scene_size(scene)?;
        scene.frame_crop(w, h, frame_px)?;
    }
    Ok(())
}

/// Removes the temporaries under `out` that interrupted runs left (a concurrent shard's are kept).
fn remove_temporaries(out: &Path) -> Result<usize> {
    Ok(unicac_io::clean_stale_temporaries_under(out)
        .map_err(|e| DatasetError::io(out, e))?
        .len())
}

/// The manifests (identical in every run and shard); rewritten only when their bytes differ.
fn write_manifests(out: &Path, plan: &Plan) -> Result<()> {
    let mut files: Vec<(String, Vec<u8>)> = vec![
        (LENSES_JSONL.into(), manifest::jsonl_bytes(&plan.lenses)),
        (LENSES_CSV.into(), manifest::lenses_csv(&plan.lenses)),
        (
            PAIRS_JSONL.into(),
            manifest::jsonl_bytes(&with_checks(out, &plan.pairs)?),
        ),
        (EDGES_JSONL.into(), manifest::jsonl_bytes(&plan.edges)),
    ];
    for split in SPLITS {
        let mut text = String::new();
        for pair in plan.pairs.iter().filter(|p| p.split == split) {
            text.push_str(&format!(
                "{}.png ({},{},3)\n",
                pair.pair_id, pair.crop[3], pair.crop[2]
            ));
        }
        files.push((format!("{split}/meta_info.txt"), text.into_bytes()));
    }
    for (name, bytes) in files {
        let path = out.join(&name);
        if std::fs::read(&path).ok().as_deref() != Some(bytes.as_slice()) {
            manifest::write_atomically(&path, &bytes)?;
        }
    }
    Ok(())
}

/// The dataset's PSF basis (docs/models.md, `psf_code`): fitted on the training lenses' tables, measured
/// on the validation and test lenses' ones.
pub fn fit_psf_basis(out: &Path, lenses: &[LensRow]) -> Result<crate::PsfBasis> {
    let tables: Vec<crate::psf_basis::FitTable> = lenses
        .iter()
        .filter(|l| !l.psf.is_empty())
        .map(|l| crate::psf_basis::FitTable {
            dir: out.join(&l.psf),
            held_out: l.split != "train",
        })
        .collect();
    crate::PsfBasis::fit(
        &tables,
        crate::psf_basis::DEFAULT_ENERGY_SHARE,
        env!("CARGO_PKG_VERSION"),
    )
}

fn pair_complete(out: &Path, pair: &PairRow) -> bool {
    out.join(&pair.lq).exists() && out.join(&pair.gt).exists() && out.join(check_relative(pair)).exists()
}

/// `SPLIT/check/PAIR_ID.json`: the pair's checks, written when it is rendered and gathered into
/// `pairs.jsonl` by every run (all of them by the run that completes the dataset).
pub fn check_relative(pair: &PairRow) -> String {
    format!("{}/check/{}.json", pair.split, pair.pair_id)
}

/// The plan's pair rows with the checks of the pairs rendered so far.
fn with_checks(out: &Path, pairs: &[PairRow]) -> Result<Vec<PairRow>> {
    pairs
        .iter()
        .map(|pair| {
            let path = out.join(check_relative(pair));
            let check = match std::fs::read(&path) {
                Ok(bytes) => Some(
                    serde_json::from_slice::<PairCheck>(&bytes)
                        .map_err(|e| DatasetError::format(&path, e.to_string()))?,
                ),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
                Err(e) => return Err(DatasetError::io(&path, e)),
            };
            Ok(PairRow {
                check,
                ..pair.clone()
            })
        })
        .collect()
}

fn dataset_complete(out: &Path, plan: &Plan) -> bool {
    plan.pairs.iter().all(|p| pair_complete(out, p))
        && plan
            .edges
            .iter()
            .all(|e| out.join(&e.lq).exists() && out.join(&e.gt).exists())
        && plan
            .lenses
            .iter()
            .filter(|l| !l.psf.is_empty())
            .all(|l| out.join(&l.psf).join(crate::psf_table::TABLE_JSON).exists())
        && out.join(fov_relative(plan.frame_px)).exists()
}

/// The PNG sample depth of the pairs (`bit_depth`).
fn sample_depth(settings: &BuildSettings) -> SampleDepth {
    if settings.bit_depth == 16 {
        SampleDepth::Sixteen
    } else {
        SampleDepth::Eight
    }
}

fn write_png(path: &Path, image: &Planar, depth: SampleDepth) -> Result<()> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| DatasetError::io(parent, e))?;
    }
    // The image error names the file itself.
    unicac_image::io::write_png(path, image, depth).map_err(|source| DatasetError::Image {
        context: None,
        source,
    })
}

/// A test lens's ODE edge patches (the kernels of its ODE fields on the build sensor); returns how
/// many files were written.
fn write_edges(
    out: &Path,
    lens: &PlannedLens,
    settings: &unicac_ode::OdeSettings,
    rows: &[&EdgeRow],
) -> Result<usize> {
    let fail =
        |e: unicac_ode::OdeError| DatasetError::ode(format!("lens {}: edge patches", lens.source.source))(e);
    let setup = unicac_ode::EvaluationSetup::new(&lens.lens, settings).map_err(fail)?;
    let fields = setup.field_kernels(&settings.field_fractions).map_err(fail)?;
    let mut written = 0;
    for (f, field) in fields.iter().enumerate() {
        for (c, kernel) in field.kernels.iter().enumerate() {
            let patches = unicac_ode::edge_patches(kernel, settings).map_err(|(_, e)| fail(e))?;
            for (d, patch) in patches.iter().enumerate() {
                let row = rows[(f * 3 + c) * 2 + d];
                for (relative, image) in [(&row.gt, &patch.ideal), (&row.lq, &patch.blurred)] {
                    let path = out.join(relative);
                    if !path.exists() {
                        write_png(&path, &render::grey_to_srgb(image), SampleDepth::Sixteen)?;
                        written += 1;
                    }
                }
            }
        }
    }
    Ok(written)
}
