//! Data sets: map and test sets of one scene from one spec file, with light, colour, occluder
//! and noise perturbations, in folders SLAM tools read, resumable and sharded.
//!
//! [`Dataset::load`] reads a spec (`spec.rs`), its scene, and plans every set's poses;
//! [`Dataset::run`] renders the frames of a shard into a folder (`run.rs`), each frame done
//! once its entry is written; [`merge`] checks a folder's frames and writes the index files
//! and `manifest.json`. Every random draw comes from (seed, set, frame) alone (`rng.rs`).
//!
//! A data set written from code: a map of four omnidirectional frames along a line in the
//! reference paper's first room, and the manifest read back.
//!
//! ```
//! use std::ops::ControlFlow;
//! use omnisim::{BackendChoice, Renderer};
//! use omnisim_dataset::{Dataset, RunOptions, manifest::Manifest};
//!
//! let folder = tempfile::tempdir()?;
//! let scenes = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes");
//! std::fs::copy(format!("{scenes}/env1.ron"), folder.path().join("env1.ron"))?;
//! let spec = r#"Dataset(
//!     scene: "env1.ron",
//!     rig: Omni(size: (64, 64), mirror: Hyperbolic(a: 0.04, b: 0.16)),
//!     sets: [Set(name: "map", poses: Trajectory(through: [(-2.0, -0.9, 0.4), (2.0, -0.9, 0.4)], count: 4))],
//! )"#;
//! let dataset = Dataset::from_text(spec.to_string(), &folder.path().join("spec.ron"))?;
//! let renderer = Renderer::new(BackendChoice::Cpu)?;
//! let out = folder.path().join("data");
//! dataset.run(&renderer, &out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()))?;
//! let manifest = Manifest::read(&out.join("manifest.json"))?;
//! assert_eq!(manifest.sets[0].frame_entries.len(), 4);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod appearance;
mod contact_sheet;
mod files;
mod folder;
mod layout;
pub mod manifest;
mod merge;
pub mod noise;
pub mod occluders;
pub mod preview;
pub mod rng;
mod run;
mod set_files;
mod sha256;
pub mod spec;
#[cfg(test)]
mod tests;
mod write;

use std::path::{Path, PathBuf};

use glam::{DVec3, dvec3};

pub use merge::{MergeSummary, merge};
pub use run::{FrameDone, RunOptions, RunSummary, Shard};

use occluders::Occluder;
use omnisim::Rig;
use omnisim::advanced::SceneBvh;
use omnisim::pose::Pose;
use omnisim::pose_sets::{self, Misplaced, RandomPoses};
use omnisim::scene::Scene;
use spec::{Heading, MisplacedPolicy, PoseSource, SetSpec, Spec};

/// Why a data set could not be planned, rendered or merged.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The spec or its scene file could not be read.
    #[error(transparent)]
    Input(#[from] omnisim::input::InputError),
    /// A problem in the spec, located.
    #[error("{}{}: {}{}{message}", path.display(),
        location.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default(),
        set.as_ref().map(|s| format!("set '{s}': ")).unwrap_or_default(),
        if field.is_empty() { String::new() } else { format!("{field}: ") })]
    Spec {
        /// The spec file.
        path: PathBuf,
        /// (line, column), 1-based.
        location: Option<(usize, usize)>,
        /// The set the problem is in.
        set: Option<String>,
        /// The field inside the set (or the spec), e.g. `poses.spacing`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The scene the spec names.
    #[error(transparent)]
    Scene(#[from] omnisim::scene::SceneError),
    /// Rendering failed.
    #[error(transparent)]
    Render(#[from] omnisim::RenderError),
    /// Writing an output failed.
    #[error(transparent)]
    Output(#[from] omnisim::output::OutputError),
    /// A file or folder could not be read or written.
    #[error("{}: {source}{}", path.display(), io_hint(source))]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The folder holds another spec's data set.
    #[error(
        "{} holds a data set of another spec (or scene): {previous}. Choose another folder, or add --overwrite to \
         remove that data set's files first (nothing else is touched)",
        dir.display()
    )]
    AnotherSpec {
        /// The folder.
        dir: PathBuf,
        /// What it holds.
        previous: String,
    },
    /// Another run (or merge) of another data set works in the folder now.
    #[error(
        "{} is in use by another omnisim run (or merge) of {previous}: wait for it to end (--overwrite then \
         replaces that data set), or choose another folder",
        dir.display()
    )]
    Busy {
        /// The folder.
        dir: PathBuf,
        /// The data set that run writes.
        previous: String,
    },
    /// The folder's frames come from another omnisim version or renderer: their bytes would
    /// differ from this run's.
    #[error(
        "{} holds frames rendered by {recorded}; this run renders with {current}, whose bytes differ. Finish it \
         with that version and backend (e.g. --backend cpu on every machine) or render into another folder \
         (`omnisim dataset --overwrite` starts this one afresh)",
        dir.display()
    )]
    OtherRenderer {
        /// The folder.
        dir: PathBuf,
        /// What rendered its frames.
        recorded: String,
        /// What renders now.
        current: String,
    },
    /// A data-set folder's stamp is unreadable or disagrees with the spec it holds.
    #[error(
        "{}: {problem}; restore it (a shard folder holds the same), or render the data set into a new folder",
        path.display()
    )]
    BadStamp {
        /// The stamp file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// A folder of the data set is a link.
    #[error(
        "{} is a link: a data set writes only into real folders under its folder; remove the link (or put the whole \
         --out folder where the link pointed)",
        path.display()
    )]
    Link {
        /// The link.
        path: PathBuf,
    },
    /// A folder of the data set (--out itself, or one above it) is a file.
    #[error("{} is a file, not a folder: name a new or empty folder, or a data set's, for --out", path.display())]
    NotAFolder {
        /// The file in the way.
        path: PathBuf,
    },
    /// The output folder lies inside a data set's bookkeeping folder.
    #[error(
        "{} is or lies inside a data set's bookkeeping folder ({}, its frame entries): a data set there would be \
         mixed with them; choose a folder outside it",
        dir.display(),
        folder.display()
    )]
    InBookkeeping {
        /// The output folder.
        dir: PathBuf,
        /// The bookkeeping folder.
        folder: PathBuf,
    },
    /// The output folder lies inside another data set's folder.
    #[error(
        "{} lies inside the data set in {} (it holds {}): a folder holds one data set; choose a folder outside it",
        dir.display(),
        outer.display(),
        files::STAMP
    )]
    InDataSet {
        /// The output folder.
        dir: PathBuf,
        /// The data set's folder.
        outer: PathBuf,
    },
    /// A merge was given a folder no data-set run wrote.
    #[error(
        "{} holds no data set (no {} stamp): give the folder `omnisim dataset` rendered into, then any shard \
         folders rendered apart",
        dir.display(),
        files::STAMP
    )]
    NotADataSet {
        /// The folder.
        dir: PathBuf,
    },
    /// A merge was given a shard of another spec.
    #[error(
        "{} holds frames of another spec (or scene) than {}: {theirs}. Merge only the shards of one spec",
        dir.display(),
        dest.display()
    )]
    ShardOfAnotherSpec {
        /// The shard's folder.
        dir: PathBuf,
        /// The merge's destination.
        dest: PathBuf,
        /// What the shard holds.
        theirs: String,
    },
    /// The folder holds files no data set recorded.
    #[error(
        "{} already holds files that no omnisim data set recorded, e.g. '{}'; choose an empty or new folder \
         (`omnisim dataset --overwrite` renders into it anyway, leaving those files)",
        dir.display(),
        omnisim::input::shown(example, 64)
    )]
    Unrecorded {
        /// The folder.
        dir: PathBuf,
        /// One such file.
        example: String,
    },
    /// A merge found frames missing.
    #[error(
        "set '{set}' is incomplete: {missing} of {total} frames missing (first: frame {first}); render the missing shards, then merge again"
    )]
    Incomplete {
        /// The set.
        set: String,
        /// Frames missing.
        missing: usize,
        /// Frames the set has.
        total: usize,
        /// The first missing frame.
        first: usize,
    },
    /// A file differs from what its frame entry recorded.
    #[error("{}: {problem}; render its frame again (delete {}) or restore the file", path.display(), entry.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// The frame entry that lists it.
        entry: PathBuf,
        /// Size or hash mismatch, or missing.
        problem: String,
    },
    /// The preview picture could not be rasterised.
    #[error("cannot draw the preview picture: {0}")]
    Picture(String),
}

impl DatasetError {
    /// Whether the same command would fail the same way: the folder was refused (another
    /// spec's or renderer's frames, unrecorded files) or the spec asks what cannot be (such as
    /// occluders with no free place). Other errors (a full disk, a killed writer) leave a resumable run.
    pub fn needs_a_change(&self) -> bool {
        matches!(
            self,
            Self::AnotherSpec { .. }
                | Self::Busy { .. }
                | Self::OtherRenderer { .. }
                | Self::ShardOfAnotherSpec { .. }
                | Self::Unrecorded { .. }
                | Self::NotADataSet { .. }
                | Self::BadStamp { .. }
                | Self::Link { .. }
                | Self::NotAFolder { .. }
                | Self::InBookkeeping { .. }
                | Self::InDataSet { .. }
                | Self::Spec { .. }
        )
    }
}

/// Occluders of `set` with no free place (in frame `frame`, or for the whole set), as a spec
/// error at the `Occluders` entry (per-frame or not) the unplaced one came from.
fn crowded(
    at: &spec::SpecText,
    set: &SetSpec,
    per_frame: bool,
    frame: Option<usize>,
    error: &occluders::NoFreePlace,
) -> DatasetError {
    // Per-frame occluders are numbered after the set's own.
    let mut numbered = if per_frame {
        set.occluders.iter().filter(|o| !o.per_frame).map(|o| o.count).sum()
    } else {
        0
    };
    let entry = set
        .occluders
        .iter()
        .enumerate()
        .filter(|(_, o)| o.per_frame == per_frame)
        .find(|(_, o)| {
            numbered += o.count;
            error.number <= numbered
        })
        .map_or(0, |(i, _)| i);
    at.error(
        spec::Place {
            set: Some(&set.name),
            field: format!("occluders[{entry}]"),
        },
        format!(
            "{}{error}; lower their count or clearance, or widen their region",
            frame.map(|i| format!("frame {i}: ")).unwrap_or_default()
        ),
    )
}

/// `most` indices from 0 to `total` − 1 (all of them if there are no more), evenly spread,
/// the first and the last included: the frames a picture shows of a large set.
pub(crate) fn evenly_spread(total: usize, most: usize) -> Vec<usize> {
    if total <= most {
        return (0..total).collect();
    }
    (0..most).map(|k| k * (total - 1) / (most - 1).max(1)).collect()
}

/// What to do about the system errors a user can fix.
fn io_hint(error: &std::io::Error) -> &'static str {
    use std::io::ErrorKind;
    match error.kind() {
        ErrorKind::NotADirectory => " (a part of this path is a file, not a folder: choose another path)",
        ErrorKind::StorageFull => " (the disk is full: free space, then run the same command again to resume)",
        ErrorKind::PermissionDenied => " (no permission to write there: choose another folder)",
        ErrorKind::ReadOnlyFilesystem => " (the file system is read-only: choose another folder)",
        _ => "",
    }
}

/// World positions of `rig`'s optical centres at `pose` (what occluders keep away from).
fn centres(rig: &Rig, pose: &Pose) -> Vec<DVec3> {
    match rig {
        Rig::Single(_) => vec![pose.position],
        Rig::Stereo(stereo) => (stereo.pinholes().iter())
            .map(|eye| pose.position + pose.world_from_body_rotation() * eye.position)
            .collect(),
    }
}

/// A pose a set leaves out, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SkippedPose {
    /// Position in the pose source's list, from 0.
    pub source_index: usize,
    /// Position, metres.
    pub position: [f64; 3],
    /// Why: outside the scene, or inside which object.
    pub reason: String,
}

/// A set made ready: its spec, its poses and its per-set occluders.
#[derive(Debug, Clone)]
pub struct SetPlan {
    /// The set as written.
    pub spec: SetSpec,
    /// Frame i is rendered from `poses[i]`.
    pub poses: Vec<Pose>,
    /// Poses left out (inside objects, outside the scene).
    pub skipped: Vec<SkippedPose>,
    /// Occluders shared by every frame of the set.
    pub occluders: Vec<Occluder>,
}

/// A loaded spec: scene, rig and planned sets.
pub struct Dataset {
    /// The spec as parsed.
    pub spec: Spec,
    /// The spec file.
    pub spec_path: PathBuf,
    spec_text: String,
    /// The scene it names.
    pub scene: Scene,
    scene_path: PathBuf,
    scene_sha256: String,
    /// The vision system.
    pub rig: Rig,
    /// The sets, in spec order.
    pub sets: Vec<SetPlan>,
    /// What the user should hear (skipped poses).
    pub warnings: Vec<String>,
    bvh: SceneBvh,
}

impl Dataset {
    /// Reads and checks the spec at `path` and its scene, and plans every set's poses and
    /// per-set occluders.
    pub fn load(path: &Path) -> Result<Self, DatasetError> {
        let text = omnisim::input::read_text(path, omnisim::input::SCENE_LIMIT)?;
        Self::from_text(text, path)
    }

    /// As [`Dataset::load`], with the spec's text given (`path` locates the scene and errors).
    pub fn from_text(text: String, path: &Path) -> Result<Self, DatasetError> {
        let spec = spec::parse(&text, path)?;
        let at = spec::SpecText { text: &text, path };
        let top = |field: &str, message: String| {
            at.error(
                spec::Place {
                    set: None,
                    field: field.into(),
                },
                message,
            )
        };
        let rig = spec.rig.build().map_err(|e| top("rig", e.to_string()))?;
        if !spec.outputs.writes_frame_files(&rig) {
            return Err(top(
                "outputs",
                "no output is written for this rig's frames: turn on colour, range or point_cloud (depth is \
                 written for pinhole views only, disparity for stereo rigs only)"
                    .into(),
            ));
        }
        let scene_path = spec::scene_path(&spec, path).map_err(|m| top("scene", m))?;
        let scene_text = omnisim::input::read_text(&scene_path, omnisim::input::SCENE_LIMIT)?;
        let mut scene = Scene::from_ron(&scene_text, &scene_path)?;
        scene.source = Some(scene_path.clone());
        spec.outputs
            .check_scene(&scene)
            .map_err(|e| top("outputs", e.to_string()))?;
        let bvh = SceneBvh::build(&scene).map_err(omnisim::RenderError::from)?;
        let mut warnings = scene.warnings.clone();
        let mut sets = Vec::with_capacity(spec.sets.len());
        let mut total_poses = 0;
        for set in &spec.sets {
            let fail = |field: &str, message: String| {
                at.error(
                    spec::Place {
                        set: Some(&set.name),
                        field: field.into(),
                    },
                    message,
                )
            };
            appearance::check(&scene, set).map_err(|(field, m)| fail(&field, m))?;
            let all = poses(&spec, set, &scene, &bvh).map_err(|too_few| {
                fail(
                    "poses",
                    format!("{too_few}; lower clearance, widen low/high or ask for fewer poses"),
                )
            })?;
            // A guard behind the spec's bounds: manifests cannot hold a non-finite number.
            if let Some(n) = all
                .iter()
                .position(|p| !(p.position.is_finite() && p.angles.is_finite()))
            {
                return Err(fail(
                    "poses",
                    format!(
                        "pose #{n} is not finite; keep coordinates and angles within ±{:e}",
                        spec::MAX_MAGNITUDE
                    ),
                ));
            }
            total_poses += all.len();
            if total_poses > spec::MAX_POSES {
                return Err(fail(
                    "poses",
                    format!(
                        "the sets so far hold {total_poses} poses, more than {} in all",
                        spec::MAX_POSES
                    ),
                ));
            }
            let (poses, skipped) = sort_misplaced(&scene, &bvh, all);
            if !skipped.is_empty() {
                let summary = describe_skipped(&skipped);
                if set.misplaced == MisplacedPolicy::Refuse {
                    return Err(fail("poses", format!("{summary} (misplaced: Refuse)")));
                }
                warnings.push(format!("set '{}': skipped {summary}", set.name));
            }
            if poses.is_empty() {
                return Err(fail("poses", "no pose is left to render".into()));
            }
            let shared: Vec<_> = set.occluders.iter().filter(|o| !o.per_frame).collect();
            let occluders = if shared.is_empty() {
                Vec::new()
            } else {
                let cameras: Vec<DVec3> = poses.iter().flat_map(|p| centres(&rig, p)).collect();
                let mut rng = rng::stream(spec.seed, &set.name, None, rng::Purpose::Occluders);
                occluders::place(&scene, &bvh, &shared, &cameras, &[], &mut rng)
                    .map_err(|e| crowded(&at, set, false, None, &e))?
            };
            sets.push(SetPlan {
                spec: set.clone(),
                poses,
                skipped,
                occluders,
            });
        }
        let dataset = Self {
            scene_sha256: manifest::sha256_hex(scene_text.as_bytes()),
            spec,
            spec_path: path.to_path_buf(),
            spec_text: text,
            scene,
            scene_path,
            rig,
            sets,
            warnings,
            bvh,
        };
        for s in 0..dataset.sets.len() {
            dataset.check_frame_occluders(s)?;
        }
        Ok(dataset)
    }

    /// Places every frame's per-frame occluders of set `s` (on every core; discarded: a frame
    /// draws the same ones from its own stream as it renders), so that a spec asking for more
    /// than fits fails at load, not after the sets before it have rendered. The error is the
    /// first such frame's.
    fn check_frame_occluders(&self, s: usize) -> Result<(), DatasetError> {
        let frames = self.sets[s].poses.len();
        if !self.sets[s].spec.occluders.iter().any(|o| o.per_frame) {
            return Ok(());
        }
        let threads = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
        let chunk = frames.div_ceil(threads).max(1);
        std::thread::scope(|scope| {
            let checks: Vec<_> = (0..frames)
                .step_by(chunk)
                .map(|start| {
                    scope.spawn(move || {
                        (start..frames.min(start + chunk)).try_for_each(|i| self.frame_occluders(s, i).map(drop))
                    })
                })
                .collect();
            checks
                .into_iter()
                .try_for_each(|check| check.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
        })
    }

    /// Number of frames over every set.
    pub fn frame_count(&self) -> usize {
        self.sets.iter().map(|s| s.poses.len()).sum()
    }
}

/// Every pose a set's source gives, before misplaced ones are left out.
fn poses(spec: &Spec, set: &SetSpec, scene: &Scene, bvh: &SceneBvh) -> Result<Vec<Pose>, pose_sets::TooFewClear> {
    let degrees = |(x, y, z): (f64, f64, f64)| dvec3(x, y, z) * (std::f64::consts::PI / 180.0);
    Ok(match &set.poses {
        PoseSource::Trajectory {
            through,
            spacing,
            count,
            heading,
        } => {
            let waypoints: Vec<DVec3> = through.iter().map(|&p| p.into()).collect();
            let length: f64 = waypoints.windows(2).map(|w| w[0].distance(w[1])).sum();
            let step = spacing.unwrap_or_else(|| length / (count.unwrap_or(2) - 1) as f64);
            let mut poses = pose_sets::trajectory(&waypoints, step);
            if let Some(n) = count {
                // Rounding may add a pose a hair before the end: keep the last one, the end.
                while poses.len() > *n {
                    poses.remove(poses.len() - 2);
                }
            }
            if let Heading::Fixed { angles } = heading {
                for pose in &mut poses {
                    pose.angles = degrees(*angles);
                }
            }
            poses
        }
        PoseSource::Grid { x, y, z, headings } => headings
            .iter()
            .flat_map(|&heading| {
                pose_sets::grid(
                    &pose_sets::steps(x.0, x.1, x.2),
                    &pose_sets::steps(y.0, y.1, y.2),
                    z,
                    dvec3(0.0, 0.0, heading.to_radians()),
                )
            })
            .collect(),
        PoseSource::Random {
            count,
            low,
            high,
            tilt,
            clearance,
            angles,
            seed,
        } => {
            // A set's own seed stands for the spec's and the set's name ("" names no set).
            let (seed, key) = match seed {
                Some(seed) => (*seed, ""),
                None => (spec.seed, set.name.as_str()),
            };
            let mut poses = pose_sets::random(
                scene,
                bvh,
                &RandomPoses {
                    count: *count,
                    seed: rng::seed_u64(seed, key, rng::Purpose::Poses),
                    low: (*low).into(),
                    high: (*high).into(),
                    max_tilt: tilt.to_radians(),
                    clearance: *clearance,
                },
            )?;
            if let Some(ranges) = angles {
                // Positions as drawn above; angles from a stream of their own.
                let mut rng = rng::stream(seed, key, None, rng::Purpose::Angles);
                for pose in &mut poses {
                    *pose = Pose::new(pose.position, degrees(draw_angles(ranges, &mut rng)));
                }
            }
            poses
        }
        PoseSource::List(list) => list
            .iter()
            .map(|&(x, y, z, ax, ay, az)| Pose::from_degrees(dvec3(x, y, z), dvec3(ax, ay, az)))
            .collect(),
    })
}

/// θx, θy, θz (degrees), each uniform in its (min, max).
fn draw_angles(ranges: &spec::AngleRanges, rng: &mut impl rand::Rng) -> (f64, f64, f64) {
    let mut draw = |(low, high): (f64, f64)| low + (high - low) * rng.random::<f64>();
    (draw(ranges.0), draw(ranges.1), draw(ranges.2))
}

/// Splits poses into those to render and those inside a closed object or outside the scene.
fn sort_misplaced(scene: &Scene, bvh: &SceneBvh, all: Vec<Pose>) -> (Vec<Pose>, Vec<SkippedPose>) {
    let mut kept = Vec::with_capacity(all.len());
    let mut skipped = Vec::new();
    for (source_index, pose) in all.into_iter().enumerate() {
        match pose_sets::misplaced(scene, bvh, pose.position) {
            None => kept.push(pose),
            Some(place) => skipped.push(SkippedPose {
                source_index,
                position: pose.position.to_array(),
                reason: match place {
                    Misplaced::OutsideBounds => "outside the scene".into(),
                    Misplaced::Inside(object) => format!("inside '{object}'"),
                },
            }),
        }
    }
    (kept, skipped)
}

/// "3 poses: 2 inside 'table' (#4, #17), 1 outside the scene (#50)".
fn describe_skipped(skipped: &[SkippedPose]) -> String {
    let mut reasons: Vec<(&str, Vec<usize>)> = Vec::new();
    for s in skipped {
        match reasons.iter_mut().find(|(r, _)| *r == s.reason) {
            Some((_, list)) => list.push(s.source_index),
            None => reasons.push((&s.reason, vec![s.source_index])),
        }
    }
    let parts: Vec<String> = reasons
        .iter()
        .map(|(reason, list)| {
            let shown: Vec<String> = list.iter().take(5).map(|i| format!("#{i}")).collect();
            let more = if list.len() > 5 { ", ..." } else { "" };
            format!("{} {reason} ({}{more})", list.len(), shown.join(", "))
        })
        .collect();
    format!("{} pose(s): {}", skipped.len(), parts.join(", "))
}
