//! Nothing half-written: every output file is written beside its destination under a temporary
//! name and renamed into place only once complete.
//!
//! Temporaries are created exclusively (`O_EXCL`) under an unpredictable name, so a link planted
//! in the folder is never followed; the rename replaces whatever sits at the destination (a
//! link included) with the new regular file. Their names start with [`TEMPORARY_PREFIX`], the
//! writer's process id and host name ([`temporary_prefix`]), so the next run into the folder
//! can remove those a killed run left ([`remove_stale_temporaries`]) without touching those
//! that shards on other machines, sharing the folder, are writing.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// How every temporary file's name starts.
pub const TEMPORARY_PREFIX: &str = ".omnisim-tmp-";

/// Bytes handed to the kernel per write: a 250 × 250 frame's PLY (0.74 MB) in three calls
/// instead of ninety with the default 8 KiB.
const WRITE_BUFFER: usize = 256 * 1024;

/// A temporary untouched this long is stale even if a process with its id runs (ids are reused).
const STALE_AFTER: Duration = Duration::from_secs(3600);

/// When a file written through [`write_bytes_atomically`] reaches the disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// Synced before it is renamed into place: on disk when the call returns.
    Now,
    /// Renamed into place unsynced: whole for every reader at once, on disk once the caller
    /// has called [`DurableFolder::make_durable`] for it (one pass for a batch of files instead of an
    /// `fsync` each). After a crash before that, the file may be missing, empty or cut short
    /// under its name, so nothing that vouches for it (an entry, a manifest) may be written
    /// before [`DurableFolder::make_durable`] returns.
    Deferred,
}

/// Writes `path` through `fill`, durable when it returns; on any error the temporary file
/// is removed and `path` is untouched.
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    write_temporary(path, Durability::Now, |file| {
        let mut out = BufWriter::with_capacity(WRITE_BUFFER, file);
        fill(&mut out)?;
        out.into_inner().map_err(std::io::IntoInnerError::into_error)
    })
}

/// [`write_atomically`] of bytes already encoded: one `write` call, synced as `durability`
/// says.
pub fn write_bytes_atomically(path: &Path, durability: Durability, bytes: &[u8]) -> std::io::Result<()> {
    write_temporary(path, durability, |mut file| {
        file.write_all(bytes)?;
        Ok(file)
    })
}

/// Creates the temporary beside `path`, lets `fill` write it, syncs it as `durability` says
/// and renames it into place.
fn write_temporary(
    path: &Path,
    durability: Durability,
    fill: impl FnOnce(File) -> std::io::Result<File>,
) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let prefix = temporary_prefix();
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix);
    // tempfile creates 0600 files; outputs get the usual umask-filtered 0666.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    // Dropping `temporary` on an early return removes the file.
    let (file, temporary) = builder.tempfile_in(dir)?.into_parts();
    let file = fill(file)?;
    if durability == Durability::Now {
        file.sync_all()?;
    }
    temporary.persist(path).map_err(|e| e.error)
}

/// A folder whose files, written with [`Durability::Deferred`] into it or folders below it
/// (on one file system), are made durable a batch at a time ([`DurableFolder::make_durable`]).
/// Open it before the first file of a batch is written: Linux's `syncfs` reports the
/// write-back errors since its handle was opened, and only once across every process (a
/// shard beside this one may see an error first), so a handle opened per batch could miss
/// the one error that says a file of this run was lost.
#[derive(Debug)]
pub struct DurableFolder {
    #[cfg_attr(not(target_os = "linux"), allow(dead_code))]
    handle: File,
    /// Whether one `syncfs` of the folder's file system stands for every file's `fsync`.
    whole_file_system: bool,
}

impl DurableFolder {
    /// Opens `dir` to make the files written below it durable later.
    pub fn open(dir: &Path) -> std::io::Result<Self> {
        let handle = File::open(dir)?;
        #[cfg(target_os = "linux")]
        let whole_file_system = syncfs_reports_errors() && is_local_disk(&handle);
        #[cfg(not(target_os = "linux"))]
        let whole_file_system = false;
        Ok(Self {
            handle,
            whole_file_system,
        })
    }

    /// Puts `files` on disk, their names included. Linux 5.8 and later on a local disk file
    /// system: one `syncfs` of the folder's file system (the renames included). Elsewhere: an
    /// `fsync` of each file, then of each folder holding one ([`sync_each`]); older kernels'
    /// `syncfs` does not report write-back errors (a lost write would go unnoticed), and on
    /// network and cluster file systems (NFS, Lustre, GPFS, FUSE mounts of object stores)
    /// errors may surface only on each file's own `fsync`.
    pub fn make_durable(&self, files: &[PathBuf]) -> std::io::Result<()> {
        #[cfg(target_os = "linux")]
        if self.whole_file_system {
            return Ok(rustix::fs::syncfs(&self.handle)?);
        }
        sync_each(files)
    }
}

/// Whether `folder` lies on a local disk file system whose `syncfs` writes back and reports
/// every file's data: ext2/3/4, XFS, Btrfs, F2FS, ZFS or tmpfs, by `statfs`'s magic number.
/// Any other (NFS, CIFS, Lustre, GPFS, FUSE, overlay) or an unreadable one is not.
#[cfg(target_os = "linux")]
fn is_local_disk(folder: &File) -> bool {
    const LOCAL_DISKS: [u32; 6] = [0xEF53, 0x5846_5342, 0x9123_683E, 0xF2F5_2010, 0x2FC1_2FC1, 0x0102_1994];
    // `f_type` is a signed or unsigned word by architecture; the magic numbers are its low 32 bits.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    rustix::fs::fstatfs(folder).is_ok_and(|stat| LOCAL_DISKS.contains(&(stat.f_type as u64 as u32)))
}

/// Whether this kernel's `syncfs` reports write-back errors (Linux 5.8 and later), as its
/// release (`/proc/sys/kernel/osrelease`) says; read once.
#[cfg(target_os = "linux")]
fn syncfs_reports_errors() -> bool {
    static REPORTS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *REPORTS.get_or_init(|| {
        let release = std::fs::read_to_string("/proc/sys/kernel/osrelease").unwrap_or_default();
        release_at_least(&release, (5, 8))
    })
}

/// Whether a kernel release such as `4.18.0-477.el8.x86_64` is `least` or later; an
/// unreadable one is not.
#[cfg(target_os = "linux")]
fn release_at_least(release: &str, least: (u32, u32)) -> bool {
    let mut numbers = release
        .trim()
        .split(|c: char| !c.is_ascii_digit())
        .map(|n| n.parse::<u32>().ok());
    match (numbers.next().flatten(), numbers.next().flatten()) {
        (Some(major), Some(minor)) => (major, minor) >= least,
        _ => false,
    }
}

/// `fsync`s each of `files`, then each folder holding one (so that their renames are on disk
/// too; Windows cannot open a folder to sync it, and its file system logs renames itself).
/// An error names the file or folder.
fn sync_each(files: &[PathBuf]) -> std::io::Result<()> {
    let mut dirs = std::collections::BTreeSet::new();
    for path in files {
        // Windows syncs only handles open for writing; opening one neither truncates
        // nor creates.
        let file = File::options().read(true).write(cfg!(windows)).open(path);
        file.and_then(|file| file.sync_all()).map_err(|e| at(path, &e))?;
        dirs.insert(
            path.parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new(".")),
        );
    }
    if cfg!(unix) {
        for dir in dirs {
            File::open(dir)
                .and_then(|dir| dir.sync_all())
                .map_err(|e| at(dir, &e))?;
        }
    }
    Ok(())
}

/// `error` with the path it happened at in its message.
fn at(path: &Path, error: &std::io::Error) -> std::io::Error {
    std::io::Error::new(error.kind(), format!("{}: {error}", path.display()))
}

/// How this process's temporaries are named: [`TEMPORARY_PREFIX`], the process id, `@`, the host
/// name, `@`, then a random part. A shared folder (shards on a cluster file system) holds
/// other machines' temporaries too, whose process ids mean nothing here.
pub fn temporary_prefix() -> String {
    format!("{TEMPORARY_PREFIX}{}@{}@", std::process::id(), host_name())
}

/// Where this process's id means something: the machine's name and its process-id namespace
/// (containers sharing a host name, `--network host`, have namespaces of their own), as the
/// system says (`/proc`), in file-name-safe characters; empty elsewhere, and then no
/// temporary is judged by its process. Read once.
fn host_name() -> &'static str {
    static HOST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HOST.get_or_init(|| {
        let name = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
        let namespace = std::fs::read_link("/proc/self/ns/pid").unwrap_or_default();
        let safe = |text: &str| -> String {
            text.chars()
                .filter(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '.' | '_'))
                .collect()
        };
        match (safe(name.trim()), safe(&namespace.to_string_lossy())) {
            (name, _) if name.is_empty() => String::new(),
            (name, namespace) => format!("{name}.{namespace}"),
        }
    })
}

/// The process id and host name in a temporary's name (after [`TEMPORARY_PREFIX`]).
fn writer_of(rest: &str) -> Option<(u32, &str)> {
    let (pid, rest) = rest.split_once('@')?;
    let (host, _) = rest.split_once('@')?;
    Some((pid.parse().ok()?, host))
}

/// Removes the temporaries that interrupted runs left in `dir`: this machine's whose process
/// is gone, and any untouched for an hour (another machine's, or a reused process id). Returns
/// how many were removed; a missing `dir` has none.
pub fn remove_stale_temporaries(dir: &Path) -> std::io::Result<usize> {
    let (own_pid, own_host) = (std::process::id(), host_name());
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
        let untouched = metadata
            .modified()
            .ok()
            .and_then(|m| SystemTime::now().duration_since(m).ok())
            .is_some_and(|age| age > STALE_AFTER);
        let (stale, mine) = match writer_of(rest) {
            Some((pid, host)) if !host.is_empty() && host == own_host => {
                (untouched || process_alive(pid) == Some(false), pid == own_pid)
            }
            Some(_) => (untouched, false),
            // Not a name this module makes: nothing is writing it.
            None => (true, false),
        };
        if stale && !mine {
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
    fn temporaries_of_dead_processes_here_are_removed_and_others_kept() {
        let dir = tempfile::tempdir().unwrap();
        let here = host_name();
        let named = |pid: u32, host: &str| dir.path().join(format!("{TEMPORARY_PREFIX}{pid}@{host}@abc"));
        // u32::MAX is above every pid limit; pid 1 always runs.
        let dead = named(u32::MAX, here);
        let live = named(1, here);
        let mine = named(std::process::id(), here);
        // A shard on another machine writes into the same folder: its pid means nothing here.
        let elsewhere = named(u32::MAX, &format!("{here}-other"));
        let unnamed = dir.path().join(format!("{TEMPORARY_PREFIX}xyz"));
        let other = dir.path().join("notes.txt");
        for path in [&dead, &live, &mine, &elsewhere, &unnamed, &other] {
            std::fs::write(path, b"x").unwrap();
        }
        let removed = remove_stale_temporaries(dir.path()).unwrap();
        if process_alive(1).is_some() && !here.is_empty() {
            assert_eq!(removed, 2);
            assert!(!dead.exists() && !unnamed.exists());
        } else {
            assert_eq!(removed, 1, "without /proc only the unnamed one is known to be stale");
        }
        assert!(live.exists() && mine.exists() && elsewhere.exists() && other.exists());
        assert_eq!(remove_stale_temporaries(&dir.path().join("missing")).unwrap(), 0);
    }

    #[test]
    fn deferred_files_are_whole_at_once_and_made_durable_together() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.bin"), dir.path().join("b.bin"));
        write_bytes_atomically(&a, Durability::Deferred, b"first").unwrap();
        write_bytes_atomically(&b, Durability::Now, b"second").unwrap();
        // Replacing a file leaves the new bytes only, and no temporary beside it.
        write_bytes_atomically(&a, Durability::Deferred, b"third").unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"third");
        assert_eq!(std::fs::read(&b).unwrap(), b"second");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        DurableFolder::open(dir.path())
            .unwrap()
            .make_durable(&[a.clone(), b])
            .unwrap();
        // A folder that is not there cannot be made durable: the caller hears of it.
        assert!(DurableFolder::open(&dir.path().join("missing")).is_err());
    }

    /// The per-file way (other systems, Linux before 5.8) syncs files in several folders, and
    /// names the file it could not sync.
    #[test]
    fn files_synced_one_by_one_and_their_folders_name_what_failed() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        let (a, b) = (dir.path().join("a.bin"), sub.join("b.bin"));
        for path in [&a, &b] {
            write_bytes_atomically(path, Durability::Deferred, b"x").unwrap();
        }
        sync_each(&[a.clone(), b]).unwrap();
        let missing = sub.join("gone.bin");
        let error = sync_each(&[a, missing.clone()]).unwrap_err();
        assert_eq!(error.kind(), std::io::ErrorKind::NotFound);
        assert!(error.to_string().contains(&missing.display().to_string()), "{error}");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn syncfs_is_trusted_from_linux_5_8() {
        for (release, trusted) in [
            ("4.18.0-477.27.1.el8_8.x86_64", false),
            ("5.4.0-150-generic", false),
            ("5.8.0", true),
            ("5.15.167.4-microsoft-standard-WSL2", true),
            ("6.8.0-45-generic\n", true),
            ("", false),
        ] {
            assert_eq!(release_at_least(release, (5, 8)), trusted, "{release}");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn only_local_disk_file_systems_are_synced_whole() {
        // procfs stands in for any file system off the list (NFS, FUSE, Lustre): each file is
        // then synced on its own.
        assert!(!is_local_disk(&File::open("/proc").unwrap()));
        if let Ok(shm) = File::open("/dev/shm") {
            assert!(is_local_disk(&shm), "/dev/shm is tmpfs");
        }
    }

    #[test]
    fn this_processs_temporaries_name_it_and_its_host() {
        let prefix = temporary_prefix();
        let rest = prefix.strip_prefix(TEMPORARY_PREFIX).unwrap();
        assert_eq!(
            writer_of(&format!("{rest}x1y2")),
            Some((std::process::id(), host_name()))
        );
    }
}
