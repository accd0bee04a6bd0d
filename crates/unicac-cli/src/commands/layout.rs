//! `unicac layout`: the lens drawn with ray bundles.

use crate::args::LayoutArgs;
use crate::lens_input::load_lens;
use anyhow::Result;
use unicac_trace::{apertures::clear_semi_diameters, Aiming};

pub fn run(args: &LayoutArgs) -> Result<()> {
    let lens = load_lens(&args.lens.lens)?;
    let semi_diameters = clear_semi_diameters(&lens, Aiming::Auto)?;
    let bundles = unicac_plot::layout_bundles(&lens, args.rays.max(1))?;
    unicac_plot::layout(&lens, &bundles, &semi_diameters, &args.plot)?;
    eprintln!("wrote {}", args.plot.display());
    Ok(())
}
