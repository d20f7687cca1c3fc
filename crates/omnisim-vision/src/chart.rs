//! Charts as SVG: labelled points ([`scatter`], log–log) and lines ([`lines`] log–log,
//! [`lines_on`] on the axes asked for). Written by hand: plotters, the usual crate, needs system
//! font libraries (font-kit, fontconfig) to lay out text, and a chart of a dozen labelled
//! points needs none of that.

use std::fmt::Write;

/// One labelled point of a [`scatter`] chart.
pub struct Point {
    /// Legend text.
    pub label: String,
    /// Position (both axes logarithmic).
    pub x: f64,
    /// Position; values below the chart's floor are drawn on it.
    pub y: f64,
    /// SVG fill colour of its marker and legend swatch: points of one method share one.
    pub colour: String,
}

const WIDTH: f64 = 1020.0;
const HEIGHT: f64 = 460.0;
const LEFT: f64 = 80.0;
/// Room for the legend: 60 characters at `SMALL_FONT`.
const RIGHT: f64 = 450.0;
const TOP: f64 = 56.0;
const BOTTOM: f64 = 60.0;
/// Radius of a [`scatter`] marker.
const MARKER_RADIUS: f64 = 5.0;
/// Font size of point numbers and legend text.
const SMALL_FONT: f64 = 11.0;

/// An axis-aligned box in SVG units: what a label or marker covers.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn around(x: f64, y: f64, radius: f64) -> Self {
        Self {
            x0: x - radius,
            y0: y - radius,
            x1: x + radius,
            y1: y + radius,
        }
    }

    fn overlaps(&self, other: &Rect) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }

    fn inside(&self, outer: &Rect) -> bool {
        self.x0 >= outer.x0 && self.x1 <= outer.x1 && self.y0 >= outer.y0 && self.y1 <= outer.y1
    }

    /// The point of this box nearest to (x, y).
    fn nearest(&self, x: f64, y: f64) -> (f64, f64) {
        (x.clamp(self.x0, self.x1), y.clamp(self.y0, self.y1))
    }
}

/// What a text of `text`'s length covers at `SMALL_FONT` with its baseline starting at (x, y):
/// digits and most letters of a sans-serif font are at most 0.6 em wide, capitals 0.75 em tall.
fn text_box(x: f64, y: f64, text: &str) -> Rect {
    Rect {
        x0: x,
        y0: y - 0.75 * SMALL_FONT,
        x1: x + 0.6 * SMALL_FONT * text.chars().count() as f64,
        y1: y + 0.2 * SMALL_FONT,
    }
}

/// How an axis maps values to positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Logarithmic, whole decades.
    Log,
    /// Linear from 0 (or the smallest value, if negative) to a round number above the largest.
    Linear,
}

/// One axis: its scale and the range it spans.
struct Axis {
    scale: Scale,
    lo: f64,
    hi: f64,
}

impl Axis {
    fn new(scale: Scale, values: impl Iterator<Item = f64>) -> Self {
        let (lo, hi) = values
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        match scale {
            Scale::Log => {
                let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (1.0, 10.0) };
                let d0 = lo.log10().floor();
                let d1 = hi.log10().ceil().max(d0 + 1.0);
                Self { scale, lo: d0, hi: d1 }
            }
            Scale::Linear => {
                let (lo, hi) = if lo.is_finite() {
                    (lo.min(0.0), hi.max(0.0))
                } else {
                    (0.0, 1.0)
                };
                let step = nice_step(hi - lo);
                Self {
                    scale,
                    lo: (lo / step).floor() * step,
                    hi: ((hi / step).ceil() * step).max(lo + step),
                }
            }
        }
    }

    /// Position of `v` along the axis, 0..1.
    fn fraction(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Log => (v.log10() - self.lo) / (self.hi - self.lo),
            Scale::Linear => (v - self.lo) / (self.hi - self.lo),
        }
    }

    /// Grid values and their labels (`log_label` writes a decade's).
    fn ticks(&self, log_label: impl Fn(i32) -> String) -> Vec<(f64, String)> {
        match self.scale {
            Scale::Log => (self.lo as i32..=self.hi as i32)
                .map(|d| (10f64.powi(d), log_label(d)))
                .collect(),
            Scale::Linear => {
                let step = nice_step(self.hi - self.lo);
                let count = ((self.hi - self.lo) / step).round() as usize;
                (0..=count)
                    .map(|i| {
                        let v = self.lo + step * i as f64;
                        // As many decimals as the step has: 0.15, not 0.15000000000000002.
                        let decimals = (-step.log10().floor()).max(0.0) as usize;
                        (v, format!("{:.*}", decimals, (v / step).round() * step))
                    })
                    .collect()
            }
        }
    }
}

/// A step of 1, 2 or 5 times a power of ten giving 4 to 10 grid lines over `span`.
fn nice_step(span: f64) -> f64 {
    let span = if span > 0.0 && span.is_finite() { span } else { 1.0 };
    let raw = span / 5.0;
    let power = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|&step| span / step <= 10.0)
        .unwrap_or(10.0 * power)
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Axes: the frame, grid lines, labels, and the mapping from data to SVG coordinates.
/// Everything a chart draws goes in `svg`, closed by [`Axes::finish`].
struct Axes {
    svg: String,
    x_axis: Axis,
    y_axis: Axis,
    floor: f64,
}

impl Axes {
    /// The axes of a chart whose `title` may have more lines after `\n`: the first is the
    /// title, the others (smaller) say what a reader must know to read it, such as where it
    /// was measured.
    fn new(title: &str, labels: (&str, &str), xs: &[f64], ys: &[f64], floor: f64, scales: (Scale, Scale)) -> Self {
        let (x_label, y_label) = labels;
        let mut axes = Self {
            svg: String::new(),
            x_axis: Axis::new(scales.0, xs.iter().copied()),
            y_axis: Axis::new(scales.1, ys.iter().map(|y| y.max(floor))),
            floor,
        };
        let (plot_w, plot_h) = (WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM);
        let _ = writeln!(
            axes.svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>"#
        );
        for (i, line) in title.lines().enumerate() {
            let (y, size) = if i == 0 {
                (24.0, 16.0)
            } else {
                (26.0 + 15.0 * i as f64, 12.0)
            };
            let _ = writeln!(
                axes.svg,
                r#"<text class="title" x="{}" y="{y}" font-size="{size}" text-anchor="middle">{}</text>"#,
                WIDTH / 2.0,
                escape(line)
            );
        }
        let _ = writeln!(
            axes.svg,
            r#"<rect x="{LEFT}" y="{TOP}" width="{plot_w}" height="{plot_h}" fill="none" stroke="black"/>"#
        );
        for (value, label) in axes.x_axis.ticks(|d| 10f64.powi(d).to_string()) {
            let x = axes.x(value);
            let _ = writeln!(
                axes.svg,
                r##"<line x1="{x}" y1="{TOP}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">{label}</text>"##,
                TOP + plot_h,
                TOP + plot_h + 18.0,
            );
        }
        for (value, label) in axes.y_axis.ticks(|d| format!("1e{d}")) {
            let y = axes.y(value);
            let _ = writeln!(
                axes.svg,
                r##"<line x1="{LEFT}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">{label}</text>"##,
                LEFT + plot_w,
                LEFT - 6.0,
                y + 4.0
            );
        }
        let _ = writeln!(
            axes.svg,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>
<text x="18" y="{}" text-anchor="middle" transform="rotate(-90 18 {})">{}</text>"#,
            LEFT + plot_w / 2.0,
            HEIGHT - 18.0,
            escape(x_label),
            TOP + plot_h / 2.0,
            TOP + plot_h / 2.0,
            escape(y_label)
        );
        axes
    }

    fn x(&self, x: f64) -> f64 {
        LEFT + self.x_axis.fraction(x) * (WIDTH - LEFT - RIGHT)
    }

    fn y(&self, y: f64) -> f64 {
        let plot_h = HEIGHT - TOP - BOTTOM;
        TOP + plot_h - self.y_axis.fraction(y.max(self.floor)) * plot_h
    }

    fn plot(&self) -> Rect {
        Rect {
            x0: LEFT,
            y0: TOP,
            x1: WIDTH - RIGHT,
            y1: HEIGHT - BOTTOM,
        }
    }

    /// Legend line `row` at the right of the plot: `swatch(x, y)` draws the series' sample
    /// centred at (x, y), the text follows it.
    fn legend(&mut self, row: usize, swatch: &str, text: &str) {
        let y = TOP + 14.0 + 16.0 * row as f64;
        let _ = writeln!(
            self.svg,
            r#"<g class="legend">{swatch}<text x="{}" y="{y}" font-size="{SMALL_FONT}">{}</text></g>"#,
            WIDTH - RIGHT + 44.0,
            escape(text)
        );
    }

    /// Where a legend row's swatch is centred.
    fn legend_swatch_centre(row: usize) -> (f64, f64) {
        (WIDTH - RIGHT + 26.0, TOP + 10.0 + 16.0 * row as f64)
    }

    fn finish(mut self) -> String {
        self.svg += "</svg>\n";
        self.svg
    }
}

/// Where each point's number goes: around its marker at (x, y), the nearest spot that covers
/// no other number and no marker, lies nearer its own marker than any other that a reader can
/// tell from it (or the reader pairs it with the wrong point; markers drawn over each other
/// are told apart by the leader lines) and stays inside `plot`; where none is free within 60 px,
/// above-right of the marker. Points measured close together (equal errors, similar times)
/// would otherwise print their numbers over each other.
fn place_labels(markers: &[(f64, f64)], texts: &[String], plot: &Rect) -> Vec<Rect> {
    let covered: Vec<Rect> = markers
        .iter()
        .map(|&(x, y)| Rect::around(x, y, MARKER_RADIUS + 1.0))
        .collect();
    let mut placed: Vec<Rect> = Vec::with_capacity(markers.len());
    for (own, (&(x, y), text)) in markers.iter().zip(texts).enumerate() {
        let size = text_box(0.0, 0.0, text);
        let (w, h) = (size.x1 - size.x0, size.y1 - size.y0);
        let at = |dx: f64, dy: f64| {
            // The box whose edge is `(dx, dy)` away from the marker's centre, on that side.
            let left = if dx > 0.0 {
                x + dx
            } else if dx < 0.0 {
                x + dx - w
            } else {
                x - w / 2.0
            };
            let top = if dy > 0.0 {
                y + dy
            } else if dy < 0.0 {
                y + dy - h
            } else {
                y - h / 2.0
            };
            Rect {
                x0: left,
                y0: top,
                x1: left + w,
                y1: top + h,
            }
        };
        let first = at(MARKER_RADIUS + 2.0, -2.0);
        let spot = (0..8)
            .flat_map(|ring| {
                let d = MARKER_RADIUS + 2.0 + 8.0 * f64::from(ring);
                [
                    (d, -2.0),
                    (d, 0.0),
                    (d, 2.0),
                    (0.0, -d),
                    (0.0, d),
                    (-d, -2.0),
                    (-d, 0.0),
                    (-d, 2.0),
                    (d, -d),
                    (d, d),
                    (-d, -d),
                    (-d, d),
                ]
            })
            .map(|(dx, dy)| at(dx, dy))
            .find(|spot| {
                let distance = |&(mx, my): &(f64, f64)| {
                    let (nx, ny) = spot.nearest(mx, my);
                    (nx - mx).hypot(ny - my)
                };
                let mine = distance(&(x, y));
                spot.inside(plot)
                    && !covered.iter().any(|marker| marker.overlaps(spot))
                    && !placed.iter().any(|label| label.overlaps(spot))
                    && markers.iter().enumerate().all(|(other, &(mx, my))| {
                        other == own || (mx - x).hypot(my - y) < MARKER_RADIUS || distance(&(mx, my)) > mine
                    })
            })
            .unwrap_or(first);
        placed.push(spot);
    }
    placed
}

/// Log–log chart of numbered `points`, each in its colour, with a legend of their labels;
/// values below `floor` on y are drawn at `floor`.
pub fn scatter(title: &str, x_label: &str, y_label: &str, points: &[Point], floor: f64) -> String {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let mut axes = Axes::new(title, (x_label, y_label), &xs, &ys, floor, (Scale::Log, Scale::Log));
    let markers: Vec<(f64, f64)> = points.iter().map(|p| (axes.x(p.x), axes.y(p.y))).collect();
    let numbers: Vec<String> = (1..=points.len()).map(|n| n.to_string()).collect();
    let labels = place_labels(&markers, &numbers, &axes.plot());
    for (p, &(x, y)) in points.iter().zip(&markers) {
        let _ = writeln!(
            axes.svg,
            r#"<circle class="marker" cx="{x:.1}" cy="{y:.1}" r="{MARKER_RADIUS}" fill="{}" fill-opacity="0.85"/>"#,
            p.colour
        );
    }
    for ((number, label), &(x, y)) in numbers.iter().zip(&labels).zip(&markers) {
        let (nx, ny) = label.nearest(x, y);
        if (nx - x).hypot(ny - y) > MARKER_RADIUS + 6.0 {
            // Moved away from a crowd: a leader line says whose number it is.
            let _ = writeln!(
                axes.svg,
                r##"<line class="leader" x1="{x:.1}" y1="{y:.1}" x2="{nx:.1}" y2="{ny:.1}" stroke="#777" stroke-width="0.7"/>"##
            );
        }
        let _ = writeln!(
            axes.svg,
            r#"<text class="label" x="{:.1}" y="{:.1}" font-size="{SMALL_FONT}">{number}</text>"#,
            label.x0,
            label.y1 - 0.2 * SMALL_FONT
        );
    }
    for (i, p) in points.iter().enumerate() {
        let (sx, sy) = Axes::legend_swatch_centre(i);
        let swatch = format!(
            r#"<circle cx="{sx}" cy="{sy}" r="{MARKER_RADIUS}" fill="{}" fill-opacity="0.85"/>"#,
            p.colour
        );
        axes.legend(i, &swatch, &format!("{}: {}", i + 1, p.label));
    }
    axes.finish()
}

/// How a [`Series`] marks its points: series that share a colour differ in marker and dash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// A filled disc.
    Disc,
    /// A ring: white inside, the series' colour around.
    Ring,
}

/// One line of a [`lines`] chart: its legend, colour, dash pattern ("" for solid), marker and
/// points. The legend shows all three, so that series of one colour stay apart.
pub struct Series {
    /// Legend text.
    pub label: String,
    /// SVG colour.
    pub colour: String,
    /// SVG `stroke-dasharray` ("" for a solid line).
    pub dash: String,
    /// The mark of each point.
    pub marker: Marker,
    /// (x, y) in drawing order.
    pub points: Vec<(f64, f64)>,
}

/// One point of `series` at (x, y).
fn series_marker(series: &Series, x: f64, y: f64) -> String {
    let colour = &series.colour;
    match series.marker {
        Marker::Disc => format!(r#"<circle class="marker" cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{colour}"/>"#),
        Marker::Ring => format!(
            r#"<circle class="marker" cx="{x:.1}" cy="{y:.1}" r="3.5" fill="white" stroke="{colour}" stroke-width="1.5"/>"#
        ),
    }
}

/// Log–log chart of lines with markers; values below `floor` on y are drawn at `floor`.
pub fn lines(title: &str, x_label: &str, y_label: &str, series: &[Series], floor: f64) -> String {
    lines_on((Scale::Log, Scale::Log), title, (x_label, y_label), series, floor)
}

/// Chart of lines with markers on the given (x, y) scales and (x, y) labels; values below
/// `floor` on y are drawn at `floor` (give −∞ for none on a linear axis).
pub fn lines_on(scales: (Scale, Scale), title: &str, labels: (&str, &str), series: &[Series], floor: f64) -> String {
    let xs: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
    let ys: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).collect();
    let mut axes = Axes::new(title, labels, &xs, &ys, floor, scales);
    for (i, s) in series.iter().enumerate() {
        let path: Vec<String> = s
            .points
            .iter()
            .map(|&(x, y)| format!("{:.1},{:.1}", axes.x(x), axes.y(y)))
            .collect();
        let _ = writeln!(
            axes.svg,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="2" stroke-dasharray="{}"/>"#,
            path.join(" "),
            s.colour,
            s.dash
        );
        for &(x, y) in &s.points {
            let marker = series_marker(s, axes.x(x), axes.y(y));
            axes.svg += &marker;
            axes.svg += "\n";
        }
        let (sx, sy) = Axes::legend_swatch_centre(i);
        let swatch = format!(
            r#"<line x1="{}" y1="{sy}" x2="{}" y2="{sy}" stroke="{}" stroke-width="2" stroke-dasharray="{}"/>{}"#,
            sx - 14.0,
            sx + 14.0,
            s.colour,
            s.dash,
            series_marker(s, sx, sy)
        );
        axes.legend(i, &swatch, &s.label);
    }
    axes.finish()
}

/// Charts stacked top to bottom in one SVG document.
pub fn stack(charts: &[String]) -> String {
    let mut svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{}">"#,
        HEIGHT * charts.len() as f64
    );
    for (i, chart) in charts.iter().enumerate() {
        let inner = chart.replacen("<svg ", &format!(r#"<svg y="{}" "#, HEIGHT * i as f64), 1);
        svg += "\n";
        svg += inner.trim_end();
    }
    svg += "\n</svg>\n";
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value of attribute `name` in the SVG element `element`.
    fn attribute<'a>(element: &'a str, name: &str) -> &'a str {
        let start = element
            .find(&format!(" {name}=\""))
            .unwrap_or_else(|| panic!("no {name} in {element}"))
            + name.len()
            + 3;
        &element[start..start + element[start..].find('"').unwrap()]
    }

    /// The elements of `svg` that start with `start` (up to their end: the line).
    fn elements<'a>(svg: &'a str, start: &str) -> Vec<&'a str> {
        svg.match_indices(start)
            .map(|(i, _)| &svg[i..i + svg[i..].find('\n').unwrap()])
            .collect()
    }

    fn number(element: &str, name: &str) -> f64 {
        attribute(element, name).parse().unwrap()
    }

    fn point(label: &str, x: f64, y: f64, colour: &str) -> Point {
        Point {
            label: label.into(),
            x,
            y,
            colour: colour.into(),
        }
    }

    #[test]
    fn draws_every_point_on_log_axes_with_escaped_labels() {
        let points = vec![point("a<b", 2.0, 0.5, "red"), point("c", 40.0, 0.0, "blue")];
        let svg = scatter("t", "x", "y", &points, 1e-3);
        assert_eq!(elements(&svg, "<circle class=\"marker\"").len(), 2);
        assert!(svg.contains("a&lt;b") && !svg.contains("a<b"));
        // x spans the decades 1..100: 2 ms sits log10(2)/2 of the way across.
        let plot_w = WIDTH - LEFT - RIGHT;
        assert!(svg.contains(&format!("cx=\"{:.1}\"", LEFT + 2f64.log10() / 2.0 * plot_w)));
        // y = 0 is drawn on the floor, the bottom edge of the 1e-3..1e0 axis.
        assert!(svg.contains(&format!("cy=\"{:.1}\"", HEIGHT - BOTTOM)));
    }

    /// Each legend swatch has its point's colour, as the markers do (they were all one blue).
    #[test]
    fn legend_swatches_take_their_points_colours() {
        let colours = ["#1f77b4", "#ff7f0e", "#2ca02c"];
        let points: Vec<Point> = colours
            .iter()
            .enumerate()
            .map(|(i, colour)| point(&format!("p{i}"), 1.0 + i as f64, 0.5, colour))
            .collect();
        let svg = scatter("t\nsubtitle", "x", "y", &points, 1e-3);
        let legend = elements(&svg, "<g class=\"legend\">");
        let markers = elements(&svg, "<circle class=\"marker\"");
        assert_eq!(legend.len(), 3);
        for ((row, marker), colour) in legend.iter().zip(&markers).zip(colours) {
            assert_eq!(attribute(row, "fill"), colour, "{row}");
            assert_eq!(attribute(marker, "fill"), colour, "{marker}");
        }
        // The second title line is drawn, smaller.
        assert!(svg.contains(r#"font-size="12" text-anchor="middle">subtitle</text>"#));
    }

    /// Points measured close together (equal error, times within a few per cent) get numbers
    /// that cover neither each other nor any marker: in docs/speed-accuracy.svg 6, 11 and 3
    /// printed as "6113". Checked on the shipped figures and on eight points at one spot.
    #[test]
    fn labels_cover_neither_each_other_nor_markers() {
        let shipped =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/speed-accuracy.jsonl")).unwrap();
        let from_file: Vec<Point> = shipped
            .lines()
            .map(|line| {
                let record: serde_json::Value = serde_json::from_str(line).unwrap();
                let value = |key: &str| record[key].as_f64().unwrap();
                point("m", value("median_ms"), value("mean_abs_colour_error"), "black")
            })
            .collect();
        let cluster: Vec<Point> = (0..8).map(|_| point("c", 10.0, 0.1, "black")).collect();
        for points in [from_file, cluster] {
            let svg = scatter("t", "x", "y", &points, 1e-3);
            let labels: Vec<Rect> = elements(&svg, "<text class=\"label\"")
                .iter()
                .map(|e| {
                    let text = &e[e.find('>').unwrap() + 1..e.find("</text>").unwrap()];
                    text_box(number(e, "x"), number(e, "y"), text)
                })
                .collect();
            let markers: Vec<Rect> = elements(&svg, "<circle class=\"marker\"")
                .iter()
                .map(|e| Rect::around(number(e, "cx"), number(e, "cy"), number(e, "r")))
                .collect();
            assert_eq!(labels.len(), points.len());
            for (i, label) in labels.iter().enumerate() {
                assert!(label.inside(&Rect {
                    x0: LEFT,
                    y0: TOP,
                    x1: WIDTH - RIGHT,
                    y1: HEIGHT - BOTTOM
                }));
                assert!(
                    !markers.iter().any(|m| m.overlaps(label)),
                    "label {} covers a marker",
                    i + 1
                );
                for (j, other) in labels.iter().enumerate().skip(i + 1) {
                    assert!(!label.overlaps(other), "labels {} and {} overlap", i + 1, j + 1);
                }
                // Nearer its own marker than any other a reader can tell from it.
                let centre = |m: &Rect| ((m.x0 + m.x1) / 2.0, (m.y0 + m.y1) / 2.0);
                let distance = |m: &Rect| {
                    let (x, y) = centre(m);
                    let (nx, ny) = label.nearest(x, y);
                    (nx - x).hypot(ny - y)
                };
                let (ox, oy) = centre(&markers[i]);
                for (j, marker) in markers.iter().enumerate() {
                    let (mx, my) = centre(marker);
                    if j != i && (mx - ox).hypot(my - oy) >= MARKER_RADIUS {
                        assert!(
                            distance(marker) > distance(&markers[i]),
                            "label {} is nearer point {}",
                            i + 1,
                            j + 1
                        );
                    }
                }
            }
        }
    }

    /// A line chart draws one polyline and one marker per point, at the log positions; its
    /// legend shows each series' colour, dash and marker, so series of one colour (bilinear,
    /// bicubic) stay apart; stacked charts are offset by one chart height each.
    #[test]
    fn lines_legends_and_stacks() {
        let series = vec![
            Series {
                label: "solid".into(),
                colour: "red".into(),
                dash: String::new(),
                marker: Marker::Disc,
                points: vec![(1.0, 0.1), (10.0, 1.0)],
            },
            Series {
                label: "dashed".into(),
                colour: "red".into(),
                dash: "6 4".into(),
                marker: Marker::Ring,
                points: vec![(1.0, 0.2), (10.0, 0.5)],
            },
        ];
        let svg = lines("t", "x", "y", &series, 1e-3);
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(elements(&svg, "<circle class=\"marker\"").len(), 4 + 2);
        assert!(svg.contains(&format!(
            "{:.1},{:.1} {:.1},{:.1}",
            LEFT,
            HEIGHT - BOTTOM,
            WIDTH - RIGHT,
            TOP
        )));
        let legend = elements(&svg, "<g class=\"legend\">");
        assert_eq!(legend.len(), 2);
        for (row, s) in legend.iter().zip(&series) {
            assert_eq!(attribute(row, "stroke"), s.colour);
            assert_eq!(attribute(row, "stroke-dasharray"), s.dash);
        }
        assert!(legend[0].contains(r#"r="3.5" fill="red"/>"#), "{}", legend[0]);
        assert!(legend[1].contains(r#"fill="white" stroke="red""#), "{}", legend[1]);
        let both = stack(&[svg.clone(), svg]);
        assert!(both.contains(&format!("<svg y=\"{HEIGHT}\" ")) && both.contains("<svg y=\"0\" "));
        assert!(both.contains(&format!("height=\"{}\"", 2.0 * HEIGHT)));
    }
}
