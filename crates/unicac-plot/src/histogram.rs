//! Histograms per level: one panel per metric (e.g. ODE, OIQ, U_s, U_c), the values of each level
//! stacked in one colour per level (blue = level 1 .. red = last), like the paper's benchmark figure.

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One panel: a metric's values per level (`values_by_level[k]` = level k + 1).
#[derive(Debug, Clone)]
pub struct LevelHistogram {
    pub metric: String,
    pub values_by_level: Vec<Vec<f64>>,
}

const PANEL_WIDTH: u32 = 460;
const PANEL_HEIGHT: u32 = 320;
const LEGEND_HEIGHT: u32 = 30;
/// Bins per panel.
pub const BINS: usize = 16;

/// Draws the panels two per row, with a legend naming the levels (`level_names[k]`).
pub fn level_histograms(
    title: &str,
    level_names: &[String],
    panels: &[LevelHistogram],
    path: &Path,
) -> Result<(), PlotError> {
    if panels.is_empty() || level_names.is_empty() {
        return Err(PlotError::InvalidInput("no levels or metrics to draw".into()));
    }
    for panel in panels {
        if panel.values_by_level.len() != level_names.len() {
            return Err(PlotError::InvalidInput(format!(
                "{}: {} levels of values for {} level names",
                panel.metric,
                panel.values_by_level.len(),
                level_names.len()
            )));
        }
    }
    render(
        &Histograms {
            title,
            level_names,
            panels,
        },
        path,
    )
}

struct Histograms<'a> {
    title: &'a str,
    level_names: &'a [String],
    panels: &'a [LevelHistogram],
}

impl Picture for Histograms<'_> {
    fn size(&self) -> (u32, u32) {
        let rows = self.panels.len().div_ceil(2) as u32;
        (
            2 * PANEL_WIDTH,
            style::TITLE_HEIGHT + LEGEND_HEIGHT + rows * PANEL_HEIGHT,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, self.title)?;
        let (legend, body) = area.split_vertically(LEGEND_HEIGHT);
        let levels = self.level_names.len();
        let step = 2 * PANEL_WIDTH as i32 / (levels as i32 + 1);
        for (k, name) in self.level_names.iter().enumerate() {
            let x = step / 2 + k as i32 * step;
            legend.draw(&Rectangle::new(
                [(x, 8), (x + 14, 22)],
                style::ramp(k, levels).filled(),
            ))?;
            legend.draw_text(name, &style::font(14.0), (x + 20, 7))?;
        }
        let rows = self.panels.len().div_ceil(2);
        let cells = body.split_evenly((rows, 2));
        for (panel, cell) in self.panels.iter().zip(cells.iter()) {
            draw_panel(cell, panel, levels)?;
        }
        Ok(())
    }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &LevelHistogram,
    levels: usize,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let finite: Vec<f64> = panel
        .values_by_level
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let (lo, hi) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let (lo, hi) = if finite.is_empty() {
        (0.0, 1.0)
    } else if hi - lo < 1e-9 {
        (lo - 0.05, hi + 0.05)
    } else {
        let pad = 0.02 * (hi - lo);
        (lo - pad, hi + pad)
    };
    let width = (hi - lo) / BINS as f64;
    let bin = |v: f64| (((v - lo) / width) as usize).min(BINS - 1);
    let mut counts = vec![vec![0usize; BINS]; levels];
    for (k, values) in panel.values_by_level.iter().enumerate() {
        for &v in values.iter().filter(|v| v.is_finite()) {
            counts[k][bin(v)] += 1;
        }
    }
    let tallest = (0..BINS)
        .map(|b| (0..levels).map(|k| counts[k][b]).sum::<usize>())
        .max()
        .unwrap_or(0);
    let caption = format!("{} distribution", panel.metric);
    let mut chart = style::panel(
        area,
        Axes {
            caption: &caption,
            x: lo..hi,
            y: 0.0..(tallest.max(1) as f64 * 1.1),
            x_desc: &panel.metric,
            y_desc: "lenses",
            equal_aspect: false,
        },
    )?;
    for b in 0..BINS {
        let x0 = lo + b as f64 * width;
        let mut base = 0.0;
        for (k, level_counts) in counts.iter().enumerate() {
            let n = level_counts[b] as f64;
            if n > 0.0 {
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(x0 + 0.04 * width, base), (x0 + 0.96 * width, base + n)],
                    style::ramp(k, levels).mix(0.85).filled(),
                )))?;
                base += n;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_png_and_refuses_mismatched_levels() {
        let dir = std::env::temp_dir().join(format!("unicac-hist-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let panels = vec![
            LevelHistogram {
                metric: "ODE".into(),
                values_by_level: vec![vec![0.9, 0.85], vec![0.5], vec![0.1, 0.2, 0.15]],
            },
            LevelHistogram {
                metric: "U_s".into(),
                values_by_level: vec![vec![0.7; 2], vec![0.7], vec![0.3; 3]],
            },
        ];
        let names: Vec<String> = (1..=3).map(|k| format!("level {k}")).collect();
        let path = dir.join("levels.png");
        level_histograms("Lens library", &names, &panels, &path).unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 1000);
        assert!(level_histograms("x", &names[..2], &panels, &path).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
