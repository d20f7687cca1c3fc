//! Reading files a user names: only regular files (a FIFO would block forever, `/dev/zero`
//! would fill memory), never more bytes than a stated limit, the files a file names (a scene's
//! meshes and textures, a mesh's own) only from its folder and below (`inside_folder`), and
//! error messages that name the file without quoting what is in it; and, for RON files, errors
//! that say where ([`locate`]).

pub mod locate;

use std::fs::File;
use std::io::{Read, Take};
use std::path::{Component, Path, PathBuf};

/// Largest scene file read: 64 MiB holds some 400,000 objects.
pub const SCENE_LIMIT: u64 = 64 << 20;
/// Largest mesh file read (a binary PLY of ~150 M triangles).
pub const MESH_LIMIT: u64 = 2 << 30;
/// Largest pose file read (~5 million poses).
pub const POSE_FILE_LIMIT: u64 = 256 << 20;

/// Why an input file was not read.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The system refused (missing, no permission).
    #[error("cannot read {}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        error: std::io::Error,
    },
    /// A FIFO, device, socket or folder: reading it could block or never end.
    #[error("{} is {kind}, not a regular file; omnisim reads only regular files", path.display())]
    NotAFile {
        /// The file.
        path: PathBuf,
        /// What it is instead.
        kind: &'static str,
    },
    /// Larger than omnisim reads from such a file.
    #[error("{} is {size} bytes, more than the {limit} bytes omnisim reads from such a file", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size, bytes.
        size: u64,
        /// The cap, bytes.
        limit: u64,
    },
    /// Not UTF-8 text.
    #[error("{} is not UTF-8 text (at byte {at})", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
        /// Offset of the first invalid byte.
        at: usize,
    },
}

/// What a non-regular file is, in words.
pub(crate) fn kind_of(file_type: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_char_device() || file_type.is_block_device() {
            return "a device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    if file_type.is_dir() { "a folder" } else { "not a file" }
}

fn check(path: &Path, metadata: &std::fs::Metadata, limit: u64) -> Result<(), InputError> {
    if !metadata.is_file() {
        return Err(InputError::NotAFile {
            path: path.to_path_buf(),
            kind: kind_of(metadata.file_type()),
        });
    }
    if metadata.len() > limit {
        return Err(InputError::TooLarge {
            path: path.to_path_buf(),
            size: metadata.len(),
            limit,
        });
    }
    Ok(())
}

/// Whether `path` could be read by `open_regular`, checked without opening it: lets a command
/// report a missing input before anything else.
pub fn check_regular(path: &Path, limit: u64) -> Result<(), InputError> {
    let metadata = std::fs::metadata(path).map_err(|error| InputError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    check(path, &metadata, limit)
}

/// Opens `path` for reading if it is a regular file of at most `limit` bytes; the reader stops
/// at `limit` even if the file grows meanwhile. The type is checked before opening, since
/// opening a FIFO blocks until a writer appears.
pub fn open_regular(path: &Path, limit: u64) -> Result<Take<File>, InputError> {
    let io = |error| InputError::Io {
        path: path.to_path_buf(),
        error,
    };
    check_regular(path, limit)?;
    let file = File::open(path).map_err(io)?;
    // Swapped for something else between the two calls: check what was opened.
    check(path, &file.metadata().map_err(io)?, limit)?;
    Ok(file.take(limit))
}

/// The whole text of a regular UTF-8 file of at most `limit` bytes.
pub fn read_text(path: &Path, limit: u64) -> Result<String, InputError> {
    let mut bytes = Vec::new();
    open_regular(path, limit)?
        .read_to_end(&mut bytes)
        .map_err(|error| InputError::Io {
            path: path.to_path_buf(),
            error,
        })?;
    String::from_utf8(bytes).map_err(|e| InputError::NotText {
        path: path.to_path_buf(),
        at: e.utf8_error().valid_up_to(),
    })
}

/// The path of file `relative` (as a scene file or a mesh names it) below the folder of
/// `parent`: a file from anyone reads from its own folder and below only.
pub(crate) fn inside_folder(parent: &Path, relative: &str, what: &str) -> Result<PathBuf, String> {
    let path = Path::new(relative);
    if relative.is_empty()
        || path
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(format!(
            "{what} path '{}' must be relative to the scene file's folder (a mesh's own files: to the mesh's \
             folder) and stay inside it (no '..', no absolute path); put the file beside it or in a folder below it",
            shown(relative, 80)
        ));
    }
    Ok(parent.parent().unwrap_or(Path::new(".")).join(path))
}

/// How every RON input (scenes, data-set specs) is parsed: newtype variants unwrapped and
/// `Some` implied, so files say `Move(light: "lamp", position: (1, 2, 3))` and `frames: (0, 5)`.
pub fn ron_options() -> ron::Options {
    ron::Options::default().with_default_extension(
        ron::extensions::Extensions::UNWRAP_VARIANT_NEWTYPES | ron::extensions::Extensions::IMPLICIT_SOME,
    )
}

/// `text` without the UTF-8 byte-order mark some Windows editors put first, which RON would
/// read as a stray character.
pub fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// A number as an error message shows it: plain for ordinary magnitudes, scientific otherwise
/// (1e-300 printed in full is 300 zeros).
pub fn shown_number(value: f64) -> String {
    if value == 0.0 || !value.is_finite() || (1e-4..1e9).contains(&value.abs()) {
        value.to_string()
    } else {
        format!("{value:e}")
    }
}

/// User text as an error message shows it: escaped (no control characters reach the
/// terminal) and at most `max` characters.
pub fn shown(text: &str, max: usize) -> String {
    excerpt(&text.escape_debug().to_string(), max)
}

/// At most `max` characters of `text` for an error message, with how much was left out: a
/// 10 MB line must not be echoed whole.
pub fn excerpt(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        None => text.to_string(),
        Some((cut, _)) => format!("{}… ({} more bytes)", &text[..cut], text.len() - cut),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_folders_devices_and_large_files() {
        let dir = tempfile::tempdir().unwrap();
        let error = read_text(dir.path(), 10).unwrap_err().to_string();
        assert!(error.contains("is a folder"), "{error}");
        #[cfg(unix)]
        {
            let error = read_text(Path::new("/dev/zero"), 10).unwrap_err().to_string();
            assert!(error.contains("a device"), "{error}");
        }
        let file = dir.path().join("f.txt");
        std::fs::write(&file, "0123456789abc").unwrap();
        let error = read_text(&file, 10).unwrap_err().to_string();
        assert!(error.contains("13 bytes, more than the 10"), "{error}");
        assert_eq!(read_text(&file, 13).unwrap(), "0123456789abc");
        std::fs::write(&file, b"ab\xffcd").unwrap();
        assert!(read_text(&file, 10).unwrap_err().to_string().contains("at byte 2"));
    }

    #[test]
    fn excerpts_are_short() {
        assert_eq!(excerpt("abc", 5), "abc");
        assert_eq!(excerpt(&"é".repeat(100), 3), "ééé… (194 more bytes)");
    }
}
