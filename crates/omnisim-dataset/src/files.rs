//! The names of a data-set folder's bookkeeping files, and their JSON and atomic I/O: the
//! leaf every other part of the folder code reads.

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

use super::DatasetError;
use omnisim::output::atomic::{self, Durability, FileStore, Sink, write_bytes_atomically};

/// The stamp's file name in a data-set folder.
pub(crate) const STAMP: &str = ".omnisim-dataset.json";

/// The manifest's file name.
pub(crate) const MANIFEST: &str = "manifest.json";

/// Folder of a set's frame entries.
pub(crate) const ENTRIES: &str = ".frames";

/// A set's own entry, in `ENTRIES`.
pub(crate) const SET_ENTRY: &str = "set.json";

/// Lock file a run holds exclusively for the moment it decides whether the folder is its own
/// and writes the stamp: runs started together decide one after the other.
pub(crate) const GATE: &str = ".omnisim-dataset.lock";

/// Lock file every run and merge holds shared while it works in the folder (shards of one
/// spec together): an `--overwrite` is refused while anyone holds it.
pub(crate) const RUNNING: &str = ".omnisim-dataset.running";

/// The error of an I/O failure on `path`, for `map_err`.
pub(crate) fn io(path: &Path) -> impl Fn(std::io::Error) -> DatasetError + '_ {
    move |source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `bytes` to `path` atomically (never half a file, never through a link).
pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    atomic::write_atomically(path, |out| std::io::Write::write_all(out, bytes)).map_err(io(path))
}

/// How a run writes a set's files and `set.json`, which a finished data set's manifest
/// already vouches for. A file that holds exactly the new bytes is left alone (outputs are
/// deterministic, so a run over a done folder replaces nothing); one holding other bytes is
/// replaced synced (an unsynced rename over it could leave, after a power cut, a cut-short
/// file under a name the manifest vouches for); a new one is written unsynced, for the run
/// to make durable before anything vouches for it. Keeps every path, unchanged ones
/// included (a killed run may have left one not yet on disk).
#[derive(Default)]
pub(crate) struct SetFiles {
    /// Every file written or found unchanged, to be made durable.
    pub(crate) paths: Vec<PathBuf>,
    /// Reused by each file.
    buffer: Vec<u8>,
}

impl SetFiles {
    /// Writes `bytes` to `path` as the type says.
    pub(crate) fn write(&mut self, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
        match std::fs::symlink_metadata(path) {
            // Read only a regular file of the right size: a link is replaced, never read through.
            Ok(found) if found.is_file() && found.len() == bytes.len() as u64 && std::fs::read(path)? == bytes => {}
            Ok(_) => write_bytes_atomically(path, Durability::Now, bytes)?,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                write_bytes_atomically(path, Durability::Deferred, bytes)?;
            }
            Err(e) => return Err(e),
        }
        self.paths.push(path.to_path_buf());
        Ok(())
    }
}

impl FileStore for SetFiles {
    fn store(&mut self, path: &Path, fill: impl FnOnce(&mut dyn Sink) -> std::io::Result<()>) -> std::io::Result<()> {
        let mut encoded = Cursor::new(std::mem::take(&mut self.buffer));
        encoded.get_mut().clear();
        fill(&mut encoded)?;
        encoded.flush()?;
        let bytes = encoded.into_inner();
        let written = self.write(path, &bytes);
        self.buffer = bytes;
        written
    }
}

/// Frame entry files of a set (`NNNNNN.json`), sorted; none if the folder is missing.
pub(crate) fn read_entry_paths(entries: &Path) -> Result<Vec<PathBuf>, DatasetError> {
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

pub(crate) fn entry_path(set_dir: &Path, index: usize) -> PathBuf {
    set_dir.join(ENTRIES).join(format!("{index:06}.json"))
}

/// Reads and parses a JSON bookkeeping file; unreadable JSON is a corrupt folder.
pub(crate) fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, DatasetError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    serde_json::from_slice(&bytes).map_err(|e| DatasetError::Corrupt {
        path: path.to_path_buf(),
        entry: path.to_path_buf(),
        problem: format!("unreadable: {e}"),
    })
}
