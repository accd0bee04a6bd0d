//! Per-pair sanity checks (docs/dataset.md, "Pair checks"): how far apart LQ and GT are, whether
//! their pixels correspond, and how much of their difference the lens blur explains. A pair whose
//! error is mostly misregistration or shading teaches a model geometry the ODE never graded.

use crate::manifest::PairCheck;
use unicac_image::Planar;

/// Largest shift (px) the registration search tries in each direction; a tile whose best shift
/// lies on this bound is reported at it (the true shift is at least that large).
pub const MAX_SHIFT_PX: usize = 6;
/// Tiles are at least this wide and high (px), at most `MAX_TILES_PER_SIDE` per side.
const MIN_TILE_PX: usize = 16;
const MAX_TILES_PER_SIDE: usize = 8;
/// A tile whose GT luminance varies less than this (variance, sRGB units squared) has no structure
/// to register and is left out.
const MIN_TILE_VARIANCE: f64 = 1e-4;

/// The checks of one pair: `lq` and `gt` as stored (sRGB in [0, 1]); `lq_clean` the LQ without
/// sensor noise and `gt_blurred` the GT's chain with the lens blur put in (same geometry as the GT).
/// The blur share leaves the noise out: noise is no fault of the pairing, and a sharp lens's pairs
/// would otherwise look as if blur explained little of them.
pub fn measure(lq: &Planar, lq_clean: &Planar, gt: &Planar, gt_blurred: &Planar) -> PairCheck {
    let pair_mse = mse(lq, gt);
    let lens_mse = mse(lq_clean, gt);
    let blur_share = if lens_mse > 0.0 {
        (1.0 - mse(lq_clean, gt_blurred) / lens_mse).clamp(0.0, 1.0)
    } else {
        1.0 // the lens changed nothing, so nothing is misaligned
    };
    PairCheck {
        lq_gt_psnr_db: rounded(psnr_db(pair_mse)),
        // Against the blurred GT: a sharp GT against a strongly blurred LQ has no clear best shift
        // (a heavy, asymmetric blur drags the match around), while blurring both leaves the geometry.
        registration_px: rounded(registration_px(lq, gt_blurred)),
        blur_share: rounded(blur_share),
    }
}

/// Four decimals: stable, readable manifests.
fn rounded(value: f64) -> f64 {
    (value * 1e4).round() / 1e4
}

/// Mean squared difference over every sample (images of one shape).
pub fn mse(a: &Planar, b: &Planar) -> f64 {
    let sum: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| {
            let d = (*x - *y) as f64;
            d * d
        })
        .sum();
    sum / a.data.len().max(1) as f64
}

/// PSNR for an MSE of [0, 1] samples, with the project's cap for identical images.
pub fn psnr_db(mse: f64) -> f64 {
    unicac_metrics::psnr::psnr_from_mse(mse * 255.0 * 255.0).db
}

fn luminance(image: &Planar) -> Vec<f64> {
    let n = image.width * image.height;
    if image.channels < 3 {
        return image.data[..n].iter().map(|&v| v as f64).collect();
    }
    let (r, g, b) = (image.plane(0), image.plane(1), image.plane(2));
    (0..n)
        .map(|i| 0.2126 * r[i] as f64 + 0.7152 * g[i] as f64 + 0.0722 * b[i] as f64)
        .collect()
}

/// Mean over textured tiles of the length (px) of the shift of `gt` that best matches `lq`
/// (least squared luminance difference; integer search within +-`MAX_SHIFT_PX`, refined by a
/// parabola through the neighbours on each axis). Tiles rather than one global shift, because a
/// radial distortion moves opposite corners in opposite directions and averages out over a frame.
pub fn registration_px(lq: &Planar, gt: &Planar) -> f64 {
    let (w, h) = (lq.width, lq.height);
    let (a, b) = (luminance(lq), luminance(gt));
    let tiles = |length: usize| (length / MIN_TILE_PX).clamp(1, MAX_TILES_PER_SIDE);
    let (nx, ny) = (tiles(w), tiles(h));
    let mut lengths = Vec::new();
    for ty in 0..ny {
        for tx in 0..nx {
            let rect = [tx * w / nx, ty * h / ny, (tx + 1) * w / nx, (ty + 1) * h / ny];
            if variance(&b, w, rect) < MIN_TILE_VARIANCE {
                continue;
            }
            let [dx, dy] = best_shift(&a, &b, w, h, rect);
            lengths.push(dx.hypot(dy));
        }
    }
    if lengths.is_empty() {
        return 0.0;
    }
    lengths.iter().sum::<f64>() / lengths.len() as f64
}

fn variance(plane: &[f64], w: usize, [x0, y0, x1, y1]: [usize; 4]) -> f64 {
    let values = || (y0..y1).flat_map(move |y| (x0..x1).map(move |x| plane[y * w + x]));
    let n = ((x1 - x0) * (y1 - y0)).max(1) as f64;
    let mean = values().sum::<f64>() / n;
    values().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n
}

/// The shift (dx, dy) for which GT(x + dx, y + dy) best matches LQ(x, y) over the tile (the GT is
/// read with its border replicated). The match is the normalised cross-correlation (1 - NCC is
/// minimised), so a difference of brightness or contrast across the tile (shading) does not pull
/// the shift towards the brighter side.
fn best_shift(lq: &[f64], gt: &[f64], w: usize, h: usize, [x0, y0, x1, y1]: [usize; 4]) -> [f64; 2] {
    let r = MAX_SHIFT_PX as isize;
    let side = 2 * MAX_SHIFT_PX + 1;
    let n = ((x1 - x0) * (y1 - y0)) as f64;
    let mut error = vec![0.0f64; side * side];
    for dy in -r..=r {
        for dx in -r..=r {
            let (mut sa, mut sb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for y in y0..y1 {
                let sy = (y as isize + dy).clamp(0, h as isize - 1) as usize;
                for x in x0..x1 {
                    let sx = (x as isize + dx).clamp(0, w as isize - 1) as usize;
                    let (a, b) = (lq[y * w + x], gt[sy * w + sx]);
                    (sa, sb, saa, sbb, sab) = (sa + a, sb + b, saa + a * a, sbb + b * b, sab + a * b);
                }
            }
            let covariance = sab - sa * sb / n;
            let spread = ((saa - sa * sa / n) * (sbb - sb * sb / n)).max(0.0).sqrt();
            let ncc = if spread > 0.0 { covariance / spread } else { 0.0 };
            error[(dy + r) as usize * side + (dx + r) as usize] = 1.0 - ncc;
        }
    }
    let best = (0..error.len())
        .min_by(|&i, &j| error[i].total_cmp(&error[j]))
        .unwrap_or(side * side / 2);
    let (bx, by) = (best % side, best / side);
    let at = |x: usize, y: usize| error[y * side + x];
    let refine = |low: Option<f64>, centre: f64, high: Option<f64>| match (low, high) {
        (Some(l), Some(h)) if l + h - 2.0 * centre > 0.0 => {
            (0.5 * (l - h) / (l + h - 2.0 * centre)).clamp(-0.5, 0.5)
        }
        _ => 0.0,
    };
    let fx = refine(
        bx.checked_sub(1).map(|x| at(x, by)),
        at(bx, by),
        (bx + 1 < side).then(|| at(bx + 1, by)),
    );
    let fy = refine(
        by.checked_sub(1).map(|y| at(bx, y)),
        at(bx, by),
        (by + 1 < side).then(|| at(bx, by + 1)),
    );
    [bx as f64 - r as f64 + fx, by as f64 - r as f64 + fy]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn textured(w: usize, h: usize, shift: [f64; 2]) -> Planar {
        Planar::from_fn(w, h, 3, |_, x, y| {
            let (x, y) = (x as f64 - shift[0], y as f64 - shift[1]);
            (0.5 + 0.2 * (x * 0.31).sin() * (y * 0.23).cos() + 0.1 * (x * 0.07 + y * 0.11).sin()) as f32
        })
    }

    #[test]
    fn registration_finds_a_known_shift_and_none_between_equal_images() {
        let gt = textured(120, 96, [0.0, 0.0]);
        let still = registration_px(&gt, &gt);
        assert!(still < 0.05, "{still}");
        // LQ(x) = GT(x - 3, y + 2): the GT shifted by (-3, 2) matches.
        let lq = textured(120, 96, [3.0, -2.0]);
        let found = registration_px(&lq, &gt);
        assert!((found - 13f64.sqrt()).abs() < 0.2, "{found}");
    }

    #[test]
    fn blur_share_is_one_when_blur_explains_everything_and_zero_when_it_explains_nothing() {
        let gt = textured(64, 48, [0.0, 0.0]);
        let lq = textured(64, 48, [0.0, 1.0]);
        let explained = measure(&lq, &lq, &gt, &lq);
        assert_eq!(explained.blur_share, 1.0);
        let unexplained = measure(&lq, &lq, &gt, &gt);
        assert_eq!(unexplained.blur_share, 0.0);
        assert!(unexplained.lq_gt_psnr_db.is_finite() && unexplained.lq_gt_psnr_db < 40.0);
        assert_eq!(measure(&gt, &gt, &gt, &gt).lq_gt_psnr_db, 100.0);
    }
}
