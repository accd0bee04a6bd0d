//! The lens layout: surfaces, elements, stop, image surface and rays in the y-z plane.

use crate::render::{render, Picture};
use crate::style::{self, Axes, Chart};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use unicac_optics::Lens;
use unicac_trace::meridional::RayBundle;

/// Plot width (pixels) of the layout; the height follows from the lens's aspect ratio.
const PLOT_WIDTH: f64 = 1300.0;
const PLOT_HEIGHT_LIMITS: (f64, f64) = (320.0, 820.0);
/// Length of the stop's blades as a fraction of the plot's half-height.
const STOP_BLADE: f64 = 0.08;
/// Points sampled along each surface profile.
const PROFILE_SAMPLES: usize = 81;

/// Draws the lens in the y-z plane (z right, y up, one scale for both): surface profiles over
/// `semi_diameters` (one per surface, as from `unicac_trace::apertures::clear_semi_diameters`), glass
/// elements shaded and closed by flat edges, the stop's blades, the image surface, and the rays of each
/// bundle in the field's colour.
pub fn layout(
    lens: &Lens,
    bundles: &[RayBundle],
    semi_diameters: &[f64],
    path: &Path,
) -> Result<(), PlotError> {
    if semi_diameters.len() != lens.surfaces.len() {
        return Err(PlotError::InvalidInput(format!(
            "{} semi-diameters for {} surfaces",
            semi_diameters.len(),
            lens.surfaces.len()
        )));
    }
    let surfaces: Vec<Vec<(f64, f64)>> = (0..lens.surfaces.len())
        .map(|i| profile(lens, i, semi_diameters[i]))
        .collect();
    let points = surfaces.iter().flatten().copied().chain(
        bundles
            .iter()
            .flat_map(|b| &b.paths)
            .flatten()
            .map(|p| (p[2], p[1])),
    );
    let (mut z, mut y) = (f64::INFINITY..f64::NEG_INFINITY, 0.0f64);
    for (pz, py) in points.filter(|(pz, py)| pz.is_finite() && py.is_finite()) {
        (z.start, z.end, y) = (z.start.min(pz), z.end.max(pz), y.max(py.abs()));
    }
    if z.is_empty() {
        return Err(PlotError::InvalidInput("the lens has no extent to draw".into()));
    }
    let pad = 0.04 * (z.end - z.start);
    // Room above the stop for its blades (STOP_BLADE of the half-height) and its label.
    let stop_room = semi_diameters[lens.stop_index] / (1.0 - STOP_BLADE - 0.06);
    let (z, y) = (z.start - pad..z.end + pad, (y.max(pad) + pad).max(stop_room));
    let plot_height =
        (PLOT_WIDTH * 2.0 * y / (z.end - z.start)).clamp(PLOT_HEIGHT_LIMITS.0, PLOT_HEIGHT_LIMITS.1);
    render(
        &Layout {
            lens,
            bundles,
            semi_diameters,
            surfaces,
            z,
            y_half: y,
            plot_height,
        },
        path,
    )
}

/// Points (z, y) of surface `index`'s profile for |y| <= semi-diameter (within the conic's domain).
fn profile(lens: &Lens, index: usize, semi_diameter: f64) -> Vec<(f64, f64)> {
    let surface = &lens.surfaces[index];
    let half = semi_diameter.min(surface.profile.conic_rho_limit().sqrt());
    (0..PROFILE_SAMPLES)
        .map(|k| {
            let y = half * (2.0 * k as f64 / (PROFILE_SAMPLES - 1) as f64 - 1.0);
            (surface.z_mm + surface.profile.sag(y * y), y)
        })
        .filter(|(z, _)| z.is_finite())
        .collect()
}

struct Layout<'a> {
    lens: &'a Lens,
    bundles: &'a [RayBundle],
    semi_diameters: &'a [f64],
    /// Profile points of every surface, bottom to top.
    surfaces: Vec<Vec<(f64, f64)>>,
    z: std::ops::Range<f64>,
    y_half: f64,
    plot_height: f64,
}

impl Picture for Layout<'_> {
    fn size(&self) -> (u32, u32) {
        // Plot area plus axis labels, caption and figure margins (see `style::panel`).
        (PLOT_WIDTH as u32 + 100, self.plot_height as u32 + 110)
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let name = if self.lens.name.is_empty() {
            "lens".to_string()
        } else {
            self.lens.name.clone()
        };
        let first = self.lens.first_order()?;
        let caption = format!(
            "Layout: {name}   (EFL {} mm, F/{}, total track {} mm)",
            style::significant(first.efl_mm, 4),
            style::significant(first.f_number, 3),
            style::significant(first.total_track_mm, 4)
        );
        let axes = Axes {
            caption: &caption,
            x: self.z.clone(),
            y: -self.y_half..self.y_half,
            x_desc: "z (mm)",
            y_desc: "y (mm)",
            equal_aspect: true,
        };
        let mut chart = style::panel(&root, axes)?;
        self.draw_glass(&mut chart)?;
        let image = self.lens.image_index();
        for (i, points) in self.surfaces.iter().enumerate() {
            let style = if i == image {
                BLACK.stroke_width(3)
            } else {
                BLACK.stroke_width(1)
            };
            // Air-to-air surfaces other than the image (dummy planes, an air stop) are drawn faintly.
            let in_air = i != image && !self.is_glass_face(i);
            style::line(
                &mut chart,
                points.iter().copied(),
                if in_air { BLACK.mix(0.25).into() } else { style },
                None,
            )?;
        }
        let fields = style::distinct(self.bundles.iter().map(|b| b.field_deg));
        for bundle in self.bundles {
            let colour = style::ramp(style::rank(&fields, bundle.field_deg), fields.len());
            for (k, ray) in bundle.paths.iter().enumerate() {
                let label = (k == 0).then(|| format!("field {}", style::field_label(bundle.field_deg)));
                style::line(
                    &mut chart,
                    ray.iter().map(|p| (p[2], p[1])),
                    colour.stroke_width(1),
                    label,
                )?;
            }
        }
        self.draw_stop(&mut chart)?;
        style::legend(&mut chart)
    }
}

impl Layout<'_> {
    /// Whether surface `i` bounds a glass element (glass before or after it).
    fn is_glass_face(&self, i: usize) -> bool {
        let glass_after = |j: usize| !self.lens.surfaces[j].medium_after.is_air();
        glass_after(i) || (i > 0 && glass_after(i - 1))
    }

    /// Each glass element (surface i with glass after it and surface i + 1) as a shaded outline whose
    /// edge is flat at the larger of its two semi-diameters.
    fn draw_glass<'a, DB: DrawingBackend + 'a>(&self, chart: &mut Chart<'a, DB>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        for i in 0..self.lens.image_index().saturating_sub(1) {
            if self.lens.surfaces[i].medium_after.is_air() {
                continue;
            }
            let (front, back) = (&self.surfaces[i], &self.surfaces[i + 1]);
            let (Some(&front_top), Some(&back_top)) = (front.last(), back.last()) else {
                continue;
            };
            let edge = self.semi_diameters[i].max(self.semi_diameters[i + 1]);
            let mut outline = front.clone();
            outline.extend([(front_top.0, edge), (back_top.0, edge)]);
            outline.extend(back.iter().rev());
            outline.extend([(back_top.0, -edge), (front_top.0, -edge), front[0]]);
            chart.draw_series(std::iter::once(Polygon::new(
                outline.clone(),
                RGBColor(150, 190, 230).mix(0.35),
            )))?;
            style::line(chart, outline, BLACK.stroke_width(1), None)?;
        }
        Ok(())
    }

    /// Blades from the stop's clear semi-diameter outwards, and its name.
    fn draw_stop<'a, DB: DrawingBackend + 'a>(&self, chart: &mut Chart<'a, DB>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let stop = self.lens.stop_index;
        let (z, y) = self.surfaces[stop]
            .last()
            .copied()
            .unwrap_or((self.lens.surfaces[stop].z_mm, 0.0));
        let blade = STOP_BLADE * self.y_half;
        for sign in [1.0, -1.0] {
            style::line(
                chart,
                [(z, sign * y), (z, sign * (y + blade))],
                BLACK.stroke_width(4),
                None,
            )?;
        }
        let label = Text::new(
            "STOP",
            (z, y + blade),
            style::font(13.0).pos(Pos::new(HPos::Center, VPos::Bottom)),
        );
        chart.draw_series(std::iter::once(label))?;
        Ok(())
    }
}
