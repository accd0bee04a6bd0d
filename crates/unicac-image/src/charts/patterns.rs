//! Analytic charts: checkerboard, slanted edge, Siemens star. Their two tones are kept clear of 0 and 1
//! (default 0.2 and 0.8) so that blur overshoot, noise and white-balance gains are not clipped, as ISO 12233
//! recommends for edge targets (reduced contrast, ISO 12233:2017 section 6.1, about 4:1).

use super::render_grey;
use crate::error::{ImageError, Result};
use crate::Planar;

/// Sub-samples per pixel side for the analytic charts (4 x 4 = 16 per pixel).
pub const SUPERSAMPLING: usize = 4;
/// Mean level of the two-tone charts (linear light).
pub const CHART_MEAN: f32 = 0.5;
/// Dark tone at full contrast: `CHART_MEAN - 0.3`.
pub const CHART_LOW: f32 = 0.2;
/// Light tone at full contrast: `CHART_MEAN + 0.3`.
pub const CHART_HIGH: f32 = 0.8;

fn finite(field: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ImageError::invalid(field, format!("{value} is not finite")))
    }
}

fn unit(field: &'static str, value: f64) -> Result<f64> {
    if (0.0..=1.0).contains(&value) {
        Ok(value)
    } else {
        Err(ImageError::invalid(field, format!("{value} is outside [0, 1]")))
    }
}

/// Checkerboard with squares of side `period_px / 2` (one full dark + light cycle every `period_px` along
/// both square axes), rotated by `slant_deg` about the image centre so that every edge is a slanted edge
/// for ISO 12233 e-SFR analysis (a few degrees, e.g. 5, avoids edges aligned with the pixel grid).
///
/// Tones are `CHART_MEAN ± 0.3 * contrast` (`contrast` in [0, 1]; at 1 the squares are 0.2 and 0.8), so the
/// mean over whole periods is exactly 0.5. A corner of four squares lies at the image centre; with
/// `slant_deg = 0` and `width / 2`, `height / 2` multiples of `period_px / 2` the edges fall on pixel borders.
pub fn checkerboard(
    width: usize,
    height: usize,
    period_px: f64,
    contrast: f64,
    slant_deg: f64,
) -> Result<Planar> {
    super::check_chart_size(width, height)?;
    if !(period_px.is_finite() && period_px >= 2.0) {
        return Err(ImageError::invalid(
            "period_px",
            format!("{period_px}, expected a finite value >= 2 px"),
        ));
    }
    let amplitude = (CHART_HIGH - CHART_MEAN) as f64 * unit("contrast", contrast)?;
    let (sin, cos) = finite("slant_deg", slant_deg)?.to_radians().sin_cos();
    let (cx, cy) = (width as f64 / 2.0, height as f64 / 2.0);
    let side = period_px / 2.0;
    Ok(render_grey(width, height, SUPERSAMPLING, |x, y| {
        let u = (x - cx) * cos + (y - cy) * sin;
        let v = -(x - cx) * sin + (y - cy) * cos;
        // The square's parity from integer cell indices (truncation, one down for negative
        // non-integers: the floor for every index a chart can reach, |index| < 2^52), without the
        // libm floor and remainder calls, which cost more than the rest of the chart drawing.
        let cell = |t: f64| {
            let index = t as i64;
            if (index as f64) > t {
                index - 1
            } else {
                index
            }
        };
        let even = (cell(u / side) + cell(v / side)).rem_euclid(2) == 0;
        CHART_MEAN as f64 + if even { amplitude } else { -amplitude }
    }))
}

/// A straight edge through the image centre, tilted `angle_deg` from vertical (ISO 12233:2017 section 6.2
/// slanted-edge target; a few degrees, typically 5): at height y it crosses x = cx + (y - cy) tan(angle),
/// (cx, cy) being the image centre, so a positive angle moves the edge right going down. Pixels left of the
/// edge are `low`, right of it `high` (both in [0, 1], linear light).
pub fn slanted_edge(width: usize, height: usize, angle_deg: f64, low: f64, high: f64) -> Result<Planar> {
    super::check_chart_size(width, height)?;
    let (low, high) = (unit("low", low)?, unit("high", high)?);
    let (sin, cos) = finite("angle_deg", angle_deg)?.to_radians().sin_cos();
    let (cx, cy) = (width as f64 / 2.0, height as f64 / 2.0);
    Ok(render_grey(width, height, SUPERSAMPLING, |x, y| {
        // Signed distance from the line through the centre with direction (sin, cos) (y pointing down).
        let distance = (x - cx) * cos - (y - cy) * sin;
        if distance < 0.0 {
            low
        } else {
            high
        }
    }))
}

/// Binary Siemens star (ISO 12233:2000 resolution target; ISO 15775): `spokes` dark/light cycles around the
/// centre (2 * `spokes` wedges), tones `CHART_LOW` / `CHART_HIGH`, inside the largest centred disk; outside
/// it the image is `CHART_MEAN`. The spatial period at radius r is `2 pi r / spokes` px; the centre aliases
/// by construction and the supersampling only tempers it.
pub fn siemens_star(width: usize, height: usize, spokes: usize) -> Result<Planar> {
    super::check_chart_size(width, height)?;
    if spokes < 2 {
        return Err(ImageError::invalid(
            "spokes",
            format!("{spokes}, expected at least 2"),
        ));
    }
    let (cx, cy) = (width as f64 / 2.0, height as f64 / 2.0);
    let radius = cx.min(cy);
    let wedge = std::f64::consts::PI / spokes as f64;
    Ok(render_grey(width, height, SUPERSAMPLING, |x, y| {
        let (dx, dy) = (x - cx, y - cy);
        if dx.hypot(dy) > radius {
            return CHART_MEAN as f64;
        }
        let parity = (dy.atan2(dx) / wedge).floor().rem_euclid(2.0);
        if parity < 0.5 {
            CHART_HIGH as f64
        } else {
            CHART_LOW as f64
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mean(values: &[f32]) -> f64 {
        values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64
    }

    #[test]
    fn checkerboard_mean_is_the_documented_half_within_1e_3() {
        for (slant, contrast) in [(0.0, 1.0), (5.0, 1.0), (12.5, 0.6), (-30.0, 0.25)] {
            let chart = checkerboard(512, 384, 24.0, contrast, slant).unwrap();
            let m = mean(&chart.data);
            assert!((m - CHART_MEAN as f64).abs() < 1e-3, "slant {slant}: mean {m}");
            let (lo, hi) = chart
                .data
                .iter()
                .fold((1.0f32, 0.0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            let amplitude = 0.3 * contrast as f32;
            assert!(lo >= CHART_MEAN - amplitude - 1e-6 && hi <= CHART_MEAN + amplitude + 1e-6);
        }
    }

    #[test]
    fn unslanted_checkerboard_has_exactly_the_requested_period() {
        let period = 16;
        let chart = checkerboard(256, 128, period as f64, 1.0, 0.0).unwrap();
        let row: Vec<f64> = chart.plane(0)[..256].iter().map(|&v| v as f64 - 0.5).collect();
        // Autocorrelation over lags 1..2*period peaks exactly at the period (and is -1 at half the period).
        let autocorrelation = |lag: usize| -> f64 {
            let n = row.len() - lag;
            (0..n).map(|i| row[i] * row[i + lag]).sum::<f64>() / (n as f64 * 0.09)
        };
        let best = (1..2 * period)
            .max_by(|&a, &b| autocorrelation(a).total_cmp(&autocorrelation(b)))
            .unwrap();
        assert_eq!(best, period);
        assert!((autocorrelation(period) - 1.0).abs() < 1e-6);
        assert!((autocorrelation(period / 2) + 1.0).abs() < 1e-6);
        // Zero crossings: two per period.
        let crossings = row.windows(2).filter(|w| (w[0] > 0.0) != (w[1] > 0.0)).count();
        assert_eq!(crossings, 2 * 256 / period - 1);
    }

    /// Bilinear interpolation of plane 0 at continuous pixel coordinates (pixel centres at +0.5).
    fn sample(chart: &Planar, x: f64, y: f64) -> f64 {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (ax, ay) = (fx - x0, fy - y0);
        let at = |dx: f64, dy: f64| chart.get(0, (x0 + dx) as usize, (y0 + dy) as usize) as f64;
        (1.0 - ay) * ((1.0 - ax) * at(0.0, 0.0) + ax * at(1.0, 0.0))
            + ay * ((1.0 - ax) * at(0.0, 1.0) + ax * at(1.0, 1.0))
    }

    #[test]
    fn slanted_checkerboard_has_the_requested_period_along_its_rotated_axis() {
        // Walk the rotated u axis through the middle of a row of squares (v = side / 2, clear of the
        // v edges): the profile is a square wave that changes tone every period / 2 px.
        let (width, height, period, slant) = (400usize, 400usize, 20.0, 7.0f64);
        let chart = checkerboard(width, height, period, 1.0, slant).unwrap();
        let (sin, cos) = slant.to_radians().sin_cos();
        let side = period / 2.0;
        let (t_min, t_max) = (-145.0, 145.0);
        let steps = ((t_max - t_min) / 0.05) as usize;
        let mut crossings = Vec::new();
        let mut previous = None;
        for k in 0..=steps {
            let t = t_min + k as f64 * 0.05;
            let (x, y) = (
                200.0 + t * cos - side / 2.0 * sin,
                200.0 + t * sin + side / 2.0 * cos,
            );
            let above = sample(&chart, x, y) > CHART_MEAN as f64;
            if previous.is_some_and(|p| p != above) {
                crossings.push(t);
            }
            previous = Some(above);
        }
        // Edges at every multiple of the square side in (t_min, t_max): -140, -130, ..., 140.
        assert_eq!(crossings.len(), 29);
        for (k, t) in crossings.iter().enumerate() {
            let edge = -140.0 + k as f64 * side;
            assert!((t - edge).abs() < 0.2, "crossing {k} at {t}, edge at {edge}");
        }
        let spacing = (crossings[28] - crossings[0]) / 28.0;
        assert!((2.0 * spacing - period).abs() < 0.03, "period {}", 2.0 * spacing);
    }

    #[test]
    fn slanted_edge_is_antialiased_and_balanced() {
        let chart = slanted_edge(101, 101, 5.0, 0.2, 0.8).unwrap();
        // Centred edge through a square: equal areas on both sides.
        assert!((mean(&chart.data) - 0.5).abs() < 1e-3);
        let row = &chart.plane(0)[50 * 101..51 * 101];
        assert_eq!((row[0], row[100]), (0.2, 0.8));
        let intermediate = row.iter().filter(|&&v| v > 0.2 && v < 0.8).count();
        assert!(
            (1..=2).contains(&intermediate),
            "{intermediate} grey pixels on the edge"
        );
        // Edge position per row = width - (pixels of "high"); it moves right by tan(5 deg) px per row.
        let edge_x = |y: usize| {
            let row = &chart.plane(0)[y * 101..(y + 1) * 101];
            101.0 - row.iter().map(|&v| (v as f64 - 0.2) / 0.6).sum::<f64>()
        };
        let shift_per_row = (edge_x(90) - edge_x(10)) / 80.0;
        assert!(
            (shift_per_row - 5f64.to_radians().tan()).abs() < 1e-3,
            "{shift_per_row}"
        );
        assert!(slanted_edge(8, 8, 5.0, -0.1, 0.5).is_err());
    }

    #[test]
    fn siemens_star_has_the_requested_spokes_and_mean() {
        let spokes = 18;
        let chart = siemens_star(256, 256, spokes).unwrap();
        // Walk a circle of radius 100 px: 2 * spokes tone changes.
        let samples: Vec<f32> = (0..3600)
            .map(|k| {
                let angle = (k as f64 + 0.5) / 3600.0 * std::f64::consts::TAU;
                let (x, y) = (128.0 + 100.0 * angle.cos(), 128.0 + 100.0 * angle.sin());
                chart.get(0, x as usize, y as usize)
            })
            .collect();
        let mut changes = 0;
        for k in 0..samples.len() {
            let (a, b) = (samples[k], samples[(k + 1) % samples.len()]);
            changes += usize::from((a > 0.5) != (b > 0.5));
        }
        assert_eq!(changes, 2 * spokes);
        assert!((mean(&chart.data) - 0.5).abs() < 2e-3);
        assert!(siemens_star(64, 64, 1).is_err());
    }

    #[test]
    fn bad_chart_parameters_are_typed_errors() {
        assert!(matches!(
            checkerboard(8, 8, 1.0, 1.0, 0.0),
            Err(ImageError::InvalidParameter {
                field: "period_px",
                ..
            })
        ));
        assert!(matches!(
            checkerboard(8, 8, 8.0, 1.5, 0.0),
            Err(ImageError::InvalidParameter {
                field: "contrast",
                ..
            })
        ));
        assert!(matches!(
            checkerboard(8, 8, 8.0, 1.0, f64::NAN),
            Err(ImageError::InvalidParameter {
                field: "slant_deg",
                ..
            })
        ));
        // An empty chart is refused (MAX_CHART_PIXELS and at least one pixel), not returned empty.
        assert!(matches!(
            checkerboard(0, 5, 8.0, 1.0, 0.0),
            Err(ImageError::InvalidParameter { field: "size", .. })
        ));
    }
}
