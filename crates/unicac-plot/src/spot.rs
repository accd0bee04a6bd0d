//! Spot diagrams: one panel per field (rows, in the order given) and wavelength (columns, ascending),
//! each centred on its centroid, all at one scale.

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use unicac_trace::Spot;

const PANEL_SIZE: (u32, u32) = (340, 360);
const MIN_WIDTH: u32 = 760;

/// Draws `spots` as a grid of spot diagrams (rows: fields, columns: wavelengths, dots in the
/// wavelength's colour). Panel axes are µm from the panel's centroid, with one common half-width for all
/// panels so spot sizes compare; panel titles give field, wavelength and RMS radius about the centroid.
/// A spot without rays gets an empty panel saying so.
pub fn spot_diagram(spots: &[Spot], path: &Path) -> Result<(), PlotError> {
    if spots.is_empty() {
        return Err(PlotError::InvalidInput("no spots to draw".into()));
    }
    let largest_radius_um = spots
        .iter()
        .filter_map(|s| s.geometric_radius_um)
        .fold(0.0, f64::max);
    render(
        &SpotDiagram {
            spots,
            fields: style::distinct(spots.iter().map(|s| s.field_deg)),
            wavelengths: style::sorted_distinct(spots.iter().map(|s| s.wavelength_um)),
            half_width_um: style::nice_ceiling(1.1 * largest_radius_um),
        },
        path,
    )
}

struct SpotDiagram<'a> {
    spots: &'a [Spot],
    fields: Vec<f64>,
    wavelengths: Vec<f64>,
    half_width_um: f64,
}

impl Picture for SpotDiagram<'_> {
    fn size(&self) -> (u32, u32) {
        let (columns, rows) = (self.wavelengths.len() as u32, self.fields.len() as u32);
        (
            (columns * PANEL_SIZE.0).max(MIN_WIDTH),
            rows * PANEL_SIZE.1 + style::TITLE_HEIGHT,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let title = format!(
            "Spot diagram: each panel centred on its centroid, common scale ±{} µm",
            style::significant(self.half_width_um, 2)
        );
        let panels = style::figure(&root, &title)?.split_evenly((self.fields.len(), self.wavelengths.len()));
        for (i, area) in panels.iter().enumerate() {
            let (field, wavelength) = (
                self.fields[i / self.wavelengths.len()],
                self.wavelengths[i % self.wavelengths.len()],
            );
            if let Some(spot) = self
                .spots
                .iter()
                .find(|s| s.field_deg == field && s.wavelength_um == wavelength)
            {
                self.draw_panel(area, spot)?;
            }
        }
        Ok(())
    }
}

impl SpotDiagram<'_> {
    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        spot: &Spot,
    ) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let radius = match spot.rms_radius_um {
            Some(rms) if !spot.points_mm.is_empty() => format!("RMS {} µm", style::significant(rms, 3)),
            _ => "no rays".into(),
        };
        let caption = format!(
            "{}   {}   {radius}",
            style::field_label(spot.field_deg),
            style::wavelength_label(spot.wavelength_um)
        );
        let h = self.half_width_um;
        let mut chart = style::panel(
            area,
            Axes {
                caption: &caption,
                x: -h..h,
                y: -h..h,
                x_desc: "Δx (µm)",
                y_desc: "Δy (µm)",
                equal_aspect: true,
            },
        )?;
        let colour = style::ramp(
            style::rank(&self.wavelengths, spot.wavelength_um),
            self.wavelengths.len(),
        );
        match spot.centroid_x_mm.zip(spot.centroid_y_mm) {
            Some((cx, cy)) => {
                let dot =
                    |p: &[f64; 2]| Circle::new(((p[0] - cx) * 1e3, (p[1] - cy) * 1e3), 1.6, colour.filled());
                chart.draw_series(spot.points_mm.iter().map(dot))?;
            }
            None => {
                let note = format!("none of {} rays reached the image", spot.rays_traced);
                chart.draw_series(std::iter::once(Text::new(note, (0.0, 0.0), style::centred(14.0))))?;
            }
        }
        Ok(())
    }
}
