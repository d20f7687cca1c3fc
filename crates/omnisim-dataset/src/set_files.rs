//! The store a run writes a set's files through: each file written only where its bytes
//! differ from what is there, and kept with its size and SHA-256 for the set's entry.

use std::io::Read;
use std::path::{Path, PathBuf};

use crate::DatasetError;
use crate::files::io;
use crate::manifest::{FileEntry, FileKind, relative, sha256_hex};
use omnisim::atomic_file::{Durability, write_bytes_atomically};
use omnisim::output::store::{EncodeBuffer, FileStore, Sink};

/// How a run writes a set's files and `set.json`, which a finished data set's manifest
/// already vouches for. A file that holds exactly the new bytes is left alone (outputs are
/// deterministic, so a run over a done folder replaces nothing); one holding other bytes is
/// replaced synced (an unsynced rename over it could leave, after a power cut, a cut-short
/// file under a name the manifest vouches for); a new one is written unsynced, for the run
/// to make durable before anything vouches for it. Keeps every path, unchanged ones
/// included (a killed run may have left one not yet on disk).
/// Keeps each file's size and SHA-256, taken from the bytes in memory, for `set.json`.
#[derive(Default)]
pub(crate) struct SetFiles {
    /// Every file written or found unchanged, to be made durable, with its size and SHA-256:
    /// one list, so a path and its hash cannot get out of step.
    kept: Vec<KeptFile>,
    /// Reused by each file.
    buffer: EncodeBuffer,
}

/// A set file [`SetFiles`] wrote or found unchanged.
struct KeptFile {
    path: PathBuf,
    bytes: u64,
    /// Lowercase hex; none for a file no entry lists (`set.json`), which is not hashed.
    sha256: Option<String>,
}

impl SetFiles {
    /// Writes `bytes` to `path` as the type says, without hashing them: for `set.json`,
    /// which no entry lists.
    pub(crate) fn write_unlisted(&mut self, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
        write_kept(&mut self.kept, path, bytes, false)
    }

    /// The paths of every file written or found unchanged, to be made durable.
    pub(crate) fn into_paths(self) -> Vec<PathBuf> {
        self.kept.into_iter().map(|kept| kept.path).collect()
    }

    /// The entry of `path`, a file of the set folder's under `root`: its size and SHA-256 as
    /// written or found here (never read back). Every set file is written through this store,
    /// so a path it did not keep is a slip in the code, reported as an error on that path.
    pub(crate) fn entry(&self, root: &Path, path: &Path, kind: FileKind) -> Result<FileEntry, DatasetError> {
        let kept = self.kept.iter().rev().find(|kept| kept.path == path);
        let (bytes, sha256) = (kept.and_then(|kept| Some((kept.bytes, kept.sha256.clone()?))))
            .ok_or_else(|| io(path)(std::io::Error::other("a set file not written through the run's store")))?;
        Ok(FileEntry {
            path: relative(root, path),
            kind,
            bytes,
            sha256,
        })
    }
}

/// Writes `bytes` to `path` as [`SetFiles`] says, and keeps the path, size and (if `hash`)
/// SHA-256 in `kept`. A free function so that `store` can borrow the list and the encode
/// buffer apart.
fn write_kept(kept: &mut Vec<KeptFile>, path: &Path, bytes: &[u8], hash: bool) -> std::io::Result<()> {
    match found(path, bytes)? {
        Found::Same => {}
        Found::Other => write_bytes_atomically(path, Durability::Now, bytes)?,
        Found::Missing => write_bytes_atomically(path, Durability::Deferred, bytes)?,
    }
    kept.push(KeptFile {
        path: path.to_path_buf(),
        bytes: bytes.len() as u64,
        sha256: hash.then(|| sha256_hex(bytes)),
    });
    Ok(())
}

/// What sits at a set file's path, against the bytes a run would write there.
#[derive(Debug, PartialEq, Eq)]
enum Found {
    /// Nothing.
    Missing,
    /// A regular file holding exactly those bytes.
    Same,
    /// Anything else: other bytes, a link, a folder, a device, a FIFO.
    Other,
}

/// Bytes compared per read.
const COMPARE_CHUNK: usize = 64 * 1024;

/// What sits at `path`, against `bytes`. Only a regular file is read, never through a link
/// and never past one byte beyond `bytes`' length: it is opened without following a link or
/// waiting for a FIFO's writer and checked on the opened handle, so a FIFO or a device at the
/// path (or swapped in) neither hangs the run nor is read without bound.
fn found(path: &Path, bytes: &[u8]) -> std::io::Result<Found> {
    let file = match open_unfollowed(path) {
        Ok(Some(file)) => file,
        Ok(None) => return Ok(Found::Other),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Found::Missing),
        Err(e) => return Err(e),
    };
    let meta = file.metadata()?;
    if !meta.is_file() || meta.len() != bytes.len() as u64 {
        return Ok(Found::Other);
    }
    let mut reader = file.take(bytes.len() as u64 + 1);
    let mut chunk = vec![0; COMPARE_CHUNK.min(bytes.len() + 1)];
    let mut rest = bytes;
    loop {
        let read = match reader.read(&mut chunk) {
            Ok(0) => return Ok(if rest.is_empty() { Found::Same } else { Found::Other }),
            Ok(read) => read,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        match rest.split_at_checked(read) {
            Some((head, tail)) if head == &chunk[..read] => rest = tail,
            _ => return Ok(Found::Other),
        }
    }
}

impl FileStore for SetFiles {
    fn store(&mut self, path: &Path, fill: impl FnOnce(&mut dyn Sink) -> std::io::Result<()>) -> std::io::Result<()> {
        write_kept(&mut self.kept, path, self.buffer.encode(fill)?, true)
    }
}

/// Opens `path` to read without following a link (`None`: a link) or waiting for a FIFO's
/// writer (`O_NOFOLLOW | O_NONBLOCK`).
#[cfg(unix)]
fn open_unfollowed(path: &Path) -> std::io::Result<Option<std::fs::File>> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut options, libc::O_NOFOLLOW | libc::O_NONBLOCK);
    match options.open(path) {
        Err(e) if e.raw_os_error() == Some(libc::ELOOP) => Ok(None),
        opened => opened.map(Some),
    }
}

/// Opens `path` to read unless it is a link (`None`); without `O_NOFOLLOW`, a link swapped in
/// between the look and the open is followed.
#[cfg(not(unix))]
fn open_unfollowed(path: &Path) -> std::io::Result<Option<std::fs::File>> {
    if std::fs::symlink_metadata(path)?.is_symlink() {
        return Ok(None);
    }
    std::fs::File::open(path).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::hash_file;

    #[test]
    fn only_a_regular_file_with_the_same_bytes_is_the_same() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("calibration.yaml");
        let bytes = b"the calibration";
        assert_eq!(found(&path, bytes).unwrap(), Found::Missing);
        std::fs::write(&path, bytes).unwrap();
        assert_eq!(found(&path, bytes).unwrap(), Found::Same);
        std::fs::write(&path, b"the calibratioN").unwrap();
        assert_eq!(found(&path, bytes).unwrap(), Found::Other, "same length, other bytes");
        std::fs::write(&path, b"the calibration!").unwrap();
        assert_eq!(found(&path, bytes).unwrap(), Found::Other, "longer");
        std::fs::write(&path, b"").unwrap();
        assert_eq!(found(&path, b"").unwrap(), Found::Same);
        assert_eq!(found(&path, bytes).unwrap(), Found::Other, "shorter");
        // A file longer than one chunk, differing in its last byte.
        let long: Vec<u8> = (0..COMPARE_CHUNK * 2 + 7).map(|i| (i % 251) as u8).collect();
        std::fs::write(&path, &long).unwrap();
        assert_eq!(found(&path, &long).unwrap(), Found::Same);
        let mut other = long.clone();
        *other.last_mut().unwrap() ^= 1;
        assert_eq!(found(&path, &other).unwrap(), Found::Other);
        std::fs::remove_file(&path).unwrap();
        std::fs::create_dir(&path).unwrap();
        assert_eq!(found(&path, bytes).unwrap(), Found::Other, "a folder");
    }

    /// A set file's entry comes from the bytes written or found unchanged, and equals the
    /// file's own hash; a file the store did not write, or wrote unhashed, has none (an error).
    #[test]
    fn set_file_entries_are_the_files_hashes_without_reading_them_back() {
        let dir = tempfile::tempdir().unwrap();
        let [new, same, other, unlisted] = ["a.yaml", "b.yaml", "c.txt", "set.json"].map(|name| dir.path().join(name));
        std::fs::write(&same, b"unchanged").unwrap();
        std::fs::write(&other, b"not the store's").unwrap();
        let mut store = SetFiles::default();
        for (path, bytes) in [(&new, b"new bytes"), (&same, b"unchanged")] {
            store.store(path, |sink| sink.write_all(bytes)).unwrap();
        }
        store.write_unlisted(&unlisted, b"{}").unwrap();
        for path in [&new, &same] {
            let entry = store.entry(dir.path(), path, FileKind::Set).unwrap();
            assert_eq!(
                (entry.bytes, entry.sha256),
                hash_file(path).unwrap(),
                "{}",
                path.display()
            );
        }
        for path in [&other, &unlisted] {
            assert!(
                store.entry(dir.path(), path, FileKind::Set).is_err(),
                "{}",
                path.display()
            );
        }
        // The kept entry is the bytes', not the file's as it is now.
        std::fs::write(&new, b"changed since").unwrap();
        assert_eq!(store.entry(dir.path(), &new, FileKind::Set).unwrap().bytes, 9);
        assert_eq!(store.into_paths(), [new, same, unlisted]);
    }

    /// A link is never read through: one to a regular file with the same bytes is other.
    #[cfg(unix)]
    #[test]
    fn a_link_to_the_same_bytes_is_other() {
        let dir = tempfile::tempdir().unwrap();
        let (target, path) = (dir.path().join("outside"), dir.path().join("calibration.yaml"));
        std::fs::write(&target, b"the calibration").unwrap();
        std::os::unix::fs::symlink(&target, &path).unwrap();
        assert_eq!(found(&path, b"the calibration").unwrap(), Found::Other);
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero")).unwrap();
        assert_eq!(found(&dir.path().join("zero"), &[0; 8]).unwrap(), Found::Other);
    }

    /// A FIFO with no writer is other at once (an open waiting for a writer would hang).
    #[cfg(unix)]
    #[test]
    fn a_fifo_is_other_without_waiting() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("calibration.yaml");
        let made = std::process::Command::new("mkfifo").arg(&path).status().unwrap();
        assert!(made.success());
        let (told, heard) = std::sync::mpsc::channel();
        let looked = path.clone();
        // A thread, so that a hang fails the test instead of stalling it.
        std::thread::spawn(move || told.send(found(&looked, b"").map_err(|e| e.to_string())));
        let answer = heard.recv_timeout(std::time::Duration::from_secs(10));
        assert_eq!(answer, Ok(Ok(Found::Other)));
    }
}
