//! Rendering a data set into a folder, resuming, sharding and merging.
//!
//! Folder: `.omnisim-dataset.json` (the stamp: which spec and scene, how many frames per
//! set), then per set `<set>/` with the frame files, the set files (calibration), the layouts
//! (`tum/`, `mav0/`) and `.frames/` (one entry per done frame, and `set.json`). Every file
//! is written atomically; a frame is done when its entry exists, so a killed run re-renders
//! at most the frames it was writing, with the same bytes. Frame files and set files are not
//! synced one by one: a batch of frames is made durable in one pass (`syncfs` on Linux) on a
//! thread of its own while later frames render, and only then are their entries written, so
//! an entry never names a file a crash could lose. `merge` checks every file's hash
//! and writes the layouts' index files and `manifest.json`; the merge that ends an unsharded
//! run checks only the sizes of the frames that run wrote itself (it hashed them as it wrote
//! them, so a file changed during the run without changing size goes unnoticed until the
//! next `omnisim dataset merge`) and hashes the frames earlier runs left.

use std::collections::HashSet;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use super::appearance::frame_appearance;
use super::layout::{self};
use super::manifest::{FileKind, to_json};
use super::occluders::{self, Occluder};
use super::rng::{Purpose, stream};
use super::{Dataset, DatasetError, SetPlan};
use crate::files::{ENTRIES, SET_ENTRY, io};
use crate::folder::{is_done, open_folder, prepare_subdir, set_entry};
use crate::merge::assemble;
use crate::set_files::SetFiles;
use crate::write::{RenderedFrame, WrittenFrame};
use omnisim::atomic_file::{Durability, DurableFolder, write_bytes_atomically};
use omnisim::frame::{Frame, Plane};
use omnisim::output::{PlainFolder, SegmentationLegend};
use omnisim::{PreparedScene, Renderer};

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

/// Writer threads: as asked, else enough to keep up with the renderer and few enough to
/// leave it the cores.
fn writer_threads(asked: Option<usize>) -> usize {
    match asked {
        Some(writers) => writers.max(1),
        None => std::thread::available_parallelism()
            .map_or(2, std::num::NonZero::get)
            .clamp(2, 4),
    }
}

/// What a writer thread says of a frame: its set and index, and the frame written or why not.
type WriterReport = (usize, usize, Result<WrittenFrame, DatasetError>);

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

impl<'a, 'b> Heard<'a, 'b> {
    /// Nothing heard yet of the `total` frames of the sets `names`.
    fn new(
        names: Vec<&'a str>,
        total: usize,
        summary: &'b mut RunSummary,
        on_frame: &'b mut dyn FnMut(&FrameDone) -> ControlFlow<()>,
        stop: &'b AtomicBool,
    ) -> Self {
        Self {
            names,
            summary,
            on_frame,
            done: 0,
            total,
            failure: None,
            stopped: false,
            stop,
            written: HashSet::new(),
        }
    }

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

/// Makes files durable: [`DurableFolder::make_durable`], or a test's.
pub(crate) type MakeDurable<'s> = &'s (dyn Fn(&DurableFolder, &[PathBuf]) -> std::io::Result<()> + Sync);

/// How a run makes files durable, and when a batch goes: [`Syncing::DISK`] for every run;
/// tests put in failing syncs and one-frame batches.
#[derive(Clone, Copy)]
pub(crate) struct Syncing<'s> {
    pub(crate) make_durable: MakeDurable<'s>,
    pub(crate) batches: BatchLimits,
}

impl Syncing<'static> {
    /// The folder's own sync, and batches of up to 32 frames, 64 MiB or a second's work.
    pub(crate) const DISK: Self = Syncing {
        make_durable: &DurableFolder::make_durable,
        batches: BatchLimits {
            frames: 32,
            bytes: 64 << 20,
            age: Duration::from_secs(1),
        },
    };
}

/// When a batch goes to be made durable: once it holds `frames` frames or `bytes` bytes, or
/// its first frame has waited `age`.
#[derive(Clone, Copy)]
pub(crate) struct BatchLimits {
    pub(crate) frames: usize,
    pub(crate) bytes: u64,
    pub(crate) age: Duration,
}

/// Frames of a batch: written, their files not yet durable, their entries not yet written.
/// A batch goes to be made durable as its [`BatchLimits`] say. A crash loses up to three
/// batches of finished work (one being synced, one queued for the syncing thread, the one
/// pending), which the next run renders again.
struct Pending {
    limits: BatchLimits,
    frames: Vec<WrittenFrame>,
    bytes: u64,
    since: Option<Instant>,
    /// Files written outside the batch's frames and not yet durable: the set files, and the
    /// entries written since the last batch left (the next sync makes them durable too).
    unsynced: Unsynced,
}

/// Files for one sync to make durable.
#[derive(Default)]
struct Unsynced {
    /// Every file: first the set files and `set.json`s (until the first sync takes them),
    /// then entries and frame files.
    paths: Vec<PathBuf>,
    /// How many of `paths` are set files.
    set_files: usize,
}

impl Unsynced {
    /// The set files and `set.json`s, to be made durable before anything vouches for them.
    fn of_set_files(paths: Vec<PathBuf>) -> Self {
        Self {
            set_files: paths.len(),
            paths,
        }
    }

    /// Makes every file durable. Should that fail, removes the set files, best effort: after a
    /// failed write-back the kernel may keep their new bytes in pages marked clean, so the
    /// next run would find them holding its bytes, leave them, and vouch for files never on
    /// disk (its own sync, on a new handle, hears nothing of the old error); gone, they are
    /// written anew and synced before anything vouches for them.
    fn make_durable(&self, make_durable: MakeDurable, folder: &DurableFolder) -> std::io::Result<()> {
        // Nothing written, nothing to make durable (on Linux the call would sync the whole
        // file system for no file).
        if self.paths.is_empty() {
            return Ok(());
        }
        let synced = make_durable(folder, &self.paths);
        if synced.is_err() {
            for path in &self.paths[..self.set_files] {
                let _ = std::fs::remove_file(path);
            }
        }
        synced
    }
}

/// A batch on its way to the disk: its frames in frame order, and every file its sync covers.
struct Batch {
    frames: Vec<WrittenFrame>,
    files: Unsynced,
}

impl Pending {
    fn new(limits: BatchLimits, set_files: Vec<PathBuf>) -> Self {
        Self {
            limits,
            frames: Vec::new(),
            bytes: 0,
            since: None,
            unsynced: Unsynced::of_set_files(set_files),
        }
    }

    fn push(&mut self, frame: WrittenFrame) {
        self.bytes += frame.bytes;
        self.since.get_or_insert_with(Instant::now);
        self.frames.push(frame);
    }

    fn due(&self) -> bool {
        self.frames.len() >= self.limits.frames
            || self.bytes >= self.limits.bytes
            || self.since.is_some_and(|since| since.elapsed() >= self.limits.age)
    }

    /// Takes the batch, frames in frame order whatever order the writers finished in (a
    /// stopped run has done the first frames of its batch), with the files written outside
    /// it that are not yet durable; `None` if it holds no frame.
    fn take(&mut self) -> Option<Batch> {
        let mut frames = std::mem::take(&mut self.frames);
        (self.bytes, self.since) = (0, None);
        if frames.is_empty() {
            return None;
        }
        frames.sort_by_key(|frame| (frame.set, frame.index));
        let mut files = std::mem::take(&mut self.unsynced);
        for frame in &mut frames {
            files.paths.append(&mut frame.files);
        }
        Some(Batch { frames, files })
    }

    /// Once a batch's files are durable (`synced`), writes each frame's entry and tells
    /// `heard`, frame by frame: once the run stops, no further entry is written (those frames
    /// are rendered again by a later run). Entries are themselves synced by the next batch,
    /// or by the end of the run.
    /// A failed sync is the run's error even once it has stopped (a later sync of the same
    /// handle reports the lost write-back no more); after an earlier error, it takes its place
    /// and says it.
    fn write_entries(&mut self, out: &Path, heard: &mut Heard, (frames, synced): Synced) {
        if let Err(error) = synced {
            let named: Vec<String> = (frames.iter())
                .map(|frame| format!("{} {}", heard.names[frame.set], frame.index))
                .collect();
            let mut context = format!("making the files of frames {} durable: {error}", named.join(", "));
            if let Some(earlier) = heard.failure.take() {
                context.push_str(&format!(" (after an earlier error: {earlier})"));
            }
            heard.failure = Some(io(out)(std::io::Error::new(error.kind(), context)));
            heard.stop();
            return;
        }
        if heard.stopped {
            return;
        }
        for frame in frames {
            if heard.stopped {
                return;
            }
            let written = write_bytes_atomically(&frame.entry_path, Durability::Deferred, &frame.entry)
                .map(|()| Outcome::Written(frame.bytes))
                .map_err(io(&frame.entry_path));
            if written.is_ok() {
                self.unsynced.paths.push(frame.entry_path);
            }
            heard.frame(frame.set, frame.index, written);
        }
    }
}

/// What the syncing thread says of a batch: its frames, and whether their files are durable.
type Synced = (Vec<WrittenFrame>, std::io::Result<()>);

/// The renderer a run was given, the one reopened in its place after a lost device, the set
/// scene prepared on the one in use, and the notes each reopening leaves.
struct Reopening<'a> {
    renderer: &'a Renderer,
    fresh: &'a mut Option<Renderer>,
    current: &'a mut Option<SetScene>,
    notes: &'a mut Vec<String>,
}

/// A set's prepared scene, with its per-set occluders, kept while its frames render.
struct SetScene {
    set: usize,
    scene: omnisim::Scene,
    prepared: PreparedScene,
}

impl Dataset {
    /// Renders the frames of `options.shard` (all frames without one) into `out`, skipping
    /// those an earlier run finished, then, without a shard, merges. Frames render on this
    /// thread while writer threads write the ones before them. `on_frame` hears of every
    /// frame and may stop the run (frames whose files are still waiting for their batch to be
    /// made durable get no entry and are rendered again by a later run, which resumes the rest).
    pub fn run(
        &self,
        renderer: &Renderer,
        out: &Path,
        options: &RunOptions,
        on_frame: &mut dyn FnMut(&FrameDone) -> ControlFlow<()>,
    ) -> Result<RunSummary, DatasetError> {
        self.run_syncing(renderer, out, options, on_frame, &Syncing::DISK)
    }

    /// [`Dataset::run`], making files durable and batching frames as `syncing` says.
    pub(crate) fn run_syncing(
        &self,
        renderer: &Renderer,
        out: &Path,
        options: &RunOptions,
        on_frame: &mut dyn FnMut(&FrameDone) -> ControlFlow<()>,
        syncing: &Syncing,
    ) -> Result<RunSummary, DatasetError> {
        let make_durable = syncing.make_durable;
        // Held until the run returns, its final merge included.
        let (notes, _held) = open_folder(out, &self.stamp(renderer), options.overwrite)?;
        let mut summary = RunSummary {
            notes,
            ..RunSummary::default()
        };
        // Opened before the first file it makes durable is written.
        let folder = DurableFolder::open(out).map_err(io(out))?;
        let mut set_files = SetFiles::default();
        for set in &self.sets {
            if let Err(error) = self.prepare_set(out, set, &mut set_files) {
                // Best effort: the error is what the user hears.
                let _ = Unsynced::of_set_files(set_files.into_paths()).make_durable(make_durable, &folder);
                return Err(error);
            }
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
        let mut reopenings = Vec::new();
        let names = self.sets.iter().map(|s| s.spec.name.as_str()).collect();
        let mut heard = Heard::new(names, frames.len(), &mut summary, on_frame, &stop);
        // Frames render here, one after another (the renderer is not shared), while writer
        // threads encode and write the frames before them; a bounded queue (a frame per
        // writer) keeps at most 3 x writers + 1 rendered frames in memory: one being rendered,
        // the queued ones, and two each writer holds, with their encoded files (about 2 MB at
        // 250² with PLY, tens of MB at large panoramas), when it pairs a frame with the next
        // (`WrittenFrame::hashed`). Each frame's entry is its last file, so whatever
        // moment a run is killed at, a frame is done exactly when its entry exists.
        let writers = writer_threads(options.writers);
        let (to_write, queue) = mpsc::sync_channel::<RenderedFrame>(writers);
        // Shared by the writers alone: if every writer ends (a panic), the queue closes and
        // the renderer's next send fails instead of waiting for ever.
        let queue = Arc::new(Mutex::new(queue));
        let (report, written) = mpsc::channel();
        let mut pending = Pending::new(syncing.batches, set_files.into_paths());
        // Batches are made durable on a thread of their own, so that rendering and writing go
        // on while the disk catches up; one more batch may wait for it.
        let (to_sync, batches) = mpsc::sync_channel::<Batch>(1);
        let (synced_report, synced) = mpsc::channel::<Synced>();
        std::thread::scope(|scope| {
            let folder = &folder;
            scope.spawn(move || {
                for Batch { frames, files } in batches {
                    if synced_report
                        .send((frames, files.make_durable(make_durable, folder)))
                        .is_err()
                    {
                        break;
                    }
                }
            });
            for _ in 0..writers {
                let (queue, report, stop) = (Arc::clone(&queue), report.clone(), &stop);
                scope.spawn(move || {
                    // A frame, and the next one where it is already queued, are written and
                    // then their files hashed together (`WrittenFrame::hashed`). A writer never
                    // waits for the second: not for a frame not yet rendered, nor for the lock,
                    // which a writer waiting for a frame holds (the queue is then empty).
                    while let Some(first) = queue.lock().ok().and_then(|q| q.recv().ok()) {
                        let next = queue.try_lock().ok().and_then(|q| q.try_recv().ok());
                        let mut unhashed = Vec::with_capacity(2);
                        for frame in std::iter::once(first).chain(next) {
                            if stop.load(Ordering::Relaxed) {
                                continue;
                            }
                            let (set, index) = (frame.set, frame.index);
                            match self.write_frame(out, frame) {
                                Ok(frame) => unhashed.push(frame),
                                Err(error) => {
                                    if report.send((set, index, Err(error))).is_err() {
                                        return;
                                    }
                                }
                            }
                        }
                        for frame in WrittenFrame::hashed(unhashed) {
                            if report.send((frame.set, frame.index, Ok(frame))).is_err() {
                                return;
                            }
                        }
                    }
                });
            }
            drop((report, queue));
            let mut current: Option<SetScene> = None;
            // The renderer reopened in `renderer`'s place after its device was lost.
            let mut fresh: Option<Renderer> = None;
            let hear = |heard: &mut Heard, pending: &mut Pending, (set, index, result): WriterReport| match result {
                Ok(frame) => pending.push(frame),
                Err(error) => heard.frame(set, index, Err(error)),
            };
            for &(s, index) in &frames {
                while let Ok(report) = written.try_recv() {
                    hear(&mut heard, &mut pending, report);
                }
                while let Ok(batch) = synced.try_recv() {
                    pending.write_entries(out, &mut heard, batch);
                }
                if heard.stopped {
                    break;
                }
                if pending.due()
                    && let Some(batch) = pending.take()
                    && to_sync.send(batch).is_err()
                {
                    break; // the syncing thread has ended: the scope reports why
                }
                let outcome = if let Some(bytes) = is_done(out, &out.join(&self.sets[s].spec.name), index) {
                    Ok(Outcome::Resumed(bytes))
                } else {
                    let mut on = Reopening {
                        renderer,
                        fresh: &mut fresh,
                        current: &mut current,
                        notes: &mut reopenings,
                    };
                    match self.render_reopening(&mut on, s, index) {
                        Ok(frame) => match to_write.send(frame) {
                            Ok(()) => continue,
                            Err(_) => break, // every writer has ended: the scope reports why
                        },
                        Err(e) => Err(e),
                    }
                };
                heard.frame(s, index, outcome);
            }
            drop(to_write);
            for report in written {
                hear(&mut heard, &mut pending, report);
            }
            if !heard.stopped
                && let Some(batch) = pending.take()
            {
                // A failed send means the syncing thread has ended: the scope reports why.
                let _ = to_sync.send(batch);
            }
            drop(to_sync);
            for batch in synced {
                pending.write_entries(out, &mut heard, batch);
            }
        });
        let (failure, done, written) = (heard.failure, heard.done, heard.written);
        summary.notes.append(&mut reopenings);
        // The entries written since the last batch, and the set files where no batch took
        // them (not the frames of a pending or failed batch); after a failure, best effort
        // for the next run, and the failure is what the user hears.
        let synced = pending.unsynced.make_durable(make_durable, &folder);
        if let Some(failure) = failure {
            return Err(failure);
        }
        synced.map_err(io(out))?;
        summary.stopped = done < frames.len();
        if options.shard.is_none() && !summary.stopped {
            assemble(out, &[], &written)?;
            summary.merged = true;
        }
        Ok(summary)
    }

    /// Creates a set's folders and writes its set files and `set.json` through `store`
    /// (unchanged ones left alone, new ones not yet durable), which keeps their paths for the
    /// first batch (or the end of the run) to make durable before anything vouches for them.
    fn prepare_set(&self, out: &Path, set: &SetPlan, store: &mut SetFiles) -> Result<(), DatasetError> {
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
        let mut folder = PlainFolder {
            dir: set_dir.clone(),
            store: &mut *store,
        };
        let paths = (self.spec.outputs).write_set_files(&mut folder, &scene, &self.rig)?;
        let files = paths
            .iter()
            .map(|path| store.entry(out, path, FileKind::Set))
            .collect::<Result<_, _>>()?;
        let own = set_dir.join(ENTRIES).join(SET_ENTRY);
        store
            .write_unlisted(&own, &to_json(&set_entry(set, files)))
            .map_err(io(&own))
    }

    /// Renders frame `index` of set `s` on the renderer in use, with `current`'s scene where it
    /// is that set's. Where the GPU device was lost (a driver reset, a GPU fault), the frame is
    /// rendered once more on a renderer reopened on a fresh device, kept for the rest of the
    /// run: a long run goes on where the loss passes, and stops (resumably) where it does not.
    /// Only a renderer that renders the same bytes (`Renderer::reopen`: the folder's stamp)
    /// takes over: `auto` that finds no GPU now stops the run instead of mixing backends.
    fn render_reopening(&self, on: &mut Reopening, s: usize, index: usize) -> Result<RenderedFrame, DatasetError> {
        let renderer = on.fresh.as_ref().unwrap_or(on.renderer);
        let lost = match self.render_on(renderer, on.current, s, index) {
            Err(DatasetError::Render(lost)) if lost.is_device_lost() => lost,
            other => return other,
        };
        let Some(fresh) = renderer.reopen() else {
            return Err(lost.into());
        };
        on.notes.push(format!(
            "set '{}', frame {index}: {lost}; rendered again on the device opened in its place",
            self.sets[s].spec.name
        ));
        // Its prepared scene lives on the lost device.
        *on.current = None;
        let fresh = on.fresh.insert(fresh);
        self.render_on(fresh, on.current, s, index)
    }

    /// Renders frame `index` of set `s` on `renderer`, with `current`'s scene where it is that
    /// set's (else the set's scene, prepared now), which `current` then holds.
    fn render_on(
        &self,
        renderer: &Renderer,
        current: &mut Option<SetScene>,
        s: usize,
        index: usize,
    ) -> Result<RenderedFrame, DatasetError> {
        let mut scene = match current.take() {
            Some(scene) if scene.set == s => scene,
            _ => self.set_scene(renderer, s)?,
        };
        let frame = self.render_frame(renderer, &mut scene, index);
        *current = Some(scene);
        frame
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
        .map_err(|e| {
            let at = super::spec::SpecText {
                text: &self.spec_text,
                path: &self.spec_path,
            };
            super::crowded(&at, &plan.spec, true, Some(index), &e)
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
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of set `set` whose entry would go in `dir`.
    fn frame(dir: &Path, set: usize, index: usize) -> WrittenFrame {
        WrittenFrame {
            set,
            index,
            bytes: 1,
            files: Vec::new(),
            entry_path: dir.join(format!("{set}-{index}.json")),
            entry: b"{}".to_vec(),
        }
    }

    /// A batch whose sync failed after the run had stopped (the callback asked, or an error
    /// came first) is still the run's error, naming its frames, and gets no entries.
    #[test]
    fn a_failed_sync_heard_after_a_stop_is_the_runs_error() {
        let dir = tempfile::tempdir().unwrap();
        let stop = AtomicBool::new(false);
        let mut summary = RunSummary::default();
        let mut on_frame = |_: &FrameDone| ControlFlow::Break(());
        let mut heard = Heard::new(vec!["map", "test"], 4, &mut summary, &mut on_frame, &stop);
        heard.stop();
        let frames = vec![frame(dir.path(), 0, 1), frame(dir.path(), 1, 0)];
        let lost = std::io::Error::other("write-back failed");
        let mut pending = Pending::new(Syncing::DISK.batches, Vec::new());
        pending.write_entries(dir.path(), &mut heard, (frames, Err(lost)));
        let failure = heard.failure.take().expect("the failed sync is the run's error");
        let message = failure.to_string();
        assert!(
            message.contains("frames map 1, test 0") && message.contains("write-back failed"),
            "{message}"
        );
        assert!(heard.stopped && stop.load(Ordering::Relaxed));
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no entry was written"
        );
        assert!(pending.unsynced.paths.is_empty());
    }

    /// A failed sync heard after an earlier error (a full disk) is not dropped: it is the
    /// run's error and says the earlier one.
    #[test]
    fn a_failed_sync_after_an_error_says_both() {
        let dir = tempfile::tempdir().unwrap();
        let stop = AtomicBool::new(false);
        let mut summary = RunSummary::default();
        let mut on_frame = |_: &FrameDone| ControlFlow::Continue(());
        let full = std::io::Error::other("no space left");
        let mut heard = Heard::new(vec!["map"], 2, &mut summary, &mut on_frame, &stop);
        heard.failure = Some(io(&dir.path().join("map/000001.png"))(full));
        heard.stop();
        let lost = std::io::Error::other("write-back failed");
        let mut pending = Pending::new(Syncing::DISK.batches, Vec::new());
        pending.write_entries(dir.path(), &mut heard, (vec![frame(dir.path(), 0, 0)], Err(lost)));
        let message = heard.failure.take().expect("an error").to_string();
        assert!(
            message.contains("frames map 0") && message.contains("write-back failed"),
            "{message}"
        );
        assert!(
            message.contains("000001.png") && message.contains("no space left"),
            "{message}"
        );
    }
}
