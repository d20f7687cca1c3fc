//! Log–log charts as SVG: labelled points ([`scatter`]) and lines ([`lines`]). Written by hand: plotters, the usual crate, needs system
//! font libraries (font-kit, fontconfig) to lay out text, and a chart of a dozen labelled
//! points needs none of that.

use std::fmt::Write;

/// One labelled point.
pub struct Point {
    /// Legend text.
    pub label: String,
    /// Position (both axes logarithmic).
    pub x: f64,
    /// Position; values below the chart's floor are drawn on it.
    pub y: f64,
}

const WIDTH: f64 = 990.0;
const HEIGHT: f64 = 460.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 420.0;
const TOP: f64 = 50.0;
const BOTTOM: f64 = 60.0;

fn decades(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    (
        lo.log10().floor() as i32,
        (hi.log10().ceil() as i32).max(lo.log10().floor() as i32 + 1),
    )
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Log–log axes: the frame, decade grid lines, labels, and the mapping from data to SVG
/// coordinates. Everything a chart draws goes in `svg`, closed by [`Axes::finish`].
struct Axes {
    svg: String,
    x_decades: (i32, i32),
    y_decades: (i32, i32),
    floor: f64,
}

impl Axes {
    fn new(title: &str, x_label: &str, y_label: &str, xs: &[f64], ys: &[f64], floor: f64) -> Self {
        let x_decades = decades(xs.iter().copied());
        let y_decades = decades(ys.iter().map(|y| y.max(floor)));
        let mut axes = Self {
            svg: String::new(),
            x_decades,
            y_decades,
            floor,
        };
        let (plot_w, plot_h) = (WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM);
        let _ = write!(
            axes.svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>
<text x="{}" y="28" font-size="16" text-anchor="middle">{}</text>
<rect x="{LEFT}" y="{TOP}" width="{plot_w}" height="{plot_h}" fill="none" stroke="black"/>
"#,
            LEFT + plot_w / 2.0,
            escape(title)
        );
        for d in x_decades.0..=x_decades.1 {
            let x = axes.x(10f64.powi(d));
            let _ = writeln!(
                axes.svg,
                r##"<line x1="{x}" y1="{TOP}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">{}</text>"##,
                TOP + plot_h,
                TOP + plot_h + 18.0,
                10f64.powi(d)
            );
        }
        for d in y_decades.0..=y_decades.1 {
            let y = axes.y(10f64.powi(d));
            let _ = writeln!(
                axes.svg,
                r##"<line x1="{LEFT}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">1e{d}</text>"##,
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
        let (x0, x1) = self.x_decades;
        LEFT + (x.log10() - f64::from(x0)) / f64::from(x1 - x0) * (WIDTH - LEFT - RIGHT)
    }

    fn y(&self, y: f64) -> f64 {
        let (y0, y1) = self.y_decades;
        let plot_h = HEIGHT - TOP - BOTTOM;
        TOP + plot_h - (y.max(self.floor).log10() - f64::from(y0)) / f64::from(y1 - y0) * plot_h
    }

    /// Legend line `row` at the right of the plot, with a swatch of `colour`.
    fn legend(&mut self, row: usize, colour: &str, text: &str) {
        let y = TOP + 14.0 + 16.0 * row as f64;
        let _ = writeln!(
            self.svg,
            r#"<rect x="{}" y="{}" width="10" height="10" fill="{colour}"/><text x="{}" y="{y}" font-size="11">{}</text>"#,
            WIDTH - RIGHT + 12.0,
            y - 9.0,
            WIDTH - RIGHT + 28.0,
            escape(text)
        );
    }

    fn finish(mut self) -> String {
        self.svg += "</svg>\n";
        self.svg
    }
}

/// Log–log chart of `points`; values below `floor` on y are drawn at `floor`.
pub fn scatter(title: &str, x_label: &str, y_label: &str, points: &[Point], floor: f64) -> String {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let mut axes = Axes::new(title, x_label, y_label, &xs, &ys, floor);
    for (i, p) in points.iter().enumerate() {
        let (x, y) = (axes.x(p.x), axes.y(p.y));
        let _ = writeln!(
            axes.svg,
            r##"<circle cx="{x:.1}" cy="{y:.1}" r="5" fill="#1f77b4"/><text x="{:.1}" y="{:.1}" font-size="11">{}</text>"##,
            x + 7.0,
            y - 6.0,
            i + 1
        );
        axes.legend(i, "#1f77b4", &format!("{}: {}", i + 1, p.label));
    }
    axes.finish()
}

/// One line of a [`lines`] chart: its legend, colour, dash pattern ("" for solid) and points.
pub struct Series {
    /// Legend text.
    pub label: String,
    /// SVG colour.
    pub colour: String,
    /// SVG `stroke-dasharray` ("" for a solid line).
    pub dash: String,
    /// (x, y) in drawing order.
    pub points: Vec<(f64, f64)>,
}

/// Log–log chart of lines with markers; values below `floor` on y are drawn at `floor`.
pub fn lines(title: &str, x_label: &str, y_label: &str, series: &[Series], floor: f64) -> String {
    let xs: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
    let ys: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).collect();
    let mut axes = Axes::new(title, x_label, y_label, &xs, &ys, floor);
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
            let _ = writeln!(
                axes.svg,
                r#"<circle cx="{:.1}" cy="{:.1}" r="3.5" fill="{}"/>"#,
                axes.x(x),
                axes.y(y),
                s.colour
            );
        }
        axes.legend(i, &s.colour, &s.label);
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

    #[test]
    fn draws_every_point_on_log_axes_with_escaped_labels() {
        let points = vec![
            Point {
                label: "a<b".into(),
                x: 2.0,
                y: 0.5,
            },
            Point {
                label: "c".into(),
                x: 40.0,
                y: 0.0,
            },
        ];
        let svg = scatter("t", "x", "y", &points, 1e-3);
        assert_eq!(svg.matches("<circle").count(), 2);
        assert!(svg.contains("a&lt;b") && !svg.contains("a<b"));
        // x spans the decades 1..100: 2 ms sits log10(2)/2 of the way across.
        let plot_w = WIDTH - LEFT - RIGHT;
        assert!(svg.contains(&format!("cx=\"{:.1}\"", LEFT + 2f64.log10() / 2.0 * plot_w)));
        // y = 0 is drawn on the floor, the bottom edge of the 1e-3..1e0 axis.
        assert!(svg.contains(&format!("cy=\"{:.1}\"", HEIGHT - BOTTOM)));
    }

    /// A line chart draws one polyline and one marker per point, at the log positions; stacked
    /// charts are offset by one chart height each.
    #[test]
    fn lines_and_stacks() {
        let series = vec![Series {
            label: "s".into(),
            colour: "red".into(),
            dash: String::new(),
            points: vec![(1.0, 0.1), (10.0, 1.0)],
        }];
        let svg = lines("t", "x", "y", &series, 1e-3);
        assert_eq!(svg.matches("<polyline").count(), 1);
        assert_eq!(svg.matches("<circle").count(), 2);
        assert!(svg.contains(&format!(
            "{:.1},{:.1} {:.1},{:.1}",
            LEFT,
            HEIGHT - BOTTOM,
            WIDTH - RIGHT,
            TOP
        )));
        let both = stack(&[svg.clone(), svg]);
        assert!(both.contains(&format!("<svg y=\"{HEIGHT}\" ")) && both.contains("<svg y=\"0\" "));
        assert!(both.contains(&format!("height=\"{}\"", 2.0 * HEIGHT)));
    }
}
