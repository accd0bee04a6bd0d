//! Benchmark pictures: per-model lines across levels (metric trends, ranking trends) and scatter plots
//! with least-squares lines (the per-lens O.P.-vs-ODE and O.P.-vs-RMS analysis).

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const LINE_SIZE: (u32, u32) = (1040, 560);
const SCATTER_PANEL: (u32, u32) = (620, 520);

/// One model's values across levels; `None` where a level has no value.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelSeries {
    pub label: String,
    pub values: Vec<Option<f64>>,
}

/// Lines of `series` against the level (1, 2, ...), with markers. `rank_axis` draws the y axis from the
/// last rank down to 1 at the top (the paper's ranking-trend plot, Fig. 5).
pub fn level_lines(
    title: &str,
    y_desc: &str,
    series: &[LevelSeries],
    rank_axis: bool,
    path: &Path,
) -> Result<(), PlotError> {
    let levels = series.iter().map(|s| s.values.len()).max().unwrap_or(0);
    if series.is_empty() || levels == 0 {
        return Err(PlotError::InvalidInput("no series to draw".into()));
    }
    let finite: Vec<f64> = series
        .iter()
        .flat_map(|s| s.values.iter().flatten().copied())
        .filter(|v| v.is_finite())
        .collect();
    if finite.is_empty() {
        return Err(PlotError::InvalidInput(format!("{title}: no finite values")));
    }
    let (lo, hi) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let pad = ((hi - lo) * 0.08).max(1e-3);
    let y = if rank_axis {
        (series.len() as f64 + 0.5)..0.5
    } else {
        (lo - pad)..(hi + pad)
    };
    render(
        &LinePlot {
            title,
            y_desc,
            series,
            levels,
            y,
        },
        path,
    )
}

struct LinePlot<'a> {
    title: &'a str,
    y_desc: &'a str,
    series: &'a [LevelSeries],
    levels: usize,
    y: std::ops::Range<f64>,
}

impl Picture for LinePlot<'_> {
    fn size(&self) -> (u32, u32) {
        LINE_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, self.title)?;
        let labels: Vec<&str> = self.series.iter().map(|s| s.label.as_str()).collect();
        let looks = style::looks(&labels);
        // The legend gets its own strip: inside the chart it would cover the best ranks' markers.
        let (width, _) = area.dim_in_pixel();
        let legend_px = style::legend_width(&labels).min(width / 3);
        let (area, legend_area) = area.split_horizontally(width - legend_px);
        let entries: Vec<(&str, style::Look)> = labels.iter().copied().zip(looks.iter().copied()).collect();
        style::legend_beside(&legend_area, &entries)?;
        let mut chart = style::panel(
            &area,
            Axes {
                caption: "",
                x: 0.7..self.levels as f64 + 0.3,
                y: self.y.clone(),
                x_desc: "level",
                y_desc: self.y_desc,
                equal_aspect: false,
            },
        )?;
        for (s, &look) in self.series.iter().zip(&looks) {
            let points: Vec<(f64, f64)> = s
                .values
                .iter()
                .enumerate()
                .filter_map(|(i, v)| v.filter(|v| v.is_finite()).map(|v| (i as f64 + 1.0, v)))
                .collect();
            style::series(&mut chart, points.clone(), look, &s.label)?;
            chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, look.colour.filled())))?;
        }
        Ok(())
    }
}

/// One scatter panel: points with labels, and the least-squares line `y = intercept + slope x`.
#[derive(Clone, Debug, PartialEq)]
pub struct ScatterPanel {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub points: Vec<(f64, f64)>,
    /// (intercept, slope) of the fitted line, if any.
    pub fit: Option<(f64, f64)>,
}

/// Scatter panels side by side under one title.
pub fn scatter_fits(title: &str, panels: &[ScatterPanel], path: &Path) -> Result<(), PlotError> {
    if panels.is_empty()
        || panels
            .iter()
            .any(|p| p.points.iter().all(|(x, y)| !(x.is_finite() && y.is_finite())))
    {
        return Err(PlotError::InvalidInput(
            "scatter panels need finite points".into(),
        ));
    }
    render(&ScatterPlot { title, panels }, path)
}

struct ScatterPlot<'a> {
    title: &'a str,
    panels: &'a [ScatterPanel],
}

fn padded(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let pad = ((hi - lo) * 0.1).max(1e-3);
    (lo - pad)..(hi + pad)
}

/// The part of the line y = a + b x inside the plotted box, or None when it misses the box. Drawn
/// as is, an end outside the y range is pinned to the box's edge by the plotting library, which tilts
/// the line (a steep fit looked shallower than the data).
fn line_in_box(
    (a, b): (f64, f64),
    x: &std::ops::Range<f64>,
    y: &std::ops::Range<f64>,
) -> Option<[(f64, f64); 2]> {
    let (mut x0, mut x1) = (x.start, x.end);
    if b != 0.0 {
        let (at_bottom, at_top) = ((y.start - a) / b, (y.end - a) / b);
        x0 = x0.max(at_bottom.min(at_top));
        x1 = x1.min(at_bottom.max(at_top));
    } else if !(y.start..=y.end).contains(&a) {
        return None;
    }
    (x0 < x1 && (a + b * x0).is_finite() && (a + b * x1).is_finite())
        .then_some([(x0, a + b * x0), (x1, a + b * x1)])
}

impl Picture for ScatterPlot<'_> {
    fn size(&self) -> (u32, u32) {
        (SCATTER_PANEL.0 * self.panels.len() as u32, SCATTER_PANEL.1)
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, self.title)?;
        let cells = area.split_evenly((1, self.panels.len()));
        for (panel, cell) in self.panels.iter().zip(&cells) {
            let x = padded(panel.points.iter().map(|p| p.0));
            let y = padded(panel.points.iter().map(|p| p.1));
            let mut chart = style::panel(
                cell,
                Axes {
                    caption: &panel.title,
                    x: x.clone(),
                    y: y.clone(),
                    x_desc: &panel.x_desc,
                    y_desc: &panel.y_desc,
                    equal_aspect: false,
                },
            )?;
            let colour = style::ramp(0, 1);
            chart.draw_series(
                panel
                    .points
                    .iter()
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|&p| Circle::new(p, 5, colour.filled())),
            )?;
            if let Some(segment) = panel.fit.and_then(|fit| line_in_box(fit, &x, &y)) {
                style::line(
                    &mut chart,
                    segment,
                    RGBColor(200, 40, 40).stroke_width(2),
                    Some("least-squares fit".into()),
                )?;
                style::legend(&mut chart)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::line_in_box;

    #[test]
    fn a_fit_line_is_cut_at_the_box_not_pinned_to_it() {
        // y = 0.28 + 1.88 x over x in [0.15, 1.07], y in [0.3, 2.0]: leaves through the top at x = 0.915.
        let [(x0, y0), (x1, y1)] = line_in_box((0.28, 1.88), &(0.15..1.07), &(0.3..2.0)).unwrap();
        assert!((x0 - 0.15).abs() < 1e-12 && (y0 - (0.28 + 1.88 * 0.15)).abs() < 1e-12);
        assert!((x1 - 1.72 / 1.88).abs() < 1e-12 && (y1 - 2.0).abs() < 1e-12);
        // Its slope is the fit's.
        assert!(((y1 - y0) / (x1 - x0) - 1.88).abs() < 1e-9);
        // Falling lines and lines that miss the box.
        let [(_, top), (_, bottom)] = line_in_box((2.0, -1.0), &(0.0..3.0), &(0.5..1.5)).unwrap();
        assert!((top - 1.5).abs() < 1e-12 && (bottom - 0.5).abs() < 1e-12);
        assert!(line_in_box((5.0, 0.0), &(0.0..1.0), &(0.0..1.0)).is_none());
        assert!(line_in_box((5.0, 1.0), &(0.0..1.0), &(0.0..1.0)).is_none());
    }
}
