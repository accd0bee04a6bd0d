//! Point spread function kernels: each as an image, normalised to its peak, and their central rows.

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// One kernel image with its caption, scale bar and colour key.
const CELL_SIZE: (u32, u32) = (290, 320);
const CAPTION_HEIGHT: u32 = 30;
/// Below the image: scale bar and colour key.
const KEY_HEIGHT: u32 = 44;
const CROSS_SECTION_HEIGHT: u32 = 340;
const MIN_WIDTH: u32 = 820;
/// At most this many coloured cells along a side of an image; larger kernels are averaged in blocks.
const MAX_CELLS: usize = 160;
/// Up to this many kernels stand in one row; more make a square-ish grid.
const MAX_ONE_ROW: usize = 4;

/// One square kernel: `size` × `size` samples `pitch_um` apart, row-major with row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct PsfPanel {
    pub label: String,
    pub size: usize,
    pub pitch_um: f64,
    pub data: Vec<f32>,
}

/// Draws `panels` as images side by side (a grid when there are more than four), each normalised to
/// its own peak in a perceptual colour map (viridis) with a scale bar in µm, and below them one chart
/// of each kernel's central row against offset in µm, normalised to the same peak (labels naming a
/// colour channel, "R", "G", "B", draw in that colour).
pub fn psf_panels(title: &str, panels: &[PsfPanel], path: &Path) -> Result<(), PlotError> {
    if panels.is_empty() {
        return Err(PlotError::InvalidInput("no PSF kernels to draw".into()));
    }
    for panel in panels {
        let bad = if panel.size == 0 || panel.data.len() != panel.size * panel.size {
            Some(format!(
                "{} samples for a {}×{} kernel",
                panel.data.len(),
                panel.size,
                panel.size
            ))
        } else if !(panel.pitch_um.is_finite() && panel.pitch_um > 0.0) {
            Some(format!("pitch {} µm", panel.pitch_um))
        } else if panel.data.iter().any(|v| !v.is_finite()) {
            Some("non-finite samples".into())
        } else {
            None
        };
        if let Some(bad) = bad {
            return Err(PlotError::InvalidInput(format!(
                "PSF kernel '{}': {bad}",
                panel.label
            )));
        }
    }
    let columns = if panels.len() <= MAX_ONE_ROW {
        panels.len()
    } else {
        (panels.len() as f64).sqrt().ceil() as usize
    };
    render(
        &PsfPlot {
            title,
            panels,
            columns,
            rows: panels.len().div_ceil(columns),
        },
        path,
    )
}

struct PsfPlot<'a> {
    title: &'a str,
    panels: &'a [PsfPanel],
    columns: usize,
    rows: usize,
}

impl Picture for PsfPlot<'_> {
    fn size(&self) -> (u32, u32) {
        (
            (self.columns as u32 * CELL_SIZE.0).max(MIN_WIDTH),
            style::TITLE_HEIGHT + self.rows as u32 * CELL_SIZE.1 + CROSS_SECTION_HEIGHT,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, self.title)?;
        let (images, cross_section) = area.split_vertically(self.rows as u32 * CELL_SIZE.1);
        // The grid of cells, centred when the picture is wider than the cells.
        let (width, _) = images.dim_in_pixel();
        let grid_width = self.columns as u32 * CELL_SIZE.0;
        let left_margin = (width.saturating_sub(grid_width) / 2) as i32;
        let images = images.margin(0, 0, left_margin, width as i32 - grid_width as i32 - left_margin);
        let cells = images.split_evenly((self.rows, self.columns));
        for (panel, cell) in self.panels.iter().zip(&cells) {
            draw_kernel(cell, panel)?;
        }
        self.draw_cross_section(&cross_section)
    }
}

/// The largest sample, or 1 when none is positive.
fn peak(panel: &PsfPanel) -> f64 {
    let peak = panel.data.iter().fold(0.0f32, |m, v| m.max(*v)) as f64;
    if peak > 0.0 {
        peak
    } else {
        1.0
    }
}

/// One kernel in `cell`: caption, image, scale bar and colour key.
fn draw_kernel<DB: DrawingBackend>(cell: &DrawingArea<DB, Shift>, panel: &PsfPanel) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (width, height) = cell.dim_in_pixel();
    let caption = format!(
        "{}   ({n}×{n}, {} µm pitch)",
        panel.label,
        style::trimmed(panel.pitch_um, 3),
        n = panel.size
    );
    cell.draw_text(
        &caption,
        &style::centred(15.0),
        (width as i32 / 2, CAPTION_HEIGHT as i32 / 2 + 2),
    )?;
    let side = width
        .saturating_sub(40)
        .min(height.saturating_sub(CAPTION_HEIGHT + KEY_HEIGHT)) as i32;
    let (left, top) = ((width as i32 - side) / 2, CAPTION_HEIGHT as i32);

    // Image cells: block averages of the kernel, normalised to its peak; cell edges rounded to whole
    // pixels so neighbours meet without gaps.
    let n = panel.size;
    let cells = n.min(MAX_CELLS).min(side.max(1) as usize);
    let peak = peak(panel);
    let edge = |k: usize| (k as f64 * side as f64 / cells as f64).round() as i32;
    let span = |k: usize| k * n / cells..((k + 1) * n / cells).max(k * n / cells + 1);
    for row in 0..cells {
        for column in 0..cells {
            let (rows, columns) = (span(row), span(column));
            let count = (rows.len() * columns.len()) as f64;
            let sum: f64 = rows
                .flat_map(|r| columns.clone().map(move |c| panel.data[r * n + c] as f64))
                .sum();
            let colour = style::colour_map(sum / count / peak);
            cell.draw(&Rectangle::new(
                [
                    (left + edge(column), top + edge(row)),
                    (left + edge(column + 1), top + edge(row + 1)),
                ],
                colour.filled(),
            ))?;
        }
    }
    cell.draw(&Rectangle::new(
        [(left - 1, top - 1), (left + side, top + side)],
        BLACK.mix(0.5),
    ))?;

    // Scale bar: a round length near a fifth of the kernel's width.
    let key_y = top + side + 18;
    let extent_um = n as f64 * panel.pitch_um;
    let bar_um = style::nice_ceiling(extent_um / 5.0);
    let bar_px = (bar_um / extent_um * side as f64).round() as i32;
    let bar = BLACK.stroke_width(3);
    cell.draw(&PathElement::new(
        vec![(left, key_y), (left + bar_px, key_y)],
        bar,
    ))?;
    for x in [left, left + bar_px] {
        cell.draw(&PathElement::new(
            vec![(x, key_y - 5), (x, key_y + 5)],
            BLACK.stroke_width(1),
        ))?;
    }
    let label = style::font(13.0).pos(Pos::new(HPos::Left, VPos::Center));
    cell.draw_text(
        &format!("{} µm", style::trimmed(bar_um, 3)),
        &label,
        (left + bar_px + 6, key_y),
    )?;

    // Colour key: 0 to the peak, at the right under the image.
    let (key_width, steps) = (80, 40);
    let key_left = left + side - key_width - 12;
    for k in 0..steps {
        let x = |k: i32| key_left + k * key_width / steps;
        cell.draw(&Rectangle::new(
            [(x(k), key_y - 5), (x(k + 1), key_y + 5)],
            style::colour_map((k as f64 + 0.5) / steps as f64).filled(),
        ))?;
    }
    let small = style::font(12.0);
    cell.draw_text(
        "0",
        &small.pos(Pos::new(HPos::Right, VPos::Center)),
        (key_left - 4, key_y),
    )?;
    cell.draw_text(
        "1",
        &small.pos(Pos::new(HPos::Left, VPos::Center)),
        (key_left + key_width + 4, key_y),
    )?;
    Ok(())
}

impl PsfPlot<'_> {
    /// The central row of every kernel against offset from its centre, normalised to its peak.
    fn draw_cross_section<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let rows: Vec<Vec<(f64, f64)>> = self
            .panels
            .iter()
            .map(|p| {
                let (n, peak) = (p.size, peak(p));
                let centre = (n as f64 - 1.0) / 2.0;
                (0..n)
                    .map(|c| {
                        let offset = (c as f64 - centre) * p.pitch_um;
                        (offset, p.data[(n / 2) * n + c] as f64 / peak)
                    })
                    .collect()
            })
            .collect();
        let half_width = self
            .panels
            .iter()
            .map(|p| (p.size as f64 - 1.0) / 2.0 * p.pitch_um)
            .fold(0.0, f64::max);
        let half_width = if half_width > 0.0 { half_width } else { 1.0 };
        let lowest = rows.iter().flatten().fold(0.0, |m: f64, (_, v)| m.min(*v));
        let mut chart = style::panel(
            area,
            Axes {
                caption: "Central row of each kernel, normalised to its peak",
                x: -half_width..half_width,
                y: lowest..1.05,
                x_desc: "offset (µm)",
                y_desc: "relative intensity",
                equal_aspect: false,
            },
        )?;
        let labels: Vec<&str> = self.panels.iter().map(|p| p.label.as_str()).collect();
        for ((row, look), label) in rows.into_iter().zip(style::looks(&labels)).zip(&labels) {
            style::series(&mut chart, row, look, label)?;
        }
        style::legend_at(&mut chart, SeriesLabelPosition::UpperRight)
    }
}
