//! `unicac bench`: the plan first (`plan.rs`: every check before any work), then every pair of the
//! split through every method, then the report.

use std::path::PathBuf;

use unicac_dataset::PairRow;

use crate::choices::ClassicalMethod;
use crate::edges::edge_groups;
use crate::error::Result;
pub use crate::inputs::{read_rgb, InputMaps};
pub use crate::model_run::{run_onnx, run_onnx_batch, run_onnx_with};
use crate::plan::{LearnedJudges, Plan};
use crate::report::summarise;
use crate::report::write::{write_report, Report};
use crate::report::Scores;
use crate::scoring::{method_entries, EdgeScores, Judges, LensTables, Needs, Pass, Running};
pub use crate::settings::{BenchSettings, MAX_THREADS, MAX_WIENER_NSR};

/// Progress of a run (`unicac_io::progress`): one stage, "test pixels", whose work is counted in pixels
/// (each test pair's and edge patch's, through every method), to which a run's time is about
/// proportional, so the share done gives a fair estimate of the time left even though pairs are larger
/// than patches.
pub use unicac_io::progress::Progress;

/// The name of the bench's one progress stage.
pub const PROGRESS_STAGE: &str = "test pixels";

/// The whole benchmark; returns the report and the files written.
pub fn run_bench(s: &BenchSettings, progress: &dyn Progress) -> Result<(Report, Vec<PathBuf>)> {
    let plan = crate::plan::plan(s)?;
    // Every check passed: the report folder is made (or a previous report cleared) before the work.
    let created = crate::report::folder::claim(&s.out)?;
    let result = benchmark(s, progress, plan);
    if result.is_err() && created {
        let _ = std::fs::remove_dir_all(&s.out);
    }
    result
}

/// Every pair and edge patch through every method, then the report.
fn benchmark(s: &BenchSettings, progress: &dyn Progress, plan: Plan) -> Result<(Report, Vec<PathBuf>)> {
    let Plan {
        mut notices,
        loaded,
        runtime,
        dataset,
        pairs,
        lenses,
        has_psf,
        available,
        judges: LearnedJudges { lpips, fid, clip },
        edges,
        basis,
        designs,
    } = plan;
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
    let pairs_px: usize = pairs
        .iter()
        .chain(designs.iter().flat_map(|d| &d.pairs))
        .map(pair_px)
        .sum();
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
    // The as-built split's designs, through the same methods: what the units' pairs are compared with.
    let mut design_scores = Scores::default();
    if let Some(designs) = &designs {
        let mut design_pass = Pass {
            pairs: &designs.pairs,
            lenses: &designs.lenses,
            ..pass
        };
        for pair in &designs.pairs {
            design_pass.score_pair(pair, &mut entries, &mut design_scores)?;
            progress.advance(pair_px(pair));
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
    let as_built = designs.as_ref().map(|d| crate::report::as_built::AsBuiltReport {
        units_per_lens: pairs.len() / d.pairs.len().max(1),
        rows: crate::report::as_built::as_built_loss(&scores.pairs, &design_scores.pairs, &names),
    });
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
        as_built,
    };
    // The design references' rows follow the units' in pairs.csv, so the as-built table can be
    // recomputed (or regrouped) outside unicac.
    let listed: Vec<_> = scores.pairs.iter().chain(&design_scores.pairs).cloned().collect();
    let written = write_report(&s.out, &report, &listed)?;
    Ok((report, written))
}
