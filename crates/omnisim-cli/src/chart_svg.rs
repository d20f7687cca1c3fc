//! A log–log scatter chart as SVG. Written by hand: plotters, the usual crate, needs system
//! font libraries (font-kit, fontconfig) to lay out text, and a chart of a dozen labelled
//! points needs none of that.

use std::fmt::Write;

/// One labelled point.
pub struct Point {
    pub label: String,
    pub x: f64,
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

/// Log–log chart of `points`; values below `floor` on y are drawn at `floor`.
pub fn scatter(title: &str, x_label: &str, y_label: &str, points: &[Point], floor: f64) -> String {
    let ys = points.iter().map(|p| p.y.max(floor));
    let (x0, x1) = decades(points.iter().map(|p| p.x));
    let (y0, y1) = decades(ys);
    let plot_w = WIDTH - LEFT - RIGHT;
    let plot_h = HEIGHT - TOP - BOTTOM;
    let sx = |x: f64| LEFT + (x.log10() - x0 as f64) / (x1 - x0) as f64 * plot_w;
    let sy = |y: f64| TOP + plot_h - (y.max(floor).log10() - y0 as f64) / (y1 - y0) as f64 * plot_h;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>
<text x="{}" y="28" font-size="16" text-anchor="middle">{}</text>
<rect x="{LEFT}" y="{TOP}" width="{plot_w}" height="{plot_h}" fill="none" stroke="black"/>
"#,
        LEFT + plot_w / 2.0,
        escape(title)
    );
    for d in x0..=x1 {
        let x = sx(10f64.powi(d));
        let _ = writeln!(
            svg,
            r##"<line x1="{x}" y1="{TOP}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">{}</text>"##,
            TOP + plot_h,
            TOP + plot_h + 18.0,
            10f64.powi(d)
        );
    }
    for d in y0..=y1 {
        let y = sy(10f64.powi(d));
        let _ = writeln!(
            svg,
            r##"<line x1="{LEFT}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">1e{d}</text>"##,
            LEFT + plot_w,
            LEFT - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>
<text x="18" y="{}" text-anchor="middle" transform="rotate(-90 18 {})">{}</text>"#,
        LEFT + plot_w / 2.0,
        HEIGHT - 18.0,
        escape(x_label),
        TOP + plot_h / 2.0,
        TOP + plot_h / 2.0,
        escape(y_label)
    );
    for (i, p) in points.iter().enumerate() {
        let (x, y) = (sx(p.x), sy(p.y));
        let _ = writeln!(
            svg,
            r##"<circle cx="{x:.1}" cy="{y:.1}" r="5" fill="#1f77b4"/><text x="{:.1}" y="{:.1}" font-size="11">{}</text>
<text x="{}" y="{}" font-size="11">{}: {}</text>"##,
            x + 7.0,
            y - 6.0,
            i + 1,
            WIDTH - RIGHT + 12.0,
            TOP + 14.0 + 16.0 * i as f64,
            i + 1,
            escape(&p.label)
        );
    }
    svg += "</svg>\n";
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
}
