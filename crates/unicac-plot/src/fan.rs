//! Ray fan plots: transverse aberration against pupil coordinate, per field, wavelengths overlaid.

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use unicac_trace::spot::{FanPoint, RayFan};

const PANEL_SIZE: (u32, u32) = (520, 300);

/// Draws `fans` as one row per field (in the order given): tangential ey against py on the left,
/// sagittal ex against px on the right, in µm about the chief ray, one colour per wavelength and one
/// vertical scale for every panel. Rays that failed break their curve.
pub fn ray_fan_plot(fans: &[RayFan], path: &Path) -> Result<(), PlotError> {
    if fans.is_empty() {
        return Err(PlotError::InvalidInput("no ray fans to draw".into()));
    }
    let largest_um = fans
        .iter()
        .flat_map(|f| {
            f.tangential
                .iter()
                .map(|p| p.ey_um)
                .chain(f.sagittal.iter().map(|p| p.ex_um))
        })
        .fold(0.0, |m: f64, e| if e.is_finite() { m.max(e.abs()) } else { m });
    render(
        &FanPlot {
            fans,
            fields: style::distinct(fans.iter().map(|f| f.field_deg)),
            wavelengths: style::sorted_distinct(fans.iter().map(|f| f.wavelength_um)),
            half_range_um: style::nice_ceiling(1.05 * largest_um),
        },
        path,
    )
}

struct FanPlot<'a> {
    fans: &'a [RayFan],
    fields: Vec<f64>,
    wavelengths: Vec<f64>,
    half_range_um: f64,
}

impl Picture for FanPlot<'_> {
    fn size(&self) -> (u32, u32) {
        (
            2 * PANEL_SIZE.0,
            self.fields.len() as u32 * PANEL_SIZE.1 + style::TITLE_HEIGHT,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, "Ray fans: transverse aberration about the chief ray")?;
        for (i, panel) in area.split_evenly((self.fields.len(), 2)).iter().enumerate() {
            self.draw_panel(panel, self.fields[i / 2], i % 2 == 0, i == 0)?;
        }
        Ok(())
    }
}

impl FanPlot<'_> {
    /// The tangential or sagittal fans of one field; `with_legend` adds the wavelength legend.
    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        field_deg: f64,
        tangential: bool,
        with_legend: bool,
    ) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let (name, x_desc, y_desc) = if tangential {
            ("tangential", "py", "ey (µm)")
        } else {
            ("sagittal", "px", "ex (µm)")
        };
        let caption = format!("{}   {name}", style::field_label(field_deg));
        let h = self.half_range_um;
        let mut chart = style::panel(
            area,
            Axes {
                caption: &caption,
                x: -1.0..1.0,
                y: -h..h,
                x_desc,
                y_desc,
                equal_aspect: false,
            },
        )?;
        style::line(&mut chart, [(-1.0, 0.0), (1.0, 0.0)], BLACK.mix(0.5).into(), None)?;
        for fan in self.fans.iter().filter(|f| f.field_deg == field_deg) {
            let colour = style::ramp(
                style::rank(&self.wavelengths, fan.wavelength_um),
                self.wavelengths.len(),
            );
            let points = if tangential {
                &fan.tangential
            } else {
                &fan.sagittal
            };
            let value = |p: &FanPoint| if tangential { p.ey_um } else { p.ex_um };
            // Consecutive arriving rays form one curve; a failed ray breaks it.
            for (k, run) in points
                .split(|p| !p.status.is_ok())
                .filter(|run| !run.is_empty())
                .enumerate()
            {
                let label = (with_legend && k == 0).then(|| style::wavelength_label(fan.wavelength_um));
                style::line(
                    &mut chart,
                    run.iter().map(|p| (p.pupil, value(p))),
                    colour.stroke_width(2),
                    label,
                )?;
            }
        }
        if with_legend {
            style::legend(&mut chart)?;
        }
        Ok(())
    }
}
