//! The shared look of every picture: fonts, the colour ramp, number formats, axis ranges, and the one
//! kind of chart panel all pictures are built from.

use crate::PlotError;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::ops::Range;

pub(crate) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

const MARGIN: u32 = 10;
/// Wider on the right, where half of the last x tick label sticks out of the plot.
const MARGIN_RIGHT: u32 = 28;
const X_LABEL_AREA: u32 = 46;
const Y_LABEL_AREA: u32 = 62;
/// Height taken by a figure title drawn with `figure`.
pub(crate) const TITLE_HEIGHT: u32 = 40;

pub(crate) fn font(size: f64) -> TextStyle<'static> {
    TextStyle::from(("sans-serif", size).into_font())
}

/// Text centred on its anchor point.
pub(crate) fn centred(size: f64) -> TextStyle<'static> {
    font(size).pos(Pos::new(HPos::Center, VPos::Center))
}

/// Draws the figure title across the top of `root` and returns the area below it.
pub(crate) fn figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<DrawingArea<DB, Shift>, PlotError>
where
    DB::ErrorType: 'static,
{
    let (top, rest) = root.split_vertically(TITLE_HEIGHT);
    let (width, height) = top.dim_in_pixel();
    top.draw_text(title, &centred(21.0), (width as i32 / 2, height as i32 / 2))?;
    Ok(rest)
}

/// Colour `rank` of `count` series, from blue (first) through green to red (last).
pub(crate) fn ramp(rank: usize, count: usize) -> RGBColor {
    let t = if count > 1 {
        rank as f64 / (count - 1) as f64
    } else {
        0.0
    };
    let (r, g, b) = HSLColor((1.0 - t) * 240.0 / 360.0, 0.9, 0.38).rgb();
    RGBColor(r, g, b)
}

/// The values in order of first appearance, each once.
pub(crate) fn distinct(values: impl IntoIterator<Item = f64>) -> Vec<f64> {
    let mut seen: Vec<f64> = Vec::new();
    for v in values {
        if !seen.contains(&v) {
            seen.push(v);
        }
    }
    seen
}

/// The values sorted ascending, each once.
pub(crate) fn sorted_distinct(values: impl IntoIterator<Item = f64>) -> Vec<f64> {
    let mut values = distinct(values);
    values.sort_by(f64::total_cmp);
    values
}

/// Index of `value` in `values` (0 when absent, which callers never ask for).
pub(crate) fn rank(values: &[f64], value: f64) -> usize {
    values.iter().position(|v| *v == value).unwrap_or(0)
}

/// `x` rounded up to a round number (1, 1.5, 2, 2.5, 3, 4, 5, 6 or 8 times a power of ten; 1 for zero or
/// non-finite input).
pub(crate) fn nice_ceiling(x: f64) -> f64 {
    if !(x > 0.0 && x.is_finite()) {
        return 1.0;
    }
    let power = 10f64.powf(x.log10().floor());
    [1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0]
        .iter()
        .map(|m| m * power)
        .find(|v| *v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * power)
}

/// `x` with `digits` significant digits, never in exponent form.
pub(crate) fn significant(x: f64, digits: i32) -> String {
    let decimals = if x == 0.0 {
        0
    } else {
        (digits - 1 - x.abs().log10().floor() as i32).max(0)
    };
    format!("{x:.*}", decimals as usize)
}

/// `x` with at most `decimals` decimals, trailing zeros dropped ("14", "2.85").
fn trimmed(x: f64, decimals: usize) -> String {
    let text = format!("{x:.decimals$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        &text
    };
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

fn tick_label(value: &f64) -> String {
    trimmed(*value, 6)
}

pub(crate) fn field_label(field_deg: f64) -> String {
    format!("{}°", trimmed(field_deg, 2))
}

pub(crate) fn wavelength_label(wavelength_um: f64) -> String {
    format!("{} µm", trimmed(wavelength_um, 4))
}

/// What a panel shows: its caption, data ranges and axis descriptions.
pub(crate) struct Axes<'t> {
    pub caption: &'t str,
    pub x: Range<f64>,
    pub y: Range<f64>,
    pub x_desc: &'t str,
    pub y_desc: &'t str,
    /// Widen one range so a unit is as long along x as along y.
    pub equal_aspect: bool,
}

/// A captioned chart with a light grid and labelled axes filling `area`.
pub(crate) fn panel<'a, DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    axes: Axes,
) -> Result<Chart<'a, DB>, PlotError>
where
    DB::ErrorType: 'static,
{
    let area = area.titled(axes.caption, font(16.0))?;
    let (x, y) = if axes.equal_aspect {
        let (width, height) = area.dim_in_pixel();
        let plot_width = width.saturating_sub(Y_LABEL_AREA + MARGIN + MARGIN_RIGHT).max(1);
        let plot_height = height.saturating_sub(X_LABEL_AREA + 2 * MARGIN).max(1);
        equal_aspect(axes.x, axes.y, (plot_width, plot_height))
    } else {
        (axes.x, axes.y)
    };
    let mut chart = ChartBuilder::on(&area)
        .margin(MARGIN)
        .margin_right(MARGIN_RIGHT)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc(axes.x_desc)
        .y_desc(axes.y_desc)
        .label_style(font(13.0))
        .axis_desc_style(font(14.0))
        .bold_line_style(BLACK.mix(0.12))
        .light_line_style(BLACK.mix(0.04))
        .x_labels(7)
        .y_labels(7)
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .draw()?;
    Ok(chart)
}

/// Ranges widened about their centres so that both axes have the same units per pixel.
fn equal_aspect(x: Range<f64>, y: Range<f64>, (width, height): (u32, u32)) -> (Range<f64>, Range<f64>) {
    let per_pixel = ((x.end - x.start) / width as f64).max((y.end - y.start) / height as f64);
    let widen = |r: Range<f64>, pixels: u32| {
        let (mid, half) = ((r.start + r.end) / 2.0, per_pixel * pixels as f64 / 2.0);
        mid - half..mid + half
    };
    (widen(x, width), widen(y, height))
}

/// Draws a polyline, entered in the legend under `label` if given.
pub(crate) fn line<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    points: impl IntoIterator<Item = (f64, f64)>,
    style: ShapeStyle,
    label: Option<String>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let series = chart.draw_series(LineSeries::new(points, style))?;
    if let Some(label) = label {
        series
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style));
    }
    Ok(())
}

/// The legend of the labelled series, in the upper left corner.
pub(crate) fn legend<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(font(13.0))
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ceiling_rounds_up_to_round_numbers() {
        assert_eq!(nice_ceiling(3.2), 4.0);
        assert_eq!(nice_ceiling(20.0), 20.0);
        assert_eq!(nice_ceiling(21.0), 25.0);
        assert_eq!(nice_ceiling(7150.0), 8000.0);
        assert!((nice_ceiling(0.013) - 0.015).abs() < 1e-15);
        assert_eq!(nice_ceiling(0.0), 1.0);
    }

    #[test]
    fn labels_drop_trailing_zeros() {
        assert_eq!(field_label(14.0), "14°");
        assert_eq!(field_label(-0.0001), "0°");
        assert_eq!(wavelength_label(0.5875618), "0.5876 µm");
        assert_eq!(significant(3.21456, 3), "3.21");
        assert_eq!(significant(123.4, 3), "123");
    }

    #[test]
    fn equal_aspect_gives_both_axes_one_scale() {
        let (x, y) = equal_aspect(0.0..100.0, -10.0..10.0, (1000, 400));
        assert_eq!(x, 0.0..100.0);
        assert!(((y.end - y.start) - 40.0).abs() < 1e-12 && (y.start + y.end).abs() < 1e-12);
    }
}
