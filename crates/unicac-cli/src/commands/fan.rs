//! `unicac fan`: tangential and sagittal ray fans.

use super::{fields_and_wavelengths, print_json};
use crate::args::FanArgs;
use crate::lens_input::load_lens;
use anyhow::Result;
use unicac_trace::{spot::ray_fan, SpotTracer};

pub fn run(args: &FanArgs) -> Result<()> {
    unicac_trace::spot::check_fan_samples(args.samples).map_err(super::flag_error)?;
    crate::outputs::check_lens_and_picture(&args.lens.lens, "--plot", args.plot.as_deref())?;
    let lens = load_lens(&args.lens.lens)?;
    let (fields, wavelengths) = fields_and_wavelengths(&lens, &args.rays)?;
    let mut fans = Vec::new();
    for wavelength in wavelengths {
        let tracer = SpotTracer::new(&lens, wavelength, args.rays.aim)?;
        fans.extend(
            fields
                .iter()
                .filter_map(|&field| ray_fan(&tracer, field, args.samples)),
        );
    }
    if let Some(path) = &args.plot {
        unicac_plot::ray_fan_plot(&fans, path)?;
        eprintln!("wrote {}", path.display());
    }
    if args.json {
        return print_json(&fans);
    }
    for fan in &fans {
        let worst = |points: &[unicac_trace::spot::FanPoint],
                     pick: fn(&unicac_trace::spot::FanPoint) -> f64| {
            points.iter().map(pick).fold(0.0f64, |m, v| m.max(v.abs()))
        };
        println!(
            "field {:>8.4} deg  wl {:.6} um  max |ey| tangential {:>10.4} um  max |ex| sagittal {:>10.4} um",
            fan.field_deg,
            fan.wavelength_um,
            worst(&fan.tangential, |p| p.ey_um),
            worst(&fan.sagittal, |p| p.ex_um)
        );
    }
    Ok(())
}
