//! `unicac chart`: generated test charts (no downloaded data needed).

use crate::args::{ChartArgs, ChartKind};
use anyhow::Result;
use unicac_image::charts;

pub fn run(args: &ChartArgs) -> Result<()> {
    let [w, h] = args.size;
    charts::check_chart_size(w, h).map_err(|e| anyhow::anyhow!("--size {w}x{h}: {e}"))?;
    unicac_io::require_extension("--out", &args.out, &["png", "tif", "tiff", "exr"])?;
    let chart = match args.kind {
        ChartKind::DeadLeaves => charts::dead_leaves(w, h, args.seed)?,
        ChartKind::Checkerboard => charts::checkerboard(w, h, (w.min(h) as f64 / 8.0).max(8.0), 1.0, 5.0)?,
        ChartKind::SlantedEdge => charts::slanted_edge(w, h, 5.0, 0.2, 0.8)?,
        ChartKind::SiemensStar => charts::siemens_star(w, h, 36)?,
    };
    super::simulate::write_linear(&chart, &args.out, None)?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
