//! Dead-leaves chart (Matheron 1968; Lee, Mumford & Huang, IJCV 2001; used as a texture target by Cao,
//! Guichard & Hornung, SPIE 7537, 2010, and ISO/TS 19567-2:2019): opaque disks with radius density
//! p(r) ∝ r^-3 on [r_min, r_max] (scale invariant, power spectrum close to natural images), centres uniform,
//! random grey or colour, the earlier disks occluding the later ones, until the image is covered.
//!
//! Rendering is front to back: a disk only paints sub-samples no earlier disk covered, which is the same
//! image as painting back to front and lets the loop stop as soon as everything is covered. Sub-samples
//! (`supersampling`² per pixel) are box-averaged for anti-aliasing; memory is 4 * supersampling² bytes per
//! pixel for the label buffer.
//!
//! Most disks drawn late in a chart land on ground that is already covered; `Coverage` counts the
//! uncovered sub-samples per row and per segment of `SEGMENT` sub-samples of a row, so a disk skips
//! covered rows and segments without visiting their samples (same image, several times faster at 1 MP).

use crate::error::{ImageError, Result};
use crate::Planar;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

/// How leaves are coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LeafColours {
    /// One uniform value per leaf, the same in R, G and B.
    Grey,
    /// Independent uniform values per channel per leaf (chromatic edges at every orientation, which is
    /// what chromatic-aberration training needs).
    Colour,
}

/// Dead-leaves parameters. [`DeadLeaves::for_size`] gives the defaults used by [`dead_leaves`].
#[derive(Debug, Clone, PartialEq)]
pub struct DeadLeaves {
    /// Smallest disk radius, px (> 0). Default 1.
    pub r_min_px: f64,
    /// Largest disk radius, px (>= `r_min_px`). Default a quarter of the shorter image side.
    pub r_max_px: f64,
    pub colours: LeafColours,
    /// Leaf values are drawn uniformly in [low, high] ⊆ [0, 1] (linear light). Default [0, 1]; narrow it
    /// (e.g. [0.25, 0.75]) for an ISO 19567-2-style reduced-contrast target.
    pub value_range: (f32, f32),
    /// Safety cap on the number of disks; sub-samples still uncovered then take the mid value of
    /// `value_range`. Default 5,000,000 (far above what full coverage needs at the default radii).
    pub max_leaves: usize,
    /// Sub-samples per pixel side (1..=16). Default 4.
    pub supersampling: usize,
}

impl DeadLeaves {
    /// Default parameters for a `width` x `height` chart: colour leaves, r from 1 px to a quarter of the
    /// shorter side, values in [0, 1], 4 x 4 supersampling.
    pub fn for_size(width: usize, height: usize) -> DeadLeaves {
        DeadLeaves {
            r_min_px: 1.0,
            r_max_px: (width.min(height) as f64 / 4.0).max(1.0),
            colours: LeafColours::Colour,
            value_range: (0.0, 1.0),
            max_leaves: 5_000_000,
            supersampling: 4,
        }
    }

    fn validate(&self) -> Result<()> {
        if !(self.r_min_px.is_finite() && self.r_min_px > 0.0) {
            return Err(ImageError::invalid(
                "r_min_px",
                format!("{}, expected > 0", self.r_min_px),
            ));
        }
        if !(self.r_max_px.is_finite() && self.r_max_px >= self.r_min_px) {
            return Err(ImageError::invalid(
                "r_max_px",
                format!("{}, expected >= r_min_px", self.r_max_px),
            ));
        }
        let (low, high) = self.value_range;
        if !(0.0 <= low && low <= high && high <= 1.0) {
            return Err(ImageError::invalid(
                "value_range",
                format!("({low}, {high}), expected 0 <= low <= high <= 1"),
            ));
        }
        if !(1..=16).contains(&self.supersampling) {
            return Err(ImageError::invalid(
                "supersampling",
                format!("{}, expected 1..=16", self.supersampling),
            ));
        }
        if self.max_leaves >= u32::MAX as usize {
            return Err(ImageError::invalid(
                "max_leaves",
                format!("{}, expected < 2^32 - 1", self.max_leaves),
            ));
        }
        Ok(())
    }

    /// Renders the chart (linear-light RGB in `value_range`), deterministic for a given `seed`.
    pub fn render(&self, width: usize, height: usize, seed: u64) -> Result<Planar> {
        Ok(self.render_counted(width, height, seed)?.0)
    }

    /// The chart and the number of leaves drawn until full coverage (or `max_leaves`).
    fn render_counted(&self, width: usize, height: usize, seed: u64) -> Result<(Planar, usize)> {
        super::check_chart_size(width, height)?;
        self.validate()?;
        let n = self.supersampling;
        let (fine_width, fine_height) = (width * n, height * n);
        let mut coverage = Coverage::new(fine_width, fine_height);
        let mut colours: Vec<[f32; 3]> = Vec::new();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let margin = self.r_max_px;
        while coverage.uncovered > 0 && colours.len() < self.max_leaves {
            // Centres uniform on the image enlarged by r_max on every side, so border statistics match the
            // interior (Gousseau & Roueff 2007: the model is stationary only on an unbounded plane).
            let cx = rng.random_range(-margin..width as f64 + margin);
            let cy = rng.random_range(-margin..height as f64 + margin);
            let radius = power_law_radius(self.r_min_px, self.r_max_px, rng.random::<f64>());
            let colour = self.draw_colour(&mut rng);
            let label = colours.len() as u32;
            colours.push(colour);
            let disk = Disk {
                cx: cx * n as f64,
                cy: cy * n as f64,
                radius: radius * n as f64,
            };
            disk.paint(&mut coverage, label);
        }
        let (low, high) = self.value_range;
        let fallback = [(low + high) / 2.0; 3];
        let image = box_downsample(&coverage.labels, &colours, fallback, width, height, n);
        Ok((image, colours.len()))
    }

    fn draw_colour(&self, rng: &mut ChaCha8Rng) -> [f32; 3] {
        let (low, high) = self.value_range;
        let mut value = || low + (high - low) * rng.random::<f32>();
        match self.colours {
            LeafColours::Grey => [value(); 3],
            LeafColours::Colour => [value(), value(), value()],
        }
    }
}

/// Dead-leaves chart with the default parameters of [`DeadLeaves::for_size`]: colour leaves, radii from
/// 1 px to a quarter of the shorter side with density ∝ r^-3, values in [0, 1], covered completely.
pub fn dead_leaves(width: usize, height: usize, seed: u64) -> Result<Planar> {
    DeadLeaves::for_size(width, height).render(width, height, seed)
}

const UNCOVERED: u32 = u32::MAX;

/// Inverse-CDF sample of p(r) ∝ r^-3 on [r_min, r_max] from `u` uniform in [0, 1): with
/// F(r) = (r_min^-2 - r^-2) / (r_min^-2 - r_max^-2), r = (r_min^-2 - u (r_min^-2 - r_max^-2))^(-1/2).
fn power_law_radius(r_min: f64, r_max: f64, u: f64) -> f64 {
    let (a, b) = (r_min.powi(-2), r_max.powi(-2));
    (a - u * (a - b)).powf(-0.5)
}

/// A disk in sub-sample coordinates.
struct Disk {
    cx: f64,
    cy: f64,
    radius: f64,
}

impl Disk {
    /// Writes `label` into every still-uncovered sub-sample whose centre lies inside the disk, row span by
    /// row span, skipping rows and row segments that are already covered.
    fn paint(&self, coverage: &mut Coverage, label: u32) {
        let (width, height) = (coverage.width, coverage.height);
        let row_first = (self.cy - self.radius - 0.5).ceil().max(0.0);
        let row_last = (self.cy + self.radius - 0.5).floor().min(height as f64 - 1.0);
        if row_first > row_last {
            return;
        }
        for row in row_first as usize..=row_last as usize {
            if coverage.row_uncovered[row] == 0 {
                continue;
            }
            let dy = row as f64 + 0.5 - self.cy;
            let half_width = (self.radius * self.radius - dy * dy).max(0.0).sqrt();
            let first = (self.cx - half_width - 0.5).ceil().max(0.0);
            let last = (self.cx + half_width - 0.5).floor().min(width as f64 - 1.0);
            if first <= last {
                coverage.paint_span(row, first as usize, last as usize, label);
            }
        }
    }
}

/// Sub-samples per row segment whose uncovered ones are counted.
const SEGMENT: usize = 16;

/// The label of every sub-sample, with counts of the uncovered ones per row and per row segment.
struct Coverage {
    labels: Vec<u32>,
    width: usize,
    height: usize,
    segments_per_row: usize,
    segment_uncovered: Vec<u8>,
    row_uncovered: Vec<u32>,
    uncovered: usize,
}

impl Coverage {
    fn new(width: usize, height: usize) -> Coverage {
        let segments_per_row = width.div_ceil(SEGMENT);
        let segment_width = |i: usize| (width - i * SEGMENT).min(SEGMENT) as u8;
        let row: Vec<u8> = (0..segments_per_row).map(segment_width).collect();
        Coverage {
            labels: vec![UNCOVERED; width * height],
            width,
            height,
            segments_per_row,
            segment_uncovered: row.repeat(height),
            row_uncovered: vec![width as u32; height],
            uncovered: width * height,
        }
    }

    /// Labels the uncovered sub-samples of `row` from column `first` to `last` (inclusive).
    fn paint_span(&mut self, row: usize, first: usize, last: usize, label: u32) {
        let start = row * self.width;
        let segments = row * self.segments_per_row;
        let mut painted_row = 0;
        for segment in first / SEGMENT..=last / SEGMENT {
            let count = &mut self.segment_uncovered[segments + segment];
            if *count == 0 {
                continue;
            }
            let (from, to) = (
                (segment * SEGMENT).max(first),
                (segment * SEGMENT + SEGMENT - 1).min(last),
            );
            let mut painted = 0;
            for sample in &mut self.labels[start + from..=start + to] {
                if *sample == UNCOVERED {
                    *sample = label;
                    painted += 1;
                }
            }
            *count -= painted;
            painted_row += u32::from(painted);
        }
        self.row_uncovered[row] -= painted_row;
        self.uncovered -= painted_row as usize;
    }
}

/// Mean colour of each `n x n` block of labelled sub-samples (box filter), as RGB planes.
fn box_downsample(
    labels: &[u32],
    colours: &[[f32; 3]],
    fallback: [f32; 3],
    width: usize,
    height: usize,
    n: usize,
) -> Planar {
    let mut image = Planar::new(width, height, 3);
    let fine_width = width * n;
    let weight = 1.0 / (n * n) as f32;
    for y in 0..height {
        for x in 0..width {
            let mut sum = [0.0f32; 3];
            for j in 0..n {
                let row = (y * n + j) * fine_width + x * n;
                for &label in &labels[row..row + n] {
                    let colour = colours.get(label as usize).unwrap_or(&fallback);
                    for (s, c) in sum.iter_mut().zip(colour) {
                        *s += c;
                    }
                }
            }
            for (channel, s) in sum.iter().enumerate() {
                image.set(channel, x, y, s * weight);
            }
        }
    }
    image
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_leaves_is_reproducible_per_seed_and_differs_across_seeds() {
        let a = dead_leaves(96, 64, 7).unwrap();
        let b = dead_leaves(96, 64, 7).unwrap();
        let c = dead_leaves(96, 64, 8).unwrap();
        assert_eq!(a, b);
        let differing = a.data.iter().zip(&c.data).filter(|(x, y)| x != y).count();
        assert!(
            differing as f64 > 0.9 * a.data.len() as f64,
            "only {differing} samples differ"
        );
        assert!(a.data.iter().all(|v| (0.0..=1.0).contains(v)));
        assert_eq!((a.width, a.height, a.channels), (96, 64, 3));
    }

    #[test]
    fn dead_leaves_covers_the_image_and_respects_options() {
        let mut options = DeadLeaves::for_size(128, 128);
        options.colours = LeafColours::Grey;
        options.value_range = (0.25, 0.75);
        let (chart, leaves) = options.render_counted(128, 128, 3).unwrap();
        assert!(leaves < options.max_leaves, "stopped by the cap, not by coverage");
        assert!(chart.data.iter().all(|v| (0.25..=0.75).contains(v)));
        assert_eq!(chart.plane(0), chart.plane(2));
        // Colour leaves decorrelate the channels.
        let colour = dead_leaves(128, 128, 3).unwrap();
        let differing = colour
            .plane(0)
            .iter()
            .zip(colour.plane(1))
            .filter(|(r, g)| r != g)
            .count();
        assert!(differing > 128 * 128 / 2);
        // A tiny cap leaves uncovered samples at the mid value instead of failing.
        options.max_leaves = 1;
        options.r_max_px = 1.0;
        let sparse = options.render(16, 16, 1).unwrap();
        assert!(sparse.data.iter().filter(|&&v| v == 0.5).count() > 200);
    }

    #[test]
    fn radii_follow_the_inverse_cube_law() {
        // Median of p(r) ∝ r^-3 on [1, 100]: F(r) = 1/2 at r = (1 - (1 - 1e-4) / 2)^(-1/2) = 1.41414.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut radii: Vec<f64> = (0..100_000)
            .map(|_| power_law_radius(1.0, 100.0, rng.random()))
            .collect();
        radii.sort_by(f64::total_cmp);
        let median = radii[radii.len() / 2];
        assert!((median / 1.414_14 - 1.0).abs() < 0.01, "median {median}");
        // 90th percentile: (1 - 0.9 (1 - 1e-4))^(-1/2) = 3.16083.
        let p90 = radii[radii.len() * 9 / 10];
        assert!((p90 / 3.160_83 - 1.0).abs() < 0.02, "p90 {p90}");
        assert!(radii.iter().all(|&r| (1.0..=100.0).contains(&r)));
    }

    #[test]
    fn bad_dead_leaves_parameters_are_typed_errors() {
        let mut options = DeadLeaves::for_size(32, 32);
        options.r_min_px = 0.0;
        assert!(matches!(
            options.render(32, 32, 0),
            Err(ImageError::InvalidParameter {
                field: "r_min_px",
                ..
            })
        ));
        let mut options = DeadLeaves::for_size(32, 32);
        options.value_range = (0.8, 0.2);
        assert!(matches!(
            options.render(32, 32, 0),
            Err(ImageError::InvalidParameter {
                field: "value_range",
                ..
            })
        ));
    }
}

#[cfg(test)]
mod golden {
    use super::*;

    /// FNV-1a over the chart's f32 bits: a fingerprint of the exact output.
    fn fingerprint(chart: &Planar) -> u64 {
        chart.data.iter().fold(0xcbf2_9ce4_8422_2325, |h, v| {
            (h ^ u64::from(v.to_bits())).wrapping_mul(0x0100_0000_01b3)
        })
    }

    /// The coverage counts only skip work: the charts are the ones the plain front-to-back painter drew
    /// (fingerprints recorded from it before the counts were added), so datasets built on dead-leaves
    /// scenes keep their bytes.
    #[test]
    fn charts_are_bit_identical_to_the_plain_painter() {
        for (w, h, seed, expected) in [
            (300, 200, 5, 0xa6f7_f2a4_2c4d_4e91u64),
            (640, 480, 9, 0x4187_3846_7607_e4f0),
            (97, 61, 1, 0x958a_6f21_ac8a_bb49),
        ] {
            let chart = dead_leaves(w, h, seed).unwrap();
            assert_eq!(fingerprint(&chart), expected, "{w}x{h} seed {seed}");
        }
    }
}
