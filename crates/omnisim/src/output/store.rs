//! Where the file writers put their files ([`FileStore`]): straight into a temporary synced
//! before its rename ([`Synced`]), or encoded in memory first ([`EncodeBuffer`]); never half a
//! file under its name. The atomic writing itself (temporaries, renames, durability) is
//! `crate::atomic_file`, below the scene and the outputs, since a scene's export writes
//! through it too.

use std::io::{Cursor, Seek, Write};
use std::path::Path;

use crate::atomic_file::write_atomically;

/// What a file writer writes into: bytes in order, and a seek back for EXR's offset table.
pub trait Sink: Write + Seek {}

impl<T: Write + Seek + ?Sized> Sink for T {}

/// Where the file writers (`output::write_png` and the others) put a file once they have its
/// path: always atomically (never half a file under its name); when it reaches the disk and
/// what else is kept of it is the store's choice.
pub trait FileStore {
    /// Writes the file `path` through `fill`: by default straight to its temporary, synced
    /// before it is renamed into place ([`write_atomically`]).
    fn store(&mut self, path: &Path, fill: impl FnOnce(&mut dyn Sink) -> std::io::Result<()>) -> std::io::Result<()> {
        write_atomically(path, |out| fill(out))
    }

    /// Whether writers may encode parts of a file ahead: a point cloud's points in the pass
    /// that reads the range EXR's values, an extra copy of up to 15 bytes a pixel held from
    /// the range EXR to the point cloud. Worth it where the store buffers each file whole
    /// anyway (a data set's frames); otherwise, and by default, writers stream.
    fn encodes_in_memory(&self) -> bool {
        false
    }
}

impl<T: FileStore> FileStore for &mut T {
    fn store(&mut self, path: &Path, fill: impl FnOnce(&mut dyn Sink) -> std::io::Result<()>) -> std::io::Result<()> {
        (**self).store(path, fill)
    }

    fn encodes_in_memory(&self) -> bool {
        (**self).encodes_in_memory()
    }
}

/// Memory a store encodes each file into before writing it in one call (and hashing or
/// comparing it there), reused from one file to the next.
#[derive(Debug, Default)]
pub struct EncodeBuffer(Vec<u8>);

impl EncodeBuffer {
    /// The bytes `fill` writes, in this buffer (emptied first).
    pub fn encode(&mut self, fill: impl FnOnce(&mut dyn Sink) -> std::io::Result<()>) -> std::io::Result<&[u8]> {
        self.0.clear();
        fill(&mut Cursor::new(&mut self.0))?;
        Ok(&self.0)
    }

    /// The bytes encoded last, kept.
    pub fn into_bytes(self) -> Vec<u8> {
        self.0
    }
}

/// Each file written straight to its temporary and synced before it is renamed into place:
/// [`write_atomically`].
#[derive(Debug, Clone, Copy, Default)]
pub struct Synced;

impl FileStore for Synced {}
