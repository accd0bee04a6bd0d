//! `simulate --crops PATH`: the aberrations at pixel scale. A picture of 1:1 crops, the sharp input above
//! the simulated output, at the image centre (left) and at the edge of the field (right: on the diagonal
//! towards the top-right corner, as far out as a whole crop fits), so blur, colour fringes and their
//! growth with field angle are visible without zooming into a large image.

use anyhow::Result;
use std::path::Path;
use unicac_image::io::{write_png, SampleDepth};
use unicac_image::Planar;

/// Side of each crop (px), at most a third of the image's shorter side.
const CROP_PX: usize = 256;
/// White gutter between the crops (px).
const GUTTER_PX: usize = 8;

/// Writes the 2 x 2 crop picture of `sharp` (above) and `simulated` (below), both sRGB-encoded RGB.
pub fn write(sharp: &Planar, simulated: &Planar, path: &Path) -> Result<()> {
    let (w, h) = (simulated.width, simulated.height);
    let side = CROP_PX.min(w.min(h) / 3).max(1);
    let centre = ((w - side) / 2, (h - side) / 2);
    let edge = (w - side, 0);
    let size = 2 * side + GUTTER_PX;
    let picture = Planar::from_fn(size, size, 3, |c, x, y| {
        let (column, row) = (x / (side + GUTTER_PX), y / (side + GUTTER_PX));
        let (cx, cy) = (x % (side + GUTTER_PX), y % (side + GUTTER_PX));
        if cx >= side || cy >= side {
            return 1.0;
        }
        let (ox, oy) = if column == 0 { centre } else { edge };
        let source = if row == 0 { sharp } else { simulated };
        source.get(c, ox + cx, oy + cy)
    });
    write_png(path, &picture, SampleDepth::Eight)?;
    Ok(())
}
