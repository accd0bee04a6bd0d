//! `unicac layout`: the lens drawn with ray bundles.

use crate::args::LayoutArgs;
use crate::lens_input::load_lens;
use anyhow::Result;
use unicac_trace::{apertures::clear_semi_diameters, Aiming};

pub fn run(args: &LayoutArgs) -> Result<()> {
    if !(1..=unicac_plot::MAX_LAYOUT_RAYS).contains(&args.rays) {
        anyhow::bail!(
            "--rays {}: must lie between 1 and {} (MAX_LAYOUT_RAYS)",
            args.rays,
            unicac_plot::MAX_LAYOUT_RAYS
        );
    }
    crate::outputs::check_lens_and_picture(&args.lens.lens, "--plot", Some(args.plot.as_path()))?;
    let lens = load_lens(&args.lens.lens)?;
    let semi_diameters = clear_semi_diameters(&lens, Aiming::Paraxial)?;
    let bundles = unicac_plot::layout_bundles(&lens, args.rays)?;
    unicac_plot::layout(&lens, &bundles, &semi_diameters, &args.plot)?;
    eprintln!("wrote {}", args.plot.display());
    Ok(())
}
