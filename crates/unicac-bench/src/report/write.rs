//! The files of REPORT_DIR: `results.json`, `pairs.csv`, `tables.md`, `tables/{ode,us,uc}.tex`, and the
//! pictures `ranking_trend.png` (the paper's Fig. 5), `metric_{psnr,ssim,lpips,op}.png` (per-metric
//! lines across the `ode` levels) and `analysis.png` (per-lens O.P. against ODE and RMS radius with the
//! least-squares lines), and `report.html` (all of it on one self-contained page). Every file is written
//! atomically.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{tables, PairScore, ResultRow, Results};
use crate::choices::{Benchmark, Split};
use crate::error::Result;
use unicac_learned_metrics::npz::write_atomically;
use unicac_onnx::cost::ModelCost;

/// One benchmarked method as the report describes it.
#[derive(Debug, Clone, Serialize)]
pub struct ModelInfo {
    pub name: String,
    /// `identity`, `wiener` or `onnx`.
    pub kind: String,
    pub path: Option<PathBuf>,
    pub inputs: Vec<String>,
    pub metadata: std::collections::BTreeMap<String, String>,
    pub cost: Option<ModelCost>,
    /// Pairs that failed (image named, with the reason); the others went on.
    pub failures: Vec<String>,
}

/// Everything `results.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub unicac_version: &'static str,
    pub dataset: PathBuf,
    pub split: Split,
    pub benchmarks: Vec<Benchmark>,
    /// Metric name -> available (false: reported as null, see `notices`).
    pub metrics: std::collections::BTreeMap<String, bool>,
    pub notices: Vec<String>,
    /// The onnxruntime library loaded and how it was found (None: not loaded).
    pub onnxruntime: Option<unicac_onnx::ort_library::Located>,
    pub models: Vec<ModelInfo>,
    #[serde(flatten)]
    pub results: Results,
    /// With `--split as_built`: each method's loss against the designs (`report::as_built`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub as_built: Option<super::as_built::AsBuiltReport>,
}

fn csv_number(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.6}")).unwrap_or_default()
}

/// `pairs.csv`: `model,pair_id,lens_id,level,psnr_db,ssim,lpips,clipiqa` (empty = unavailable).
pub fn pairs_csv(pairs: &[PairScore]) -> String {
    let mut out = String::from("model,pair_id,lens_id,level,psnr_db,ssim,lpips,clipiqa\n");
    for p in pairs {
        out.push_str(&format!(
            "{},{},{},{},{:.6},{:.6},{},{}\n",
            p.model,
            p.pair_id,
            p.lens_id,
            p.level,
            p.psnr_db,
            p.ssim,
            csv_number(p.lpips),
            csv_number(p.clipiqa)
        ));
    }
    out
}

/// `lens_op.csv`: per model and lens, the O.P. the analysis uses with the lens's metrics
/// (`model,lens_id,ode,rms_radius_um,op`), so every analysis figure can be recomputed outside unicac.
pub fn lens_op_csv(analysis: &super::Analysis) -> String {
    let mut out = String::from("model,lens_id,ode,rms_radius_um,op\n");
    for (model, a) in &analysis.per_model {
        for p in &a.points {
            out.push_str(&format!(
                "{model},{},{:.6},{:.6},{:.6}\n",
                p.lens_id, p.ode, p.rms_radius_um, p.op
            ));
        }
    }
    out
}

fn cost_table(models: &[ModelInfo]) -> String {
    let mut out = String::from("### Model cost (1 x 3 x 256 x 256)\n\n| model | inputs | params | GFLOPs | latency (ms) |\n|---|---|---:|---:|---:|\n");
    for m in models {
        let (params, flops, latency) = match &m.cost {
            Some(c) => (
                c.params.to_string(),
                format!("{:.3}", c.flops_g),
                format!("{:.1}", c.latency_ms),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        out.push_str(&format!(
            "| {} | {} | {params} | {flops} | {latency} |\n",
            m.name,
            m.inputs.join(", ")
        ));
    }
    out
}

fn overall_table(report: &Report) -> String {
    let mut out = String::from("### Overall (all test pairs)\n\n| rank | model | PSNR | SSIM | LPIPS | OIQE | FID | ClipIQA | O.P. | O.P. terms |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|---|\n");
    let mut rows: Vec<_> = report.results.overall.iter().collect();
    // Unranked models (no scored pair) last.
    rows.sort_by_key(|r| r.rank.unwrap_or(usize::MAX));
    let f = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |v| format!("{v:.d$}"));
    for r in rows {
        let x = &r.row;
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.rank.map_or("-".to_string(), |k| k.to_string()),
            x.model,
            f(x.psnr_db, 2),
            f(x.ssim, 4),
            f(x.lpips, 4),
            f(x.oiqe, 4),
            f(x.fid, 2),
            f(x.clipiqa, 4),
            f(x.op, 4),
            if x.op_complete {
                "all".to_string()
            } else {
                x.op_terms.join("+")
            }
        ));
    }
    out
}

/// Writes every report file into `dir`; returns the paths written.
pub fn write_report(dir: &Path, report: &Report, pairs: &[PairScore]) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| crate::error::BenchError::io(dir, e))?;
    let mut written = Vec::new();
    let mut put = |name: &str, bytes: &[u8]| -> Result<()> {
        let path = dir.join(name);
        write_atomically(&path, bytes)?;
        written.push(path);
        Ok(())
    };
    let json = serde_json::to_string_pretty(report).expect("report serialises");
    put("results.json", json.as_bytes())?;
    put("pairs.csv", pairs_csv(pairs).as_bytes())?;
    put("lens_op.csv", lens_op_csv(&report.results.analysis).as_bytes())?;
    let names: Vec<String> = report.models.iter().map(|m| m.name.clone()).collect();
    let mut md = format!(
        "# unicac bench: dataset `{}`\n\nsplit `{}`; metrics as pyiqa's defaults (docs/bench.md). Best **bold**, second <u>underlined</u>.\n\n",
        unicac_dataset::info::dataset_name(&report.dataset),
        report.split
    );
    md.push_str(&overall_table(report));
    md.push('\n');
    for &benchmark in &report.benchmarks {
        // A dataset built without --sub-benchmarks has no U_s / U_c levels: say so rather than print an
        // empty table.
        if !report.results.rows.iter().any(|r| r.benchmark == benchmark) {
            md.push_str(&format!(
                "### Benchmark `{benchmark}`\n\nNo test lens has a `{benchmark}` level in this dataset (sub-benchmarks are built by `unicac dataset build --sub-benchmarks`).\n\n"
            ));
            continue;
        }
        md.push_str(&tables::markdown(&report.results.rows, &names, benchmark));
        md.push('\n');
        put(
            &format!("tables/{benchmark}.tex"),
            tables::latex(&report.results.rows, &names, benchmark).as_bytes(),
        )?;
    }
    if let Some(as_built) = &report.as_built {
        md.push_str(&super::as_built::markdown(
            &as_built.rows,
            as_built.units_per_lens,
        ));
        md.push('\n');
    }
    md.push_str(&cost_table(&report.models));
    md.push_str(&super::analysis_md::markdown(&report.results.analysis));
    if !report.notices.is_empty() {
        md.push_str("\n### Notices\n\n");
        for n in &report.notices {
            md.push_str(&format!("- {n}\n"));
        }
    }
    put("tables.md", md.as_bytes())?;
    let pictures = plots(dir, report)?;
    let names: Vec<String> = pictures
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    written.extend(pictures);
    let html = super::html::page(&md, dir, &names);
    let path = dir.join("report.html");
    write_atomically(&path, html.as_bytes())?;
    written.push(path);
    Ok(written)
}

fn level_series(
    rows: &[ResultRow],
    models: &[String],
    value: impl Fn(&ResultRow) -> Option<f64>,
) -> Vec<unicac_plot::LevelSeries> {
    models
        .iter()
        .map(|m| unicac_plot::LevelSeries {
            label: m.clone(),
            values: (1..=super::LEVELS)
                .map(|l| {
                    rows.iter()
                        .find(|r| &r.model == m && r.benchmark == Benchmark::Ode && r.level == l)
                        .and_then(&value)
                })
                .collect(),
        })
        .collect()
}

fn plots(dir: &Path, report: &Report) -> Result<Vec<PathBuf>> {
    let rows = &report.results.rows;
    let models: Vec<String> = report.models.iter().map(|m| m.name.clone()).collect();
    let mut written = Vec::new();
    if !rows.iter().any(|r| r.benchmark == Benchmark::Ode) {
        return Ok(written);
    }
    // Rank by O.P. at each level, 1 = best.
    let ops = level_series(rows, &models, |r| r.op);
    let ranks: Vec<unicac_plot::LevelSeries> = ops
        .iter()
        .map(|s| unicac_plot::LevelSeries {
            label: s.label.clone(),
            values: s
                .values
                .iter()
                .enumerate()
                .map(|(l, v)| {
                    v.map(|v| 1.0 + ops.iter().filter(|o| o.values[l].is_some_and(|w| w > v)).count() as f64)
                })
                .collect(),
        })
        .collect();
    let path = dir.join("ranking_trend.png");
    unicac_plot::level_lines(
        "Ranking by O.P. across ODE levels",
        "rank (1 = best)",
        &ranks,
        true,
        &path,
    )?;
    written.push(path);
    type Metric = (&'static str, &'static str, fn(&ResultRow) -> Option<f64>);
    let metrics: [Metric; 4] = [
        ("psnr", "PSNR (dB)", |r| r.psnr_db),
        ("ssim", "SSIM", |r| r.ssim),
        ("lpips", "LPIPS", |r| r.lpips),
        ("op", "O.P.", |r| r.op),
    ];
    for (key, label, value) in metrics {
        let series = level_series(rows, &models, value);
        if series.iter().all(|s| s.values.iter().all(Option::is_none)) {
            continue;
        }
        let path = dir.join(format!("metric_{key}.png"));
        unicac_plot::level_lines(
            &format!("{label} across ODE levels"),
            label,
            &series,
            false,
            &path,
        )?;
        written.push(path);
    }
    let a = &report.results.analysis.all;
    if a.predictors.lenses >= 2 {
        use super::predictors::LensMetric;
        let number = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.3}"));
        let panels: Vec<unicac_plot::ScatterPanel> = LensMetric::ALL
            .iter()
            .map(|&metric| {
                let m = a.predictors.metric(metric);
                let x_desc = match metric {
                    LensMetric::Ode => "ODE of the lens",
                    LensMetric::RmsRadius => "RMS spot radius (um)",
                    LensMetric::LogRmsRadius => "ln RMS spot radius (um)",
                };
                let inverse = if m.direction_expected() == Some(false) {
                    " (inverse)"
                } else {
                    ""
                };
                unicac_plot::ScatterPanel {
                    title: format!(
                        "{}: R^2 {}, r {}{inverse}",
                        metric.label(),
                        number(m.r2.value),
                        number(m.pearson.value)
                    ),
                    x_desc: x_desc.into(),
                    y_desc: "mean O.P. of the models".into(),
                    points: a.points.iter().map(|p| (metric.of(p), p.op)).collect(),
                    fit: m.fit.map(|f| (f.intercept, f.slope)),
                }
            })
            .collect();
        let path = dir.join("analysis.png");
        unicac_plot::scatter_fits(
            &format!("Per-lens restorability, {} lenses", a.predictors.lenses),
            &panels,
            &path,
        )?;
        written.push(path);
    }
    Ok(written)
}
