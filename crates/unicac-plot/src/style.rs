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
pub(crate) fn trimmed(x: f64, decimals: usize) -> String {
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
    build_panel(area, axes, YTicks::Numbers)
}

/// Like [`panel`], for horizontal bars: the y axis holds `rows` rows, row `i` centred at
/// [`row_y`]`(i, rows)` (the first at the top) and named by `names[i]` in a label area `label_width`
/// pixels wide (no names, and a narrow label area, when `names` is empty). `axes.y` is ignored.
pub(crate) fn row_panel<'a, DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    axes: Axes,
    rows: usize,
    names: &[String],
    label_width: u32,
) -> Result<Chart<'a, DB>, PlotError>
where
    DB::ErrorType: 'static,
{
    let axes = Axes {
        y: -0.5..rows as f64 - 0.5,
        ..axes
    };
    build_panel(
        area,
        axes,
        YTicks::Rows {
            rows,
            names,
            label_width,
        },
    )
}

/// The y coordinate of the centre of row `i` of `rows` in a [`row_panel`].
pub(crate) fn row_y(i: usize, rows: usize) -> f64 {
    (rows - 1 - i) as f64
}

/// Width in pixels of the label area that fits every name at the tick label size.
pub(crate) fn row_label_width(names: &[String]) -> u32 {
    names.iter().map(|n| text_width(n, 13.0)).max().unwrap_or(0) + 16
}

/// Width in pixels of `text` in the sans-serif font (estimated when the font cannot be measured).
pub(crate) fn text_width(text: &str, size: f64) -> u32 {
    font(size)
        .font
        .box_size(text)
        .map(|(w, _)| w)
        .unwrap_or((0.6 * size * text.chars().count() as f64).ceil() as u32)
}

enum YTicks<'n> {
    Numbers,
    Rows {
        rows: usize,
        names: &'n [String],
        label_width: u32,
    },
}

fn build_panel<'a, DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    axes: Axes,
    y_ticks: YTicks,
) -> Result<Chart<'a, DB>, PlotError>
where
    DB::ErrorType: 'static,
{
    let area = area.titled(axes.caption, font(16.0))?;
    let y_label_area = match y_ticks {
        YTicks::Numbers => Y_LABEL_AREA,
        YTicks::Rows { names: [], .. } => MARGIN,
        YTicks::Rows { label_width, .. } => label_width,
    };
    let (x, y) = if axes.equal_aspect {
        let (width, height) = area.dim_in_pixel();
        let plot_width = width.saturating_sub(y_label_area + MARGIN + MARGIN_RIGHT).max(1);
        let plot_height = height.saturating_sub(X_LABEL_AREA + 2 * MARGIN).max(1);
        equal_aspect(axes.x, axes.y, (plot_width, plot_height))
    } else {
        (axes.x, axes.y)
    };
    let mut chart = ChartBuilder::on(&area)
        .margin(MARGIN)
        .margin_right(MARGIN_RIGHT)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x, y)?;
    let row_name = |value: &f64| match y_ticks {
        YTicks::Rows { rows, names, .. } => {
            let row = value.round();
            let i = rows as f64 - 1.0 - row;
            if (value - row).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                names[i as usize].clone()
            } else {
                String::new()
            }
        }
        YTicks::Numbers => tick_label(value),
    };
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(axes.x_desc)
        .y_desc(axes.y_desc)
        .label_style(font(13.0))
        .axis_desc_style(font(14.0))
        .bold_line_style(BLACK.mix(0.12))
        .light_line_style(BLACK.mix(0.04))
        .x_labels(7)
        .x_label_formatter(&tick_label)
        .y_label_formatter(&row_name);
    match y_ticks {
        YTicks::Numbers => mesh.y_labels(7),
        // One key point per row: plotters' f64 key points over -0.5..rows-0.5 with at most `rows` points
        // are the integers.
        YTicks::Rows { rows, names, .. } => mesh
            .y_labels(if names.is_empty() { 0 } else { rows })
            .disable_y_mesh(),
    };
    mesh.draw()?;
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

/// Draws a dashed polyline, entered in the legend under `label` if given.
pub(crate) fn dashed_line<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    points: impl IntoIterator<Item = (f64, f64)>,
    (dash, gap): (i32, i32),
    style: ShapeStyle,
    label: Option<String>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let points: Vec<(f64, f64)> = points.into_iter().collect();
    let series = chart.draw_series(DashedLineSeries::new(points, dash, gap, style))?;
    if let Some(label) = label {
        series.label(label).legend(move |(x, y)| {
            EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (9, 0)], style)
                + PathElement::new(vec![(15, 0), (24, 0)], style)
        });
    }
    Ok(())
}

/// How one of several labelled data series is drawn: its colour, and whether it is dashed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Look {
    pub colour: RGBColor,
    pub dashed: bool,
}

pub(crate) const CHANNEL_RED: RGBColor = RGBColor(205, 35, 35);
pub(crate) const CHANNEL_GREEN: RGBColor = RGBColor(25, 145, 45);
pub(crate) const CHANNEL_BLUE: RGBColor = RGBColor(35, 70, 210);

/// The colour channel a label names by its last word ("R", "G", "B", or "red", "green", "blue").
fn channel(label: &str) -> Option<RGBColor> {
    match label.split_whitespace().last()?.to_ascii_lowercase().as_str() {
        "r" | "red" => Some(CHANNEL_RED),
        "g" | "green" => Some(CHANNEL_GREEN),
        "b" | "blue" => Some(CHANNEL_BLUE),
        _ => None,
    }
}

/// Looks for series labelled `labels`, in order: red, green and blue when every label names a colour
/// channel ("R", "exact G", ...), otherwise the ramp. A series whose colour an earlier one already has
/// is dashed.
pub(crate) fn looks(labels: &[&str]) -> Vec<Look> {
    let channels: Option<Vec<RGBColor>> = labels.iter().map(|l| channel(l)).collect();
    let colours = channels.unwrap_or_else(|| (0..labels.len()).map(|i| ramp(i, labels.len())).collect());
    colours
        .iter()
        .enumerate()
        .map(|(i, c)| Look {
            colour: *c,
            dashed: colours[..i].contains(c),
        })
        .collect()
}

/// Draws one series in its look, 2 px wide, entered in the legend under `label`.
pub(crate) fn series<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    points: impl IntoIterator<Item = (f64, f64)>,
    look: Look,
    label: &str,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let style = look.colour.stroke_width(2);
    if look.dashed {
        dashed_line(chart, points, (9, 6), style, Some(label.into()))
    } else {
        line(chart, points, style, Some(label.into()))
    }
}

/// The legend of the labelled series, in the upper left corner.
pub(crate) fn legend<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    legend_at(chart, SeriesLabelPosition::UpperLeft)
}

/// The legend of the labelled series at `position`.
pub(crate) fn legend_at<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    position: SeriesLabelPosition,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(font(13.0))
        .draw()?;
    Ok(())
}

/// A legend in its own area beside a chart (never over its markers): a short line, a marker and the
/// label per series, top down. Returns the width it needs for `labels`.
pub(crate) fn legend_width(labels: &[&str]) -> u32 {
    labels.iter().map(|l| text_width(l, 13.0)).max().unwrap_or(0) + 60
}

/// Draws the legend of [`legend_width`] into `area` (the strip to the right of a chart).
pub(crate) fn legend_beside<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(&str, Look)],
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    const ROW: i32 = 22;
    const TOP: i32 = 40;
    for (i, (label, look)) in entries.iter().enumerate() {
        let y = TOP + ROW * i as i32;
        let colour = look.colour;
        if look.dashed {
            area.draw(&PathElement::new(vec![(8, y), (16, y)], colour.stroke_width(2)))?;
            area.draw(&PathElement::new(vec![(24, y), (32, y)], colour.stroke_width(2)))?;
        } else {
            area.draw(&PathElement::new(vec![(8, y), (32, y)], colour.stroke_width(2)))?;
        }
        area.draw(&Circle::new((20, y), 4, colour.filled()))?;
        area.draw_text(
            label,
            &font(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
            (40, y),
        )?;
    }
    Ok(())
}

/// Perceptual colour map (viridis, interpolated between nine of its colours): dark purple at 0 through
/// blue and green to yellow at 1; `t` is clamped to 0..1 (non-finite counts as 0).
pub(crate) fn colour_map(t: f64) -> RGBColor {
    const VIRIDIS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let position = t * (VIRIDIS.len() - 1) as f64;
    let k = (position.floor() as usize).min(VIRIDIS.len() - 2);
    let f = position - k as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let ((r0, g0, b0), (r1, g1, b1)) = (VIRIDIS[k], VIRIDIS[k + 1]);
    RGBColor(mix(r0, r1), mix(g0, g1), mix(b0, b1))
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
    fn looks_use_channel_colours_and_dash_repeats() {
        let rgb = looks(&["R", "G", "B", "exact G"]);
        assert_eq!(
            rgb.iter().map(|l| (l.colour, l.dashed)).collect::<Vec<_>>(),
            [
                (CHANNEL_RED, false),
                (CHANNEL_GREEN, false),
                (CHANNEL_BLUE, false),
                (CHANNEL_GREEN, true)
            ]
        );
        let other = looks(&["0°", "10°", "R"]);
        assert_eq!(other[0].colour, ramp(0, 3));
        assert!(other.iter().all(|l| !l.dashed));
    }

    #[test]
    fn colour_map_runs_dark_to_bright() {
        assert_eq!(colour_map(0.0), RGBColor(68, 1, 84));
        assert_eq!(colour_map(1.0), RGBColor(253, 231, 37));
        assert_eq!(colour_map(2.0), colour_map(1.0));
        assert_eq!(colour_map(f64::NAN), colour_map(0.0));
        let luma = |c: RGBColor| 0.3 * c.0 as f64 + 0.59 * c.1 as f64 + 0.11 * c.2 as f64;
        let values: Vec<f64> = (0..=20).map(|i| luma(colour_map(i as f64 / 20.0))).collect();
        assert!(values.windows(2).all(|w| w[1] > w[0]), "{values:?}");
    }

    #[test]
    fn equal_aspect_gives_both_axes_one_scale() {
        let (x, y) = equal_aspect(0.0..100.0, -10.0..10.0, (1000, 400));
        assert_eq!(x, 0.0..100.0);
        assert!(((y.end - y.start) - 40.0).abs() < 1e-12 && (y.start + y.end).abs() < 1e-12);
    }
}
