//! The field-of-view map of docs/models.md: per pixel, the position of its centre in the full frame,
//! relative to the frame centre and divided by the half-diagonal (x right, y down).

use crate::{ChannelMap, FrameCrop, Result};

/// `[2, h, w]` float32: channel 0 = x, channel 1 = y of each crop pixel in the full frame.
pub fn fov_map(crop: FrameCrop) -> Result<ChannelMap> {
    crop.check()?;
    let (w, h) = (crop.w, crop.h);
    let mut data = vec![0.0f32; 2 * w * h];
    let (xs, ys) = data.split_at_mut(w * h);
    for row in 0..h {
        for column in 0..w {
            let [x, y] = crop.normalised(row, column);
            xs[row * w + column] = x as f32;
            ys[row * w + column] = y as f32;
        }
    }
    Ok(ChannelMap {
        channels: 2,
        height: h,
        width: w,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_and_centre_follow_the_formula() {
        let (fw, fh) = (64usize, 48usize);
        let map = fov_map(FrameCrop::full(fw, fh)).unwrap();
        let half_diagonal = 0.5 * ((fw * fw + fh * fh) as f64).sqrt(); // 40
                                                                       // Top-left pixel centre: (0.5 - 32, 0.5 - 24) / 40.
        assert_eq!(map.at(0, 0, 0), ((0.5 - 32.0) / half_diagonal) as f32);
        assert_eq!(map.at(1, 0, 0), ((0.5 - 24.0) / half_diagonal) as f32);
        // Bottom-right: (63.5 - 32, 47.5 - 24) / 40, just inside radius 1.
        let (x, y) = (map.at(0, fh - 1, fw - 1), map.at(1, fh - 1, fw - 1));
        assert_eq!((x, y), ((31.5 / 40.0) as f32, (23.5 / 40.0) as f32));
        assert!(((x as f64).hypot(y as f64) - 1.0).abs() < 0.02);
        // The four centre pixels sit at +-0.5 px / 40 from the axis.
        assert_eq!(map.at(0, 23, 31), (-0.5 / 40.0) as f32);
        assert_eq!(map.at(1, 24, 32), (0.5 / 40.0) as f32);
    }

    #[test]
    fn a_crop_keeps_its_full_frame_coordinates() {
        let full = fov_map(FrameCrop::full(64, 48)).unwrap();
        let crop = FrameCrop {
            x0: 40,
            y0: 30,
            w: 24,
            h: 18,
            ..FrameCrop::full(64, 48)
        };
        let part = fov_map(crop).unwrap();
        for c in 0..2 {
            for row in 0..18 {
                for column in 0..24 {
                    assert_eq!(part.at(c, row, column), full.at(c, 30 + row, 40 + column));
                }
            }
        }
        let outside = FrameCrop { x0: 41, ..crop };
        assert!(fov_map(outside).unwrap_err().to_string().contains("outside"));
    }
}
