//! A bird's-eye picture of a data set (the reference paper's Fig. 7): the scene's faces seen
//! from above in their colours, its extent and a scale bar, every set's poses and headings,
//! the occluders, the point lights, and the poses left out, as SVG and as PNG.
//!
//! The SVG is written by hand: it is a few dozen kinds of element with fixed attributes, and
//! the elements carry `class` and `data-*` attributes that tests and users can select on,
//! which a drawing crate would hide. The PNG is that same SVG rasterised by `resvg`, with the
//! system's fonts for the labels (shapes do not depend on fonts).

use std::fmt::Write;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};

use super::occluders::Occluder;
use super::spec::LightChange;
use super::{Dataset, DatasetError};
use omnisim::scene::lighting::LightKind;

/// One colour per set, in spec order (matplotlib's "tab10", distinct for colour-blind eyes
/// too); sets beyond ten reuse them.
const SET_COLOURS: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];
/// Colour of the crosses at skipped poses.
const SKIPPED_COLOUR: &str = "rgb(230,0,0)";
/// Largest size of the floor plan in the picture, pixels.
const PLAN_SIZE: (f64, f64) = (900.0, 640.0);
/// Room left around the plan: title above, dimensions and scale bar below, legend right.
const MARGIN: Margin = Margin {
    left: 70.0,
    top: 60.0,
    right: 330.0,
    bottom: 90.0,
};
/// Poses drawn per set at most; larger sets show this many, evenly spread.
const MAX_DRAWN: usize = 5000;
/// Length of a heading arrow, metres.
const ARROW_LENGTH: f64 = 0.18;
/// Radius of a pose's disc, pixels.
const POSE_RADIUS: f64 = 3.5;

struct Margin {
    left: f64,
    top: f64,
    right: f64,
    bottom: f64,
}

/// Where a world point (x, y) falls in the picture: x to the right, y up, metres to pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanView {
    /// World (x, y) of the plan's top-left corner, metres.
    pub corner: DVec2,
    /// Pixels per metre.
    pub scale: f64,
    /// Picture size, pixels.
    pub size: (u32, u32),
}

impl PlanView {
    /// Fits the floor-plan rectangle `low`–`high` (metres) into the picture.
    fn fit(low: DVec2, high: DVec2) -> Self {
        let extent = (high - low).max(DVec2::splat(1e-3));
        let scale = (PLAN_SIZE.0 / extent.x).min(PLAN_SIZE.1 / extent.y);
        let size = (
            (MARGIN.left + extent.x * scale + MARGIN.right).ceil() as u32,
            (MARGIN.top + extent.y * scale + MARGIN.bottom).ceil().max(420.0) as u32,
        );
        Self {
            corner: DVec2::new(low.x, high.y),
            scale,
            size,
        }
    }

    /// Picture position (pixels, y down) of the world point (x, y).
    pub fn to_picture(&self, world: DVec2) -> DVec2 {
        DVec2::new(
            MARGIN.left + (world.x - self.corner.x) * self.scale,
            MARGIN.top + (self.corner.y - world.y) * self.scale,
        )
    }
}

/// The drawing, as SVG text, with the transform that placed it.
#[derive(Debug, Clone)]
pub struct Preview {
    /// The SVG document.
    pub svg: String,
    /// World to picture.
    pub view: PlanView,
    /// Poses drawn (every set's; at most 5000 per set, evenly spread, for larger sets).
    pub poses: usize,
    /// Skipped poses marked.
    pub skipped: usize,
}

/// Draws the bird's-eye picture of `dataset`. Per-frame occluders are placed as the run
/// places them (the same streams), so the picture shows the occluders the frames will have.
pub fn draw(dataset: &Dataset) -> Result<Preview, DatasetError> {
    let scene = &dataset.scene;
    let (low, high) = scene.bounds().unwrap_or((DVec3::splat(-1.0), DVec3::splat(1.0)));
    let mut plan_low = low.truncate();
    let mut plan_high = high.truncate();
    for set in &dataset.sets {
        let positions = set.poses.iter().map(|p| p.position);
        let skipped = set.skipped.iter().map(|s| DVec3::from(s.position));
        let moved = set.spec.lights.iter().filter_map(|change| match change {
            LightChange::Move { position, .. } => Some(DVec3::from(*position)),
            _ => None,
        });
        for p in positions.chain(skipped).chain(moved) {
            plan_low = plan_low.min(p.truncate());
            plan_high = plan_high.max(p.truncate());
        }
    }
    let view = PlanView::fit(plan_low, plan_high);
    let mut svg = Svg::new(view);
    svg.title(dataset);
    svg.faces(dataset, high.z);
    svg.dimensions(low.truncate(), high.truncate(), plan_low);
    let mut legend = Vec::new();
    // The frames drawn: all, or an even spread of a large set's (the picture stays readable
    // and its size bounded).
    let drawn: Vec<Vec<usize>> = dataset
        .sets
        .iter()
        .map(|set| super::evenly_spread(set.poses.len(), MAX_DRAWN))
        .collect();
    for (s, set) in dataset.sets.iter().enumerate() {
        let per_frame: Vec<Vec<Occluder>> = drawn[s]
            .iter()
            .map(|&i| dataset.frame_occluders(s, i))
            .collect::<Result<_, _>>()?;
        let colour = set_colour(s);
        svg.occluders(&set.spec.name, &colour, per_frame.iter().flatten(), true);
        svg.occluders(&set.spec.name, &colour, &set.occluders, false);
        legend.push(per_frame.iter().any(|o| !o.is_empty()) || !set.occluders.is_empty());
    }
    for (s, set) in dataset.sets.iter().enumerate() {
        let colour = set_colour(s);
        for &i in &drawn[s] {
            let pose = &set.poses[i];
            let heading = pose.world_from_body_rotation() * DVec3::X;
            svg.pose(&set.spec.name, i, pose.position.truncate(), heading.truncate(), &colour);
        }
    }
    svg.lights(dataset);
    for (s, set) in dataset.sets.iter().enumerate() {
        svg.moved_lights(dataset, &set.spec.name, &set_colour(s), &set.spec.lights);
    }
    // Crosses last: a skipped pose is what the user must not miss.
    for set in &dataset.sets {
        for skip in &set.skipped {
            svg.skipped(&set.spec.name, skip);
        }
    }
    let poses = drawn.iter().map(Vec::len).sum();
    let skipped = dataset.sets.iter().map(|s| s.skipped.len()).sum();
    svg.legend(dataset, &legend, skipped);
    Ok(Preview {
        svg: svg.finish(),
        view,
        poses,
        skipped,
    })
}

impl Preview {
    /// The picture rasterised at one pixel per SVG unit, as PNG bytes.
    pub fn png(&self) -> Result<Vec<u8>, DatasetError> {
        rasterise(&self.svg, Some(self.view.size))
    }

    /// Writes `PREFIX.svg` and `PREFIX.png` (each atomically, the PNG drawn before either is
    /// written, so a failure leaves neither new); returns their paths.
    pub fn write(&self, prefix: &Path) -> Result<[PathBuf; 2], DatasetError> {
        let [svg, png] = Self::paths(prefix);
        let png_bytes = self.png()?;
        super::files::write_file(&svg, self.svg.as_bytes())?;
        super::files::write_file(&png, &png_bytes)?;
        Ok([svg, png])
    }

    /// `PREFIX.svg` and `PREFIX.png`.
    pub fn paths(prefix: &Path) -> [PathBuf; 2] {
        ["svg", "png"].map(|extension| {
            let mut name = prefix.as_os_str().to_owned();
            name.push(format!(".{extension}"));
            PathBuf::from(name)
        })
    }

    /// Whether an SVG file's first bytes are a preview's, so that a new preview may replace it
    /// (and its PNG) where it would not replace a user's own picture.
    pub fn wrote(svg_start: &[u8]) -> bool {
        let text = String::from_utf8_lossy(svg_start);
        let mut lines = text.lines();
        lines.next().is_some_and(|first| first.starts_with(SVG_OPENING)) && lines.next() == Some(SVG_BACKGROUND)
    }
}

/// A preview's first line's start and its second line.
const SVG_OPENING: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width=""#;
const SVG_BACKGROUND: &str = r#"<rect width="100%" height="100%" fill="white"/>"#;

/// An SVG drawing as PNG bytes, one pixel per SVG unit, at `size` (width, height) or the
/// drawing's own size; text in the system's fonts.
pub fn rasterise(svg: &str, size: Option<(u32, u32)>) -> Result<Vec<u8>, DatasetError> {
    let mut options = resvg::usvg::Options::default();
    let fonts = options.fontdb_mut();
    fonts.load_system_fonts();
    // `sans-serif` means Arial to usvg; where there is none, a sans-serif face that is there.
    let installed = |family: &str| fonts.faces().any(|f| f.families.iter().any(|(name, _)| name == family));
    if let Some(family) = ["Arial", "DejaVu Sans", "Liberation Sans", "Noto Sans"]
        .into_iter()
        .find(|f| installed(f))
    {
        fonts.set_sans_serif_family(family);
    }
    let picture = |e: String| DatasetError::Picture(e);
    let tree = resvg::usvg::Tree::from_str(svg, &options).map_err(|e| picture(e.to_string()))?;
    let own = tree.size().to_int_size();
    let (width, height) = size.unwrap_or((own.width(), own.height()));
    let mut pixmap = resvg::tiny_skia::Pixmap::new(width, height)
        .ok_or_else(|| picture(format!("{width}×{height} is not a picture size")))?;
    resvg::render(&tree, resvg::tiny_skia::Transform::identity(), &mut pixmap.as_mut());
    pixmap.encode_png().map_err(|e| picture(e.to_string()))
}

fn set_colour(set: usize) -> String {
    let [r, g, b] = SET_COLOURS[set % SET_COLOURS.len()];
    format!("rgb({r},{g},{b})")
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The SVG document being built, in drawing order (later elements on top).
struct Svg {
    text: String,
    view: PlanView,
}

impl Svg {
    fn new(view: PlanView) -> Self {
        let (w, h) = view.size;
        let mut text = String::new();
        let _ = writeln!(
            text,
            r#"{SVG_OPENING}{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="DejaVu Sans, sans-serif" font-size="13">"#
        );
        let _ = writeln!(text, "{SVG_BACKGROUND}");
        Self { text, view }
    }

    fn at(&self, world: DVec2) -> DVec2 {
        self.view.to_picture(world)
    }

    fn title(&mut self, dataset: &Dataset) {
        let spec = dataset
            .spec_path
            .file_name()
            .map(|n| n.to_string_lossy())
            .unwrap_or_default();
        let _ = writeln!(
            self.text,
            r#"<text x="{}" y="30" font-size="17">{} — scene '{}', seen from above</text>"#,
            MARGIN.left,
            escape(&spec),
            escape(&dataset.scene.name)
        );
    }

    /// Faces from above in order of their highest point, so that higher faces cover lower
    /// ones; the horizontal faces at the scene's top (the ceiling) are left out. Vertical
    /// faces (walls, sides) are seen edge-on: drawn as thick lines, darker.
    fn faces(&mut self, dataset: &Dataset, top: f64) {
        let scene = &dataset.scene;
        let mut order: Vec<usize> = (0..scene.faces.len()).collect();
        let highest = |f: usize| scene.faces[f].vertices.iter().map(|v| v.z).fold(f64::MIN, f64::max);
        order.sort_by(|&a, &b| highest(a).total_cmp(&highest(b)).then(a.cmp(&b)));
        let _ = writeln!(self.text, r#"<g class="faces" stroke-linejoin="round">"#);
        for f in order {
            let face = &scene.faces[f];
            let normal = scene.face_normal(f);
            let [r, g, b] = face.colour;
            let points: Vec<DVec2> = face.vertices.iter().map(|v| self.at(v.truncate())).collect();
            let object = escape(&scene.objects[face.object as usize].name);
            if normal.z.abs() < 1e-6 {
                let (first, last) = farthest_pair(&points);
                let dark = |c: u8| (f64::from(c) * 0.6) as u8;
                let _ = writeln!(
                    self.text,
                    r#"<line class="face" data-object="{object}" x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="rgb({},{},{})" stroke-width="3" stroke-linecap="round"/>"#,
                    first.x,
                    first.y,
                    last.x,
                    last.y,
                    dark(r),
                    dark(g),
                    dark(b)
                );
                continue;
            }
            let lowest = face.vertices.iter().map(|v| v.z).fold(f64::MAX, f64::min);
            if lowest >= top - 1e-6 {
                continue;
            }
            let _ = writeln!(
                self.text,
                r#"<polygon class="face" data-object="{object}" points="{}" fill="rgb({r},{g},{b})" stroke="rgb(90,90,90)" stroke-width="0.6"/>"#,
                polygon_points(&points)
            );
        }
        let _ = writeln!(self.text, "</g>");
    }

    /// Dimension lines under and left of the room, with its extent in metres, and a scale bar.
    fn dimensions(&mut self, low: DVec2, high: DVec2, plan_low: DVec2) {
        let (a, b) = (
            self.at(DVec2::new(low.x, plan_low.y)),
            self.at(DVec2::new(high.x, plan_low.y)),
        );
        let y = a.y + 22.0;
        let _ = writeln!(
            self.text,
            r#"<g class="dimensions" stroke="black" fill="black"><line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}"/><line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}"/><line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}"/><text stroke="none" x="{:.2}" y="{:.2}" text-anchor="middle">{:.2} m</text>"#,
            a.x,
            b.x,
            a.x,
            y - 5.0,
            a.x,
            y + 5.0,
            b.x,
            y - 5.0,
            b.x,
            y + 5.0,
            (a.x + b.x) / 2.0,
            y + 17.0,
            high.x - low.x
        );
        let (c, d) = (self.at(DVec2::new(low.x, low.y)), self.at(DVec2::new(low.x, high.y)));
        let x = MARGIN.left - 22.0;
        let _ = writeln!(
            self.text,
            r#"<line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}"/><line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}"/><line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}"/><text stroke="none" transform="translate({:.2} {:.2}) rotate(-90)" text-anchor="middle">{:.2} m</text>"#,
            c.y,
            d.y,
            x - 5.0,
            c.y,
            x + 5.0,
            c.y,
            x - 5.0,
            d.y,
            x + 5.0,
            d.y,
            x - 8.0,
            (c.y + d.y) / 2.0,
            high.y - low.y
        );
        // A round length near a fifth of the room, with its ends marked.
        let metres = scale_bar_length((high.x - low.x) / 5.0);
        let start = DVec2::new(MARGIN.left, y + 45.0);
        let end = start.x + metres * self.view.scale;
        let _ = writeln!(
            self.text,
            r#"<g class="scale-bar"><rect x="{:.2}" y="{:.2}" width="{:.2}" height="6" fill="black"/><text stroke="none" x="{:.2}" y="{:.2}">{} m</text></g></g>"#,
            start.x,
            start.y,
            end - start.x,
            end + 8.0,
            start.y + 7.0,
            metres
        );
    }

    /// Occluders' footprints: per-set ones filled in their colour, per-frame ones (a few per
    /// frame, many per set) as light outlines in the set's colour.
    fn occluders<'a>(
        &mut self,
        set: &str,
        colour: &str,
        occluders: impl IntoIterator<Item = &'a Occluder>,
        per_frame: bool,
    ) {
        for occluder in occluders {
            let points = polygon_points(&occluder.footprint.iter().map(|&p| self.at(p)).collect::<Vec<_>>());
            let [r, g, b] = occluder.colour;
            let _ = if per_frame {
                writeln!(
                    self.text,
                    r#"<polygon class="occluder per-frame" data-set="{set}" points="{points}" fill="none" stroke="{colour}" stroke-opacity="0.45" stroke-width="0.8"/>"#
                )
            } else {
                writeln!(
                    self.text,
                    r#"<polygon class="occluder" data-set="{set}" points="{points}" fill="rgb({r},{g},{b})" fill-opacity="0.8" stroke="black" stroke-width="0.8"/>"#
                )
            };
        }
    }

    /// A disc at the position and an arrow along the body's x axis seen from above.
    fn pose(&mut self, set: &str, frame: usize, position: DVec2, heading: DVec2, colour: &str) {
        let centre = self.at(position);
        let tip = self.at(position + heading * ARROW_LENGTH);
        let _ = write!(
            self.text,
            r#"<g class="pose" data-set="{set}" data-frame="{frame}" fill="{colour}" stroke="{colour}">"#
        );
        if heading.length() > 1e-3 {
            let along = (tip - centre).normalize_or_zero();
            let side = along.perp() * 3.0;
            let base = tip - along * 6.0;
            let _ = write!(
                self.text,
                r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke-width="1.2"/><polygon points="{}" stroke="none"/>"#,
                centre.x,
                centre.y,
                base.x,
                base.y,
                polygon_points(&[tip, base + side, base - side])
            );
        }
        let _ = writeln!(
            self.text,
            r#"<circle class="pose-marker" cx="{:.2}" cy="{:.2}" r="{POSE_RADIUS}" stroke="none"/></g>"#,
            centre.x, centre.y
        );
    }

    fn skipped(&mut self, set: &str, skip: &super::SkippedPose) {
        let p = self.at(DVec2::new(skip.position[0], skip.position[1]));
        let r = 4.5;
        let _ = writeln!(
            self.text,
            r#"<path class="skipped" data-set="{set}" data-source-index="{}" d="M{:.2} {:.2}L{:.2} {:.2}M{:.2} {:.2}L{:.2} {:.2}" stroke="{SKIPPED_COLOUR}" stroke-width="2"><title>{}</title></path>"#,
            skip.source_index,
            p.x - r,
            p.y - r,
            p.x + r,
            p.y + r,
            p.x - r,
            p.y + r,
            p.x + r,
            p.y - r,
            escape(&skip.reason)
        );
    }

    /// Point lights: a yellow sun symbol with the light's name (grey when switched off).
    /// Directional lights: an arrow in the top left corner along the light's travel seen from
    /// above, with its elevation.
    fn lights(&mut self, dataset: &Dataset) {
        let Some(lighting) = &dataset.scene.lighting else {
            return;
        };
        let mut suns = 0;
        for light in &lighting.lights {
            let fill = if light.on { "rgb(255,215,0)" } else { "rgb(190,190,190)" };
            match light.kind {
                LightKind::Point { position, .. } => {
                    let p = self.at(position.truncate());
                    self.sun_symbol(
                        &format!(r#"class="light" data-light="{}""#, escape(&light.name)),
                        p,
                        fill,
                        "black",
                    );
                    self.label(p, &format!("{} ({:.2} m)", light.name, position.z));
                }
                LightKind::Directional { direction, .. } => {
                    self.directional(light, direction, fill, suns);
                    suns += 1;
                }
            }
        }
    }

    /// A sun symbol (cross and disc) at `p`, with `attributes` on its group.
    fn sun_symbol(&mut self, attributes: &str, p: DVec2, fill: &str, stroke: &str) {
        let _ = writeln!(
            self.text,
            r#"<g {attributes}><path d="M{:.2} {:.2}h20M{:.2} {:.2}v20" stroke="{stroke}" stroke-width="1.2"/><circle cx="{:.2}" cy="{:.2}" r="6" fill="{fill}" stroke="{stroke}" stroke-width="1.5"/></g>"#,
            p.x - 10.0,
            p.y,
            p.x,
            p.y - 10.0,
            p.x,
            p.y,
        );
    }

    fn label(&mut self, p: DVec2, text: &str) {
        let _ = writeln!(
            self.text,
            r#"<text x="{:.2}" y="{:.2}" font-size="12">{}</text>"#,
            p.x + 9.0,
            p.y - 8.0,
            escape(text)
        );
    }

    /// Directional light number `k`: an arrow along the horizontal part of its direction of
    /// travel (a disc where it falls straight down), its name and elevation above the horizon.
    fn directional(&mut self, light: &omnisim::scene::lighting::Light, direction: DVec3, fill: &str, k: usize) {
        let origin = DVec2::new(MARGIN.left + 30.0, MARGIN.top + 30.0 + 40.0 * k as f64);
        let across = direction.truncate();
        let elevation = (-direction.z).atan2(across.length()).to_degrees();
        // Picture y grows downwards: world +y is up on the plan.
        let along = DVec2::new(across.x, -across.y).normalize_or_zero() * 22.0;
        let (tail, tip) = (origin - along, origin + along);
        let side = along.normalize_or_zero().perp() * 4.0;
        let base = tip - along.normalize_or_zero() * 8.0;
        let _ = writeln!(
            self.text,
            r#"<g class="light directional" data-light="{name}"><line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="black" stroke-width="2"/><polygon points="{}"/><circle cx="{:.2}" cy="{:.2}" r="5" fill="{fill}" stroke="black"/><text x="{:.2}" y="{:.2}" font-size="12">{name} (directional, {elevation:.0}° up)</text></g>"#,
            tail.x,
            tail.y,
            base.x,
            base.y,
            polygon_points(&[tip, base + side, base - side]),
            tail.x,
            tail.y,
            origin.x + 28.0,
            origin.y + 4.0,
            name = escape(&light.name)
        );
    }

    /// The point lights a set moves: a sun symbol outlined in the set's colour at the new
    /// position, dashed from where the scene has it.
    fn moved_lights(&mut self, dataset: &Dataset, set: &str, colour: &str, changes: &[LightChange]) {
        let lights = dataset
            .scene
            .lighting
            .as_ref()
            .map(|l| l.lights.as_slice())
            .unwrap_or_default();
        for change in changes {
            let LightChange::Move { light, position, .. } = change else {
                continue;
            };
            let to = DVec3::from(*position);
            let p = self.at(to.truncate());
            if let Some(LightKind::Point { position: from, .. }) =
                lights.iter().find(|l| &l.name == light).map(|l| l.kind)
            {
                let q = self.at(from.truncate());
                let _ = writeln!(
                    self.text,
                    r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="{colour}" stroke-width="1.2" stroke-dasharray="4 3"/>"#,
                    q.x, q.y, p.x, p.y
                );
            }
            let attributes = format!(
                r#"class="light moved" data-light="{}" data-set="{}""#,
                escape(light),
                escape(set)
            );
            self.sun_symbol(&attributes, p, "rgb(255,215,0)", colour);
            self.label(p, &format!("{light} in {set} ({:.2} m)", to.z));
        }
    }

    fn legend(&mut self, dataset: &Dataset, occluded: &[bool], skipped: usize) {
        let x = f64::from(self.view.size.0) - MARGIN.right + 30.0;
        let mut y = MARGIN.top + 10.0;
        let _ = writeln!(self.text, r#"<g class="legend">"#);
        for (s, set) in dataset.sets.iter().enumerate() {
            let extra = match (set.skipped.len(), occluded[s]) {
                (0, false) => String::new(),
                (0, true) => ", occluders".into(),
                (k, false) => format!(", {k} skipped"),
                (k, true) => format!(", {k} skipped, occluders"),
            };
            let extra = if set.poses.len() > MAX_DRAWN {
                format!("{extra} ({MAX_DRAWN} drawn)")
            } else {
                extra
            };
            // A later set's markers cover an earlier set's at the same poses: say so.
            let extra = match dataset.sets[s + 1..].iter().find(|later| later.poses == set.poses) {
                Some(later) => format!("{extra}, under {}'s", escape(&later.spec.name)),
                None => extra,
            };
            let _ = writeln!(
                self.text,
                r#"<circle cx="{x}" cy="{:.1}" r="5" fill="{}"/><text x="{}" y="{:.1}">{}: {} poses{extra}</text>"#,
                y - 4.0,
                set_colour(s),
                x + 12.0,
                y,
                escape(&set.spec.name),
                set.poses.len()
            );
            y += 20.0;
            if !set.spec.lights.is_empty() {
                for line in wrap(&light_changes(&set.spec.lights), LEGEND_LINE) {
                    let _ = writeln!(
                        self.text,
                        r#"<text class="light-changes" data-set="{}" x="{}" y="{:.1}" font-size="11" fill="rgb(80,80,80)">{}</text>"#,
                        escape(&set.spec.name),
                        x + 12.0,
                        y - 4.0,
                        escape(&line)
                    );
                    y += 15.0;
                }
            }
        }
        y += 8.0;
        let _ = writeln!(
            self.text,
            r#"<path d="M{:.1} {:.1}l9 9m0 -9l-9 9" stroke="{SKIPPED_COLOUR}" stroke-width="2"/><text x="{}" y="{y:.1}">skipped (inside an object or outside): {skipped}</text>"#,
            x - 4.5,
            y - 9.0,
            x + 12.0
        );
        y += 20.0;
        let entries = [
            ("rgb(255,215,0)", "point light (height), grey = off"),
            ("rgb(120,120,120)", "occluders: filled per set, outlined per frame"),
        ];
        for (fill, label) in entries {
            let _ = writeln!(
                self.text,
                r#"<rect x="{:.1}" y="{:.1}" width="10" height="10" fill="{fill}" stroke="black"/><text x="{}" y="{y:.1}">{label}</text>"#,
                x - 5.0,
                y - 9.0,
                x + 12.0
            );
            y += 20.0;
        }
        let _ = writeln!(
            self.text,
            r#"<text x="{}" y="{:.1}" fill="rgb(80,80,80)">arrows: camera heading (body x), {ARROW_LENGTH} m</text></g>"#,
            x - 5.0,
            y + 4.0
        );
    }

    fn finish(mut self) -> String {
        self.text.push_str("</svg>\n");
        self.text
    }
}

/// Characters of small legend text that fit beside the plan.
const LEGEND_LINE: usize = 44;

/// `text` in lines of at most `width` characters, broken after commas (a longer piece keeps
/// its own line).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for piece in text.split_inclusive(", ") {
        match lines.last_mut() {
            Some(line) if line.chars().count() + piece.trim_end().chars().count() <= width => line.push_str(piece),
            _ => lines.push(piece.to_string()),
        }
    }
    lines.iter().map(|line| line.trim_end().to_string()).collect()
}

/// A set's light changes in a few words: "lamp off, desk moved".
fn light_changes(changes: &[LightChange]) -> String {
    const SHOWN: usize = 4;
    let mut words: Vec<String> = changes
        .iter()
        .take(SHOWN)
        .map(|change| {
            let what = match change {
                LightChange::Switch { light, on, .. } => format!("{light} {}", if *on { "on" } else { "off" }),
                LightChange::Move { light, .. } => format!("{light} moved"),
                LightChange::Intensity { light, value, .. } => format!("{light} at {value}"),
                LightChange::Colour { light, .. } => format!("{light} tinted"),
                LightChange::Flicker { light, .. } => format!("{light} flickers"),
                LightChange::Ambient(lux) => format!("ambient {lux} lx"),
            };
            match change.frames() {
                Some((start, end)) => format!("{what} (frames {start}–{})", end - 1),
                None => what,
            }
        })
        .collect();
    if changes.len() > SHOWN {
        words.push(format!("{} more", changes.len() - SHOWN));
    }
    format!("lights: {}", words.join(", "))
}

/// The two points of a face seen edge-on that are farthest apart (its ends).
fn farthest_pair(points: &[DVec2]) -> (DVec2, DVec2) {
    let mut best = (points[0], points[0]);
    for (i, &a) in points.iter().enumerate() {
        for &b in &points[i + 1..] {
            if a.distance_squared(b) > best.0.distance_squared(best.1) {
                best = (a, b);
            }
        }
    }
    best
}

fn polygon_points(points: &[DVec2]) -> String {
    let coordinates: Vec<String> = points.iter().map(|p| format!("{:.2},{:.2}", p.x, p.y)).collect();
    coordinates.join(" ")
}

/// 1, 2 or 5 × a power of ten, the largest not above `length` (at least 1 cm).
fn scale_bar_length(length: f64) -> f64 {
    let power = 10f64.powf(length.max(0.01).log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * power)
        .find(|&l| l <= length)
        .unwrap_or(power)
}
