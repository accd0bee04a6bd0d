//! MTF curves: modulation against spatial frequency in cycles per pixel, with Nyquist and MTF50 marked.

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

const SIZE: (u32, u32) = (900, 580);
/// The Nyquist frequency of a sampled image, cycles per pixel.
const NYQUIST: f64 = 0.5;
const GUIDE_TEXT: RGBColor = RGBColor(60, 60, 60);

/// One labelled curve: `y` against `x`, point by point.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

/// Draws MTF `curves` (x in cycles/pixel, y the modulation) on one chart titled `title`: x from 0 to the
/// largest x (at least 0.5), y from 0 to 1.05 (or the largest value), a dashed vertical line at Nyquist
/// (0.5 cycles/pixel) and a dotted horizontal line at MTF 0.5, both labelled, and a legend of the
/// labels. Curves labelled by colour channel ("R", "G", "B", "exact G") are drawn red, green and blue,
/// a second curve of one channel dashed; other labels take the ramp's colours. Non-finite points are
/// left out.
pub fn mtf_curves(title: &str, curves: &[Curve], path: &Path) -> Result<(), PlotError> {
    if curves.is_empty() {
        return Err(PlotError::InvalidInput("no MTF curves to draw".into()));
    }
    for curve in curves {
        if curve.x.len() != curve.y.len() || curve.x.is_empty() {
            return Err(PlotError::InvalidInput(format!(
                "MTF curve '{}' has {} frequencies and {} values",
                curve.label,
                curve.x.len(),
                curve.y.len()
            )));
        }
    }
    let finite = || {
        curves
            .iter()
            .flat_map(|c| c.x.iter().zip(&c.y))
            .filter(|(x, y)| x.is_finite() && y.is_finite())
    };
    render(
        &MtfPlot {
            title,
            curves,
            x_max: finite().map(|(x, _)| *x).fold(NYQUIST, f64::max),
            y_max: finite().map(|(_, y)| *y).fold(1.05, f64::max),
        },
        path,
    )
}

struct MtfPlot<'a> {
    title: &'a str,
    curves: &'a [Curve],
    x_max: f64,
    y_max: f64,
}

impl Picture for MtfPlot<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, self.title)?;
        let mut chart = style::panel(
            &area,
            Axes {
                caption: "Modulation transfer function",
                x: 0.0..self.x_max,
                y: 0.0..self.y_max,
                x_desc: "spatial frequency (cycles/pixel)",
                y_desc: "MTF",
                equal_aspect: false,
            },
        )?;
        let guide = BLACK.mix(0.55).stroke_width(1);
        style::dashed_line(
            &mut chart,
            [(NYQUIST, 0.0), (NYQUIST, self.y_max)],
            (8, 5),
            guide,
            None,
        )?;
        style::dashed_line(&mut chart, [(0.0, 0.5), (self.x_max, 0.5)], (2, 4), guide, None)?;
        // Labels on white so crossing curves leave them readable: Nyquist at the top left of its line,
        // MTF50 above the right end of its line.
        let label = |text: &str, at: (f64, f64), shift: (i32, i32), h: HPos| {
            let style = style::font(13.0)
                .color(&GUIDE_TEXT)
                .pos(Pos::new(h, VPos::Center));
            let width = style::text_width(text, 13.0) as i32;
            let left = match h {
                HPos::Right => shift.0 - width,
                _ => shift.0,
            };
            EmptyElement::at(at)
                + Rectangle::new(
                    [(left - 3, shift.1 - 9), (left + width + 3, shift.1 + 9)],
                    WHITE.mix(0.85).filled(),
                )
                + Text::new(text.to_string(), shift, style)
        };
        chart.draw_series([
            label("Nyquist", (NYQUIST, self.y_max), (-6, 14), HPos::Right),
            label("MTF50", (self.x_max, 0.5), (-6, -12), HPos::Right),
        ])?;
        let labels: Vec<&str> = self.curves.iter().map(|c| c.label.as_str()).collect();
        for (curve, look) in self.curves.iter().zip(style::looks(&labels)) {
            let points = curve
                .x
                .iter()
                .zip(&curve.y)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .map(|(x, y)| (*x, *y));
            style::series(&mut chart, points, look, &curve.label)?;
        }
        // Below the curves at low frequency, where they are still high, the chart is empty.
        style::legend_at(&mut chart, SeriesLabelPosition::LowerLeft)?;
        Ok(())
    }
}
