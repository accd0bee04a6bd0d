//! Per-pixel quantities that depend on the distance from the image centre only (the distortion warp's
//! scale and the relative illumination), tabulated once per simulator on a uniform radius grid.
//!
//! Why: evaluated exactly, each pixel costs binary searches in the chief-ray map, a `tan` (warp) and
//! five interpolations plus `sin`/`cos` (shading); at 12 MP that was ~3 s of a ~5 s image pass
//! (docs/performance.md). A lookup is one square root and one linear interpolation.
//!
//! **Error bound.** The table samples every `RADIAL_TABLE_STEP_PX` (1/16 px) of radius and
//! interpolates linearly, so for a function f of the radius r (px) the lookup error is at most
//! `step^2 / 8 * max|f''|` where f is smooth, and about `step / 4 * |jump of f'|` at corners. The exact
//! quantities have corners: the chief-ray map and the vignetting are piecewise linear between their
//! samples, and the relative illumination divides by the slope dh/dF of that piecewise-linear map, so
//! the "exact" shading itself steps at the chief-ray map's 65 samples (steps of ~1e-3, smoothed over the
//! 1e-4 rad of its difference quotient); the table's error there is within the step. The test
//! `lookups_match_the_exact_per_pixel_evaluation_within_the_stated_bound` evaluates both at every pixel
//! radius of a quadrant and on a fine radial sweep, on every bundled lens at 200 x 150 and 1000 x 750:
//! worst warp position change 1.3e-4 px (wide angle), worst shading change 1.5e-3 at 200 x 150 and
//! 3.0e-4 at 1000 x 750 (wide angle), under the stated `WARP_BOUND_PX` and `SHADING_BOUND`.

/// Radius step of the tables (pixels).
pub const RADIAL_TABLE_STEP_PX: f64 = 0.0625;

/// Largest difference between a tabulated and an exactly evaluated warp source position (pixels).
pub const WARP_BOUND_PX: f64 = 5e-4;

/// Largest difference between a tabulated and an exactly evaluated shading factor (absolute; factors
/// are at most 1).
pub const SHADING_BOUND: f64 = 3e-3;

/// f(r) sampled at r = 0, step, 2 step, ... up to at least `max_radius_px`; lookups interpolate linearly
/// and clamp beyond the last sample.
#[derive(Debug, Clone)]
pub struct RadialTable {
    inverse_step: f64,
    values: Vec<f64>,
}

impl RadialTable {
    /// Samples `f` (a function of the radius in pixels) from 0 to `max_radius_px`.
    pub fn sample(max_radius_px: f64, f: impl Fn(f64) -> f64) -> RadialTable {
        let intervals = (max_radius_px.max(0.0) / RADIAL_TABLE_STEP_PX).ceil() as usize + 1;
        let values = (0..=intervals)
            .map(|i| f(i as f64 * RADIAL_TABLE_STEP_PX))
            .collect();
        RadialTable {
            inverse_step: 1.0 / RADIAL_TABLE_STEP_PX,
            values,
        }
    }

    /// The samples f(0), f(step), f(2 step), ... (`RADIAL_TABLE_STEP_PX`), for a device that looks them
    /// up itself.
    pub fn samples(&self) -> &[f64] {
        &self.values
    }

    /// f at `radius_px` (linear between samples; the last sample beyond them).
    #[inline]
    pub fn at(&self, radius_px: f64) -> f64 {
        let position = radius_px * self.inverse_step;
        let last = self.values.len() - 1;
        // `as usize` saturates (negative and NaN radii go to 0), so the index is always in range; a
        // negative or NaN offset reads the sample itself.
        let i = (position as usize).min(last - 1);
        let offset = position - i as f64;
        let t = if offset > 0.0 { offset.min(1.0) } else { 0.0 };
        self.values[i] + t * (self.values[i + 1] - self.values[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_function_is_exact_and_lookups_clamp_beyond_the_range() {
        let table = RadialTable::sample(10.0, |r| 2.0 * r + 1.0);
        for r in [0.0, 0.3, 5.0625, 9.99, 10.0] {
            assert!((table.at(r) - (2.0 * r + 1.0)).abs() < 1e-12, "r {r}");
        }
        let end = table.at(1e9);
        assert!((end - table.at(10.0 + RADIAL_TABLE_STEP_PX)).abs() < 1e-12);
        assert_eq!(table.at(-1.0), 1.0);
        assert_eq!(table.at(f64::NAN), 1.0);
    }

    #[test]
    fn a_smooth_function_stays_within_the_interpolation_bound() {
        // f = r^2 / 1000: f'' = 1/500, so the bound is step^2 / 8 / 500.
        let table = RadialTable::sample(100.0, |r| r * r / 1000.0);
        let bound = RADIAL_TABLE_STEP_PX.powi(2) / 8.0 / 500.0;
        let worst = (0..100_000)
            .map(|i| i as f64 * 1e-3)
            .map(|r| (table.at(r) - r * r / 1000.0).abs())
            .fold(0.0, f64::max);
        assert!(worst <= bound * 1.000_001, "worst {worst}, bound {bound}");
        assert!(
            worst > bound * 0.9,
            "the bound is tight: worst {worst}, bound {bound}"
        );
    }
}
