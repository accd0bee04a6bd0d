//! Lens comparison bars: Optical Degradation Evaluator (ODE) score and RMS spot radius, one row per lens.

use crate::render::{render, Picture};
use crate::style::{self, Axes};
use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Width of each bar panel's plot and axes, without the names.
const PANEL_WIDTH: u32 = 440;
const ROW_HEIGHT: u32 = 26;
/// Caption, x axis and margins of a panel.
const PANEL_OVERHEAD: u32 = 100;
const MIN_PLOT_HEIGHT: u32 = 170;
/// Longer names are cut to this many characters, from the left: names that share a start (paths,
/// design ids) differ at their end.
const MAX_NAME_CHARS: usize = 40;
/// Bars at least this fraction of their axis carry their value inside their end.
const INSIDE: f64 = 0.85;

/// Draws one row per lens `names[i]` (first at the top) with two horizontal bar panels side by side:
/// `ode[i]` on 0..1.01 and `rms_radius_um[i]` on 0 to a round number above the largest, each bar's value
/// printed at its end (a non-finite value draws no bar and prints "n/a"). The picture grows with the
/// number of lenses.
pub fn ode_bars(names: &[String], ode: &[f64], rms_radius_um: &[f64], path: &Path) -> Result<(), PlotError> {
    if names.is_empty() {
        return Err(PlotError::InvalidInput("no lenses to compare".into()));
    }
    if ode.len() != names.len() || rms_radius_um.len() != names.len() {
        return Err(PlotError::InvalidInput(format!(
            "{} lens names, {} ODE values and {} RMS radii",
            names.len(),
            ode.len(),
            rms_radius_um.len()
        )));
    }
    let names: Vec<String> = names
        .iter()
        .map(|n| {
            if n.chars().count() > MAX_NAME_CHARS {
                let skip = n.chars().count() - (MAX_NAME_CHARS - 1);
                std::iter::once('…').chain(n.chars().skip(skip)).collect()
            } else {
                n.clone()
            }
        })
        .collect();
    let largest_rms = rms_radius_um
        .iter()
        .filter(|r| r.is_finite())
        .fold(0.0, |m: f64, r| m.max(*r));
    render(
        &OdeBars {
            label_width: style::row_label_width(&names),
            names,
            ode,
            rms_radius_um,
            rms_max: style::nice_ceiling(1.05 * largest_rms),
        },
        path,
    )
}

struct OdeBars<'a> {
    names: Vec<String>,
    label_width: u32,
    ode: &'a [f64],
    rms_radius_um: &'a [f64],
    rms_max: f64,
}

/// One bar panel: what it shows and how.
struct Bars<'a> {
    caption: &'a str,
    x_desc: &'a str,
    values: &'a [f64],
    max: f64,
    colour: RGBColor,
    format: fn(f64) -> String,
}

impl Picture for OdeBars<'_> {
    fn size(&self) -> (u32, u32) {
        let rows = self.names.len() as u32;
        (
            self.label_width + 2 * PANEL_WIDTH,
            style::TITLE_HEIGHT + PANEL_OVERHEAD + (rows * ROW_HEIGHT).max(MIN_PLOT_HEIGHT),
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let area = style::figure(&root, "Lens comparison: ODE and RMS spot radius")?;
        let (left, right) = area.split_horizontally(self.label_width + PANEL_WIDTH);
        let ode = Bars {
            caption: "Optical Degradation Evaluator (ODE)",
            x_desc: "ODE",
            values: self.ode,
            max: 1.01,
            colour: style::ramp(0, 2),
            format: |v| format!("{v:.3}"),
        };
        let rms = Bars {
            caption: "RMS spot radius",
            x_desc: "RMS spot radius (µm)",
            values: self.rms_radius_um,
            max: self.rms_max,
            colour: style::ramp(1, 2),
            format: |v| style::significant(v, 3),
        };
        self.draw_panel(&left, &ode, &self.names)?;
        self.draw_panel(&right, &rms, &[])
    }
}

impl OdeBars<'_> {
    /// One panel of bars; rows are named when `names` is not empty.
    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        bars: &Bars,
        names: &[String],
    ) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let rows = self.names.len();
        let mut chart = style::row_panel(
            area,
            Axes {
                caption: bars.caption,
                x: 0.0..bars.max,
                y: 0.0..1.0,
                x_desc: bars.x_desc,
                y_desc: "",
                equal_aspect: false,
            },
            rows,
            names,
            self.label_width,
        )?;
        // Bars span 68% of a row, but no thicker than in rows 1.5 times the usual height when the
        // minimum plot height spreads few rows out.
        let plot_height = (rows as u32 * ROW_HEIGHT).max(MIN_PLOT_HEIGHT) as f64;
        let half = 0.34 * (1.5 * (rows as u32 * ROW_HEIGHT) as f64 / plot_height).min(1.0);
        let finite = || {
            bars.values
                .iter()
                .enumerate()
                .filter(|(_, v)| v.is_finite())
                .map(|(i, v)| (style::row_y(i, rows), *v))
        };
        chart.draw_series(finite().map(|(y, v)| {
            Rectangle::new(
                [(0.0, y - half), (v.clamp(0.0, bars.max), y + half)],
                bars.colour.mix(0.8).filled(),
            )
        }))?;
        // Values after the bar's end, or inside it in white when the bar nearly fills the axis.
        chart.draw_series(bars.values.iter().enumerate().map(|(i, v)| {
            let y = style::row_y(i, rows);
            let (at, text, inside) = if v.is_finite() {
                let end = v.clamp(0.0, bars.max);
                (end, (bars.format)(*v), end >= INSIDE * bars.max)
            } else {
                (0.0, "n/a".to_string(), false)
            };
            let (shift, h, colour) = if inside {
                (-5, HPos::Right, &WHITE)
            } else {
                (5, HPos::Left, &BLACK)
            };
            let style = style::font(12.0).color(colour).pos(Pos::new(h, VPos::Center));
            EmptyElement::at((at, y)) + Text::new(text, (shift, 0), style)
        }))?;
        Ok(())
    }
}
