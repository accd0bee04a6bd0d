//! Line charts in one or more panels: the lens analyses (MTF against frequency or field, through-focus
//! curves, field curvature and distortion, relative illumination, encircled energy).

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const PANEL: (u32, u32) = (620, 440);
const MAX_COLUMNS: usize = 3;
/// Most panels in one picture (a 3 x 4 grid of 620 x 440 px panels is 1860 x 1800 px).
pub const MAX_PANELS: usize = 12;

/// How a line is coloured: by its series (the ramp over `series` series of the panel), or as a
/// reference curve (black, such as the diffraction limit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LineColour {
    Series { rank: usize, series: usize },
    Reference,
}

/// One labelled line: `y` against `x`, point by point (non-finite points are left out).
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub colour: LineColour,
    pub dashed: bool,
}

/// One chart: a caption, axis descriptions, the y range (None: from the data) and its lines.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePanel {
    pub caption: String,
    pub x_desc: String,
    pub y_desc: String,
    pub y_range: Option<(f64, f64)>,
    pub lines: Vec<Line>,
}

/// Draws `panels` (at most [`MAX_PANELS`], three per row) under one `title`, each with a legend in its
/// upper right corner.
pub fn line_panels(title: &str, panels: &[LinePanel], path: &Path) -> Result<(), PlotError> {
    if panels.is_empty() || panels.len() > MAX_PANELS {
        return Err(PlotError::InvalidInput(format!(
            "{} panels: need 1 to {MAX_PANELS}",
            panels.len()
        )));
    }
    for panel in panels {
        if panel.lines.is_empty() {
            return Err(PlotError::InvalidInput(format!(
                "panel '{}' has no lines",
                panel.caption
            )));
        }
        for line in &panel.lines {
            if line.x.len() != line.y.len() {
                return Err(PlotError::InvalidInput(format!(
                    "line '{}' has {} x and {} y values",
                    line.label,
                    line.x.len(),
                    line.y.len()
                )));
            }
        }
    }
    render(&LinePanels { title, panels }, path)
}

struct LinePanels<'a> {
    title: &'a str,
    panels: &'a [LinePanel],
}

fn finite_points(line: &Line) -> impl Iterator<Item = (f64, f64)> + '_ {
    line.x
        .iter()
        .zip(&line.y)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
}

/// The range of `values` padded by 5% (a unit range about a single value; 0..1 when empty).
fn padded(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        0.5 * lo.abs().max(1e-9)
    };
    (lo - pad)..(hi + pad)
}

impl Picture for LinePanels<'_> {
    fn size(&self) -> (u32, u32) {
        let columns = self.panels.len().min(MAX_COLUMNS);
        let rows = self.panels.len().div_ceil(MAX_COLUMNS);
        (
            PANEL.0 * columns as u32,
            PANEL.1 * rows as u32 + style::TITLE_HEIGHT,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, self.title)?;
        let columns = self.panels.len().min(MAX_COLUMNS);
        let rows = self.panels.len().div_ceil(MAX_COLUMNS);
        let cells = area.split_evenly((rows, columns));
        for (panel, cell) in self.panels.iter().zip(cells) {
            let x = padded(panel.lines.iter().flat_map(|l| finite_points(l).map(|p| p.0)));
            let x = if x.start < 0.0 && x.start > -1e-12 {
                0.0..x.end
            } else {
                x
            };
            let y = match panel.y_range {
                Some((lo, hi)) => lo..hi,
                None => padded(panel.lines.iter().flat_map(|l| finite_points(l).map(|p| p.1))),
            };
            let mut chart = style::panel(
                &cell,
                Axes {
                    caption: &panel.caption,
                    x,
                    y,
                    x_desc: &panel.x_desc,
                    y_desc: &panel.y_desc,
                    equal_aspect: false,
                },
            )?;
            for line in &panel.lines {
                let colour = match line.colour {
                    LineColour::Series { rank, series } => style::ramp(rank, series),
                    LineColour::Reference => BLACK,
                };
                let look = style::Look {
                    colour,
                    dashed: line.dashed,
                };
                style::series(&mut chart, finite_points(line), look, &line.label)?;
            }
            style::legend_at(&mut chart, SeriesLabelPosition::UpperRight)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(label: &str) -> Line {
        Line {
            label: label.into(),
            x: vec![0.0, 1.0, 2.0],
            y: vec![1.0, 0.5, f64::NAN],
            colour: LineColour::Series { rank: 0, series: 2 },
            dashed: false,
        }
    }

    #[test]
    fn panels_are_drawn_as_svg_and_bad_input_is_refused() {
        let dir = std::env::temp_dir().join(format!("unicac-lines-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let panel = LinePanel {
            caption: "0°".into(),
            x_desc: "cycles/mm".into(),
            y_desc: "MTF".into(),
            y_range: Some((0.0, 1.05)),
            lines: vec![
                line("tangential"),
                Line {
                    colour: LineColour::Reference,
                    dashed: true,
                    ..line("diffraction limit")
                },
            ],
        };
        let path = dir.join("mtf.svg");
        line_panels("MTF", &[panel.clone(), panel.clone()], &path).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("diffraction limit") && svg.contains("cycles/mm"));
        assert!(line_panels("MTF", &[], &path).is_err());
        let mut uneven = panel;
        uneven.lines[0].y.pop();
        assert!(matches!(
            line_panels("MTF", &[uneven], &path),
            Err(PlotError::InvalidInput(_))
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
