//! `unicac dataset info` and `plot`: what a built dataset holds, read back from its manifests.

use crate::error::{DatasetError, Result};
use crate::folder::Dataset;
use crate::manifest::{LensRow, PairRow, PairTask, Stratification};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// One level of one stratification as found in the dataset.
#[derive(Debug, Clone, Serialize)]
pub struct LevelInfo {
    pub metric: String,
    pub level: u32,
    pub lenses: usize,
    pub test_pairs: usize,
    /// The recorded thresholds: the level holds [lower, upper].
    pub lower: f64,
    pub upper: f64,
    /// The range of the metric over the level's lenses [min, max], and of the ODE.
    pub range: [f64; 2],
    pub ode_range: [f64; 2],
}

#[derive(Debug, Clone, Serialize)]
pub struct DatasetInfo {
    pub dir: String,
    pub unicac_version: String,
    pub frame_px: [usize; 2],
    /// The sensor every lens was graded on (`unicac ode --frame` with these settings prints the ODE
    /// `lenses.jsonl` records).
    pub grading: unicac_ode::FrameSensor,
    pub lenses: BTreeMap<String, usize>,
    pub pairs: BTreeMap<String, usize>,
    pub edges: usize,
    pub levels: Vec<LevelInfo>,
    /// What the pairs ask a model to undo, and whether the ODE levels order their difficulty.
    pub task: PairTask,
    pub comparable_by_ode_level: bool,
    /// The pairs' checks by lens (lenses with pairs, in manifest order).
    pub pair_checks: Vec<LensPairChecks>,
    /// Bytes of every file under the folder, and of the cache (`.cache`) among them.
    pub disk_bytes: u64,
    pub cache_bytes: u64,
}

/// A lens's pairs are flagged when their mean registration shift exceeds this (px): pixels of LQ
/// and GT no longer correspond, so a model is taught to move pixels.
pub const MISREGISTERED_PX: f64 = 0.5;
/// ... or when blur explains less than this share of the lens's part of their error (the rest is
/// the warp or the shading: not what the ODE grades).
pub const MIN_BLUR_SHARE: f64 = 0.5;

/// The mean checks of one lens's pairs (docs/dataset.md, "Pair checks").
#[derive(Debug, Clone, Serialize)]
pub struct LensPairChecks {
    pub lens_id: String,
    pub split: String,
    pub level: Option<u32>,
    pub ode: f64,
    /// Pairs of the lens, and how many of them carry checks (all in a complete dataset).
    pub pairs: usize,
    pub checked: usize,
    pub mean_lq_gt_psnr_db: Option<f64>,
    pub mean_registration_px: Option<f64>,
    pub mean_blur_share: Option<f64>,
    /// Why the lens's pairs are dominated by something other than blur; None when they are not.
    pub flag: Option<String>,
}

fn lens_pair_checks(lens: &LensRow, pairs: &[&PairRow]) -> LensPairChecks {
    let checks: Vec<_> = pairs.iter().filter_map(|p| p.check).collect();
    let mean = |value: fn(&crate::manifest::PairCheck) -> f64| {
        (!checks.is_empty()).then(|| checks.iter().map(value).sum::<f64>() / checks.len() as f64)
    };
    let (psnr, shift, share) = (
        mean(|c| c.lq_gt_psnr_db),
        mean(|c| c.registration_px),
        mean(|c| c.blur_share),
    );
    LensPairChecks {
        lens_id: lens.lens_id.clone(),
        split: lens.split.clone(),
        level: lens.level,
        ode: lens.scores.ode,
        pairs: pairs.len(),
        checked: checks.len(),
        mean_lq_gt_psnr_db: psnr,
        mean_registration_px: shift,
        mean_blur_share: share,
        flag: pair_check_flag(shift, share),
    }
}

/// The mean checks of each lens's pairs among `pairs`, for the lenses that have some, in the order of
/// `lenses` (what `unicac dataset info` prints and the trainer checks before training).
pub fn pair_checks(lenses: &[LensRow], pairs: &[PairRow]) -> Vec<LensPairChecks> {
    lenses
        .iter()
        .filter_map(|lens| {
            let own: Vec<&PairRow> = pairs.iter().filter(|p| p.lens_id == lens.lens_id).collect();
            (!own.is_empty()).then(|| lens_pair_checks(lens, &own))
        })
        .collect()
}

/// Why a lens's pairs, with mean registration shift `shift_px` and mean blur share `blur_share`, are
/// dominated by something other than blur (None: they are not, or carry no checks). The one rule
/// behind `unicac dataset info`, the trainer's refusal (`unicac.dataset`, through the bindings) and
/// docs/dataset.md "Pair checks".
pub fn pair_check_flag(shift_px: Option<f64>, blur_share: Option<f64>) -> Option<String> {
    let mut reasons = Vec::new();
    if let Some(shift) = shift_px.filter(|&s| s > MISREGISTERED_PX) {
        reasons.push(format!(
            "misregistered: LQ and GT pixels are {shift:.2} px apart (> {MISREGISTERED_PX})"
        ));
    }
    if let Some(share) = blur_share.filter(|&s| s < MIN_BLUR_SHARE) {
        reasons.push(format!(
            "blur explains {:.0}% of the lens's LQ-GT error (< {:.0}%); the rest is distortion or shading",
            100.0 * share,
            100.0 * MIN_BLUR_SHARE
        ));
    }
    (!reasons.is_empty()).then(|| reasons.join("; "))
}

fn metric_of(row: &LensRow, metric: &str) -> f64 {
    match metric {
        "u_s" => row.scores.u_s,
        "u_c" => row.scores.u_c,
        "oiq" => row.scores.oiq,
        _ => row.scores.ode,
    }
}

fn level_of(row: &LensRow, metric: &str) -> Option<u32> {
    row.level_in(metric)
}

fn range(values: impl Iterator<Item = f64>) -> [f64; 2] {
    values.fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| {
        [lo.min(v), hi.max(v)]
    })
}

pub fn info(dir: &Path) -> Result<DatasetInfo> {
    let dataset = Dataset::open(dir)?;
    let lenses = dataset.lenses()?;
    let pairs = dataset.pairs()?;
    let edges = dataset.edges()?;
    let mut lens_counts = BTreeMap::new();
    for row in &lenses {
        *lens_counts.entry(row.split.clone()).or_insert(0) += 1;
    }
    let mut pair_counts = BTreeMap::new();
    for row in &pairs {
        *pair_counts.entry(row.split.clone()).or_insert(0) += 1;
    }
    let by_id: BTreeMap<&str, &LensRow> = lenses.iter().map(|l| (l.lens_id.as_str(), l)).collect();
    let mut levels = Vec::new();
    for Stratification {
        metric,
        levels: summaries,
        ..
    } in &dataset.manifest.stratifications
    {
        for summary in summaries {
            let members: Vec<&LensRow> = lenses
                .iter()
                .filter(|l| level_of(l, metric) == Some(summary.level))
                .collect();
            let test_pairs = pairs
                .iter()
                .filter(|p| {
                    p.split == "test"
                        && by_id
                            .get(p.lens_id.as_str())
                            .is_some_and(|l| level_of(l, metric) == Some(summary.level))
                })
                .count();
            levels.push(LevelInfo {
                metric: metric.clone(),
                level: summary.level,
                lenses: members.len(),
                test_pairs,
                lower: summary.lower,
                upper: summary.upper,
                range: range(members.iter().map(|l| metric_of(l, metric))),
                ode_range: range(members.iter().map(|l| l.scores.ode)),
            });
        }
    }
    let pair_checks = pair_checks(&lenses, &pairs);
    let (disk_bytes, cache_bytes) = disk_usage(dir)?;
    Ok(DatasetInfo {
        dir: dir.display().to_string(),
        unicac_version: dataset.manifest.unicac_version.clone(),
        frame_px: dataset.manifest.frame_px,
        grading: unicac_ode::FrameSensor {
            frame_px: dataset.manifest.frame_px,
            pixel_um: dataset.manifest.settings["pixel_um"].as_f64(),
        },
        lenses: lens_counts,
        pairs: pair_counts,
        edges: edges.len(),
        levels,
        task: dataset.manifest.task,
        comparable_by_ode_level: dataset.manifest.comparable_by_ode_level,
        pair_checks,
        disk_bytes,
        cache_bytes,
    })
}

fn disk_usage(dir: &Path) -> Result<(u64, u64)> {
    let (mut total, mut cache) = (0u64, 0u64);
    let mut stack = vec![(dir.to_path_buf(), false)];
    while let Some((folder, in_cache)) = stack.pop() {
        for entry in std::fs::read_dir(&folder).map_err(|e| DatasetError::io(&folder, e))? {
            let entry = entry.map_err(|e| DatasetError::io(&folder, e))?;
            let meta = entry.metadata().map_err(|e| DatasetError::io(entry.path(), e))?;
            let cached = in_cache || (folder == dir && entry.file_name() == ".cache");
            if meta.is_dir() {
                stack.push((entry.path(), cached));
            } else {
                total += meta.len();
                if cached {
                    cache += meta.len();
                }
            }
        }
    }
    Ok((total, cache))
}

/// The lens distribution: ODE, OIQ, U_s and U_c histograms of the test lenses, one colour per ODE level.
pub fn plot(dir: &Path, out: &Path) -> Result<()> {
    let dataset = Dataset::open(dir)?;
    let lenses = dataset.lenses()?;
    let levels = dataset
        .manifest
        .stratifications
        .iter()
        .find(|s| s.metric == "ode")
        .map_or(0, |s| s.levels.len());
    if levels == 0 {
        return Err(DatasetError::format(dir, "dataset.json records no ODE levels"));
    }
    let names: Vec<String> = (1..=levels).map(|k| format!("ODE level {k}")).collect();
    let panels: Vec<unicac_plot::LevelHistogram> =
        [("ODE", "ode"), ("OIQ", "oiq"), ("U_s", "u_s"), ("U_c", "u_c")]
            .iter()
            .map(|(label, metric)| unicac_plot::LevelHistogram {
                metric: (*label).into(),
                values_by_level: (1..=levels as u32)
                    .map(|k| {
                        lenses
                            .iter()
                            .filter(|l| l.level == Some(k))
                            .map(|l| metric_of(l, metric))
                            .collect()
                    })
                    .collect(),
            })
            .collect();
    unicac_plot::level_histograms(&plot_title(dir), &names, &panels, out).map_err(|source| {
        DatasetError::Plot {
            context: out.display().to_string(),
            source,
        }
    })
}

/// The level plot's title: it names the dataset by its folder's own name, never by a path (a machine's
/// path says nothing to a reader of the picture, and a committed picture would carry it).
pub fn plot_title(dir: &Path) -> String {
    format!("Test lenses of {} by ODE level", dataset_name(dir))
}

/// A dataset's name for pictures and tables: the last component of `dir` (`.`, `..` and trailing
/// separators resolved first, since they name no folder by themselves), never a machine's path.
pub fn dataset_name(dir: &Path) -> String {
    let resolved = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    resolved
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "the dataset".into())
}

#[cfg(test)]
mod tests {
    use super::plot_title;
    use std::path::Path;

    #[test]
    fn the_plot_title_names_the_dataset_folder_without_its_path() {
        // A path that does not exist here (the small run's): its last component is the name.
        assert_eq!(
            plot_title(Path::new("/work/repro-small/dataset")),
            "Test lenses of dataset by ODE level"
        );
        // `.` names a real folder once resolved; the root names none.
        let here = std::env::current_dir().unwrap();
        let name = here.file_name().unwrap().to_string_lossy().into_owned();
        assert_eq!(
            plot_title(Path::new(".")),
            format!("Test lenses of {name} by ODE level")
        );
        assert_eq!(
            plot_title(Path::new("/")),
            "Test lenses of the dataset by ODE level"
        );
        for dir in [
            "/work/repro-small/dataset",
            ".",
            "/",
            "out/reproduce-small/dataset/",
        ] {
            assert!(!plot_title(Path::new(dir)).contains('/'), "{dir}");
        }
    }
}
