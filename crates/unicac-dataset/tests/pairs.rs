//! What a pair teaches (docs/dataset.md, "What a pair teaches" and "Pair checks"): `aligned` pairs of
//! a strongly distorting wide angle differ by blur alone, `full` ones also by the lens's geometry,
//! and every pair records checks that tell the two apart.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use unicac_dataset::builder::{self, BuildSettings, PairTask, Shard, Silent};
use unicac_dataset::folder::Dataset;
use unicac_dataset::info::{info, MIN_BLUR_SHARE, MISREGISTERED_PX};
use unicac_dataset::manifest::PairRow;

/// Laikin's 100-degree retrofocus (lenses/wide_angle_100.json: strong barrel distortion and
/// fall-off) among two bundled lenses.
fn wide() -> String {
    format!("{}/../../lenses/wide_angle_100.json", env!("CARGO_MANIFEST_DIR"))
}
const WIDE_ID: &str = "wide_angle_100";

fn settings(task: PairTask) -> BuildSettings {
    let lenses = vec![
        "builtin:cooke_triplet".into(),
        "builtin:double_gauss".into(),
        wide(),
    ];
    let mut s = BuildSettings::new(
        lenses,
        "dead-leaves:2:128x96".parse().unwrap(),
        "dead-leaves:1".parse().unwrap(),
    );
    s.frame_px = Some([128, 96]);
    s.levels = 1;
    s.test_lenses_per_level = 1;
    s.val_lenses = 1;
    s.pairs_per_lens = 2;
    s.crop_px = Some([64, 48]);
    s.seed = 5;
    s.task = task;
    s
}

fn built(task: PairTask) -> &'static Path {
    static ALIGNED: OnceLock<PathBuf> = OnceLock::new();
    static FULL: OnceLock<PathBuf> = OnceLock::new();
    let slot = match task {
        PairTask::Aligned => &ALIGNED,
        PairTask::Full => &FULL,
    };
    slot.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("unicac-pairs-{}-{}", task.name(), std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let report = builder::build(&settings(task), &dir, Shard::ALL, &Silent).unwrap();
        assert!(report.complete);
        dir
    })
}

fn wide_pairs(dir: &Path) -> Vec<PairRow> {
    let dataset = Dataset::open(dir).unwrap();
    let wide = dataset
        .lenses()
        .unwrap()
        .into_iter()
        .find(|l| l.lens_id.starts_with(WIDE_ID))
        .unwrap();
    dataset
        .pairs()
        .unwrap()
        .into_iter()
        .filter(|p| p.lens_id == wide.lens_id)
        .collect()
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let values: Vec<f64> = values.collect();
    values.iter().sum::<f64>() / values.len() as f64
}

#[test]
fn aligned_pairs_of_a_distorting_lens_differ_by_blur_while_full_ones_are_misregistered() {
    let aligned = wide_pairs(built(PairTask::Aligned));
    let full = wide_pairs(built(PairTask::Full));
    assert!(!aligned.is_empty() && aligned.len() == full.len());
    let psnr = |pairs: &[PairRow]| mean(pairs.iter().map(|p| p.check.unwrap().lq_gt_psnr_db));
    let shift = |pairs: &[PairRow]| mean(pairs.iter().map(|p| p.check.unwrap().registration_px));
    let share = |pairs: &[PairRow]| mean(pairs.iter().map(|p| p.check.unwrap().blur_share));
    println!(
        "wide angle: aligned {:.2} dB, {:.2} px, share {:.3}; full {:.2} dB, {:.2} px, share {:.3}",
        psnr(&aligned),
        shift(&aligned),
        share(&aligned),
        psnr(&full),
        shift(&full),
        share(&full)
    );
    assert!(psnr(&aligned) > 25.0, "aligned pairs: {} dB", psnr(&aligned));
    assert!(
        psnr(&aligned) > psnr(&full) + 5.0,
        "aligned {} dB vs full {} dB",
        psnr(&aligned),
        psnr(&full)
    );
    assert!(
        shift(&aligned) < MISREGISTERED_PX,
        "aligned shift {}",
        shift(&aligned)
    );
    assert!(shift(&full) > MISREGISTERED_PX, "full shift {}", shift(&full));
    assert!(share(&aligned) > MIN_BLUR_SHARE && share(&full) < MIN_BLUR_SHARE);
    for (a, f) in aligned.iter().zip(&full) {
        assert_eq!((a.task, f.task), (PairTask::Aligned, PairTask::Full));
        // Same scene, crop, seed: only the GT's geometry differs, so the LQ is the same image.
        assert_eq!(a.seed, f.seed);
        let read = |dir: &Path, rel: &str| std::fs::read(dir.join(rel)).unwrap();
        assert_eq!(
            read(built(PairTask::Aligned), &a.lq),
            read(built(PairTask::Full), &f.lq)
        );
        assert_ne!(
            read(built(PairTask::Aligned), &a.gt),
            read(built(PairTask::Full), &f.gt)
        );
    }
}

#[test]
fn every_pair_records_finite_checks_and_the_dataset_records_its_task() {
    for task in [PairTask::Aligned, PairTask::Full] {
        let dir = built(task);
        let dataset = Dataset::open(dir).unwrap();
        assert_eq!(dataset.manifest.task, task);
        assert_eq!(dataset.manifest.settings["task"], task.name());
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("dataset.json")).unwrap()).unwrap();
        assert_eq!(json["comparable_by_ode_level"], task == PairTask::Aligned);
        let text = std::fs::read_to_string(dir.join("pairs.jsonl")).unwrap();
        let mut rows = 0;
        for line in text.lines() {
            let row: serde_json::Value = serde_json::from_str(line).unwrap();
            assert_eq!(row["task"], task.name());
            for field in ["lq_gt_psnr_db", "registration_px", "blur_share"] {
                let value = row[field].as_f64().unwrap_or(f64::NAN);
                assert!(value.is_finite(), "{} {field}: {}", row["pair_id"], row[field]);
            }
            rows += 1;
        }
        assert_eq!(rows, dataset.pairs().unwrap().len());
    }
}

#[test]
fn info_flags_the_wide_angle_only_when_its_gt_is_undistorted() {
    let flagged = |task| -> Vec<String> {
        info(built(task))
            .unwrap()
            .pair_checks
            .into_iter()
            .filter(|l| l.flag.is_some())
            .map(|l| l.lens_id)
            .collect()
    };
    let full = flagged(PairTask::Full);
    assert!(full.iter().any(|id| id.starts_with(WIDE_ID)), "{full:?}");
    assert_eq!(flagged(PairTask::Aligned), Vec::<String>::new());
    let summary = info(built(PairTask::Full)).unwrap();
    assert!(!summary.comparable_by_ode_level);
    let wide = summary
        .pair_checks
        .iter()
        .find(|l| l.lens_id.starts_with(WIDE_ID))
        .unwrap();
    assert!(
        wide.flag.as_deref().unwrap().contains("misregistered"),
        "{:?}",
        wide.flag
    );
    assert_eq!(wide.checked, wide.pairs);
}

#[test]
fn switching_the_distortion_and_shading_off_makes_both_tasks_the_same_pairs() {
    // With the geometry off there is nothing for `aligned` to carry into the GT.
    let dir = |task: PairTask| {
        std::env::temp_dir().join(format!("unicac-pairs-off-{}-{}", task.name(), std::process::id()))
    };
    let mut pngs = Vec::new();
    for task in [PairTask::Aligned, PairTask::Full] {
        let mut s = settings(task);
        s.distortion = false;
        s.illumination = false;
        let out = dir(task);
        let _ = std::fs::remove_dir_all(&out);
        assert!(builder::build(&s, &out, Shard::ALL, &Silent).unwrap().complete);
        let pairs = Dataset::open(&out).unwrap().pairs().unwrap();
        assert!(pairs.iter().all(|p| !p.distortion && !p.illumination));
        pngs.push(
            pairs
                .iter()
                .flat_map(|p| {
                    [
                        std::fs::read(out.join(&p.lq)).unwrap(),
                        std::fs::read(out.join(&p.gt)).unwrap(),
                    ]
                })
                .collect::<Vec<_>>(),
        );
    }
    assert!(
        pngs[0] == pngs[1],
        "aligned and full pairs differ with the geometry off"
    );
    for task in [PairTask::Aligned, PairTask::Full] {
        std::fs::remove_dir_all(dir(task)).unwrap();
    }
}
