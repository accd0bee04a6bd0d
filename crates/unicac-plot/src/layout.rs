//! The lens layout: surfaces, elements, stop, image surface and rays in the y-z plane.

use crate::render::{render, Picture};
use crate::style::{self, Axes, Chart};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use unicac_optics::Lens;
use unicac_trace::{Aimer, Aiming, Clipping, Ray, RayStatus, TraceSystem};

/// Traced rays of one field: each path is the list of points from `TraceSystem::trace_path` (start,
/// then one point per surface reached, global mm).
#[derive(Debug, Clone, PartialEq)]
pub struct RayBundle {
    pub field_deg: f64,
    pub paths: Vec<Vec<[f64; 3]>>,
}

/// Plot width (pixels) of the layout; the height follows from the lens's aspect ratio.
const PLOT_WIDTH: f64 = 1300.0;
const PLOT_HEIGHT_LIMITS: (f64, f64) = (320.0, 820.0);
/// Length of the stop's blades as a fraction of the plot's half-height.
const STOP_BLADE: f64 = 0.08;
/// Points sampled along each surface profile.
const PROFILE_SAMPLES: usize = 81;

/// Meridional fans for `layout`: for every field angle of the lens (first-order data), `rays_per_field`
/// rays with px = 0 and py evenly from -1 to 1 (just the chief ray for 1), paraxially aimed at the primary
/// wavelength and traced with clipping at the clear semi-diameters. A ray that fails (clipped, missed,
/// totally reflected) is drawn up to the surface where it stopped. Each ray starts on the plane z = min(entrance pupil z, 0) - 0.2 total
/// track (or at the object, if nearer), so it is seen entering the lens.
/// Most rays drawn per field: more would only blacken the picture (and each ray's path is kept).
pub const MAX_LAYOUT_RAYS: usize = 1000;

pub fn layout_bundles(lens: &Lens, rays_per_field: usize) -> Result<Vec<RayBundle>, PlotError> {
    if !(1..=MAX_LAYOUT_RAYS).contains(&rays_per_field) {
        return Err(PlotError::InvalidInput(format!(
            "rays per field {rays_per_field}: must lie between 1 and {MAX_LAYOUT_RAYS} (MAX_LAYOUT_RAYS)"
        )));
    }
    let first = lens.first_order()?;
    let wavelength = lens.primary_wavelength_um();
    let aimer = Aimer::new(lens, wavelength, Aiming::Paraxial)?;
    let system = TraceSystem::new(lens, wavelength, Clipping::Apertures)?;
    let mut start_z = first.entrance_pupil_z_mm.min(0.0) - 0.2 * lens.total_track_mm().abs();
    if let Some(distance) = lens.object_distance_mm {
        start_z = start_z.max(-distance);
    }
    first
        .field_angles_deg
        .iter()
        .map(|&field_deg| {
            let paths = (0..rays_per_field)
                .map(|i| {
                    let py = if rays_per_field > 1 {
                        -1.0 + 2.0 * i as f64 / (rays_per_field - 1) as f64
                    } else {
                        0.0
                    };
                    let ray = moved_to(aimer.ray(field_deg, 0.0, py)?, start_z);
                    let (mut points, status) = system.trace_path(ray);
                    if let Some(surface) = failed_at(status) {
                        points.extend(to_surface(lens, surface, &points, ray.direction));
                    }
                    Ok(points)
                })
                .collect::<Result<_, PlotError>>()?;
            Ok(RayBundle { field_deg, paths })
        })
        .collect()
}

/// The surface where a ray's trace stopped, if it failed at one.
fn failed_at(status: RayStatus) -> Option<usize> {
    match status {
        RayStatus::Missed { surface }
        | RayStatus::Tir { surface }
        | RayStatus::Clipped { surface }
        | RayStatus::NoConvergence { surface } => Some(surface as usize),
        RayStatus::Ok | RayStatus::InvalidInput => None,
    }
}

/// Where a failed ray's last straight segment meets (approximately) surface `index` extended beyond its
/// edge, so the drawing shows it stopped there: the point on the vertex plane, moved once to the sag at
/// that height. `first_direction` is the ray's direction when the path holds only its start.
fn to_surface(lens: &Lens, index: usize, points: &[[f64; 3]], first_direction: [f64; 3]) -> Option<[f64; 3]> {
    let last = *points.last()?;
    let d = match points {
        [.., before, last] => [0, 1, 2].map(|k| last[k] - before[k]),
        _ => first_direction,
    };
    let surface = &lens.surfaces[index];
    let at_z = |z: f64| (d[2] != 0.0).then(|| [0, 1, 2].map(|k| last[k] + (z - last[2]) / d[2] * d[k]));
    let on_plane = at_z(surface.z_mm)?;
    let rho = (on_plane[0] * on_plane[0] + on_plane[1] * on_plane[1]).min(surface.profile.conic_rho_limit());
    at_z(surface.z_mm + surface.profile.sag(rho)).filter(|p| p.iter().all(|v| v.is_finite()))
}

/// The same ray, its start moved along it to the plane z = `z` (unchanged if it runs parallel to it).
fn moved_to(ray: Ray, z: f64) -> Ray {
    let [l, m, n] = ray.direction;
    if n == 0.0 {
        return ray;
    }
    let t = (z - ray.position_mm[2]) / n;
    let p = ray.position_mm;
    Ray {
        position_mm: [p[0] + t * l, p[1] + t * m, z],
        direction: ray.direction,
    }
}

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
