//! Renders the layout, spot diagram and ray fans of a lens file:
//! `cargo run -p unicac-plot --example render -- LENS OUT_PREFIX [png|svg]`
//! writes OUT_PREFIX-layout.EXT, OUT_PREFIX-spot.EXT and OUT_PREFIX-fan.EXT.

use std::path::Path;
use unicac_trace::apertures::clear_semi_diameters;
use unicac_trace::spot::ray_fan;
use unicac_trace::{Aiming, PupilSampling, SpotTracer};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let [_, lens_path, prefix, rest @ ..] = args.as_slice() else {
        return Err("usage: render LENS OUT_PREFIX [png|svg]".into());
    };
    let extension = rest.first().map_or("png", String::as_str);
    let out = |name: &str| format!("{prefix}-{name}.{extension}");
    let (lens, _warnings) = unicac_optics::load_lens(Path::new(lens_path))?;
    let fields = lens.first_order()?.field_angles_deg;

    let semi_diameters = clear_semi_diameters(&lens, Aiming::Paraxial)?;
    unicac_plot::layout(
        &lens,
        &unicac_trace::meridional::layout_bundles(&lens, 11)?,
        &semi_diameters,
        Path::new(&out("layout")),
    )?;

    let sampling = PupilSampling::Hexapolar { rings: 8 };
    let spots = unicac_trace::spots(
        &lens,
        &fields,
        &lens.wavelengths_um(),
        Aiming::Paraxial,
        &sampling,
    )?;
    unicac_plot::spot_diagram(&spots, Path::new(&out("spot")))?;

    let mut fans = Vec::new();
    for wavelength in lens.wavelengths_um() {
        let tracer = SpotTracer::new(&lens, wavelength, Aiming::Paraxial)?;
        fans.extend(fields.iter().filter_map(|&field| ray_fan(&tracer, field, 41)));
    }
    unicac_plot::ray_fan_plot(&fans, Path::new(&out("fan")))?;
    Ok(())
}
