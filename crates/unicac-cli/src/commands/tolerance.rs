//! `unicac tolerance`: Monte Carlo tolerancing into a resumable folder, with the yield curves drawn.

use super::{flag_error, named_flag_error, print_json};
use crate::args::ToleranceArgs;
use crate::lens_input::load_spec;
use crate::progress_display::ProgressDisplay;
use anyhow::{Context, Result};
use unicac_optics::Lens;
use unicac_plot::{line_panels, Line, LineColour, LinePanel};
use unicac_tolerance::{
    run_folder, Better, Grading, MonteCarlo, Statistic, Summary, ToleranceError, ToleranceSpec,
};

/// Largest tolerance file read.
const MAX_SPEC_BYTES: u64 = 1 << 20;

/// A tolerance file (docs/tolerancing.md) given by `flag`, read within `MAX_SPEC_BYTES` and checked.
pub fn read_tolerance_file(flag: &str, path: &std::path::Path) -> Result<ToleranceSpec> {
    let bytes = unicac_io::read_capped(path, MAX_SPEC_BYTES, "MAX_SPEC_BYTES")
        .with_context(|| format!("{flag} {}", path.display()))?;
    let text =
        String::from_utf8(bytes).with_context(|| format!("{flag} {}: not UTF-8 text", path.display()))?;
    ToleranceSpec::from_json(&text).with_context(|| format!("{flag} {}", path.display()))
}
/// Most units `--write-units` writes in one call.
const MAX_WRITTEN_UNITS: usize = 1000;
/// Where `--write-units` puts them, inside the run folder.
const UNITS_DIR: &str = "units";
const PLOT_FILE: &str = "yield.png";

pub fn run(args: &ToleranceArgs) -> Result<()> {
    let mut plan = crate::outputs::plan(Some(&args.lens.lens));
    plan.input(&args.spec);
    for path in unicac_tolerance::run::outputs(&args.out) {
        plan.output("--out", path);
    }
    plan.output("--out", args.out.join(PLOT_FILE));
    check_write_units(args)?;
    for &trial in &args.write_units {
        plan.output("--out", unit_path(&args.out, trial));
    }
    plan.check()?;
    let spec = read_tolerance_file("--spec", &args.spec)?;
    let lens_spec = load_spec(&args.lens.lens)?;
    let lens = Lens::from_spec(&lens_spec).with_context(|| args.lens.lens.clone())?;
    // The lens's identity is its JSON form's hash: a .zmx and its .json conversion are one lens.
    let identity = unicac_io::digest::sha256_hex(serde_json::to_string(&lens_spec)?.as_bytes());
    let grading = Grading {
        pupil_grid: args.pupil_grid,
        mtf_frequencies_cy_mm: args.mtf_cy_mm.clone(),
        ode: args.ode,
    };
    let progress = ProgressDisplay::new("tolerance");
    let shard = super::shard_arg(args.shard.as_deref())?;
    let request = MonteCarlo {
        lens_identity: identity,
        spec,
        grading,
        seed: args.seed,
        trials: args.trials,
    };
    let summary = run_folder(&lens, &request, &args.out, shard, &progress).map_err(|e| match e {
        ToleranceError::InvalidParameter(p) if p.field == "mtf_frequencies_cy_mm" => {
            named_flag_error("--mtf-cy-mm", p)
        }
        ToleranceError::InvalidParameter(p) => flag_error(p),
        // Folder and file errors are the run folder's; the rest (a lens that cannot be graded) the lens's.
        e @ (ToleranceError::Folder { .. } | ToleranceError::Io { .. }) => {
            anyhow::Error::new(e).context("--out")
        }
        other => anyhow::Error::new(other).context(args.lens.lens.clone()),
    })?;
    progress.finish();
    write_units(&lens, &request, args)?;
    let Some(summary) = summary else {
        eprintln!(
            "shard {}/{} done in {}; run the command without --shard for the summary",
            shard.index,
            shard.count,
            args.out.display()
        );
        return Ok(());
    };
    let plot = args.out.join(PLOT_FILE);
    draw_yields(&summary, &args.lens.lens, &plot)?;
    if args.json {
        return print_json(&summary);
    }
    print_table(&summary);
    eprintln!(
        "wrote {} and {}",
        args.out.join(unicac_tolerance::run::SUMMARY_FILE).display(),
        plot.display()
    );
    Ok(())
}

fn unit_path(out: &std::path::Path, trial: u64) -> std::path::PathBuf {
    out.join(UNITS_DIR).join(format!("{trial:06}.json"))
}

fn check_write_units(args: &ToleranceArgs) -> Result<()> {
    if args.write_units.len() > MAX_WRITTEN_UNITS {
        anyhow::bail!(
            "--write-units: {} units; at most {MAX_WRITTEN_UNITS} per call",
            args.write_units.len()
        );
    }
    if let Some(trial) = args.write_units.iter().find(|&&t| t >= args.trials as u64) {
        anyhow::bail!(
            "--write-units {trial}: trials are numbered 0 to {} (--trials {})",
            args.trials.saturating_sub(1),
            args.trials
        );
    }
    Ok(())
}

/// `--write-units`: each named unit as a lens file (JSON: an index error has no .zmx form).
fn write_units(nominal: &Lens, request: &MonteCarlo, args: &ToleranceArgs) -> Result<()> {
    if args.write_units.is_empty() {
        return Ok(());
    }
    std::fs::create_dir_all(args.out.join(UNITS_DIR))
        .with_context(|| format!("--out {}", args.out.display()))?;
    for &trial in &args.write_units {
        let unit = unicac_tolerance::unit_lens(nominal, request, trial)
            .with_context(|| format!("--write-units {trial}"))?;
        let mut spec = unit.to_spec();
        spec.name = format!("{} unit {trial}", nominal.name);
        spec.provenance = format!(
            "unicac tolerance {} --spec {} --seed {} --pupil-grid {}: unit {trial}, as graded",
            args.lens.lens,
            args.spec.display(),
            args.seed,
            args.pupil_grid
        );
        let path = unit_path(&args.out, trial);
        unicac_optics::format::write_spec(&spec, &path).with_context(|| format!("--write-units {trial}"))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn print_table(summary: &Summary) {
    println!(
        "{} units ({} could not be graded), seed {}; the value met by each share of units:",
        summary.trials, summary.failed, summary.record.seed
    );
    println!(
        "{:<28} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "metric", "nominal", "mean", "50%", "80%", "90%", "98%"
    );
    for s in &summary.statistics {
        println!(
            "{:<28} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>10.4}",
            s.metric, s.nominal, s.mean, s.met_by_50, s.met_by_80, s.met_by_90, s.met_by_98
        );
    }
}

/// One panel per metric: the share of units meeting each value, with the nominal lens's value.
fn draw_yields(summary: &Summary, lens: &str, path: &std::path::Path) -> Result<()> {
    let panels: Vec<LinePanel> = summary
        .statistics
        .iter()
        .filter(|s| !s.yield_curve.is_empty())
        .map(panel)
        .collect();
    if panels.is_empty() {
        return Ok(());
    }
    let title = format!("{lens}: {} units as built", summary.trials);
    line_panels(&title, &panels, path)?;
    Ok(())
}

fn panel(statistic: &Statistic) -> LinePanel {
    let n = statistic.yield_curve.len() as f64;
    let shares: Vec<f64> = (1..=statistic.yield_curve.len()).map(|k| k as f64 / n).collect();
    let bound = match statistic.better {
        Better::Lower => "at most",
        Better::Higher => "at least",
    };
    LinePanel {
        caption: statistic.metric.clone(),
        x_desc: statistic.metric.clone(),
        y_desc: format!("share of units {bound} x"),
        y_range: Some((0.0, 1.0)),
        lines: vec![
            Line {
                label: "built units".into(),
                x: statistic.yield_curve.clone(),
                y: shares,
                colour: LineColour::Series { rank: 0, series: 1 },
                dashed: false,
            },
            Line {
                label: "nominal".into(),
                x: vec![statistic.nominal; 2],
                y: vec![0.0, 1.0],
                colour: LineColour::Reference,
                dashed: true,
            },
        ],
    }
}
