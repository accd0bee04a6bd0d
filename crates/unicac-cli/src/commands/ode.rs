//! `unicac ode`: ODE and RMS spot radius of many lenses, in parallel, with a progress bar; on the lens
//! files' sensors or, with `--frame`, on the sensor `unicac dataset build` grades with.

use super::print_json;
use crate::args::OdeArgs;
use crate::lens_input::load_lens;
use crate::progress_display::ProgressDisplay;
use anyhow::Result;
use rayon::prelude::*;
use std::fmt::Write as _;
use unicac_dataset::builder::sources::parse_size;
use unicac_io::progress::Progress;
use unicac_ode::{evaluate, FrameSensor, LensOde, OdeSettings};

pub fn run(args: &OdeArgs) -> Result<()> {
    let mut plan = crate::outputs::plan(None);
    for lens in args
        .lenses
        .iter()
        .filter(|l| !l.starts_with(crate::lens_input::BUILTIN_PREFIX))
    {
        plan.input(lens);
    }
    if let Some(csv) = &args.csv {
        unicac_io::require_extension("--csv", csv, &["csv"])?;
        plan.output("--csv", csv);
    }
    crate::outputs::picture(&mut plan, "--plot", args.plot.as_deref())?;
    let frame = frame_sensor(args)?;
    plan.check()?;
    let settings = OdeSettings {
        backend: super::gpu::backend(&args.device),
        ..frame.map_or_else(OdeSettings::default, |f| f.ode_settings())
    };
    let display = ProgressDisplay::new("ode");
    display.stage("lenses", args.lenses.len());
    let results: Vec<Result<LensOde>> = args
        .lenses
        .par_iter()
        .map(|name| {
            let result = load_lens(name)
                .map(|lens| match frame {
                    Some(f) => f.apply(&lens),
                    None => lens,
                })
                .and_then(|lens| evaluate(&lens, &settings).map_err(|e| anyhow::anyhow!("{name}: {e}")))
                .map(|report| LensOde {
                    lens: name.clone(),
                    report,
                });
            display.advance(1);
            result
        })
        .collect();
    display.finish();
    super::gpu::print_notes(settings.backend.take_notes());
    let lenses: Vec<LensOde> = results.into_iter().collect::<Result<_>>()?;
    if let Some(path) = &args.csv {
        unicac_optics::io::write_atomically(path, csv(&lenses).as_bytes())?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.plot {
        let names = plot_labels(&lenses.iter().map(|l| l.lens.as_str()).collect::<Vec<_>>());
        let ode: Vec<f64> = lenses.iter().map(|l| l.report.scores.ode).collect();
        let rms: Vec<f64> = lenses.iter().map(|l| l.report.scores.rms_radius_um).collect();
        unicac_plot::ode_bars(&names, &ode, &rms, path)?;
        eprintln!("wrote {}", path.display());
    }
    if args.json {
        return print_json(&serde_json::json!({ "lenses": lenses }));
    }
    println!(
        "{:<32} {:>7} {:>7} {:>7} {:>7} {:>7} {:>8} {:>7} {:>9}",
        "lens", "ODE", "OIQ", "U_s", "U_c", "OIQE", "PSNR dB", "SSIM", "RMS um"
    );
    for l in &lenses {
        let r = &l.report;
        println!(
            "{:<32} {:>7.4} {:>7.4} {:>7.4} {:>7.4} {:>7.4} {:>8.2} {:>7.4} {:>9.3}",
            l.lens,
            r.scores.ode,
            r.scores.oiq,
            r.scores.u_s,
            r.scores.u_c,
            r.scores.oiqe,
            r.scores.psnr_db,
            r.scores.ssim,
            r.scores.rms_radius_um
        );
    }
    Ok(())
}

/// `--frame WxH [--pixel-um X]`: the sensor `unicac dataset build` grades on with the same flags.
fn frame_sensor(args: &OdeArgs) -> Result<Option<FrameSensor>> {
    let Some(text) = &args.frame else {
        return Ok(None);
    };
    let frame = FrameSensor {
        frame_px: parse_size(text).map_err(|m| anyhow::anyhow!("--frame: {m}"))?,
        pixel_um: args.pixel_um,
    };
    frame.check().map_err(super::flag_error)?;
    Ok(Some(frame))
}

fn csv(lenses: &[LensOde]) -> String {
    let mut text = format!("lens,{},pixel_um\n", unicac_ode::OdeScores::NAMES.join(","));
    for l in lenses {
        let scores: Vec<String> = l.report.scores.values().iter().map(f64::to_string).collect();
        let _ = writeln!(text, "{},{},{}", l.lens, scores.join(","), l.report.pixel_um);
    }
    text
}

/// Short, unique plot labels for lens arguments: the file stem (`builtin:NAME` gives NAME); stems that
/// collide get their parent directory, and any still equal keep the whole argument.
fn plot_labels(lenses: &[&str]) -> Vec<String> {
    let path = |name: &str| std::path::PathBuf::from(name.strip_prefix("builtin:").unwrap_or(name));
    let stem = |name: &str| {
        path(name)
            .file_stem()
            .map_or_else(|| name.to_string(), |s| s.to_string_lossy().into_owned())
    };
    let with_parent = |name: &str| {
        let p = path(name);
        match p.parent().and_then(|d| d.file_name()) {
            Some(dir) => format!("{}/{}", dir.to_string_lossy(), stem(name)),
            None => stem(name),
        }
    };
    let unique = |labels: &[String], i: usize| labels.iter().filter(|l| **l == labels[i]).count() == 1;
    let stems: Vec<String> = lenses.iter().map(|n| stem(n)).collect();
    let parents: Vec<String> = (0..lenses.len())
        .map(|i| {
            if unique(&stems, i) {
                stems[i].clone()
            } else {
                with_parent(lenses[i])
            }
        })
        .collect();
    (0..lenses.len())
        .map(|i| {
            if unique(&parents, i) {
                parents[i].clone()
            } else {
                lenses[i].to_string()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::plot_labels;

    #[test]
    fn plot_labels_are_file_stems_made_unique_by_their_directory() {
        let labels = plot_labels(&[
            "out/designs/lenses/e3_h20_f5_middle_f50_s1_0001.json",
            "out/designs/lenses/e3_h20_f5_middle_f50_s1_0002.json",
            "builtin:cooke_triplet",
            "a/triplet.json",
            "b/triplet.json",
        ]);
        assert_eq!(
            labels,
            [
                "e3_h20_f5_middle_f50_s1_0001",
                "e3_h20_f5_middle_f50_s1_0002",
                "cooke_triplet",
                "a/triplet",
                "b/triplet"
            ]
        );
    }
}
