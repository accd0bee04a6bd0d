//! `unicac spot`: spot diagrams and RMS radii.

use super::{fields_and_wavelengths, or_dash, print_json};
use crate::args::SpotArgs;
use crate::lens_input::load_lens;
use anyhow::Result;
use serde::Serialize;
use unicac_trace::{spots, Aiming, AutoAiming, PupilSampling, Spot};

#[derive(Serialize)]
struct SpotReport<'a> {
    lens: &'a str,
    aiming: Aiming,
    /// With `--aim auto`: the aiming it chose for this lens and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    auto_aiming: Option<AutoAiming>,
    pupil_sampling: PupilSampling,
    spots: &'a [Spot],
}

pub fn run(args: &SpotArgs) -> Result<()> {
    crate::outputs::check_lens_and_picture(&args.lens.lens, "--plot", args.plot.as_deref())?;
    let lens = load_lens(&args.lens.lens)?;
    let (fields, wavelengths) = fields_and_wavelengths(&lens, &args.rays)?;
    let selection = super::gpu::selection(&args.device);
    let auto_aiming = super::auto_aiming(&lens, args.rays.aim)?;
    let rays_per_spot = args.pupil_sampling.point_count();
    let spots = match selection.tracer_for(rays_per_spot) {
        Some(tracer) => unicac_gpu::spot::spots(
            tracer,
            &lens,
            &fields,
            &wavelengths,
            args.rays.aim,
            &args.pupil_sampling,
        )?,
        None => spots(&lens, &fields, &wavelengths, args.rays.aim, &args.pupil_sampling)?,
    };
    super::gpu::print_notes(unicac_psf::HitTracer::take_notes(selection.as_ref()));
    if let Some(path) = &args.plot {
        unicac_plot::spot_diagram(&spots, path)?;
        eprintln!("wrote {}", path.display());
    }
    if args.json {
        return print_json(&SpotReport {
            lens: &args.lens.lens,
            aiming: args.rays.aim,
            auto_aiming,
            pupil_sampling: args.pupil_sampling,
            spots: &spots,
        });
    }
    println!(
        "{:>10} {:>10} {:>12} {:>12} {:>14} {:>14} {:>8}",
        "field deg", "wl um", "RMS um", "RMS chief um", "centroid x mm", "centroid y mm", "ok/all"
    );
    for s in &spots {
        println!(
            "{:>10.4} {:>10.6} {:>12} {:>12} {:>14} {:>14} {:>8}",
            s.field_deg,
            s.wavelength_um,
            or_dash(s.rms_radius_um, 4),
            or_dash(s.rms_radius_chief_um, 4),
            or_dash(s.centroid_x_mm, 6),
            or_dash(s.centroid_y_mm, 6),
            format!("{}/{}", s.rays_ok, s.rays_traced)
        );
    }
    Ok(())
}
