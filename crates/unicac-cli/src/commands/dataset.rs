//! `unicac dataset build|info|plot` (docs/dataset.md).

use crate::args::{DatasetBuildArgs, DatasetInfoArgs, DatasetPlotArgs, PairTaskArg};
use crate::progress_display::ProgressDisplay;
use anyhow::{Context, Result};
use std::sync::Arc;
use unicac_dataset::builder::{
    self, sources::parse_size, BuildSettings, PairTask, RenderDevice, SceneSource,
};
use unicac_gpu::{DeviceChoice, DeviceSelection, Precision};
use unicac_sim::ImageBackend;

/// `--device` of a dataset build, resolved before any work: the record names the device that renders,
/// so `gpu` that cannot open is an error (not the CPU with a note, as for simulate) and `auto` is
/// decided here, once.
fn render_device(choice: DeviceChoice) -> Result<(RenderDevice, ImageBackend)> {
    let cpu = || Ok((RenderDevice::Cpu, ImageBackend::cpu()));
    // `auto` never opens Vulkan without a hardware GPU's device node.
    if choice == DeviceChoice::Cpu
        || (choice == DeviceChoice::Auto && !unicac_gpu::select::hardware_gpu_node_present())
    {
        return cpu();
    }
    // The `gpu` policy: every pass on the device, whatever its size (auto's size rule would mix devices).
    let selection = Arc::new(DeviceSelection::new(DeviceChoice::Gpu, Precision::F32));
    match selection.image_pass_now() {
        Ok(pass) if choice == DeviceChoice::Auto && pass.context().adapter.software => cpu(),
        Ok(_) => Ok((RenderDevice::Gpu, DeviceSelection::image_backend(&selection))),
        Err(_) if choice == DeviceChoice::Auto => cpu(),
        Err(why) => anyhow::bail!("--device gpu: {why}"),
    }
}

pub fn build(args: &DatasetBuildArgs) -> Result<()> {
    let scenes = |flag: &str, text: &str| {
        text.parse::<SceneSource>()
            .map_err(|message| anyhow::anyhow!("{flag} {message}"))
    };
    let mut settings = BuildSettings::new(
        args.lenses.clone(),
        scenes("--images", &args.images)?,
        scenes("--test-images", &args.test_images)?,
    );
    settings.frame_px = args
        .frame
        .as_deref()
        .map(|f| parse_size(f).map_err(|m| anyhow::anyhow!("--frame: {m}")))
        .transpose()?;
    settings.pixel_um = args.pixel_um;
    settings.levels = args.levels;
    settings.test_lenses_per_level = args.test_lenses_per_level;
    settings.val_lenses = args.val_lenses;
    settings.sub_benchmarks = args.sub_benchmarks;
    settings.pairs_per_lens = args.pairs_per_lens;
    settings.crop_px = match args.crop.as_str() {
        "full" => None,
        size => Some(parse_size(size).map_err(|m| anyhow::anyhow!("--crop: {m}"))?),
    };
    settings.seed = args.seed;
    settings.isp = !args.no_isp;
    settings.noise = !args.no_noise;
    settings.illumination = !args.no_illumination;
    settings.distortion = !args.no_distortion;
    settings.task = match args.task {
        PairTaskArg::Aligned => PairTask::Aligned,
        PairTaskArg::Full => PairTask::Full,
    };
    settings.white_balance_jitter = args.wb_jitter;
    settings.iso = args.iso;
    settings.bit_depth = args.bit_depth;
    settings.psf_basis_from = args.psf_basis_from.clone();
    settings.unseen_by = args.unseen_by.clone();
    settings.exclude_flagged = args.exclude_flagged;
    if let (Some(units), Some(path)) = (args.as_built, &args.tolerances) {
        settings.as_built = Some(unicac_dataset::builder::as_built::AsBuiltSettings {
            units,
            tolerances: super::tolerance::read_tolerance_file("--tolerances", path)?,
        });
    }
    (settings.device, settings.image) = render_device(args.device)?;
    let shard = super::shard_arg(args.shard.as_deref())?;
    let threads = args.threads.unwrap_or(0);
    if threads > 1024 {
        anyhow::bail!("--threads {threads}: at most 1024");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("starting the worker threads")?;
    let progress = ProgressDisplay::new("dataset build");
    let start = std::time::Instant::now();
    let report = pool
        .install(|| builder::build(&settings, &args.out, shard, &progress))
        .map_err(flag_error)?;
    progress.finish();
    super::gpu::print_notes(settings.image.take_notes());
    let seconds = start.elapsed().as_secs_f64();
    if args.json {
        let mut value = serde_json::to_value(&report)?;
        value["seconds"] = serde_json::json!(seconds);
        value["pairs_per_s"] = serde_json::json!(report.pairs_rendered as f64 / seconds.max(1e-9));
        super::print_json(&value)?;
    } else {
        let total: usize = report.pairs.values().sum();
        println!(
            "{} {}: {} lenses ({}), {} pairs ({}), {} edge patches; this run: {} ODEs ({} cached), {} PSF tables, {} pairs in {:.1} s ({:.2} pairs/s){}{}",
            if report.complete { "built" } else { "partial" },
            args.out.display(),
            report.lenses.values().sum::<usize>(),
            counts(&report.lenses),
            total,
            counts(&report.pairs),
            report.edges,
            report.odes_computed + report.odes_from_cache,
            report.odes_from_cache,
            report.psf_tables_written,
            report.pairs_rendered,
            seconds,
            report.pairs_rendered as f64 / seconds.max(1e-9),
            if report.as_built_pairs_rendered > 0 {
                format!("; {} as-built pairs", report.as_built_pairs_rendered)
            } else {
                String::new()
            },
            if report.complete { String::new() } else { format!(" (shard {}; dataset.json is written when every shard is done)", report.shard) }
        );
    }
    Ok(())
}

/// The dataset library's setting error in this face's words: the flag for the library's field.
fn flag_error(error: unicac_dataset::DatasetError) -> anyhow::Error {
    let unicac_dataset::DatasetError::Setting { field, message } = &error else {
        return error.into();
    };
    let flag = match field.as_str() {
        "crop_px" => "--crop".to_string(),
        "frame_px" => "--frame".into(),
        "white_balance_jitter" => "--wb-jitter".into(),
        field => format!("--{}", field.replace('_', "-")),
    };
    anyhow::anyhow!("{flag} {message}")
}

fn counts(map: &std::collections::BTreeMap<String, usize>) -> String {
    map.iter()
        .filter(|(_, n)| **n > 0)
        .map(|(k, n)| format!("{k} {n}"))
        .collect::<Vec<_>>()
        .join(", ")
}

pub fn info(args: &DatasetInfoArgs) -> Result<()> {
    let info = unicac_dataset::info::info(&args.dir)?;
    let ode_command = ode_command(&info.grading);
    if args.json {
        let mut value = serde_json::to_value(&info)?;
        value["ode_command"] = serde_json::json!(ode_command);
        return super::print_json(&value);
    }
    println!(
        "{} (unicac {}), frame {} x {} px",
        info.dir, info.unicac_version, info.frame_px[0], info.frame_px[1]
    );
    println!("lenses: {}", counts(&info.lenses));
    println!("pairs:  {}; edge patches: {}", counts(&info.pairs), info.edges);
    println!(
        "{:<6} {:>5} {:>7} {:>10} {:>21} {:>21}",
        "metric", "level", "lenses", "test pairs", "thresholds", "ODE range"
    );
    for level in &info.levels {
        println!(
            "{:<6} {:>5} {:>7} {:>10} {:>10.4}..{:<10.4} {:>10.4}..{:<10.4}",
            level.metric,
            level.level,
            level.lenses,
            level.test_pairs,
            level.lower,
            level.upper,
            level.ode_range[0],
            level.ode_range[1]
        );
    }
    print_pair_checks(&info);
    println!(
        "disk: {:.1} MB ({:.1} MB cache)",
        info.disk_bytes as f64 / 1e6,
        info.cache_bytes as f64 / 1e6
    );
    println!("each lens's recorded ODE is what `{ode_command}` prints (LENS: its `source` in lenses.jsonl)");
    Ok(())
}

/// The task and, per lens, the mean pair PSNR next to its ODE, with the lenses whose pairs are
/// dominated by something other than blur flagged (thresholds in `unicac_dataset::info`).
fn print_pair_checks(info: &unicac_dataset::info::DatasetInfo) {
    println!(
        "task: {}{}",
        info.task.name(),
        if info.comparable_by_ode_level {
            ""
        } else {
            " (the GT is undistorted and unshaded: ODE levels, which grade blur alone, do not order these pairs)"
        }
    );
    println!(
        "{:<32} {:<5} {:>5} {:>7} {:>5} {:>9} {:>8} {:>10}  flag",
        "lens", "split", "level", "ODE", "pairs", "PSNR dB", "shift px", "blur share"
    );
    let number = |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |v| format!("{v:.digits$}"));
    for lens in &info.pair_checks {
        println!(
            "{:<32} {:<5} {:>5} {:>7.4} {:>5} {:>9} {:>8} {:>10}  {}",
            lens.lens_id,
            lens.split,
            lens.level.map_or("-".to_string(), |l| l.to_string()),
            lens.ode,
            lens.pairs,
            number(lens.mean_lq_gt_psnr_db, 2),
            number(lens.mean_registration_px, 2),
            number(lens.mean_blur_share, 3),
            lens.flag.as_deref().unwrap_or("")
        );
    }
    let flagged = info.pair_checks.iter().filter(|l| l.flag.is_some()).count();
    println!(
        "{flagged} lens(es) flagged: mean shift > {} px or blur share < {} (docs/dataset.md, \"Pair checks\")",
        unicac_dataset::info::MISREGISTERED_PX,
        unicac_dataset::info::MIN_BLUR_SHARE
    );
}

/// The `unicac ode` command that grades a lens as the dataset did: on the CPU, as builds grade (a GPU
/// traces the PSF rays with other rounding, so its digits may differ).
fn ode_command(grading: &unicac_ode::FrameSensor) -> String {
    let [w, h] = grading.frame_px;
    let pitch = grading
        .pixel_um
        .map_or(String::new(), |p| format!(" --pixel-um {p}"));
    format!("unicac ode LENS --frame {w}x{h}{pitch} --device cpu")
}

pub fn plot(args: &DatasetPlotArgs) -> Result<()> {
    // The dataset is read as a whole: the picture may be neither one of its files nor land inside it.
    let mut plan = unicac_io::OutputPlan::new();
    plan.input_folder(&args.dir);
    crate::outputs::picture(&mut plan, "--out", Some(&args.out))?;
    plan.check()?;
    unicac_dataset::info::plot(&args.dir, &args.out)?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
