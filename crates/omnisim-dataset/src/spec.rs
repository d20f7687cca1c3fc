//! The RON schema of a data-set spec, exactly as a person writes it, and its checks.
//!
//! `deny_unknown_fields` everywhere: a misspelt field is an error, not an ignored line. Every
//! error names the file, the line and column, the set and the field (`spec.ron:12:9: set
//! 'map': poses.spacing: ...`), located the way scene errors are (`scene::locate`).

use std::path::{Component, Path, PathBuf};

use omnisim::camera::RigSpec;
use omnisim::output::OutputSet;
use serde::{Deserialize, Serialize};

use super::DatasetError;
use omnisim::input::locate;
use omnisim::input::shown_number as number;

/// An sRGB colour, 0–255 per channel.
pub type Rgb = (u8, u8, u8);

/// A whole spec: one scene, one rig, several sets of poses and perturbations.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "Dataset")]
pub struct Spec {
    /// Scene file, relative to the spec's folder and inside it.
    pub scene: String,
    /// Every random draw of the data set derives from it (with the set name and frame index).
    #[serde(default)]
    pub seed: u64,
    /// The vision system every set is rendered with.
    pub rig: RigSpec,
    /// Which ground-truth files each frame gets.
    #[serde(default)]
    pub outputs: OutputSet,
    /// Anti-aliased colour, as `render --edge-samples`: pixels on face edges traced again
    /// with this many stratified samples (a square: 1, 4, 16, 64, ... up to 1024); range,
    /// points and the other planes are unchanged.
    #[serde(default = "one")]
    pub edge_samples: u32,
    /// The sets; each gets its own folder named after it.
    pub sets: Vec<SetSpec>,
}

fn one() -> u32 {
    1
}

/// One set: its poses, its perturbations, its layouts.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "Set")]
pub struct SetSpec {
    /// Folder name of the set: letters, digits, `-`, `_`, `.`.
    pub name: String,
    /// Where the camera goes.
    pub poses: PoseSource,
    /// What to do with poses inside a closed object or outside the scene.
    #[serde(default)]
    pub misplaced: MisplacedPolicy,
    /// Changes to the scene's lights, applied in order.
    #[serde(default)]
    pub lights: Vec<LightChange>,
    /// Changes to object colours, applied in order.
    #[serde(default)]
    pub colours: Vec<ColourChange>,
    /// Objects added at random free places.
    #[serde(default)]
    pub occluders: Vec<OccluderSpec>,
    /// Sensor noise; noise-free ground truth is always written too.
    #[serde(default)]
    pub noise: NoiseSpec,
    /// Layouts SLAM tools read, besides the frame files.
    #[serde(default)]
    pub layouts: Vec<LayoutSpec>,
}

/// Where the poses of a set come from. Positions in metres, angles in degrees.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum PoseSource {
    /// Poses along the polyline through `through`, every `spacing` metres or `count` poses.
    Trajectory {
        /// Waypoints (x, y, z).
        through: Vec<(f64, f64, f64)>,
        /// Distance between poses, metres.
        #[serde(default)]
        spacing: Option<f64>,
        /// Number of poses, evenly spread (instead of `spacing`).
        #[serde(default)]
        count: Option<usize>,
        /// Which way the camera faces.
        #[serde(default)]
        heading: Heading,
    },
    /// Every combination of x, y, z and heading (x fastest, heading slowest).
    Grid {
        /// (start, stop, step), metres; stop included.
        x: (f64, f64, f64),
        /// (start, stop, step), metres.
        y: (f64, f64, f64),
        /// Heights, metres.
        z: Vec<f64>,
        /// θz values, degrees.
        #[serde(default = "zero_heading")]
        headings: Vec<f64>,
    },
    /// Uniform random positions in a box with clearance from every surface (see `pose_sets`).
    Random {
        /// How many.
        count: usize,
        /// Lowest corner, metres.
        low: (f64, f64, f64),
        /// Highest corner, metres.
        high: (f64, f64, f64),
        /// Largest |θx| and |θy|, degrees; θz is uniform over the full turn.
        #[serde(default)]
        tilt: f64,
        /// Free distance from every surface along ±x, ±y, ±z, metres.
        #[serde(default = "default_clearance")]
        clearance: f64,
        /// Per-axis ranges ((θx min, max), (θy min, max), (θz min, max)), degrees, each drawn
        /// uniformly and independently; instead of `tilt` and the full turn of θz.
        #[serde(default)]
        angles: Option<AngleRanges>,
        /// Seed of these poses; without it they derive from the spec's seed and the set's
        /// name. Sets with the same `Random` and `seed` get the same poses (one place seen by
        /// day and by night).
        #[serde(default)]
        seed: Option<u64>,
    },
    /// Poses given one by one: (x, y, z, θx, θy, θz).
    List(Vec<(f64, f64, f64, f64, f64, f64)>),
}

/// (min, max) of θx, θy and θz, degrees.
pub type AngleRanges = ((f64, f64), (f64, f64), (f64, f64));

/// Which way a trajectory's camera faces.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Heading {
    /// θz along the direction of travel.
    #[default]
    AlongPath,
    /// The same angles at every pose.
    Fixed {
        /// (θx, θy, θz), degrees.
        angles: (f64, f64, f64),
    },
}

/// What to do with a pose inside a closed object or outside the scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
pub enum MisplacedPolicy {
    /// Leave it out, with a warning that says which and how many.
    #[default]
    Skip,
    /// Refuse the spec.
    Refuse,
}

/// A change to a named light of the scene (or to the ambient term).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum LightChange {
    /// Switch a light on or off.
    Switch {
        /// Light name in the scene.
        light: String,
        /// On or off.
        on: bool,
        /// Only frames `start ≤ index < end` of the set (a schedule); every frame without it.
        #[serde(default)]
        frames: Option<(usize, usize)>,
    },
    /// Move a point light, metres.
    Move {
        /// Light name.
        light: String,
        /// New position.
        position: (f64, f64, f64),
        /// Only frames `start ≤ index < end` of the set (a schedule); every frame without it.
        #[serde(default)]
        frames: Option<(usize, usize)>,
    },
    /// Set a light's intensity (candela) or illuminance (lux, directional).
    Intensity {
        /// Light name.
        light: String,
        /// New value.
        value: f64,
        /// Only frames `start ≤ index < end` of the set (a schedule); every frame without it.
        #[serde(default)]
        frames: Option<(usize, usize)>,
    },
    /// Set a light's sRGB tint.
    Colour {
        /// Light name.
        light: String,
        /// New tint.
        colour: Rgb,
        /// Only frames `start ≤ index < end` of the set (a schedule); every frame without it.
        #[serde(default)]
        frames: Option<(usize, usize)>,
    },
    /// Per frame: off with probability `off`, else intensity × (1 + uniform(−jitter, jitter)).
    Flicker {
        /// Light name.
        light: String,
        /// Probability of being off in a frame.
        #[serde(default)]
        off: f64,
        /// Relative intensity variation.
        #[serde(default)]
        jitter: f64,
        /// Only frames `start ≤ index < end` of the set (a schedule); every frame without it.
        #[serde(default)]
        frames: Option<(usize, usize)>,
    },
    /// Set the ambient illuminance, lux (every frame of the set).
    Ambient(f64),
}

impl LightChange {
    /// The frames it is limited to, if any: (start, end), end excluded.
    pub fn frames(&self) -> Option<(usize, usize)> {
        match self {
            Self::Switch { frames, .. }
            | Self::Move { frames, .. }
            | Self::Intensity { frames, .. }
            | Self::Colour { frames, .. }
            | Self::Flicker { frames, .. } => *frames,
            Self::Ambient(_) => None,
        }
    }

    /// Whether it changes frame `index` of its set.
    pub fn applies_to(&self, index: usize) -> bool {
        self.frames().is_none_or(|(start, end)| (start..end).contains(&index))
    }
}

/// A change of object colours.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum ColourChange {
    /// Paint every face of the named object.
    Paint {
        /// Object name in the scene.
        object: String,
        /// New sRGB colour.
        colour: Rgb,
    },
    /// Shift each listed object's colours (all objects when empty) by a random amount in
    /// [−range, range] per channel, per set or per frame.
    Shift {
        /// Object names; empty: every object.
        #[serde(default)]
        objects: Vec<String>,
        /// Largest shift per channel, 8-bit steps.
        range: u8,
        /// Draw anew for every frame (else once for the set).
        #[serde(default)]
        per_frame: bool,
    },
}

/// Occluders placed at random free positions.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, rename = "Occluders")]
pub struct OccluderSpec {
    /// Their shape.
    pub shape: OccluderShape,
    /// How many.
    pub count: usize,
    /// New places for every frame (else once for the whole set).
    #[serde(default = "yes")]
    pub per_frame: bool,
    /// Floor-plan rectangle ((x0, y0), (x1, y1)) they stand in; default the scene's bounds.
    #[serde(default)]
    pub region: Option<((f64, f64), (f64, f64))>,
    /// Height they stand on, metres; default the scene's lowest point.
    #[serde(default)]
    pub floor: Option<f64>,
    /// Least distance from every camera of the frame (of the set, for per-set occluders), metres.
    #[serde(default = "default_clearance")]
    pub clearance: f64,
    /// Colour; random when absent.
    #[serde(default)]
    pub colour: Option<Rgb>,
}

/// The shape of an occluder; it stands upright, turned by a random angle about z.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum OccluderShape {
    /// A box, metres.
    Box {
        /// (length, width, height).
        size: (f64, f64, f64),
    },
    /// A person-sized octagonal prism: 0.5 × 0.3 m, 1.75 m high.
    Person,
}

/// Sensor noise of a set.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// Colour noise, applied in order in linear light (1.0 = full scale), before encoding.
    #[serde(default)]
    pub colour: Vec<ColourNoise>,
    /// Depth (pinhole) or range (other cameras) noise.
    #[serde(default)]
    pub depth: Option<DepthNoise>,
    /// Stereo disparity noise.
    #[serde(default)]
    pub disparity: Option<DisparityNoise>,
}

/// One colour noise model; values in linear light, 1.0 = full scale.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum ColourNoise {
    /// Additive white Gaussian noise of standard deviation `sigma`.
    Gaussian {
        /// Standard deviation.
        sigma: f64,
    },
    /// Signal-dependent noise, variance a·y + b at linear value y (Poisson shot noise + read noise).
    PoissonGaussian {
        /// Shot-noise gain.
        a: f64,
        /// Read-noise variance.
        b: f64,
    },
    /// Each pixel black or white (even odds) with this probability.
    SaltPepper {
        /// Probability per pixel.
        probability: f64,
    },
}

/// Depth noise of standard deviation σ(z) = c0 + c1·z + c2·z² metres (z in metres).
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DepthNoise {
    /// Constant term, metres.
    #[serde(default)]
    pub c0: f64,
    /// Linear term.
    #[serde(default)]
    pub c1: f64,
    /// Quadratic term, 1/metres (RGB-D sensors: about 0.0012 to 0.003).
    #[serde(default)]
    pub c2: f64,
}

/// Disparity noise: Gaussian of `sigma` pixels, then rounded to 1/`subpixel` pixel.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DisparityNoise {
    /// Standard deviation, pixels.
    pub sigma: f64,
    /// Sub-pixel steps per pixel (e.g. 16 as `OpenCV`'s SGBM); 0 keeps the value unquantized.
    #[serde(default)]
    pub subpixel: u32,
}

/// A layout SLAM tools read.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum LayoutSpec {
    /// TUM RGB-D: `tum/rgb/`, `tum/depth/`, `rgb.txt`, `depth.txt`, `groundtruth.txt`.
    Tum {
        /// Frames per second: frame i has timestamp i / rate.
        rate: f64,
    },
    /// EuRoC/ASL: `mav0/cam0/data/<ns>.png`, `data.csv`, `sensor.yaml`, ground truth.
    Euroc {
        /// Frames per second.
        rate: f64,
    },
}

/// Slowest layout rate: 10 M frames at 0.01 frames/s end at 1e9 s, in 64-bit nanoseconds.
const MIN_RATE: f64 = 0.01;
/// Fastest layout rate: TUM's microsecond timestamps still differ from frame to frame.
const MAX_RATE: f64 = 1e6;

impl LayoutSpec {
    /// Frames per second.
    pub fn rate(&self) -> f64 {
        match self {
            LayoutSpec::Tum { rate } | LayoutSpec::Euroc { rate } => *rate,
        }
    }
}

fn default_clearance() -> f64 {
    0.2
}
fn zero_heading() -> Vec<f64> {
    vec![0.0]
}
fn yes() -> bool {
    true
}

/// Where in the spec a problem is: the set (if any) and the field path inside it.
pub(crate) struct Place<'a> {
    pub(crate) set: Option<&'a str>,
    pub(crate) field: String,
}

/// The text and path of a spec, for locating errors.
pub(crate) struct SpecText<'a> {
    pub(crate) text: &'a str,
    pub(crate) path: &'a Path,
}

impl SpecText<'_> {
    /// A located error: at the field inside its set (at the set's `name` where the field is
    /// not written after it), or at the top-level field.
    pub(crate) fn error(&self, place: Place, message: impl Into<String>) -> DatasetError {
        let location = if let Some(set) = place.set {
            locate::name_field(self.text, set, 0)
                .map(|name| locate::field_of_element(self.text, name, &place.field).unwrap_or(name))
        } else {
            let top = place.field.split(['.', '[']).next().unwrap_or_default();
            locate::scene_field(self.text, top)
        };
        DatasetError::Spec {
            path: self.path.to_path_buf(),
            location,
            set: place.set.map(|set| omnisim::input::shown(set, 64)),
            field: place.field,
            message: message.into(),
        }
    }
}

/// Parses spec text; syntax and schema errors are located at the set they fall in.
pub fn parse(text: &str, path: &Path) -> Result<Spec, DatasetError> {
    let text = omnisim::input::without_bom(text);
    let spec: Spec = omnisim::input::ron_options().from_str(text).map_err(|e| {
        let (line, column) = (e.span.start.line, e.span.start.col);
        let field = locate::field_of_error(text, &e);
        DatasetError::Spec {
            path: path.to_path_buf(),
            location: Some((line, column)),
            set: locate::element_at(text, "sets", line, column),
            field: field.unwrap_or_default(),
            message: e.code.to_string(),
        }
    })?;
    check(&spec, &SpecText { text, path })?;
    Ok(spec)
}

/// Checks what serde cannot: names, numbers, references between fields.
fn check(spec: &Spec, at: &SpecText) -> Result<(), DatasetError> {
    let top = |field: &str, message: String| {
        at.error(
            Place {
                set: None,
                field: field.into(),
            },
            message,
        )
    };
    scene_path(spec, at.path).map_err(|m| top("scene", m))?;
    let n = spec.edge_samples;
    if !((1..=1024).contains(&n) && n.isqrt() * n.isqrt() == n) {
        return Err(top(
            "edge_samples",
            format!("must be a square from 1 to 1024 (1, 4, 16, 64, ...), not {n}"),
        ));
    }
    if spec.edge_samples > 1 && !spec.outputs.colour {
        return Err(top(
            "edge_samples",
            "anti-aliases the colour images, which outputs leaves out (colour: false)".into(),
        ));
    }
    if spec.sets.is_empty() {
        return Err(top("sets", "a data set needs at least one set".into()));
    }
    if spec.sets.len() > MAX_SETS {
        return Err(top(
            "sets",
            format!(
                "{} sets are more than {MAX_SETS}: a set is a folder with its own files, entries and contact \
                 sheet; put the poses of sets that share their changes into one set",
                spec.sets.len()
            ),
        ));
    }
    let mut names = std::collections::HashSet::new();
    for set in &spec.sets {
        let fail = |field: &str, message: String| {
            at.error(
                Place {
                    set: Some(&set.name),
                    field: field.into(),
                },
                message,
            )
        };
        if !is_folder_name(&set.name) {
            return Err(fail(
                "name",
                "a set name is its folder's name: 1-64 letters, digits, '-', '_' or '.', not starting with '.'".into(),
            ));
        }
        if set.name.eq_ignore_ascii_case(super::files::MANIFEST) {
            return Err(fail(
                "name",
                format!(
                    "'{}' is the data set's manifest file; name the set otherwise",
                    super::files::MANIFEST
                ),
            ));
        }
        if !names.insert(set.name.as_str()) {
            return Err(fail("name", "another set has this name".into()));
        }
        check_poses(&set.poses).map_err(|(field, m)| fail(&format!("poses.{field}"), m))?;
        check_set(spec, set).map_err(|(field, m)| fail(&field, m))?;
    }
    Ok(())
}

/// The scene file a spec names: relative to the spec's folder and inside it.
pub fn scene_path(spec: &Spec, spec_path: &Path) -> Result<PathBuf, String> {
    let relative = Path::new(&spec.scene);
    if spec.scene.is_empty()
        || relative
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(format!(
            "'{}' must be relative to the spec's folder and stay inside it (no '..', no absolute path)",
            omnisim::input::shown(&spec.scene, 80)
        ));
    }
    Ok(spec_path.parent().unwrap_or(Path::new(".")).join(relative))
}

fn is_folder_name(name: &str) -> bool {
    (1..=64).contains(&name.len())
        && !name.starts_with('.')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
}

type Checked = Result<(), (String, String)>;

/// Largest coordinate (metres) or angle (degrees) a spec may give: far beyond any scene, and
/// small enough that sums, differences and rounding to 1e-9 stay finite.
pub(crate) const MAX_MAGNITUDE: f64 = 1e9;

fn finite(field: &str, values: &[f64]) -> Checked {
    match values.iter().find(|v| !(v.is_finite() && v.abs() <= MAX_MAGNITUDE)) {
        Some(&v) => Err((
            field.into(),
            format!(
                "must be a finite number within ±{MAX_MAGNITUDE:e} (metres or degrees), not {}",
                number(v)
            ),
        )),
        None => Ok(()),
    }
}

fn positive(field: &str, value: f64) -> Checked {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err((field.into(), format!("must be a positive finite number, not {value}")))
    }
}

fn probability(field: &str, value: f64) -> Checked {
    if (0.0..=1.0).contains(&value) {
        Ok(())
    } else {
        Err((field.into(), format!("must be a probability from 0 to 1, not {value}")))
    }
}

/// Pose counts beyond this are refused: a typo, not a data set.
pub const MAX_POSES: usize = 10_000_000;

/// The most sets a data set holds: each is a folder, a preview colour and a legend line, so
/// without a bound a spec's size alone (64 MiB, ~900,000 sets) sets the memory and folders made.
pub const MAX_SETS: usize = 1000;

fn check_poses(source: &PoseSource) -> Result<(), (String, String)> {
    let err = |field: &str, m: String| Err((field.to_string(), m));
    match source {
        PoseSource::Trajectory {
            through,
            spacing,
            count,
            heading,
        } => {
            if through.len() < 2 {
                return err("through", "a trajectory needs at least two waypoints".into());
            }
            let flat: Vec<f64> = through.iter().flat_map(|p| [p.0, p.1, p.2]).collect();
            finite("through", &flat)?;
            if let Heading::Fixed { angles: a } = heading {
                finite("heading", &[a.0, a.1, a.2])?;
            }
            let length: f64 = through
                .windows(2)
                .map(|w| glam::DVec3::from(w[0]).distance(glam::DVec3::from(w[1])))
                .sum();
            match (spacing, count) {
                (Some(s), None) => {
                    positive("spacing", *s)?;
                    if length / s > MAX_POSES as f64 {
                        return err("spacing", format!("gives more than {MAX_POSES} poses"));
                    }
                }
                (None, Some(n)) if (2..=MAX_POSES).contains(n) => {}
                (None, Some(n)) => return err("count", format!("must be from 2 to {MAX_POSES}, not {n}")),
                _ => return err("spacing", "give either spacing (metres) or count".into()),
            }
            if length == 0.0 {
                return err("through", "the waypoints are all the same point".into());
            }
        }
        PoseSource::Grid { x, y, z, headings } => {
            for (field, (start, stop, step)) in [("x", x), ("y", y)] {
                finite(field, &[*start, *stop])?;
                positive(&format!("{field}.2 (step)"), *step)?;
                if stop < start {
                    return err(field, format!("stop {stop} is below start {start}"));
                }
            }
            finite("z", z)?;
            finite("headings", headings)?;
            let along = |(a, b, s): (f64, f64, f64)| ((b - a) / s).floor() + 1.0;
            let total = along(*x) * along(*y) * z.len() as f64 * headings.len() as f64;
            if total < 1.0 || total > MAX_POSES as f64 {
                return err(
                    "z",
                    format!("the grid has {total} poses; it must have 1 to {MAX_POSES}"),
                );
            }
        }
        PoseSource::Random {
            count,
            low,
            high,
            tilt,
            clearance,
            angles,
            seed: _,
        } => {
            if let Some(((x0, x1), (y0, y1), (z0, z1))) = *angles {
                finite("angles", &[x0, x1, y0, y1, z0, z1])?;
                for (axis, low, high) in [("θx", x0, x1), ("θy", y0, y1), ("θz", z0, z1)] {
                    if !(low.is_finite() && high.is_finite() && low <= high && high - low <= 360.0) {
                        return err(
                            "angles",
                            format!("{axis}: ({low}, {high}) must be finite degrees, min ≤ max, at most 360 apart"),
                        );
                    }
                }
                if *tilt != 0.0 {
                    return err("angles", "give tilt or per-axis angles, not both".into());
                }
            }
            if !(1..=MAX_POSES).contains(count) {
                return err("count", format!("must be from 1 to {MAX_POSES}, not {count}"));
            }
            finite("low", &[low.0, low.1, low.2])?;
            finite("high", &[high.0, high.1, high.2])?;
            if high.0 < low.0 || high.1 < low.1 || high.2 < low.2 {
                return err("high", "every coordinate of high must be at least that of low".into());
            }
            if !(0.0..=90.0).contains(tilt) {
                return err("tilt", format!("must be from 0 to 90 degrees, not {tilt}"));
            }
            if !(clearance.is_finite() && *clearance >= 0.0) {
                return err("clearance", format!("must be a finite distance ≥ 0, not {clearance}"));
            }
        }
        PoseSource::List(poses) => {
            if poses.is_empty() || poses.len() > MAX_POSES {
                return err("List", format!("must hold 1 to {MAX_POSES} poses"));
            }
            let flat: Vec<f64> = poses.iter().flat_map(|p| [p.0, p.1, p.2, p.3, p.4, p.5]).collect();
            finite("List", &flat)?;
        }
    }
    Ok(())
}

fn check_set(spec: &Spec, set: &SetSpec) -> Checked {
    for (i, change) in set.lights.iter().enumerate() {
        let field = format!("lights[{i}]");
        if let Some((start, end)) = change.frames()
            && start >= end
        {
            return Err((
                format!("{field}.frames"),
                format!(
                    "({start}, {end}) holds no frame: give (first, one past the last), e.g. ({start}, {})",
                    start + 1
                ),
            ));
        }
        match change {
            LightChange::Move { position, .. } => finite(&field, &[position.0, position.1, position.2])?,
            LightChange::Intensity { value, .. } if !(value.is_finite() && *value >= 0.0) => {
                return Err((field, format!("intensity must be a finite number ≥ 0, not {value}")));
            }
            LightChange::Flicker { off, jitter, .. } => {
                probability(&format!("{field}.off"), *off)?;
                probability(&format!("{field}.jitter"), *jitter)?;
            }
            LightChange::Ambient(lux) if !(lux.is_finite() && *lux >= 0.0) => {
                return Err((field, format!("ambient must be a finite number of lux ≥ 0, not {lux}")));
            }
            _ => {}
        }
    }
    for (i, occluders) in set.occluders.iter().enumerate() {
        let field = format!("occluders[{i}]");
        if let OccluderShape::Box { size: (l, w, h) } = occluders.shape {
            for v in [l, w, h] {
                positive(&format!("{field}.shape"), v)?;
            }
        }
        if occluders.count > 1000 {
            return Err((format!("{field}.count"), "at most 1000 occluders".into()));
        }
        if let Some(((x0, y0), (x1, y1))) = occluders.region {
            finite(&format!("{field}.region"), &[x0, y0, x1, y1])?;
            if x1 <= x0 || y1 <= y0 {
                return Err((
                    format!("{field}.region"),
                    "the second corner must lie above the first".into(),
                ));
            }
        }
        finite(&format!("{field}.floor"), &[occluders.floor.unwrap_or(0.0)])?;
        if !(occluders.clearance.is_finite() && occluders.clearance >= 0.0) {
            return Err((format!("{field}.clearance"), "must be a finite distance ≥ 0".into()));
        }
    }
    for (i, noise) in set.noise.colour.iter().enumerate() {
        let field = format!("noise.colour[{i}]");
        match *noise {
            ColourNoise::Gaussian { sigma } if !(sigma.is_finite() && sigma >= 0.0) => {
                return Err((field, format!("sigma must be finite and ≥ 0, not {sigma}")));
            }
            ColourNoise::PoissonGaussian { a, b } if !(a.is_finite() && b.is_finite() && a >= 0.0 && b >= 0.0) => {
                return Err((field, "a and b must be finite and ≥ 0".into()));
            }
            ColourNoise::SaltPepper { probability: p } => probability(&field, p)?,
            _ => {}
        }
    }
    if let Some(d) = set.noise.depth
        && !([d.c0, d.c1, d.c2].iter().all(|c| c.is_finite() && *c >= 0.0))
    {
        return Err(("noise.depth".into(), "c0, c1 and c2 must be finite and ≥ 0".into()));
    }
    if let Some(d) = set.noise.disparity {
        if !(d.sigma.is_finite() && d.sigma >= 0.0) {
            return Err(("noise.disparity.sigma".into(), "must be finite and ≥ 0".into()));
        }
        match &spec.rig {
            RigSpec::Stereo(stereo) if stereo.lens.is_some() || stereo.distortion.is_some() => {
                return Err((
                    "noise.disparity".into(),
                    "a Stereo rig with a lens or distortion has no disparity (it is defined for rectified ideal \
                     pinholes): remove noise.disparity, or the rig's lens"
                        .into(),
                ));
            }
            RigSpec::Stereo(_) => {}
            _ => return Err(("noise.disparity".into(), "only a Stereo rig has disparity".into())),
        }
    }
    for (i, layout) in set.layouts.iter().enumerate() {
        let rate = layout.rate();
        // TUM writes timestamps to the microsecond, EuRoC to the nanosecond in 64 bits: frames
        // must get distinct stamps, and the last one must fit.
        if !(MIN_RATE..=MAX_RATE).contains(&rate) {
            return Err((
                format!("layouts[{i}].rate"),
                format!(
                    "must be from {MIN_RATE} to {MAX_RATE} frames per second, not {}",
                    number(rate)
                ),
            ));
        }
        if set.layouts[..i]
            .iter()
            .any(|other| std::mem::discriminant(other) == std::mem::discriminant(layout))
        {
            return Err((
                format!("layouts[{i}]"),
                "a set has one layout of each kind (both would write the same files); make another set for \
                 another rate"
                    .into(),
            ));
        }
        let optical_depth = match &spec.rig {
            RigSpec::Pinhole(_) => true,
            RigSpec::Stereo(stereo) => stereo.lens.is_none(),
            _ => false,
        };
        if matches!(layout, LayoutSpec::Tum { .. }) && !optical_depth {
            return Err((
                format!("layouts[{i}]"),
                "TUM RGB-D pairs every colour image with a depth image along an optical axis, which only a Pinhole \
                 or Stereo rig (without a fisheye lens) has; for this rig use Euroc (images and poses), with the range EXRs as depth"
                    .into(),
            ));
        }
    }
    Ok(())
}
