//! `unicac lens info | convert | list`.

use super::{or_dash, print_json};
use crate::args::{ConvertArgs, LensInfoArgs};
use crate::lens_input::{load_lens, load_spec, BUILTIN_PREFIX};
use anyhow::Result;
use unicac_optics::builtin;
use unicac_trace::LensSummary;

pub fn info(args: &LensInfoArgs) -> Result<()> {
    let lens = load_lens(&args.lens.lens)?;
    let info = LensSummary::of(&lens)?;
    if args.json {
        return print_json(&info);
    }
    let f = &info.first_order;
    println!(
        "{}",
        if info.name.is_empty() {
            &args.lens.lens
        } else {
            &info.name
        }
    );
    let rows: [(&str, String); 16] = [
        ("surfaces (incl. image)", info.surfaces.to_string()),
        ("stop surface", info.stop_surface_number.to_string()),
        ("wavelength (um)", format!("{:.6}", f.wavelength_um)),
        ("EFL (mm)", format!("{:.6}", f.efl_mm)),
        ("BFL (mm)", format!("{:.6}", f.bfl_mm)),
        ("FFL (mm)", format!("{:.6}", f.ffl_mm)),
        ("EPD (mm)", format!("{:.6}", f.epd_mm)),
        ("entrance pupil z (mm)", format!("{:.6}", f.entrance_pupil_z_mm)),
        ("exit pupil z (mm)", or_dash(f.exit_pupil_z_mm, 6)),
        ("exit pupil diameter (mm)", or_dash(f.exit_pupil_diameter_mm, 6)),
        ("F/# (EFL/EPD)", format!("{:.4}", f.f_number)),
        (
            "paraxial working F/#",
            format!("{:.4}", f.paraxial_working_f_number),
        ),
        ("working F/# (real)", or_dash(info.working_f_number, 4)),
        ("total track (mm)", format!("{:.6}", f.total_track_mm)),
        ("Petzval sum (1/mm)", format!("{:.6e}", f.petzval_sum_per_mm)),
        ("paraxial image z (mm)", format!("{:.6}", f.paraxial_image_z_mm)),
    ];
    for (label, value) in rows {
        println!("  {label:<26} {value}");
    }
    println!(
        "  {:<12} {:>16} {:>16} {:>14}",
        "field (deg)", "paraxial y (mm)", "real y (mm)", "distortion %"
    );
    for d in &info.distortion {
        println!(
            "  {:<12.4} {:>16.6} {:>16.6} {:>14.4}",
            d.field_deg, d.paraxial_image_height_mm, d.real_image_height_mm, d.distortion_percent
        );
    }
    Ok(())
}

pub fn convert(args: &ConvertArgs) -> Result<()> {
    unicac_io::require_extension("OUTPUT", &args.output, &["json", "zmx"])?;
    let mut plan = crate::outputs::plan(Some(args.input.as_str()));
    plan.output("OUTPUT", &args.output);
    plan.check()?;
    let spec = load_spec(&args.input)?;
    unicac_optics::Lens::from_spec(&spec).map_err(|e| anyhow::anyhow!("{}: {e}", args.input))?;
    unicac_optics::write_spec(&spec, &args.output)?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}

pub fn list() -> Result<()> {
    for name in builtin::names() {
        let lens = builtin::lens(name)?;
        let f = lens.first_order()?;
        let max_field = f.field_angles_deg.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        println!(
            "{BUILTIN_PREFIX}{name:<16} EFL {:>8.3} mm  F/{:<5.2} half-FoV {:>5.1} deg  {}",
            f.efl_mm, f.f_number, max_field, lens.name
        );
    }
    Ok(())
}
