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

    fn sized(x0: f64, y0: f64, w: f64, h: f64) -> Self {
        Self {
            x0,
            y0,
            x1: x0 + w,
            y1: y0 + h,
        }
    }

    fn grown(&self, by: f64) -> Self {
        Self {
            x0: self.x0 - by,
            y0: self.y0 - by,
            x1: self.x1 + by,
            y1: self.y1 + by,
        }
    }

    fn contains(&self, x: f64, y: f64) -> bool {
        (self.x0..=self.x1).contains(&x) && (self.y0..=self.y1).contains(&y)
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

impl Scale {
    /// Whether the scale has a place for `v`: a finite value, and on a log scale one above 0
    /// (log10(0) = −∞ would make its decades endless).
    fn holds(self, v: f64) -> bool {
        v.is_finite() && (self == Scale::Linear || v > 0.0)
    }
}

/// One axis: its scale and the range it spans.
struct Axis {
    scale: Scale,
    lo: f64,
    hi: f64,
}

impl Axis {
    /// The axis spanning those of `values` the scale holds ([`Scale::holds`]).
    fn new(scale: Scale, values: impl Iterator<Item = f64>) -> Self {
        let (lo, hi) = values
            .filter(|&v| scale.holds(v))
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

/// How far apart (SVG units) a placed number keeps from markers, other numbers and leader
/// lines, so that the positions printed to 0.1 in the SVG still keep them apart.
const CLEARANCE: f64 = 0.5;

/// The leader line from a marker at (x, y) to its number's box, where the box lies too far
/// from the marker to be read as its number without one.
fn leader(x: f64, y: f64, label: &Rect) -> Option<[(f64, f64); 2]> {
    let (nx, ny) = label.nearest(x, y);
    ((nx - x).hypot(ny - y) > MARKER_RADIUS + 6.0).then_some([(x, y), (nx, ny)])
}

/// Whether the segment from `a` to `b` passes through the inside of `rect` (Liang–Barsky
/// clipping; touching its edge does not count).
fn segment_enters(rect: &Rect, [a, b]: [(f64, f64); 2]) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for (p, q) in [
        (-dx, a.0 - rect.x0),
        (dx, rect.x1 - a.0),
        (-dy, a.1 - rect.y0),
        (dy, rect.y1 - a.1),
    ] {
        if p == 0.0 {
            if q <= 0.0 {
                return false;
            }
        } else if p < 0.0 {
            t0 = t0.max(q / p);
        } else {
            t1 = t1.min(q / p);
        }
    }
    t0 < t1
}

/// Whether two leader lines cross at a point inside both that a reader sees: not under one of
/// the markers `hidden` (those of the blob both start in; sharing an end, as the leaders of
/// markers drawn at one spot do, is not crossing).
fn leaders_cross([a, b]: [(f64, f64); 2], [c, d]: [(f64, f64); 2], hidden: &[Rect]) -> bool {
    // Twice the signed area of p, q, r: its sign says on which side of p→q r lies (0: on the line).
    let area = |p: (f64, f64), q: (f64, f64), r: (f64, f64)| (q.0 - p.0) * (r.1 - p.1) - (q.1 - p.1) * (r.0 - p.0);
    let apart = |s: f64, t: f64| (s < 0.0 && t > 0.0) || (s > 0.0 && t < 0.0);
    let (cda, cdb) = (area(c, d, a), area(c, d, b));
    if !(apart(area(a, b, c), area(a, b, d)) && apart(cda, cdb)) {
        return false;
    }
    let t = cda / (cda - cdb);
    let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
    !hidden.iter().any(|marker| marker.contains(x, y))
}

/// Which markers are drawn as one blob: each marker's blob is the smallest index among the
/// markers joined to it through a chain of overlapping discs. A leader line starting in a blob
/// may cross its markers: a reader sees the blob as one shape, and cannot leave it otherwise.
fn blobs(markers: &[(f64, f64)]) -> Vec<usize> {
    // Union–find over the overlapping pairs, each set rooted at its smallest index (a merge
    // hangs the larger root under the smaller), so one pass over the pairs suffices.
    let mut parent: Vec<usize> = (0..markers.len()).collect();
    let root = |parent: &mut Vec<usize>, mut i: usize| {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    };
    for i in 0..markers.len() {
        for j in 0..i {
            let (a, b) = (markers[i], markers[j]);
            if (a.0 - b.0).hypot(a.1 - b.1) < 2.0 * (MARKER_RADIUS + 1.0) {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                parent[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    (0..markers.len()).map(|i| root(&mut parent, i)).collect()
}

/// How strictly [`place_labels`] picks a spot: every candidate is tried at one level before
/// the next, looser one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rule {
    /// Nearer its own marker than any other a reader can tell from it, and a leader line (if
    /// it needs one) crossing no number, no other leader and no marker outside its own blob.
    Nearest,
    /// As `Nearest`, but a number with a leader line may lie nearer another marker: the line
    /// says whose it is.
    CleanLeader,
    /// Only off every marker and number: a plot too crowded for clean leader lines.
    Free,
}

/// Spots tried for a number whose box is `w` × `h`, nearest first: twelve around the marker
/// at (x, y) in eight rings 8 px apart, then rings 8 px apart all around out to the farthest
/// corner of `plot`, one spot every 8 px along each (these need a leader line).
fn candidate_spots(x: f64, y: f64, w: f64, h: f64, plot: &Rect) -> impl Iterator<Item = Rect> {
    // Along one axis: where a box of `size` starts whose edge is `d` away from `centre` on
    // that side (centred on it for 0).
    let start = |centre: f64, d: f64, size: f64| {
        if d > 0.0 {
            centre + d
        } else if d < 0.0 {
            centre + d - size
        } else {
            centre - size / 2.0
        }
    };
    // The box whose edge is `(dx, dy)` away from the marker's centre, on that side.
    let at = move |dx: f64, dy: f64| Rect::sized(start(x, dx, w), start(y, dy, h), w, h);
    let near = (0..8).flat_map(move |ring| {
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
        .map(|(dx, dy)| at(dx, dy))
    });
    // No spot farther than the plot's diagonal can lie inside it: that bound keeps the rings
    // finite for a marker far outside the plot, or at an infinite or NaN position.
    let reach = [
        (plot.x0, plot.y0),
        (plot.x1, plot.y0),
        (plot.x0, plot.y1),
        (plot.x1, plot.y1),
    ]
    .iter()
    .map(|&(cx, cy)| (cx - x).hypot(cy - y))
    .fold(0.0, f64::max)
    .min((plot.x1 - plot.x0).hypot(plot.y1 - plot.y0));
    let far = (0..)
        .map(|ring| MARKER_RADIUS + 2.0 + 8.0 * f64::from(8 + ring))
        .take_while(move |&d| d <= reach)
        .flat_map(move |d| {
            let steps = (std::f64::consts::TAU * d / 8.0).ceil() as u32;
            (0..steps).map(move |k| {
                // The box touches the ring at angle θ from its side facing the marker.
                let (sin, cos) = (std::f64::consts::TAU * f64::from(k) / f64::from(steps)).sin_cos();
                let (ax, ay) = (x + d * cos, y + d * sin);
                Rect::sized(ax - w * (1.0 - cos) / 2.0, ay - h * (1.0 - sin) / 2.0, w, h)
            })
        });
    near.chain(far)
}

/// Where each point's number goes: around its marker, the nearest spot inside `plot` that
/// covers no marker, no other number and no leader line, and lies nearer its own marker than
/// any other that a reader can tell from it (or the reader pairs it with the wrong point;
/// markers drawn over each other are told apart by the leader lines). Points measured close
/// together (equal errors, similar times) would otherwise print their numbers over each other.
/// A number moved away from its marker gets a leader line, which crosses no number, no other
/// leader and no marker outside the blob its own is drawn in. Where no spot keeps all of that,
/// the nearest with a clean leader line is taken, then the nearest merely free; `None` where
/// the plot has no free spot left at all (the legend still lists the point), and for a
/// marker outside `plot` or at a non-finite position (such a marker is not drawn, and is left
/// out of every other number's placing).
fn place_labels(markers: &[(f64, f64)], texts: &[String], plot: &Rect) -> Vec<Option<Rect>> {
    let on_plot: Vec<usize> = (0..markers.len())
        .filter(|&i| plot.contains(markers[i].0, markers[i].1))
        .collect();
    if on_plot.len() < markers.len() {
        let kept: Vec<(f64, f64)> = on_plot.iter().map(|&i| markers[i]).collect();
        let kept_texts: Vec<String> = on_plot.iter().map(|&i| texts[i].clone()).collect();
        let mut labels = vec![None; markers.len()];
        for (&i, label) in on_plot.iter().zip(place_labels(&kept, &kept_texts, plot)) {
            labels[i] = label;
        }
        return labels;
    }
    let covered: Vec<Rect> = markers
        .iter()
        .map(|&(x, y)| Rect::around(x, y, MARKER_RADIUS + 1.0))
        .collect();
    let mut placed: Vec<Rect> = Vec::with_capacity(markers.len());
    // Each leader line with the marker it starts from.
    let mut leaders: Vec<(usize, [(f64, f64); 2])> = Vec::new();
    let mut labels = Vec::with_capacity(markers.len());
    let blob = blobs(markers);
    for (own, (&(x, y), text)) in markers.iter().zip(texts).enumerate() {
        let size = text_box(0.0, 0.0, text);
        let (w, h) = (size.x1 - size.x0, size.y1 - size.y0);
        let own_blob: Vec<Rect> = (0..markers.len())
            .filter(|&other| blob[other] == blob[own])
            .map(|other| covered[other])
            .collect();
        let fits = |spot: &Rect, rule: Rule| {
            let padded = spot.grown(CLEARANCE);
            if !spot.inside(plot)
                || covered.iter().any(|marker| marker.overlaps(&padded))
                || placed.iter().any(|label| label.overlaps(&padded))
            {
                return false;
            }
            if rule == Rule::Free {
                return true;
            }
            if leaders.iter().any(|&(_, line)| segment_enters(&padded, line)) {
                return false;
            }
            let line = leader(x, y, spot);
            if let Some(line) = line {
                let crosses_marker = covered
                    .iter()
                    .enumerate()
                    .any(|(other, marker)| blob[other] != blob[own] && segment_enters(marker, line));
                if crosses_marker
                    || placed.iter().any(|label| segment_enters(label, line))
                    || leaders.iter().any(|&(from, other)| {
                        let hidden = if blob[from] == blob[own] { &own_blob[..] } else { &[] };
                        leaders_cross(other, line, hidden)
                    })
                {
                    return false;
                }
            }
            (rule == Rule::CleanLeader && line.is_some()) || {
                let distance = |&(mx, my): &(f64, f64)| {
                    let (nx, ny) = spot.nearest(mx, my);
                    (nx - mx).hypot(ny - my)
                };
                let mine = distance(&(x, y));
                markers.iter().enumerate().all(|(other, &(mx, my))| {
                    other == own || (mx - x).hypot(my - y) < MARKER_RADIUS || distance(&(mx, my)) > mine
                })
            }
        };
        let spot = [Rule::Nearest, Rule::CleanLeader, Rule::Free]
            .into_iter()
            .find_map(|rule| candidate_spots(x, y, w, h, plot).find(|spot| fits(spot, rule)));
        if let Some(spot) = spot {
            placed.push(spot);
            leaders.extend(leader(x, y, &spot).map(|line| (own, line)));
        }
        labels.push(spot);
    }
    labels
}

/// Why `point` has no place on a log–log chart whose y values below `floor` are drawn on it
/// (the legend's note), or `None` where it has one: a log axis holds only finite values above 0.
fn off_log_axes(point: &Point, x_label: &str, y_label: &str, floor: f64) -> Option<String> {
    let (label, value) = if !Scale::Log.holds(point.x) {
        (x_label, point.x)
    } else if point.y.is_nan() || !Scale::Log.holds(point.y.max(floor)) {
        (y_label, point.y)
    } else {
        return None;
    };
    Some(format!(
        " (not drawn: its {label} is {value}, and a log axis holds only finite values above 0)"
    ))
}

/// Log–log chart of numbered `points`, each in its colour, with a legend of their labels;
/// values below `floor` on y are drawn at `floor`. A point with a value a log axis cannot hold
/// (0, negative, infinite, NaN) is not drawn, and its legend row says why.
pub fn scatter(title: &str, x_label: &str, y_label: &str, points: &[Point], floor: f64) -> String {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let mut axes = Axes::new(title, (x_label, y_label), &xs, &ys, floor, (Scale::Log, Scale::Log));
    let left_off: Vec<Option<String>> = points
        .iter()
        .map(|p| off_log_axes(p, x_label, y_label, floor))
        .collect();
    // A point left off has no marker: NaN keeps it out of the numbers' placing.
    let markers: Vec<(f64, f64)> = points
        .iter()
        .zip(&left_off)
        .map(|(p, off)| match off {
            None => (axes.x(p.x), axes.y(p.y)),
            Some(_) => (f64::NAN, f64::NAN),
        })
        .collect();
    let numbers: Vec<String> = (1..=points.len()).map(|n| n.to_string()).collect();
    let labels = place_labels(&markers, &numbers, &axes.plot());
    for ((p, &(x, y)), off) in points.iter().zip(&markers).zip(&left_off) {
        if off.is_some() {
            continue;
        }
        let _ = writeln!(
            axes.svg,
            r#"<circle class="marker" cx="{x:.1}" cy="{y:.1}" r="{MARKER_RADIUS}" fill="{}" fill-opacity="0.85"/>"#,
            p.colour
        );
    }
    for ((number, label), &(x, y)) in numbers.iter().zip(&labels).zip(&markers) {
        let Some(label) = label else { continue };
        if let Some([_, (nx, ny)]) = leader(x, y, label) {
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
        let note = match (&left_off[i], labels[i]) {
            (Some(why), _) => why,
            (None, None) => " (no room to number it on the plot)",
            (None, Some(_)) => "",
        };
        axes.legend(i, &swatch, &format!("{}: {}{note}", i + 1, p.label));
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
/// `floor` on y are drawn at `floor` (give −∞ for none on a linear axis). A point an axis
/// cannot hold ([`Scale::holds`]: NaN, ±∞, and 0 or below on a log axis) is not drawn, its
/// line is broken there, and its series' legend row says how many were left out.
pub fn lines_on(scales: (Scale, Scale), title: &str, labels: (&str, &str), series: &[Series], floor: f64) -> String {
    let xs: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
    let ys: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).collect();
    let mut axes = Axes::new(title, labels, &xs, &ys, floor, scales);
    let held = |&(x, y): &(f64, f64)| scales.0.holds(x) && !y.is_nan() && scales.1.holds(y.max(floor));
    for (i, s) in series.iter().enumerate() {
        for run in s.points.split(|p| !held(p)).filter(|run| !run.is_empty()) {
            let path: Vec<String> = run
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
            for &(x, y) in run {
                let marker = series_marker(s, axes.x(x), axes.y(y));
                axes.svg += &marker;
                axes.svg += "\n";
            }
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
        let left_out = s.points.iter().filter(|p| !held(p)).count();
        let text = match left_out {
            0 => s.label.clone(),
            n => format!(
                "{} ({n} point{} not drawn: an axis holds only finite values, and a log axis only those above 0)",
                s.label,
                if n == 1 { "" } else { "s" }
            ),
        };
        axes.legend(i, &swatch, &text);
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
    use rand::{Rng, SeedableRng};

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

    /// The plot of every [`scatter`] chart.
    const PLOT: Rect = Rect {
        x0: LEFT,
        y0: TOP,
        x1: WIDTH - RIGHT,
        y1: HEIGHT - BOTTOM,
    };

    /// Asserts that every placed number lies inside `plot`, off every marker and every other
    /// number. With `strict`, also that a number without a leader line is nearer its own
    /// marker than any other a reader can tell from it, and that leader lines cross no other
    /// marker outside their own's blob, no number and no other leader.
    fn assert_readable(markers: &[(f64, f64)], labels: &[Option<Rect>], plot: &Rect, strict: bool) {
        assert_eq!(labels.len(), markers.len());
        let discs: Vec<Rect> = markers
            .iter()
            .map(|&(x, y)| Rect::around(x, y, MARKER_RADIUS))
            .collect();
        let blob = blobs(markers);
        let leaders: Vec<Option<[(f64, f64); 2]>> = markers
            .iter()
            .zip(labels)
            .map(|(&(x, y), label)| label.as_ref().and_then(|label| leader(x, y, label)))
            .collect();
        for (i, (&(x, y), label)) in markers.iter().zip(labels).enumerate() {
            let Some(label) = label else { continue };
            assert!(label.inside(plot), "label {} leaves the plot: {label:?}", i + 1);
            assert!(
                !discs.iter().any(|m| m.overlaps(label)),
                "label {} covers a marker",
                i + 1
            );
            for (j, other) in labels.iter().enumerate().skip(i + 1) {
                if let Some(other) = other {
                    assert!(!label.overlaps(other), "labels {} and {} overlap", i + 1, j + 1);
                }
            }
            if !strict {
                continue;
            }
            if let Some(line) = leaders[i] {
                for j in 0..markers.len() {
                    assert!(
                        blob[j] == blob[i] || !segment_enters(&discs[j], line),
                        "leader {} crosses marker {}",
                        i + 1,
                        j + 1
                    );
                    if let Some(other) = labels[j].filter(|_| j != i) {
                        assert!(
                            !segment_enters(&other, line),
                            "leader {} crosses label {}",
                            i + 1,
                            j + 1
                        );
                    }
                    if let Some(other) = leaders[j].filter(|_| j != i) {
                        let hidden: Vec<Rect> = (0..markers.len())
                            .filter(|&k| blob[j] == blob[i] && blob[k] == blob[i])
                            .map(|k| Rect::around(markers[k].0, markers[k].1, MARKER_RADIUS + 1.0))
                            .collect();
                        assert!(
                            !leaders_cross(other, line, &hidden),
                            "leaders {} and {} cross",
                            i + 1,
                            j + 1
                        );
                    }
                }
            } else {
                // Nearer its own marker than any other a reader can tell from it.
                let distance = |(mx, my): (f64, f64)| {
                    let (nx, ny) = label.nearest(mx, my);
                    (nx - mx).hypot(ny - my)
                };
                for (j, &other) in markers.iter().enumerate() {
                    if j != i && (other.0 - x).hypot(other.1 - y) >= MARKER_RADIUS {
                        assert!(
                            distance(other) > distance((x, y)),
                            "label {} is nearer point {}",
                            i + 1,
                            j + 1
                        );
                    }
                }
            }
        }
    }

    /// Points measured close together (equal error, times within a few per cent) get numbers
    /// that cover neither each other nor any marker: in docs/speed-accuracy.svg 6, 11 and 3
    /// printed as "6113", and with the 2026-11-26 figures 3 and 11 printed over each other.
    /// Checked on the SVG drawn from the shipped figures and from eight points at one spot.
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
            let labels: Vec<Option<Rect>> = elements(&svg, "<text class=\"label\"")
                .iter()
                .map(|e| {
                    let text = &e[e.find('>').unwrap() + 1..e.find("</text>").unwrap()];
                    Some(text_box(number(e, "x"), number(e, "y"), text))
                })
                .collect();
            let markers: Vec<(f64, f64)> = elements(&svg, "<circle class=\"marker\"")
                .iter()
                .map(|e| (number(e, "cx"), number(e, "cy")))
                .collect();
            assert_eq!(labels.len(), points.len());
            assert_readable(&markers, &labels, &PLOT, true);
            let leaders = markers
                .iter()
                .zip(&labels)
                .filter(|&(&(x, y), label)| leader(x, y, label.as_ref().unwrap()).is_some())
                .count();
            assert_eq!(elements(&svg, "<line class=\"leader\"").len(), leaders);
        }
    }

    /// Point sets that left the placer of the 2026-11-26 session without a free spot near
    /// the marker (it then printed the number above-right: over other numbers, over markers or
    /// outside the plot; or its leader lines crossed): many points at one spot, points at the
    /// plot's corners, rows of points 5 px apart along its edges, a jittered crowd, and three
    /// points 0, 5 and 15 px apart as 6, 11 and 3 were. Every number is placed and readable by
    /// the strict rules. Crowds twice as large leave no clean leader line for some numbers:
    /// those still cover no marker and no other number.
    #[test]
    fn crowds_and_edges_keep_numbers_apart() {
        let centre = ((PLOT.x0 + PLOT.x1) / 2.0, (PLOT.y0 + PLOT.y1) / 2.0);
        let corners = [
            (PLOT.x0, PLOT.y0),
            (PLOT.x1, PLOT.y0),
            (PLOT.x0, PLOT.y1),
            (PLOT.x1, PLOT.y1),
        ];
        let edge_rows = |count: u32| -> Vec<(f64, f64)> {
            (0..count)
                .map(|i| (PLOT.x0 + 5.0 * f64::from(i), PLOT.y0))
                .chain((0..count).map(|i| (PLOT.x1, PLOT.y1 - 5.0 * f64::from(i))))
                .collect()
        };
        // Seeded: the same crowds every run.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(26);
        let mut crowd = |count: usize| -> Vec<(f64, f64)> {
            (0..count)
                .map(|_| {
                    (
                        centre.0 + rng.random_range(-8.0..8.0),
                        centre.1 + rng.random_range(-8.0..8.0),
                    )
                })
                .collect()
        };
        let readable: Vec<Vec<(f64, f64)>> = vec![
            vec![centre; 30],
            corners.iter().flat_map(|&c| [c; 12]).collect(),
            edge_rows(8),
            crowd(20),
            vec![
                (300.0, 200.0),
                (305.0, 200.0),
                (285.0, 200.0),
                (300.0, 200.0),
                (320.0, 201.0),
            ],
        ];
        let crowded = vec![vec![centre; 60], edge_rows(20), crowd(40)];
        for (markers, strict) in readable
            .into_iter()
            .map(|m| (m, true))
            .chain(crowded.into_iter().map(|m| (m, false)))
        {
            let texts: Vec<String> = (1..=markers.len()).map(|n| n.to_string()).collect();
            let labels = place_labels(&markers, &texts, &PLOT);
            assert!(labels.iter().all(Option::is_some), "a number found no spot");
            assert_readable(&markers, &labels, &PLOT, strict);
        }
    }

    /// A plot too small for every number: those placed still cover no marker and no other
    /// number; the rest are left off.
    #[test]
    fn an_overfull_plot_leaves_numbers_off_rather_than_overlapping() {
        let plot = Rect {
            x0: 100.0,
            y0: 100.0,
            x1: 160.0,
            y1: 140.0,
        };
        let markers = vec![(130.0, 120.0); 30];
        let texts: Vec<String> = (1..=markers.len()).map(|n| n.to_string()).collect();
        let labels = place_labels(&markers, &texts, &plot);
        assert!(labels.iter().any(Option::is_none) && labels.iter().any(Option::is_some));
        assert_readable(&markers, &labels, &plot, false);
    }

    /// Markers at infinite or NaN positions (a `Point` at x or y = +∞ reaches the placer so)
    /// get no number, and leave the finite ones theirs: the placer's rings around such a marker
    /// never ended.
    #[test]
    fn markers_off_the_plot_or_not_finite_get_no_number() {
        let markers = [
            (f64::INFINITY, 200.0),
            (300.0, f64::INFINITY),
            (f64::NAN, f64::NAN),
            (f64::NEG_INFINITY, 200.0),
            (LEFT - 50.0, 200.0),
            (300.0, 200.0),
        ];
        let texts: Vec<String> = (1..=markers.len()).map(|n| n.to_string()).collect();
        let labels = place_labels(&markers, &texts, &PLOT);
        assert!(labels[..5].iter().all(Option::is_none), "{labels:?}");
        assert_readable(&markers[5..], &labels[5..], &PLOT, true);
        assert!(labels[5].is_some());
    }

    /// Points at x or y = +∞, x = 0 or below, y = NaN are not drawn and their legend rows say
    /// why; the others are drawn and numbered, and the axes keep to the finite positive values
    /// (log10(0) = −∞ made the decades run from `i32::MIN`).
    #[test]
    fn points_a_log_axis_cannot_hold_are_left_off_with_a_reason() {
        let points = vec![
            point("infinite x", f64::INFINITY, 0.5, "red"),
            point("infinite y", 3.0, f64::INFINITY, "red"),
            point("zero x", 0.0, 0.5, "red"),
            point("negative x", -2.0, 0.5, "red"),
            point("NaN y", 3.0, f64::NAN, "red"),
            point("drawn", 3.0, 0.5, "blue"),
        ];
        let svg = scatter("t", "time", "error", &points, 1e-3);
        let markers = elements(&svg, "<circle class=\"marker\"");
        assert_eq!(markers.len(), 1);
        assert_eq!(attribute(markers[0], "fill"), "blue");
        assert_eq!(elements(&svg, "<text class=\"label\"").len(), 1);
        let legend = elements(&svg, "<g class=\"legend\">");
        for (row, why) in legend
            .iter()
            .zip(["time is inf", "error is inf", "time is 0", "time is -2", "error is NaN"])
        {
            assert!(
                row.contains(&format!(
                    "(not drawn: its {why}, and a log axis holds only finite values above 0)"
                )),
                "{row}"
            );
        }
        assert!(!legend[5].contains("not drawn") && !legend[5].contains("no room"));
        // x spans one decade, 1..10, around the one point drawn: two grid lines.
        assert_eq!(svg.matches(r#"text-anchor="middle">1</text>"#).count(), 1);
        assert_eq!(svg.matches(r#"text-anchor="middle">10</text>"#).count(), 1);
        assert!(!svg.contains("inf\"") && !svg.contains("NaN\""));
    }

    /// The placer's geometry against closed forms, on the box (0, 0)–(10, 10).
    #[test]
    fn a_segment_enters_a_box_only_through_its_inside() {
        let square = Rect {
            x0: 0.0,
            y0: 0.0,
            x1: 10.0,
            y1: 10.0,
        };
        let enters = |a: (f64, f64), b: (f64, f64)| segment_enters(&square, [a, b]) && segment_enters(&square, [b, a]);
        assert!(enters((-5.0, 5.0), (15.0, 5.0)), "straight through");
        assert!(enters((-5.0, -4.0), (15.0, 14.0)), "through, slanted");
        assert!(enters((-5.0, 5.0), (5.0, 5.0)), "ending inside");
        assert!(enters((2.0, 2.0), (3.0, 8.0)), "wholly inside");
        assert!(!enters((-5.0, 0.0), (15.0, 0.0)), "along an edge");
        assert!(!enters((-5.0, 5.0), (5.0, -5.0)), "touching a corner");
        assert!(!enters((-5.0, 5.0), (0.0, 5.0)), "ending on an edge");
        assert!(!enters((-5.0, 15.0), (15.0, 15.0)), "parallel, outside");
        assert!(
            !enters((-5.0, -5.0), (-5.0, 15.0)),
            "parallel to the other side, outside"
        );
        assert!(!enters((12.0, -20.0), (30.0, 5.0)), "slanted, missing");
    }

    /// Two leader lines cross only at a point inside both, seen outside the markers hidden.
    #[test]
    fn leaders_cross_only_in_their_insides() {
        let diagonal = [(0.0, 0.0), (10.0, 10.0)];
        let cross = |other: [(f64, f64); 2], hidden: &[Rect]| {
            let one = leaders_cross(diagonal, other, hidden);
            assert_eq!(one, leaders_cross(other, diagonal, hidden), "{other:?}");
            one
        };
        assert!(cross([(0.0, 10.0), (10.0, 0.0)], &[]), "an X");
        assert!(
            !cross([(0.0, 10.0), (10.0, 0.0)], &[Rect::around(5.0, 5.0, 1.0)]),
            "an X under a marker"
        );
        assert!(
            cross([(0.0, 10.0), (10.0, 0.0)], &[Rect::around(2.0, 2.0, 1.0)]),
            "an X beside a marker"
        );
        assert!(!cross([(0.0, 0.0), (10.0, 0.0)], &[]), "a shared end");
        assert!(!cross([(5.0, 5.0), (10.0, 0.0)], &[]), "one's end on the other");
        assert!(!cross([(0.0, 10.0), (4.0, 6.0)], &[]), "short of the other");
        assert!(!cross([(1.0, 0.0), (11.0, 10.0)], &[]), "parallel");
        assert!(!cross([(2.0, 2.0), (8.0, 8.0)], &[]), "overlapping on one line");
    }

    /// Blobs: markers joined through a chain of overlapping discs (centres nearer than
    /// 2 × (radius + 1) = 12), each labelled with its chain's smallest index, in any order.
    #[test]
    fn blobs_join_chains_in_any_order() {
        let chain = |xs: &[f64]| blobs(&xs.iter().map(|&x| (x, 50.0)).collect::<Vec<_>>());
        assert_eq!(
            chain(&[40.0, 30.0, 20.0, 10.0, 0.0, 200.0]),
            [0, 0, 0, 0, 0, 5],
            "reversed"
        );
        assert_eq!(chain(&[20.0, 0.0, 40.0, 10.0, 30.0]), [0; 5], "shuffled");
        assert_eq!(
            chain(&[100.0, 0.0, 10.0, 90.0, 50.0]),
            [0, 1, 1, 0, 4],
            "two chains and one alone"
        );
        assert_eq!(chain(&[0.0, 11.5, 23.5]), [0, 0, 2], "12 apart is not overlapping");
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

    /// Points an axis cannot hold (x = 0 or below and y = NaN on log axes, ±∞ on any) are
    /// left out: no "inf" or "NaN" coordinate reaches the SVG, the line breaks there, and the
    /// legend counts them; y = 0 is still drawn on the floor.
    #[test]
    fn lines_leave_out_points_an_axis_cannot_hold() {
        let series = |points: Vec<(f64, f64)>| Series {
            label: "s".into(),
            colour: "red".into(),
            dash: String::new(),
            marker: Marker::Disc,
            points,
        };
        let log = lines(
            "t",
            "x",
            "y",
            &[series(vec![
                (1.0, 0.1),
                (0.0, 0.5),
                (10.0, 0.0),
                (100.0, f64::NAN),
                (1000.0, 1.0),
            ])],
            1e-3,
        );
        let linear = lines_on(
            (Scale::Linear, Scale::Linear),
            "t",
            ("x", "y"),
            &[series(vec![(1.0, 1.0), (2.0, f64::INFINITY), (3.0, 2.0), (4.0, 3.0)])],
            f64::NEG_INFINITY,
        );
        for (svg, polylines, markers, left_out) in [(&log, 3, 3, "2 points"), (&linear, 2, 3, "1 point ")] {
            assert!(!svg.to_lowercase().contains("inf") && !svg.contains("NaN"), "{svg}");
            assert_eq!(svg.matches("<polyline").count(), polylines, "{svg}");
            assert_eq!(elements(svg, "<circle class=\"marker\"").len(), markers + 1, "{svg}");
            let legend = elements(svg, "<g class=\"legend\">");
            assert!(legend[0].contains(&format!("({left_out}")), "{}", legend[0]);
        }
        assert!(
            log.contains(&format!("cy=\"{:.1}\"", HEIGHT - BOTTOM)),
            "y = 0 on the floor: {log}"
        );
    }
}
