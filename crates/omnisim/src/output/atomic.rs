//! Nothing half-written: every output file is written beside its destination under a temporary
//! name and renamed into place only once complete.
//!
//! Temporaries are created exclusively (`O_EXCL`) under an unpredictable name, so a link planted
//! in the folder is never followed; the rename replaces whatever sits at the destination (a
//! link included) with the new regular file. Their names start with [`TEMPORARY_PREFIX`] and
//! the writer's process id, so the next run into the folder can remove those a killed run
//! left ([`remove_stale_temporaries`]).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::{Duration, SystemTime};

/// How every temporary file's name starts.
pub const TEMPORARY_PREFIX: &str = ".omnisim-tmp-";

/// A temporary untouched this long is stale even if a process with its id runs (ids are reused).
const STALE_AFTER: Duration = Duration::from_secs(3600);

/// Writes `path` through `fill`; on any error the temporary file is removed and `path` is
/// untouched.
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let prefix = format!("{TEMPORARY_PREFIX}{}-", std::process::id());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix);
    // tempfile creates 0600 files; outputs get the usual umask-filtered 0666.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    // Dropping `temporary` on an early return removes the file.
    let (file, temporary) = builder.tempfile_in(dir)?.into_parts();
    let mut out = BufWriter::new(file);
    fill(&mut out)?;
    out.flush()?;
    out.into_inner().map_err(|e| e.into_error())?.sync_all()?;
    temporary.persist(path).map_err(|e| e.error)
}

/// Removes the temporaries that interrupted runs left in `dir`: those whose process is gone, or
/// untouched for an hour. Returns how many were removed; a missing `dir` has none.
pub fn remove_stale_temporaries(dir: &Path) -> std::io::Result<usize> {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(e),
    };
    let mut removed = 0;
    for entry in entries {
        let entry = entry?;
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(TEMPORARY_PREFIX)) else {
            continue;
        };
        let metadata = entry.metadata()?;
        if metadata.is_dir() {
            continue;
        }
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        let untouched = metadata
            .modified()
            .ok()
            .and_then(|m| SystemTime::now().duration_since(m).ok())
            .is_some_and(|age| age > STALE_AFTER);
        let stale = match pid.map(process_alive) {
            Some(Some(false)) | None => true,
            Some(Some(true) | None) => untouched,
        };
        if stale && pid != Some(std::process::id()) {
            match std::fs::remove_file(entry.path()) {
                Ok(()) => removed += 1,
                // Another run cleaned it first.
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(removed)
}

/// Whether process `pid` runs, where the system says (`/proc`); `None` elsewhere.
fn process_alive(pid: u32) -> Option<bool> {
    Path::new("/proc/self")
        .exists()
        .then(|| Path::new("/proc").join(pid.to_string()).exists())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporaries_of_dead_processes_are_removed_and_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        // u32::MAX is above every pid limit; pid 1 always runs.
        let dead = dir.path().join(format!("{TEMPORARY_PREFIX}{}-abc", u32::MAX));
        let live = dir.path().join(format!("{TEMPORARY_PREFIX}1-abc"));
        let unnamed = dir.path().join(format!("{TEMPORARY_PREFIX}xyz"));
        let mine = dir.path().join(format!("{TEMPORARY_PREFIX}{}-abc", std::process::id()));
        let other = dir.path().join("notes.txt");
        for path in [&dead, &live, &unnamed, &mine, &other] {
            std::fs::write(path, b"x").unwrap();
        }
        let removed = remove_stale_temporaries(dir.path()).unwrap();
        if process_alive(1).is_some() {
            assert_eq!(removed, 2);
            assert!(!dead.exists() && !unnamed.exists());
        } else {
            assert_eq!(removed, 1, "without /proc only the unnamed one is known to be stale");
        }
        assert!(live.exists() && mine.exists() && other.exists());
        assert_eq!(remove_stale_temporaries(&dir.path().join("missing")).unwrap(), 0);
    }
}
