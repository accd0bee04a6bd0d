//! `unicac layout`: the lens drawn with ray bundles.

use crate::args::LayoutArgs;
use crate::lens_input::load_lens;
use anyhow::Result;
use unicac_trace::meridional::{check_rays_per_field, layout_bundles};
use unicac_trace::{apertures::clear_semi_diameters, Aiming};

pub fn run(args: &LayoutArgs) -> Result<()> {
    check_rays_per_field(args.rays).map_err(|p| super::named_flag_error("--rays", p))?;
    crate::outputs::check_lens_and_picture(&args.lens.lens, "--plot", Some(args.plot.as_path()))?;
    let lens = load_lens(&args.lens.lens)?;
    let semi_diameters = clear_semi_diameters(&lens, Aiming::Auto)?;
    let bundles = layout_bundles(&lens, args.rays)?;
    unicac_plot::layout(&lens, &bundles, &semi_diameters, &args.plot)?;
    eprintln!("wrote {}", args.plot.display());
    Ok(())
}
