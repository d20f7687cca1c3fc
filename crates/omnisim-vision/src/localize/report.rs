//! The localization report: what one run compared and measured, as JSON (schema:
//! `docs/localization-report.schema.json`, [`SCHEMA`]) and as charts of the papers' kinds
//! (error against noise, occlusion and map density, per test set), one line per descriptor.

use serde::{Deserialize, Serialize};

use super::metrics::{Summary, recall, summarise};
use super::{Distance, Estimate, Score};
use crate::chart::{Marker, Scale, Series, lines_on, stack};

/// The `distance` of local features' results: retrieval by the count of ratio-test matches.
pub const LOCAL_FEATURES: &str = "ratio-matches";

/// The schema's `$id`, which every report names in its `$schema` field.
pub const SCHEMA: &str = "https://omnisim.invalid/schemas/localization-report.schema.json";

/// One run of `omnisim localize`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// [`SCHEMA`].
    #[serde(rename = "$schema")]
    pub schema: String,
    /// "omnisim".
    pub tool: String,
    /// omnisim's version.
    pub version: String,
    /// The command line.
    pub command: Vec<String>,
    /// The data set the images and poses come from.
    pub dataset: DatasetRecord,
    /// The descriptors and their settings, the panorama, the neighbours.
    pub settings: serde_json::Value,
    /// The map and test sets and their conditions.
    pub sets: Vec<SetRecord>,
    /// One entry per map, test set, descriptor, distance and neighbour count.
    pub results: Vec<ResultRecord>,
}

/// The data set of a report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetRecord {
    /// Its folder, as given.
    pub folder: String,
    /// SHA-256 of its spec.
    pub spec_sha256: String,
    /// SHA-256 of its scene as loaded.
    pub geometry_sha256: String,
    /// What rendered it.
    pub renderer: String,
    /// The omnisim version that wrote it.
    pub version: String,
}

/// A set and the conditions it was taken under.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetRecord {
    /// Its name in the data set.
    pub name: String,
    /// "map", "test", or both (a map tested against itself: ideal conditions).
    pub roles: Vec<String>,
    /// Images.
    pub frames: usize,
    /// σ of its Gaussian colour noise (0 without), linear light; the images read are the
    /// noisy copies where it has noise.
    pub noise_sigma: f64,
    /// Occluders per frame, mean.
    pub occluders_per_frame: f64,
    /// The fraction of the image's pixels that see something which per-frame occluders
    /// cover, mean over frames; `None` where the data set has no segmentation images.
    pub occluded_fraction: Option<f64>,
    /// Maps: the mean distance from each pose to its nearest neighbour, metres (the grid
    /// step of a grid).
    pub spacing_m: Option<f64>,
}

/// Recall: the fraction of test images localized within a radius.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Recall {
    /// Within 10 cm.
    pub at_10_cm: f64,
    /// Within 25 cm.
    pub at_25_cm: f64,
    /// Within 50 cm.
    pub at_50_cm: f64,
}

/// The heading estimate of a descriptor that has one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrientationRecord {
    /// "fourier-phase", "radon-poc" or "feature-planar-motion".
    pub method: String,
    /// Absolute heading errors, degrees.
    pub error_deg: Summary,
}

/// Seconds per image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Describing one image (mean over the map and test images; resampling the panorama
    /// included for descriptors that read it).
    pub describe: f64,
    /// Matching one test image against the map (and estimating its heading).
    pub matching: f64,
}

/// One test image's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImageRecord {
    /// Index in the test set.
    pub index: usize,
    /// The nearest map image.
    pub nearest: usize,
    /// Position error, cm.
    pub position_error_cm: f64,
    /// Heading error, degrees.
    pub orientation_error_deg: Option<f64>,
}

/// One descriptor and distance on one map and test set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultRecord {
    /// The map set.
    pub map: String,
    /// The test set.
    pub test: String,
    /// The descriptor.
    pub descriptor: String,
    /// The distance ([`Distance::name`]), or "ratio-matches" for local features.
    pub distance: String,
    /// Neighbours averaged for the position (1: the nearest).
    pub neighbours: usize,
    /// Position errors in the floor plane, cm.
    pub position_error_cm: Summary,
    /// Fraction within 10, 25, 50 cm.
    pub recall: Recall,
    /// Heading errors, where the descriptor gives a heading.
    pub orientation: Option<OrientationRecord>,
    /// Time per image.
    pub seconds_per_image: Timing,
    /// Bytes a map image's descriptor takes (f32 values, and what the heading needs).
    pub bytes_per_map_image: usize,
    /// Every test image.
    pub images: Vec<ImageRecord>,
}

/// Which map, test set, descriptor and method a [`ResultRecord`] is for.
#[derive(Debug, Clone)]
pub struct Case<'a> {
    /// The map set.
    pub map: &'a str,
    /// The test set.
    pub test: &'a str,
    /// The descriptor.
    pub descriptor: &'a str,
    /// The distance ([`Distance::name`]), or "ratio-matches" for local features.
    pub distance: &'a str,
    /// Neighbours.
    pub neighbours: usize,
    /// The heading method's name, where there is one.
    pub heading: Option<&'static str>,
}

impl ResultRecord {
    /// The record of `estimates` scored as `scores` (one per test image, at least one).
    pub fn new(case: &Case, estimates: &[Estimate], scores: &[Score], timing: Timing, bytes: usize) -> Option<Self> {
        let errors_cm: Vec<f64> = scores.iter().map(|s| 100.0 * s.position_m).collect();
        let headings: Vec<f64> = scores
            .iter()
            .filter_map(|s| s.heading_rad.map(f64::to_degrees))
            .collect();
        let orientation = case
            .heading
            .zip(summarise(&headings))
            .map(|(method, error_deg)| OrientationRecord {
                method: method.to_string(),
                error_deg,
            });
        Some(Self {
            map: case.map.to_string(),
            test: case.test.to_string(),
            descriptor: case.descriptor.to_string(),
            distance: case.distance.to_string(),
            neighbours: case.neighbours,
            position_error_cm: summarise(&errors_cm)?,
            recall: Recall {
                at_10_cm: recall(&errors_cm, 10.0),
                at_25_cm: recall(&errors_cm, 25.0),
                at_50_cm: recall(&errors_cm, 50.0),
            },
            orientation,
            seconds_per_image: timing,
            bytes_per_map_image: bytes,
            images: estimates
                .iter()
                .zip(scores)
                .enumerate()
                .map(|(index, (e, s))| ImageRecord {
                    index,
                    nearest: e.nearest,
                    position_error_cm: 100.0 * s.position_m,
                    orientation_error_deg: s.heading_rad.map(f64::to_degrees),
                })
                .collect(),
        })
    }
}

/// Colours of the lines, one per descriptor (cycled with a dash after eight).
const COLOURS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2",
];

impl Report {
    fn set(&self, name: &str) -> Option<&SetRecord> {
        self.sets.iter().find(|s| s.name == name)
    }

    fn descriptors(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for r in &self.results {
            if !names.contains(&r.descriptor.as_str()) {
                names.push(&r.descriptor);
            }
        }
        names
    }

    /// The charts, stacked in one SVG: median position error per test set; against noise σ,
    /// occluders per frame (test sets that differ in it; of several with one value, the first
    /// given) and map spacing (each map on the first test set); median heading error per
    /// test set. One line per descriptor, for `distance` and the nearest neighbour; the first
    /// map where one map is needed. Every chart's second title line gives the version, the
    /// spec's hash and the command (also in the SVG's `<desc>`).
    pub fn charts(&self, distance: Distance) -> String {
        let has = |s: &SetRecord, role: &str| s.roles.iter().any(|r| r == role);
        let maps: Vec<&SetRecord> = self.sets.iter().filter(|s| has(s, "map")).collect();
        let tests: Vec<&SetRecord> = self.sets.iter().filter(|s| has(s, "test")).collect();
        let first_map = maps.first().map_or("", |m| m.name.as_str());
        let first_test = tests.first().map_or("", |t| t.name.as_str());
        let median = |map: &str, test: &str, descriptor: &str| {
            self.results
                .iter()
                .find(|r| {
                    r.map == map
                        && r.test == test
                        && r.descriptor == descriptor
                        && (r.distance == distance.name() || r.distance == LOCAL_FEATURES)
                        && r.neighbours == 1
                })
                .map(|r| {
                    (
                        r.position_error_cm.median,
                        r.orientation.as_ref().map(|o| o.error_deg.median),
                    )
                })
        };
        let series = |points_of: &dyn Fn(&str) -> Vec<(f64, f64)>| -> Vec<Series> {
            self.descriptors()
                .iter()
                .enumerate()
                .map(|(i, d)| Series {
                    label: d.to_string(),
                    colour: COLOURS[i % COLOURS.len()].to_string(),
                    dash: if i < COLOURS.len() {
                        String::new()
                    } else {
                        "6 3".to_string()
                    },
                    marker: if i % 2 == 0 { Marker::Disc } else { Marker::Ring },
                    points: points_of(d),
                })
                .filter(|s| !s.points.is_empty())
                .collect()
        };
        let stamp = format!(
            "omnisim {} · spec sha256 {} · {}",
            self.version,
            self.dataset.spec_sha256.get(..12).unwrap_or(&self.dataset.spec_sha256),
            self.command.join(" ")
        );
        let linear = (Scale::Linear, Scale::Linear);
        let mut charts = Vec::new();
        let names: Vec<String> = tests
            .iter()
            .enumerate()
            .map(|(i, t)| format!("{} {}", i + 1, t.name))
            .collect();
        charts.push(lines_on(
            linear,
            &format!(
                "Median position error per test set (map {first_map}, {} distance)\n{stamp}",
                distance.name()
            ),
            (&format!("test set: {}", names.join(", ")), "median position error (cm)"),
            &series(&|d| {
                tests
                    .iter()
                    .enumerate()
                    .filter_map(|(i, t)| median(first_map, &t.name, d).map(|m| ((i + 1) as f64, m.0)))
                    .collect()
            }),
            f64::NEG_INFINITY,
        ));
        let distinct = |key: &dyn Fn(&SetRecord) -> f64| -> Vec<&SetRecord> {
            let mut chosen: Vec<&SetRecord> = Vec::new();
            for t in &tests {
                if !chosen.iter().any(|c| key(c) == key(t)) {
                    chosen.push(t);
                }
            }
            chosen.sort_by(|a, b| key(a).total_cmp(&key(b)));
            chosen
        };
        for (title, axis, key) in [
            (
                "Median position error against noise",
                "Gaussian noise σ (linear light, 1 = full scale)",
                &(|s: &SetRecord| s.noise_sigma) as &dyn Fn(&SetRecord) -> f64,
            ),
            if tests.iter().all(|t| t.occluded_fraction.is_some()) {
                (
                    "Median position error against occlusion",
                    "occluded fraction of the image",
                    &(|s: &SetRecord| s.occluded_fraction.unwrap_or(0.0)) as &dyn Fn(&SetRecord) -> f64,
                )
            } else {
                (
                    "Median position error against occlusion",
                    "occluders per frame",
                    &(|s: &SetRecord| s.occluders_per_frame) as &dyn Fn(&SetRecord) -> f64,
                )
            },
        ] {
            let sets = distinct(key);
            if sets.len() >= 2 {
                charts.push(lines_on(
                    linear,
                    &format!("{title} (map {first_map})\n{stamp}"),
                    (axis, "median position error (cm)"),
                    &series(&|d| {
                        sets.iter()
                            .filter_map(|t| median(first_map, &t.name, d).map(|m| (key(t), m.0)))
                            .collect()
                    }),
                    f64::NEG_INFINITY,
                ));
            }
        }
        if maps.len() >= 2 {
            charts.push(lines_on(
                linear,
                &format!("Median position error against map density (test set {first_test})\n{stamp}"),
                ("map spacing (m)", "median position error (cm)"),
                &series(&|d| {
                    maps.iter()
                        .filter_map(|m| Some((m.spacing_m?, median(&m.name, first_test, d)?.0)))
                        .collect()
                }),
                f64::NEG_INFINITY,
            ));
        }
        let headings = series(&|d| {
            tests
                .iter()
                .enumerate()
                .filter_map(|(i, t)| Some(((i + 1) as f64, median(first_map, &t.name, d)?.1?)))
                .collect()
        });
        if !headings.is_empty() {
            charts.push(lines_on(
                linear,
                &format!("Median heading error per test set (map {first_map})\n{stamp}"),
                (
                    &format!("test set: {}", names.join(", ")),
                    "median heading error (degrees)",
                ),
                &headings,
                f64::NEG_INFINITY,
            ));
        }
        let svg = stack(&charts);
        let desc = format!("<desc>{}</desc>", escape(&stamp));
        svg.replacen('>', &format!(">\n{desc}"), 1)
    }

    /// The set named `name`'s record, for callers checking conditions.
    pub fn set_record(&self, name: &str) -> Option<&SetRecord> {
        self.set(name)
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
