//! Output folders hold one run each. A manifest ([`MANIFEST_NAME`]) records which run wrote the
//! folder and every file it wrote, each listed before it is written, so that a later run can
//! refuse to mix its files with another run's, or remove exactly that run's files when told
//! to (`overwrite`), even after a kill.

use std::collections::HashSet;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::atomic_file::{remove_stale_temporaries, temporary_prefix, write_atomically};

/// The manifest's file name in every run folder.
pub const MANIFEST_NAME: &str = "omnisim-run.txt";

const MANIFEST_HEADER: &str = "# omnisim run manifest: the run that wrote this folder and every file it wrote.\n\
# omnisim render refuses to write another run into this folder; --overwrite removes exactly the\n\
# files listed here first. A run ends with the line 'complete'.\n";

/// Why an output folder cannot take this run.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// The system refused (permissions, full disk).
    #[error("cannot use output folder {}: {source}", dir.display())]
    Io {
        /// The folder.
        dir: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The folder holds another run's files.
    #[error(
        "{} holds the {count} files of another run ({previous}); this run's files would mix with them. \
         Choose another output folder, or add --overwrite to remove that run's files first (nothing else is touched)",
        dir.display()
    )]
    AnotherRun {
        /// The folder.
        dir: PathBuf,
        /// The other run's command.
        previous: String,
        /// How many files it wrote.
        count: usize,
    },
    /// Another run works in the folder now.
    #[error(
        "{} is in use by another omnisim run now (it holds the folder's lock): wait for it to end, or choose another \
         output folder",
        dir.display()
    )]
    InUse {
        /// The folder.
        dir: PathBuf,
    },
    /// The folder holds files no run recorded.
    #[error(
        "{} already holds files that no omnisim run recorded (no {MANIFEST_NAME}), e.g. '{example}'. Choose an empty \
         or new output folder, or add --overwrite to write into it anyway (files with the same names are replaced, \
         nothing else is touched)",
        dir.display()
    )]
    Unrecorded {
        /// The folder.
        dir: PathBuf,
        /// One of the files found.
        example: String,
    },
    /// A file name that would leave the folder.
    #[error("'{name}' is not a plain file name: outputs stay inside the output folder")]
    BadName {
        /// The name refused.
        name: String,
    },
    /// The folder, or one above it, is a file.
    #[error("{} is a file, not a folder: name a new or empty folder", path.display())]
    NotAFolder {
        /// The file in the way.
        path: PathBuf,
    },
    /// The destination is a device, FIFO, socket or folder: writing it whole means replacing it.
    #[error(
        "{} is {kind}, not a regular file: omnisim writes a file by replacing it whole, which would remove {kind}; \
         name a regular file",
        path.display()
    )]
    NotAFile {
        /// The destination.
        path: PathBuf,
        /// What it is instead.
        kind: &'static str,
    },
}

/// An output folder opened for one run.
#[derive(Debug)]
pub struct RunFolder {
    dir: PathBuf,
    manifest: File,
    /// The folder's lock, held while the run works ([`lock_folder`]).
    _lock: Option<File>,
    claimed: HashSet<String>,
    /// What opening did that the user should hear about (stale files removed).
    pub notes: Vec<String>,
}

/// What a manifest says.
struct Manifest {
    identity: String,
    command: String,
    files: Vec<String>,
}

impl RunFolder {
    /// Creates `dir` if needed, removes temporaries that killed runs left, and checks that the
    /// folder is free for the run `identity` (a one-line key: equal keys mean the same run, whose
    /// re-run may replace its own files). `command` is shown to whoever finds the folder taken.
    pub fn open(dir: &Path, identity: &str, command: &str, overwrite: bool) -> Result<Self, FolderError> {
        let io = |source| FolderError::Io {
            dir: dir.to_path_buf(),
            source,
        };
        create_folder(dir)?;
        let mut notes = Vec::new();
        let lock = lock_folder(dir, &mut notes)?;
        let stale = remove_stale_temporaries(dir).map_err(io)?;
        if stale > 0 {
            notes.push(format!(
                "removed {stale} temporary file(s) that an interrupted run left in {}",
                dir.display()
            ));
        }
        let manifest_path = dir.join(MANIFEST_NAME);
        let carried = match read_manifest(&manifest_path).map_err(io)? {
            Some(previous) if previous.identity == identity => previous.files,
            Some(previous) if !overwrite => {
                return Err(FolderError::AnotherRun {
                    dir: dir.to_path_buf(),
                    previous: previous.command,
                    count: previous.files.len(),
                });
            }
            Some(previous) => {
                let removed = remove_listed(dir, &previous.files).map_err(io)?;
                notes.push(format!(
                    "--overwrite: removed {removed} file(s) of the previous run ({})",
                    previous.command
                ));
                Vec::new()
            }
            None => {
                if let (Some(example), false) = (unrecorded_file(dir).map_err(io)?, overwrite) {
                    return Err(FolderError::Unrecorded {
                        dir: dir.to_path_buf(),
                        example,
                    });
                }
                Vec::new()
            }
        };
        write_atomically(&manifest_path, |out| {
            out.write_all(MANIFEST_HEADER.as_bytes())?;
            writeln!(out, "run {}", one_line(identity))?;
            writeln!(out, "command {}", one_line(command))?;
            for name in &carried {
                writeln!(out, "file {name}")?;
            }
            Ok(())
        })
        .map_err(io)?;
        let manifest = OpenOptions::new().append(true).open(&manifest_path).map_err(io)?;
        Ok(Self {
            dir: dir.to_path_buf(),
            manifest,
            _lock: lock,
            claimed: carried.into_iter().collect(),
            notes,
        })
    }

    /// The output folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Records `name` as this run's file, before it is written, and returns its path in the
    /// folder. Names that could leave the folder are refused.
    pub fn claim(&mut self, name: impl Into<String>) -> Result<PathBuf, FolderError> {
        let name = name.into();
        if !is_plain_name(&name) {
            return Err(FolderError::BadName { name });
        }
        if !self.claimed.contains(&name) {
            writeln!(self.manifest, "file {name}").map_err(|source| FolderError::Io {
                dir: self.dir.clone(),
                source,
            })?;
            self.claimed.insert(name.clone());
        }
        Ok(self.dir.join(name))
    }

    /// Marks the run complete in the manifest.
    pub fn finish(mut self) -> Result<(), FolderError> {
        let io = |source| FolderError::Io {
            dir: self.dir.clone(),
            source,
        };
        writeln!(self.manifest, "complete").map_err(io)?;
        self.manifest.sync_all().map_err(io)
    }
}

/// Locks the folder itself (the system's advisory lock on the folder, not a file in it) for
/// as long as the returned handle lives, which the system ends with the process however it
/// ends: two runs started into one folder together both found it free and mixed their files.
/// Where the system cannot open a folder as a file (Windows) there is no lock; where its file
/// system cannot lock one (some network file systems), `notes` says so.
fn lock_folder(dir: &Path, notes: &mut Vec<String>) -> Result<Option<File>, FolderError> {
    let Ok(folder) = File::open(dir) else {
        return Ok(None);
    };
    match folder.try_lock() {
        Ok(()) => Ok(Some(folder)),
        Err(std::fs::TryLockError::WouldBlock) => Err(FolderError::InUse { dir: dir.to_path_buf() }),
        Err(std::fs::TryLockError::Error(e)) => {
            notes.push(format!(
                "{} cannot be locked ({e}): a second run started into it at the same time would not be refused",
                dir.display()
            ));
            Ok(None)
        }
    }
}

/// Prepares the destination of a single output file the user named: creates its folder,
/// removes stale temporaries there and checks that a file can be created, so a long
/// computation does not end in an unwritable path. Returns notes for the user. A destination
/// that exists and is not a regular file (`/dev/null`, a FIFO) is refused: the rename that
/// puts the file in place would replace it. A link is replaced, not followed.
pub fn prepare_file(path: &Path) -> Result<Vec<String>, FolderError> {
    if let Ok(metadata) = std::fs::symlink_metadata(path)
        && !metadata.is_file()
        && !metadata.file_type().is_symlink()
    {
        return Err(FolderError::NotAFile {
            path: path.to_path_buf(),
            kind: crate::input::kind_of(metadata.file_type()),
        });
    }
    let dir = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let io = |source| FolderError::Io {
        dir: dir.to_path_buf(),
        source,
    };
    create_folder(dir)?;
    let stale = remove_stale_temporaries(dir).map_err(io)?;
    probe(dir).map_err(io)?;
    Ok(if stale > 0 {
        vec![format!(
            "removed {stale} temporary file(s) that an interrupted run left in {}",
            dir.display()
        )]
    } else {
        Vec::new()
    })
}

/// Why [`create_real_folder`] stopped.
#[derive(Debug, thiserror::Error)]
pub enum RealFolderError {
    /// A level of the folder is a link: writing there would land wherever it points.
    #[error("{} is a link: omnisim writes only into real folders under the one named; remove the link", .0.display())]
    Link(PathBuf),
    /// A level of the folder is a file.
    #[error("{} is a file, not a folder: name a new or empty folder", .0.display())]
    NotAFolder(PathBuf),
    /// The system refused.
    #[error("cannot create {}: {source}", .0.display(), source = .1)]
    Io(PathBuf, std::io::Error),
}

/// Checks, creating nothing that stays, that the folder `dir` will take files: `dir` itself
/// where it exists, else the nearest folder above it that does (where it would be made). For a
/// command that works long before it writes (`describe`), so that a folder that cannot take
/// its outputs (a read-only file system, no permission) is found before the work.
pub fn check_writable(dir: &Path) -> Result<(), FolderError> {
    if let Some(path) = file_in_the_way(dir) {
        return Err(FolderError::NotAFolder { path });
    }
    let existing = (dir.ancestors())
        .find(|folder| !folder.as_os_str().is_empty() && folder.exists())
        .unwrap_or(Path::new("."));
    probe(existing).map_err(|source| FolderError::Io {
        dir: existing.to_path_buf(),
        source,
    })
}

/// Creates a temporary file in `dir` and removes it: whether `dir` takes files. A probe a
/// killed process leaves is a temporary, which the next run's cleaning removes.
fn probe(dir: &Path) -> std::io::Result<()> {
    tempfile::Builder::new()
        .prefix(&temporary_prefix())
        .tempfile_in(dir)
        .map(drop)
}

/// `create_dir_all`, naming the file in the way where `dir` or a folder above it is a file
/// (the system says only "File exists" or "Not a directory", as if the folder were fine).
fn create_folder(dir: &Path) -> Result<(), FolderError> {
    std::fs::create_dir_all(dir).map_err(|source| match file_in_the_way(dir) {
        Some(path) => FolderError::NotAFolder { path },
        None => FolderError::Io {
            dir: dir.to_path_buf(),
            source,
        },
    })
}

/// The first of `dir` and the folders above it that exists and is not a folder (links
/// followed), if one is.
fn file_in_the_way(dir: &Path) -> Option<PathBuf> {
    (dir.ancestors())
        .filter(|path| !path.as_os_str().is_empty())
        .find(|path| std::fs::metadata(path).is_ok_and(|metadata| !metadata.is_dir()))
        .map(Path::to_path_buf)
}

/// Creates `dir` below `root` (which the user named, and may itself be a link) one level at a
/// time, refusing a level that is a link: outputs written into `dir` then stay under `root`.
/// A link swapped in afterwards is not seen.
pub fn create_real_folder(root: &Path, dir: &Path) -> Result<(), RealFolderError> {
    std::fs::create_dir_all(root).map_err(|e| match file_in_the_way(root) {
        Some(path) => RealFolderError::NotAFolder(path),
        None => RealFolderError::Io(root.to_path_buf(), e),
    })?;
    let below = dir.strip_prefix(root).map_err(|_| {
        RealFolderError::Io(
            dir.to_path_buf(),
            std::io::Error::other(format!("is not inside {}", root.display())),
        )
    })?;
    let mut path = root.to_path_buf();
    for part in below.components() {
        path.push(part);
        match std::fs::symlink_metadata(&path) {
            Ok(metadata) if metadata.file_type().is_symlink() => return Err(RealFolderError::Link(path)),
            Ok(metadata) if !metadata.is_dir() => return Err(RealFolderError::NotAFolder(path)),
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => match std::fs::create_dir(&path) {
                // Another writer (a shard) may make it first.
                Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => return Err(RealFolderError::Io(path, e)),
                _ => {}
            },
            Err(e) => return Err(RealFolderError::Io(path, e)),
        }
    }
    Ok(())
}

fn one_line(text: &str) -> String {
    text.chars().map(|c| if c.is_control() { ' ' } else { c }).collect()
}

fn is_plain_name(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains(['/', '\\'])
        && !name.chars().any(char::is_control)
        && name != MANIFEST_NAME
}

fn read_manifest(path: &Path) -> std::io::Result<Option<Manifest>> {
    let text = match std::fs::read(path) {
        Ok(bytes) => String::from_utf8_lossy(&bytes).into_owned(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    let mut manifest = Manifest {
        identity: String::new(),
        command: "an unknown run".into(),
        files: Vec::new(),
    };
    let mut seen = HashSet::new();
    for line in text.lines() {
        if let Some(identity) = line.strip_prefix("run ") {
            manifest.identity = identity.to_string();
        } else if let Some(command) = line.strip_prefix("command ") {
            manifest.command = command.to_string();
        } else if let Some(name) = line.strip_prefix("file ") {
            // A hand-edited manifest must not make --overwrite remove anything outside the folder.
            if is_plain_name(name) && seen.insert(name) {
                manifest.files.push(name.to_string());
            }
        }
    }
    Ok(Some(manifest))
}

/// Removes the listed files that exist (never a folder); returns how many.
fn remove_listed(dir: &Path, names: &[String]) -> std::io::Result<usize> {
    let mut removed = 0;
    for name in names {
        let path = dir.join(name);
        match std::fs::symlink_metadata(&path) {
            Ok(metadata) if !metadata.is_dir() => {
                std::fs::remove_file(&path)?;
                removed += 1;
            }
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e),
        }
    }
    Ok(removed)
}

/// A file in `dir` that no manifest accounts for (hidden files and sub-folders aside).
fn unrecorded_file(dir: &Path) -> std::io::Result<Option<String>> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.starts_with('.') && !entry.file_type()?.is_dir() {
            return Ok(Some(name));
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(dir: &Path, identity: &str, overwrite: bool, names: &[&str]) -> Result<(), FolderError> {
        let mut folder = RunFolder::open(dir, identity, &format!("run {identity}"), overwrite)?;
        for name in names {
            let path = folder.claim(*name)?;
            std::fs::write(path, identity).unwrap();
        }
        folder.finish()
    }

    #[test]
    fn another_run_is_refused_and_overwrite_removes_only_its_files() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        run(&out, "omni", false, &["a.png", "calibration.yaml"]).unwrap();
        // The same run again is fine.
        run(&out, "omni", false, &["a.png", "calibration.yaml"]).unwrap();
        let refused = run(&out, "pinhole", false, &["a.png"]).unwrap_err();
        assert!(matches!(refused, FolderError::AnotherRun { count: 2, .. }), "{refused}");
        assert!(refused.to_string().contains("run omni") && refused.to_string().contains("--overwrite"));
        std::fs::write(out.join("mine.txt"), "the user's").unwrap();
        run(&out, "pinhole", true, &["a.png"]).unwrap();
        assert!(!out.join("calibration.yaml").exists());
        assert_eq!(std::fs::read_to_string(out.join("a.png")).unwrap(), "pinhole");
        assert!(out.join("mine.txt").exists());
    }

    #[test]
    fn a_killed_rerun_keeps_every_file_listed() {
        let dir = tempfile::tempdir().unwrap();
        run(dir.path(), "omni", false, &["a.png", "b.png"]).unwrap();
        // Re-run killed after its first file: b.png must still be listed.
        let mut folder = RunFolder::open(dir.path(), "omni", "omni", false).unwrap();
        folder.claim("a.png").unwrap();
        drop(folder);
        run(dir.path(), "other", true, &[]).unwrap();
        assert!(!dir.path().join("a.png").exists() && !dir.path().join("b.png").exists());
    }

    #[test]
    fn unrecorded_files_are_refused_and_names_stay_inside() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
        assert!(matches!(
            run(dir.path(), "omni", false, &[]),
            Err(FolderError::Unrecorded { .. })
        ));
        for bad in ["../escaped.png", "/etc/x", "..", "a\nb", MANIFEST_NAME] {
            assert!(matches!(
                run(dir.path(), "omni", true, &[bad]),
                Err(FolderError::BadName { .. })
            ));
        }
        // A manifest naming files outside the folder removes nothing there.
        let victim = dir.path().join("victim");
        std::fs::write(&victim, "x").unwrap();
        let out = dir.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join(MANIFEST_NAME), "run omni\nfile ../victim\n").unwrap();
        run(&out, "pinhole", true, &[]).unwrap();
        assert!(victim.exists());
    }

    #[test]
    fn prepare_file_creates_the_folder_and_refuses_an_impossible_one() {
        let dir = tempfile::tempdir().unwrap();
        prepare_file(&dir.path().join("a/b/chart.svg")).unwrap();
        assert!(dir.path().join("a/b").is_dir());
        assert_eq!(std::fs::read_dir(dir.path().join("a/b")).unwrap().count(), 0);
        std::fs::write(dir.path().join("file"), "x").unwrap();
        assert!(prepare_file(&dir.path().join("file/chart.svg")).is_err());
        let error = prepare_file(&dir.path().join("a")).unwrap_err().to_string();
        assert!(error.contains("is a folder, not a regular file"), "{error}");
    }
}
