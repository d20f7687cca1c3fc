//! A data-set folder's state: its stamp (which spec, scene and renderer), the temporaries a
//! killed run left, which frames are done, and which folders a run may write into.

use std::fs::{File, TryLockError};
use std::path::{Path, PathBuf};

use super::contact_sheet::CONTACT_SHEET;
use super::manifest::{FileEntry, FrameEntry, SetEntry, Stamp, inside, sha256_hex, to_json};
use super::{Dataset, DatasetError, SetPlan};
use crate::files::{ENTRIES, GATE, MANIFEST, RUNNING, SET_ENTRY, STAMP, entry_path, io, read_entry_paths, write_file};
use omnisim::Renderer;
use omnisim::atomic_file;
use omnisim::output;

/// Creates `dir` and removes the temporaries a killed run left there.
pub(crate) fn prepare_dir(dir: &Path) -> Result<(), DatasetError> {
    // `dir` itself, which the user named, may be a link.
    output::folder::create_real_folder(dir, dir).map_err(refused)?;
    atomic_file::remove_stale_temporaries(dir).map_err(io(dir))?;
    Ok(())
}

/// A data set's error for a folder [`output::folder::create_real_folder`] could not make.
fn refused(error: output::folder::RealFolderError) -> DatasetError {
    match error {
        output::folder::RealFolderError::Link(path) => DatasetError::Link { path },
        output::folder::RealFolderError::NotAFolder(path) => DatasetError::NotAFolder { path },
        output::folder::RealFolderError::Io(path, source) => DatasetError::Io { path, source },
    }
}

/// Refuses a data-set folder `dir` inside a set's bookkeeping folder (`.frames`) or inside
/// another data set's folder, where its files would mix with that data set's. Judged on the
/// path as the system resolves the part of it that exists (a link to `.frames` counts).
pub(crate) fn refuse_nested(dir: &Path) -> Result<(), DatasetError> {
    let absolute = std::path::absolute(dir).map_err(io(dir))?;
    let existing = absolute.ancestors().find(|a| a.exists()).unwrap_or(&absolute);
    let resolved = match absolute.strip_prefix(existing) {
        Ok(rest) => std::fs::canonicalize(existing).map_err(io(existing))?.join(rest),
        Err(_) => absolute.clone(),
    };
    for ancestor in resolved.ancestors() {
        if ancestor.file_name() == Some(ENTRIES.as_ref()) {
            return Err(DatasetError::InBookkeeping {
                dir: dir.to_path_buf(),
                folder: ancestor.to_path_buf(),
            });
        }
        if ancestor != resolved && ancestor.join(STAMP).is_file() {
            return Err(DatasetError::InDataSet {
                dir: dir.to_path_buf(),
                outer: ancestor.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// [`prepare_dir`] for a folder inside the data-set folder `root`, refused where a level is a
/// link (a set folder linked elsewhere would have the run write there).
pub(crate) fn prepare_subdir(root: &Path, dir: &Path) -> Result<(), DatasetError> {
    output::folder::create_real_folder(root, dir).map_err(refused)?;
    atomic_file::remove_stale_temporaries(dir).map_err(io(dir))?;
    Ok(())
}

/// Refuses a folder without a stamp that holds visible files: someone else's.
pub(crate) fn refuse_unrecorded(dir: &Path) -> Result<(), DatasetError> {
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

pub(crate) fn read_stamp(dir: &Path) -> Result<Option<Stamp>, DatasetError> {
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

pub(crate) fn describe(stamp: &Stamp) -> String {
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

/// This process's hold on a data-set folder while it works there, shared with the other runs
/// (shards) and merges of its data set. Dropping it lets go, and so does the system when the
/// process ends, however it ends: a killed run leaves nothing that blocks the next one.
pub(crate) struct Hold {
    _running: Option<File>,
}

/// The folder's gate, held while a run decides whether the folder is its own and writes the
/// stamp, so that two runs never both find it free.
///
/// The locks are the system's advisory file locks (`File::lock`: `flock` on Unix, `LockFileEx`
/// on Windows; Linux NFS clients take them on the server, so shards on several hosts see each
/// other's), not lock files created exclusively and removed at the end: a run killed on another
/// host would leave such a file, and no process id tells from here whether that run lives. The
/// lock files stay: removing one lets a later run lock a new file while another holds the old.
struct Gate {
    /// (gate, running), the gate locked; `None` where the file system cannot lock files.
    locks: Option<(File, File)>,
    running_path: PathBuf,
}

impl Gate {
    /// Waits for the gate (others hold it for moments); notes a file system without locks.
    fn enter(dir: &Path, notes: &mut Vec<String>) -> Result<Self, DatasetError> {
        let gate = lock_file(&dir.join(GATE))?;
        let running_path = dir.join(RUNNING);
        let locks = match gate.lock() {
            Ok(()) => Some((gate, lock_file(&running_path)?)),
            Err(e) => {
                notes.push(format!(
                    "{} cannot lock files ({e}): a run of another spec started into it at the same moment would \
                     not be noticed",
                    dir.display()
                ));
                None
            }
        };
        Ok(Self { locks, running_path })
    }

    /// Whether another run or merge works in the folder now (every one takes its hold through
    /// the gate, so none can start before this one opens it).
    fn others_inside(&self) -> Result<bool, DatasetError> {
        let Some((_, running)) = &self.locks else {
            return Ok(false);
        };
        match running.try_lock() {
            Ok(()) => running.unlock().map(|()| false).map_err(io(&self.running_path)),
            Err(TryLockError::WouldBlock) => Ok(true),
            Err(TryLockError::Error(e)) => Err(io(&self.running_path)(e)),
        }
    }

    /// Holds the folder, then opens the gate (in that order: no `--overwrite` finds the folder
    /// free in between).
    fn hold(self) -> Result<Hold, DatasetError> {
        let Some((_gate, running)) = self.locks else {
            return Ok(Hold { _running: None });
        };
        running.lock_shared().map_err(io(&self.running_path))?;
        Ok(Hold {
            _running: Some(running),
        })
    }
}

/// Opens or creates a lock file; never through a link, nor a FIFO or device under its name.
fn lock_file(path: &Path) -> Result<File, DatasetError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if !m.is_file() => Err(DatasetError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::other("not a plain file (a link, folder or device): remove it"),
        }),
        Ok(_) => File::options().write(true).open(path).map_err(io(path)),
        Err(_) => File::options()
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(io(path)),
    }
}

/// Holds the data-set folder `dir` (which exists) as [`open_folder`] does, without touching
/// its stamp: for a merge, which a concurrent `--overwrite` must not pull files from under.
pub(crate) fn hold(dir: &Path) -> Result<Hold, DatasetError> {
    Gate::enter(dir, &mut Vec::new())?.hold()
}

/// Opens `dir` for the data set `stamp`: refuses another spec's data set (or files no data
/// set recorded) unless `overwrite`, and any other data set while a run works on it, and
/// writes the stamp. Returns notes, and the hold to keep while the run writes.
pub(crate) fn open_folder(dir: &Path, stamp: &Stamp, overwrite: bool) -> Result<(Vec<String>, Hold), DatasetError> {
    refuse_nested(dir)?;
    prepare_dir(dir)?;
    let mut notes = Vec::new();
    let gate = Gate::enter(dir, &mut notes)?;
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
            same_renderer(dir, &previous, stamp)?;
        }
        Some(previous) if gate.others_inside()? => {
            return Err(DatasetError::Busy {
                dir: dir.to_path_buf(),
                previous: describe(&previous),
            });
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
    Ok((notes, gate.hold()?))
}

/// Refuses frames of `theirs`'s version or renderer beside those of `ours` (same spec).
pub(crate) fn same_renderer(dir: &Path, theirs: &Stamp, ours: &Stamp) -> Result<(), DatasetError> {
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
pub(crate) fn is_done(root: &Path, set_dir: &Path, index: usize) -> Option<u64> {
    let entry: FrameEntry = serde_json::from_slice(&std::fs::read(entry_path(set_dir, index)).ok()?).ok()?;
    let sizes_match = entry.files.iter().all(|f| {
        inside(root, &f.path)
            .and_then(|p| std::fs::metadata(p).ok())
            .is_some_and(|m| m.len() == f.bytes)
    });
    sizes_match.then(|| entry.files.iter().map(|f| f.bytes).sum())
}

impl Dataset {
    /// The stamp of this data set, rendered by `renderer`.
    pub(crate) fn stamp(&self, renderer: &Renderer) -> Stamp {
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
}

pub(crate) fn set_entry(set: &SetPlan, files: Vec<FileEntry>) -> SetEntry {
    SetEntry {
        name: set.spec.name.clone(),
        frames: set.poses.len(),
        skipped: set.skipped.clone(),
        noise: set.spec.noise.clone(),
        layouts: set.spec.layouts.clone(),
        files,
    }
}
