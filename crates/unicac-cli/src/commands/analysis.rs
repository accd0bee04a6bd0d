//! `unicac analysis mtf|through-focus|field-curves|illumination|encircled-energy`: the lens analyses of
//! unicac-analysis, checked before any work, printed (table or JSON), written (--out) and plotted.

use super::{flag_error, print_json};
use crate::args::{AnalysisArgs, AnalysisMtfArgs, FieldCurvesArgs, ThroughFocusArgs};
use crate::lens_input::load_lens;
use anyhow::{bail, Result};
use serde::Serialize;
use unicac_analysis::{linspace, AnalysisError, MtfMethod, MtfSettings, Spectrum};
use unicac_optics::Lens;
use unicac_plot::{Line, LineColour, LinePanel};

/// Most fields of `--fields`; most focus positions of `--steps`.
const MAX_FIELD_SAMPLES: usize = 256;
const MAX_FOCUS_STEPS: usize = 401;

/// A library error in this face's words: a parameter by its flag.
fn analysis_error(error: AnalysisError) -> anyhow::Error {
    match error {
        AnalysisError::InvalidParameter(parameter)
        | AnalysisError::Psf(unicac_psf::PsfError::InvalidParameter(parameter)) => flag_error(parameter),
        other => other.into(),
    }
}

/// The lens, spectrum and fields of a request, everything checked before any work.
struct Request {
    lens: Lens,
    spectrum: Spectrum,
    fields_deg: Vec<f64>,
}

/// Checks the outputs (never onto the lens file or each other), the pupil grid, the wavelengths and
/// the fields (the given ones, else `default_fields` of the lens).
fn prepare(args: &AnalysisArgs, default_fields: impl FnOnce(&Lens) -> Result<Vec<f64>>) -> Result<Request> {
    let mut plan = crate::outputs::plan(Some(args.lens.lens.as_str()));
    crate::outputs::picture(&mut plan, "--plot", args.plot.as_deref())?;
    if let Some(out) = &args.out {
        unicac_io::require_extension("--out", out, &["json"])?;
        plan.output("--out", out);
    }
    plan.check()?;
    let lens = load_lens(&args.lens.lens)?;
    unicac_analysis::setup::check_pupil_grid(args.pupil_grid).map_err(flag_error)?;
    let spectrum = if args.wavelengths_um.is_empty() {
        Spectrum::of_lens(&lens)
    } else {
        Spectrum::equal(&args.wavelengths_um).map_err(analysis_error)?
    };
    let fields_deg = if args.fields_deg.is_empty() {
        default_fields(&lens)?
    } else {
        args.fields_deg.clone()
    };
    unicac_analysis::check_fields(&lens, &fields_deg).map_err(analysis_error)?;
    Ok(Request {
        lens,
        spectrum,
        fields_deg,
    })
}

fn lens_fields(lens: &Lens) -> Result<Vec<f64>> {
    Ok(lens.first_order()?.field_angles_deg)
}

/// `count` fields from the axis to the lens's largest.
fn field_samples(lens: &Lens, count: usize) -> Result<Vec<f64>> {
    check_count("--fields", count, 2, MAX_FIELD_SAMPLES)?;
    Ok(linspace(0.0, lens.first_order()?.max_field_deg(), count))
}

fn check_count(flag: &str, value: usize, low: usize, high: usize) -> Result<()> {
    if !(low..=high).contains(&value) {
        bail!("{flag} {value}: must lie between {low} and {high}");
    }
    Ok(())
}

fn check_positive(flag: &str, value: f64) -> Result<f64> {
    if !(value.is_finite() && value > 0.0) {
        bail!("{flag} {value}: must be positive and finite");
    }
    Ok(value)
}

/// The primary wavelength's on-axis diffraction cutoff 1 / (lambda N) (N the paraxial working F/#),
/// rounded up to 10 cycles/mm: the default top of the frequency axis.
fn cutoff_cy_mm(lens: &Lens) -> Result<f64> {
    let n = lens.first_order()?.paraxial_working_f_number;
    let cutoff = 1.0 / (lens.primary_wavelength_um() * 1e-3 * n);
    if !(cutoff.is_finite() && cutoff > 0.0) {
        bail!("the lens has no finite working F/# to scale frequencies by; give --max-frequency-cy-mm");
    }
    Ok((cutoff / 10.0).ceil() * 10.0)
}

/// Writes `--out`, then prints the JSON (--json) or the table.
fn emit(args: &AnalysisArgs, report: &impl Serialize, table: impl FnOnce()) -> Result<()> {
    if let Some(out) = &args.out {
        unicac_optics::io::write_atomically(out, serde_json::to_string_pretty(report)?.as_bytes())?;
        eprintln!("wrote {}", out.display());
    }
    if args.json {
        return print_json(report);
    }
    table();
    Ok(())
}

fn plot(args: &AnalysisArgs, title: &str, panels: &[LinePanel]) -> Result<()> {
    if let Some(path) = &args.plot {
        unicac_plot::line_panels(title, panels, path)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn line(label: String, x: &[f64], y: &[f64], colour: LineColour, dashed: bool) -> Line {
    Line {
        label,
        x: x.to_vec(),
        y: y.to_vec(),
        colour,
        dashed,
    }
}

fn series(rank: usize, series: usize) -> LineColour {
    LineColour::Series { rank, series }
}

fn degrees(field: f64) -> String {
    format!("{}°", (field * 100.0).round() / 100.0)
}

fn panel(
    caption: String,
    x_desc: &str,
    y_desc: &str,
    y_range: Option<(f64, f64)>,
    lines: Vec<Line>,
) -> LinePanel {
    LinePanel {
        caption,
        x_desc: x_desc.into(),
        y_desc: y_desc.into(),
        y_range,
        lines,
    }
}

fn lens_name(args: &AnalysisArgs) -> &str {
    &args.lens.lens
}

pub fn mtf(args: &AnalysisMtfArgs) -> Result<()> {
    let common = &args.common;
    let method: MtfMethod = args.method.parse().map_err(flag_error)?;
    check_count(
        "--frequencies",
        args.frequencies,
        2,
        unicac_analysis::setup::MAX_SAMPLES,
    )?;
    if let Some(max) = args.max_frequency_cy_mm {
        check_positive("--max-frequency-cy-mm", max)?;
    }
    for &f in &args.frequencies_cy_mm {
        if !(f.is_finite() && f >= 0.0) {
            bail!("--frequency-cy-mm {f}: must be finite and non-negative");
        }
    }
    let request = if args.vs_field {
        let count = args.fields;
        prepare(common, |lens| field_samples(lens, count))?
    } else {
        prepare(common, lens_fields)?
    };
    if !args.vs_field && common.plot.is_some() && request.fields_deg.len() > unicac_plot::MAX_PANELS {
        bail!(
            "--plot draws at most {} fields, one panel each ({} asked)",
            unicac_plot::MAX_PANELS,
            request.fields_deg.len()
        );
    }
    let settings = MtfSettings {
        method,
        pupil_grid: common.pupil_grid,
        scale_by_diffraction_limit: !args.no_diffraction_scale,
    };
    let max = match args.max_frequency_cy_mm {
        Some(max) => max,
        None => cutoff_cy_mm(&request.lens)?,
    };
    let name = lens_name(common);
    if args.vs_field {
        let frequencies = if args.frequencies_cy_mm.is_empty() {
            vec![max / 8.0, max / 4.0, max / 2.0]
        } else {
            args.frequencies_cy_mm.clone()
        };
        let report = unicac_analysis::mtf_vs_field(
            &request.lens,
            &request.spectrum,
            &request.fields_deg,
            &frequencies,
            settings,
        )
        .map_err(analysis_error)?;
        let n = report.curves.len();
        let lines = report
            .curves
            .iter()
            .enumerate()
            .flat_map(|(k, c)| {
                let label = format!("{} cy/mm", (c.frequency_cy_mm * 10.0).round() / 10.0);
                [
                    line(
                        format!("{label} T"),
                        &report.fields_deg,
                        &c.tangential,
                        series(k, n),
                        false,
                    ),
                    line(
                        format!("{label} S"),
                        &report.fields_deg,
                        &c.sagittal,
                        series(k, n),
                        true,
                    ),
                ]
            })
            .collect();
        plot(
            common,
            &format!("{} MTF against field, {name}", args.method),
            &[panel(
                "".into(),
                "field angle (deg)",
                "MTF",
                Some((0.0, 1.05)),
                lines,
            )],
        )?;
        return emit(common, &report, || {
            for c in &report.curves {
                println!("{:.1} cycles/mm", c.frequency_cy_mm);
                for ((f, t), s) in report.fields_deg.iter().zip(&c.tangential).zip(&c.sagittal) {
                    println!("  field {f:>8.3} deg  T {t:.4}  S {s:.4}");
                }
            }
        });
    }
    let frequencies = linspace(0.0, max, args.frequencies);
    let report = unicac_analysis::mtf(
        &request.lens,
        &request.spectrum,
        &request.fields_deg,
        &frequencies,
        settings,
    )
    .map_err(analysis_error)?;
    if report.fields.iter().any(|f| f.undersampled) {
        eprintln!(
            "warning: the pupil grid undersamples a wavefront (raise --pupil-grid); the MTF is approximate"
        );
    }
    let count = report.fields.len();
    let panels: Vec<LinePanel> = report
        .fields
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let x = &f.frequencies_cy_mm;
            panel(
                degrees(f.field_deg),
                "spatial frequency (cycles/mm)",
                "MTF",
                Some((0.0, 1.05)),
                vec![
                    line("tangential".into(), x, &f.tangential, series(k, count), false),
                    line("sagittal".into(), x, &f.sagittal, series(k, count), true),
                    line(
                        "diffraction limit T".into(),
                        x,
                        &f.diffraction_limit.tangential,
                        LineColour::Reference,
                        false,
                    ),
                    line(
                        "diffraction limit S".into(),
                        x,
                        &f.diffraction_limit.sagittal,
                        LineColour::Reference,
                        true,
                    ),
                ],
            )
        })
        .collect();
    plot(common, &format!("{} MTF, {name}", args.method), &panels)?;
    emit(common, &report, || {
        for f in &report.fields {
            let at = |fraction: f64| {
                let k = ((f.frequencies_cy_mm.len() - 1) as f64 * fraction).round() as usize;
                (
                    f.frequencies_cy_mm[k],
                    f.tangential[k],
                    f.sagittal[k],
                    f.diffraction_limit.tangential[k],
                )
            };
            for fraction in [0.125, 0.25, 0.5] {
                let (nu, t, s, limit) = at(fraction);
                println!(
                    "field {:>8.3} deg  {nu:>8.1} cy/mm  T {t:.4}  S {s:.4}  (diffraction limit {limit:.4})",
                    f.field_deg
                );
            }
        }
    })
}

pub fn through_focus(args: &ThroughFocusArgs) -> Result<()> {
    let common = &args.common;
    check_count("--steps", args.steps, 2, MAX_FOCUS_STEPS)?;
    if let Some(f) = args.frequency_cy_mm {
        if !(f.is_finite() && f >= 0.0) {
            bail!("--frequency-cy-mm {f}: must be finite and non-negative");
        }
    }
    if let Some(range) = args.focus_range_mm {
        check_positive("--focus-range-mm", range)?;
    }
    let request = prepare(common, lens_fields)?;
    let lens = &request.lens;
    let frequency = match args.frequency_cy_mm {
        Some(f) => f,
        None => (cutoff_cy_mm(lens)? / 4.0).round(),
    };
    let range = match args.focus_range_mm {
        Some(range) => range,
        None => {
            let n = lens.first_order()?.paraxial_working_f_number;
            8.0 * lens.primary_wavelength_um() * 1e-3 * n * n
        }
    };
    let shifts = linspace(-range, range, args.steps);
    let settings = MtfSettings {
        pupil_grid: common.pupil_grid,
        ..MtfSettings::default()
    };
    let report = unicac_analysis::through_focus(
        lens,
        &request.spectrum,
        &request.fields_deg,
        frequency,
        &shifts,
        settings,
    )
    .map_err(analysis_error)?;
    let n = report.fields.len();
    let mut mtf_lines = Vec::new();
    let mut rms_lines = Vec::new();
    for (k, f) in report.fields.iter().enumerate() {
        let label = degrees(f.field_deg);
        mtf_lines.push(line(
            format!("{label} T"),
            &f.focus_shifts_mm,
            &f.tangential,
            series(k, n),
            false,
        ));
        mtf_lines.push(line(
            format!("{label} S"),
            &f.focus_shifts_mm,
            &f.sagittal,
            series(k, n),
            true,
        ));
        rms_lines.push(line(
            label,
            &f.focus_shifts_mm,
            &f.rms_spot_um,
            series(k, n),
            false,
        ));
    }
    plot(
        common,
        &format!("Through focus, {}", lens_name(common)),
        &[
            panel(
                format!("MTF at {frequency} cycles/mm"),
                "focus shift (mm)",
                "MTF",
                Some((0.0, 1.05)),
                mtf_lines,
            ),
            panel(
                "RMS spot radius".into(),
                "focus shift (mm)",
                "RMS radius (µm)",
                None,
                rms_lines,
            ),
        ],
    )?;
    emit(common, &report, || {
        for f in &report.fields {
            let best = (0..f.rms_spot_um.len())
                .min_by(|&a, &b| f.rms_spot_um[a].total_cmp(&f.rms_spot_um[b]))
                .unwrap_or(0);
            let peak = (0..f.tangential.len())
                .max_by(|&a, &b| {
                    (f.tangential[a] + f.sagittal[a]).total_cmp(&(f.tangential[b] + f.sagittal[b]))
                })
                .unwrap_or(0);
            println!(
                "field {:>8.3} deg  smallest RMS {:.3} um at {:+.4} mm; best MTF at {frequency} cy/mm: T {:.4} S {:.4} at {:+.4} mm",
                f.field_deg, f.rms_spot_um[best], f.focus_shifts_mm[best], f.tangential[peak], f.sagittal[peak], f.focus_shifts_mm[peak]
            );
        }
    })
}

pub fn field_curves(args: &FieldCurvesArgs) -> Result<()> {
    let common = &args.common;
    let count = args.fields;
    let request = prepare(common, |lens| field_samples(lens, count))?;
    let report = unicac_analysis::field_curves(&request.lens, &request.spectrum, &request.fields_deg)
        .map_err(analysis_error)?;
    let n = report.field_curvature.len();
    let mut focus_lines = Vec::new();
    for (k, c) in report.field_curvature.iter().enumerate() {
        let label = format!("{} µm", c.wavelength_um);
        let unwrap = |v: &[Option<f64>]| v.iter().map(|x| x.unwrap_or(f64::NAN)).collect::<Vec<_>>();
        focus_lines.push(line(
            format!("{label} T"),
            &report.fields_deg,
            &unwrap(&c.tangential_mm),
            series(k, n),
            false,
        ));
        focus_lines.push(line(
            format!("{label} S"),
            &report.fields_deg,
            &unwrap(&c.sagittal_mm),
            series(k, n),
            true,
        ));
    }
    let (fields, percent): (Vec<f64>, Vec<f64>) = report
        .distortion
        .iter()
        .map(|p| (p.field_deg, p.distortion_percent))
        .unzip();
    plot(
        common,
        &format!("Field curvature and distortion, {}", lens_name(common)),
        &[
            panel(
                "Field curvature".into(),
                "field angle (deg)",
                "focus from image surface (mm)",
                None,
                focus_lines,
            ),
            panel(
                "Distortion".into(),
                "field angle (deg)",
                "distortion (%)",
                None,
                vec![line("distortion".into(), &fields, &percent, series(0, 1), false)],
            ),
        ],
    )?;
    emit(common, &report, || {
        let primary = report
            .field_curvature
            .iter()
            .find(|c| c.wavelength_um == request.lens.primary_wavelength_um())
            .unwrap_or(&report.field_curvature[0]);
        let show = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:+.5}"));
        println!(
            "field deg   tangential mm   sagittal mm   distortion %   ({} um)",
            primary.wavelength_um
        );
        for (k, f) in report.fields_deg.iter().enumerate() {
            let d = report
                .distortion
                .iter()
                .find(|p| p.field_deg == *f)
                .map(|p| p.distortion_percent);
            println!(
                "{f:>9.3}   {:>13}   {:>11}   {:>12}",
                show(primary.tangential_mm[k]),
                show(primary.sagittal_mm[k]),
                show(d)
            );
        }
    })
}

pub fn illumination(args: &FieldCurvesArgs) -> Result<()> {
    let common = &args.common;
    let count = args.fields;
    let request = prepare(common, |lens| field_samples(lens, count))?;
    let report = unicac_analysis::relative_illumination(
        &request.lens,
        &request.spectrum,
        &request.fields_deg,
        common.pupil_grid,
    )
    .map_err(analysis_error)?;
    plot(
        common,
        &format!("Relative illumination, {}", lens_name(common)),
        &[panel(
            "".into(),
            "field angle (deg)",
            "relative illumination",
            Some((0.0, 1.05)),
            vec![
                line(
                    "relative illumination".into(),
                    &report.fields_deg,
                    &report.relative_illumination,
                    series(0, 2),
                    false,
                ),
                line(
                    "vignetting (transmitted fraction)".into(),
                    &report.fields_deg,
                    &report.vignetting,
                    series(1, 2),
                    true,
                ),
            ],
        )],
    )?;
    emit(common, &report, || {
        println!("field deg   relative illumination   vignetting   image height mm");
        for k in 0..report.fields_deg.len() {
            println!(
                "{:>9.3}   {:>21.5}   {:>10.5}   {:>15.5}",
                report.fields_deg[k],
                report.relative_illumination[k],
                report.vignetting[k],
                report.image_height_mm[k]
            );
        }
    })
}

pub fn encircled_energy(args: &AnalysisArgs) -> Result<()> {
    let request = prepare(args, lens_fields)?;
    let report = unicac_analysis::encircled_energy(
        &request.lens,
        &request.spectrum,
        &request.fields_deg,
        None,
        args.pupil_grid,
    )
    .map_err(analysis_error)?;
    let n = report.fields.len();
    let lines = report
        .fields
        .iter()
        .enumerate()
        .map(|(k, f)| line(degrees(f.field_deg), &f.radii_um, &f.energy, series(k, n), false))
        .collect();
    plot(
        args,
        &format!("Encircled energy (geometric), {}", lens_name(args)),
        &[panel(
            "".into(),
            "radius from the centroid (µm)",
            "encircled energy",
            Some((0.0, 1.05)),
            lines,
        )],
    )?;
    emit(args, &report, || {
        for f in &report.fields {
            println!(
                "field {:>8.3} deg  50% within {:.3} um, 80% within {:.3} um",
                f.field_deg, f.radius_50_um, f.radius_80_um
            );
        }
    })
}
