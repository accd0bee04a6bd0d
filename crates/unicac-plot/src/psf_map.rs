//! The PSF map of a sensor: R, G, B kernels at a grid of sensor positions, each drawn where it sits,
//! so field dependence (growth, elongation towards the corners, lateral colour) shows at a glance.

use crate::render::{render, Picture};
use crate::style;
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One position of the map: sensor coordinates (mm, +y up) and its R, G, B kernels (`size` x `size`,
/// row-major, row 0 at the top).
#[derive(Clone, Debug, PartialEq)]
pub struct PsfMapCell {
    pub x_mm: f64,
    pub y_mm: f64,
    pub size: usize,
    pub rgb: [Vec<f32>; 3],
}

/// Cell side in pixels and the caption strip below it.
const CELL_PX: u32 = 150;
const CAPTION_PX: u32 = 22;
const FOOTER_PX: u32 = 30;
/// Kernels larger than this are averaged in blocks before drawing.
const MAX_SAMPLES: usize = 75;

/// Draws `cells` (given row by row, `columns` per row, top row first) as a grid of colour images; each
/// kernel is normalised to the peak of its three channels (so colour fringes show lateral colour) and
/// drawn on a square-root scale so faint halos stay visible.
pub fn psf_map(
    title: &str,
    cells: &[PsfMapCell],
    columns: usize,
    pitch_um: f64,
    path: &Path,
) -> Result<(), PlotError> {
    if cells.is_empty() || columns == 0 || !cells.len().is_multiple_of(columns) {
        return Err(PlotError::InvalidInput(format!(
            "{} PSFs do not fill rows of {columns}",
            cells.len()
        )));
    }
    if let Some(bad) = cells.iter().find(|c| {
        c.size == 0
            || c.rgb
                .iter()
                .any(|k| k.len() != c.size * c.size || k.iter().any(|v| !v.is_finite()))
    }) {
        return Err(PlotError::InvalidInput(format!(
            "PSF at ({}, {}) mm: kernels of the wrong length or with non-finite samples",
            bad.x_mm, bad.y_mm
        )));
    }
    render(
        &MapPlot {
            title,
            cells,
            columns,
            rows: cells.len() / columns,
            pitch_um,
        },
        path,
    )
}

struct MapPlot<'a> {
    title: &'a str,
    cells: &'a [PsfMapCell],
    columns: usize,
    rows: usize,
    pitch_um: f64,
}

impl Picture for MapPlot<'_> {
    fn size(&self) -> (u32, u32) {
        (
            (self.columns as u32 * CELL_PX).max(600),
            style::TITLE_HEIGHT + self.rows as u32 * (CELL_PX + CAPTION_PX) + FOOTER_PX,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let area = style::figure(&root, self.title)?;
        let (grid, footer) = area.split_vertically(self.rows as u32 * (CELL_PX + CAPTION_PX));
        let size = self.cells[0].size;
        let note = format!(
            "each PSF: {size} x {size} px ({} µm), normalised to its peak, square-root scale",
            style::trimmed(size as f64 * self.pitch_um, 4)
        );
        let (width, _) = footer.dim_in_pixel();
        footer.draw_text(
            &note,
            &style::centred(14.0),
            (width as i32 / 2, FOOTER_PX as i32 / 2),
        )?;
        for (cell, area) in self
            .cells
            .iter()
            .zip(grid.split_evenly((self.rows, self.columns)))
        {
            draw_cell(&area, cell)?;
        }
        Ok(())
    }
}

fn draw_cell<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, cell: &PsfMapCell) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (width, _) = area.dim_in_pixel();
    let block = cell.size.div_ceil(MAX_SAMPLES);
    let samples = cell.size.div_ceil(block);
    let averaged: Vec<Vec<f64>> = cell
        .rgb
        .iter()
        .map(|k| block_average(k, cell.size, block))
        .collect();
    let peak = averaged.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
    let scale = if peak > 0.0 { 1.0 / peak } else { 1.0 };
    let side = (CELL_PX - 10) as f64;
    let step = side / samples as f64;
    let left = (width as f64 - side) / 2.0;
    for row in 0..samples {
        for column in 0..samples {
            let channel = |c: usize| {
                ((averaged[c][row * samples + column] * scale).max(0.0).sqrt() * 255.0).round() as u8
            };
            let (x0, y0) = (left + column as f64 * step, 5.0 + row as f64 * step);
            area.draw(&Rectangle::new(
                [
                    (x0 as i32, y0 as i32),
                    ((x0 + step).ceil() as i32, (y0 + step).ceil() as i32),
                ],
                RGBColor(channel(0), channel(1), channel(2)).filled(),
            ))?;
        }
    }
    let caption = format!(
        "({}, {}) mm",
        style::trimmed(cell.x_mm, 3),
        style::trimmed(cell.y_mm, 3)
    );
    area.draw_text(
        &caption,
        &style::centred(13.0),
        (width as i32 / 2, (CELL_PX + CAPTION_PX / 2) as i32),
    )?;
    Ok(())
}

/// Means over `block` x `block` squares (the last ones partial).
fn block_average(data: &[f32], size: usize, block: usize) -> Vec<f64> {
    let samples = size.div_ceil(block);
    let mut out = vec![0.0; samples * samples];
    let mut counts = vec![0usize; samples * samples];
    for (i, v) in data.iter().enumerate() {
        let index = (i / size / block) * samples + (i % size) / block;
        out[index] += *v as f64;
        counts[index] += 1;
    }
    out.iter().zip(&counts).map(|(s, n)| s / *n as f64).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_averages_keep_the_mean() {
        let data: Vec<f32> = (0..25).map(|i| i as f32).collect();
        let averaged = block_average(&data, 5, 2);
        assert_eq!(averaged.len(), 9);
        assert_eq!(averaged[0], (0.0 + 1.0 + 5.0 + 6.0) / 4.0);
        assert_eq!(averaged[8], 24.0);
    }
}
