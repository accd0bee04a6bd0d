//! The ranking-trend picture (`level_lines`, the bench's `ranking_trend.png` and `metric_*.png`): its
//! legend covers no marker, whichever corner of the chart the markers fill (issue 33: the small run's
//! legend hid the best ranks at levels 4-5). Checked on the SVG, which states every marker's centre and
//! every label's position.

use unicac_plot::{level_lines, LevelSeries};

/// An axis-aligned box in picture pixels: [left, right] x [top, bottom].
#[derive(Clone, Copy, Debug)]
struct Box2 {
    left: f64,
    right: f64,
    top: f64,
    bottom: f64,
}

impl Box2 {
    fn overlaps(&self, other: &Box2) -> bool {
        self.left < other.right
            && other.left < self.right
            && self.top < other.bottom
            && other.top < self.bottom
    }

    fn union(&self, other: &Box2) -> Box2 {
        Box2 {
            left: self.left.min(other.left),
            right: self.right.max(other.right),
            top: self.top.min(other.top),
            bottom: self.bottom.max(other.bottom),
        }
    }
}

/// The number in `name="..."` of one SVG element.
fn attribute(element: &str, name: &str) -> f64 {
    let start = element.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
    element[start..].split('"').next().unwrap().parse().unwrap()
}

/// Every `<circle>` of the SVG as (cx, cy, r), in drawing order.
fn circles(svg: &str) -> Vec<(f64, f64, f64)> {
    svg.split("<circle")
        .skip(1)
        .map(|e| (attribute(e, "cx"), attribute(e, "cy"), attribute(e, "r")))
        .collect()
}

/// The anchor (x, y) and font size of the `<text>` element reading `label` (plotters puts the text on a
/// line of its own).
fn text_anchor(svg: &str, label: &str) -> (f64, f64, f64) {
    let element = svg
        .split("<text")
        .skip(1)
        .map(|e| &e[..e.find("</text>").unwrap()])
        .find(|e| e[e.find('>').unwrap() + 1..].trim() == label)
        .unwrap_or_else(|| panic!("no text {label:?}"));
    (
        attribute(element, "x"),
        attribute(element, "y"),
        attribute(element, "font-size"),
    )
}

/// Eight models whose ranks fill all four corners of the chart: rank 1 and rank 8 at the first and at
/// the last level, so a legend inside the chart, in any corner, would cover a marker.
fn ranks_filling_every_corner() -> Vec<LevelSeries> {
    let ranks: [[f64; 5]; 8] = [
        [7.0, 2.0, 1.0, 1.0, 1.0],
        [1.0, 1.0, 2.0, 2.0, 2.0],
        [2.0, 3.0, 3.0, 3.0, 3.0],
        [4.0, 5.0, 5.0, 4.0, 4.0],
        [6.0, 7.0, 7.0, 7.0, 5.0],
        [3.0, 4.0, 4.0, 5.0, 6.0],
        [5.0, 6.0, 6.0, 6.0, 7.0],
        [8.0, 8.0, 8.0, 8.0, 8.0],
    ];
    ranks
        .iter()
        .enumerate()
        .map(|(i, r)| LevelSeries {
            label: format!("model-{}", (b'a' + i as u8) as char),
            values: r.iter().map(|&v| Some(v)).collect(),
        })
        .collect()
}

/// The box of a left-anchored, vertically centred label: an upper bound of its width (0.62 em per
/// character covers the widest lower-case sans-serif letters on average) and its font's height.
fn label_box(x: f64, y: f64, font_size: f64, label: &str) -> Box2 {
    Box2 {
        left: x,
        right: x + font_size * 0.62 * label.chars().count() as f64,
        top: y - font_size * 0.6,
        bottom: y + font_size * 0.6,
    }
}

#[test]
fn the_ranking_trend_legend_covers_no_marker() {
    let series = ranks_filling_every_corner();
    // Its own scratch folder: tests/common would bring in helpers this file does not use (dead code).
    let dir = std::env::temp_dir().join(format!("unicac-plot-ranking-legend-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("ranking_trend.svg");
    level_lines(
        "Ranking by O.P. across ODE levels",
        "rank (1 = best)",
        &series,
        true,
        &path,
    )
    .unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let mut markers = circles(&svg);

    // Each legend entry: its label and the marker drawn on the label's line just left of it.
    let mut legend: Option<Box2> = None;
    for s in &series {
        let (x, y, font_size) = text_anchor(&svg, &s.label);
        let at = markers
            .iter()
            .position(|&(cx, cy, _)| (cy - y).abs() < 1.0 && cx < x && x - cx < 40.0)
            .unwrap_or_else(|| panic!("no legend marker for {}", s.label));
        let (cx, cy, r) = markers.remove(at);
        let entry = label_box(x, y, font_size, &s.label).union(&Box2 {
            left: cx - 12.0,
            right: cx + r,
            top: cy - r,
            bottom: cy + r,
        });
        legend = Some(legend.map_or(entry, |l| l.union(&entry)));
    }
    let legend = legend.unwrap();

    // What is left are the data markers: one per model and level.
    assert_eq!(markers.len(), series.len() * 5, "one marker per model and level");
    for &(cx, cy, r) in &markers {
        let marker = Box2 {
            left: cx - r,
            right: cx + r,
            top: cy - r,
            bottom: cy + r,
        };
        assert!(
            !marker.overlaps(&legend),
            "the legend {legend:?} covers the marker at ({cx}, {cy})"
        );
    }
}
