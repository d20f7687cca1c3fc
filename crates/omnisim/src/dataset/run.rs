//! Rendering a data set into a folder, resuming, sharding and merging.
//!
//! Folder: `.omnisim-dataset.json` (the stamp: which spec and scene, how many frames per
//! set), then per set `<set>/` with the frame files, the set files (calibration), the layouts
//! (`tum/`, `mav0/`) and `.frames/` (one entry per done frame, and `set.json`). Every file
//! is written atomically; a frame is done when its entry exists, so a killed run re-renders
//! at most the frames it was writing, with the same bytes. `merge` checks every file's hash
//! and writes the layouts' index files and `manifest.json`; the merge that ends an unsharded
//! run checks only the sizes of the frames that run wrote itself (it hashed them as it wrote
//! them, so a file changed during the run without changing size goes unnoticed until the
//! next `omnisim dataset merge`) and hashes the frames earlier runs left.

use std::collections::HashSet;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};

use serde::Serialize;

use super::appearance::{AppearanceRecord, frame_appearance};
use super::contact_sheet::{self, CONTACT_SHEET};
use super::layout::{self, Image};
use super::manifest::{
    FileEntry, FileKind, FrameEntry, Manifest, ManifestSet, PoseEntry, SetEntry, Stamp, file_entry, inside,
    read_verified, sha256_hex, to_json, verify, verify_size,
};
use super::occluders::{self, Occluder};
use super::rng::{Purpose, stream};
use super::{Dataset, DatasetError, SetPlan, noise};
use crate::camera::Camera;
use crate::frame::{Frame, Plane, Planes};
use crate::output::{self, FrameTarget, PlainFolder, SegmentObject, SegmentationLegend, atomic};
use crate::renderer::{PreparedScene, Renderer};
use crate::rig::Rig;

/// The stamp's file name in a data-set folder.
pub(crate) const STAMP: &str = ".omnisim-dataset.json";
/// The manifest's file name.
pub(crate) const MANIFEST: &str = "manifest.json";
/// Folder of a set's frame entries.
const ENTRIES: &str = ".frames";
/// A set's own entry, in `ENTRIES`.
const SET_ENTRY: &str = "set.json";

/// Slice `index` (from 0) of `count` disjoint slices: frame n of the data set (counted over
/// every set in spec order) belongs to slice n mod count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This slice, 0 ≤ index < count.
    pub index: usize,
    /// Number of slices.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N`, 0 ≤ K < N (Slurm array and Kubernetes indexed-job numbering).
    fn from_str(text: &str) -> Result<Self, String> {
        let parsed = text
            .split_once('/')
            .and_then(|(k, n)| Some((k.trim().parse::<usize>().ok()?, n.trim().parse::<usize>().ok()?)));
        match parsed {
            Some((index, count)) if index < count => Ok(Shard { index, count }),
            _ => Err(format!("'{text}' is not a shard K/N with 0 ≤ K < N, e.g. 0/4")),
        }
    }
}

impl Shard {
    /// Whether frame `n` (counted over every set in spec order) is this slice's.
    pub fn takes(&self, n: usize) -> bool {
        n % self.count == self.index
    }
}

/// How to run.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions {
    /// Render only this slice (and leave the merge to `merge`).
    pub shard: Option<Shard>,
    /// Remove another spec's data set from the folder first (only the files it recorded).
    pub overwrite: bool,
    /// Threads that write frames while the next ones render (at least 1); `None`: from the
    /// machine's cores, 2 to 4.
    pub writers: Option<usize>,
}

/// A frame finished (or found done), for progress reports. Frames are written on several
/// threads, so they are reported as they finish, not always in frame order.
#[derive(Debug, Clone)]
pub struct FrameDone<'a> {
    /// Its set.
    pub set: &'a str,
    /// Its index in the set.
    pub index: usize,
    /// Rendered now (false: done by an earlier run).
    pub rendered: bool,
    /// Bytes of its files.
    pub bytes: u64,
    /// Frames of this run done so far, this one included.
    pub done: usize,
    /// Frames of this run (this shard).
    pub total: usize,
}

/// What a run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSummary {
    /// Frames rendered now.
    pub rendered: usize,
    /// Frames an earlier run had done.
    pub resumed: usize,
    /// Bytes written now.
    pub bytes: u64,
    /// The callback stopped the run early.
    pub stopped: bool,
    /// Index files and manifest written (an unsharded, complete run).
    pub merged: bool,
    /// What the user should hear (cleaned-up temporaries, removed data sets).
    pub notes: Vec<String>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> DatasetError + '_ {
    move |source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    }
}

pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    atomic::write_atomically(path, |out| std::io::Write::write_all(out, bytes)).map_err(io(path))
}

/// Creates `dir` and removes the temporaries a killed run left there.
fn prepare_dir(dir: &Path) -> Result<(), DatasetError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    atomic::remove_stale_temporaries(dir).map_err(io(dir))?;
    Ok(())
}

/// [`prepare_dir`] for a folder inside the data-set folder `root`, refused where a level is a
/// link (a set folder linked elsewhere would have the run write there).
fn prepare_subdir(root: &Path, dir: &Path) -> Result<(), DatasetError> {
    output::folder::create_real_folder(root, dir).map_err(|e| match e {
        output::folder::RealFolderError::Link(path) => DatasetError::Link { path },
        output::folder::RealFolderError::Io(path, source) => DatasetError::Io { path, source },
    })?;
    atomic::remove_stale_temporaries(dir).map_err(io(dir))?;
    Ok(())
}

/// Refuses a folder without a stamp that holds visible files: someone else's.
fn refuse_unrecorded(dir: &Path) -> Result<(), DatasetError> {
    let listing = std::fs::read_dir(dir).map_err(io(dir))?;
    let example = listing
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .find(|name| !name.starts_with('.'));
    match example {
        Some(example) => Err(DatasetError::Unrecorded {
            dir: dir.to_path_buf(),
            example,
        }),
        None => Ok(()),
    }
}

fn read_stamp(dir: &Path) -> Result<Option<Stamp>, DatasetError> {
    let path = dir.join(STAMP);
    match std::fs::read(&path) {
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| DatasetError::BadStamp {
                path: path.clone(),
                problem: format!("not a data-set stamp: {e}"),
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io(&path)(e)),
    }
}

fn describe(stamp: &Stamp) -> String {
    format!(
        "spec {} (SHA-256 {}…), scene {} ({}…)",
        stamp.spec_file,
        short_hash(&stamp.spec_sha256),
        stamp.scene_file,
        short_hash(&stamp.scene_sha256)
    )
}

/// The first 12 characters of a hash read from a stamp file, which may have been edited.
fn short_hash(hash: &str) -> &str {
    hash.get(..12).unwrap_or(hash)
}

/// The files of a layout's index, for every layout (to remove a previous data set's).
fn index_names(set: &SetEntry) -> Vec<String> {
    let mut names = Vec::new();
    for layout in &set.layouts {
        match layout {
            super::spec::LayoutSpec::Tum { .. } => names.extend(
                ["rgb.txt", "depth.txt", "groundtruth.txt", "groundtruth-body.txt"].map(|n| format!("tum/{n}")),
            ),
            super::spec::LayoutSpec::Euroc { .. } => {
                for k in 0..2 {
                    names.extend(["data.csv", "sensor.yaml"].map(|n| format!("mav0/cam{k}/{n}")));
                }
                names.push("mav0/state_groundtruth_estimate0/data.csv".into());
            }
        }
    }
    names
}

/// Removes exactly the files a previous data set recorded (entries, set files, index files,
/// manifest, stamp); returns how many.
fn remove_previous(dir: &Path, previous: &Stamp) -> Result<usize, DatasetError> {
    let mut removed = 0;
    let mut remove = |path: &Path| -> Result<(), DatasetError> {
        match std::fs::symlink_metadata(path) {
            Ok(m) if !m.is_dir() => {
                std::fs::remove_file(path).map_err(io(path))?;
                removed += 1;
                Ok(())
            }
            Ok(_) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(io(path)(e)),
        }
    };
    for set in &previous.sets {
        // Every path through `inside`: a link anywhere below `dir` is not followed.
        let within = |name: &str| inside(dir, &format!("{}/{name}", set.name));
        if let Some(entries) = within(ENTRIES) {
            for entry in read_entry_paths(&entries)? {
                if let Ok(frame) = serde_json::from_slice::<FrameEntry>(&std::fs::read(&entry).unwrap_or_default()) {
                    for file in frame.files.iter().filter_map(|f| inside(dir, &f.path)) {
                        remove(&file)?;
                    }
                }
                remove(&entry)?;
            }
        }
        if let Some(own_path) = within(&format!("{ENTRIES}/{SET_ENTRY}")) {
            if let Ok(own) = serde_json::from_slice::<SetEntry>(&std::fs::read(&own_path).unwrap_or_default()) {
                for file in own.files.iter().filter_map(|f| inside(dir, &f.path)) {
                    remove(&file)?;
                }
            }
            remove(&own_path)?;
        }
        for name in index_names(set).into_iter().chain([CONTACT_SHEET.to_string()]) {
            if let Some(path) = within(&name) {
                remove(&path)?;
            }
        }
    }
    remove(&dir.join(MANIFEST))?;
    remove(&dir.join(STAMP))?;
    Ok(removed)
}

/// Frame entry files of a set (`NNNNNN.json`), sorted; none if the folder is missing.
fn read_entry_paths(entries: &Path) -> Result<Vec<PathBuf>, DatasetError> {
    let listing = match std::fs::read_dir(entries) {
        Ok(listing) => listing,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io(entries)(e)),
    };
    let mut paths = Vec::new();
    for item in listing {
        let path = item.map_err(io(entries))?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        if name.strip_suffix(".json").is_some_and(|n| n.parse::<usize>().is_ok()) {
            paths.push(path);
        }
    }
    paths.sort();
    Ok(paths)
}

fn entry_path(set_dir: &Path, index: usize) -> PathBuf {
    set_dir.join(ENTRIES).join(format!("{index:06}.json"))
}

/// Opens `dir` for the data set `stamp`: refuses another spec's data set (or files no data
/// set recorded) unless `overwrite`, and writes the stamp. Returns notes.
fn open_folder(dir: &Path, stamp: &Stamp, overwrite: bool) -> Result<Vec<String>, DatasetError> {
    prepare_dir(dir)?;
    let mut notes = Vec::new();
    let previous = match read_stamp(dir) {
        // Nothing tells which files were its own: they stay, and new ones replace them.
        Err(DatasetError::BadStamp { problem, .. }) if overwrite => {
            notes.push(format!(
                "--overwrite: the previous stamp is unreadable ({problem}); its files stay"
            ));
            None
        }
        previous => previous?,
    };
    match previous {
        Some(previous) if previous.identity == stamp.identity && same_renderer(dir, &previous, stamp).is_ok() => {}
        // The same spec by another renderer; or an earlier omnisim's stamp, which has no
        // geometry hash, so its identity cannot match: saying so beats calling it another spec.
        Some(previous) if !overwrite && (previous.identity == stamp.identity || previous.version.is_empty()) => {
            same_renderer(dir, &previous, stamp)?
        }
        Some(previous) if !overwrite => {
            return Err(DatasetError::AnotherSpec {
                dir: dir.to_path_buf(),
                previous: describe(&previous),
            });
        }
        Some(previous) => {
            let removed = remove_previous(dir, &previous)?;
            notes.push(format!(
                "--overwrite: removed {removed} file(s) of the previous data set ({})",
                describe(&previous)
            ));
        }
        None if overwrite => {}
        None => refuse_unrecorded(dir)?,
    }
    write_file(&dir.join(STAMP), &to_json(stamp))?;
    Ok(notes)
}

/// Refuses frames of `theirs`'s version or renderer beside those of `ours` (same spec).
fn same_renderer(dir: &Path, theirs: &Stamp, ours: &Stamp) -> Result<(), DatasetError> {
    let made_by = |stamp: &Stamp| match (stamp.version.as_str(), stamp.renderer.as_str()) {
        ("", _) | (_, "") => "an omnisim version that did not record its renderer".to_string(),
        (version, renderer) => format!("omnisim {version} ({renderer})"),
    };
    let (recorded, current) = (made_by(theirs), made_by(ours));
    if recorded == current {
        Ok(())
    } else {
        Err(DatasetError::OtherRenderer {
            dir: dir.to_path_buf(),
            recorded,
            current,
        })
    }
}

/// Whether frame `index` of a set is done: its entry parses and its files have their sizes.
fn is_done(root: &Path, set_dir: &Path, index: usize) -> Option<u64> {
    let entry: FrameEntry = serde_json::from_slice(&std::fs::read(entry_path(set_dir, index)).ok()?).ok()?;
    let sizes_match = entry.files.iter().all(|f| {
        inside(root, &f.path)
            .and_then(|p| std::fs::metadata(p).ok())
            .is_some_and(|m| m.len() == f.bytes)
    });
    sizes_match.then(|| entry.files.iter().map(|f| f.bytes).sum())
}

/// Writer threads: as asked, else enough to keep up with the renderer and few enough to
/// leave it the cores.
fn writer_threads(asked: Option<usize>) -> usize {
    match asked {
        Some(writers) => writers.max(1),
        None => std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(2, 4),
    }
}

/// How a frame of a run came to be done.
enum Outcome {
    /// An earlier run wrote it: its bytes.
    Resumed(u64),
    /// Written now: its bytes.
    Written(u64),
}

/// The run's tally of done frames, and whether the run goes on.
struct Heard<'a, 'b> {
    names: Vec<&'a str>,
    summary: &'b mut RunSummary,
    on_frame: &'b mut dyn FnMut(&FrameDone) -> ControlFlow<()>,
    done: usize,
    total: usize,
    /// The first error; the run stops rendering and lets the frames in flight finish.
    failure: Option<DatasetError>,
    /// Set on an error or when `on_frame` asks to stop.
    stopped: bool,
    /// Tells the writers to drop the frames still queued (they are not done; a later run
    /// renders them again).
    stop: &'b AtomicBool,
    /// (set name, frame) of every frame this run wrote: their entries hold hashes of the files
    /// as written, which the final merge need not compute again.
    written: HashSet<(&'a str, usize)>,
}

impl Heard<'_, '_> {
    /// Counts frame `index` of set `s` and tells `on_frame`.
    fn frame(&mut self, s: usize, index: usize, outcome: Result<Outcome, DatasetError>) {
        let (rendered, bytes) = match outcome {
            Ok(Outcome::Resumed(bytes)) => {
                self.summary.resumed += 1;
                (false, bytes)
            }
            Ok(Outcome::Written(bytes)) => {
                self.written.insert((self.names[s], index));
                self.summary.rendered += 1;
                self.summary.bytes += bytes;
                (true, bytes)
            }
            Err(error) => {
                self.failure.get_or_insert(error);
                self.stop();
                return;
            }
        };
        self.done += 1;
        let report = FrameDone {
            set: self.names[s],
            index,
            rendered,
            bytes,
            done: self.done,
            total: self.total,
        };
        if (self.on_frame)(&report).is_break() {
            self.stop();
        }
    }

    fn stop(&mut self) {
        self.stopped = true;
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// A frame rendered and not yet written.
struct RenderedFrame {
    set: usize,
    index: usize,
    /// One per view of the rig.
    frames: Vec<Frame>,
    /// Its per-frame occluders, each with its ids in this frame's segmentation images (where
    /// the data set writes them).
    placed: Vec<(Occluder, Option<SegmentObject>)>,
    record: AppearanceRecord,
}

/// A set's prepared scene, with its per-set occluders, kept while its frames render.
struct SetScene {
    set: usize,
    scene: crate::Scene,
    prepared: PreparedScene,
}

#[derive(Serialize)]
struct Perturbations<'a> {
    #[serde(flatten)]
    appearance: AppearanceRecord,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    occluders: Vec<OccluderRecord<'a>>,
}

/// An occluder in a frame's entry.
#[derive(Serialize)]
struct OccluderRecord<'a> {
    #[serde(flatten)]
    occluder: &'a Occluder,
    /// A per-frame occluder's object and face ids in this frame's segmentation images (the
    /// set's `segmentation.json` lists the scene's objects and the set-wide occluders).
    #[serde(skip_serializing_if = "Option::is_none")]
    segment: Option<&'a SegmentObject>,
}

impl Dataset {
    /// The stamp of this data set, rendered by `renderer`.
    fn stamp(&self, renderer: &Renderer) -> Stamp {
        let spec_sha256 = sha256_hex(self.spec_text.as_bytes());
        let name = |p: &Path| {
            p.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        };
        // Hashed here, once per run, not on every load (a preview needs none).
        let geometry_sha256 = super::manifest::geometry_sha256(&self.scene);
        let identity = format!("{spec_sha256} {} {geometry_sha256}", self.scene_sha256);
        Stamp {
            identity: sha256_hex(identity.as_bytes()),
            version: env!("CARGO_PKG_VERSION").into(),
            renderer: renderer.renders_with(),
            geometry_sha256,
            spec_file: name(&self.spec_path),
            spec_text: self.spec_text.clone(),
            spec_sha256,
            scene_file: name(&self.scene_path),
            scene_sha256: self.scene_sha256.clone(),
            sets: self.sets.iter().map(|set| set_entry(set, Vec::new())).collect(),
        }
    }

    /// Renders the frames of `options.shard` (all frames without one) into `out`, skipping
    /// those an earlier run finished, then, without a shard, merges. Frames render on this
    /// thread while writer threads write the ones before them. `on_frame` hears of every
    /// frame and may stop the run (frames being written finish; a later run resumes the rest).
    pub fn run(
        &self,
        renderer: &Renderer,
        out: &Path,
        options: &RunOptions,
        on_frame: &mut dyn FnMut(&FrameDone) -> ControlFlow<()>,
    ) -> Result<RunSummary, DatasetError> {
        let mut summary = RunSummary {
            notes: open_folder(out, &self.stamp(renderer), options.overwrite)?,
            ..RunSummary::default()
        };
        for set in &self.sets {
            self.prepare_set(out, set)?;
        }
        let frames: Vec<(usize, usize)> = self
            .sets
            .iter()
            .enumerate()
            .flat_map(|(s, set)| (0..set.poses.len()).map(move |i| (s, i)))
            .enumerate()
            .filter(|(n, _)| options.shard.is_none_or(|shard| shard.takes(*n)))
            .map(|(_, frame)| frame)
            .collect();
        let stop = AtomicBool::new(false);
        let mut heard = Heard {
            names: self.sets.iter().map(|s| s.spec.name.as_str()).collect(),
            summary: &mut summary,
            on_frame,
            done: 0,
            total: frames.len(),
            failure: None,
            stopped: false,
            stop: &stop,
            written: HashSet::new(),
        };
        // Frames render here, one after another (the renderer is not shared), while writer
        // threads encode and write the frames before them; a bounded queue keeps at most a
        // few rendered frames in memory. Each frame's entry is its last file, so whatever
        // moment a run is killed at, a frame is done exactly when its entry exists.
        let writers = writer_threads(options.writers);
        let (to_write, queue) = mpsc::sync_channel::<RenderedFrame>(writers);
        // Shared by the writers alone: if every writer ends (a panic), the queue closes and
        // the renderer's next send fails instead of waiting for ever.
        let queue = Arc::new(Mutex::new(queue));
        let (report, written) = mpsc::channel();
        std::thread::scope(|scope| {
            for _ in 0..writers {
                let (queue, report, stop) = (Arc::clone(&queue), report.clone(), &stop);
                scope.spawn(move || {
                    while let Some(frame) = queue.lock().ok().and_then(|q| q.recv().ok()) {
                        if stop.load(Ordering::Relaxed) {
                            continue;
                        }
                        let (set, index) = (frame.set, frame.index);
                        if report.send((set, index, self.write_frame(out, frame))).is_err() {
                            break;
                        }
                    }
                });
            }
            drop((report, queue));
            let mut current: Option<SetScene> = None;
            for &(s, index) in &frames {
                while let Ok((set, i, result)) = written.try_recv() {
                    heard.frame(set, i, result.map(Outcome::Written));
                }
                if heard.stopped {
                    break;
                }
                let outcome = match is_done(out, &out.join(&self.sets[s].spec.name), index) {
                    Some(bytes) => Ok(Outcome::Resumed(bytes)),
                    None => {
                        let scene = match current.take() {
                            Some(scene) if scene.set == s => Ok(scene),
                            _ => self.set_scene(renderer, s),
                        };
                        let rendered = scene.and_then(|mut scene| {
                            let frame = self.render_frame(renderer, &mut scene, index);
                            current = Some(scene);
                            frame
                        });
                        match rendered {
                            Ok(frame) => match to_write.send(frame) {
                                Ok(()) => continue,
                                Err(_) => break, // every writer has ended: the scope reports why
                            },
                            Err(e) => Err(e),
                        }
                    }
                };
                heard.frame(s, index, outcome);
            }
            drop(to_write);
            for (set, i, result) in written {
                heard.frame(set, i, result.map(Outcome::Written));
            }
        });
        let (failure, done, written) = (heard.failure, heard.done, heard.written);
        if let Some(failure) = failure {
            return Err(failure);
        }
        summary.stopped = done < frames.len();
        if options.shard.is_none() && !summary.stopped {
            assemble(out, &[], &written)?;
            summary.merged = true;
        }
        Ok(summary)
    }

    /// Creates a set's folders and writes its set files and `set.json`.
    fn prepare_set(&self, out: &Path, set: &SetPlan) -> Result<(), DatasetError> {
        let set_dir = out.join(&set.spec.name);
        let views = self.rig.views().len();
        prepare_subdir(out, &set_dir)?;
        prepare_subdir(out, &set_dir.join(ENTRIES))?;
        for layout in &set.spec.layouts {
            for (_, path) in layout::frame_files(layout, &set_dir, 0, views) {
                prepare_subdir(out, path.parent().unwrap_or(&set_dir))?;
            }
        }
        let scene = occluders::with_occluders(&self.scene, &set.occluders);
        let files = (self.spec.outputs)
            .write_set_files(&mut PlainFolder(set_dir.clone()), &scene, &self.rig)?
            .iter()
            .map(|path| file_entry(out, path, FileKind::Set))
            .collect::<Result<_, _>>()?;
        write_file(&set_dir.join(ENTRIES).join(SET_ENTRY), &to_json(&set_entry(set, files)))
    }

    /// The scene of set `s` with its per-set occluders, prepared.
    fn set_scene(&self, renderer: &Renderer, s: usize) -> Result<SetScene, DatasetError> {
        let set = &self.sets[s];
        let (scene, prepared) = if set.occluders.is_empty() {
            (
                self.scene.clone(),
                renderer.prepare_with(&self.scene, self.bvh.clone())?,
            )
        } else {
            let scene = occluders::with_occluders(&self.scene, &set.occluders);
            let prepared = renderer.prepare(&scene)?;
            (scene, prepared)
        };
        Ok(SetScene {
            set: s,
            scene,
            prepared,
        })
    }

    /// The per-frame occluders of frame `index` of set `s` (none if the set has no per-frame
    /// occluders), drawn from the frame's own stream.
    pub(crate) fn frame_occluders(&self, s: usize, index: usize) -> Result<Vec<Occluder>, DatasetError> {
        let plan = &self.sets[s];
        let per_frame: Vec<_> = plan.spec.occluders.iter().filter(|o| o.per_frame).collect();
        if per_frame.is_empty() {
            return Ok(Vec::new());
        }
        let mut rng = stream(self.spec.seed, &plan.spec.name, Some(index), Purpose::Occluders);
        occluders::place(
            &self.scene,
            &self.bvh,
            &per_frame,
            &super::centres(&self.rig, &plan.poses[index]),
            &plan.occluders,
            &mut rng,
        )
        .map_err(|source| DatasetError::Occluders {
            set: plan.spec.name.clone(),
            frame: index.to_string(),
            source,
        })
    }

    /// Renders frame `index` of the set of `base` (its per-frame occluders, lights and
    /// colours applied): what `write_frame` then writes.
    fn render_frame(
        &self,
        renderer: &Renderer,
        base: &mut SetScene,
        index: usize,
    ) -> Result<RenderedFrame, DatasetError> {
        let set = &self.sets[base.set].spec;
        let pose = &self.sets[base.set].poses[index];
        let placed = self.frame_occluders(base.set, index)?;
        let mut own = None;
        let mut segments = vec![None; placed.len()];
        if !placed.is_empty() {
            let scene = occluders::with_occluders(&base.scene, &placed);
            if self.spec.outputs.segmentation {
                // The placed occluders are the frame scene's last objects.
                let legend = SegmentationLegend::of(&scene);
                segments = legend.objects[legend.objects.len() - placed.len()..]
                    .iter()
                    .cloned()
                    .map(Some)
                    .collect();
            }
            own = Some((renderer.prepare(&scene)?, scene));
        }
        let (prepared, scene) = match own.as_mut() {
            Some((prepared, scene)) => (prepared, &*scene),
            None => (&mut base.prepared, &base.scene),
        };
        let (appearance, record) = frame_appearance(scene, self.scene.objects.len(), set, self.spec.seed, index);
        renderer.set_appearance(prepared, appearance)?;
        let mut planes = self.spec.outputs.planes();
        if !set.noise.colour.is_empty() {
            planes = planes.with(Plane::LinearColour);
        }
        let frames = self
            .rig
            .views()
            .iter()
            .map(|view| {
                renderer.render_antialiased(prepared, &view.camera, pose, planes, self.spec.edge_samples.isqrt())
            })
            .collect::<Result<Vec<Frame>, _>>()?;
        Ok(RenderedFrame {
            set: base.set,
            index,
            frames,
            placed: placed.into_iter().zip(segments).collect(),
            record,
        })
    }

    /// Writes a rendered frame's files (ground truth, noisy copies, layouts), then its entry;
    /// returns the bytes written. Runs on a writer thread while later frames render.
    fn write_frame(&self, out: &Path, rendered: RenderedFrame) -> Result<u64, DatasetError> {
        let RenderedFrame {
            set: s,
            index,
            frames,
            placed,
            record,
        } = rendered;
        let plan = &self.sets[s];
        let set = &plan.spec;
        let set_dir = out.join(&set.name);
        let pose = &plan.poses[index];
        let seed = self.spec.seed;
        let noisy_colour = !set.noise.colour.is_empty();
        let views = self.rig.views();
        let scene_stem = self.scene.file_stem();
        let target = FrameTarget {
            scene: &scene_stem,
            index,
            pose,
        };
        let stem = target.stem();
        let mut files = Vec::new();
        let written =
            (self.spec.outputs).write_frame_files(&mut PlainFolder(set_dir.clone()), &target, &self.rig, &frames)?;
        for path in written {
            files.push(file_entry(out, &path, FileKind::GroundTruth)?);
        }
        // Noisy copies, each view's colour then depth, then disparity: one stream, fixed order.
        let mut rng = stream(seed, &set.name, Some(index), Purpose::Noise);
        let mut sensor_colour = Vec::with_capacity(views.len());
        let mut sensor_depth = None;
        let mut noisy = Vec::new();
        for (view, frame) in views.iter().zip(&frames) {
            let (suffix, camera) = (view.suffix, &view.camera);
            let size = (frame.width, frame.height);
            let colour = match (noisy_colour, frame.linear_colour()) {
                (true, Some(linear)) => {
                    let colour = noise::colour(linear, &set.noise.colour, &mut rng);
                    let path = set_dir.join(format!("{stem}{suffix}-noisy.png"));
                    output::write_png(&path, &colour_frame(size, colour.clone()))?;
                    noisy.push(path);
                    colour
                }
                _ => frame.colour().map(<[_]>::to_vec).unwrap_or_default(),
            };
            sensor_colour.push(colour);
            let depth = match camera {
                Camera::Pinhole(pinhole) => Some(pinhole.axial_depth(frame, pose)),
                _ => None,
            };
            if let Some(model) = &set.noise.depth {
                match &depth {
                    Some(depth) => {
                        let values = noise::depth(depth, model, &mut rng);
                        let png = set_dir.join(format!("{stem}{suffix}-depth-noisy.png"));
                        output::write_tum_depth_png(&png, size, &values)?;
                        let exr = set_dir.join(format!("{stem}{suffix}-depth-noisy.exr"));
                        output::write_axial_depth_exr(&exr, size, values.clone(), self.spec.outputs.exr_compression)?;
                        noisy.extend([png, exr]);
                        sensor_depth.get_or_insert(values);
                    }
                    None => {
                        let ranges: Vec<f32> = frame.pixels().iter().map(|p| p.range).collect();
                        let values = noise::depth(&ranges, model, &mut rng);
                        let hits = frame
                            .pixels()
                            .iter()
                            .zip(values)
                            .map(|(p, range)| crate::Pixel { range, ..*p })
                            .collect();
                        let exr = set_dir.join(format!("{stem}{suffix}-range-noisy.exr"));
                        output::write_range_exr(
                            &exr,
                            &Frame::from_hits(size.0, size.1, hits),
                            camera,
                            self.spec.outputs.exr_compression,
                        )?;
                        noisy.push(exr);
                    }
                }
            }
            if sensor_depth.is_none() {
                sensor_depth = depth;
            }
        }
        if let (Some(model), Rig::Stereo(stereo)) = (&set.noise.disparity, &self.rig) {
            let values = noise::disparity(&stereo.disparity(&frames[0], pose), model, &mut rng);
            let path = set_dir.join(format!("{stem}-disparity-noisy.exr"));
            output::write_disparity_exr(
                &path,
                (frames[0].width, frames[0].height),
                values,
                self.spec.outputs.exr_compression,
            )?;
            noisy.push(path);
        }
        for path in noisy {
            files.push(file_entry(out, &path, FileKind::Noisy)?);
        }
        let size = (frames[0].width, frames[0].height);
        for layout in &set.layouts {
            for (image, path) in layout::frame_files(layout, &set_dir, index, views.len()) {
                match image {
                    Image::Colour(k) => output::write_png(&path, &colour_frame(size, sensor_colour[k].clone()))?,
                    Image::Depth => {
                        output::write_tum_depth_png(&path, size, sensor_depth.as_deref().unwrap_or_default())?
                    }
                }
                files.push(file_entry(out, &path, FileKind::Layout)?);
            }
        }
        let perturbations = Perturbations {
            appearance: record,
            occluders: (plan.occluders.iter().map(|occluder| OccluderRecord {
                occluder,
                segment: None,
            }))
            .chain(placed.iter().map(|(occluder, segment)| OccluderRecord {
                occluder,
                segment: segment.as_ref(),
            }))
            .collect(),
        };
        let entry = FrameEntry {
            index,
            stem,
            pose: PoseEntry::of(pose),
            perturbations: serde_json::to_value(&perturbations).unwrap_or_default(),
            files,
        };
        write_file(&entry_path(&set_dir, index), &to_json(&entry))?;
        Ok(entry.files.iter().map(|f| f.bytes).sum())
    }
}

fn set_entry(set: &SetPlan, files: Vec<FileEntry>) -> SetEntry {
    SetEntry {
        name: set.spec.name.clone(),
        frames: set.poses.len(),
        skipped: set.skipped.clone(),
        noise: set.spec.noise.clone(),
        layouts: set.spec.layouts.clone(),
        files,
    }
}

/// A frame holding only a colour plane, for the PNG writer.
fn colour_frame(size: (u32, u32), colour: Vec<[u8; 3]>) -> Frame {
    let mut frame = Frame::empty(size.0, size.1);
    frame.set_shading(Planes::COLOUR, Vec::new(), colour);
    frame
}

/// What `merge` found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MergeSummary {
    /// Frames over every set.
    pub frames: usize,
    /// Files listed in the manifest.
    pub files: usize,
    /// Their bytes.
    pub bytes: u64,
}

/// Copies the frames of `sources` (shard folders of the same spec, checked by hash) into
/// `dest`, checks that every frame of every set is there with the size and hash its entry
/// records, and writes the layouts' index files and `manifest.json`. With no `sources`, shards
/// wrote into `dest` itself (a shared file system).
pub fn merge(dest: &Path, sources: &[PathBuf]) -> Result<MergeSummary, DatasetError> {
    assemble(dest, sources, &HashSet::new())
}

/// [`merge`], checking only the sizes of the files of the frames in `written` ((set name,
/// frame) written by the calling run, which hashed them as it wrote them).
fn assemble(dest: &Path, sources: &[PathBuf], written: &HashSet<(&str, usize)>) -> Result<MergeSummary, DatasetError> {
    let mut stamp = read_stamp(dest)?;
    // Every stamp met is checked against its spec before anything is copied; shards of one
    // identity carry the same spec text.
    let mut spec = stamp.as_ref().map(|ours| checked_spec(dest, ours)).transpose()?;
    for source in sources {
        let theirs = read_stamp(source)?.ok_or_else(|| DatasetError::NotADataSet { dir: source.clone() })?;
        let their_spec = checked_spec(source, &theirs)?;
        let ours = match &stamp {
            Some(ours) => ours,
            None => {
                prepare_dir(dest)?;
                refuse_unrecorded(dest)?;
                let bytes = std::fs::read(source.join(STAMP)).map_err(io(source))?;
                write_file(&dest.join(STAMP), &bytes)?;
                spec = Some(their_spec);
                stamp.insert(theirs.clone())
            }
        };
        if ours.identity != theirs.identity {
            return Err(DatasetError::ShardOfAnotherSpec {
                dir: source.clone(),
                dest: dest.to_path_buf(),
                theirs: describe(&theirs),
            });
        }
        same_renderer(source, &theirs, ours)?;
        copy_frames(source, dest, ours)?;
    }
    let (Some(stamp), Some(spec)) = (stamp, spec) else {
        return Err(DatasetError::NotADataSet {
            dir: dest.to_path_buf(),
        });
    };
    // The index files and contact sheets are this binary's: they must be the renderer's.
    let merging = Stamp {
        version: env!("CARGO_PKG_VERSION").into(),
        ..stamp.clone()
    };
    same_renderer(dest, &stamp, &merging)?;
    let spec_path = dest.join(&stamp.spec_file);
    let rig = super::build_rig(&spec.rig).map_err(|message| DatasetError::Spec {
        path: spec_path.clone(),
        location: None,
        set: None,
        field: "rig".into(),
        message,
    })?;
    let mut summary = MergeSummary::default();
    let mut sets = Vec::new();
    for set in &stamp.sets {
        let set_dir = inside(dest, &set.name).ok_or_else(|| DatasetError::Link {
            path: dest.join(&set.name),
        })?;
        let own_path = set_dir.join(ENTRIES).join(SET_ENTRY);
        let mut own: SetEntry = read_json(&own_path)?;
        // Not `with_capacity(set.frames)`: the count comes from a file that may have been edited.
        let mut frames = Vec::new();
        let mut missing = Vec::new();
        for index in 0..set.frames {
            let path = entry_path(&set_dir, index);
            if !path.exists() {
                missing.push(index);
                continue;
            }
            let entry: FrameEntry = read_json(&path)?;
            // The stem names files (the contact sheet reads them): a plain name, as written.
            if entry.index != index
                || entry.stem.is_empty()
                || entry.stem.starts_with('.')
                || entry.stem.contains(['/', '\\'])
            {
                return Err(DatasetError::Corrupt {
                    path: path.clone(),
                    entry: path,
                    problem: "its index or stem is not the one this frame was written with".into(),
                });
            }
            let fresh = written.contains(&(set.name.as_str(), index));
            for file in &entry.files {
                if fresh {
                    verify_size(dest, file, &path)?;
                } else {
                    verify(dest, file, &path)?;
                }
            }
            frames.push(entry);
        }
        if let Some(&first) = missing.first() {
            return Err(DatasetError::Incomplete {
                set: set.name.clone(),
                missing: missing.len(),
                total: set.frames,
                first,
            });
        }
        for file in &own.files {
            verify(dest, file, &own_path)?;
        }
        for layout in &set.layouts {
            for (name, text) in layout::index_files(layout, &rig, &frames) {
                let path = set_dir.join(&name);
                prepare_subdir(dest, path.parent().unwrap_or(&set_dir))?;
                write_file(&path, text.as_bytes())?;
                own.files.push(FileEntry {
                    path: format!("{}/{name}", set.name),
                    kind: FileKind::Index,
                    bytes: text.len() as u64,
                    sha256: sha256_hex(text.as_bytes()),
                });
            }
        }
        if spec.outputs.colour {
            let sheet = set_dir.join(CONTACT_SHEET);
            let bytes = set_contact_sheet(&set_dir, &rig, &frames)?;
            write_file(&sheet, &bytes)?;
            own.files.push(FileEntry {
                path: format!("{}/{CONTACT_SHEET}", set.name),
                kind: FileKind::Overview,
                bytes: bytes.len() as u64,
                sha256: sha256_hex(&bytes),
            });
        }
        let counted = own.files.iter().chain(frames.iter().flat_map(|f| &f.files));
        for file in counted {
            summary.files += 1;
            summary.bytes += file.bytes;
        }
        summary.frames += frames.len();
        sets.push(ManifestSet {
            set: own,
            frame_entries: frames,
        });
    }
    let manifest = Manifest {
        tool: "omnisim".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        spec_file: stamp.spec_file.clone(),
        spec: stamp.spec_text.clone(),
        spec_sha256: stamp.spec_sha256.clone(),
        scene_file: stamp.scene_file.clone(),
        scene_sha256: stamp.scene_sha256.clone(),
        geometry_sha256: stamp.geometry_sha256.clone(),
        renderer: stamp.renderer.clone(),
        seed: spec.seed,
        rig: spec.rig.clone(),
        outputs: spec.outputs,
        sets,
    };
    write_file(&dest.join(MANIFEST), &to_json(&manifest))?;
    Ok(summary)
}

/// The spec a stamp carries, refusing a stamp that is not its own spec's (the text's hash,
/// the sets' names in order, layouts and noise, a possible frame count): merges trust it for
/// what to check and write.
fn checked_spec(dir: &Path, stamp: &Stamp) -> Result<super::spec::Spec, DatasetError> {
    let spec = super::spec::parse(&stamp.spec_text, &dir.join(&stamp.spec_file))?;
    let problem = if sha256_hex(stamp.spec_text.as_bytes()) != stamp.spec_sha256 {
        Some("its spec text does not have its recorded hash".to_string())
    } else if stamp.sets.len() != spec.sets.len() {
        Some(format!(
            "it lists {} sets; its spec has {}",
            stamp.sets.len(),
            spec.sets.len()
        ))
    } else {
        stamp.sets.iter().zip(&spec.sets).find_map(|(ours, theirs)| {
            let same = ours.name == theirs.name && ours.layouts == theirs.layouts && ours.noise == theirs.noise;
            let possible = (1..=super::spec::MAX_POSES).contains(&ours.frames);
            (!(same && possible)).then(|| {
                format!(
                    "set '{}' is not its spec's set, or has an impossible frame count",
                    crate::input::shown(&ours.name, 64)
                )
            })
        })
    };
    match problem {
        Some(problem) => Err(DatasetError::BadStamp {
            path: dir.join(STAMP),
            problem,
        }),
        None => Ok(spec),
    }
}

/// The contact sheet of a set's frames (the first view's ground-truth colour).
fn set_contact_sheet(set_dir: &Path, rig: &Rig, frames: &[FrameEntry]) -> Result<Vec<u8>, DatasetError> {
    let suffix = rig.views().first().map(|v| v.suffix).unwrap_or_default();
    let paths: Vec<(usize, PathBuf)> = contact_sheet::chosen(frames.len())
        .into_iter()
        .map(|i| (frames[i].index, set_dir.join(format!("{}{suffix}.png", frames[i].stem))))
        .collect();
    let shown: Vec<(usize, &Path)> = paths.iter().map(|(i, p)| (*i, p.as_path())).collect();
    contact_sheet::contact_sheet(&shown)
}

pub(crate) fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, DatasetError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    serde_json::from_slice(&bytes).map_err(|e| DatasetError::Corrupt {
        path: path.to_path_buf(),
        entry: path.to_path_buf(),
        problem: format!("unreadable: {e}"),
    })
}

/// Copies every done frame (and the set files) of `source` into `dest`, each file checked
/// against its entry first; entries last, so a copy killed half-way leaves no false "done".
fn copy_frames(source: &Path, dest: &Path, stamp: &Stamp) -> Result<(), DatasetError> {
    for set in &stamp.sets {
        let from = inside(source, &set.name).ok_or_else(|| DatasetError::Link {
            path: source.join(&set.name),
        })?;
        let to = inside(dest, &set.name).ok_or_else(|| DatasetError::Link {
            path: dest.join(&set.name),
        })?;
        prepare_subdir(dest, &to.join(ENTRIES))?;
        let mut entries = read_entry_paths(&from.join(ENTRIES))?;
        entries.push(from.join(ENTRIES).join(SET_ENTRY));
        for entry in entries {
            if !entry.exists() {
                continue;
            }
            let files: Vec<FileEntry> = if entry.ends_with(SET_ENTRY) {
                read_json::<SetEntry>(&entry)?.files
            } else {
                read_json::<FrameEntry>(&entry)?.files
            };
            for file in &files {
                let bytes = read_verified(source, file, &entry)?;
                // Checked by read_verified: the path stays inside.
                let to_file = dest.join(&file.path);
                if let Some(parent) = to_file.parent() {
                    prepare_subdir(dest, parent)?;
                }
                write_file(&to_file, &bytes)?;
            }
            let name = entry.file_name().map(PathBuf::from).unwrap_or_default();
            write_file(
                &to.join(ENTRIES).join(name),
                &std::fs::read(&entry).map_err(io(&entry))?,
            )?;
        }
    }
    Ok(())
}
