//! The dataset builder end to end on tiny frames (64 x 48): splits, levels, regeneration from the
//! manifest, resume after an interrupted run, shards and thread counts (byte for byte), bad input.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use unicac_dataset::builder::{self, render, sources, BuildSettings, SceneSource, Shard, Silent};
use unicac_dataset::folder::Dataset;
use unicac_dataset::manifest::PairRow;

// The singlet's PSF exceeds a 64 x 48 frame: it serves as the lens that fails below.
const LENSES: [&str; 6] = [
    "achromat",
    "cooke_triplet",
    "double_gauss",
    "petzval",
    "phone_asphere",
    "wide_angle",
];

fn settings() -> BuildSettings {
    let lenses = LENSES.iter().map(|n| format!("builtin:{n}")).collect();
    let mut s = BuildSettings::new(
        lenses,
        "dead-leaves:3:80x60".parse().unwrap(),
        "dead-leaves:2".parse().unwrap(),
    );
    s.frame_px = Some([64, 48]);
    s.levels = 4;
    s.test_lenses_per_level = 1;
    s.val_lenses = 1;
    s.sub_benchmarks = true;
    s.pairs_per_lens = 2;
    s.crop_px = Some([32, 24]);
    s.seed = 11;
    s
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-dataset-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn build_with(
    threads: usize,
    settings: &BuildSettings,
    out: &Path,
    shard: Shard,
) -> unicac_dataset::Result<builder::BuildReport> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| builder::build(settings, out, shard, &Silent))
}

/// The reference build (2 threads), made once per test binary.
fn reference() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = scratch("reference");
        let report = build_with(2, &settings(), &dir, Shard::ALL).unwrap();
        assert!(report.complete);
        dir
    })
}

/// Every file under `dir` (relative path -> bytes), the ODE/PSF cache aside.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            let relative = path.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
            if relative.starts_with(".cache") {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else {
                out.insert(relative, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

fn assert_same_files(a: &Path, b: &Path) {
    let (fa, fb) = (files(a), files(b));
    let names_a: Vec<&String> = fa.keys().collect();
    let names_b: Vec<&String> = fb.keys().collect();
    assert_eq!(names_a, names_b, "file lists differ");
    for (name, bytes) in &fa {
        assert!(bytes == &fb[name], "{name} differs");
    }
}

#[test]
fn splits_are_lens_disjoint_and_levels_are_ordered_inside_their_thresholds() {
    let dataset = Dataset::open(reference()).unwrap();
    let lenses = dataset.lenses().unwrap();
    let pairs = dataset.pairs().unwrap();
    assert_eq!(lenses.len(), 6);
    let split_of: BTreeMap<&str, &str> = lenses
        .iter()
        .map(|l| (l.lens_id.as_str(), l.split.as_str()))
        .collect();
    for pair in &pairs {
        assert_eq!(split_of[pair.lens_id.as_str()], pair.split, "{}", pair.pair_id);
        assert!(dataset.resolve(&pair.lq).unwrap().is_file() && dataset.resolve(&pair.gt).unwrap().is_file());
        assert_eq!(Path::new(&pair.lq).file_name(), Path::new(&pair.gt).file_name());
    }
    // Scenes: training/validation and test pairs use disjoint images.
    let scenes = |split: &[&str]| -> std::collections::BTreeSet<String> {
        pairs
            .iter()
            .filter(|p| split.contains(&p.split.as_str()))
            .map(|p| p.image_id.clone())
            .collect()
    };
    assert!(scenes(&["train", "val"]).is_disjoint(&scenes(&["test"])));
    // The test split is exactly test lenses x test images.
    let test_lenses = lenses.iter().filter(|l| l.split == "test").count();
    assert_eq!(test_lenses, 4);
    assert_eq!(
        pairs.iter().filter(|p| p.split == "test").count(),
        test_lenses * 2
    );
    assert_eq!(lenses.iter().filter(|l| l.split == "val").count(), 1);
    assert_eq!(lenses.iter().filter(|l| l.split == "train").count(), 1);
    // Levels: exactly one test lens each, inside the recorded thresholds, ordered mild to severe.
    let ode = &dataset.manifest.stratifications[0];
    assert_eq!(ode.metric, "ode");
    assert!(
        ode.thresholds.windows(2).all(|w| w[0] >= w[1]),
        "{:?}",
        ode.thresholds
    );
    let mut previous = f64::INFINITY;
    for level in 1..=4u32 {
        let members: Vec<_> = lenses.iter().filter(|l| l.level == Some(level)).collect();
        assert_eq!(members.len(), 1, "level {level}");
        let summary = &ode.levels[level as usize - 1];
        for l in &members {
            assert!(
                l.scores.ode <= summary.upper && l.scores.ode >= summary.lower,
                "level {level}: {} not in [{}, {}]",
                l.scores.ode,
                summary.lower,
                summary.upper
            );
            assert!(l.scores.ode <= previous);
            previous = l.scores.ode;
        }
    }
    // Sub-benchmarks cover the test lenses once each.
    assert_eq!(lenses.iter().filter(|l| l.us_level.is_some()).count(), 4);
    assert_eq!(lenses.iter().filter(|l| l.uc_level.is_some()).count(), 4);
    // Edge patches: 5 fields x 3 channels x 2 directions per test lens.
    assert_eq!(dataset.edges().unwrap().len(), 4 * 30);
    // BasicSR meta_info lists each pair once with its size.
    let meta = std::fs::read_to_string(reference().join("train/meta_info.txt")).unwrap();
    assert_eq!(meta.lines().count(), 2);
    assert!(meta.lines().all(|l| l.ends_with(".png (24,32,3)")), "{meta}");
    // The FoV map is the one of docs/models.md.
    let (shape, data) = unicac_dataset::npy::read_f32(&reference().join("fov/64x48.npy")).unwrap();
    assert_eq!(shape, vec![2, 48, 64]);
    assert_eq!(
        data,
        unicac_dataset::fov_map(unicac_dataset::FrameCrop::full(64, 48))
            .unwrap()
            .data
    );
    // Nothing run-specific in the manifests.
    for name in ["lenses.jsonl", "pairs.jsonl", "edges.jsonl"] {
        let text = std::fs::read_to_string(reference().join(name)).unwrap();
        assert!(
            !text.contains(&*std::env::temp_dir().to_string_lossy()),
            "{name} holds an absolute path"
        );
    }
}

/// Renders a pair again from nothing but its manifest row and lens row.
/// The level plot names the dataset by its folder, never by the path it was built at (issue 33: the
/// small run's committed picture carried `/work/repro-small/dataset`).
#[test]
fn the_level_plot_is_titled_by_the_dataset_folder_name_not_its_path() {
    let out = scratch("level-plot");
    std::fs::create_dir_all(&out).unwrap();
    let svg = out.join("levels.svg");
    unicac_dataset::info::plot(reference(), &svg).unwrap();
    let picture = std::fs::read_to_string(&svg).unwrap();
    let name = reference().file_name().unwrap().to_string_lossy();
    let title = format!("Test lenses of {name} by ODE level");
    assert!(picture.contains(&title), "no title {title:?} in the picture");
    let parent = reference().parent().unwrap().to_string_lossy();
    assert!(!picture.contains(parent.as_ref()), "the picture names {parent}");
    std::fs::remove_dir_all(&out).unwrap();
}

fn regenerate(dataset: &Dataset, pair: &PairRow) -> (Vec<u8>, Vec<u8>) {
    let lenses = dataset.lenses().unwrap();
    let lens_row = lenses.iter().find(|l| l.lens_id == pair.lens_id).unwrap();
    let lens_source = sources::lens_sources(std::slice::from_ref(&lens_row.source), &dataset.dir, false)
        .unwrap()
        .remove(0);
    assert_eq!(lens_source.sha256, lens_row.lens_sha256);
    let lens = builder::grading::BuildSensor {
        frame_px: pair.frame_px,
        pixel_um: None,
    }
    .apply(&lens_source.load().unwrap());
    let sim = render::simulator(
        &lens,
        pair.frame_px,
        pair.pixel_um,
        pair.distortion,
        pair.illumination,
        None,
        unicac_sim::ImageBackend::cpu(),
    )
    .unwrap();
    // image_source is dead-leaves:SEED:WxH.
    let parts: Vec<&str> = pair.image_source.split(':').collect();
    let [w, h] = sources::parse_size(parts[2]).unwrap();
    let scene = unicac_image::charts::dead_leaves(w, h, parts[1].parse().unwrap()).unwrap();
    let frame = sources::cut(&scene, pair.scene_crop);
    let rendered = render::render_pair(&sim, &frame, pair).unwrap();
    assert_eq!(
        Some(rendered.check),
        pair.check,
        "{}: the recorded checks",
        pair.pair_id
    );
    let (lq, gt) = (rendered.lq, rendered.gt);
    let dir = scratch(&format!("regen-{}", pair.pair_id));
    std::fs::create_dir_all(&dir).unwrap();
    let encode = |image: &unicac_image::Planar, name: &str| {
        let path = dir.join(name);
        unicac_image::io::write_png(&path, image, unicac_image::io::SampleDepth::Eight).unwrap();
        std::fs::read(&path).unwrap()
    };
    let out = (encode(&lq, "lq.png"), encode(&gt, "gt.png"));
    std::fs::remove_dir_all(&dir).unwrap();
    out
}

#[test]
fn a_pair_regenerated_from_its_manifest_entry_equals_the_stored_files() {
    let dataset = Dataset::open(reference()).unwrap();
    let pairs = dataset.pairs().unwrap();
    for split in ["train", "test"] {
        let pair = pairs.iter().find(|p| p.split == split).unwrap();
        let (lq, gt) = regenerate(&dataset, pair);
        assert!(
            lq == std::fs::read(dataset.resolve(&pair.lq).unwrap()).unwrap(),
            "{} lq",
            pair.pair_id
        );
        assert!(
            gt == std::fs::read(dataset.resolve(&pair.gt).unwrap()).unwrap(),
            "{} gt",
            pair.pair_id
        );
        assert_ne!(lq, gt, "the lens and noise change the image");
    }
}

#[test]
fn an_interrupted_build_resumes_to_the_same_bytes() {
    let dir = scratch("resume");
    build_with(2, &settings(), &dir, Shard::ALL).unwrap();
    // What a kill leaves: missing outputs, a half-written temporary, no dataset.json.
    let pairs = Dataset::open(&dir).unwrap().pairs().unwrap();
    std::fs::remove_file(dir.join(&pairs[0].lq)).unwrap();
    std::fs::remove_file(dir.join(&pairs[pairs.len() - 1].gt)).unwrap();
    std::fs::remove_file(dir.join(&pairs[0].psf).join("table.json")).unwrap();
    std::fs::remove_file(dir.join("edges.jsonl")).unwrap();
    std::fs::remove_dir_all(dir.join("edges/lq")).unwrap();
    std::fs::remove_file(dir.join("dataset.json")).unwrap();
    std::fs::remove_dir_all(dir.join(unicac_dataset::psf_basis::BASIS_RELATIVE)).unwrap();
    std::fs::write(dir.join("test/lq/.half.png.tmp-999"), b"partial").unwrap();
    let report = build_with(2, &settings(), &dir, Shard::ALL).unwrap();
    assert!(report.complete);
    assert_eq!(
        report.pairs_rendered, 2,
        "only the two incomplete pairs are rendered again"
    );
    assert_eq!(report.psf_tables_written, 1);
    assert_eq!(report.temporaries_removed, 1);
    assert_eq!(report.odes_from_cache, 6);
    assert_same_files(reference(), &dir);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_completed_dataset_has_a_psf_basis_fitted_on_its_training_lenses() {
    let dir = reference();
    let basis = unicac_dataset::psf_basis::read_dataset_basis(dir).unwrap();
    let lenses = Dataset::open(dir).unwrap().lenses().unwrap();
    let train: Vec<_> = lenses.iter().filter(|l| l.split == "train").collect();
    let largest = lenses
        .iter()
        .filter(|l| !l.psf.is_empty())
        .map(|l| {
            unicac_dataset::PsfTable::read_meta(&dir.join(&l.psf))
                .unwrap()
                .kernel_px
        })
        .max()
        .unwrap();
    assert_eq!(basis.meta.kernel_px, largest);
    assert_eq!(basis.meta.fit_lenses, train.len());
    // The tiny frames' training lens may form the same kernel at every field: no variance, so no
    // component is needed (the code is all zeros). Otherwise the stated share, or all 16 components.
    for c in 0..3 {
        let (m, explained) = (basis.meta.components[c], basis.meta.explained[c]);
        assert!(m <= 16 && (0.0..=1.0).contains(&explained), "{:?}", basis.meta);
        assert!(explained >= 0.95 || m == 16, "{:?}", basis.meta);
    }
    assert_eq!(basis.meta.fit_kernels, 17 * train.len());
    assert!(basis.meta.explained_held_out.is_some());
    // Every lens in use gets a finite code.
    for lens in lenses.iter().filter(|l| !l.psf.is_empty()) {
        let table = unicac_dataset::PsfTable::read(&dir.join(&lens.psf)).unwrap();
        let codes = basis.field_codes(&table);
        assert!(codes.codes().iter().flatten().all(|v| v.is_finite()));
    }
}

#[test]
fn shards_in_one_folder_and_one_thread_equal_the_single_run() {
    let dir = scratch("shards");
    let first = build_with(2, &settings(), &dir, Shard::parse("1/2").unwrap()).unwrap();
    assert!(!first.complete && !dir.join("dataset.json").exists());
    let second = build_with(2, &settings(), &dir, Shard::parse("2/2").unwrap()).unwrap();
    assert!(second.complete);
    let total: usize = first.pairs.values().sum();
    assert_eq!(first.pairs_rendered + second.pairs_rendered, total);
    assert_same_files(reference(), &dir);
    std::fs::remove_dir_all(&dir).unwrap();
    let single = scratch("one-thread");
    build_with(1, &settings(), &single, Shard::ALL).unwrap();
    assert_same_files(reference(), &single);
    std::fs::remove_dir_all(&single).unwrap();
}

/// Only dot-named entries (the cache) may be left by a refused build.
fn nothing_written(dir: &Path) -> bool {
    !dir.exists()
        || std::fs::read_dir(dir)
            .unwrap()
            .all(|e| e.unwrap().file_name().to_string_lossy().starts_with('.'))
}

#[test]
fn bad_input_is_refused_by_name_and_leaves_nothing_half_written() {
    // An unreadable image.
    let images = scratch("bad-images");
    std::fs::create_dir_all(&images).unwrap();
    std::fs::write(images.join("broken.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let mut s = settings();
    s.images = SceneSource::Path(images.clone());
    let out = scratch("bad-image-out");
    let error = builder::build(&s, &out, Shard::ALL, &Silent)
        .unwrap_err()
        .to_string();
    assert!(error.contains("broken.png"), "{error}");
    assert!(nothing_written(&out));
    // A lens that fails to trace: a field far beyond what the singlet can image.
    let lens_dir = scratch("bad-lens");
    std::fs::create_dir_all(&lens_dir).unwrap();
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../lenses/singlet.json"))
            .unwrap();
    let broken = text.replacen("14.0", "89.0", 1).replacen("9.8", "60.0", 1);
    std::fs::write(lens_dir.join("wild.json"), broken).unwrap();
    let mut s = settings();
    s.lenses
        .push(lens_dir.join("wild.json").to_string_lossy().into_owned());
    let out = scratch("bad-lens-out");
    let error = builder::build(&s, &out, Shard::ALL, &Silent).unwrap_err();
    // The lower error keeps its kind (the simulator's: the PSF of so wide a field outgrows the frame).
    assert!(
        matches!(error, unicac_dataset::DatasetError::Simulation { .. }),
        "{error:?}"
    );
    let error = error.to_string();
    assert!(error.contains("wild.json"), "{error}");
    assert!(nothing_written(&out));
    // A lens whose PSF does not fit the frame: refused by name before anything is written.
    let mut s = settings();
    s.lenses.push("builtin:singlet".into());
    let out = scratch("big-psf-out");
    let error = builder::build(&s, &out, Shard::ALL, &Silent).unwrap_err();
    assert!(
        matches!(error, unicac_dataset::DatasetError::Simulation { .. }),
        "{error:?}"
    );
    let error = error.to_string();
    assert!(
        error.contains("singlet") && error.contains("larger than the image"),
        "{error}"
    );
    assert!(nothing_written(&out));
    // A library too small for the levels.
    let mut s = settings();
    s.test_lenses_per_level = 2;
    let out = scratch("small-out");
    let error = builder::build(&s, &out, Shard::ALL, &Silent)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("holds 6 lenses") && error.contains("need 10"),
        "{error}"
    );
    assert!(nothing_written(&out));
    // An output folder that holds another dataset is left untouched.
    let before = files(reference());
    let mut s = settings();
    s.seed = 12;
    let error = builder::build(&s, reference(), Shard::ALL, &Silent)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("another build with different settings holds this folder") && error.contains("seed"),
        "{error}"
    );
    assert!(before == files(reference()));
    // A folder with unrelated files is not taken over either.
    let stranger = scratch("stranger");
    std::fs::create_dir_all(&stranger).unwrap();
    std::fs::write(stranger.join("notes.txt"), b"mine").unwrap();
    let error = builder::build(&settings(), &stranger, Shard::ALL, &Silent)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("not empty") && error.contains("notes.txt"),
        "{error}"
    );
    for dir in [images, lens_dir, out, stranger] {
        let _ = std::fs::remove_dir_all(dir);
    }
}

#[test]
fn a_dataset_can_adopt_another_datasets_psf_basis() {
    let dir = scratch("adopted-basis");
    let mut s = settings();
    s.seed = 12;
    s.psf_basis_from = Some(reference().to_path_buf());
    assert!(build_with(2, &s, &dir, Shard::ALL).unwrap().complete);
    let read = unicac_dataset::psf_basis::read_dataset_basis;
    assert_eq!(read(&dir).unwrap(), read(reference()).unwrap());
    // A basis folder on its own (what `unicac-train export` writes beside a psf_code model) serves too.
    let model_basis = scratch("adopted-basis-model").join("m.basis");
    std::fs::create_dir_all(&model_basis).unwrap();
    read(reference()).unwrap().write(&model_basis).unwrap();
    let from_model = scratch("adopted-basis-from-model");
    s.psf_basis_from = Some(model_basis.clone());
    assert!(build_with(2, &s, &from_model, Shard::ALL).unwrap().complete);
    assert_eq!(read(&from_model).unwrap(), read(reference()).unwrap());
    // A damaged one is refused before any work, naming the setting and the file.
    std::fs::write(model_basis.join("mean.npy"), b"not an array").unwrap();
    let error = build_with(2, &s, &scratch("adopted-basis-damaged"), Shard::ALL).unwrap_err();
    assert!(
        matches!(&error, unicac_dataset::DatasetError::Setting { field, .. } if field == "psf_basis_from")
            && error.to_string().contains("mean.npy"),
        "{error}"
    );
    // A folder without a basis is refused before any work, naming the setting.
    let missing = scratch("adopted-basis-missing");
    s.psf_basis_from = Some(missing.join("nowhere"));
    let error = build_with(2, &s, &scratch("adopted-basis-refused"), Shard::ALL).unwrap_err();
    assert!(
        matches!(&error, unicac_dataset::DatasetError::Setting { field, .. } if field == "psf_basis_from"),
        "{error}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_test_set_for_models_trained_elsewhere_refuses_their_lenses() {
    let dir = scratch("unseen-by");
    let mut s = settings();
    s.unseen_by = Some(reference().to_path_buf());
    // The reference's own lenses: its training and validation ones are named, before any work.
    let error = build_with(2, &s, &dir, Shard::ALL).unwrap_err();
    let unicac_dataset::DatasetError::Setting { field, message } = &error else {
        panic!("{error}")
    };
    assert_eq!(field, "unseen_by");
    let lenses = unicac_dataset::folder::Dataset::open(reference())
        .unwrap()
        .lenses()
        .unwrap();
    let seen = lenses.iter().filter(|row| row.split != "test").count();
    assert!(
        message.contains(&format!("{seen} of the {} lenses given", LENSES.len())),
        "{message}"
    );
    assert!(!dir.exists(), "nothing is written before the refusal");
    // A file where the dataset should be is named as such.
    s.unseen_by = Some(reference().join("dataset.json"));
    let error = build_with(2, &s, &dir, Shard::ALL).unwrap_err().to_string();
    assert!(error.contains("dataset.json: not a folder"), "{error}");
    s.unseen_by = Some(reference().to_path_buf());
    // Its test lenses alone are unseen: they make a test set.
    s.lenses = lenses
        .iter()
        .filter(|row| row.split == "test")
        .map(|row| row.source.clone())
        .collect();
    (s.levels, s.test_lenses_per_level, s.val_lenses, s.sub_benchmarks) = (1, 1, 0, false);
    assert!(build_with(2, &s, &dir, Shard::ALL).unwrap().complete);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A folder begun by a release whose sensor noise had another generator (its record has no
/// `noise_draws`) is not resumed into a mix of two noise realisations; without noise nothing differs.
#[test]
fn a_folder_begun_with_another_noise_generator_is_not_resumed() {
    let older_record = |s: &BuildSettings| {
        serde_json::json!({"settings": serde_json::to_value(s).unwrap(), "scenes": null}).to_string()
    };
    let out = scratch("older-noise");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join(builder::claim::BUILD_JSON), older_record(&settings())).unwrap();
    let error = builder::build(&settings(), &out, Shard::ALL, &Silent)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("different settings") && error.contains("drawn by another release"),
        "{error}"
    );
    let mut noiseless = settings();
    noiseless.noise = false;
    std::fs::write(out.join(builder::claim::BUILD_JSON), older_record(&noiseless)).unwrap();
    assert!(
        builder::build(&noiseless, &out, Shard::ALL, &Silent)
            .unwrap()
            .complete
    );
    let _ = std::fs::remove_dir_all(&out);
}
