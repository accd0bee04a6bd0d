//! Issue 28, the dataset half, in the library: one lens under two names, counts and sizes with stated
//! limits, the folder's claim, and an output never inside an input folder, each refused before any
//! work (no grading, no folder made). Each test failed (or panicked) before its fix.

use std::path::{Path, PathBuf};
use unicac_dataset::builder::{self, claim, BuildSettings, SceneSource, Shard, Silent};
use unicac_dataset::DatasetError;

fn settings(lenses: &[&str]) -> BuildSettings {
    let lenses = lenses.iter().map(|l| l.to_string()).collect();
    let mut s = BuildSettings::new(
        lenses,
        "dead-leaves:2:80x60".parse().unwrap(),
        "dead-leaves:1".parse().unwrap(),
    );
    s.frame_px = Some([64, 48]);
    s.levels = 1;
    s.test_lenses_per_level = 1;
    s.val_lenses = 0;
    s.pairs_per_lens = 1;
    s.crop_px = Some([32, 24]);
    s
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("unicac-dataset-reliability-{}", std::process::id()))
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn refused(settings: &BuildSettings, out: &Path) -> DatasetError {
    let error = builder::build(settings, out, Shard::ALL, &Silent).unwrap_err();
    assert!(!out.exists(), "{error}: {} was made", out.display());
    error
}

fn repository_lens(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../lenses")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// Case 1: a lens's identity was the SHA-256 of its file's bytes, so the built-in lens, its JSON file,
/// a copy with a trailing newline and its `.zmx` conversion were four lenses that could land in four splits.
#[test]
fn the_same_lens_under_two_names_is_refused_before_any_work() {
    let dir = scratch("same-lens");
    let json = repository_lens("cooke_triplet.json");
    let copy = dir.join("copy.json");
    let mut bytes = std::fs::read(&json).unwrap();
    bytes.push(b'\n');
    std::fs::write(&copy, bytes).unwrap();
    let zmx = dir.join("cooke.zmx");
    let spec = unicac_optics::builtin::spec("cooke_triplet").unwrap();
    unicac_optics::write_spec(&spec, &zmx).unwrap();
    let out = dir.join("ds");
    for other in [json.as_str(), copy.to_str().unwrap(), zmx.to_str().unwrap()] {
        let error = refused(
            &settings(&["builtin:double_gauss", "builtin:cooke_triplet", other]),
            &out,
        )
        .to_string();
        let named = Path::new(other)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        assert!(
            error.contains("builtin:cooke_triplet")
                && error.contains(&named)
                && error.contains("are the same lens"),
            "{error}"
        );
    }
    // Two different lenses are not one.
    let two = settings(&["builtin:double_gauss", "builtin:cooke_triplet", "builtin:petzval"]);
    let mut too_few = two.clone();
    too_few.val_lenses = 5;
    assert!(refused(&too_few, &out)
        .to_string()
        .contains("the library holds 3 lenses"));
}

/// A change to the settings.
type Change = Box<dyn Fn(&mut BuildSettings)>;

/// `--test-lenses-per-level 9223372036854775808` panicked with "capacity overflow" (the sum wrapped),
/// a 1 x 1 crop was accepted though no metric can score it, and bad counts or oversized charts were
/// refused only after every lens was graded.
#[test]
fn every_count_and_size_has_a_limit_checked_before_any_work() {
    let dir = scratch("limits");
    let out = dir.join("ds");
    let lenses = ["builtin:double_gauss", "builtin:cooke_triplet", "builtin:petzval"];
    let cases: Vec<(&str, Change, &str)> = vec![
        (
            "test_lenses_per_level",
            Box::new(|s| s.test_lenses_per_level = 1 << 63),
            "MAX_TEST_LENSES_PER_LEVEL",
        ),
        (
            "test_lenses_per_level",
            Box::new(|s| {
                s.levels = 100;
                s.test_lenses_per_level = 1_000_000
            }),
            "MAX_ITEMS",
        ),
        ("levels", Box::new(|s| s.levels = 0), "MAX_LEVELS"),
        ("levels", Box::new(|s| s.levels = 101), "MAX_LEVELS"),
        (
            "val_lenses",
            Box::new(|s| s.val_lenses = usize::MAX),
            "MAX_VAL_LENSES",
        ),
        (
            "pairs_per_lens",
            Box::new(|s| s.pairs_per_lens = usize::MAX),
            "MAX_PAIRS_PER_LENS",
        ),
        ("crop_px", Box::new(|s| s.crop_px = Some([1, 1])), "[11, 32768]"),
        (
            "crop_px",
            Box::new(|s| s.crop_px = Some([10, 24])),
            "MIN_CROP_SIDE_PX",
        ),
        (
            "crop_px",
            Box::new(|s| s.crop_px = Some([65, 24])),
            "larger than the 64 x 48 frame",
        ),
        (
            "frame_px",
            Box::new(|s| s.frame_px = Some([8, 8])),
            "MIN_CROP_SIDE_PX",
        ),
        (
            "frame_px",
            Box::new(|s| s.frame_px = Some([32768, 32768])),
            "MAX_SIMULATE_PIXELS",
        ),
        (
            "images",
            Box::new(|s| s.images = "dead-leaves:1:32768x32768".parse().unwrap()),
            "MAX_CHART_PIXELS",
        ),
        (
            "test_images",
            Box::new(|s| s.test_images = "dead-leaves:0".parse().unwrap()),
            "dead-leaves:N",
        ),
        (
            "test_lenses_per_level",
            Box::new(|s| s.test_lenses_per_level = 5),
            "holds 3 lenses",
        ),
    ];
    for (field, change, expected) in cases {
        let mut s = settings(&lenses);
        change(&mut s);
        let start = std::time::Instant::now();
        let error = refused(&s, &out);
        assert!(
            start.elapsed().as_secs() < 10,
            "{field}: took {:?}",
            start.elapsed()
        );
        let text = error.to_string();
        assert!(text.contains(expected), "{field}: expected {expected} in: {text}");
        if let DatasetError::Setting { field: named, .. } = &error {
            assert_eq!(named, field, "{text}");
        }
    }
}

/// Case 3: two builds with different settings into one new folder both ran and mixed their files: the
/// settings were recorded only after grading.
#[test]
fn a_folder_claimed_by_other_settings_is_refused_and_the_same_settings_resume() {
    let dir = scratch("claim");
    let out = dir.join("ds");
    let first = settings(&["builtin:double_gauss", "builtin:cooke_triplet"]);
    let record = |s: &BuildSettings| claim::BuildRecord {
        settings: serde_json::to_value(s).unwrap(),
        scenes: Some(Default::default()),
    };
    // The first build's claim, as it stands while it grades.
    let held = claim::claim(&out, &record(&first)).unwrap();
    let mut second = first.clone();
    second.seed = 7;
    let error = claim::claim(&out, &record(&second)).unwrap_err().to_string();
    assert!(
        error.contains("another build with different settings holds this folder") && error.contains("seed"),
        "{error}"
    );
    let error = builder::build(&second, &out, Shard::ALL, &Silent)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("another build with different settings holds this folder"),
        "{error}"
    );
    // The same settings share the folder (a resume, another shard); a claim this run made is released
    // when the run fails before writing.
    drop(claim::claim(&out, &record(&first)).unwrap());
    assert!(out.join(claim::BUILD_JSON).exists());
    drop(held);
    assert!(!out.join(claim::BUILD_JSON).exists());
    claim::claim(&out, &record(&second)).unwrap().keep();
    assert!(claim::confirm(&out, &record(&first)).is_err());
}

/// Case 8: the record names a scene file whose bytes changed since the build began.
#[test]
fn a_changed_scene_is_named() {
    let dir = scratch("scene");
    let out = dir.join("ds");
    let s = settings(&["builtin:double_gauss", "builtin:cooke_triplet"]);
    let with = |hash: &str| claim::BuildRecord {
        settings: serde_json::to_value(&s).unwrap(),
        scenes: Some(
            [("imgs/a.png".to_string(), hash.to_string())]
                .into_iter()
                .collect(),
        ),
    };
    claim::claim(&out, &with("aaaaaaaaaaaaaaaa")).unwrap().keep();
    let error = claim::confirm(&out, &with("bbbbbbbbbbbbbbbb"))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("the scene imgs/a.png changed since this build began")
            && error.contains("aaaaaaaaaaaa then, bbbbbbbbbbbb now"),
        "{error}"
    );
}

/// Case 5: `--out` inside the `--images` folder: a rerun scanned its own output as scenes.
#[test]
fn an_output_inside_an_input_folder_is_refused() {
    let dir = scratch("inside");
    let images = dir.join("images");
    std::fs::create_dir_all(&images).unwrap();
    let chart = unicac_image::charts::dead_leaves(80, 60, 1).unwrap();
    unicac_image::io::write_png(images.join("a.png"), &chart, unicac_image::io::SampleDepth::Eight).unwrap();
    let mut s = settings(&["builtin:double_gauss", "builtin:cooke_triplet"]);
    s.images = SceneSource::Path(images.clone());
    let error = refused(&s, &images.join("ds")).to_string();
    assert!(error.contains("lies inside the input folder"), "{error}");
    let error = refused(&s, &images.join("sub").join("ds")).to_string();
    assert!(error.contains("lies inside the input folder"), "{error}");
    // An input inside the output folder is the build's own output too.
    let error = builder::build(&s, &dir, Shard::ALL, &Silent)
        .unwrap_err()
        .to_string();
    assert!(error.contains("holds the input"), "{error}");
}
