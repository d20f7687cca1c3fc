//! The names of a data-set folder's bookkeeping files, and their JSON and atomic I/O: the
//! leaf every other part of the folder code reads.

use std::path::{Path, PathBuf};

use super::DatasetError;
use omnisim::atomic_file;

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
    atomic_file::write_atomically(path, |out| std::io::Write::write_all(out, bytes)).map_err(io(path))
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
